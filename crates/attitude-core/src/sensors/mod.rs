//! Measurements as the filters see them, and the sensor models that the simulator samples.
//!
//! Frames and units: gyro rates are body-frame rad/s; a vector observation pairs a body-frame
//! measurement with the same direction or field known in the reference frame, in the same units
//! (unit vectors with `sigma` in rad, or a magnetic field in nT with `sigma` in nT). Times are seconds of
//! the sender's clock.

pub mod check;
pub mod field;
pub mod gravity;
pub mod gyro;
pub mod heading;
pub mod lowpass;
pub mod model;
pub mod vector;

pub use gyro::{GyroNoise, GyroSimulator};
pub use vector::{MagnetometerModel, StarCamera, SunSensor};

use nalgebra::Vector3;

/// One gyro sample: the measured body rate `ω̃` valid from `t_s` until the next sample (zero-order hold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroSample {
    pub t_s: f64,
    pub omega_body_rad_s: Vector3<f64>,
}

/// One vector observation `b̃ = A(q) r + v`, `v ~ N(0, σ² I₃)`.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorObservation {
    /// Measured in the body frame.
    pub body: Vector3<f64>,
    /// The same direction or field in the reference frame, same units as `body`.
    pub reference: Vector3<f64>,
    /// Per-axis 1σ noise in the units of `body` (rad for unit vectors). Always > 0.
    pub sigma: f64,
    /// Optional sensor name, for per-sensor settings and statistics.
    pub sensor: Option<String>,
    /// Which part of the attitude the observation informs (see [`Aspect`]).
    pub aspect: Aspect,
}

/// Which part of the attitude a vector observation informs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Aspect {
    /// The whole direction: `b̃ = A(q) r + v`, `v ~ N(0, σ² I₃)`.
    #[default]
    Full,
    /// Heading only about the reference-frame axis `up` (unit): the angle, about `up`, between the
    /// horizontal part (perpendicular to `up`) of `reference` and that of the measurement rotated into
    /// the reference frame. Its 1σ is `sigma / ‖horizontal part of reference‖` rad. The filters never
    /// tilt the estimate with it (see `imu`); its bias correction acts about the vertical only.
    Heading(Vector3<f64>),
    /// The direction of `up` (a gravity observation, `reference` ∥ `up`): the likelihood of the full
    /// direction (which says nothing about the rotation about `up`), but the Kalman filters turn the
    /// estimate about horizontal axes only and leave the gyro bias along the vertical alone, so that
    /// an acceleration mistaken for gravity never moves the heading or its bias (see `imu`).
    Tilt(Vector3<f64>),
}

impl Aspect {
    /// The vertical of a heading-only observation.
    pub fn heading_axis(&self) -> Option<&Vector3<f64>> {
        match self {
            Aspect::Heading(up) => Some(up),
            _ => None,
        }
    }
}

/// The vector observations taken at one instant.
#[derive(Clone, Debug, PartialEq)]
pub struct ObservationSet {
    pub t_s: f64,
    pub observations: Vec<VectorObservation>,
}

/// One raw IMU sample: the body-frame rate over `(t_prev, t]` (rad/s), the specific force (m/s²) and,
/// optionally, the magnetic field (any unit). A vehicle turns it into filter inputs with
/// [`crate::ahrs`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    pub t_s: f64,
    pub gyr_rad_s: Vector3<f64>,
    pub acc_m_s2: Vector3<f64>,
    pub mag: Option<Vector3<f64>>,
}

/// A time-stamped input of a vehicle. A filter takes `Gyro` and `Vectors`; an `Imu` sample reaches it
/// through the sensor models of [`crate::ahrs`].
#[derive(Clone, Debug, PartialEq)]
pub enum Measurement {
    Gyro(GyroSample),
    Vectors(ObservationSet),
    Imu(ImuSample),
}

impl Measurement {
    pub fn t_s(&self) -> f64 {
        match self {
            Measurement::Gyro(g) => g.t_s,
            Measurement::Vectors(v) => v.t_s,
            Measurement::Imu(s) => s.t_s,
        }
    }
}
