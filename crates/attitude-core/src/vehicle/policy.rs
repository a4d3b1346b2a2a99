//! What a vehicle is configured with: its filter (per vehicle) and the policy every vehicle follows
//! (service-wide). Validated from the configuration file by `service::config`.

use crate::ahrs::{AhrsConfig, SensorSheet};
use crate::filters::FilterConfig;
use crate::sensors::model::SensorModel;
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// How a vehicle's filter starts when no attitude is given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InitMode {
    /// From the first vector-observation set with two or more non-parallel vectors (q-method).
    Vectors,
    /// A particle filter starts from a uniformly random attitude at the first measurement.
    Uniform,
}

/// Everything needed to create one vehicle's filter.
#[derive(Clone, Debug, PartialEq)]
pub struct VehicleFilterConfig {
    pub filter: FilterConfig,
    pub init: InitMode,
    /// 1σ of the initial bias, rad/s.
    pub init_bias_sigma_rad_s: Vector3<f64>,
    /// The IMU's datasheet values (a raw-IMU vehicle's; the gyro's add to `filter.gyro` when the
    /// filter is built, [`VehicleFilterConfig::filter_config`]).
    pub sensor: SensorSheet,
}

impl VehicleFilterConfig {
    /// The filter's configuration with the datasheet's gyro noise and bias instability added to the
    /// gyro model in quadrature (the model's own terms cover what no datasheet states: scale factor,
    /// misalignment, vibration).
    pub fn filter_config(&self) -> FilterConfig {
        let mut f = self.filter.clone();
        let arw = self.sensor.gyro_arw_rad_sqrt_s();
        let rrw = self.sensor.gyro_rrw_rad_s_sqrt_s();
        f.gyro.sigma_v = f.gyro.sigma_v.hypot(arw);
        f.gyro.sigma_u = f.gyro.sigma_u.hypot(rrw);
        f
    }
}

/// How every vehicle treats time, outliers and failures (service-wide; not part of a checkpoint).
#[derive(Clone, Debug, PartialEq)]
pub struct Policy {
    /// A sample waits at most this long (in sample time, and in wall time since it arrived at the
    /// service) for the vehicle's other stream to reach its time; 0 processes every sample on arrival.
    pub reorder_window_s: f64,
    /// A sample older than what the vehicle processed, by at most this much sample time, is fused by
    /// rolling back to a kept state and replaying (`vehicle::history`); older still, it is refused
    /// (`out_of_order`). 0 keeps no history.
    pub max_lag_s: f64,
    /// Most bytes of kept states and logged samples per vehicle for that history; a vehicle whose
    /// states do not fit keeps fewer (a shorter lag) or none.
    pub history_bytes: usize,
    /// A sample further ahead of the vehicle's newest time than this is refused (`time_jump`).
    pub max_jump_s: f64,
    /// χ² threshold (3 degrees of freedom) of the innovation gate, `None` = off.
    pub gate_threshold: Option<f64>,
    /// Per-sensor thresholds overriding `gate_threshold` (`None` = that sensor is not gated).
    pub sensor_gate: BTreeMap<String, Option<f64>>,
    /// Per-sensor models (`gravity`, `field`); a sensor not listed is a plain vector observation.
    pub sensor_models: BTreeMap<String, SensorModel>,
    /// Consecutive fully gated vector sets before the vehicle re-initialises (0 = never).
    pub gate_reinit_after: u32,
    /// Consecutive failed filter steps before the vehicle re-initialises from its last good estimate.
    pub reinit_after_failures: u32,
    /// Factor on the last good estimate's 1σ when re-initialising from it.
    pub reinit_sigma_factor: f64,
    pub max_sensors_per_vehicle: usize,
    /// Largest gyro rate (and reset bias) accepted, rad/s.
    pub max_rate_rad_s: f64,
    /// The raw-IMU pipeline of `P/V/imu` vehicles.
    pub imu: AhrsConfig,
    /// Least interval between two published estimates of an IMU vehicle, s (0: every sample).
    pub imu_estimate_interval_s: f64,
}

impl Policy {
    /// The gate threshold of observations from `sensor`.
    pub fn gate_for(&self, sensor: Option<&str>) -> Option<f64> {
        match sensor.and_then(|s| self.sensor_gate.get(s)) {
            Some(t) => *t,
            None => self.gate_threshold,
        }
    }
}
