//! The commands of the `attitude-service` binary: for each, its options (clap) and the function that
//! runs it: validates the options, sets up what it needs, calls the library, prints the result.
//! `main.rs` only parses the command line and calls one of these; the work itself is in the library
//! ([`crate::study`], [`crate::service`], [`crate::tools`]), which knows nothing of the command line.
//!
//! One file per group of commands:
//! * `study`: `montecarlo` and `sweep`; `scenario`: the scenario options they share with `simulate`
//!   and `demo`, and `scenarios`;
//! * `serve`: `serve`;
//! * `simulate`: `simulate` and `demo`;
//! * `bench`: `bench` and `imu-bench`;
//! * `imu_study`: `imu-study` (and its tuning);
//! * `load`: `loadgen` and `soak`;
//! * `quadrature`: `quadrature` (the SGHQF's sparse-grid rule as JSON, for an independent check);
//! * `runtime`: the async runtime, the logging and the shutdown token (one per process, cancelled by
//!   SIGINT or SIGTERM); `config`: the configuration file and the zenoh session configurations.
//!
//! Errors are `anyhow` here, and only here (and in `main.rs`): below this layer they are typed.

pub mod bench;
pub mod config;
pub mod imu_study;
pub mod load;
pub mod quadrature;
pub mod runtime;
pub mod scenario;
pub mod serve;
pub mod simulate;
pub mod study;
