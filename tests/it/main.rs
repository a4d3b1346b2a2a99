//! The integration tests of attitude-service, in one test binary (`cargo test --release --test it`):
//! a module per subject, run by name (`cargo test --release --test it ahrs::`).
//!
//! The persisted cases of the property tests are in `tests/proptest-regressions/<module>.txt`, where
//! proptest looks for them by default (beside the folder of this `main.rs`).

mod common;

mod ahrs;
mod bad_inputs;
mod checkpoint_golden;
mod conventions;
mod fleet;
mod imu_models;
mod load;
mod mekf;
mod metrics;
mod parsers_prop;
mod properties;
mod proto;
mod qpf;
mod robustness;
mod ros2;
mod ros2_dds;
mod service;
mod sghqf;
mod tidy;
mod usque;
mod zenoh_routing;
