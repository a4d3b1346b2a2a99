//! `bench` (each filter's step cost against the MEKF) and `imu-bench` (a recorded IMU trial through one
//! vehicle, timed). VQF side by side is `benches/vqf_compare.py`, which calls these two commands.

use anyhow::{bail, Result};
use attitude_core::filters::FilterSpec;
use attitude_core::simd::Isa;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct BenchArgs {
    /// Particles of the particle filter.
    #[arg(long, default_value_t = 1000)]
    particles: usize,
    /// Measuring time per filter, s.
    #[arg(long, default_value_t = 1.0)]
    seconds: f64,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// The particle filter's instruction set: avx512, avx2 or portable (default: the widest this
    /// machine has). The estimates are the same bits with each.
    #[arg(long)]
    isa: Option<Isa>,
    /// At most this many threads per particle-filter pass (default: one per core from 65 536
    /// particles on, else one).
    #[arg(long)]
    threads: Option<usize>,
    /// Only `qpf:average`, at each of these particle counts (comma-separated): the cost curve.
    #[arg(long, value_delimiter = ',')]
    curve: Option<Vec<usize>>,
}

#[derive(Args)]
pub struct ImuBenchArgs {
    /// A trial file of scripts/broad-export.py.
    #[arg(long)]
    trial: PathBuf,
    /// The service configuration the vehicle runs.
    #[arg(long, default_value = "config/imu.json5")]
    config: PathBuf,
    /// Replace a configuration value: PATH=JSON (repeatable).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// The filter instead of the configuration's.
    #[arg(long)]
    filter: Option<FilterSpec>,
    /// Write the estimated quaternions here.
    #[arg(long)]
    estimates_out: Option<PathBuf>,
}

/// `bench`: the table, or one JSON object with `--json`.
pub fn bench(args: BenchArgs) -> Result<()> {
    if args.particles < 2 || !(args.seconds > 0.0) {
        bail!("--particles must be at least 2 and --seconds positive");
    }
    if let Err(isa) = Isa::force(args.isa) {
        bail!("this machine cannot run {}", isa.name());
    }
    attitude_core::filters::qpf::set_max_threads(args.threads.unwrap_or(0));
    if let Some(counts) = args.curve {
        if counts.iter().any(|n| *n < 2) {
            bail!("--curve: every particle count must be at least 2");
        }
        let points =
            crate::tools::bench::curve(&counts, std::time::Duration::from_secs_f64(args.seconds))?;
        if args.json {
            println!("{}", serde_json::to_value(&points)?);
        } else {
            println!(
                "qpf:average, {} — particles, threads, µs per step, ns per particle-step",
                Isa::active().name()
            );
            for p in points {
                println!(
                    "{:>9} {:>3} {:>12.1} {:>8.2}",
                    p.particles, p.threads, p.qpf_us_per_step, p.qpf_ns_per_particle_step
                );
            }
        }
        return Ok(());
    }
    let report = crate::tools::bench::run(
        args.particles,
        std::time::Duration::from_secs_f64(args.seconds),
    )?;
    if args.json {
        // (Through a JSON value, whose keys are sorted, as this output has always been.)
        println!("{}", serde_json::to_value(&report)?);
    } else {
        print!("{}", report.table());
    }
    Ok(())
}

/// `imu-bench`: prints the JSON line of [`crate::tools::imu_bench::main_entry`].
pub fn imu_bench(args: ImuBenchArgs) -> Result<()> {
    let line = crate::tools::imu_bench::main_entry(
        &args.trial,
        &args.config,
        &args.sets,
        args.filter,
        args.estimates_out.as_deref(),
    )?;
    println!("{line}");
    Ok(())
}
