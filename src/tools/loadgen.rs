//! `attitude-service loadgen`: publishes gyro and vector messages (or raw IMU samples, `--imu N`: puts of
//! N samples on `P/V/imu`, each sample answered by an estimate) for K vehicles at a fixed rate against a
//! running service and measures sustained throughput and put→estimate latency; `--echo` measures a bare
//! zenoh put→reply round trip through a trivial echo (subscribe to `P/*/vectors`, put the payload back
//! on `P/V/estimate`) in exactly the same way, so every report carries its own baseline.

use crate::service::keys::{Keys, Leaf};
use crate::wire::{GyroMsg, ImuMsg, ObservationMsg, VectorsMsg};
use serde::Serialize;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;

#[derive(Clone, Debug)]
pub struct LoadOptions {
    pub vehicles: usize,
    /// Gyro and vector messages per vehicle per second (each).
    pub rate_hz: f64,
    pub duration_s: f64,
    /// Vehicle ids `<vehicle_prefix><n>`.
    pub vehicle_prefix: String,
    /// How long to wait for the last estimates after sending stops, s.
    pub drain_s: f64,
    /// 0: gyro and vector messages. N > 0: raw IMU samples instead, N per put (a sample rate of
    /// `rate_hz · N` per vehicle), every one of which must come back as an estimate.
    pub imu_batch: usize,
}

/// The report (`--json` prints it as one object).
#[derive(Clone, Debug, Serialize)]
pub struct LoadReport {
    /// `service` or `echo`.
    pub mode: String,
    pub vehicles: usize,
    pub rate_hz: f64,
    pub duration_s: f64,
    /// Vector messages (or IMU samples) sent, each of which should produce one estimate; gyro messages
    /// are sent too (not with IMU samples).
    pub sent: u64,
    pub gyro_sent: u64,
    /// Estimates (or echoes) received for the vector messages sent.
    pub estimates: u64,
    /// Vector messages without an estimate after the drain period.
    pub lost: u64,
    /// Rejections published by the service for these vehicles.
    pub rejected: u64,
    /// Estimates per second over the sending period.
    pub rate_per_s: f64,
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
    /// Largest delay of the sender behind its schedule, ms (the load generator's own limit).
    pub send_lag_max_ms: f64,
}

/// Counts the rejections published for `index`'s vehicles into `counter` while the subscriber lives.
pub async fn count_rejections(
    session: &zenoh::Session,
    keys: &Keys,
    index: HashMap<String, usize>,
    counter: Arc<AtomicU64>,
) -> zenoh::Result<zenoh::pubsub::Subscriber<()>> {
    let k = keys.clone();
    session
        .declare_subscriber(keys.all(Leaf::Rejected))
        .callback(move |s: zenoh::sample::Sample| {
            if k.split(s.key_expr().as_str())
                .is_some_and(|(v, _)| index.contains_key(v))
            {
                counter.fetch_add(1, Ordering::Relaxed);
            }
        })
        .await
}

/// Sent-time of each vector message still waiting for its estimate, per vehicle, by `time_key(t)`.
pub type Pending = Vec<Mutex<HashMap<i64, Instant>>>;

/// Put→estimate latency, µs, of an estimate (or echo) sample: matches it with its vector message by
/// vehicle and `t` and forgets that message. `None` for a sample that is not one of ours.
pub fn latency_us(
    s: &zenoh::sample::Sample,
    keys: &Keys,
    index: &HashMap<String, usize>,
    pending: &Pending,
) -> Option<f64> {
    let now = Instant::now();
    let (vehicle, _) = keys.split(s.key_expr().as_str())?;
    let &i = index.get(vehicle)?;
    let msg = serde_json::from_slice::<JustT>(&s.payload().to_bytes()).ok()?;
    let sent = pending[i]
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .remove(&time_key(msg.t))?;
    Some(now.duration_since(sent).as_secs_f64() * 1e6)
}

