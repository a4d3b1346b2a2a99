//! The network service: zenoh subscribers and queryables around the [`engine::Engine`].
//!
//! `run(session, config, shutdown)` is the whole service: one `select!` loop over the queryables and
//! the shutdown signal. Subscriber callbacks only hand raw samples to the engine's bounded ingest
//! channel; filters run on the engine's worker threads, never on zenoh's threads or the async runtime.

pub mod config;
pub mod engine;
pub mod fleet;
pub mod keys;
pub mod persist;
pub mod ros2;
pub mod session;
/// One vehicle (the state machine of the numeric core).
pub use attitude_core::vehicle;

use crate::wire::{decode_one, ErrorMsg, RejectCode, Rejection, ResetMsg};
use config::ServiceConfig;
use engine::{Engine, EstimateOutlet, Inbound, Outlets, Sink, METRICS_ENCODING};
use keys::{Keys, Leaf};
use serde::Serialize;
use std::collections::BTreeSet;
use std::future::Future;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use thiserror::Error;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;
use zenoh::query::Query;
use zenoh::sample::Locality;
use zenoh::Wait;

#[derive(Debug, Error)]
pub enum ServiceError {
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error("HTTP (zenoh's REST plugin): {0}")]
    Http(String),
    #[error("state directory: {0}")]
    State(#[from] persist::CheckpointError),
}

fn zerr(e: impl std::fmt::Display) -> ServiceError {
    ServiceError::Zenoh(e.to_string())
}

/// How long a reset waits for the vehicle's worker.
const RESET_TIMEOUT: Duration = Duration::from_secs(10);

