//! attitude-service: networked multi-vehicle attitude estimation.
//!
//! Layout (see `ARCHITECTURE.md`):
//! * [`attitude`], [`sensors`], [`ahrs`], [`filters`], [`bounds`], [`rng`], [`stats`], [`sim`],
//!   [`rejection`] and
//!   the vehicle state machine ([`vehicle`]): the numeric core, the crate `attitude-core`
//!   (`crates/attitude-core`), re-exported here under the same paths. No I/O, no async, no JSON.
//! * [`wire`]: the contract: its key expressions and JSON messages, and their validation into domain
//!   types.
//! * [`engine`]: the vehicles without the network: registry, inboxes, dispatcher, workers and
//!   housekeeping; it reaches the fleet and the ROS 2 edge only through its [`engine::Hooks`].
//! * [`fleet`]: a fleet of instances: routes, assignment, membership, standby data, takeovers, the
//!   batches and the routed sender.
//! * [`ros2`]: the ROS 2 edge: its messages and CDR, keys, the edge, the network side, DDS.
//! * [`query`]: what the service answers: the reads, `P/@/metrics`, the queryables.
//! * [`service`]: the zenoh service's wiring, its configuration, session, checkpoints and inputs.
//! * [`tools`]: around the service, what an operator runs: the scenario publisher, the demo, and how
//!   they put inputs (`publish`; to a fleet through `fleet::sender`).
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
pub mod engine;
pub mod fleet;
pub mod query;
pub mod ros2;
pub mod service;
pub mod tools;
pub mod wire;
