//! attitude-service: networked multi-vehicle attitude estimation.
//!
//! Layout (see `ARCHITECTURE.md`):
//! * [`attitude`], [`sensors`], [`ahrs`], [`filters`], [`bounds`], [`rng`], [`stats`], [`sim`],
//!   [`rejection`] and
//!   the vehicle state machine ([`vehicle`]): the numeric core, the crate `attitude-core`
//!   (`crates/attitude-core`), re-exported here under the same paths. No I/O, no async, no JSON.
//! * [`wire`]: the JSON messages of the service and their validation into domain types.
//! * [`service`]: the zenoh service (configuration, key expressions, vehicle engine, queryables).
//! * [`tools`]: around the service, what an operator runs: the scenario publisher, the demo, and how
//!   they put inputs (`publish`, `routed`).
//! * [`cli`]: the binary's commands, `serve`, `simulate` and `demo` (options, set-up, output); `main.rs`
//!   only dispatches to them. Its runtime, logging, configuration and scenario options serve the lab's
//!   commands too.
//!
//! The laboratory (Monte-Carlo studies, sweeps, the SGHQF's rule as JSON, benches, the IMU study and its
//! tuning, load and soak) is the crate `attitude-lab` (`crates/attitude-lab`) and its binary
//! `attitude-lab`: it depends on this library, never the other way round.

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also refuses NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub use attitude_core::{
    ahrs, attitude, bounds, filters, rejection, rng, sensors, sim, simd, stats, vehicle,
};

pub mod cli;
pub mod service;
pub mod tools;
pub mod wire;
