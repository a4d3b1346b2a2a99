//! The accelerometer read as the direction of gravity, on both paths: a `gravity` sensor on
//! `P/V/vectors` ([`vector`], applied by `vehicle::VehicleState::apply_models`) and the raw-IMU
//! pipeline's gravity channel ([`channel`], with its settings [`config`]). What the two share is here:
//! the reference vertical and the norm gate.

pub mod channel;
pub mod config;
pub mod vector;

pub use channel::{GravityChannel, TiltObservation};
pub use config::AccConfig;
pub use vector::{GravityModel, LowpassState};

use nalgebra::Vector3;

/// The reference-frame vertical (East-North-Up).
pub const UP: Vector3<f64> = Vector3::new(0.0, 0.0, 1.0);

/// `|n/n₀ − 1|`: how far a specific force's norm `n` is from gravity's `n₀` (relative). NaN when
/// either is not a norm.
pub fn norm_deviation(norm: f64, gravity_norm: f64) -> f64 {
    (norm / gravity_norm - 1.0).abs()
}

/// Whether a reading that deviates by `deviation` ([`norm_deviation`]) passes the gate `norm_gate`
/// (a NaN never does): beyond it the specific force is too far from gravity to say where up is.
pub fn passes_norm_gate(deviation: f64, norm_gate: f64) -> bool {
    deviation <= norm_gate
}
