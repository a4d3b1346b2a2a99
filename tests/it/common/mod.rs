//! What several test modules need, written once: where the repository is, scratch folders, the service
//! binary, bounded waits, free ports and zenoh sessions, an in-process engine that collects what it
//! publishes, fixtures shared by several modules, and the NEES bound with its power check.

mod engine;
mod fixtures;
mod net;
mod ports;
mod wait;

pub use engine::{collecting_engine, service_config, Outputs};
pub use fixtures::{
    assert_nees_with_power, default_policy, estimates, imu_preset, unit_quaternion, CHI2_120,
};
pub use net::open_zenoh;
pub use ports::free_port;
pub use wait::{wait_until, wait_until_async};

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The root of the repository (the service crate's manifest folder).
pub fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `proto/`: the wire contract.
pub fn proto_dir() -> PathBuf {
    repo().join("proto")
}

/// A fresh path in the temporary folder for a test's files, unique in this run (the tests of this
/// binary share one process id): nothing is there (a leftover of an earlier run is removed); the caller
/// creates it, or has the binary create it.
pub fn scratch_dir(name: &str) -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "attitude-service-it-{}-{name}-{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The `attitude-service` binary that Cargo built for these tests.
pub fn service_bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_attitude-service"))
}
