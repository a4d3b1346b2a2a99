//! attitude-core: the numeric core of attitude-service, usable on its own (no network, no async, no
//! JSON: the compiler keeps it so, this crate has no such dependency).
//!
//! * [`attitude`]: quaternions (the conventions), Rodrigues parameters, the weighted quaternion
//!   average, the q-method.
//! * [`sensors`]: measurement types and sensor models; [`ahrs`]: raw IMU samples to filter inputs.
//! * [`filters`]: the MEKF, USQUE, the quaternion particle filter and the sparse-grid quadrature
//!   filter behind one interface.
//! * [`bounds`]: the Cramér–Rao bounds; [`rng`]: the particle filter's random numbers;
//!   [`sim`]: truth and measurement simulation.
//! * [`vehicle`]: one vehicle as a state machine (reorder window, time checks, gate, health, resets),
//!   taking and emitting domain values; [`rejection`]: why an input is refused (the contract's codes).
//!
//! Typed errors, never a panic on any input. `docs/algorithms.md` is the account of the mathematics.

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also refuses NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod ahrs;
pub mod attitude;
pub mod bounds;
pub mod filters;
pub mod rejection;
pub mod rng;
pub mod sensors;
pub mod sim;
pub mod simd;
pub mod stats;
pub mod vehicle;
