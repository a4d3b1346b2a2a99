//! `bench` (each filter's step cost against the MEKF) and `imu-bench` (a recorded IMU trial through one
//! vehicle, timed); `bench --vqf` runs benches/vqf_compare.py beside.

use crate::filters::FilterSpec;
use anyhow::{bail, Context, Result};
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
    /// Also run the side-by-side of our MEKF (no network) and VQF (the `vqf` PyPI package, C++ batch
    /// mode) on this BROAD trial, through benches/vqf_compare.py in the project's .venv (created by
    /// scripts/python-tests.sh).
    #[arg(long)]
    vqf: Option<PathBuf>,
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
    let report = crate::tools::bench::run(
        args.particles,
        std::time::Duration::from_secs_f64(args.seconds),
    )?;
    let vqf = match &args.vqf {
        None => None,
        Some(trial) => Some(vqf_side_by_side(trial)?),
    };
    if args.json {
        let mut v = serde_json::to_value(&report)?;
        if let (Some(obj), Some(x)) = (v.as_object_mut(), vqf) {
            obj.insert("vqf".into(), x);
        }
        println!("{v}");
    } else {
        print!("{}", report.table());
        if let Some(x) = vqf {
            println!(
                "\nMEKF vs VQF on {}:\n{}",
                args.vqf
                    .as_ref()
                    .map(|p| p.display().to_string())
                    .unwrap_or_default(),
                serde_json::to_string_pretty(&x)?
            );
        }
    }
    Ok(())
}

/// Runs benches/vqf_compare.py in the project's venv against this binary and returns its JSON.
fn vqf_side_by_side(trial: &std::path::Path) -> Result<serde_json::Value> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = root.join(".venv/bin/python");
    let script = root.join("benches/vqf_compare.py");
    if !python.exists() {
        bail!("{} is missing: run `bash scripts/python-tests.sh` once to create the venv (with vqf and h5py)", python.display());
    }
    let exe = std::env::current_exe()?;
    let out = std::process::Command::new(&python)
        .arg(&script)
        .arg(trial)
        .arg("--json")
        .arg("--no-python-loop")
        .arg("--bin")
        .arg(&exe)
        .output()
        .with_context(|| format!("running {}", script.display()))?;
    if !out.status.success() {
        bail!(
            "vqf_compare.py failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .unwrap_or("{}");
    Ok(serde_json::from_str(line)?)
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
