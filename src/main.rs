//! The `attitude-service` binary: argument parsing only; the work is in the library.

use anyhow::{bail, Context, Result};
use attitude_service::filters::FilterSpec;
use attitude_service::service::config as service_config;
use attitude_service::service::keys::Keys;
use attitude_service::sim::{InitialError, ScenarioName, ScenarioParams, DEG, DEG_PER_HR};
use attitude_service::study::report::write_report;
use attitude_service::study::runner::{run_study, StudyConfig};
use attitude_service::study::sweep::{run_sweep, write_sweep_report};
use attitude_service::tools::demo::{demo, render};
use attitude_service::tools::simulate::{simulate, SimulateOptions};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Vector3;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

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
    /// The network service: subscribes to P/*/gyro and P/*/vectors, keeps one filter per vehicle,
    /// publishes P/V/estimate and answers P/V/attitude, covariance, state, reset, P/@/vehicles and
    /// P/@/health. Stops cleanly on SIGINT or SIGTERM. Logs go to stderr; set RUST_LOG=info for more.
    Serve(ServeArgs),
    /// Publishes a scenario's measurements for N simulated vehicles to a running service (and their
    /// truth on P/V/truth), in real time or faster.
    Simulate(SimulateArgs),
    /// The service and simulated vehicles in one process over real zenoh, with a live table of each
    /// vehicle's error against the truth. By default: four vehicles with different filters on
    /// magnetometer-leo (initial errors up to 160°), 4 h of flight in about 30 s.
    Demo(DemoArgs),
    /// Each filter's per-step cost on this machine (gyro propagation + an update with three vector
    /// observations), against the MEKF measured in the same run.
    Bench(BenchArgs),
    /// A recorded IMU trial (a file of scripts/broad-export.py) through one vehicle of the service's
    /// pipeline in one process without the network, timed: the Rust half of `bench --vqf`.
    ImuBench(ImuBenchArgs),
    /// Recorded IMU trials (files of scripts/broad-export.py) through the service's vehicle pipeline in
    /// one process, scored against their truth: BROAD's RMSEs and how often the error lies inside the
    /// published covariance.
    ImuStudy(ImuStudyArgs),
    /// Load against a running service: K vehicles publishing gyro and vectors at a rate; reports
    /// throughput, put→estimate latency percentiles and losses. --echo measures a bare zenoh round
    /// trip through a trivial echo the same way (the baseline).
    Loadgen(LoadgenArgs),
    /// Soak (not run in CI): starts `serve` as a child process with the chosen filter for every
    /// vehicle, streams gyro and vector messages for N vehicles in real time, and per window records
    /// the service's resident memory, put→estimate latency p50/p99/max, estimates received against
    /// vector messages sent, and rejections; ends with the first window against the last and the
    /// child's exit status after SIGTERM.
    Soak(SoakArgs),
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

