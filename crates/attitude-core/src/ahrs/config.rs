//! The pipeline's configuration: one section per model, each with the defaults the preset starts
//! from, and their validation.

use super::gyro::GyroConfig;

/// Everything the pipeline assumes about the sensors (`service.imu` of the configuration;
/// `config/imu.json5` is the preset). The gyro noise itself is the filter's (`service.filter`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct AhrsConfig {
    /// Uncertainty of a sample's time stamp against the true instant it describes, s (sensor latency
    /// and clock offset the sender cannot know). A published estimate is uncertain by the rotation
    /// over that time, `σ_t² ω ωᵀ` about the turn axis; the filter itself does not use it.
    pub timing_sigma_s: f64,
    pub init: InitConfig,
    pub gyro: GyroConfig,
    pub rest: RestConfig,
    pub acc: AccConfig,
    pub mag: MagConfig,
    pub recovery: RecoveryConfig,
}

/// The alignment: the attitude from the first samples.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct InitConfig {
    /// Samples are averaged over this long before the filter starts, s (0: the first sample).
    pub duration_s: f64,
    /// Initial 1σ of the tilt and of the heading, rad.
    pub tilt_sigma_rad: f64,
    pub heading_sigma_rad: f64,
}

#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct RestConfig {
    pub enabled: bool,
    pub lowpass_s: f64,
    pub gyr_limit_rad_s: f64,
    pub acc_limit_m_s2: f64,
    pub bias_limit_rad_s: f64,
    pub min_duration_s: f64,
    /// The bias observation at rest: its interval and its 1σ per axis, rad/s.
    pub interval_s: f64,
    pub bias_sigma_rad_s: f64,
}

#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct AccConfig {
    /// Time constant of the low-pass in the gyro frame, s.
    pub lowpass_s: f64,
    /// Interval of the tilt updates, s, and the time over which the low-passed direction's error is
    /// correlated, s (each update counts `interval_s / correlation_s` of an independent one).
    pub interval_s: f64,
    pub correlation_s: f64,
    /// `σ₀`: the direction's 1σ without motion (accelerometer misalignment and bias), rad.
    pub sigma_rad: f64,
    /// `κ`: the motion error is `κ d_rms / g` rad (see [`gravity`]).
    pub motion_gain: f64,
    /// The direction's 1σ at rest, rad.
    pub rest_sigma_rad: f64,
    /// Largest relative deviation of the low-passed norm from gravity's for an update.
    pub norm_gate: f64,
    /// Least 1σ of the tilt per horizontal axis (what no averaging removes), rad.
    pub floor_rad: f64,
    /// The tilt's 1σ is also kept at least `floor_lp_factor · σ_lp`: an estimate that follows the
    /// low-passed direction has that direction's error, however many updates it took.
    pub floor_lp_factor: f64,
}

#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct MagConfig {
    pub enabled: bool,
    /// Low-pass of the norm and dip judged for disturbances, s.
    pub lowpass_s: f64,
    pub norm_limit: f64,
    pub dip_limit_rad: f64,
    pub min_undisturbed_s: f64,
    pub max_rejection_s: f64,
    pub rejection_factor: f64,
    /// Adaptation of the reference's norm and dip while undisturbed, s.
    pub reference_s: f64,
    pub new_field_s: f64,
    pub new_field_min_rate_rad_s: f64,
    /// Interval of the heading updates, s; the heading error's 1σ (rad) and correlation time (s).
    pub interval_s: f64,
    pub sigma_rad: f64,
    pub correlation_s: f64,
    /// Least 1σ of the heading, rad.
    pub floor_rad: f64,
    /// How much later than the gyro the magnetometer samples the field, s: each reading is turned
    /// forward by the rotation over that time, `m − δ (ω × m)` (a lag of a few milliseconds, from the
    /// magnetometer's own filtering, is a heading error of `δ ‖ω‖` in fast turns).
    pub delay_s: f64,
    /// What remains of it (the delay's uncertainty, the magnetometer's own dynamics), s: the heading
    /// 1σ grows by `σ_δ ‖ω‖` in quadrature.
    pub delay_sigma_s: f64,
    /// A reading whose low-passed norm deviates from the reference's by a relative `δn` and whose dip
    /// by `δd` (rad) is disturbed by a field of about that size: its heading 1σ grows by
    /// `deviation_gain · √(δn² + δd²) / cos(dip)` in quadrature (1: a disturbance of no preferred
    /// direction turns the horizontal field by about as much as it changes the norm and the dip).
    pub deviation_gain: f64,
    pub hard_iron: HardIronConfig,
}

