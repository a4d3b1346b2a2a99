//! The laboratory's tools, run by the commands of [`crate::cli`]: `bench` (filter step costs),
//! `imu_study` and `imu_bench` (recorded IMU trials through the vehicle pipeline), `loadgen` and `soak`
//! (zenoh clients of the service, not part of it; they put inputs the way the service's own tools do,
//! `attitude_service::tools::{publish, routed}`).
//! Library code: typed errors, no command-line parsing; a long run stops on a `CancellationToken`.

pub mod bench;
pub mod imu_bench;
pub mod imu_study;
pub mod loadgen;
pub mod soak;
