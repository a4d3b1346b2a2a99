//! attitude-lab: the laboratory of attitude-service. What a researcher runs, not what an operator
//! deploys: it depends on the service's library and the numeric core, never the other way round.
//!
//! Layout (see `ARCHITECTURE.md`):
//! * [`study`]: Monte-Carlo accuracy studies of the filters against the Cramér–Rao bound, the
//!   particle-count sweep and their reports (JSON, markdown, PNG figures); `study::broad`, the scores
//!   of a recorded IMU trial against its optical truth (BROAD's RMSEs, tilt and heading honesty).
//! * [`tools`]: `bench` (filter step costs), `imu_study` and `imu_bench` (recorded IMU trials through
//!   the vehicle pipeline, scored or timed; the tuning), `loadgen` (load against a running service, and
//!   the echo baseline) and `soak` (a long run of the service binary under load).
//! * [`cli`]: the commands of the `attitude-lab` binary (options, set-up, output); `main.rs` only
//!   dispatches to them.

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also refuses NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod cli;
pub mod study;
pub mod tools;
