//! `attitude-lab soak`: a long run of the real service under a steady load, watching for drift.
//!
//! Starts `serve` as a child process (the `attitude-service` binary, a temporary configuration that gives every vehicle
//! the chosen filter, a free loopback port), connects a zenoh client, and streams the load generator's
//! messages (a gyro sample and a vector set of three stars per vehicle every 1/rate s, real time) for
//! the whole run. The run is cut into equal windows; at the end of each it records the child's
//! resident memory (`VmRSS` of `/proc/<pid>/status`), the put→estimate latency percentiles of the
//! estimates that arrived in the window, the vector messages sent and the estimates and rejections
//! received. At the end it compares the first window with the last (memory and p99), stops the child
//! with SIGTERM and reports how it exited. Not run in CI.

use crate::tools::loadgen::{count_rejections, drain, latency_us, probe, time_key, Pending};
use attitude_core::filters::FilterSpec;
use attitude_service::tools::synthetic::star_set;
use attitude_service::wire::keys::{Keys, Leaf};
use attitude_service::wire::GyroMsg;
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use thiserror::Error;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;

/// The key prefix the soak's service uses (its own process, so the default).
const PREFIX: &str = "attitude";
/// Vehicle ids `soak1`, `soak2`, …; `soak0` is the probe.
const VEHICLE_PREFIX: &str = "soak";
/// How long the child may take to listen, and to exit after SIGTERM.
const START_TIMEOUT: Duration = Duration::from_secs(20);
const STOP_TIMEOUT: Duration = Duration::from_secs(10);
/// How long to wait for the last estimates after sending stops.
const DRAIN: Duration = Duration::from_secs(5);

#[derive(Clone, Debug)]
pub struct SoakOptions {
    pub vehicles: usize,
    /// Gyro and vector messages per vehicle per second (each).
    pub rate_hz: f64,
    /// Run length, minutes (fractions allowed).
    pub minutes: f64,
    /// The filter of every vehicle.
    pub filter: FilterSpec,
    /// The binary that runs `serve` (`attitude-service`, by default the one beside `attitude-lab`).
    pub exe: PathBuf,
}

#[derive(Debug, Error)]
pub enum SoakError {
    #[error("invalid options: {0}")]
    Options(String),
    #[error("{0}")]
    Io(String),
    #[error("the service: {0}")]
    Service(String),
    #[error("zenoh: {0}")]
    Zenoh(String),
}

/// The number of windows and their length: at least two (so that a first and a last window exist),
/// none longer than 60 s; whole minutes give one window per minute.
pub fn windows_for(total_s: f64) -> (usize, f64) {
    let n = ((total_s / 60.0).ceil() as usize).max(2);
    (n, total_s / n as f64)
}

/// One window of the run.
#[derive(Clone, Debug, Serialize)]
pub struct WindowReport {
    /// 1 for the first window.
    pub window: usize,
    /// End of the window, s since sending started.
    pub end_s: f64,
    /// The child's resident memory at the end of the window, kB (`None` without /proc).
    pub rss_kb: Option<u64>,
    /// Vector messages sent in the window (each should produce one estimate); as many gyro messages.
    pub sent: u64,
    /// Estimates that arrived in the window for messages of this run.
    pub estimates: u64,
    /// Rejections published for the soak's vehicles in the window.
    pub rejected: u64,
    /// Put→estimate latency of the estimates that arrived in the window, µs (NaN/null without any).
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
    /// Largest delay of the sender behind its schedule in the window, ms.
    pub send_lag_max_ms: f64,
}

/// The report (`--json` prints it as one object).
#[derive(Clone, Debug, Serialize)]
pub struct SoakReport {
    pub filter: String,
    pub vehicles: usize,
    pub rate_hz: f64,
    pub minutes: f64,
    pub window_s: f64,
    pub service_pid: u32,
    pub endpoint: String,
    /// The child's resident memory after the probe, before the load, kB.
    pub rss_start_kb: Option<u64>,
    pub windows: Vec<WindowReport>,
    /// Totals over the run; `lost`: vector messages without an estimate after the drain period.
    pub sent: u64,
    pub gyro_sent: u64,
    pub estimates: u64,
    pub lost: u64,
    pub rejected: u64,
    /// First window against the last: resident memory and p99 latency, and last/first.
    pub rss_first_kb: Option<u64>,
    pub rss_last_kb: Option<u64>,
    pub rss_ratio: Option<f64>,
    pub p99_first_us: f64,
    pub p99_last_us: f64,
    pub p99_ratio: f64,
    /// True when the run was cut short (SIGINT/SIGTERM to the soak).
    pub interrupted: bool,
    /// How the child ended after SIGTERM: `exit code N`, `signal N`, or `killed: …`.
    pub service_exit: String,
    /// The child's exit code (`None` when a signal ended it).
    pub service_exit_code: Option<i32>,
    /// The child exited by itself within the stop timeout with code 0.
    pub service_exit_clean: bool,
}

