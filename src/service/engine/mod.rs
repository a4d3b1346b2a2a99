//! The service's machinery without the network: vehicle registry, counters, the dispatcher that
//! parses and routes inputs in arrival order, and the worker pool that runs the filters.
//!
//! Data flow: a zenoh subscriber callback only `try_send`s the raw sample into the bounded ingest
//! channel (a full channel is counted, never waited on) → one dispatcher thread decodes and validates
//! it (pure functions of `wire`) and appends the measurements to the vehicle's bounded inbox → the
//! vehicle is scheduled once on the worker pool → a worker drains its inbox through the vehicle's
//! filter and hands every output to the [`Sink`]. A vehicle is processed by one worker at a time, in
//! arrival order; a slow vehicle occupies one worker and never blocks the others.
//!
//! Files: this one (the types, start and restore, housekeeping, the registry and the workers),
//! `dispatch.rs` (the dispatcher: decoding and queueing), `output.rs` (estimates out: serialised once, only when someone subscribes; the vehicle's
//! row of `P/@/vehicles`), `fleet.rs` (routes: ownership, standby data, takeover, the owner's batches
//! of estimates), `queries.rs` (pure reads for the queryables).

mod dispatch;
mod fleet;
mod ingest;
mod metrics;
mod output;
mod queries;
mod ros2;

pub use fleet::RoutePlan;
pub use ingest::{Admission, Held, Ingest};

/// A route's estimates waiting for the next batch to its standby members: by vehicle, whether it is
/// new since the last batch and the serialised estimate.
type Outgoing = HashMap<String, (bool, Vec<u8>)>;
pub use metrics::METRICS_ENCODING;
pub use output::{EstimateOutlet, Outlets, Sink};

use super::config::ServiceConfig;
use super::fleet::{Assignment, FleetMode};
use super::keys::{parse_route, route_of, Keys, Leaf, Received, ROUTES};
use super::persist::{self, SavedCounters};
use crate::sensors::Measurement;
use crate::vehicle::{Event, ResetRequest, Stream, TakeoverSeed, VehicleState};
use crate::wire::batch::{self, BatchWriter};
use crate::wire::{
    decode_batch_into, validate_vehicle_id, AttitudeMsg, CheckpointHealthMsg, CovarianceMsg,
    EstimateMsg, FleetHealthMsg, GyroMsg, HealthMsg, ImuMsg, IngestHealthMsg, RejectCode,
    Rejection, ResetMsg, ResetReplyMsg, VectorsMsg, VehicleInfoMsg,
};
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::Instant;

/// A raw input as received.
#[derive(Clone)]
pub struct Inbound {
    pub key: String,
    pub payload: Vec<u8>,
}

/// What a vehicle's worker processes, in order. A measurement and a tick carry the engine time they
/// were queued at: the vehicle's wall clock is the time its inputs arrived, never the time a worker
/// got to them, so a slow worker or a busy machine releases nothing from a reorder window early.
enum Input {
    Measurement(Measurement, f64),
    Reset(
        ResetRequest,
        tokio::sync::oneshot::Sender<Result<ResetReplyMsg, Rejection>>,
    ),
    /// Release what the reorder window holds beyond its wall-time limit.
    Tick(f64),
}

/// Service-wide counters (atomics: read by queries without locks).
#[derive(Default)]
pub struct Counters {
    pub received: AtomicU64,
    pub processed: AtomicU64,
    pub estimates: AtomicU64,
    pub queries: AtomicU64,
    /// Inputs refused on arrival for want of room (each told on `P/V/rejected` as `queue_full`).
    pub ingest_overflow: AtomicU64,
    /// Puts of the vehicles' inputs that zenoh reported lost (`samples_missed`).
    pub missed: AtomicU64,
    rejected: [AtomicU64; RejectCode::ALL.len()],
    /// Checkpoints: vehicles restored and files skipped at start; files written and failed writes.
    pub restored: AtomicU64,
    pub skipped: AtomicU64,
    pub written: AtomicU64,
    pub write_failed: AtomicU64,
    /// Filter step times by filter kind (`P/@/metrics`).
    steps: metrics::StepTimes,
}