/// Runs the service on `session` until `shutdown` resolves, then stops taking input, lets the workers
/// finish, and closes the session.
pub async fn run(
    session: zenoh::Session,
    config: ServiceConfig,
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServiceError> {
    let publisher = session.clone();
    // Outputs are put from the worker threads (plain threads, so the synchronous `wait` is right);
    // `Block` applies back-pressure instead of silently dropping estimates. Not `express`: zenoh then
    // batches the messages that queue up while the link is busy (one write for many under load, the
    // same latency when idle) instead of a system call per message.
    let sink: Sink = Arc::new(move |key: &str, payload: Vec<u8>| {
        if let Err(e) = publisher
            .put(key, payload)
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(CongestionControl::Block)
            .wait()
        {
            tracing::warn!(key, error = %e, "put failed");
        }
    });
    let (outlets, estimates_watch) = estimate_outlets(
        &session,
        &Keys::new(&config.key_prefix).with_vehicles(&config.fleet.vehicles),
    )
    .await?;
    let (engine, threads) = Engine::start_with(config, sink, outlets)?;
    let keys = engine.keys.clone();

    let callback = {
        let ingest = threads.ingest.clone();
        let engine = engine.clone();
        move |sample: zenoh::sample::Sample| {
            let inbound = Inbound {
                key: sample.key_expr().as_str().to_string(),
                payload: sample.payload().to_bytes().into_owned(),
            };
            // Never block zenoh's thread: count what cannot be taken.
            if ingest.try_send(Some(inbound)).is_err() {
                engine
                    .counters
                    .ingest_overflow
                    .fetch_add(1, Ordering::Relaxed);
            }
        }
    };
    let gyro = session
        .declare_subscriber(keys.all(Leaf::Gyro))
        .callback(callback.clone())
        .await
        .map_err(zerr)?;
    let vectors = session
        .declare_subscriber(keys.all(Leaf::Vectors))
        .callback(callback.clone())
        .await
        .map_err(zerr)?;
    let imu = session
        .declare_subscriber(keys.all(Leaf::Imu))
        .callback(callback.clone())
        .await
        .map_err(zerr)?;
    // The ROS 2 edge (service.ros2): its inputs go through the same callback.
    let ros2 = match engine.ros2() {
        Some(edge) => {
            Some(ros2::net::start(&session, &engine, edge.clone(), callback.clone()).await?)
        }
        None => None,
    };
    // A dynamic fleet member also follows the others' estimates (where a takeover starts), then
    // joins: see `join_fleet`.
    let dynamic = engine.config.fleet.mode == fleet::FleetMode::Dynamic;
    let estimates = if dynamic {
        Some(
            session
                .declare_subscriber(keys.all(Leaf::Estimate))
                // (Not this instance's own estimates.)
                .allowed_origin(Locality::Remote)
                .callback(callback)
                .await
                .map_err(zerr)?,
        )
    } else {
        None
    };
    let q_attitude = session
        .declare_queryable(keys.all(Leaf::Attitude))
        .await
        .map_err(zerr)?;
    let q_covariance = session
        .declare_queryable(keys.all(Leaf::Covariance))
        .await
        .map_err(zerr)?;
    let q_state = session
        .declare_queryable(keys.all(Leaf::State))
        .await
        .map_err(zerr)?;
    let q_reset = session
        .declare_queryable(keys.all(Leaf::Reset))
        .await
        .map_err(zerr)?;
    let q_vehicles = session
        .declare_queryable(keys.vehicles())
        .await
        .map_err(zerr)?;
    let q_health = session
        .declare_queryable(keys.health())
        .await
        .map_err(zerr)?;
    let instance = engine.config.fleet.instance.clone();
    let q_instance_health = session
        .declare_queryable(keys.instance_health(&instance))
        .await
        .map_err(zerr)?;
    let q_instance_vehicles = session
        .declare_queryable(keys.instance_vehicles(&instance))
        .await
        .map_err(zerr)?;
    let q_metrics = session
        .declare_queryable(keys.metrics())
        .await
        .map_err(zerr)?;
    let q_instance_metrics = session
        .declare_queryable(keys.instance_metrics(&instance))
        .await
        .map_err(zerr)?;
    let membership = if dynamic {
        Some(join_fleet(&session, &engine, &threads.members).await?)
    } else {
        None
    };
    tracing::info!(
        prefix = keys.prefix(),
        instance = %instance,
        fleet = engine.config.fleet.mode.as_str(),
        vehicles = keys.vehicle_pattern(),
        "attitude-service running"
    );

    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            _ = &mut shutdown => break,
            Ok(q) = q_attitude.recv_async() => {
                per_vehicle(&engine, &q, Leaf::Attitude, |e, v| e.attitude_of(v).map(|a| json(&a))).await
            }
            Ok(q) = q_covariance.recv_async() => {
                per_vehicle(&engine, &q, Leaf::Covariance, |e, v| e.covariance_of(v).map(|c| json(&c))).await
            }
            Ok(q) = q_state.recv_async() => {
                per_vehicle(&engine, &q, Leaf::State, |e, v| e.state_of(v).map(|s| json(&*s))).await
            }
            Ok(q) = q_reset.recv_async() => {
                // A reset waits for the vehicle's worker: answer it in its own task.
                let engine = engine.clone();
                tokio::spawn(async move { reset(&engine, q).await });
            }
            // (Replies go on the concrete key: a get on P/@/instance/*/health gets one per instance.)
            Ok(q) = q_vehicles.recv_async() => vehicles(&engine, &q, &keys.vehicles()).await,
            Ok(q) = q_instance_vehicles.recv_async() => {
                vehicles(&engine, &q, &keys.instance_vehicles(&instance)).await
            }
            Ok(q) = q_health.recv_async() => health(&engine, &q, &keys.health()).await,
            Ok(q) = q_instance_health.recv_async() => {
                health(&engine, &q, &keys.instance_health(&instance)).await
            }
            Ok(q) = q_metrics.recv_async() => {
                metrics(&engine, threads.ingest.len(), &q, &keys.metrics()).await
            }
            Ok(q) = q_instance_metrics.recv_async() => {
                metrics(&engine, threads.ingest.len(), &q, &keys.instance_metrics(&instance)).await
            }
        }
    }
    tracing::info!("shutting down");
    // Stop taking input first, then let the workers finish (their last estimates are published),
    // then leave the fleet (the others take over from those estimates and replay what they kept
    // since), then close the session.
    let _ = gyro.undeclare().await;
    let _ = vectors.undeclare().await;
    let _ = imu.undeclare().await;
    if let Some(r) = ros2 {
        r.stop().await;
    }
    if let Some(e) = estimates {
        let _ = e.undeclare().await;
    }
    for q in [
        q_attitude,
        q_covariance,
        q_state,
        q_reset,
        q_vehicles,
        q_health,
        q_instance_health,
        q_instance_vehicles,
        q_metrics,
        q_instance_metrics,
    ] {
        let _ = q.undeclare().await;
    }
    let _ = tokio::task::spawn_blocking(move || threads.shutdown()).await;
    let _ = estimates_watch.undeclare().await;
    if let Some((token, watcher)) = membership {
        // (Lets the last estimates reach the others before the token's removal does.)
        tokio::time::sleep(Duration::from_millis(100)).await;
        let _ = watcher.undeclare().await;
        let _ = token.undeclare().await;
    }
    session.close().await.map_err(zerr)?;
    Ok(())
}

