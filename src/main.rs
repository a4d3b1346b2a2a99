//! The `attitude-service` binary: argument parsing only; the work is in the library.

use anyhow::{bail, Context, Result};
use attitude_service::filters::FilterSpec;
use attitude_service::sim::{InitialError, ScenarioName, ScenarioParams, DEG, DEG_PER_HR};
use attitude_service::study::report::write_report;
use attitude_service::study::runner::{run_study, StudyConfig};
use attitude_service::study::sweep::{run_sweep, write_sweep_report};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Vector3;
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "attitude-service",
    version,
    about = "Networked multi-vehicle attitude estimation (MEKF, USQUE, quaternion particle filter)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Accuracy study: run filters on the same simulated data of a scenario and compare them with the
    /// posterior Cramér–Rao bound. Writes DIR/summary.json, DIR/summary.md and PNG plots.
    Montecarlo(MontecarloArgs),
    /// Particle-count sweep of one filter: the montecarlo study at each count of --particles; writes
    /// DIR/sweep.json, DIR/sweep.md and DIR/sweep.png (RMS/PCRB and cost per step against N).
    Sweep(SweepArgs),
    /// Lists the standard scenarios and every parameter they use.
    Scenarios,
}

#[derive(Args)]
struct MontecarloArgs {
    /// Comma-separated filters: mekf, usque:propagated, usque:average, qpf:propagated, qpf:average.
    #[arg(long, value_delimiter = ',', default_value = "mekf")]
    filters: Vec<FilterSpec>,
    /// Particles of the quaternion particle filter.
    #[arg(long, default_value_t = 1000)]
    particles: usize,
    #[command(flatten)]
    study: StudyArgs,
}

#[derive(Args)]
struct SweepArgs {
    /// The filter to sweep.
    #[arg(long, default_value = "qpf:average")]
    filter: FilterSpec,
    /// Comma-separated particle counts.
    #[arg(long, value_delimiter = ',', default_value = "250,500,1000,2000,5000")]
    particles: Vec<usize>,
    #[command(flatten)]
    study: StudyArgs,
}

/// Options shared by the studies: scenario, runs, seed, overrides, output.
#[derive(Args)]
struct StudyArgs {
    /// Scenario: star-tracker, magnetometer-leo or lost-in-space (see `scenarios`).
    #[arg(long)]
    scenario: ScenarioName,
    /// Monte-Carlo runs.
    #[arg(long, default_value_t = 20)]
    runs: usize,
    /// Study seed; the same seed gives the same summary.json.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run length, s (default: the scenario's).
    #[arg(long)]
    duration: Option<f64>,
    /// Initial attitude error, deg: one value for every axis or three comma-separated. The 3-2-1 Euler
    /// magnitudes (random signs) for magnetometer-leo; otherwise a per-axis Gaussian 1σ, and the filter
    /// is told the same 1σ (this replaces lost-in-space's uniformly random attitude).
    #[arg(long, value_delimiter = ',', num_args = 1..=3)]
    init_error_deg: Option<Vec<f64>>,
    /// Start every run from a uniformly random attitude (lost in space), whatever the scenario.
    #[arg(long)]
    uniform_init: bool,
    /// Largest true gyro bias per axis, deg/hr (drawn uniformly in ±this; the filter's initial bias
    /// 1σ is set to the same value).
    #[arg(long)]
    bias_deg_hr: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    jobs: Option<usize>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Montecarlo(args) => montecarlo(args),
        Command::Sweep(args) => sweep(args),
        Command::Scenarios => {
            for name in ScenarioName::ALL {
                println!("{}\n", ScenarioParams::default_for(name).describe());
            }
            Ok(())
        }
    }
}