impl Counters {
    pub fn reject(&self, code: RejectCode) {
        let i = RejectCode::ALL.iter().position(|c| *c == code).unwrap_or(0);
        self.rejected[i].fetch_add(1, Ordering::Relaxed);
    }

    pub fn rejected_by_code(&self) -> BTreeMap<String, u64> {
        RejectCode::ALL
            .iter()
            .zip(&self.rejected)
            .map(|(c, n)| (c.as_str().to_string(), n.load(Ordering::Relaxed)))
            .filter(|(_, n)| *n > 0)
            .collect()
    }
}

/// One vehicle: its inbox, its filter state, and what queries read without waiting for the filter.
pub struct Vehicle {
    pub id: String,
    inbox: Mutex<VecDeque<Input>>,
    scheduled: AtomicBool,
    state: Mutex<VehicleState>,
    /// The last published estimate (queries read this, never the filter).
    snapshot: RwLock<Option<Arc<EstimateMsg>>>,
    info: output::Info,
    /// Where its estimates go (made at the first one).
    outlet: output::Outlet,
    received: AtomicU64,
    processed: AtomicU64,
    rejected: AtomicU64,
    /// This vehicle's refused inputs by code, reported in its estimates' diagnostics.
    rejected_by_code: Mutex<BTreeMap<String, u64>>,
    /// Samples in the reorder window, and whether a tick is already queued.
    held: AtomicUsize,
    tick_queued: AtomicBool,
    /// Gate, re-initialisation and rollback totals (for `P/@/health`).
    gated: AtomicU64,
    reinits: AtomicU64,
    rollbacks: AtomicU64,
    /// Late samples fused and the bytes of the history that lets it (for `P/@/health`).
    late_fused: AtomicU64,
    history_bytes: AtomicU64,
    /// Puts of its inputs zenoh reported lost (since it was created or restored).
    missed: AtomicU64,
    /// Gaps in its gyro or raw-IMU samples, and the µs the raw-IMU ones hid (`Totals`).
    gaps: AtomicU64,
    blind_us: AtomicU64,
    /// Restored from a checkpoint: the newest sample time of each stream it held (zenoh may deliver
    /// those samples again from the publishers' caches; `Engine::skip_redelivered`).
    restored_newest: Option<[Option<f64>; crate::vehicle::STREAMS]>,
    /// Changed since its last checkpoint.
    dirty: AtomicBool,
}

impl Vehicle {
    fn new(id: &str, state: VehicleState, counters: SavedCounters) -> Self {
        let info = output::Info::of(&state);
        let snapshot = state.estimate().map(|p| Arc::new(EstimateMsg::from(&p)));
        let v = Vehicle {
            id: id.to_string(),
            inbox: Mutex::new(VecDeque::new()),
            scheduled: AtomicBool::new(false),
            snapshot: RwLock::new(snapshot),
            info,
            outlet: output::Outlet::default(),
            received: AtomicU64::new(counters.received),
            processed: AtomicU64::new(counters.processed),
            rejected: AtomicU64::new(counters.rejected),
            rejected_by_code: Mutex::new(counters.rejected_by_code),
            held: AtomicUsize::new(0),
            tick_queued: AtomicBool::new(false),
            gated: AtomicU64::new(0),
            reinits: AtomicU64::new(0),
            rollbacks: AtomicU64::new(0),
            late_fused: AtomicU64::new(0),
            history_bytes: AtomicU64::new(0),
            missed: AtomicU64::new(0),
            gaps: AtomicU64::new(0),
            blind_us: AtomicU64::new(0),
            restored_newest: None,
            dirty: AtomicBool::new(false),
            state: Mutex::new(state),
        };
        {
            let state = v.state.lock().unwrap_or_else(|e| e.into_inner());
            v.refresh_totals(&state);
        }
        v
    }

