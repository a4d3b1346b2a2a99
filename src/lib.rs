//! attitude-service: networked multi-vehicle attitude estimation.
//!
//! Layout (see `ARCHITECTURE.md`):
//! * [`attitude`], [`sensors`], [`filters`], [`bounds`], [`sim`], [`rng`], [`stats`]: the numeric
//!   core. No I/O, no async, no JSON; typed errors instead of panics.
//! * [`study`]: Monte-Carlo accuracy studies of the filters against the Cramér–Rao bound, and their
//!   reports.
//! * [`wire`]: the JSON messages of the service and their validation into domain types.
//! * [`service`]: the zenoh service (configuration, key expressions, vehicle engine, queryables).
//! * [`tools`]: zenoh clients of the service: the scenario publisher and the demo.

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also refuses NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod ahrs;
pub mod attitude;
pub mod bounds;
pub mod filters;
pub mod rng;
pub mod sensors;
pub mod service;
pub mod sim;
pub mod stats;
pub mod study;
pub mod tools;
pub mod wire;
