//! The network service: zenoh subscribers and queryables around the [`engine::Engine`].
//!
//! `run(session, config, shutdown)` is the whole service: one `select!` loop over the queryables and
//! the shutdown signal. Subscriber callbacks only hand raw samples to the engine's bounded ingest
//! channel; filters run on the engine's worker threads, never on zenoh's threads or the async runtime.

pub mod config;
pub mod engine;
pub mod fleet;
pub mod ingest;
pub mod keys;
pub mod persist;
pub mod ros2;
pub mod session;
/// One vehicle (the state machine of the numeric core).
pub use attitude_core::vehicle;

use crate::wire::{decode_one, ErrorMsg, RejectCode, Rejection, ResetMsg};
use config::ServiceConfig;
use engine::{Engine, EstimateOutlet, Outlets, RoutePlan, Sink, METRICS_ENCODING};
use keys::{route_of, Keys, Leaf, ROUTES};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
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

/// A flag that says whether any subscriber matches `publisher` (a publisher declared for this alone,
/// never put on): work for an outlet nobody listens to is skipped.
pub(crate) async fn matching_flag(
    publisher: &zenoh::pubsub::Publisher<'_>,
) -> Result<Arc<AtomicBool>, ServiceError> {
    let anyone = Arc::new(AtomicBool::new(false));
    let flag = anyone.clone();
    // (Called at once with the current status when it matches, then at each change.)
    publisher
        .matching_listener()
        .callback(move |s| flag.store(s.matching(), Ordering::Relaxed))
        .background()
        .await
        .map_err(zerr)?;
    Ok(anyone)
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
    let sink_keys = Keys::new(&config.key_prefix);
    // Outputs are put from the worker threads (plain threads, so the synchronous `wait` is right);
    // `Block` applies back-pressure instead of silently dropping estimates. Not `express`: zenoh then
    // batches the messages that queue up while the link is busy (one write for many under load, the
    // same latency when idle) instead of a system call per message. Rejections are JSON; a fleet
    // owner's batches of estimates for its standby members are binary (`wire::batch`).
    let sink: Sink = Arc::new(move |key: &str, payload: Vec<u8>| {
        let encoding = if sink_keys.is_standby(key) {
            Encoding::APPLICATION_OCTET_STREAM
        } else {
            Encoding::APPLICATION_JSON
        };
        if let Err(e) = publisher
            .put(key, payload)
            .encoding(encoding)
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

    // The inputs (`service::ingest`): AdvancedSubscribers for the publishers that number their
    // samples, plain subscribers for the others; every callback hands the raw sample to the engine.
    let intake = ingest::Intake::new(engine.clone(), threads.ingest.clone(), &session);
    let callback = {
        let intake = intake.clone();
        move |sample: zenoh::sample::Sample| intake.plain(sample)
    };
    let inputs = ingest::InputSubscriptions::declare(
        &session,
        &[Leaf::Gyro, Leaf::Vectors, Leaf::Imu].map(|l| keys.all(l)),
        &engine.config.ingest,
        &intake,
    )
    .await?;
    // The ROS 2 edge (service.ros2): its inputs go through the same callback. (Not routed: every
    // member of a fleet receives them, and the owner of the vehicle uses them.)
    let ros2 = match engine.ros2() {
        Some(edge) => {
            Some(ros2::net::start(&session, &engine, edge.clone(), callback.clone()).await?)
        }
        None => None,
    };
    // Routed inputs (`P/V/<leaf>/<r>`): a single instance takes every route; a member of a dynamic
    // fleet the routes it owns, and the standby batches of those it keeps, as they change (see
    // `join_fleet`).
    let dynamic = engine.config.fleet.mode == fleet::FleetMode::Dynamic;
    let mut routing = Routing::new(keys.clone(), callback.clone());
    if !dynamic {
        let served = RoutePlan {
            owned: (0..ROUTES as u8).filter(|&r| engine.serves(r)).collect(),
            standby: Vec::new(),
        };
        routing.apply(&session, &served).await?;
    }
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
    // (Following the route plan before joining: the first change after the join comes from the
    // members' thread at any moment, and a receiver made after it would take it as seen, leaving the
    // routes taken over without their input subscriptions until the next change.)
    let mut plan = engine.route_plan();
    let membership = if dynamic {
        Some(join_fleet(&session, &engine, &threads.members, &mut routing).await?)
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
            Ok(()) = async {
                match plan.as_mut() {
                    Some(p) => p.changed().await,
                    None => std::future::pending().await,
                }
            } => {
                let now = plan.as_mut().map(|p| p.borrow_and_update().clone()).unwrap_or_default();
                // (A declaration that fails now is tried again at the next change; the batches of a
                // route cover its inputs meanwhile.)
                if let Err(e) = routing.apply(&session, &now).await {
                    tracing::error!(error = %e, "route subscriptions not updated");
                }
            }
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
    inputs.undeclare().await;
    if let Some(r) = ros2 {
        r.stop().await;
    }
    routing.close().await;
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
    let anyone = matching_flag(&watch).await?;
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

/// The subscriptions that follow the routes: the routed inputs of each route owned (one for all when
/// every route is), the standby batches of each route kept (one for all when more than half are).
struct Routing<F> {
    keys: Keys,
    callback: F,
    /// By route; `None`: every route.
    owned: BTreeMap<Option<u8>, zenoh::pubsub::Subscriber<()>>,
    standby: BTreeMap<Option<u8>, zenoh::pubsub::Subscriber<()>>,
}

impl<F> Routing<F>
where
    F: Fn(zenoh::sample::Sample) + Clone + Send + Sync + 'static,
{
    fn new(keys: Keys, callback: F) -> Self {
        Routing {
            keys,
            callback,
            owned: BTreeMap::new(),
            standby: BTreeMap::new(),
        }
    }

    /// Subscribes to what `plan` needs and no more: the new subscriptions first, then the old ones
    /// undeclared, so that nothing in both is missed in between.
    async fn apply(
        &mut self,
        session: &zenoh::Session,
        plan: &RoutePlan,
    ) -> Result<(), ServiceError> {
        let want = |routes: &[u8], all_when: usize| -> BTreeSet<Option<u8>> {
            if routes.is_empty() {
                BTreeSet::new()
            } else if routes.len() >= all_when {
                BTreeSet::from([None])
            } else {
                routes.iter().map(|&r| Some(r)).collect()
            }
        };
        // (Every subscription of a session is matched against every sample it receives, so fewer is
        // cheaper; but a route's batches carry all its inputs, so taking those of routes not kept
        // costs more than it saves unless few are (measured: scripts/fleet-cpu.py). A member keeping
        // more than half of the routes takes every route's batches and drops the others; each
        // route's inputs stay on their own subscription.)
        let owned = want(&plan.owned, ROUTES);
        let standby = want(&plan.standby, ROUTES / 2 + 1);
        for (wanted, have, standby_batches) in [
            (&owned, &mut self.owned, false),
            (&standby, &mut self.standby, true),
        ] {
            for &r in wanted {
                if have.contains_key(&r) {
                    continue;
                }
                let key = if standby_batches {
                    self.keys.standby(r)
                } else {
                    self.keys.routed_inputs(r)
                };
                let sub = session
                    .declare_subscriber(key)
                    // (Not this instance's own batches of estimates.)
                    .allowed_origin(Locality::Remote)
                    .callback(self.callback.clone())
                    .await
                    .map_err(zerr)?;
                have.insert(r, sub);
            }
            let gone: Vec<Option<u8>> = have
                .keys()
                .filter(|r| !wanted.contains(r))
                .copied()
                .collect();
            for r in gone {
                if let Some(sub) = have.remove(&r) {
                    let _ = sub.undeclare().await;
                }
            }
        }
        tracing::debug!(owned = ?plan.owned, standby = ?plan.standby, "route subscriptions");
        Ok(())
    }

    async fn close(self) {
        for (_, sub) in self.owned.into_iter().chain(self.standby) {
            let _ = sub.undeclare().await;
        }
    }
}

/// The liveliness token that makes this instance a member, and the subscriber that follows the
/// others.
type Membership = (
    zenoh::liveliness::LivelinessToken,
    zenoh::pubsub::Subscriber<()>,
);

/// Joins the dynamic fleet: finds the live members, subscribes to what it will own and hold once it
/// has joined, reads the current estimates of those routes' vehicles (so the vehicles it takes start
/// where their owners are), declares this instance's token, and follows the members from then on.
/// The engine releases and takes over routes on each change.
async fn join_fleet<F>(
    session: &zenoh::Session,
    engine: &Arc<Engine>,
    members_tx: &crossbeam_channel::Sender<BTreeSet<String>>,
    routing: &mut Routing<F>,
) -> Result<Membership, ServiceError>
where
    F: Fn(zenoh::sample::Sample) + Clone + Send + Sync + 'static,
{
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
    // What this instance will own and hold: subscribed to (and kept) from now on.
    let joining = members.lock().unwrap_or_else(|e| e.into_inner()).clone();
    engine.prepare(&joining);
    if let Some(plan) = engine.route_plan() {
        let plan = plan.borrow().clone();
        routing.apply(session, &plan).await?;
    }
    if joining.len() > 1 {
        // The current estimates of the vehicles of the routes it will hold: the starting points of
        // what it takes.
        let held: Vec<u8> = fleet::Assignment::of_routes(&joining, f.routes)
            .map(|a| a.held_by(&f.instance))
            .unwrap_or_default()
            .into_iter()
            .filter(|&r| engine.serves(r))
            .collect();
        let replies = session
            .get(keys.states_of_routes(&held))
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
    // `?routes=07a`: only the vehicles of these routes (a joining fleet member's get).
    let routes: Option<Vec<u8>> = q.parameters().get("routes").map(|s| {
        s.chars()
            .filter_map(|c| keys::parse_route(&c.to_string()))
            .collect()
    });
    for v in engine.vehicles() {
        if routes
            .as_ref()
            .is_some_and(|r| !r.contains(&route_of(&v.id)))
        {
            continue;
        }
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