    fn refresh_totals(&self, state: &VehicleState) {
        let t = state.totals();
        self.held.store(state.held(), Ordering::Relaxed);
        self.gated.store(t.gated, Ordering::Relaxed);
        self.reinits.store(t.reinits, Ordering::Relaxed);
        self.rollbacks.store(t.rollbacks, Ordering::Relaxed);
        self.late_fused.store(t.late_fused, Ordering::Relaxed);
        self.history_bytes
            .store(t.history_bytes as u64, Ordering::Relaxed);
        self.gaps.store(t.gaps, Ordering::Relaxed);
        self.blind_us
            .store((t.blind_s * 1e6) as u64, Ordering::Relaxed);
    }

    fn counters(&self) -> SavedCounters {
        SavedCounters {
            received: self.received.load(Ordering::Relaxed),
            processed: self.processed.load(Ordering::Relaxed),
            rejected: self.rejected.load(Ordering::Relaxed),
            rejected_by_code: self
                .rejected_by_code
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .clone(),
        }
    }

    pub fn snapshot(&self) -> Option<Arc<EstimateMsg>> {
        self.snapshot.read().map(|s| s.clone()).unwrap_or(None)
    }

    pub fn info(&self) -> VehicleInfoMsg {
        let mut info = self.info.message(&self.id);
        info.received = self.received.load(Ordering::Relaxed);
        info.processed = self.processed.load(Ordering::Relaxed);
        info.rejected = self.rejected.load(Ordering::Relaxed);
        info
    }
}

fn refresh_info(v: &Vehicle, state: &VehicleState) {
    v.info.refresh(state);
}

/// Inputs a worker takes from one vehicle before giving other vehicles a turn.
const TURN: usize = 256;
/// ... and at most this long, s: a vehicle with a heavy filter (a particle filter of 10⁵ particles
/// steps in milliseconds) and a backlog must not hold a worker for hundreds of its steps.
const TURN_S: f64 = 0.005;

/// The engine shared by the dispatcher, the workers and the query handlers.
pub struct Engine {
    pub config: Arc<ServiceConfig>,
    pub keys: Keys,
    pub counters: Counters,
    started: Instant,
    vehicles: RwLock<HashMap<String, Arc<Vehicle>>>,
    /// `None` tells a worker to stop.
    work_tx: crossbeam_channel::Sender<Option<Arc<Vehicle>>>,
    sink: Sink,
    outlets: Outlets,
    /// Serialises checkpoint writers (the housekeeping thread and the shutdown).
    checkpointing: Mutex<()>,
    fleet: FleetState,
    /// `P/<shard>/x` when statically sharded (`fleet.vehicles` other than `*`).
    shard: Option<zenoh::key_expr::OwnedKeyExpr>,
    /// The ROS 2 edge, when `service.ros2` enables it.
    ros2: Option<Arc<super::ros2::Edge>>,
    /// The subscribers' side of the ingest channel, and the channel (its depth, for `P/@/health`).
    pub admission: Admission,
    ingest_depth: crossbeam_channel::Receiver<Option<Ingest>>,
}