/// Waits until every vector message sent has its estimate, at most `limit`.
pub async fn drain(pending: &Pending, limit: Duration) {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        let outstanding: usize = pending
            .iter()
            .map(|m| m.lock().unwrap_or_else(|e| e.into_inner()).len())
            .sum();
        if outstanding == 0 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// The time stamp of an estimate, the only field the load generators read.
#[derive(serde::Deserialize)]
pub struct JustT {
    pub t: f64,
}

/// Matches an estimate to its vector message by time stamp (µs).
pub fn time_key(t: f64) -> i64 {
    (t * 1e6).round() as i64
}

/// The echo: every vector message comes straight back on the vehicle's estimate key.
pub async fn echo(
    session: &zenoh::Session,
    keys: &Keys,
) -> Result<zenoh::pubsub::Subscriber<()>, zenoh::Error> {
    let publisher = session.clone();
    let k = keys.clone();
    session
        .declare_subscriber(keys.all(Leaf::Vectors))
        .callback(move |s: zenoh::sample::Sample| {
            if let Some((vehicle, _)) = k.split(s.key_expr().as_str()) {
                let _ = zenoh::Wait::wait(
                    publisher
                        .put(k.vehicle(vehicle, Leaf::Estimate), s.payload().clone())
                        .encoding(Encoding::APPLICATION_JSON)
                        // As the service's own puts: back-pressure, never a silent drop.
                        .congestion_control(CongestionControl::Block)
                        .express(true),
                );
            }
        })
        .await
}

/// Vehicle `i`'s vector set at `t`: three exact star directions at a fixed attitude.
pub fn star_set(t: f64, i: usize) -> VectorsMsg {
    // A fixed attitude per vehicle (a rotation about z by i·0.01 rad): A = R3(a).
    let a = i as f64 * 0.01;
    let (c, s) = (a.cos(), a.sin());
    let refs = [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.0, -0.8, 0.6]];
    VectorsMsg {
        t,
        obs: refs
            .iter()
            .map(|r| ObservationMsg {
                body: [c * r[0] + s * r[1], -s * r[0] + c * r[1], r[2]],
                reference: *r,
                sigma: 1e-4,
                sensor: None,
            })
            .collect(),
    }
}