/// `VmRSS` of a process, kB.
pub fn rss_kb(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|n| n.parse().ok())
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        f64::NAN
    } else {
        sorted[((sorted.len() - 1) as f64 * p).round() as usize]
    }
}

fn ratio(last: f64, first: f64) -> f64 {
    if first > 0.0 {
        last / first
    } else {
        f64::NAN
    }
}

fn free_port() -> Result<u16, SoakError> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| SoakError::Io(format!("no free port: {e}")))
}

/// The child service; dropped without [`ServiceChild::stop`] (an error on the way), it is stopped
/// with SIGTERM and, if need be, killed.
struct ServiceChild {
    child: Option<Child>,
    config: PathBuf,
}

impl ServiceChild {
    fn start(exe: &Path, filter: &FilterSpec, endpoint: &str) -> Result<Self, SoakError> {
        let config = std::env::temp_dir().join(format!(
            "attitude-service-soak-{}-{}.json5",
            std::process::id(),
            endpoint.rsplit(':').next().unwrap_or("0")
        ));
        let fiducial = filter.fiducial.map_or("average", |f| f.as_str());
        let text = format!(
            "// attitude-lab soak: every vehicle gets this filter.\n{{\n  service: {{\n    filter: {{ kind: \"{}\", fiducial: \"{fiducial}\" }},\n  }},\n}}\n",
            filter.kind.as_str()
        );
        std::fs::write(&config, text)
            .map_err(|e| SoakError::Io(format!("writing {}: {e}", config.display())))?;
        let child = Command::new(exe)
            .arg("serve")
            .arg("--config")
            .arg(&config)
            .arg("--listen")
            .arg(endpoint)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .map_err(|e| SoakError::Service(format!("cannot start {}: {e}", exe.display())));
        match child {
            Ok(child) => Ok(ServiceChild {
                child: Some(child),
                config,
            }),
            Err(e) => {
                let _ = std::fs::remove_file(&config);
                Err(e)
            }
        }
    }

    fn pid(&self) -> u32 {
        self.child.as_ref().map_or(0, |c| c.id())
    }

    /// `Some(status)` when the child has already exited.
    fn exited(&mut self) -> Option<ExitStatus> {
        self.child
            .as_mut()
            .and_then(|c| c.try_wait().ok().flatten())
    }

    /// Waits until the service accepts TCP connections on `port`.
    async fn wait_listening(&mut self, port: u16) -> Result<(), SoakError> {
        let deadline = Instant::now() + START_TIMEOUT;
        loop {
            if let Some(status) = self.exited() {
                return Err(SoakError::Service(format!(
                    "exited before listening ({})",
                    describe(&status)
                )));
            }
            if std::net::TcpStream::connect(("127.0.0.1", port)).is_ok() {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err(SoakError::Service(format!(
                    "not listening on port {port} after {} s",
                    START_TIMEOUT.as_secs()
                )));
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// SIGTERM (`kill -TERM <pid>`), then waits up to [`STOP_TIMEOUT`]; kills the child if it is
    /// still running. Returns the description, the exit code and whether the exit was clean.
    fn stop(&mut self) -> (String, Option<i32>, bool) {
        let Some(mut child) = self.child.take() else {
            return ("not running".into(), None, false);
        };
        let _ = std::fs::remove_file(&self.config);
        if let Ok(Some(status)) = child.try_wait() {
            return (
                format!("had already exited ({})", describe(&status)),
                status.code(),
                false,
            );
        }
        let term = Command::new("kill")
            .arg("-TERM")
            .arg(child.id().to_string())
            .status();
        if let Err(e) = term {
            let _ = child.kill();
            let _ = child.wait();
            return (format!("killed: `kill -TERM` failed ({e})"), None, false);
        }
        let deadline = Instant::now() + STOP_TIMEOUT;
        loop {
            match child.try_wait() {
                Ok(Some(status)) => {
                    return (describe(&status), status.code(), status.code() == Some(0));
                }
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(20));
                }
                _ => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return (
                        format!(
                            "killed: still running {} s after SIGTERM",
                            STOP_TIMEOUT.as_secs()
                        ),
                        None,
                        false,
                    );
                }
            }
        }
    }
}