/// What this instance knows of the rest of its fleet (dynamic mode).
#[derive(Default)]
struct FleetState {
    /// The live members (this instance among them); `None` until first known: nothing is owned
    /// before, so a starting instance never processes what another member owns.
    members: RwLock<Option<BTreeSet<String>>>,
    /// The routes' owners and holders for `members`.
    assignment: RwLock<Option<Arc<Assignment>>>,
    /// Before joining: the assignment once this instance has joined. It holds (keeps the standby
    /// data of) the routes it will hold, and owns nothing yet.
    prepared: RwLock<Option<Arc<Assignment>>>,
    /// Estimates read before a takeover (at start, or the last of a vehicle released), parsed.
    cache: Mutex<HashMap<String, Arc<EstimateMsg>>>,
    /// Inputs received one by one for vehicles of routes held but not owned (plain keys, which
    /// every member receives, or a routed input during a change of owner), with their arrival
    /// (engine time, s), for `fleet.standby_s`.
    standby: Mutex<HashMap<String, VecDeque<(f64, Inbound)>>>,
    /// Per route: its standby data (the senders' batches of its inputs, its owner's last estimates)
    /// while held, and after a takeover the inputs already used.
    routes: Mutex<Vec<fleet::RouteStandby>>,
    /// Per route owned: each vehicle's last estimate, and whether it was published since the last
    /// batch to the route's standby members.
    outgoing: Mutex<Vec<Outgoing>>,
    /// The routes to subscribe to, for the service (`service::run`).
    plan: Option<tokio::sync::watch::Sender<RoutePlan>>,
    takeovers: AtomicU64,
    released: AtomicU64,
    /// Standby batches that could not be read.
    malformed: AtomicU64,
}

/// The running threads of an engine.
pub struct EngineThreads {
    /// Where subscriber callbacks hand raw samples (through [`Admission::offer`]); `None` stops the
    /// dispatcher.
    pub ingest: crossbeam_channel::Sender<Option<Ingest>>,
    /// The live members of the fleet, whenever they change (dynamic mode); handled by the dispatcher
    /// in order with the inputs.
    pub members: crossbeam_channel::Sender<BTreeSet<String>>,
    dispatcher: std::thread::JoinHandle<()>,
    workers: Vec<std::thread::JoinHandle<()>>,
    housekeeping: std::thread::JoinHandle<()>,
    stop_housekeeping: crossbeam_channel::Sender<()>,
    engine: Arc<Engine>,
}

impl EngineThreads {
    /// Stops the dispatcher after the inputs already received, then the workers after the vehicles
    /// already scheduled, then processes whatever is still in any inbox, so nothing accepted is lost,
    /// and writes a last checkpoint of every vehicle that changed (samples still in a reorder window
    /// are part of it).
    pub fn shutdown(self) {
        let _ = self.stop_housekeeping.send(());
        let _ = self.housekeeping.join();
        let _ = self.ingest.send(None);
        let _ = self.dispatcher.join();
        for _ in &self.workers {
            let _ = self.engine.work_tx.send(None);
        }
        for h in self.workers {
            let _ = h.join();
        }
        for v in self.engine.vehicles() {
            while !v.inbox.lock().unwrap_or_else(|e| e.into_inner()).is_empty() {
                self.engine.work(&v, &mut Vec::new());
            }
        }
        // The last estimates reach the standby members before this instance leaves.
        self.engine.flush_estimates();
        self.engine.checkpoint_all();
    }
}

/// How often the housekeeping thread releases reorder windows by wall time, s.
const TICK_S: f64 = 0.01;

/// Capacity of the channel between the subscriber callbacks and the dispatcher.
pub const INGEST_CAPACITY: usize = 1 << 16;

impl Engine {
    /// [`Engine::start_with`] where every estimate is wanted and goes to `sink` too.
    pub fn start(
        config: ServiceConfig,
        sink: Sink,
    ) -> Result<(Arc<Engine>, EngineThreads), persist::CheckpointError> {
        let outlets = output::sink_outlets(&sink);
        Engine::start_with(config, sink, outlets)
    }

