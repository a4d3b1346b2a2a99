//! What several modules of the lab's tests need: the repository, scratch folders, both binaries, free
//! ports and zenoh sessions, the service in process, and the NEES bound with its power check (the
//! same helpers as the service's `tests/it/common`, for the few the lab's tests use).

use attitude_service::service::config::{parse, ServiceConfig};
use attitude_service::service::ServiceError;
use attitude_service::wire::HealthMsg;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

#[path = "../../../../tests/it/common/ports.rs"]
mod ports;
pub use ports::free_port;

/// The root of the repository (two folders above this crate's manifest).
#[allow(dead_code)]
pub fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// A fresh path in the temporary folder for a test's files, unique in this run: nothing is there (a
/// leftover of an earlier run is removed); the caller creates it, or has the binary create it.
pub fn scratch_dir(name: &str) -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "attitude-lab-it-{}-{name}-{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The `attitude-lab` binary that Cargo built for these tests.
pub fn lab_bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_attitude-lab"))
}

/// The `attitude-service` binary beside it (Cargo builds both into one folder; a workspace build,
/// `cargo build --release` or `cargo test --workspace`, builds it: this crate can name only its own
/// binaries).
pub fn service_bin_path() -> PathBuf {
    let lab = Path::new(env!("CARGO_BIN_EXE_attitude-lab"));
    let service = lab
        .with_file_name("attitude-service")
        .with_extension(std::env::consts::EXE_EXTENSION);
    assert!(
        service.is_file(),
        "{} is missing: build the workspace (cargo build --release) first",
        service.display()
    );
    service
}

/// A peer that listens on and connects to the given endpoints only (no multicast scouting).
pub async fn open_zenoh(listen: &[String], connect: &[String]) -> zenoh::Session {
    let json = serde_json::json!({
        "mode": "peer",
        "listen": {"endpoints": listen},
        "connect": {"endpoints": connect},
        "scouting": {"multicast": {"enabled": false}},
    });
    zenoh::open(zenoh::Config::from_json5(&json.to_string()).unwrap())
        .await
        .unwrap()
}

/// Waits until a service answers `P/@/health` (prefix `attitude`) to `client` with a health message;
/// fails the test after `within`.
pub async fn wait_healthy(client: &zenoh::Session, within: Duration) {
    let key = attitude_service::wire::keys::Keys::new("attitude").health();
    let start = Instant::now();
    loop {
        let replies = client
            .get(&key)
            .timeout(Duration::from_secs(2))
            .await
            .unwrap();
        let healthy = match replies.recv_async().await {
            Ok(reply) => reply.result().is_ok_and(|s| {
                serde_json::from_slice::<HealthMsg>(&s.payload().to_bytes()).is_ok()
            }),
            Err(_) => false,
        };
        if healthy {
            return;
        }
        assert!(
            start.elapsed() < within,
            "the service to answer on {key}: not within {within:?}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// The `service` section of a configuration file's text, as the service reads it.
pub fn service_config(text: &str) -> ServiceConfig {
    parse(text, "test")
        .unwrap_or_else(|e| panic!("{text}: {e}"))
        .service
}

/// The service in this process on a loopback port, and a client session connected to it.
pub struct Service {
    pub client: zenoh::Session,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: Option<tokio::task::JoinHandle<Result<(), ServiceError>>>,
}

impl Service {
    /// Starts the service and waits (with a deadline) until it answers on `attitude/@/health`.
    pub async fn start(config: ServiceConfig) -> Service {
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let s = open_zenoh(&[endpoint.clone()], &[]).await;
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let task = tokio::spawn(attitude_service::service::run(s, config, async {
            let _ = rx.await;
        }));
        let client = open_zenoh(&[], &[endpoint]).await;
        wait_healthy(&client, Duration::from_secs(10)).await;
        Service {
            client,
            stop: Some(tx),
            task: Some(task),
        }
    }

    /// Stops the service (it must stop within 10 s, without an error) and closes the client.
    pub async fn stop(mut self) {
        let _ = self.stop.take().unwrap().send(());
        let r = tokio::time::timeout(Duration::from_secs(10), self.task.take().unwrap())
            .await
            .expect("the service stops within 10 s");
        r.unwrap().unwrap();
        self.client.close().await.unwrap();
    }
}

/// `χ²₁₂₀` quantiles 0.0005 and 0.9995 (scipy.stats.chi2.ppf): the sum of 40 independent 3-dof NEES
/// samples, or of 20 6-dof ones, of a consistent filter lies between them with probability 0.999.
pub const CHI2_120: (f64, f64) = (75.467, 177.603);

/// `nees` (a mean NEES, as `what` says) inside `[lo, hi]`, and the bound has power: the same runs with
/// the covariance 1.5× too small or too large in σ (every NEES × 2.25 or ÷ 2.25) fall outside it.
pub fn assert_nees_with_power(what: &str, nees: f64, (lo, hi): (f64, f64)) {
    assert!(
        (lo..=hi).contains(&nees),
        "{what} {nees} outside [{lo}, {hi}]"
    );
    for scale in [2.25, 1.0 / 2.25] {
        assert!(
            !(lo..=hi).contains(&(nees * scale)),
            "{what}: with a covariance scaled by 1/{scale} ({}) it would pass [{lo}, {hi}]",
            nees * scale
        );
    }
}
