//! The raw-IMU field channel's settings (`service.imu.mag`, with its hard-iron fit), their defaults
//! and their checks.

use crate::sensors::check::{at_least_one, fraction, non_negative, positive};

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
    /// The part of its interval by which a reading lags beside `delay_s`: a reading that is the
    /// interval's mean describes the body half an interval before the gyro's integral does.
    pub lag_intervals: f64,
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
    /// The 1σ per axis, as a fraction of the field's norm, of a body-fixed offset that the readings
    /// cannot reveal before rotation confirms the reference (`FieldChannel::confirmed`): the
    /// reference's north, taken from one reading, may be turned by it, and the published heading
    /// allows for that until the fit has confirmed or replaced the reference. An unknown consumer
    /// magnetometer's hard iron is often as large as the Earth's field; 0 for a magnetometer
    /// calibrated in place.
    pub unconfirmed_offset: f64,
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
            lag_intervals: 0.5,
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
            unconfirmed_offset: 0.5,
        }
    }
}

impl MagConfig {
    /// Checks every value; the message names the setting (`mag.` + its path).
    pub fn validate(&self) -> Result<(), String> {
        non_negative(self.lowpass_s, "mag.lowpass_s")?;
        positive(self.norm_limit, "mag.norm_limit")?;
        positive(self.dip_limit_rad, "mag.dip_limit_rad")?;
        non_negative(self.min_undisturbed_s, "mag.min_undisturbed_s")?;
        non_negative(self.max_rejection_s, "mag.max_rejection_s")?;
        at_least_one(self.rejection_factor, "mag.rejection_factor")?;
        positive(self.reference_s, "mag.reference_s")?;
        non_negative(self.new_field_s, "mag.new_field_s")?;
        non_negative(
            self.new_field_min_rate_rad_s,
            "mag.new_field_min_rate_rad_s",
        )?;
        positive(self.interval_s, "mag.interval_s")?;
        positive(self.sigma_rad, "mag.sigma_rad")?;
        positive(self.correlation_s, "mag.correlation_s")?;
        non_negative(self.floor_rad, "mag.floor_rad")?;
        non_negative(self.delay_sigma_s, "mag.delay_sigma_s")?;
        fraction(self.lag_intervals, "mag.lag_intervals")?;
        if !(self.delay_s.abs() <= 1.0) {
            return Err(format!(
                "mag.delay_s must be within ±1 s, got {}",
                self.delay_s
            ));
        }
        self.hard_iron.validate()
    }
}

impl HardIronConfig {
    /// Checks every value; the message names the setting (`mag.hard_iron.` + its name).
    pub fn validate(&self) -> Result<(), String> {
        positive(self.window_s, "mag.hard_iron.window_s")?;
        positive(self.solve_interval_s, "mag.hard_iron.solve_interval_s")?;
        non_negative(self.confirm_s, "mag.hard_iron.confirm_s")?;
        positive(self.max_offset_sigma, "mag.hard_iron.max_offset_sigma")?;
        positive(self.max_residual, "mag.hard_iron.max_residual")?;
        positive(self.recent_s, "mag.hard_iron.recent_s")?;
        at_least_one(
            self.replace_improvement,
            "mag.hard_iron.replace_improvement",
        )?;
        fraction(self.min_excitation, "mag.hard_iron.min_excitation")?;
        non_negative(self.min_change, "mag.hard_iron.min_change")?;
        fraction(self.restart_weight, "mag.hard_iron.restart_weight")?;
        non_negative(self.unconfirmed_offset, "mag.hard_iron.unconfirmed_offset")?;
        at_least_one(self.min_improvement, "mag.hard_iron.min_improvement")
    }
}
