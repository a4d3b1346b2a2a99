//! The pipeline's configuration: one section per model, each with the defaults the preset starts
//! from, and their validation.

use crate::sensors::check::{non_negative, positive};
use crate::sensors::field::MagConfig;
use crate::sensors::gravity::AccConfig;
use crate::sensors::gyro::GyroConfig;

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
        if !(self.timing_sigma_s >= 0.0 && self.timing_sigma_s <= 1.0) {
            return Err(format!(
                "timing_sigma_s must be in [0, 1] s, got {}",
                self.timing_sigma_s
            ));
        }
        self.gyro.validate()?;
        let i = &self.init;
        non_negative(i.duration_s, "init.duration_s")?;
        positive(i.tilt_sigma_rad, "init.tilt_sigma_rad")?;
        positive(i.heading_sigma_rad, "init.heading_sigma_rad")?;
        let r = &self.rest;
        non_negative(r.lowpass_s, "rest.lowpass_s")?;
        positive(r.gyr_limit_rad_s, "rest.gyr_limit_rad_s")?;
        positive(r.acc_limit_m_s2, "rest.acc_limit_m_s2")?;
        positive(r.bias_limit_rad_s, "rest.bias_limit_rad_s")?;
        non_negative(r.min_duration_s, "rest.min_duration_s")?;
        positive(r.interval_s, "rest.interval_s")?;
        positive(r.bias_sigma_rad_s, "rest.bias_sigma_rad_s")?;
        self.acc.validate()?;
        self.mag.validate()?;
        let c = &self.recovery;
        positive(c.tilt_nis, "recovery.tilt_nis")?;
        positive(c.heading_nis, "recovery.heading_nis")?;
        positive(c.after_s, "recovery.after_s")?;
        positive(c.tilt_sigma_rad, "recovery.tilt_sigma_rad")?;
        positive(c.heading_sigma_rad, "recovery.heading_sigma_rad")?;
        Ok(())
    }
}