impl Drop for ServiceChild {
    fn drop(&mut self) {
        if self.child.is_some() {
            let _ = self.stop();
        }
    }
}

fn describe(status: &ExitStatus) -> String {
    if let Some(code) = status.code() {
        return format!("exit code {code}");
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = status.signal() {
            return format!("signal {sig}");
        }
    }
    status.to_string()
}

fn client_config(endpoint: &str) -> Result<zenoh::Config, SoakError> {
    let json = serde_json::json!({
        "mode": "peer",
        "listen": {"endpoints": []},
        "connect": {"endpoints": [endpoint]},
        "scouting": {"multicast": {"enabled": false}},
    });
    zenoh::Config::from_json5(&json.to_string()).map_err(|e| SoakError::Zenoh(e.to_string()))
}

/// What the subscribers collect for the current window.
#[derive(Default)]
struct Window {
    latencies_us: Vec<f64>,
}

/// Runs the soak. When `stop` is cancelled, sending stops at the next tick and the run ends as if it
/// had been that long (the report says so).
pub async fn run(options: &SoakOptions, stop: &CancellationToken) -> Result<SoakReport, SoakError> {
    if options.vehicles == 0
        || !(options.rate_hz > 0.0 && options.rate_hz.is_finite())
        || !(options.minutes > 0.0 && options.minutes.is_finite())
    {
        return Err(SoakError::Options(
            "--vehicles, --rate and --minutes must be positive".into(),
        ));
    }
    let total_s = options.minutes * 60.0;
    let (n_windows, window_s) = windows_for(total_s);
    let port = free_port()?;
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut service = ServiceChild::start(&options.exe, &options.filter, &endpoint)?;
    let pid = service.pid();
    service.wait_listening(port).await?;
    let session = zenoh::open(client_config(&endpoint)?)
        .await
        .map_err(|e| SoakError::Zenoh(format!("cannot open the client session: {e}")))?;
    let result = load(&session, &mut service, options, n_windows, window_s, stop).await;
    let _ = session.close().await;
    let (exit, code, clean) = service.stop();
    let (windows, totals, rss_start_kb, interrupted) = result?;
    let (first, last) = (&windows[0], &windows[windows.len() - 1]);
    Ok(SoakReport {
        filter: options.filter.to_string(),
        vehicles: options.vehicles,
        rate_hz: options.rate_hz,
        minutes: options.minutes,
        window_s,
        service_pid: pid,
        endpoint,
        rss_start_kb,
        rss_first_kb: first.rss_kb,
        rss_last_kb: last.rss_kb,
        rss_ratio: match (first.rss_kb, last.rss_kb) {
            (Some(a), Some(b)) => Some(ratio(b as f64, a as f64)),
            _ => None,
        },
        p99_first_us: first.p99_us,
        p99_last_us: last.p99_us,
        p99_ratio: ratio(last.p99_us, first.p99_us),
        sent: totals.sent,
        gyro_sent: totals.gyro_sent,
        estimates: totals.estimates,
        lost: totals.lost,
        rejected: totals.rejected,
        windows,
        interrupted,
        service_exit: exit,
        service_exit_code: code,
        service_exit_clean: clean,
    })
}

#[derive(Default)]
struct Totals {
    sent: u64,
    gyro_sent: u64,
    estimates: u64,
    lost: u64,
    rejected: u64,
}

type LoadResult = (Vec<WindowReport>, Totals, Option<u64>, bool);

