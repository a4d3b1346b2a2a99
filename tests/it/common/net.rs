//! Loopback networking: free ports and zenoh sessions.

use std::collections::BTreeSet;
use std::net::TcpListener;
use std::sync::Mutex;

/// A TCP port on 127.0.0.1 that was free a moment ago, and that no other test of this binary has been
/// given (the tests run in parallel in one process: two of them must not both listen on one port).
pub fn free_port() -> u16 {
    static GIVEN: Mutex<BTreeSet<u16>> = Mutex::new(BTreeSet::new());
    loop {
        let port = TcpListener::bind("127.0.0.1:0")
            .expect("a free port on 127.0.0.1")
            .local_addr()
            .unwrap()
            .port();
        if GIVEN.lock().unwrap().insert(port) {
            return port;
        }
    }
}

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