/// Each vehicle's estimates, put on `P/V/estimate` (its key checked once, not at every put) while
/// any subscriber of another session matches `P/*/estimate` (this session's own, a fleet member's
/// follower of the others' estimates, takes none of them): a publisher declared on that
/// wildcard, never put on, has its matching listener keep one flag, and while it is down the engine
/// does not serialise estimates (queries still answer the last one). One publisher for all: a
/// declared publisher per vehicle would give each vehicle's put its own cached route and match, but
/// zenoh 1.10 then resolves every other, undeclared key (every input the vehicles put) against all
/// those declarations, and the service's receiving thread drowned in it (BENCHMARKS.md, issue 15).
/// Puts block under congestion rather than drop.
pub async fn estimate_outlets(
    session: &zenoh::Session,
    keys: &keys::Keys,
) -> Result<(Outlets, zenoh::pubsub::Publisher<'static>), ServiceError> {
    struct Vehicle {
        session: zenoh::Session,
        key: KeyExpr<'static>,
        anyone: Arc<AtomicBool>,
    }
    impl EstimateOutlet for Vehicle {
        fn wanted(&self) -> bool {
            self.anyone.load(Ordering::Relaxed)
        }
        fn put(&self, payload: Vec<u8>) {
            let put = self
                .session
                .put(self.key.clone(), payload)
                .encoding(Encoding::APPLICATION_JSON)
                .congestion_control(CongestionControl::Block)
                .allowed_destination(Locality::Remote);
            if let Err(e) = put.wait() {
                tracing::warn!(key = %self.key, error = %e, "put failed");
            }
        }
    }
    let watch = session
        .declare_publisher(keys.all(Leaf::Estimate))
        .allowed_destination(Locality::Remote)
        .await
        .map_err(zerr)?;
    let anyone = Arc::new(AtomicBool::new(false));
    let flag = anyone.clone();
    // (Called at once with the current status when it matches, then at each change.)
    watch
        .matching_listener()
        .callback(move |s| flag.store(s.matching(), Ordering::Relaxed))
        .background()
        .await
        .map_err(zerr)?;
    let session = session.clone();
    let outlets: Outlets = Arc::new(move |key: &str| match KeyExpr::try_from(key.to_string()) {
        Ok(key) => Box::new(Vehicle {
            session: session.clone(),
            key,
            anyone: anyone.clone(),
        }) as Box<dyn EstimateOutlet>,
        Err(e) => {
            // (Vehicle ids are validated before a vehicle exists: not reached.)
            tracing::error!(key, error = %e, "not a key expression; its estimates are not put");
            Box::new(Nowhere)
        }
    });
    Ok((outlets, watch))
}

/// An outlet that nobody can reach.
struct Nowhere;

impl EstimateOutlet for Nowhere {
    fn wanted(&self) -> bool {
        false
    }
    fn put(&self, _: Vec<u8>) {}
}