#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct HardIronConfig {
    pub enabled: bool,
    /// Forgetting time of the fit, s; solved every `solve_interval_s`; accepted after `confirm_s`.
    pub window_s: f64,
    pub solve_interval_s: f64,
    pub confirm_s: f64,
    /// Acceptance, as fractions of the reference norm: the offset's largest 1σ, the RMS residual per
    /// axis (over the window and over the last `recent_s`), the least change of the offset.
    pub max_offset_sigma: f64,
    pub max_residual: f64,
    pub recent_s: f64,
    pub min_change: f64,
    /// The accepted offset's RMS residual over the window must exceed the new fit's by this factor.
    pub min_improvement: f64,
    /// Least rotation the window must have seen about every axis: the smallest eigenvalue of
    /// `I − J̄ J̄ᵀ` (`J̄` the mean attitude matrix of the window; 0 without rotation about some axis, 1
    /// for attitudes spread over the sphere). An offset along an axis the body hardly turned about is
    /// indistinguishable from the field's own component along it (a pendulum that swings in a plane).
    pub min_excitation: f64,
    /// A fit whose field differs from a reference not yet confirmed by rotation replaces it only
    /// when it explains the window this many times better than the offset in use (a disturbance of
    /// a place along a path that repeats its attitudes also fits an offset, but hardly this well).
    pub replace_improvement: f64,
    /// When the field turns disturbed, the fit keeps this weight of what it saw before (it relearns
    /// from the readings after the change).
    pub restart_weight: f64,
}

#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct RecoveryConfig {
    /// Normalised innovation squared above which a tilt (2 dof) or heading (1 dof) update is
    /// inconsistent, and how long in a row that must last before the covariance is widened.
    pub tilt_nis: f64,
    pub heading_nis: f64,
    pub after_s: f64,
    /// The 1σ the tilt or heading is widened to, rad.
    pub tilt_sigma_rad: f64,
    pub heading_sigma_rad: f64,
}

impl Default for AhrsConfig {
    fn default() -> Self {
        AhrsConfig {
            timing_sigma_s: 0.0,
            init: InitConfig::default(),
            gyro: GyroConfig::default(),
            rest: RestConfig::default(),
            acc: AccConfig::default(),
            mag: MagConfig::default(),
            recovery: RecoveryConfig::default(),
        }
    }
}

impl Default for InitConfig {
    fn default() -> Self {
        InitConfig {
            duration_s: 0.1,
            tilt_sigma_rad: 0.0349,
            heading_sigma_rad: 0.0349,
        }
    }
}

impl Default for RestConfig {
    fn default() -> Self {
        RestConfig {
            enabled: true,
            lowpass_s: 0.5,
            gyr_limit_rad_s: 0.0349,
            acc_limit_m_s2: 0.5,
            bias_limit_rad_s: 0.0349,
            min_duration_s: 1.5,
            interval_s: 1.0,
            bias_sigma_rad_s: 5.2e-4,
        }
    }
}

impl Default for AccConfig {
    fn default() -> Self {
        AccConfig {
            lowpass_s: 3.0,
            interval_s: 0.1,
            correlation_s: 6.0,
            sigma_rad: 0.0035,
            motion_gain: 1.5,
            rest_sigma_rad: 0.0017,
            norm_gate: 0.25,
            floor_rad: 0.0017,
            floor_lp_factor: 1.0,
        }
    }
}

impl Default for MagConfig {
    fn default() -> Self {
        MagConfig {
            enabled: true,
            lowpass_s: 0.05,
            norm_limit: 0.1,
            dip_limit_rad: 0.1745,
            min_undisturbed_s: 0.5,
            max_rejection_s: 60.0,
            rejection_factor: 2.0,
            reference_s: 20.0,
            new_field_s: 20.0,
            new_field_min_rate_rad_s: 0.349,
            interval_s: 0.1,
            sigma_rad: 0.0175,
            correlation_s: 5.0,
            floor_rad: 0.0052,
            delay_s: 0.0,
            delay_sigma_s: 0.0,
            deviation_gain: 1.0,
            hard_iron: HardIronConfig::default(),
        }
    }
}

impl Default for HardIronConfig {
    fn default() -> Self {
        HardIronConfig {
            enabled: true,
            window_s: 20.0,
            solve_interval_s: 0.1,
            confirm_s: 3.0,
            max_offset_sigma: 0.02,
            max_residual: 0.08,
            recent_s: 2.0,
            min_change: 0.05,
            min_improvement: 1.5,
            min_excitation: 0.1,
            replace_improvement: 4.0,
            restart_weight: 0.05,
        }
    }
}

impl Default for RecoveryConfig {
    fn default() -> Self {
        RecoveryConfig {
            tilt_nis: 13.8,
            heading_nis: 10.8,
            after_s: 3.0,
            tilt_sigma_rad: 0.087,
            heading_sigma_rad: 0.175,
        }
    }
}

