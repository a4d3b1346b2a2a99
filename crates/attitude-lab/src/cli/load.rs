//! `loadgen` (load against a running service, or a bare zenoh echo) and `soak` (a long run of the
//! service binary's `serve` under a steady load).

use crate::tools::{loadgen, soak};
use anyhow::{bail, Context, Result};
use attitude_core::filters::FilterSpec;
use attitude_service::cli::config::peer_config;
use attitude_service::cli::runtime::init_logging;
use attitude_service::service::config as service_config;
use attitude_service::wire::keys::Keys;
use clap::Args;
use std::path::PathBuf;
use tokio_util::sync::CancellationToken;

#[derive(Args)]
pub struct LoadgenArgs {
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
    /// each answered by an estimate (by the echo: each put comes back as one message).
    #[arg(long)]
    imu: Option<usize>,
    /// With --imu, against a service that caps its IMU estimates (service.imu.max_estimate_rate_hz):
    /// an estimate answers every sample of its vehicle up to its t, and one more sample per vehicle,
    /// 1 s after the run and not counted, has the last ones answered.
    #[arg(long, requires = "imu")]
    capped: bool,
    /// Send every input on its routed key `P/V/<leaf>/<r>`, and batched for the routes' standby members
    /// on `P/@/standby/<r>/inputs` (a dynamic fleet's inputs then reach a route's owner and standby
    /// members only; a single instance takes them too). Default: the plain keys `P/V/<leaf>`.
    #[arg(long)]
    routed: bool,
    /// Send each vehicle's messages at its own phase of the period (vehicle i at i/n of it), as
    /// independent vehicles do, instead of all of them at the start of each period (the default: a
    /// burst every period).
    #[arg(long)]
    spread: bool,
    /// Put through advanced publishers (one per key, with a cache, sequence numbers and heartbeats:
    /// proto/README.md, "Loss, recovery and back-pressure") instead of plain puts. Each costs the
    /// receiving service CPU for every put it makes (BENCHMARKS.md): the load figures use plain puts.
    #[arg(long)]
    advanced: bool,
    /// Puts each input key's advanced publisher keeps for the service to fetch again (--advanced).
    #[arg(long, default_value_t = attitude_service::tools::publish::CACHE)]
    cache: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
pub struct SoakArgs {
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
    /// The `attitude-service` binary that runs `serve` (default: $ATTITUDE_SERVICE_BIN, else the one
    /// beside this binary, as Cargo builds both into one folder).
    #[arg(long)]
    service_bin: Option<PathBuf>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

/// The service binary `soak` starts: the one given, else `$ATTITUDE_SERVICE_BIN`, else
/// `attitude-service` in this binary's folder.
fn service_binary(given: Option<PathBuf>) -> Result<PathBuf> {
    if let Some(path) =
        given.or_else(|| std::env::var_os("ATTITUDE_SERVICE_BIN").map(PathBuf::from))
    {
        return Ok(path);
    }
    let here = std::env::current_exe().context("locating this binary")?;
    let beside = here
        .with_file_name("attitude-service")
        .with_extension(std::env::consts::EXE_EXTENSION);
    if !beside.is_file() {
        bail!(
            "no service binary beside {} (build it: cargo build --release), or give --service-bin",
            here.display()
        );
    }
    Ok(beside)
}

/// `loadgen`: the load, then its report (a table, or one JSON object with `--json`).
pub async fn loadgen(args: LoadgenArgs) -> Result<()> {
    init_logging();
    if args.vehicles == 0 || !(args.rate > 0.0) || !(args.duration > 0.0) {
        bail!("--vehicles, --rate and --duration must be positive");
    }
    service_config::validate_key_prefix(&args.prefix)
        .map_err(|e| anyhow::anyhow!("--prefix: {e}"))?;
    let options = loadgen::LoadOptions {
        vehicles: args.vehicles,
        rate_hz: args.rate,
        duration_s: args.duration,
        vehicle_prefix: args.vehicle_prefix.clone(),
        drain_s: 5.0,
        imu_batch: args.imu.unwrap_or(0),
        covering: args.capped,
        routed: args.routed,
        spread: args.spread,
        publishing: attitude_service::cli::simulate::publishing(!args.advanced, args.cache)?,
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
        let _echo = loadgen::echo(&echo_session, &keys)
            .await
            .map_err(|e| anyhow::anyhow!("echo: {e}"))?;
        let client = zenoh::open(peer_config(&[], &[endpoint])?)
            .await
            .map_err(|e| anyhow::anyhow!("client session: {e}"))?;
        let r = loadgen::run(&client, &keys, &options, "echo")
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let _ = client.close().await;
        (r, Some(echo_session))
    } else {
        let client = zenoh::open(peer_config(&[], &args.connect)?)
            .await
            .map_err(|e| anyhow::anyhow!("cannot open the zenoh session: {e}"))?;
        let r = loadgen::run(&client, &keys, &options, "service")
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

/// `soak`: the run (cut short when `shutdown` is cancelled), then its report.
pub async fn soak(args: SoakArgs, shutdown: CancellationToken) -> Result<()> {
    init_logging();
    let options = soak::SoakOptions {
        vehicles: args.vehicles,
        rate_hz: args.rate,
        minutes: args.minutes,
        filter: args.filter,
        exe: service_binary(args.service_bin)?,
    };
    let report = soak::run(&options, &shutdown)
        .await
        .map_err(|e| anyhow::anyhow!("soak: {e}"))?;
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print!("{}", report.table());
    }
    Ok(())
}
