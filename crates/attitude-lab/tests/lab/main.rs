//! The integration tests of attitude-lab, in one test binary (`cargo test --release -p attitude-lab
//! --test lab`): a module per subject, run by name (`cargo test --release -p attitude-lab --test lab
//! montecarlo_cli::`).

mod common;

mod binaries;
mod loadgen;
mod montecarlo_cli;
mod scaling;
mod soak_cli;
mod tuning;
