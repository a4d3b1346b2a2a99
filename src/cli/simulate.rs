//! `simulate` and `demo`: a simulated fleet publishing a scenario to a service, running elsewhere
//! (`simulate`) or in this process (`demo`, with its live table).

use super::config::{load_config, peer_config};
use super::runtime::init_logging;
use super::scenario::{scenario_from_args, ScenarioArgs};
use crate::filters::FilterSpec;
use crate::service::config as service_config;
use crate::sim::ScenarioName;
use crate::tools::demo::{demo as run_demo, render};
use crate::tools::publish::Publishing;
use crate::tools::simulate::{simulate as run_simulate, SimulateOptions};
use crate::wire::keys::Keys;
use anyhow::{bail, Result};
use clap::Args;
use std::io::IsTerminal;
use std::path::PathBuf;
use tokio_util::sync::CancellationToken;

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
    /// Sparse-grid level (2..=4) of the SGHQF vehicles (default: the service's).
    #[arg(long, value_parser = clap::value_parser!(u8).range(2..=4))]
    level: Option<u8>,
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
    /// Send the inputs on their routed keys P/V/<leaf>/<r>, and batched for the routes' standby
    /// members (what a dynamic fleet needs to scale; a single instance takes them too).
    #[arg(long)]
    routed: bool,
    /// Plain puts instead of advanced publishers (which keep their last puts for the service to fetch
    /// again when one is lost: proto/README.md, "Loss, recovery and back-pressure").
    #[arg(long)]
    plain: bool,
    /// Puts each input key's advanced publisher keeps for the service to fetch again.
    #[arg(long, default_value_t = crate::tools::publish::CACHE)]
    cache: usize,
}

#[derive(Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    fleet: FleetArgs,
    /// Zenoh endpoint of the service (repeatable).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    connect: Vec<String>,
}

#[derive(Args)]
pub struct DemoArgs {
    #[command(flatten)]
    fleet: FleetArgs,
    /// Where the in-process service listens and the simulator connects (a concrete port).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    listen: String,
    /// Service configuration (JSON5), as for `serve`.
    #[arg(long)]
    config: Option<PathBuf>,
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
    crate::wire::validate_vehicle_id(&format!("{}{}", fleet.vehicle_prefix, vehicles))
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
        level: fleet.level,
        speed,
        seed: fleet.seed,
        reset: !fleet.no_reset,
        routed: fleet.routed,
        publishing: publishing(fleet.plain, fleet.cache)?,
    })
}

/// How a fleet command's (or the lab's `loadgen`'s) inputs are put: `--plain`, `--cache`.
pub fn publishing(plain: bool, cache: usize) -> Result<Publishing> {
    if cache == 0 {
        bail!("--cache must be at least 1");
    }
    Ok(if plain {
        Publishing::plain()
    } else {
        Publishing {
            cache,
            ..Publishing::default()
        }
    })
}

/// `simulate`: publishes the scenario to the service at `--connect` until the run ends or `shutdown`
/// is cancelled, then prints what was published.
pub async fn simulate(args: SimulateArgs, shutdown: CancellationToken) -> Result<()> {
    init_logging();
    let options = fleet_options(
        &args.fleet,
        FleetDefaults {
            vehicles: 3,
            speed: 1.0,
        },
    )?;
    let session = zenoh::open(peer_config(&[], &args.connect)?)
        .await
        .map_err(|e| anyhow::anyhow!("cannot open the zenoh session: {e}"))?;
    let keys = Keys::new(&args.fleet.prefix);
    let stats = run_simulate(&session, &keys, &options, &shutdown).await?;
    let _ = session.close().await;
    println!(
        "published {} vehicles: {:.0} s simulated in {:.1} s ({} gyro, {} vector, {} truth messages)",
        stats.vehicles, stats.sim_time_s, stats.wall_s, stats.gyro_messages, stats.vector_messages, stats.truth_messages
    );
    Ok(())
}

/// `demo`: the service and the simulated fleet in this process, the live table, and the final one.
pub async fn demo(mut args: DemoArgs, shutdown: CancellationToken) -> Result<()> {
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
    let interactive = std::io::stdout().is_terminal();
    let (rows, stats) = run_demo(
        &file.zenoh_json,
        &args.listen,
        file.service,
        options,
        interactive,
        shutdown,
    )
    .await?;
    if interactive {
        print!("\x1b[2J\x1b[H");
    }
    println!("{}", render(&rows, Some(&stats)));
    Ok(())
}
