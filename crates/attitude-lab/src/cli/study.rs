//! `montecarlo` and `sweep`: the accuracy studies of [`crate::study`], with a progress bar, their report
//! written and the markdown printed.

use crate::study::report::write_report;
use crate::study::runner::{run_study, StudyConfig};
use crate::study::sweep::{run_sweep, write_sweep_report};
use anyhow::{bail, Context, Result};
use attitude_core::filters::FilterSpec;
use attitude_service::cli::scenario::{scenario_from_args, ScenarioArgs};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Args)]
pub struct MontecarloArgs {
    /// Comma-separated filters: mekf, usque:propagated, usque:average, qpf:propagated, qpf:average,
    /// sghqf:propagated, sghqf:average.
    #[arg(long, value_delimiter = ',', default_value = "mekf")]
    filters: Vec<FilterSpec>,
    /// Particles of the quaternion particle filter.
    #[arg(long, default_value_t = 1000)]
    particles: usize,
    /// Sparse-grid level of the SGHQF (2..=4).
    #[arg(long, default_value_t = attitude_core::filters::sghqf::DEFAULT_LEVEL,
          value_parser = clap::value_parser!(u8).range(2..=4))]
    level: u8,
    #[command(flatten)]
    study: StudyArgs,
}

#[derive(Args)]
pub struct SweepArgs {
    /// The filter to sweep.
    #[arg(long, default_value = "qpf:average")]
    filter: FilterSpec,
    /// Comma-separated particle counts.
    #[arg(long, value_delimiter = ',', default_value = "250,500,1000,2000,5000")]
    particles: Vec<usize>,
    #[command(flatten)]
    study: StudyArgs,
}

/// Options shared by the studies: scenario, runs, seed, output.
#[derive(Args)]
struct StudyArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Monte-Carlo runs.
    #[arg(long, default_value_t = 20)]
    runs: usize,
    /// Study seed; the same seed gives the same summary.json.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    jobs: Option<usize>,
    /// Skip an input the filter refuses (and count it), as the service's vehicle rolls it back,
    /// instead of ending that run as failed.
    #[arg(long)]
    skip_refused: bool,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
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
        scenario: scenario_from_args(&args.scenario)?,
        filters,
        runs: args.runs,
        seed: args.seed,
        particles,
        level: attitude_core::filters::sghqf::DEFAULT_LEVEL,
        skip_refused: args.skip_refused,
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

/// `montecarlo`: the study, its report in `--out`, the markdown printed.
pub fn montecarlo(args: MontecarloArgs) -> Result<()> {
    let mut config = study_config(&args.study, args.filters.clone(), args.particles)?;
    config.level = args.level;
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

/// `sweep`: the study at each particle count, its report in `--out`, the markdown printed.
pub fn sweep(args: SweepArgs) -> Result<()> {
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
