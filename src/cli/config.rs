//! The configuration of the commands that talk zenoh: the service's file (or the built-in default)
//! and the zenoh session configurations, with the endpoints given on the command line.

use crate::service::config as service_config;
use anyhow::Result;
use std::path::PathBuf;

/// The built-in configuration: exactly config/default.json5.
pub const DEFAULT_CONFIG: &str = include_str!("../../config/default.json5");

/// The configuration file of `--config`, or the built-in default.
pub fn load_config(path: Option<&PathBuf>) -> Result<service_config::FileConfig> {
    Ok(match path {
        Some(p) => service_config::load(p)?,
        None => service_config::parse(DEFAULT_CONFIG, "built-in default configuration")?,
    })
}

/// A zenoh configuration from its JSON5 text; non-empty `listen` and `connect` replace its endpoints.
pub fn zenoh_config(json: &str, listen: &[String], connect: &[String]) -> Result<zenoh::Config> {
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

/// A peer without multicast scouting that listens and connects on these endpoints only.
pub fn peer_config(listen: &[String], connect: &[String]) -> Result<zenoh::Config> {
    let json = serde_json::json!({
        "mode": "peer",
        "listen": {"endpoints": listen},
        "connect": {"endpoints": connect},
        "scouting": {"multicast": {"enabled": false}},
    });
    zenoh_config(&json.to_string(), &[], &[])
}