/// The scenario and its overrides (studies, simulate, demo).
#[derive(Args, Clone)]
struct ScenarioArgs {
    /// Scenario: star-tracker, magnetometer-leo or lost-in-space (see `scenarios`). Required, except
    /// for `demo` (magnetometer-leo).
    #[arg(long)]
    scenario: Option<ScenarioName>,
    /// Run length, s (default: the scenario's; 14400 for `demo`).
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
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
struct ServeArgs {
    /// Configuration file (JSON5; `zenoh` and `service` sections). Default: the built-in defaults,
    /// identical to config/default.json5.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Zenoh endpoint to listen on (repeatable); replaces the configuration's listen endpoints.
    #[arg(long)]
    listen: Vec<String>,
    /// Zenoh endpoint to connect to (repeatable); replaces the configuration's connect endpoints.
    #[arg(long)]
    connect: Vec<String>,
    /// Checkpoint every vehicle's complete state into DIR (periodically and on shutdown) and resume
    /// from it at start; replaces `service.persistence.state_dir`.
    #[arg(long, value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Join a dynamic fleet: instances of the same group share the vehicles (liveliness membership,
    /// rendezvous hashing, takeover on failure); sets `service.fleet.mode` to `dynamic`.
    #[arg(long)]
    fleet: bool,
    /// The fleet group (`service.fleet.group`; default `default`).
    #[arg(long, value_name = "NAME")]
    group: Option<String>,
    /// This instance's name, unique in its group (`service.fleet.instance`; default host-pid).
    #[arg(long, value_name = "NAME")]
    instance: Option<String>,
    /// Serve only the vehicles whose id matches this key-expression chunk, e.g. `a$*`
    /// (`service.fleet.vehicles`; default `*`): static sharding.
    #[arg(long, value_name = "PATTERN")]
    vehicles: Option<String>,
}

/// The simulated fleet of `simulate` and `demo`.
#[derive(Args, Clone)]
struct FleetArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Number of vehicles (ids <vehicle-prefix>1, <vehicle-prefix>2, ...). Default 3 (`demo`: 4).
    #[arg(long)]
    vehicles: Option<usize>,
    /// Vehicle id prefix.
    #[arg(long, default_value = "sc")]
    vehicle_prefix: String,
    /// Filters assigned to the vehicles round-robin (by a reset before streaming); default: the
    /// service's configured filter (`demo`: qpf:average,qpf:propagated,usque:average,mekf).
    #[arg(long, value_delimiter = ',')]
    filters: Vec<FilterSpec>,
    /// Particles of the particle-filter vehicles (default: the service's).
    #[arg(long)]
    particles: Option<usize>,
    /// Simulated seconds per wall-clock second; 0 publishes as fast as possible. Default 1 (`demo`: 480).
    #[arg(long)]
    speed: Option<f64>,
    /// Seed of the simulated data.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Do not send the vehicles a reset with the scenario's initial estimate before streaming: the
    /// service then initialises each vehicle from its measurements.
    #[arg(long)]
    no_reset: bool,
    /// Key prefix of the service.
    #[arg(long, default_value = "attitude")]
    prefix: String,
}

#[derive(Args)]
struct SimulateArgs {
    #[command(flatten)]
    fleet: FleetArgs,
    /// Zenoh endpoint of the service (repeatable).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    connect: Vec<String>,
}

#[derive(Args)]
struct DemoArgs {
    #[command(flatten)]
    fleet: FleetArgs,
    /// Where the in-process service listens and the simulator connects (a concrete port).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    listen: String,
    /// Service configuration (JSON5), as for `serve`.
    #[arg(long)]
    config: Option<PathBuf>,
}

