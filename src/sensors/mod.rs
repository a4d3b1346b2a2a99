//! Measurements as the filters see them, and the sensor models that the simulator samples.
//!
//! Frames and units: gyro rates are body-frame rad/s; a vector observation pairs a body-frame
//! measurement with the same direction or field known in the reference frame, in the same units
//! (unit vectors with `sigma` in rad, or a magnetic field in nT with `sigma` in nT). Times are seconds of
//! the sender's clock.

pub mod gyro;
pub mod imu;
pub mod vector;

pub use gyro::{GyroNoise, GyroSimulator};
pub use vector::{MagnetometerModel, StarCamera, SunSensor};

use nalgebra::Vector3;

/// One gyro sample: the measured body rate `ω̃` valid from `t_s` until the next sample (zero-order hold).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GyroSample {
    pub t_s: f64,
    pub omega_body_rad_s: Vector3<f64>,
}

/// One vector observation `b̃ = A(q) r + v`, `v ~ N(0, σ² I₃)`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VectorObservation {
    /// Measured in the body frame.
    pub body: Vector3<f64>,
    /// The same direction or field in the reference frame, same units as `body`.
    pub reference: Vector3<f64>,
    /// Per-axis 1σ noise in the units of `body` (rad for unit vectors). Always > 0.
    pub sigma: f64,
    /// Optional sensor name, for per-sensor settings and statistics.
    pub sensor: Option<String>,
    /// `Some(up)`: a heading-only observation. Only the rotation about the reference-frame axis `up`
    /// (unit) is observed: the angle, about `up`, between the horizontal part (perpendicular to `up`)
    /// of `reference` and that of the measurement rotated into the reference frame. Its 1σ is
    /// `sigma / ‖horizontal part of reference‖` rad. The filters never tilt the estimate with it (see
    /// [`imu`]). `None`: the full vector observation above.
    #[serde(default)]
    pub heading_about: Option<Vector3<f64>>,
}

/// The vector observations taken at one instant.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObservationSet {
    pub t_s: f64,
    pub observations: Vec<VectorObservation>,
}

/// A time-stamped input to a filter.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Measurement {
    Gyro(GyroSample),
    Vectors(ObservationSet),
}

impl Measurement {
    pub fn t_s(&self) -> f64 {
        match self {
            Measurement::Gyro(g) => g.t_s,
            Measurement::Vectors(v) => v.t_s,
        }
    }
}