    /// Restores the vehicles checkpointed in the state directory (if one is configured; it is
    /// created when missing), then starts the dispatcher, `config.workers` worker threads and the
    /// housekeeping thread (reorder-window ticks, periodic checkpoints). Estimates go to each
    /// vehicle's outlet of `outlets`, everything else to `sink`. Only an unusable state directory is
    /// an error; a bad checkpoint file is reported and skipped.
    pub fn start_with(
        config: ServiceConfig,
        sink: Sink,
        outlets: Outlets,
    ) -> Result<(Arc<Engine>, EngineThreads), persist::CheckpointError> {
        let (work_tx, work_rx) = crossbeam_channel::unbounded::<Option<Arc<Vehicle>>>();
        let (ingest_tx, ingest_rx) = crossbeam_channel::bounded::<Option<Ingest>>(INGEST_CAPACITY);
        let (members_tx, members_rx) = crossbeam_channel::unbounded::<BTreeSet<String>>();
        let workers = config.workers.max(1);
        let keys = Keys::new(&config.key_prefix).with_vehicles(&config.fleet.vehicles);
        let shard = (config.fleet.vehicles != "*")
            .then(|| zenoh::key_expr::OwnedKeyExpr::try_from(keys.all(Leaf::Gyro)).ok())
            .flatten();
        let ros2 = config.ros2.enabled.then(|| {
            Arc::new(super::ros2::Edge::new(
                config.ros2.clone(),
                config.limits.max_vehicles,
            ))
        });
        let fleet = FleetState {
            routes: Mutex::new((0..ROUTES).map(|_| Default::default()).collect()),
            outgoing: Mutex::new((0..ROUTES).map(|_| Default::default()).collect()),
            plan: (config.fleet.mode == FleetMode::Dynamic)
                .then(|| tokio::sync::watch::Sender::new(RoutePlan::default())),
            ..Default::default()
        };
        let admission = Admission::new(&config.ingest);
        let engine = Arc::new(Engine {
            keys,
            shard,
            ros2,
            fleet,
            config: Arc::new(config),
            counters: Counters::default(),
            started: Instant::now(),
            vehicles: RwLock::new(HashMap::new()),
            work_tx,
            sink,
            outlets,
            checkpointing: Mutex::new(()),
            admission,
            ingest_depth: ingest_rx.clone(),
        });
        engine.restore()?;
        let dispatcher = {
            let engine = engine.clone();
            std::thread::Builder::new()
                .name("attitude-dispatch".into())
                .spawn(move || engine.dispatcher(ingest_rx, members_rx))
                .expect("spawn the dispatcher thread")
        };
        let workers = (0..workers)
            .map(|i| {
                let engine = engine.clone();
                let rx = work_rx.clone();
                std::thread::Builder::new()
                    .name(format!("attitude-worker-{i}"))
                    .spawn(move || {
                        // (The events' buffer is the worker's: no allocation per turn.)
                        let mut events = Vec::new();
                        while let Ok(Some(vehicle)) = rx.recv() {
                            engine.work(&vehicle, &mut events);
                        }
                    })
                    .expect("spawn a worker thread")
            })
            .collect();
        let (stop_housekeeping, stop_rx) = crossbeam_channel::bounded::<()>(1);
        let housekeeping = {
            let engine = engine.clone();
            std::thread::Builder::new()
                .name("attitude-housekeeping".into())
                .spawn(move || engine.housekeeping(stop_rx))
                .expect("spawn the housekeeping thread")
        };
        Ok((
            engine.clone(),
            EngineThreads {
                ingest: ingest_tx,
                members: members_tx,
                dispatcher,
                workers,
                housekeeping,
                stop_housekeeping,
                engine,
            },
        ))
    }