#[derive(Args)]
struct BenchArgs {
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
struct ImuBenchArgs {
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

#[derive(Args)]
struct ImuStudyArgs {
    /// Trial files, or directories of them (*.trial).
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// The service configuration the vehicles run.
    #[arg(long, default_value = "config/imu.json5")]
    config: PathBuf,
    /// Replace a configuration value: PATH=JSON, e.g. service.imu.acc.motion_gain=1.5 (repeatable).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// The filter instead of the configuration's: mekf, usque[:…], qpf[:average|:propagated].
    #[arg(long)]
    filter: Option<FilterSpec>,
    /// Particles of a qpf.
    #[arg(long)]
    particles: Option<usize>,
    /// Print one JSON array instead of a table.
    #[arg(long)]
    json: bool,
    /// Write each trial's estimates, truth and pipeline state per sample to DIR/TRIAL.csv.
    #[arg(long)]
    series: Option<PathBuf>,
    /// Tune the parameters of this specification (e.g. config/imu-tuning.json5) by coordinate
    /// descent over all the trials, starting from the configuration's values; prints the values and
    /// the tuned table.
    #[arg(long)]
    tune: Option<PathBuf>,
    /// With --tune: also leave one out (tune on all trials but one, score that one, for each trial)
    /// and report every trial's held-out scores beside its in-sample ones.
    #[arg(long, requires = "tune")]
    loo: bool,
    /// With --tune: write the whole result (values, tables, folds) to this JSON file.
    #[arg(long, requires = "tune")]
    out: Option<PathBuf>,
}

#[derive(Args)]
struct LoadgenArgs {
    /// Vehicles.
    #[arg(long, default_value_t = 10)]
    vehicles: usize,
    /// Gyro and vector messages per vehicle per second (each).
    #[arg(long, default_value_t = 10.0)]
    rate: f64,
    /// Sending time, s.
    #[arg(long, default_value_t = 10.0)]
    duration: f64,
    /// Zenoh endpoint of the service (repeatable).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    connect: Vec<String>,
    /// Key prefix of the service.
    #[arg(long, default_value = "attitude")]
    prefix: String,
    /// Vehicle id prefix.
    #[arg(long, default_value = "load")]
    vehicle_prefix: String,
    /// Measure a bare zenoh round trip through an in-process echo (its own session on a loopback TCP
    /// link) instead of the service.
    #[arg(long)]
    echo: bool,
    /// Send raw IMU samples on P/V/imu instead, N per put (N × --rate samples per second per vehicle),
    /// each answered by an estimate.
    #[arg(long, conflicts_with = "echo")]
    imu: Option<usize>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct SoakArgs {
    /// Vehicles (ids soak1, soak2, ...).
    #[arg(long, default_value_t = 30)]
    vehicles: usize,
    /// Gyro and vector messages per vehicle per second (each).
    #[arg(long, default_value_t = 10.0)]
    rate: f64,
    /// Run length in minutes; fractions allowed (0.2 = 12 s). The run is cut into
    /// max(2, ceil(minutes)) equal windows: one per minute for whole minutes, never longer than
    /// 60 s, and always at least two so that the first and the last can be compared.
    #[arg(long, default_value_t = 10.0)]
    minutes: f64,
    /// The filter of every vehicle: mekf, usque[:average|:propagated], qpf[:average|:propagated]
    /// (the service's default 1000 particles).
    #[arg(long, default_value = "qpf")]
    filter: FilterSpec,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

fn imu_study_cmd(args: ImuStudyArgs) -> Result<()> {
    use attitude_service::tools::imu_study;
    let service = imu_study::load_config(&args.config, &args.sets)?;
    let setup = imu_study::Setup::new(&service, args.filter, args.particles);
    let trials = imu_study::trial_paths(&args.trials)?
        .iter()
        .map(|p| imu_study::read_trial(p))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(spec_path) = &args.tune {
        return imu_tune_cmd(&args, spec_path, &trials);
    }
    if let Some(dir) = &args.series {
        std::fs::create_dir_all(dir)?;
    }
    let results = imu_study::study(&trials, &setup, args.series.as_deref());
    if args.json {
        println!("{}", serde_json::to_string(&results)?);
    } else {
        print!("{}", imu_study::table(&results));
    }
    Ok(())
}

fn imu_tune_cmd(
    args: &ImuStudyArgs,
    spec_path: &std::path::Path,
    trials: &[attitude_service::tools::imu_study::Trial],
) -> Result<()> {
    use attitude_service::tools::imu_study::{objective, start_point, TuneSpec, Tuner};
    let mut spec: TuneSpec = json5::from_str(&std::fs::read_to_string(spec_path)?)
        .map_err(|e| anyhow::anyhow!("{}: {e}", spec_path.display()))?;
    if let Some(r) = &spec.reference {
        let path = spec_path
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join(r);
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path)?)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        for t in trials {
            let at = &v[&t.name];
            if let (Some(total), Some(incl)) = (
                at["total_rmse_deg"].as_f64(),
                at["inclination_rmse_deg"].as_f64(),
            ) {
                spec.reference_scores.insert(t.name.clone(), (total, incl));
            }
        }
    }
    let text = std::fs::read_to_string(&args.config)?;
    let mut tuner = Tuner::new(&args.config, &args.sets, &spec, trials, args.filter)?;
    let all: Vec<usize> = (0..trials.len()).collect();
    let start = start_point(&spec, &text);
    let values = |point: &[usize]| -> serde_json::Value {
        spec.parameters
            .iter()
            .zip(point)
            .map(|(p, &k)| (p.path.clone(), serde_json::json!(p.values[k])))
            .collect::<serde_json::Map<_, _>>()
            .into()
    };
    let start_scores = tuner.scores(&start)?;
    let tuned = tuner.descend(&start, &all)?;
    let tuned_scores = tuner.scores(&tuned)?;
    eprintln!(
        "tuned on all {} trials: objective {:.4} (start {:.4}), {} evaluations",
        trials.len(),
        objective(&spec, trials, &tuned_scores, &all),
        objective(&spec, trials, &start_scores, &all),
        tuner.evaluations
    );
    println!("{}", serde_json::to_string_pretty(&values(&tuned))?);
    let mut folds = Vec::new();
    if args.loo {
        for held in 0..trials.len() {
            let rest: Vec<usize> = all.iter().copied().filter(|&i| i != held).collect();
            let point = tuner.descend(&tuned, &rest)?;
            let s = tuner.scores(&point)?;
            eprintln!(
                "fold {held} ({}): held-out total {:.2}° incl {:.2}° (in-sample {:.2}° {:.2}°), {} evaluations so far",
                trials[held].name,
                s[held].total_rmse_deg,
                s[held].inclination_rmse_deg,
                tuned_scores[held].total_rmse_deg,
                tuned_scores[held].inclination_rmse_deg,
                tuner.evaluations
            );
            folds.push(serde_json::json!({
                "trial": trials[held].name,
                "values": values(&point),
                "held_out": s[held],
                "in_sample": tuned_scores[held],
            }));
        }
        println!("| trial | in-sample total ° | held-out total ° | in-sample incl. ° | held-out incl. ° | held-out tilt in 99% | held-out NEES med. |");
        println!("|---|---:|---:|---:|---:|---:|---:|");
        for f in &folds {
            let (i, h) = (&f["in_sample"], &f["held_out"]);
            println!(
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} | {:.2} |",
                f["trial"].as_str().unwrap_or(""),
                i["total_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                h["total_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                i["inclination_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                h["inclination_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                h["tilt_in99"].as_f64().unwrap_or(f64::NAN),
                h["tilt_nees_median"].as_f64().unwrap_or(f64::NAN),
            );
        }
    }
    if let Some(out) = &args.out {
        let names: Vec<&str> = trials.iter().map(|t| t.name.as_str()).collect();
        let doc = serde_json::json!({
            "spec": spec,
            "config": args.config,
            "sets": args.sets,
            "trials": names,
            "start": values(&start),
            "start_scores": start_scores,
            "tuned": values(&tuned),
            "tuned_scores": tuned_scores,
            "folds": folds,
            "evaluations": tuner.evaluations,
        });
        std::fs::write(out, serde_json::to_string_pretty(&doc)?)?;
    }
    Ok(())
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Montecarlo(args) => montecarlo(args),
        Command::Sweep(args) => sweep(args),
        Command::Serve(args) => runtime()?.block_on(serve(args)),
        Command::Simulate(args) => runtime()?.block_on(simulate_cmd(args)),
        Command::Demo(args) => runtime()?.block_on(demo_cmd(args)),
        Command::Bench(args) => bench_cmd(args),
        Command::ImuBench(args) => {
            let line = attitude_service::tools::imu_bench::main_entry(
                &args.trial,
                &args.config,
                &args.sets,
                args.filter,
                args.estimates_out.as_deref(),
            )?;
            println!("{line}");
            Ok(())
        }
        Command::ImuStudy(args) => imu_study_cmd(args),
        Command::Loadgen(args) => runtime()?.block_on(loadgen_cmd(args)),
        Command::Soak(args) => runtime()?.block_on(soak_cmd(args)),
        Command::Scenarios => {
            for name in ScenarioName::ALL {
                println!("{}\n", ScenarioParams::default_for(name).describe());
            }
            Ok(())
        }
    }
}

fn scenario_from_args(args: &ScenarioArgs) -> Result<ScenarioParams> {
    let Some(name) = args.scenario else {
        bail!("--scenario is required (star-tracker, magnetometer-leo or lost-in-space)");
    };
    let mut p = ScenarioParams::default_for(name);
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
        scenario: scenario_from_args(&args.scenario)?,
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

fn runtime() -> Result<tokio::runtime::Runtime> {
    // Zenoh needs the multi-thread runtime.
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")
}

/// Logs to stderr, quiet (warnings only) unless RUST_LOG says otherwise.
fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Resolves on SIGINT or SIGTERM.
async fn shutdown_signal() {
    let ctrl_c = tokio::signal::ctrl_c();
    #[cfg(unix)]
    {
        let mut term =
            match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
                Ok(t) => t,
                Err(_) => {
                    let _ = ctrl_c.await;
                    return;
                }
            };
        tokio::select! {
            _ = ctrl_c => {},
            _ = term.recv() => {},
        }
    }
    #[cfg(not(unix))]
    let _ = ctrl_c.await;
}

/// The built-in configuration: exactly config/default.json5.
const DEFAULT_CONFIG: &str = include_str!("../config/default.json5");

fn load_config(path: Option<&PathBuf>) -> Result<service_config::FileConfig> {
    Ok(match path {
        Some(p) => service_config::load(p)?,
        None => service_config::parse(DEFAULT_CONFIG, "built-in default configuration")?,
    })
}

fn zenoh_config(json: &str, listen: &[String], connect: &[String]) -> Result<zenoh::Config> {
    let mut c = zenoh::Config::from_json5(json)
        .map_err(|e| anyhow::anyhow!("invalid zenoh configuration: {e}"))?;
    if !listen.is_empty() {
        c.insert_json5("listen/endpoints", &serde_json::to_string(listen)?)
            .map_err(|e| anyhow::anyhow!("--listen: {e}"))?;
    }
    if !connect.is_empty() {
        c.insert_json5("connect/endpoints", &serde_json::to_string(connect)?)
            .map_err(|e| anyhow::anyhow!("--connect: {e}"))?;
    }
    Ok(c)
}

async fn serve(args: ServeArgs) -> Result<()> {
    init_logging();
    let mut file = load_config(args.config.as_ref())?;
    if let Some(dir) = args.state_dir {
        file.service.persistence.state_dir = Some(dir);
    }
    attitude_service::service::config::override_fleet(
        &mut file.service,
        args.fleet,
        args.group,
        args.instance,
        args.vehicles,
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let zc = zenoh_config(&file.zenoh_json, &args.listen, &args.connect)?;
    let session = zenoh::open(zc)
        .await
        .map_err(|e| anyhow::anyhow!("cannot open the zenoh session: {e}"))?;
    attitude_service::service::run(session, file.service, shutdown_signal()).await?;
    Ok(())
}

/// Defaults of a fleet command where the user gave none.
struct FleetDefaults {
    vehicles: usize,
    speed: f64,
}

fn fleet_options(fleet: &FleetArgs, d: FleetDefaults) -> Result<SimulateOptions> {
    let vehicles = fleet.vehicles.unwrap_or(d.vehicles);
    let speed = fleet.speed.unwrap_or(d.speed);
    if vehicles == 0 {
        bail!("--vehicles must be at least 1");
    }
    attitude_service::wire::validate_vehicle_id(&format!("{}{}", fleet.vehicle_prefix, vehicles))
        .map_err(|e| anyhow::anyhow!("--vehicle-prefix: {}", e.message))?;
    service_config::validate_key_prefix(&fleet.prefix)
        .map_err(|e| anyhow::anyhow!("--prefix: {e}"))?;
    if !(speed >= 0.0 && speed.is_finite()) {
        bail!("--speed must be 0 (as fast as possible) or positive");
    }
    Ok(SimulateOptions {
        scenario: scenario_from_args(&fleet.scenario)?,
        vehicles,
        vehicle_prefix: fleet.vehicle_prefix.clone(),
        filters: fleet.filters.clone(),
        particles: fleet.particles,
        speed,
        seed: fleet.seed,
        reset: !fleet.no_reset,
    })
}

async fn simulate_cmd(args: SimulateArgs) -> Result<()> {
    init_logging();
    let options = fleet_options(
        &args.fleet,
        FleetDefaults {
            vehicles: 3,
            speed: 1.0,
        },
    )?;
    let json = serde_json::json!({
        "mode": "peer",
        "connect": {"endpoints": args.connect},
        "listen": {"endpoints": []},
        "scouting": {"multicast": {"enabled": false}},
    });
    let session = zenoh::open(zenoh_config(&json.to_string(), &[], &[])?)
        .await
        .map_err(|e| anyhow::anyhow!("cannot open the zenoh session: {e}"))?;
    let keys = Keys::new(&args.fleet.prefix);
    let interrupted = Arc::new(AtomicBool::new(false));
    {
        let i = interrupted.clone();
        tokio::spawn(async move {
            shutdown_signal().await;
            i.store(true, Ordering::Relaxed);
        });
    }
    let stats = simulate(&session, &keys, &options, || {
        interrupted.load(Ordering::Relaxed)
    })
    .await?;
    let _ = session.close().await;
    println!(
        "published {} vehicles: {:.0} s simulated in {:.1} s ({} gyro, {} vector, {} truth messages)",
        stats.vehicles, stats.sim_time_s, stats.wall_s, stats.gyro_messages, stats.vector_messages, stats.truth_messages
    );
    Ok(())
}

async fn demo_cmd(mut args: DemoArgs) -> Result<()> {
    init_logging();
    let f = &mut args.fleet;
    if f.scenario.scenario.is_none() {
        f.scenario.scenario = Some(ScenarioName::MagnetometerLeo);
        f.scenario.duration = f.scenario.duration.or(Some(14_400.0));
    }
    if f.filters.is_empty() {
        f.filters = ["qpf:average", "qpf:propagated", "usque:average", "mekf"]
            .iter()
            .filter_map(|s| s.parse().ok())
            .collect();
    }
    let options = fleet_options(
        &args.fleet,
        FleetDefaults {
            vehicles: 4,
            speed: 480.0,
        },
    )?;
    let mut file = load_config(args.config.as_ref())?;
    file.service.key_prefix = args.fleet.prefix.clone();
    let interrupted = Arc::new(AtomicBool::new(false));
    {
        let i = interrupted.clone();
        tokio::spawn(async move {
            shutdown_signal().await;
            i.store(true, Ordering::Relaxed);
        });
    }
    let interactive = std::io::stdout().is_terminal();
    let (rows, stats) = demo(
        &file.zenoh_json,
        &args.listen,
        file.service,
        options,
        interactive,
        interrupted,
    )
    .await?;
    if interactive {
        print!("\x1b[2J\x1b[H");
    }
    println!("{}", render(&rows, Some(&stats)));
    Ok(())
}

fn bench_cmd(args: BenchArgs) -> Result<()> {
    if args.particles < 2 || !(args.seconds > 0.0) {
        bail!("--particles must be at least 2 and --seconds positive");
    }
    let report = attitude_service::tools::bench::run(
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

fn peer_config(listen: &[String], connect: &[String]) -> Result<zenoh::Config> {
    let json = serde_json::json!({
        "mode": "peer",
        "listen": {"endpoints": listen},
        "connect": {"endpoints": connect},
        "scouting": {"multicast": {"enabled": false}},
    });
    zenoh_config(&json.to_string(), &[], &[])
}

async fn loadgen_cmd(args: LoadgenArgs) -> Result<()> {
    init_logging();
    if args.vehicles == 0 || !(args.rate > 0.0) || !(args.duration > 0.0) {
        bail!("--vehicles, --rate and --duration must be positive");
    }
    service_config::validate_key_prefix(&args.prefix)
        .map_err(|e| anyhow::anyhow!("--prefix: {e}"))?;
    let options = attitude_service::tools::loadgen::LoadOptions {
        vehicles: args.vehicles,
        rate_hz: args.rate,
        duration_s: args.duration,
        vehicle_prefix: args.vehicle_prefix.clone(),
        drain_s: 5.0,
        imu_batch: args.imu.unwrap_or(0),
    };
    let keys = Keys::new(&args.prefix);
    let (report, _echo_session) = if args.echo {
        let port = std::net::TcpListener::bind("127.0.0.1:0")?
            .local_addr()?
            .port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let echo_session = zenoh::open(peer_config(&[endpoint.clone()], &[])?)
            .await
            .map_err(|e| anyhow::anyhow!("echo session: {e}"))?;
        let _echo = attitude_service::tools::loadgen::echo(&echo_session, &keys)
            .await
            .map_err(|e| anyhow::anyhow!("echo: {e}"))?;
        let client = zenoh::open(peer_config(&[], &[endpoint])?)
            .await
            .map_err(|e| anyhow::anyhow!("client session: {e}"))?;
        let r = attitude_service::tools::loadgen::run(&client, &keys, &options, "echo")
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let _ = client.close().await;
        (r, Some(echo_session))
    } else {
        let client = zenoh::open(peer_config(&[], &args.connect)?)
            .await
            .map_err(|e| anyhow::anyhow!("cannot open the zenoh session: {e}"))?;
        let r = attitude_service::tools::loadgen::run(&client, &keys, &options, "service")
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let _ = client.close().await;
        (r, None)
    };
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print!("{}", report.table());
    }
    Ok(())
}

async fn soak_cmd(args: SoakArgs) -> Result<()> {
    init_logging();
    let options = attitude_service::tools::soak::SoakOptions {
        vehicles: args.vehicles,
        rate_hz: args.rate,
        minutes: args.minutes,
        filter: args.filter,
        exe: std::env::current_exe().context("locating this binary")?,
    };
    let interrupted = Arc::new(AtomicBool::new(false));
    {
        let i = interrupted.clone();
        tokio::spawn(async move {
            shutdown_signal().await;
            i.store(true, Ordering::Relaxed);
        });
    }
    let report =
        attitude_service::tools::soak::run(&options, || interrupted.load(Ordering::Relaxed))
            .await
            .map_err(|e| anyhow::anyhow!("soak: {e}"))?;
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print!("{}", report.table());
    }
    Ok(())
}