async fn load(
    session: &zenoh::Session,
    service: &mut ServiceChild,
    options: &SoakOptions,
    n_windows: usize,
    window_s: f64,
    stop: &CancellationToken,
) -> Result<LoadResult, SoakError> {
    let keys = Keys::new(PREFIX);
    let pid = service.pid();
    let ids: Vec<String> = (1..=options.vehicles)
        .map(|n| format!("{VEHICLE_PREFIX}{n}"))
        .collect();
    let index: HashMap<String, usize> = ids.iter().cloned().zip(0..).collect();
    // Per vehicle: the send instant of each outstanding vector message, by time stamp.
    let pending: Arc<Pending> = Arc::new(
        (0..ids.len())
            .map(|_| Mutex::new(Default::default()))
            .collect(),
    );
    let window = Arc::new(Mutex::new(Window::default()));
    let rejected = Arc::new(AtomicU64::new(0));
    let zerr = |e: zenoh::Error| SoakError::Zenoh(e.to_string());

    let (p, w, k, idx) = (pending.clone(), window.clone(), keys.clone(), index.clone());
    let _estimates = session
        .declare_subscriber(keys.all(Leaf::Estimate))
        .callback(move |s: zenoh::sample::Sample| {
            if let Some(us) = latency_us(&s, &k, &idx, &p) {
                w.lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .latencies_us
                    .push(us);
            }
        })
        .await
        .map_err(zerr)?;
    let _rejections = count_rejections(session, &keys, index.clone(), rejected.clone())
        .await
        .map_err(zerr)?;
    probe(session, &keys, VEHICLE_PREFIX)
        .await
        .map_err(|e| SoakError::Zenoh(e.to_string()))?;
    let rss_start_kb = rss_kb(pid);

    let put = |key: String, payload: Vec<u8>| {
        session
            .put(key, payload)
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(CongestionControl::Block)
            .express(true)
    };
    let gyro_keys: Vec<String> = ids.iter().map(|v| keys.vehicle(v, Leaf::Gyro)).collect();
    let vector_keys: Vec<String> = ids.iter().map(|v| keys.vehicle(v, Leaf::Vectors)).collect();
    let period = 1.0 / options.rate_hz;
    let ticks_per_window = (window_s * options.rate_hz).round().max(1.0) as u64;
    let start = Instant::now();
    let mut windows = Vec::with_capacity(n_windows);
    let mut totals = Totals::default();
    let mut was_interrupted = false;
    let mut rejected_before = 0;
    let mut tick: u64 = 0;
    for k in 0..n_windows {
        let (mut sent, mut lag_max) = (0u64, Duration::ZERO);
        for _ in 0..ticks_per_window {
            let due = start + Duration::from_secs_f64(tick as f64 * period);
            let now = Instant::now();
            tokio::select! {
                biased;
                _ = stop.cancelled() => {
                    was_interrupted = true;
                    break;
                }
                _ = async {
                    if now < due {
                        tokio::time::sleep_until(due.into()).await;
                    }
                } => {}
            }
            if now >= due {
                lag_max = lag_max.max(now - due);
            }
            let t = tick as f64 * period;
            for i in 0..ids.len() {
                let vectors = serde_json::to_vec(&star_set(t, i)).unwrap_or_default();
                pending[i]
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .insert(time_key(t), Instant::now());
                put(vector_keys[i].clone(), vectors).await.map_err(zerr)?;
                sent += 1;
                let gyro = serde_json::to_vec(&GyroMsg { t, omega: [0.0; 3] }).unwrap_or_default();
                put(gyro_keys[i].clone(), gyro).await.map_err(zerr)?;
                totals.gyro_sent += 1;
            }
            tick += 1;
        }
        let last = k + 1 == n_windows || was_interrupted;
        let end = start + Duration::from_secs_f64((k + 1) as f64 * window_s);
        if last {
            // Wait for the estimates still on their way (at most DRAIN).
            drain(&pending, DRAIN).await;
        } else if Instant::now() < end {
            tokio::time::sleep_until(end.into()).await;
        }
        let mut lat = std::mem::take(
            &mut window
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .latencies_us,
        );
        lat.sort_by(f64::total_cmp);
        let rejected_now = rejected.load(Ordering::Relaxed);
        let report = WindowReport {
            window: k + 1,
            end_s: start.elapsed().as_secs_f64(),
            rss_kb: rss_kb(pid),
            sent,
            estimates: lat.len() as u64,
            rejected: rejected_now - rejected_before,
            p50_us: percentile(&lat, 0.5),
            p99_us: percentile(&lat, 0.99),
            max_us: lat.last().copied().unwrap_or(f64::NAN),
            send_lag_max_ms: lag_max.as_secs_f64() * 1e3,
        };
        rejected_before = rejected_now;
        totals.sent += report.sent;
        totals.estimates += report.estimates;
        windows.push(report);
        // (An interrupt from a terminal reaches the child too: then its exit is expected.)
        if let Some(status) = service.exited().filter(|_| !was_interrupted) {
            return Err(SoakError::Service(format!(
                "exited during the run ({}) after {} window(s)",
                describe(&status),
                windows.len()
            )));
        }
        if last {
            break;
        }
    }
    totals.lost = pending
        .iter()
        .map(|m| m.lock().unwrap_or_else(|e| e.into_inner()).len() as u64)
        .sum();
    totals.rejected = rejected.load(Ordering::Relaxed);
    Ok((windows, totals, rss_start_kb, was_interrupted))
}