fn scenario_from_args(args: &StudyArgs) -> Result<ScenarioParams> {
    let mut p = ScenarioParams::default_for(args.scenario);
    if let Some(d) = args.duration {
        p.duration_s = d;
    }
    if let Some(e) = &args.init_error_deg {
        let v = match e.as_slice() {
            [a] => Vector3::repeat(*a),
            [a, b, c] => Vector3::new(*a, *b, *c),
            _ => bail!("--init-error-deg takes one or three values"),
        } * DEG;
        p.initial_error = match p.initial_error {
            InitialError::PerAxisGaussian { .. } => {
                p.filter_init_sigma_att_rad = v;
                InitialError::PerAxisGaussian { sigma_rad: v }
            }
            InitialError::Euler321Magnitudes { .. } => InitialError::Euler321Magnitudes {
                roll_rad: v[0],
                pitch_rad: v[1],
                yaw_rad: v[2],
            },
            // A Gaussian error instead of the uniformly random attitude.
            InitialError::UniformRandom => {
                p.filter_init_sigma_att_rad = v;
                InitialError::PerAxisGaussian { sigma_rad: v }
            }
        };
    }
    if args.uniform_init {
        p.initial_error = InitialError::UniformRandom;
        p.filter_init_sigma_att_rad = Vector3::repeat(std::f64::consts::PI);
    }
    if let Some(b) = args.bias_deg_hr {
        p.true_bias_rad_s = attitude_service::sim::BiasSpec::UniformPerAxis {
            max_rad_s: b * DEG_PER_HR,
        };
        p.filter_init_bias_sigma_rad_s = Vector3::repeat((b * DEG_PER_HR).max(1e-3 * DEG_PER_HR));
    }
    p.validate()
        .map_err(|e| anyhow::anyhow!("invalid scenario parameters: {e}"))?;
    Ok(p)
}

fn study_config(
    args: &StudyArgs,
    filters: Vec<FilterSpec>,
    particles: usize,
) -> Result<StudyConfig> {
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    if filters.is_empty() {
        bail!("--filters must name at least one filter");
    }
    if particles < 2 {
        bail!("--particles must be at least 2");
    }
    let jobs = args.jobs.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    });
    Ok(StudyConfig {
        scenario: scenario_from_args(args)?,
        filters,
        runs: args.runs,
        seed: args.seed,
        particles,
        jobs,
    })
}

/// A progress bar on a terminal, nothing otherwise (CI logs, pipes).
fn progress(total: usize, message: String) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(total as u64);
    b.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} runs, {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    b.set_message(message);
    b
}

fn montecarlo(args: MontecarloArgs) -> Result<()> {
    let config = study_config(&args.study, args.filters.clone(), args.particles)?;
    let bar = progress(config.runs, config.scenario.name.to_string());
    let study = run_study(&config, &|| bar.inc(1));
    bar.finish_and_clear();
    let out = &args.study.out;
    let files = write_report(&study, out)
        .with_context(|| format!("writing the report to {}", out.display()))?;
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap_or_default();
    println!("{md}");
    println!("wrote:");
    for f in files {
        println!("  {}", f.display());
    }
    Ok(())
}

fn sweep(args: SweepArgs) -> Result<()> {
    if args.particles.iter().any(|&n| n < 2) || args.particles.is_empty() {
        bail!("--particles must list counts of at least 2");
    }
    let config = study_config(&args.study, vec![args.filter], args.particles[0])?;
    let bar = progress(
        config.runs * args.particles.len(),
        format!("{} sweep", config.scenario.name),
    );
    let rows = run_sweep(&config, &args.particles, &|| bar.inc(1));
    bar.finish_and_clear();
    let out = &args.study.out;
    let files = write_sweep_report(&config.scenario.name.to_string(), config.seed, &rows, out)
        .with_context(|| format!("writing the sweep to {}", out.display()))?;
    println!(
        "{}",
        std::fs::read_to_string(out.join("sweep.md")).unwrap_or_default()
    );
    println!("wrote:");
    for f in files {
        println!("  {}", f.display());
    }
    Ok(())
}
