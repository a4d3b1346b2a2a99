//! Command-line tools around the service: the scenario publisher (`simulate`) and the all-in-one
//! `demo`. They are zenoh clients of the service, not part of it.

pub mod bench;
pub mod demo;
pub mod imu_bench;
pub mod imu_study;
pub mod loadgen;
pub mod simulate;
pub mod soak;