fn mb(kb: Option<u64>) -> String {
    kb.map_or("-".into(), |k| format!("{:.1}", k as f64 / 1024.0))
}

fn ms(us: f64) -> String {
    if us.is_finite() {
        format!("{:.2}", us / 1e3)
    } else {
        "-".into()
    }
}

impl SoakReport {
    pub fn table(&self) -> String {
        let mut s = format!(
            "soak: {} for {} vehicles × {} Hz (gyro + vectors), {} min in {} windows of {:.1} s; service pid {} on {}{}\n",
            self.filter,
            self.vehicles,
            self.rate_hz,
            self.minutes,
            self.windows.len(),
            self.window_s,
            self.service_pid,
            self.endpoint,
            if self.interrupted { " (interrupted)" } else { "" }
        );
        s += &format!(
            "service RSS before the load: {} MB\n\n",
            mb(self.rss_start_kb)
        );
        s += "window   end s   RSS MB     sent  estimates  rejected   p50 ms   p99 ms   max ms  lag ms\n";
        for w in &self.windows {
            s += &format!(
                "{:>6} {:>7.1} {:>8} {:>8} {:>10} {:>9} {:>8} {:>8} {:>8} {:>7.1}\n",
                w.window,
                w.end_s,
                mb(w.rss_kb),
                w.sent,
                w.estimates,
                w.rejected,
                ms(w.p50_us),
                ms(w.p99_us),
                ms(w.max_us),
                w.send_lag_max_ms
            );
        }
        s += &format!(
            "\ntotal: {} vector + {} gyro messages sent, {} estimates, {} lost (no estimate {} s after the end), {} rejected\n",
            self.sent, self.gyro_sent, self.estimates, self.lost, DRAIN.as_secs(), self.rejected
        );
        s += &format!(
            "window 1 vs window {}: RSS {} -> {} MB (×{}), p99 {} -> {} ms (×{})\n",
            self.windows.len(),
            mb(self.rss_first_kb),
            mb(self.rss_last_kb),
            self.rss_ratio.map_or("-".into(), |r| format!("{r:.3}")),
            ms(self.p99_first_us),
            ms(self.p99_last_us),
            if self.p99_ratio.is_finite() {
                format!("{:.2}", self.p99_ratio)
            } else {
                "-".into()
            }
        );
        s += &format!("service after SIGTERM: {}\n", self.service_exit);
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_are_at_most_a_minute_and_at_least_two() {
        assert_eq!(windows_for(600.0), (10, 60.0));
        assert_eq!(windows_for(60.0), (2, 30.0));
        assert_eq!(windows_for(12.0), (2, 6.0));
        let (n, w) = windows_for(630.0);
        assert_eq!(n, 11);
        assert!(w <= 60.0 && (n as f64 * w - 630.0).abs() < 1e-9);
    }

    #[test]
    fn percentiles_and_rss() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.5), 51.0);
        assert_eq!(percentile(&v, 0.99), 99.0);
        assert!(percentile(&[], 0.5).is_nan());
        // This process has a resident set on Linux.
        if cfg!(target_os = "linux") {
            assert!(rss_kb(std::process::id()).is_some_and(|k| k > 0));
        }
    }
}