impl AhrsConfig {
    /// Checks every value; the message names the field (`service.imu.` + the path).
    pub fn validate(&self) -> Result<(), String> {
        let positive = |v: f64, name: &str| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} must be positive and finite, got {v}"))
            }
        };
        let nonneg = |v: f64, name: &str| {
            if v >= 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} must be non-negative and finite, got {v}"))
            }
        };
        if !(self.timing_sigma_s >= 0.0 && self.timing_sigma_s <= 1.0) {
            return Err(format!(
                "timing_sigma_s must be in [0, 1] s, got {}",
                self.timing_sigma_s
            ));
        }
        self.gyro.validate()?;
        let i = &self.init;
        nonneg(i.duration_s, "init.duration_s")?;
        positive(i.tilt_sigma_rad, "init.tilt_sigma_rad")?;
        positive(i.heading_sigma_rad, "init.heading_sigma_rad")?;
        let r = &self.rest;
        nonneg(r.lowpass_s, "rest.lowpass_s")?;
        positive(r.gyr_limit_rad_s, "rest.gyr_limit_rad_s")?;
        positive(r.acc_limit_m_s2, "rest.acc_limit_m_s2")?;
        positive(r.bias_limit_rad_s, "rest.bias_limit_rad_s")?;
        nonneg(r.min_duration_s, "rest.min_duration_s")?;
        positive(r.interval_s, "rest.interval_s")?;
        positive(r.bias_sigma_rad_s, "rest.bias_sigma_rad_s")?;
        let a = &self.acc;
        positive(a.lowpass_s, "acc.lowpass_s")?;
        positive(a.interval_s, "acc.interval_s")?;
        positive(a.correlation_s, "acc.correlation_s")?;
        positive(a.sigma_rad, "acc.sigma_rad")?;
        nonneg(a.motion_gain, "acc.motion_gain")?;
        positive(a.rest_sigma_rad, "acc.rest_sigma_rad")?;
        positive(a.norm_gate, "acc.norm_gate")?;
        nonneg(a.floor_rad, "acc.floor_rad")?;
        nonneg(a.floor_lp_factor, "acc.floor_lp_factor")?;
        let m = &self.mag;
        nonneg(m.lowpass_s, "mag.lowpass_s")?;
        positive(m.norm_limit, "mag.norm_limit")?;
        positive(m.dip_limit_rad, "mag.dip_limit_rad")?;
        nonneg(m.min_undisturbed_s, "mag.min_undisturbed_s")?;
        nonneg(m.max_rejection_s, "mag.max_rejection_s")?;
        if !(m.rejection_factor >= 1.0 && m.rejection_factor.is_finite()) {
            return Err(format!(
                "mag.rejection_factor must be at least 1, got {}",
                m.rejection_factor
            ));
        }
        positive(m.reference_s, "mag.reference_s")?;
        nonneg(m.new_field_s, "mag.new_field_s")?;
        nonneg(m.new_field_min_rate_rad_s, "mag.new_field_min_rate_rad_s")?;
        positive(m.interval_s, "mag.interval_s")?;
        positive(m.sigma_rad, "mag.sigma_rad")?;
        positive(m.correlation_s, "mag.correlation_s")?;
        nonneg(m.floor_rad, "mag.floor_rad")?;
        nonneg(m.delay_sigma_s, "mag.delay_sigma_s")?;
        if !(m.delay_s.abs() <= 1.0) {
            return Err(format!(
                "mag.delay_s must be within ±1 s, got {}",
                m.delay_s
            ));
        }
        let h = &m.hard_iron;
        positive(h.window_s, "mag.hard_iron.window_s")?;
        positive(h.solve_interval_s, "mag.hard_iron.solve_interval_s")?;
        nonneg(h.confirm_s, "mag.hard_iron.confirm_s")?;
        positive(h.max_offset_sigma, "mag.hard_iron.max_offset_sigma")?;
        positive(h.max_residual, "mag.hard_iron.max_residual")?;
        positive(h.recent_s, "mag.hard_iron.recent_s")?;
        if !(h.replace_improvement >= 1.0 && h.replace_improvement.is_finite()) {
            return Err(format!(
                "mag.hard_iron.replace_improvement must be at least 1, got {}",
                h.replace_improvement
            ));
        }
        if !(0.0..=1.0).contains(&h.min_excitation) {
            return Err(format!(
                "mag.hard_iron.min_excitation must be in [0, 1], got {}",
                h.min_excitation
            ));
        }
        nonneg(h.min_change, "mag.hard_iron.min_change")?;
        if !(h.restart_weight >= 0.0 && h.restart_weight <= 1.0) {
            return Err(format!(
                "mag.hard_iron.restart_weight must be in [0, 1], got {}",
                h.restart_weight
            ));
        }
        if !(h.min_improvement >= 1.0 && h.min_improvement.is_finite()) {
            return Err(format!(
                "mag.hard_iron.min_improvement must be at least 1, got {}",
                h.min_improvement
            ));
        }
        let c = &self.recovery;
        positive(c.tilt_nis, "recovery.tilt_nis")?;
        positive(c.heading_nis, "recovery.heading_nis")?;
        positive(c.after_s, "recovery.after_s")?;
        positive(c.tilt_sigma_rad, "recovery.tilt_sigma_rad")?;
        positive(c.heading_sigma_rad, "recovery.heading_sigma_rad")?;
        Ok(())
    }
}
