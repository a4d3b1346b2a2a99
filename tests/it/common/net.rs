//! Loopback networking: zenoh sessions (free ports: ports.rs).

/// A peer that listens on and connects to the given endpoints only (no multicast scouting).
fn zenoh_config(listen: &[String], connect: &[String]) -> zenoh::Config {
    let json = serde_json::json!({
        "mode": "peer",
        "listen": {"endpoints": listen},
        "connect": {"endpoints": connect},
        "scouting": {"multicast": {"enabled": false}},
    });
    zenoh::Config::from_json5(&json.to_string()).unwrap()
}

/// A zenoh session of [`zenoh_config`].
pub async fn open_zenoh(listen: &[String], connect: &[String]) -> zenoh::Session {
    zenoh::open(zenoh_config(listen, connect)).await.unwrap()
}
