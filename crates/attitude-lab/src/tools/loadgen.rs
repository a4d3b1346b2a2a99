//! `attitude-lab loadgen`: publishes gyro and vector messages (or raw IMU samples, `--imu N`: puts of
//! N samples on `P/V/imu`, each sample answered by an estimate) for K vehicles at a fixed rate against a
//! running service and measures sustained throughput and put→estimate latency; `--echo` measures a bare
//! zenoh put→reply round trip through a trivial echo (subscribe to `P/*/vectors` and `P/*/imu`, put the
//! payload back on `P/V/estimate`) in exactly the same way, so every report carries its own baseline.
//!
//! Its puts have the service's own quality of service: congestion control `Block` (never a silent
//! drop), not `express` (zenoh batches what queues up while the link is busy). Plain puts by default, not
//! a publisher declared per key: real vehicles are separate sessions with a key or two each, and one
//! process declaring thousands would measure what holding them costs zenoh (as published, zenoh 1.10.2
//! visits every declaration for each undeclared key a peer receives or puts; the service's and this
//! tool's zenoh is patched, vendor/README.md, a stock router's is not) rather than the service.
//! `--advanced` puts through advanced publishers ([`attitude_service::tools::publish`]: a sequence
//! number, a cache, a heartbeat), one per key, which declare a publisher, a queryable and a token each:
//! what that costs the service is measured in BENCHMARKS.md.

use attitude_service::fleet::sender::{RoutedSender, FLUSH_S};
use attitude_service::tools::publish::{Inputs, Publishing};
use attitude_service::tools::synthetic::{imu_sample, star_set};
use attitude_service::wire::keys::{Keys, Leaf};
use attitude_service::wire::{GyroMsg, ImuMsg};
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
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
    /// IMU samples against a service that caps its estimate rate (`service.imu.max_estimate_rate_hz`):
    /// an estimate answers every sample of its vehicle up to its `t` (all of them went through the
    /// filter, in order, before it), and after the run one more sample per vehicle, 1 s later and not
    /// counted, has the last samples answered too.
    pub covering: bool,
    /// Inputs on their routed keys, and batched for the routes' standby members
    /// ([`attitude_service::fleet::sender`]): how a fleet scales.
    pub routed: bool,
    /// Each vehicle's messages at its own phase of the period (vehicle i at i/n of it), as
    /// independent vehicles send, instead of every vehicle's at the start of each period (a burst).
    pub spread: bool,
    /// How the inputs on their plain keys are put.
    pub publishing: Publishing,
}

/// With `spread`, vehicles sent together (the sender's timer has a resolution of about 1 ms).
const SPREAD_SLOT: usize = 8;

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
    /// Vector messages (or IMU samples) answered by an estimate (or echo).
    pub estimates: u64,
    /// Estimate (or echo) messages received for them (fewer than `estimates` with `covering`, or
    /// from the echo of IMU batches).
    pub messages: u64,
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
            // (A `gap` is told on the same key but is no refusal: `--capped` sends one on purpose.)
            let gap =
                serde_json::from_slice::<attitude_service::wire::ErrorMsg>(&s.payload().to_bytes())
                    .is_ok_and(|m| m.code == "gap");
            if !gap
                && k.split(s.key_expr().as_str())
                    .is_some_and(|(v, _)| index.contains_key(v))
            {
                counter.fetch_add(1, Ordering::Relaxed);
            }
        })
        .await
}

/// Sent-time of each vector message still waiting for its estimate, per vehicle, by `time_key(t)`.
pub type Pending = Vec<Mutex<BTreeMap<i64, Instant>>>;

/// Put→estimate latency, µs, of an estimate (or echo) sample: matches it with its vector message by
/// vehicle and `t` and forgets that message. `None` for a sample that is not one of ours.
pub fn latency_us(
    s: &zenoh::sample::Sample,
    keys: &Keys,
    index: &HashMap<String, usize>,
    pending: &Pending,
) -> Option<f64> {
    let mut latency = None;
    latencies_us(s, keys, index, pending, false, |us| latency = Some(us));
    latency
}

/// [`latency_us`] of every message a sample answers: one estimate, or an echo of a batch of IMU
/// samples (an array); `covering`: an estimate answers every message of its vehicle up to its `t`.
pub fn latencies_us(
    s: &zenoh::sample::Sample,
    keys: &Keys,
    index: &HashMap<String, usize>,
    pending: &Pending,
    covering: bool,
    mut each: impl FnMut(f64),
) {
    let now = Instant::now();
    let Some((vehicle, _)) = keys.split(s.key_expr().as_str()) else {
        return;
    };
    let Some(&i) = index.get(vehicle) else {
        return;
    };
    let payload = s.payload().to_bytes();
    let mut pending = pending[i].lock().unwrap_or_else(|e| e.into_inner());
    let mut answer = |t: f64| {
        let latency = |sent: Instant| now.duration_since(sent).as_secs_f64() * 1e6;
        if covering {
            let later = pending.split_off(&(time_key(t) + 1));
            for sent in std::mem::replace(&mut *pending, later).into_values() {
                each(latency(sent));
            }
        } else if let Some(sent) = pending.remove(&time_key(t)) {
            each(latency(sent));
        }
    };
    match first_t(&payload) {
        Some(t) => answer(t),
        None => {
            if let Ok(batch) = serde_json::from_slice::<Vec<JustT>>(&payload) {
                batch.iter().for_each(|m| answer(m.t));
            } else if let Ok(m) = serde_json::from_slice::<JustT>(&payload) {
                answer(m.t)
            }
        }
    }
}

