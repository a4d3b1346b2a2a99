//! The `attitude-service` binary: parses the command line and calls the command's function in
//! `attitude_service::cli`, which does the rest (see `ARCHITECTURE.md`). What an operator runs:
//! `serve`, `simulate` and `demo`; the studies, benches and load tools are the `attitude-lab` binary's.

use anyhow::Result;
use attitude_service::cli::runtime::block_on_until_signal;
use attitude_service::cli::{serve, simulate};
use clap::{Parser, Subcommand};

// jemalloc is the process's `malloc` (linked in unprefixed), for C and Rust alike: Rust's default
// allocator calls `malloc`, and the DDS plugin's C library frees memory Rust allocated (a Rust-only
// allocator beside glibc's aborted there). Freed pages go back from one background thread.
use tikv_jemalloc_sys as _;

#[allow(non_upper_case_globals)]
#[export_name = "malloc_conf"]
pub static malloc_conf: &[u8] = b"background_thread:true,max_background_threads:1\0";

#[derive(Parser)]
#[command(
    name = "attitude-service",
    version,
    about = "Networked multi-vehicle attitude estimation (MEKF, USQUE, quaternion particle filter, \
             sparse-grid quadrature filter)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The network service: subscribes to P/*/gyro and P/*/vectors, keeps one filter per vehicle,
    /// publishes P/V/estimate and answers P/V/attitude, covariance, state, reset, P/@/vehicles and
    /// P/@/health. Stops cleanly on SIGINT or SIGTERM. Logs go to stderr; set RUST_LOG=info for more.
    Serve(serve::ServeArgs),
    /// Publishes a scenario's measurements for N simulated vehicles to a running service (and their
    /// truth on P/V/truth), in real time or faster.
    Simulate(simulate::SimulateArgs),
    /// The service and simulated vehicles in one process over real zenoh, with a live table of each
    /// vehicle's error against the truth. By default: four vehicles with different filters on
    /// magnetometer-leo (initial errors up to 160°), 4 h of flight in about 30 s.
    Demo(simulate::DemoArgs),
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Serve(args) => block_on_until_signal(|stop| serve::serve(args, stop)),
        Command::Simulate(args) => block_on_until_signal(|stop| simulate::simulate(args, stop)),
        Command::Demo(args) => block_on_until_signal(|stop| simulate::demo(args, stop)),
    }
}
