//! `serve`: the network service ([`crate::service::run`]) with the configuration file and the
//! command line's overrides, until the shutdown token is cancelled.

use super::config::{load_config, zenoh_config};
use super::runtime::init_logging;
use crate::service::ServiceError;
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use tokio_util::sync::CancellationToken;

#[derive(Args)]
pub struct ServeArgs {
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
    /// Serve only the vehicles of these routes (`service.fleet.routes`; default `all`): hex digits and
    /// ranges, e.g. `0-7` or `0-3,c-f` (proto/README.md, Routed inputs). Static sharding that is even
    /// whatever the vehicle ids; with --fleet the group shares these routes.
    #[arg(long, value_name = "ROUTES")]
    routes: Option<String>,
    /// Serve HTTP with zenoh's REST plugin, run inside the service, on PORT (every interface) or
    /// IP:PORT, e.g. `127.0.0.1:8000`: `GET /attitude/sc1/attitude`, `GET /attitude/@/metrics?_raw=true`
    /// (Prometheus). Sets the zenoh configuration's `plugins/rest/http_port`. Default: no HTTP.
    #[arg(long, value_name = "PORT")]
    rest_http_port: Option<String>,
}

/// `serve`: runs the service until `shutdown` is cancelled, then lets it wind down.
pub async fn serve(args: ServeArgs, shutdown: CancellationToken) -> Result<()> {
    init_logging();
    let mut file = load_config(args.config.as_ref())?;
    if let Some(dir) = args.state_dir {
        file.service.persistence.state_dir = Some(dir);
    }
    crate::service::config::override_fleet(
        &mut file.service,
        args.fleet,
        args.group,
        args.instance,
        args.vehicles,
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    if let Some(routes) = &args.routes {
        crate::service::config::override_routes(&mut file.service, routes)
            .map_err(|e| anyhow::anyhow!("--routes: {e}"))?;
    }
    let mut zc = zenoh_config(&file.zenoh_json, &args.listen, &args.connect)?;
    if let Some(port) = args.rest_http_port {
        zc.insert_json5("plugins/rest/http_port", &serde_json::to_string(&port)?)
            .map_err(|e| anyhow::anyhow!("--rest-http-port: {e}"))?;
    }
    // The ROS 2 edge on DDS: zenoh-plugin-ros2dds in the service's runtime (ros2::dds).
    if let (true, Some(dds)) = (file.service.ros2.enabled, &file.service.ros2.dds) {
        let key = format!("plugins/{}", crate::ros2::dds::PLUGIN);
        zc.insert_json5(&key, &dds.to_string())
            .map_err(|e| anyhow::anyhow!("service.ros2.dds: {e}"))?;
        // The plugin's routes for transient-local topics (/rosout, /tf_static) need timestamps, as
        // zenoh-bridge-ros2dds turns them on.
        zc.insert_json5("timestamping/enabled", "true")
            .map_err(|e| anyhow::anyhow!("timestamping: {e}"))?;
    }
    let opened = crate::service::session::open(zc)
        .await
        .map_err(|e| match e {
            ServiceError::Http(_) => anyhow::anyhow!("{e}"),
            ServiceError::Zenoh(m) if m.contains("DDS") => anyhow::anyhow!("{m}"),
            _ => anyhow::anyhow!("cannot open the zenoh session: {e}"),
        })?;
    crate::service::run(
        opened.session.clone(),
        file.service,
        shutdown.cancelled_owned(),
    )
    .await?;
    opened.close().await?;
    Ok(())
}