/// The liveliness token that makes this instance a member, and the subscriber that follows the
/// others.
type Membership = (
    zenoh::liveliness::LivelinessToken,
    zenoh::pubsub::Subscriber<()>,
);

/// Joins the dynamic fleet: finds the live members and the vehicles' current estimates (so the
/// vehicles this instance takes start where their owners are), declares this instance's token, and
/// follows the members from then on. The engine releases and takes over vehicles on each change.
async fn join_fleet(
    session: &zenoh::Session,
    engine: &Arc<Engine>,
    members_tx: &crossbeam_channel::Sender<BTreeSet<String>>,
) -> Result<Membership, ServiceError> {
    let f = &engine.config.fleet;
    let keys = &engine.keys;
    let timeout = Duration::from_secs_f64(f.discovery_timeout_s);
    let members = Arc::new(std::sync::Mutex::new(BTreeSet::from([f.instance.clone()])));
    let replies = session
        .liveliness()
        .get(keys.fleet_members(&f.group))
        .timeout(timeout)
        .await
        .map_err(zerr)?;
    while let Ok(r) = replies.recv_async().await {
        if let Ok(sample) = r.result() {
            if let Some(name) = keys.member_of(&f.group, sample.key_expr().as_str()) {
                members
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .insert(name.to_string());
            }
        }
    }
    let others = members.lock().unwrap_or_else(|e| e.into_inner()).len() - 1;
    if others > 0 {
        // The current estimates of every vehicle: the starting points of what this instance takes.
        let replies = session
            .get(keys.all(Leaf::State))
            .consolidation(zenoh::query::ConsolidationMode::None)
            .timeout(timeout)
            .await
            .map_err(zerr)?;
        while let Ok(r) = replies.recv_async().await {
            if let Ok(sample) = r.result() {
                if let Some((vehicle, _)) = keys.split(sample.key_expr().as_str()) {
                    engine.remember_estimate(vehicle, &sample.payload().to_bytes());
                }
            }
        }
    }
    let token = session
        .liveliness()
        .declare_token(keys.fleet_member(&f.group, &f.instance))
        .await
        .map_err(zerr)?;
    let watcher = {
        let members = members.clone();
        let tx = members_tx.clone();
        let keys = keys.clone();
        let group = f.group.clone();
        let me = f.instance.clone();
        session
            .liveliness()
            .declare_subscriber(keys.fleet_members(&group))
            .history(true)
            .callback(move |sample: zenoh::sample::Sample| {
                let Some(name) = keys.member_of(&group, sample.key_expr().as_str()) else {
                    return;
                };
                let mut m = members.lock().unwrap_or_else(|e| e.into_inner());
                match sample.kind() {
                    zenoh::sample::SampleKind::Put => m.insert(name.to_string()),
                    zenoh::sample::SampleKind::Delete if name != me => m.remove(name),
                    _ => false,
                };
                let _ = tx.send(m.clone());
            })
            .await
            .map_err(zerr)?
    };
    let initial = members.lock().unwrap_or_else(|e| e.into_inner()).clone();
    tracing::info!(instance = %f.instance, members = ?initial, "joined the fleet");
    let _ = members_tx.send(initial);
    Ok((token, watcher))
}

async fn vehicles(engine: &Engine, q: &Query, key: &str) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    let list: Vec<_> = engine.vehicles().iter().map(|v| v.info()).collect();
    reply(q, key, json(&list)).await;
}

async fn health(engine: &Engine, q: &Query, key: &str) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    reply(q, key, json(&engine.health())).await;
}

/// `P/@/metrics`: encoded off the async runtime's threads (it walks every vehicle).
async fn metrics(engine: &Arc<Engine>, ingest_depth: usize, q: &Query, key: &str) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    let e = engine.clone();
    let text = tokio::task::spawn_blocking(move || e.metrics_text(ingest_depth))
        .await
        .unwrap_or_default();
    if let Err(e) = q
        .reply(key, text)
        .encoding(Encoding::from(METRICS_ENCODING))
        .await
    {
        tracing::warn!(key, error = %e, "reply failed");
    }
}

