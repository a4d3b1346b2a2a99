//! The raw-IMU gravity channel's settings (`service.imu.acc`), their defaults and their checks.

use crate::sensors::check::{fraction, non_negative, positive};

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
    /// `κ`: the motion error is `κ d_rms / g` rad (see [`super::channel`]).
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
    /// The part of its interval by which a reading lags the gyro's integral: a reading that is the
    /// interval's mean (a sensor's decimation filter, the same as its gyro's) describes the body
    /// half an interval before the rotation integrated to its time stamp. Gravity in it is turned
    /// forward by the rotation over that part of the interval (0: the reading is of the end).
    pub lag_intervals: f64,
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
            lag_intervals: 0.5,
        }
    }
}

impl AccConfig {
    /// Checks every value; the message names the setting (`acc.` + its name).
    pub fn validate(&self) -> Result<(), String> {
        positive(self.lowpass_s, "acc.lowpass_s")?;
        positive(self.interval_s, "acc.interval_s")?;
        positive(self.correlation_s, "acc.correlation_s")?;
        positive(self.sigma_rad, "acc.sigma_rad")?;
        non_negative(self.motion_gain, "acc.motion_gain")?;
        positive(self.rest_sigma_rad, "acc.rest_sigma_rad")?;
        positive(self.norm_gate, "acc.norm_gate")?;
        non_negative(self.floor_rad, "acc.floor_rad")?;
        non_negative(self.floor_lp_factor, "acc.floor_lp_factor")?;
        fraction(self.lag_intervals, "acc.lag_intervals")
    }
}