/// The top-level `t` of one JSON object, read without parsing the rest (the load generator reads
/// every estimate, and must not be what limits the load): the number after the first `"t":`, which
/// in an estimate follows only `"vehicle"` (an id, without quotes inside) and in an input message
/// comes first. `None` for anything else (an array, another layout), which is then parsed.
fn first_t(payload: &[u8]) -> Option<f64> {
    if payload.first() != Some(&b'{') {
        return None;
    }
    let at = payload.windows(4).position(|w| w == b"\"t\":")? + 4;
    let rest = &payload[at..];
    let end = rest.iter().position(|&c| c == b',' || c == b'}')?;
    std::str::from_utf8(&rest[..end]).ok()?.trim().parse().ok()
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

/// The echo: every vector message (or batch of IMU samples) comes straight back on the vehicle's
/// estimate key.
pub async fn echo(session: &zenoh::Session, keys: &Keys) -> Result<Echo, zenoh::Error> {
    let mut subscribers = Vec::new();
    // (Plain and routed inputs.)
    for key in [Leaf::Vectors, Leaf::Imu]
        .into_iter()
        .flat_map(|leaf| [keys.all(leaf), keys.routed_all(leaf)])
    {
        let publisher = session.clone();
        let k = keys.clone();
        subscribers.push(
            session
                .declare_subscriber(key)
                .callback(move |s: zenoh::sample::Sample| {
                    if let Some(attitude_service::wire::keys::Received::Vehicle {
                        vehicle, ..
                    }) = k.classify(s.key_expr().as_str())
                    {
                        let _ = zenoh::Wait::wait(
                            publisher
                                .put(k.vehicle(vehicle, Leaf::Estimate), s.payload().clone())
                                .encoding(Encoding::APPLICATION_JSON)
                                // As the service's own puts: back-pressure, never a silent drop.
                                .congestion_control(CongestionControl::Block),
                        );
                    }
                })
                .await?,
        );
    }
    Ok(Echo {
        _subscribers: subscribers,
    })
}

/// The echo's subscribers: it echoes while this lives.
pub struct Echo {
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
}

/// Sends vector sets for `<vehicle_prefix>0` until its first estimate comes back (at most 10 s).
pub async fn probe(
    session: &zenoh::Session,
    keys: &Keys,
    vehicle_prefix: &str,
) -> Result<(), zenoh::Error> {
    probe_on(session, keys, vehicle_prefix, None).await
}

/// [`probe`], through `routed` when given.
async fn probe_on(
    session: &zenoh::Session,
    keys: &Keys,
    vehicle_prefix: &str,
    routed: Option<&RoutedSender>,
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
        match routed {
            Some(r) => {
                let key = r.key(&vehicle, Leaf::Vectors)?;
                r.put(&vehicle, Leaf::Vectors, &key, payload).await?
            }
            None => {
                session
                    .put(keys.vehicle(&vehicle, Leaf::Vectors), payload)
                    .encoding(Encoding::APPLICATION_JSON)
                    .await?
            }
        }
        t += 1.0;
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    // Let the other declarations settle too.
    tokio::time::sleep(Duration::from_millis(200)).await;
    Ok(())
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
    let pending: Arc<Pending> = Arc::new(
        (0..ids.len())
            .map(|_| Mutex::new(BTreeMap::new()))
            .collect(),
    );
    let latencies: Arc<Mutex<Vec<f64>>> = Arc::new(Mutex::new(Vec::new()));
    let rejected = Arc::new(AtomicU64::new(0));
    let messages = Arc::new(AtomicU64::new(0));

    let (p, l, k, idx, m) = (
        pending.clone(),
        latencies.clone(),
        keys.clone(),
        index.clone(),
        messages.clone(),
    );
    let covering = options.covering && options.imu_batch > 0;
    let _estimates = session
        .declare_subscriber(keys.all(Leaf::Estimate))
        .callback(move |s: zenoh::sample::Sample| {
            let mut l = l.lock().unwrap_or_else(|e| e.into_inner());
            let before = l.len();
            latencies_us(&s, &k, &idx, &p, covering, |us| l.push(us));
            if l.len() > before {
                m.fetch_add(1, Ordering::Relaxed);
            }
        })
        .await?;
    let _rejections = count_rejections(session, keys, index.clone(), rejected.clone()).await?;
    let routed = options
        .routed
        .then(|| RoutedSender::start(session, keys, Duration::from_secs_f64(FLUSH_S)));
    // Prove the path before the clock starts: a probe vehicle (`<prefix>0`) until its first estimate
    // comes back, so that declarations still propagating are not counted as losses.
    probe_on(session, keys, &options.vehicle_prefix, routed.as_ref()).await?;

    // Each vehicle's keys, checked once.
    let keys_of = |leaf: Leaf| -> Result<Vec<KeyExpr<'static>>, zenoh::Error> {
        ids.iter()
            .map(|v| match &routed {
                Some(r) => r.key(v, leaf),
                None => KeyExpr::try_from(keys.vehicle(v, leaf)),
            })
            .collect()
    };
    let (gyro, vectors, imu) = (
        keys_of(Leaf::Gyro)?,
        keys_of(Leaf::Vectors)?,
        keys_of(Leaf::Imu)?,
    );
    let inputs = Inputs::new(session, options.publishing.clone());
    let put = |i: usize, leaf: Leaf, key: &KeyExpr<'static>, payload: Vec<u8>| {
        let (routed, ids, inputs) = (routed.as_ref(), &ids, &inputs);
        let key = key.clone();
        async move {
            match routed {
                Some(r) => r.put(&ids[i], leaf, &key, payload).await,
                None => inputs.put(&key, payload).await,
            }
        }
    };
    if options.imu_batch > 0 {
        // An IMU vehicle aligns from its first samples (no estimate for them): 0.2 s of samples (twice
        // the preset's alignment) before the clock starts, not counted, put in batches of the load's
        // size (one put of thousands of samples would overflow the vehicle's queue and be refused).
        let dt = 1.0 / (options.rate_hz * options.imu_batch as f64);
        let n = (0.2 / dt).ceil() as usize;
        for i in 0..ids.len() {
            let warmup: Vec<ImuMsg> = (0..n)
                .map(|j| imu_sample(-((n - j) as f64) * dt, i))
                .collect();
            for chunk in warmup.chunks(options.imu_batch) {
                put(
                    i,
                    Leaf::Imu,
                    &imu[i],
                    serde_json::to_vec(chunk).unwrap_or_default(),
                )
                .await?;
            }
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
    let period = Duration::from_secs_f64(1.0 / options.rate_hz);
    let ticks = (options.duration_s * options.rate_hz).round().max(1.0) as u64;
    let start = Instant::now();
    let (mut sent, mut gyro_sent, mut lag_max) = (0u64, 0u64, Duration::ZERO);
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
            for (i, key) in imu.iter().enumerate() {
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
                put(i, Leaf::Imu, key, payload).await?;
                sent += n as u64;
            }
            continue;
        }
        for i in 0..ids.len() {
            if options.spread && i % SPREAD_SLOT == 0 {
                // Vehicle i's messages at its own phase of the period, a slot of vehicles at a time.
                let at = due + period.mul_f64(i as f64 / ids.len() as f64);
                if Instant::now() < at {
                    tokio::time::sleep_until(at.into()).await;
                }
            }
            let payload = serde_json::to_vec(&star_set(t, i)).unwrap_or_default();
            pending[i]
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(time_key(t), Instant::now());
            put(i, Leaf::Vectors, &vectors[i], payload).await?;
            sent += 1;
            let gyro_payload =
                serde_json::to_vec(&GyroMsg { t, omega: [0.0; 3] }).unwrap_or_default();
            put(i, Leaf::Gyro, &gyro[i], gyro_payload).await?;
            gyro_sent += 1;
        }
    }
    let sending = start.elapsed().as_secs_f64();
    if covering {
        // One sample per vehicle 1 s after its last, not counted: its estimate is due whatever the
        // cap (from 1 Hz on) and answers the samples the last published estimate did not cover.
        let t = ticks as f64 / options.rate_hz + 1.0;
        for (i, key) in imu.iter().enumerate() {
            put(
                i,
                Leaf::Imu,
                key,
                serde_json::to_vec(&imu_sample(t, i)).unwrap_or_default(),
            )
            .await?;
        }
    }
    if let Some(r) = routed {
        r.close().await;
    }
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
        messages: messages.load(Ordering::Relaxed),
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
            "{} load: {} vehicles × {} Hz for {} s\n  sent {} vector (or IMU) + {} gyro messages; {} answered ({:.0}/s) by {} messages, {} lost, {} rejected\n  put→estimate latency p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs; sender lag max {:.1} ms\n",
            self.mode, self.vehicles, self.rate_hz, self.duration_s, self.sent, self.gyro_sent, self.estimates,
            self.rate_per_s, self.messages, self.lost, self.rejected, self.p50_us, self.p99_us, self.max_us, self.send_lag_max_ms
        )
    }
}
