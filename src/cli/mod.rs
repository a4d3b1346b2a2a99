//! The commands of the `attitude-service` binary: for each, its options (clap) and the function that
//! runs it: validates the options, sets up what it needs, calls the library, prints the result.
//! `main.rs` only parses the command line and calls one of these; the work itself is in the library
//! ([`crate::service`], [`crate::tools`]), which knows nothing of the command line.
//!
//! One file per group of commands:
//! * `serve`: `serve`;
//! * `simulate`: `simulate` and `demo`;
//! * `scenario`: the scenario options `simulate` and `demo` share with the lab's studies;
//! * `runtime`: the async runtime, the logging and the shutdown token (one per process, cancelled by
//!   SIGINT or SIGTERM); `config`: the configuration file and the zenoh session configurations.
//!
//! `scenario`, `runtime`, `config` and `simulate::publishing` are public for the commands of the
//! laboratory's binary too (`attitude-lab`: its studies, benches, load and soak), so both binaries read
//! scenarios, run, log and configure zenoh one way.
//!
//! Errors are `anyhow` here, and only here (and in `main.rs`): below this layer they are typed.

pub mod config;
pub mod runtime;
pub mod scenario;
pub mod serve;
pub mod simulate;