fn json<T: Serialize + ?Sized>(value: &T) -> Vec<u8> {
    serde_json::to_vec(value).unwrap_or_else(|e| {
        format!(r#"{{"code":"internal","message":"cannot serialise: {e}","key":""}}"#).into_bytes()
    })
}

async fn reply(q: &Query, key: &str, payload: Vec<u8>) {
    if let Err(e) = q
        .reply(key, payload)
        .encoding(Encoding::APPLICATION_JSON)
        .await
    {
        tracing::warn!(key, error = %e, "reply failed");
    }
}

async fn reply_err(q: &Query, r: &Rejection) {
    let msg: ErrorMsg = crate::wire::ToMessage::to_message(r, q.key_expr().as_str());
    if let Err(e) = q
        .reply_err(json(&msg))
        .encoding(Encoding::APPLICATION_JSON)
        .await
    {
        tracing::warn!(error = %e, "error reply failed");
    }
}

/// A get on `P/V/<leaf>`: one vehicle (an error when it is unknown or has no estimate), or, when the
/// vehicle chunk is a wildcard, one reply per matching vehicle that has an estimate, each on its
/// concrete key.
async fn per_vehicle(
    engine: &Engine,
    q: &Query,
    leaf: Leaf,
    answer: impl Fn(&Engine, &str) -> Result<Vec<u8>, Rejection>,
) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    let asked = q.key_expr().clone();
    if let Some((vehicle, _)) = engine.keys.split(asked.as_str()) {
        if !vehicle.contains(['*', '$']) {
            if !engine.owns(vehicle) {
                // Another member of the fleet answers (the query is finalised without a reply).
                return;
            }
            match answer(engine, vehicle) {
                Ok(payload) => reply(q, asked.as_str(), payload).await,
                Err(r) => {
                    engine.counters.reject(r.code);
                    reply_err(q, &r).await
                }
            }
            return;
        }
    }
    for v in engine.vehicles() {
        let key = engine.keys.vehicle(&v.id, leaf);
        let matches = KeyExpr::try_from(key.as_str())
            .map(|k| k.intersects(&asked))
            .unwrap_or(false);
        if matches {
            if let Ok(payload) = answer(engine, &v.id) {
                reply(q, &key, payload).await;
            }
        }
    }
}

async fn reset(engine: &Engine, q: Query) {
    let key = q.key_expr().as_str().to_string();
    // Another member of the fleet owns this vehicle and answers (a wildcard is refused by one).
    if let Some((vehicle, _)) = engine.keys.split(&key) {
        if !engine.owns(vehicle) {
            return;
        }
    }
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    let fail = |code: RejectCode, m: String| Rejection::new(code, m);
    let result: Result<Vec<u8>, Rejection> = async {
        let (vehicle, _) = engine
            .keys
            .split(&key)
            .filter(|(v, _)| !v.contains(['*', '$']))
            .ok_or_else(|| {
                fail(
                    RejectCode::BadRequest,
                    "reset one vehicle at a time: P/V/reset with a concrete V".into(),
                )
            })?;
        let req: ResetMsg = match q.payload() {
            Some(p) if !p.is_empty() => decode_one(&p.to_bytes(), &engine.config.limits.input)?,
            _ => ResetMsg::default(),
        };
        let rx = engine.request_reset(vehicle, req)?;
        match tokio::time::timeout(RESET_TIMEOUT, rx).await {
            Ok(Ok(Ok(reply))) => Ok(json(&reply)),
            Ok(Ok(Err(r))) => Err(r),
            Ok(Err(_)) | Err(_) => Err(fail(
                RejectCode::Internal,
                "the vehicle's worker did not answer the reset".into(),
            )),
        }
    }
    .await;
    match result {
        Ok(payload) => reply(&q, &key, payload).await,
        Err(r) => {
            engine.counters.reject(r.code);
            reply_err(&q, &r).await
        }
    }
}
