//! The `attitude-lab` binary: parses the command line and calls the command's function in
//! `attitude_lab::cli`, which does the rest (see `ARCHITECTURE.md`). The laboratory: studies, benches,
//! the IMU study and its tuning, load and soak; what an operator runs is `attitude-service`.

use anyhow::Result;
use attitude_lab::cli::{bench, imu_study, load, quadrature, scenarios, study};
use attitude_service::cli::runtime::{block_on, block_on_until_signal};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "attitude-lab",
    version,
    about = "The laboratory of attitude-service: accuracy studies, benches, the IMU study and its \
             tuning, load and soak"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Accuracy study: run filters on the same simulated data of a scenario and compare them with the
    /// posterior Cramér–Rao bound. Writes DIR/summary.json, DIR/summary.md and PNG plots.
    Montecarlo(study::MontecarloArgs),
    /// Particle-count sweep of one filter: the montecarlo study at each count of --particles; writes
    /// DIR/sweep.json, DIR/sweep.md and DIR/sweep.png (RMS/PCRB and cost per step against N).
    Sweep(study::SweepArgs),
    /// Lists the standard scenarios and every parameter they use.
    Scenarios,
    /// Prints a sparse-grid Gauss–Hermite rule of the SGHQF (points and weights for a standard
    /// normal) as JSON, for a check against an independent implementation.
    Quadrature(quadrature::QuadratureArgs),
    /// Each filter's per-step cost on this machine (gyro propagation + an update with three vector
    /// observations), against the MEKF measured in the same run.
    Bench(bench::BenchArgs),
    /// A recorded IMU trial (a file of scripts/broad-export.py) through one vehicle of the service's
    /// pipeline in one process without the network, timed: the Rust half of benches/vqf_compare.py.
    ImuBench(bench::ImuBenchArgs),
    /// Recorded IMU trials (files of scripts/broad-export.py) through the service's vehicle pipeline in
    /// one process, scored against their truth: BROAD's RMSEs and how often the error lies inside the
    /// published covariance.
    ImuStudy(imu_study::ImuStudyArgs),
    /// Load against a running service: K vehicles publishing gyro and vectors at a rate; reports
    /// throughput, put→estimate latency percentiles and losses. --echo measures a bare zenoh round
    /// trip through a trivial echo the same way (the baseline).
    Loadgen(load::LoadgenArgs),
    /// Soak (not run in CI): starts `attitude-service serve` as a child process with the chosen filter
    /// for every vehicle, streams gyro and vector messages for N vehicles in real time, and per window
    /// records the service's resident memory, put→estimate latency p50/p99/max, estimates received
    /// against vector messages sent, and rejections; ends with the first window against the last and
    /// the child's exit status after SIGTERM.
    Soak(load::SoakArgs),
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Montecarlo(args) => study::montecarlo(args),
        Command::Sweep(args) => study::sweep(args),
        Command::Scenarios => scenarios::list_scenarios(),
        Command::Quadrature(args) => quadrature::quadrature(args),
        Command::Bench(args) => bench::bench(args),
        Command::ImuBench(args) => bench::imu_bench(args),
        Command::ImuStudy(args) => imu_study::imu_study(args),
        Command::Loadgen(args) => block_on(load::loadgen(args)),
        Command::Soak(args) => block_on_until_signal(|stop| load::soak(args, stop)),
    }
}