    fn now_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// Loads every checkpoint of the state directory.
    fn restore(&self) -> Result<(), persist::CheckpointError> {
        let Some(dir) = &self.config.persistence.state_dir else {
            return Ok(());
        };
        std::fs::create_dir_all(dir).map_err(|e| persist::CheckpointError::Io {
            path: dir.display().to_string(),
            message: e.to_string(),
        })?;
        let (good, bad) = persist::load_dir(dir)?;
        for e in &bad {
            tracing::error!(error = %e, "checkpoint skipped");
        }
        self.counters
            .skipped
            .fetch_add(bad.len() as u64, Ordering::Relaxed);
        let mut map = self.vehicles.write().unwrap_or_else(|e| e.into_inner());
        for c in good {
            let id = c.state.id().to_string();
            if map.len() >= self.config.limits.max_vehicles {
                tracing::error!(vehicle = %id, "checkpoint skipped: limits.max_vehicles reached");
                self.counters.skipped.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            if validate_vehicle_id(&id).is_err() {
                self.counters.skipped.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            let newest = c.state.snapshot().newest;
            let mut v = Vehicle::new(&id, c.state, c.counters);
            v.restored_newest = Some(newest);
            map.insert(id.clone(), Arc::new(v));
            self.counters.restored.fetch_add(1, Ordering::Relaxed);
        }
        tracing::info!(
            dir = %dir.display(),
            restored = map.len(),
            skipped = bad.len(),
            "vehicles restored from checkpoints"
        );
        Ok(())
    }

    /// Ticks the reorder windows that hold samples, and checkpoints every interval, until stopped.
    fn housekeeping(&self, stop: crossbeam_channel::Receiver<()>) {
        let interval = self.config.persistence.checkpoint_interval_s;
        let mut next_checkpoint = self.now_s() + interval;
        let mut next_trim = self.now_s() + 1.0;
        let flush = self.config.fleet.flush_s;
        let mut next_flush = self.now_s() + flush;
        let tick = std::time::Duration::from_secs_f64(TICK_S);
        loop {
            match stop.recv_timeout(tick) {
                Err(crossbeam_channel::RecvTimeoutError::Timeout) => {}
                _ => return,
            }
            // (Every 10 ms: only the vehicles that hold samples, neither sorted nor all cloned.)
            let holding: Vec<Arc<Vehicle>> = self
                .vehicles
                .read()
                .map(|m| {
                    m.values()
                        .filter(|v| v.held.load(Ordering::Relaxed) > 0)
                        .cloned()
                        .collect()
                })
                .unwrap_or_default();
            for v in holding {
                if !v.tick_queued.swap(true, Ordering::AcqRel) {
                    let mut inbox = v.inbox.lock().unwrap_or_else(|e| e.into_inner());
                    // (Stamped under the inbox's lock: stamps never go back along an inbox.)
                    inbox.push_back(Input::Tick(self.now_s()));
                    drop(inbox);
                    self.schedule(&v);
                }
            }
            if self.now_s() >= next_flush {
                self.flush_estimates();
                next_flush = self.now_s() + flush;
            }
            if self.now_s() >= next_trim {
                self.trim_standby();
                next_trim = self.now_s() + 1.0;
            }
            if self.now_s() >= next_checkpoint {
                self.checkpoint_all();
                next_checkpoint = self.now_s() + interval;
            }
        }
    }

    /// Writes a checkpoint of every vehicle that changed since its last one.
    pub fn checkpoint_all(&self) {
        let Some(dir) = &self.config.persistence.state_dir else {
            return;
        };
        let _one_writer = self.checkpointing.lock().unwrap_or_else(|e| e.into_inner());
        for v in self.vehicles() {
            if !v.dirty.swap(false, Ordering::AcqRel) {
                continue;
            }
            // Encoded under the vehicle's lock (a consistent state), written outside it.
            let bytes = {
                let state = v.state.lock().unwrap_or_else(|e| e.into_inner());
                persist::encode(&state, &v.counters())
            };
            let result = bytes
                .map_err(|m| m.to_string())
                .and_then(|b| persist::write_atomic(dir, &v.id, &b).map_err(|e| e.to_string()));
            match result {
                Ok(()) => {
                    self.counters.written.fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => {
                    self.counters.write_failed.fetch_add(1, Ordering::Relaxed);
                    v.dirty.store(true, Ordering::Release);
                    tracing::error!(vehicle = %v.id, error = %e, "checkpoint failed");
                }
            }
        }
    }

    pub fn uptime_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    pub fn vehicle(&self, id: &str) -> Option<Arc<Vehicle>> {
        self.vehicles.read().ok()?.get(id).cloned()
    }

    /// Every vehicle, sorted by id.
    pub fn vehicles(&self) -> Vec<Arc<Vehicle>> {
        let mut v: Vec<Arc<Vehicle>> = self
            .vehicles
            .read()
            .map(|m| m.values().cloned().collect())
            .unwrap_or_default();
        v.sort_by(|a, b| a.id.cmp(&b.id));
        v
    }

    fn get_or_create(&self, id: &str) -> Result<Arc<Vehicle>, Rejection> {
        if let Some(v) = self.vehicle(id) {
            return Ok(v);
        }
        let mut map = self.vehicles.write().unwrap_or_else(|e| e.into_inner());
        if let Some(v) = map.get(id) {
            return Ok(v.clone());
        }
        if map.len() >= self.config.limits.max_vehicles {
            return Err(Rejection::new(
                RejectCode::TooManyVehicles,
                format!(
                    "the service tracks its maximum of {} vehicles",
                    self.config.limits.max_vehicles
                ),
            ));
        }
        let state = VehicleState::new(id, self.config.filter_for(id).clone());
        let v = Arc::new(Vehicle::new(id, state, SavedCounters::default()));
        map.insert(id.to_string(), v.clone());
        tracing::info!(vehicle = id, "new vehicle");
        Ok(v)
    }

    /// Publishes `r` on `P/V/rejected` without counting it as a rejection (a gap: the sample was used).
    fn tell_only(&self, vehicle: &str, key: &str, r: &Rejection) {
        tracing::debug!(key, code = r.code.as_str(), message = %r.message, "told");
        let msg = crate::wire::ToMessage::to_message(r, key);
        if let Ok(payload) = serde_json::to_vec(&msg) {
            (self.sink)(&self.keys.vehicle(vehicle, Leaf::Rejected), payload);
        }
    }

    /// Publishes a rejection on `P/V/rejected` and counts it.
    pub fn reject(&self, vehicle: &str, key: &str, r: &Rejection) {
        self.counters.reject(r.code);
        if let Some(v) = self.vehicle(vehicle) {
            v.rejected.fetch_add(1, Ordering::Relaxed);
            *v.rejected_by_code
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .entry(r.code.as_str().to_string())
                .or_insert(0) += 1;
        }
        tracing::debug!(key, code = r.code.as_str(), message = %r.message, "rejected");
        let msg = crate::wire::ToMessage::to_message(r, key);
        let to = if vehicle.contains(['*', '$']) {
            self.keys.rejected_wildcard()
        } else {
            self.keys.vehicle(vehicle, Leaf::Rejected)
        };
        if let Ok(payload) = serde_json::to_vec(&msg) {
            (self.sink)(&to, payload);
        }
    }

    fn schedule(&self, v: &Arc<Vehicle>) {
        if !v.scheduled.swap(true, Ordering::AcqRel) {
            let _ = self.work_tx.send(Some(v.clone()));
        }
    }

    /// Queues a reset for `vehicle` (creating it) and returns the channel its reply arrives on.
    pub fn request_reset(
        &self,
        vehicle: &str,
        req: ResetMsg,
    ) -> Result<tokio::sync::oneshot::Receiver<Result<ResetReplyMsg, Rejection>>, Rejection> {
        validate_vehicle_id(vehicle)?;
        // The request's values are validated once, here; what depends on the vehicle's filter and the
        // limits is checked where it is applied (`VehicleState::on_reset`).
        let request = ResetRequest::try_from(&req)?;
        if self.vehicle(vehicle).is_none() {
            // A refused reset must not create the vehicle: a new vehicle runs its configured filter.
            let config = self.config.filter_for(vehicle);
            request.config_for(config, config, &self.config.policy)?;
        }
        let v = self.get_or_create(vehicle)?;
        let (tx, rx) = tokio::sync::oneshot::channel();
        v.inbox
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push_back(Input::Reset(request, tx));
        self.schedule(&v);
        Ok(rx)
    }

    /// Drains a vehicle's inbox through its filter (a worker thread).
    fn work(&self, v: &Arc<Vehicle>, events: &mut Vec<Event>) {
        let policy = &self.config.policy;
        events.clear();
        {
            let mut state = v.state.lock().unwrap_or_else(|e| e.into_inner());
            let turn_ends = self.now_s() + TURN_S;
            for _ in 0..TURN {
                if self.now_s() > turn_ends {
                    break;
                }
                let next = v
                    .inbox
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .pop_front();
                let Some(input) = next else { break };
                v.dirty.store(true, Ordering::Release);
                match input {
                    Input::Measurement(m, now) => {
                        let stream = crate::vehicle::stream_of(&m);
                        let result = self.timed(&mut state, events, |s, e| {
                            s.on_measurement(m, now, policy, e)
                        });
                        if let Err(r) = result {
                            self.reject(&v.id, &self.stream_key(&v.id, stream), &r);
                        }
                        self.handle(v, &state, events);
                    }
                    Input::Tick(now) => {
                        v.tick_queued.store(false, Ordering::Release);
                        self.timed(&mut state, events, |s, e| s.on_tick(now, policy, e));
                        self.handle(v, &state, events);
                    }
                    Input::Reset(req, reply) => {
                        let base = self.config.filter_for(&v.id).clone();
                        let result = state.on_reset(&req, &base, policy, events);
                        // What the reorder window still held is used first.
                        self.handle(v, &state, events);
                        // (A refused reset is counted by the query handler that answers it.)
                        refresh_info(v, &state);
                        let result = result.map(|outcome| {
                            let reply = ResetReplyMsg::from(outcome);
                            *v.snapshot.write().unwrap_or_else(|e| e.into_inner()) =
                                reply.estimate.clone().map(Arc::new);
                            if let Some(e) = &reply.estimate {
                                self.publish_estimate(v, e.clone());
                            }
                            reply
                        });
                        let _ = reply.send(result);
                    }
                }
            }
            refresh_info(v, &state);
            v.refresh_totals(&state);
        }
        v.scheduled.store(false, Ordering::Release);
        let pending = !v.inbox.lock().unwrap_or_else(|e| e.into_inner()).is_empty();
        if pending {
            self.schedule(v);
        }
    }

    fn stream_key(&self, vehicle: &str, stream: Stream) -> String {
        self.keys.vehicle(
            vehicle,
            match stream {
                Stream::Gyro => Leaf::Gyro,
                Stream::Vectors => Leaf::Vectors,
                Stream::Imu => Leaf::Imu,
            },
        )
    }

    /// Counts, refuses and publishes what the vehicle's samples produced.
    fn handle(&self, v: &Arc<Vehicle>, state: &VehicleState, events: &mut Vec<Event>) {
        for event in events.drain(..) {
            match event {
                Event::Processed(_) => {
                    v.processed.fetch_add(1, Ordering::Relaxed);
                    self.counters.processed.fetch_add(1, Ordering::Relaxed);
                }
                Event::Rejected(stream, r) => {
                    self.reject(&v.id, &self.stream_key(&v.id, stream), &r)
                }
                // Not a refusal: told, and counted as a gap (`Totals`), not as a rejection.
                Event::Gap(stream, r) => self.tell_only(&v.id, &self.stream_key(&v.id, stream), &r),
                Event::Estimate(p) => {
                    // What a subscriber sees must agree with P/@/vehicles at once.
                    refresh_info(v, state);
                    self.publish_estimate(v, EstimateMsg::from(p));
                }
            }
        }
    }
}