/// Sends vector sets for `<vehicle_prefix>0` until its first estimate comes back (at most 10 s).
pub async fn probe(
    session: &zenoh::Session,
    keys: &Keys,
    vehicle_prefix: &str,
) -> Result<(), zenoh::Error> {
    let vehicle = format!("{vehicle_prefix}0");
    let got = Arc::new(AtomicU64::new(0));
    let g = got.clone();
    let _sub = session
        .declare_subscriber(keys.vehicle(&vehicle, Leaf::Estimate))
        .callback(move |_| {
            g.fetch_add(1, Ordering::Relaxed);
        })
        .await?;
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut t = 0.0;
    while got.load(Ordering::Relaxed) == 0 {
        if Instant::now() > deadline {
            return Err("no estimate for the probe vehicle within 10 s: is the service (or echo) reachable?".into());
        }
        let payload = serde_json::to_vec(&star_set(t, 0)).unwrap_or_default();
        session
            .put(keys.vehicle(&vehicle, Leaf::Vectors), payload)
            .encoding(Encoding::APPLICATION_JSON)
            .await?;
        t += 1.0;
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    // Let the other declarations settle too.
    tokio::time::sleep(Duration::from_millis(200)).await;
    Ok(())
}

/// A raw IMU sample of vehicle `i` at `t`: turning slowly about a tilted axis, gravity and a field seen
/// from that attitude (the pipeline has real work: tilt, heading, no rest).
pub fn imu_sample(t: f64, i: usize) -> ImuMsg {
    use crate::attitude::Quaternion;
    use nalgebra::Vector3;
    let w = Vector3::new(0.1, -0.05, 0.2 + 0.01 * (i % 7) as f64);
    let q = Quaternion::from_rotation_vector(&(w * t));
    let a = q.attitude_matrix();
    let g = a * Vector3::new(0.0, 0.0, 9.81);
    let m = a * Vector3::new(0.0, 15.6, -41.7);
    ImuMsg {
        t,
        gyr: [w[0], w[1], w[2]],
        acc: [g[0], g[1], g[2]],
        mag: Some([m[0], m[1], m[2]]),
    }
}

/// Runs the load. The session must reach the service (or the echo).
pub async fn run(
    session: &zenoh::Session,
    keys: &Keys,
    options: &LoadOptions,
    mode: &str,
) -> Result<LoadReport, zenoh::Error> {
    let ids: Vec<String> = (1..=options.vehicles)
        .map(|n| format!("{}{n}", options.vehicle_prefix))
        .collect();
    let index: HashMap<String, usize> = ids
        .iter()
        .cloned()
        .enumerate()
        .map(|(i, v)| (v, i))
        .collect();
    // Per vehicle: send instant of each outstanding vector message, by time stamp.
    let pending: Arc<Vec<Mutex<HashMap<i64, Instant>>>> =
        Arc::new((0..ids.len()).map(|_| Mutex::new(HashMap::new())).collect());
    let latencies: Arc<Mutex<Vec<f64>>> = Arc::new(Mutex::new(Vec::new()));
    let rejected = Arc::new(AtomicU64::new(0));

    let (p, l, k, idx) = (
        pending.clone(),
        latencies.clone(),
        keys.clone(),
        index.clone(),
    );
    let _estimates = session
        .declare_subscriber(keys.all(Leaf::Estimate))
        .callback(move |s: zenoh::sample::Sample| {
            if let Some(us) = latency_us(&s, &k, &idx, &p) {
                l.lock().unwrap_or_else(|e| e.into_inner()).push(us);
            }
        })
        .await?;
    let _rejections = count_rejections(session, keys, index.clone(), rejected.clone()).await?;
    // Prove the path before the clock starts: a probe vehicle (`<prefix>0`) until its first estimate
    // comes back, so that declarations still propagating are not counted as losses.
    probe(session, keys, &options.vehicle_prefix).await?;

    let put = |key: String, payload: Vec<u8>| {
        session
            .put(key, payload)
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(CongestionControl::Block)
            .express(true)
    };
    if options.imu_batch > 0 {
        // An IMU vehicle aligns from its first samples (no estimate for them): 0.2 s of samples (twice
        // the preset's alignment) before the clock starts, not counted, put in batches of the load's
        // size (one put of thousands of samples would overflow the vehicle's queue and be refused).
        let dt = 1.0 / (options.rate_hz * options.imu_batch as f64);
        let n = (0.2 / dt).ceil() as usize;
        for (i, v) in ids.iter().enumerate() {
            let warmup: Vec<ImuMsg> = (0..n)
                .map(|j| imu_sample(-((n - j) as f64) * dt, i))
                .collect();
            for chunk in warmup.chunks(options.imu_batch) {
                session
                    .put(
                        keys.vehicle(v, Leaf::Imu),
                        serde_json::to_vec(chunk).unwrap_or_default(),
                    )
                    .encoding(Encoding::APPLICATION_JSON)
                    .congestion_control(CongestionControl::Block)
                    .await?;
            }
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
    let period = Duration::from_secs_f64(1.0 / options.rate_hz);
    let ticks = (options.duration_s * options.rate_hz).round().max(1.0) as u64;
    let start = Instant::now();
    let (mut sent, mut gyro_sent, mut lag_max) = (0u64, 0u64, Duration::ZERO);
    let gyro_keys: Vec<String> = ids.iter().map(|v| keys.vehicle(v, Leaf::Gyro)).collect();
    let vector_keys: Vec<String> = ids.iter().map(|v| keys.vehicle(v, Leaf::Vectors)).collect();
    let imu_keys: Vec<String> = ids.iter().map(|v| keys.vehicle(v, Leaf::Imu)).collect();
    for tick in 0..ticks {
        let due = start + period * tick as u32;
        let now = Instant::now();
        if now < due {
            tokio::time::sleep_until(due.into()).await;
        } else {
            lag_max = lag_max.max(now - due);
        }
        let t = tick as f64 / options.rate_hz;
        if options.imu_batch > 0 {
            for (i, key) in imu_keys.iter().enumerate() {
                let n = options.imu_batch;
                let samples: Vec<ImuMsg> = (0..n)
                    .map(|j| imu_sample(t + j as f64 / (options.rate_hz * n as f64), i))
                    .collect();
                let payload = serde_json::to_vec(&samples).unwrap_or_default();
                {
                    let mut p = pending[i].lock().unwrap_or_else(|e| e.into_inner());
                    let now = Instant::now();
                    for s in &samples {
                        p.insert(time_key(s.t), now);
                    }
                }
                put(key.clone(), payload).await?;
                sent += n as u64;
            }
            continue;
        }
        for i in 0..ids.len() {
            let vectors = serde_json::to_vec(&star_set(t, i)).unwrap_or_default();
            pending[i]
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(time_key(t), Instant::now());
            put(vector_keys[i].clone(), vectors).await?;
            sent += 1;
            let gyro = serde_json::to_vec(&GyroMsg { t, omega: [0.0; 3] }).unwrap_or_default();
            put(gyro_keys[i].clone(), gyro).await?;
            gyro_sent += 1;
        }
    }
    let sending = start.elapsed().as_secs_f64();
    drain(&pending, Duration::from_secs_f64(options.drain_s)).await;
    let mut lat = latencies.lock().unwrap_or_else(|e| e.into_inner()).clone();
    lat.sort_by(f64::total_cmp);
    let pct = |p: f64| -> f64 {
        if lat.is_empty() {
            f64::NAN
        } else {
            lat[((lat.len() - 1) as f64 * p).round() as usize]
        }
    };
    let estimates = lat.len() as u64;
    Ok(LoadReport {
        mode: mode.to_string(),
        vehicles: options.vehicles,
        rate_hz: options.rate_hz,
        duration_s: options.duration_s,
        sent,
        gyro_sent,
        estimates,
        lost: sent.saturating_sub(estimates),
        rejected: rejected.load(Ordering::Relaxed),
        rate_per_s: estimates as f64 / sending,
        p50_us: pct(0.5),
        p99_us: pct(0.99),
        max_us: lat.last().copied().unwrap_or(f64::NAN),
        send_lag_max_ms: lag_max.as_secs_f64() * 1e3,
    })
}

impl LoadReport {
    pub fn table(&self) -> String {
        format!(
            "{} load: {} vehicles × {} Hz for {} s\n  sent {} vector + {} gyro messages; {} estimates ({:.0}/s), {} lost, {} rejected\n  put→estimate latency p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs; sender lag max {:.1} ms\n",
            self.mode, self.vehicles, self.rate_hz, self.duration_s, self.sent, self.gyro_sent, self.estimates,
            self.rate_per_s, self.lost, self.rejected, self.p50_us, self.p99_us, self.max_us, self.send_lag_max_ms
        )
    }
}
