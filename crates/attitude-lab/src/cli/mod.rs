//! The commands of the `attitude-lab` binary: for each, its options (clap) and the function that runs
//! it: validates the options, sets up what it needs, calls the library, prints the result. `main.rs`
//! only parses the command line and calls one of these; the work itself is in the library
//! ([`crate::study`], [`crate::tools`]), which knows nothing of the command line.
//!
//! One file per group of commands:
//! * `study`: `montecarlo` and `sweep` (with the scenario options of the service's
//!   `attitude_service::cli::scenario`, which `simulate` and `demo` share); `scenarios`: `scenarios`;
//! * `bench`: `bench` and `imu-bench`;
//! * `imu_study`: `imu-study` (and its tuning);
//! * `load`: `loadgen` and `soak`;
//! * `quadrature`: `quadrature` (the SGHQF's sparse-grid rule as JSON, for an independent check).
//!
//! The async runtime, the logging, the shutdown token and the zenoh session configurations are the
//! service's (`attitude_service::cli::{runtime, config}`): one way to run a command in both binaries.
//! Errors are `anyhow` here, and only here (and in `main.rs`): below this layer they are typed.

pub mod bench;
pub mod imu_study;
pub mod load;
pub mod quadrature;
pub mod scenarios;
pub mod study;
