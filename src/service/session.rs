//! The service's zenoh session: `zenoh::open` as usual, or, when the zenoh configuration has a
//! `plugins/rest` section (`serve --rest-http-port`), a zenoh runtime of the service's own with
//! zenoh's REST plugin linked in, and the session on that runtime, as zenoh-bridge-ros2dds does. The
//! plugin then serves HTTP from inside the service: a GET is a zenoh get, answered by whatever the
//! zenoh network answers (this service and any other), so nothing else needs building or running
//! (zenohd can only load the plugin as a dynamic library, which `cargo install zenohd` does not build).
//! The same runtime carries zenoh-plugin-ros2dds when the ROS 2 edge is on DDS (`ros2::dds`, the
//! cargo feature `dds`).

use super::{zerr, ServiceError};
use zenoh::internal::plugins::PluginsManager;
use zenoh::internal::runtime::{Runtime, RuntimeBuilder};

/// The key of the REST plugin's section in a zenoh configuration (zenohd's name for it).
const REST: &str = "rest";
/// zenoh-plugin-ros2dds' section (`ros2::dds`).
const DDS: &str = crate::ros2::dds::PLUGIN;

/// A session, and the runtime of its own that carries the REST plugin when there is one.
pub struct ServiceSession {
    pub session: zenoh::Session,
    runtime: Option<Runtime>,
    http: Option<std::net::SocketAddr>,
}

impl ServiceSession {
    /// Where the REST plugin listens for HTTP, when it runs.
    pub fn http_addr(&self) -> Option<std::net::SocketAddr> {
        self.http
    }

    /// Closes the runtime of its own, after the session was closed (`service::run` closes it): a
    /// session made on a runtime (`zenoh::session::init`) leaves the runtime open.
    pub async fn close(self) -> Result<(), ServiceError> {
        if let Some(runtime) = self.runtime {
            runtime.close().await.map_err(zerr)?;
        }
        Ok(())
    }
}

/// Opens the service's session from `config`; with a `plugins/rest` section (its `http_port`: a port,
/// or `IP:PORT`) the REST plugin serves HTTP there; with a `plugins/ros2dds` section (written by the
/// service from `service.ros2`, `format: "dds"`; `ros2::dds`) zenoh-plugin-ros2dds joins the DDS
/// domain. A port that cannot be listened on, or a plugin this build lacks or that does not start, is
/// an error.
pub async fn open(config: zenoh::Config) -> Result<ServiceSession, ServiceError> {
    let rest = config.plugin(REST).cloned();
    let dds_config = config.plugin(DDS).cloned();
    let dds = dds_config.is_some();
    if rest.is_none() && !dds {
        return Ok(ServiceSession {
            session: zenoh::open(config).await.map_err(zerr)?,
            runtime: None,
            http: None,
        });
    }
    let rest: Option<zenoh_plugin_rest::Config> = rest
        .map(serde_json::from_value)
        .transpose()
        .map_err(|e| ServiceError::Http(format!("plugins/{REST} (--rest-http-port): {e}")))?;
    if let Some(rest) = &rest {
        // The plugin reports a port it cannot listen on only in a log line (it starts its server in
        // the background): try it first, for a clear error at start.
        std::net::TcpListener::bind(rest.addr)
            .map_err(|e| ServiceError::Http(format!("cannot listen on {}: {e}", rest.addr)))?;
    }
    let subscribers = config.aggregation().subscribers().clone();
    let publishers = config.aggregation().publishers().clone();
    let mut plugins = PluginsManager::static_plugins_only();
    // Not `required`: a required plugin that fails to start panics inside zenoh; checked below.
    if rest.is_some() {
        plugins.declare_static_plugin::<zenoh_plugin_rest::RestPlugin, &str>(REST, false);
    }
    if let Some(c) = &dds_config {
        declare_dds(&mut plugins, c)?;
    }
    let mut runtime = RuntimeBuilder::new(config)
        .plugins_manager(plugins)
        .build()
        .await
        .map_err(zerr)?;
    if let Some(rest) = &rest {
        if runtime.plugins_manager().started_plugin(REST).is_none() {
            let _ = runtime.close().await;
            return Err(ServiceError::Http(format!(
                "the plugin did not start on {} (see the log)",
                rest.addr
            )));
        }
    }
    if dds && runtime.plugins_manager().started_plugin(DDS).is_none() {
        let _ = runtime.close().await;
        return Err(ServiceError::Zenoh(
            "the DDS plugin (service.ros2, format \"dds\") did not start (see the log)".into(),
        ));
    }
    // As `zenoh::open` does: the session first, then the runtime's links.
    let session = zenoh::session::init(runtime.clone().into())
        .aggregated_subscribers(subscribers)
        .aggregated_publishers(publishers)
        .await
        .map_err(zerr)?;
    runtime.start().await.map_err(zerr)?;
    if let Some(rest) = &rest {
        tracing::info!(http = %rest.addr, "zenoh's REST plugin serves HTTP");
    }
    if dds {
        tracing::info!("zenoh-plugin-ros2dds runs: the ROS 2 edge is on DDS");
    }
    Ok(ServiceSession {
        session,
        runtime: Some(runtime),
        http: rest.map(|r| r.addr),
    })
}

#[cfg(feature = "dds")]
fn declare_dds(
    plugins: &mut PluginsManager,
    plugin: &serde_json::Value,
) -> Result<(), ServiceError> {
    let env = |k: &str| std::env::var(k).ok();
    if let Some(uri) = crate::ros2::dds::cyclonedds_uri(plugin, &env) {
        // Read by CycloneDDS when the plugin creates its participant, as the plugin's own settings are.
        std::env::set_var("CYCLONEDDS_URI", uri);
    }
    plugins.declare_static_plugin::<zenoh_plugin_ros2dds::ROS2Plugin, &str>(DDS, false);
    Ok(())
}

#[cfg(not(feature = "dds"))]
fn declare_dds(
    _plugins: &mut PluginsManager,
    _plugin: &serde_json::Value,
) -> Result<(), ServiceError> {
    Err(ServiceError::Zenoh(
        "service.ros2.format \"dds\" needs a build with the DDS plugin: cargo build --release \
         --features dds (docs/ros2.md)"
            .into(),
    ))
}
