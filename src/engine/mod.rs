//! The engine: the vehicles without the network. A registry of vehicles, each with a bounded inbox;
//! one dispatcher thread that decodes the inputs in arrival order and queues them on their vehicle's
//! inbox; a worker pool that drains one vehicle at a time through its filter and publishes what it
//! gives; a housekeeping thread (reorder-window ticks, periodic checkpoints).
//!
//! Data flow: a zenoh subscriber callback only hands the raw sample to the bounded ingest channel
//! ([`Admission::offer`]) → the dispatcher decodes and validates it (pure functions of `wire`) and
//! appends the measurements to the vehicle's bounded inbox → the vehicle is scheduled once on the
//! worker pool → a worker drains its inbox through the vehicle's filter and hands every estimate to
//! the vehicle's [`EstimateOutlet`], everything else to the [`Sink`]. A vehicle is processed by one
//! worker at a time, in arrival order; a slow vehicle occupies one worker and never blocks the others.
//!
//! The engine knows neither zenoh nor the features around it: a fleet and the ROS 2 edge reach it only
//! through its [`Hooks`] (who owns a vehicle, what a standby keeps, what happens to an estimate),
//! which the wiring (`service::Node`) plugs in, and through the operations it offers them
//! ([`Engine::accept`], [`Engine::queue`], [`Engine::adopt`], [`Engine::release`]) and the tasks it
//! runs on its dispatcher thread in order with the inputs ([`EngineThreads::tasks`]).
//!
//! Files: this one (the engine, its hooks, start and restore, the workers, housekeeping,
//! checkpoints, the registry, estimates out), `dispatch.rs` (the dispatcher: classifying, decoding,
//! queueing; telling what was refused or missed), `vehicle.rs` (what the engine keeps: each vehicle's
//! record, the counters), `admission.rs` (the subscribers' side of the ingest channel).

mod admission;
mod dispatch;
mod vehicle;

pub use admission::{Admission, Held, Ingest};
pub use vehicle::{
    sink_outlets, Counters, EstimateOutlet, Outlets, Sink, StepTimes, Vehicle, VehicleTotals, KINDS,
};

use crate::sensors::Measurement;
use crate::service::config::ServiceConfig;
use crate::service::persist::{self, SavedCounters};
use crate::vehicle::{Event, ResetRequest, Stream, VehicleState};
use crate::wire::keys::{Keys, Leaf};
use crate::wire::{
    validate_vehicle_id, write_estimate, EstimateMsg, RejectCode, Rejection, ResetMsg,
    ResetReplyMsg,
};
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::Instant;

/// What the engine asks of the features around it, plugged in by the wiring. Each method's default is
/// a lone instance's: it owns every vehicle, keeps nothing for another, and an estimate goes to its
/// outlet only. Called on the dispatcher thread unless said otherwise.
pub trait Hooks: Send + Sync {
    /// Who owns a vehicle: whether this instance processes and answers for `vehicle` (any string: a
    /// wildcard chunk is owned too, so that exactly one member refuses a wildcard put). Any thread.
    fn owns(&self, _vehicle: &str) -> bool {
        true
    }

    /// What a standby keeps: an input of a vehicle this instance does not own.
    fn not_owned(&self, _engine: &Engine, _vehicle: &str, _inbound: Inbound) {}

    /// Whether an input of an owned vehicle was used already (by a takeover), so is not used again.
    fn used_before(&self, _engine: &Engine, _vehicle: &str, _leaf: Leaf, _payload: &[u8]) -> bool {
        false
    }

    /// An input on a key that is not a vehicle's `P/V/<leaf>` (a standby batch, a ROS 2 topic):
    /// decoded and queued through [`Engine::accept`] or [`Engine::queue`], the vehicles to schedule
    /// pushed on `touched`. `decoded`: the dispatcher's buffer.
    fn other_input(
        &self,
        _engine: &Engine,
        _inbound: Inbound,
        _decoded: &mut Vec<Measurement>,
        _touched: &mut Vec<Arc<Vehicle>>,
    ) {
    }

    /// The vehicle of such a key (to count and tell what was refused or missed on it).
    fn vehicle_of<'a>(&self, _key: &'a str) -> Option<&'a str> {
        None
    }

    /// Whether `vehicle`'s estimates are wanted serialised even when no subscriber listens (a fleet
    /// owner's standby members get every one). A worker thread.
    fn wants_bytes(&self, _vehicle: &str) -> bool {
        false
    }

    /// What happens to an estimate besides its outlet: `bytes`, its JSON when it was serialised. A
    /// worker thread, before the estimate is put.
    fn on_estimate(&self, _vehicle: &str, _estimate: &EstimateMsg, _bytes: Option<&[u8]>) {}

    /// The housekeeping thread's tick (every 10 ms while a reorder window holds samples, else every
    /// 0.1 s or [`Hooks::period_s`], whichever is shorter), after the reorder windows' ticks are
    /// queued.
    fn housekeeping(&self, _engine: &Engine) {}

    /// The longest `housekeeping` may wait between two calls, s.
    fn period_s(&self) -> f64 {
        f64::INFINITY
    }

    /// At shutdown, once every inbox is drained, before the last checkpoints.
    fn on_shutdown(&self, _engine: &Engine) {}
}

/// The hooks of an engine alone: no fleet, no ROS 2 edge.
pub struct Alone;

impl Hooks for Alone {}

/// Work for the dispatcher thread, run in order with the inputs (a fleet's change of members).
pub type Task = Box<dyn FnOnce(&Engine) + Send>;

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
    /// (Boxed: the request is four times a measurement's size, and every input of the inbox would
    /// otherwise be as large.)
    Reset(
        Box<ResetRequest>,
        tokio::sync::oneshot::Sender<Result<ResetReplyMsg, Rejection>>,
    ),
    /// Release what the reorder window holds beyond its wall-time limit.
    Tick(f64),
}

fn refresh_info(v: &Vehicle, state: &VehicleState) {
    v.info.refresh(state);
}

/// Inputs a worker takes from one vehicle before giving other vehicles a turn.
const TURN: usize = 256;
/// ... and at most this long, s: a vehicle with a heavy filter (a particle filter of 10⁵ particles
/// steps in milliseconds) and a backlog must not hold a worker for hundreds of its steps.
const TURN_S: f64 = 0.005;

/// The engine shared by the dispatcher, the workers, the housekeeping thread and the queries.
pub struct Engine {
    pub config: Arc<ServiceConfig>,
    pub keys: Keys,
    pub counters: Counters,
    started: Instant,
    vehicles: RwLock<HashMap<String, Arc<Vehicle>>>,
    /// Vehicles whose reorder windows hold samples: the housekeeping thread looks for them among all
    /// (a cache miss per vehicle, every 10 ms) only while there are any.
    holding: AtomicUsize,
    /// The housekeeping thread's stop and nudge.
    alarm: Alarm,
    /// Wakes the dispatcher from its doze when something it must tell is kept (bounded to one: a
    /// nudge already pending is enough).
    dispatcher_nudge: crossbeam_channel::Sender<()>,
    /// `None` tells a worker to stop.
    work_tx: crossbeam_channel::Sender<Option<Arc<Vehicle>>>,
    sink: Sink,
    outlets: Outlets,
    /// Serialises checkpoint writers (the housekeeping thread and the shutdown).
    checkpointing: Mutex<()>,
    /// The fleet's and the ROS 2 edge's side, as the wiring plugged it in.
    hooks: Arc<dyn Hooks>,
    /// The subscribers' side of the ingest channel, and the channel (its depth, for `P/@/health`).
    pub admission: Admission,
    ingest_depth: crossbeam_channel::Receiver<Option<Ingest>>,
}

/// The running threads of an engine.
pub struct EngineThreads {
    /// Where subscriber callbacks hand raw samples (through [`Admission::offer`]); `None` stops the
    /// dispatcher.
    pub ingest: crossbeam_channel::Sender<Option<Ingest>>,
    /// Work run on the dispatcher thread in order with the inputs (a fleet's change of members).
    pub tasks: crossbeam_channel::Sender<Task>,
    dispatcher: std::thread::JoinHandle<()>,
    workers: Vec<std::thread::JoinHandle<()>>,
    housekeeping: std::thread::JoinHandle<()>,
    engine: Arc<Engine>,
}

/// What the housekeeping thread waits on between its ticks: the stop, and a nudge when a reorder
/// window starts holding samples while it dozes. (Not a crossbeam channel: its receive with a timeout
/// spins and yields the core several times before it sleeps; under load, where other threads are
/// runnable, each yield is a task switch, and the thread's hundred waits a second were 8.6% of a
/// fleet member's CPU samples under the MEKF load, 2.4% with a plain wait.)
#[derive(Default)]
struct Alarm {
    state: Mutex<AlarmState>,
    signal: std::sync::Condvar,
    /// Set (under the lock) while the thread takes a long nap: only then does a nudge wake it.
    dozing: std::sync::atomic::AtomicBool,
}

#[derive(Default)]
struct AlarmState {
    stopped: bool,
    nudged: bool,
}

impl Alarm {
    fn stop(&self) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).stopped = true;
        self.signal.notify_all();
    }

    /// A reorder window began to hold samples: wakes the thread if it dozes.
    fn nudge(&self) {
        if self.dozing.load(Ordering::SeqCst) {
            self.state.lock().unwrap_or_else(|e| e.into_inner()).nudged = true;
            self.signal.notify_all();
        }
    }

    /// Waits `tick`, or `nap` while `idle()` holds once the thread dozes (a nudge ends the nap);
    /// whether the stop came.
    fn wait(
        &self,
        tick: std::time::Duration,
        nap: std::time::Duration,
        idle: impl Fn() -> bool,
    ) -> bool {
        let state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let timeout = if nap > tick {
            // (Dozing is set before `idle` is looked at, and `holding_began` counts before it looks
            // at dozing: either the count is seen here or the nudge comes.)
            self.dozing.store(true, Ordering::SeqCst);
            if idle() {
                nap
            } else {
                tick
            }
        } else {
            tick
        };
        let (mut state, _) = self
            .signal
            .wait_timeout_while(state, timeout, |s| !s.stopped && !s.nudged)
            .unwrap_or_else(|e| e.into_inner());
        self.dozing.store(false, Ordering::SeqCst);
        state.nudged = false;
        state.stopped
    }
}

impl EngineThreads {
    /// Stops the dispatcher after the inputs already received, then the workers after the vehicles
    /// already scheduled, then processes whatever is still in any inbox, so nothing accepted is lost,
    /// and writes a last checkpoint of every vehicle that changed (samples still in a reorder window
    /// are part of it).
    pub fn shutdown(self) {
        self.engine.alarm.stop();
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
        // (A fleet's last estimates reach the standby members before this instance leaves.)
        self.engine.hooks.on_shutdown(&self.engine);
        self.engine.checkpoint_all();
    }
}

/// How often the housekeeping thread releases reorder windows by wall time, s.
const TICK_S: f64 = 0.01;
/// Its tick while no window holds samples (its hooks and checkpoints may ask for less), s.
const IDLE_TICK_S: f64 = 0.1;
/// How long it keeps the short tick after a window held samples, s.
const BUSY_S: f64 = 1.0;

/// Capacity of the channel between the subscriber callbacks and the dispatcher.
pub const INGEST_CAPACITY: usize = 1 << 16;

impl Engine {
    /// An engine alone (no fleet, no ROS 2 edge) where every estimate is wanted and goes to `sink`
    /// too.
    pub fn start_alone(
        config: ServiceConfig,
        sink: Sink,
    ) -> Result<(Arc<Engine>, EngineThreads), persist::CheckpointError> {
        let outlets = sink_outlets(&sink);
        Engine::start(config, sink, outlets, Arc::new(Alone))
    }

    /// Restores the vehicles checkpointed in the state directory (if one is configured; it is
    /// created when missing), then starts the dispatcher, `config.workers` worker threads and the
    /// housekeeping thread (reorder-window ticks, periodic checkpoints). Estimates go to each
    /// vehicle's outlet of `outlets`, everything else to `sink`; `hooks` are the features' side.
    /// Only an unusable state directory is an error; a bad checkpoint file is reported and skipped.
    pub fn start(
        config: ServiceConfig,
        sink: Sink,
        outlets: Outlets,
        hooks: Arc<dyn Hooks>,
    ) -> Result<(Arc<Engine>, EngineThreads), persist::CheckpointError> {
        let (work_tx, work_rx) = crossbeam_channel::unbounded::<Option<Arc<Vehicle>>>();
        let (ingest_tx, ingest_rx) = crossbeam_channel::bounded::<Option<Ingest>>(INGEST_CAPACITY);
        let (tasks_tx, tasks_rx) = crossbeam_channel::unbounded::<Task>();
        let (nudge_tx, nudge_rx) = crossbeam_channel::bounded::<()>(1);
        let workers = config.workers.max(1);
        let keys = Keys::new(&config.key_prefix).with_vehicles(&config.fleet.vehicles);
        let admission = Admission::new(&config.ingest);
        let engine = Arc::new(Engine {
            keys,
            hooks,
            config: Arc::new(config),
            counters: Counters::default(),
            started: Instant::now(),
            vehicles: RwLock::new(HashMap::new()),
            holding: AtomicUsize::new(0),
            alarm: Alarm::default(),
            dispatcher_nudge: nudge_tx,
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
                .spawn(move || engine.dispatcher(ingest_rx, tasks_rx, nudge_rx))
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
        let housekeeping = {
            let engine = engine.clone();
            std::thread::Builder::new()
                .name("attitude-housekeeping".into())
                .spawn(move || engine.housekeeping())
                .expect("spawn the housekeeping thread")
        };
        Ok((
            engine.clone(),
            EngineThreads {
                ingest: ingest_tx,
                tasks: tasks_tx,
                dispatcher,
                workers,
                housekeeping,
                engine,
            },
        ))
    }

    /// The engine time, s since it started: what inputs, ticks and standby data are stamped with.
    pub fn now_s(&self) -> f64 {
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
            let v = Arc::new(v);
            self.count_if_holding(&v);
            map.insert(id.clone(), v);
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
    fn housekeeping(&self) {
        let interval = self.config.persistence.checkpoint_interval_s;
        let mut next_checkpoint = self.now_s() + interval;
        let tick = std::time::Duration::from_secs_f64(TICK_S);
        // (While no window holds samples the thread dozes: ten wake-ups a second instead of a
        // hundred. It keeps its 10 ms tick for BUSY_S after one held any, so that a vehicle whose
        // windows hold now and then nudges it once, not each time.)
        let nap = std::time::Duration::from_secs_f64(
            IDLE_TICK_S
                .min(self.hooks.period_s())
                .min(interval)
                .max(TICK_S),
        );
        let mut busy_until = f64::NEG_INFINITY;
        loop {
            let idle = || self.holding.load(Ordering::SeqCst) == 0;
            let dozing = self.now_s() >= busy_until;
            if self.alarm.wait(tick, if dozing { nap } else { tick }, idle) {
                return;
            }
            if !idle() {
                busy_until = self.now_s() + BUSY_S;
            }
            // (Only the vehicles that hold samples, neither sorted nor all cloned, and none looked
            // at while none holds any.)
            let holding: Vec<Arc<Vehicle>> = if self.holding.load(Ordering::Relaxed) == 0 {
                Vec::new()
            } else {
                self.vehicles
                    .read()
                    .map(|m| {
                        m.values()
                            .filter(|v| v.held.load(Ordering::Relaxed) > 0)
                            .cloned()
                            .collect()
                    })
                    .unwrap_or_default()
            };
            for v in holding {
                if !v.tick_queued.swap(true, Ordering::AcqRel) {
                    let mut inbox = v.inbox.lock().unwrap_or_else(|e| e.into_inner());
                    // (Stamped under the inbox's lock: stamps never go back along an inbox.)
                    inbox.push_back(Input::Tick(self.now_s()));
                    drop(inbox);
                    self.schedule(&v);
                }
            }
            self.hooks.housekeeping(self);
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

    /// Whether an estimate put now would reach anyone (`P/@/health` `listened`). The service's outlets
    /// share one matching flag (`service::outlets`), so an outlet made for the question answers it.
    pub fn estimates_listened(&self) -> bool {
        (self.outlets)(&self.keys.vehicle("_", Leaf::Estimate)).wanted()
    }

    /// A vehicle joins the registry (restored, adopted) holding samples already: counted at once.
    fn count_if_holding(&self, v: &Vehicle) {
        if v.held.load(Ordering::Relaxed) > 0 {
            self.holding_began();
        }
    }

    fn holding_began(&self) {
        if self.holding.fetch_add(1, Ordering::SeqCst) == 0 {
            self.alarm.nudge();
        }
    }

    /// Wakes the dispatcher to tell what was kept untold (`Admission::keep_untold`).
    pub(super) fn nudge_dispatcher(&self) {
        let _ = self.dispatcher_nudge.try_send(());
    }

    fn holding_stopped(&self) {
        let _ = self
            .holding
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| n.checked_sub(1));
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
            .push_back(Input::Reset(Box::new(request), tx));
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
            match v.refresh_totals(&state) {
                Some(true) => self.holding_began(),
                Some(false) => self.holding_stopped(),
                None => {}
            }
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

/// Estimates out, the features' operations, and the reads the queries make.
impl Engine {
    /// Runs one input through its vehicle (`f`, on a worker), timed for `attitude_step_seconds`.
    fn timed<T>(
        &self,
        state: &mut VehicleState,
        events: &mut Vec<Event>,
        f: impl FnOnce(&mut VehicleState, &mut Vec<Event>) -> T,
    ) -> T {
        let started = Instant::now();
        let out = f(state, events);
        let kind = state.spec().kind;
        self.counters.steps.observe(kind, started.elapsed(), events);
        out
    }

    /// Keeps `e` (with the vehicle's rejection counts) as the snapshot the queries answer and, when
    /// anyone subscribes to the vehicle's estimates (or the hooks want its bytes), serialises it once
    /// and puts it.
    fn publish_estimate(&self, v: &Vehicle, mut e: EstimateMsg) {
        {
            let rejected = v.rejected_by_code.lock().unwrap_or_else(|e| e.into_inner());
            if !rejected.is_empty() {
                e.diagnostics.rejected = rejected.clone();
            }
        }
        e.diagnostics.missed = v.missed.load(Ordering::Relaxed);
        let out = &v.outlet;
        let outlet = out
            .outlet
            .get_or_init(|| (self.outlets)(&self.keys.vehicle(&v.id, Leaf::Estimate)));
        // (In a fleet the route's standby members get every estimate, in the owner's next batch.)
        let wanted = outlet.wanted();
        let payload = if wanted || self.hooks.wants_bytes(&v.id) {
            let mut buf = Vec::with_capacity(out.last_len.load(Ordering::Relaxed) + 64);
            // (serde_json's bytes, written without its per-field machinery: wire::write_estimate.)
            write_estimate(&mut buf, &e);
            out.last_len.store(buf.len(), Ordering::Relaxed);
            Some(buf)
        } else {
            None
        };
        self.hooks.on_estimate(&v.id, &e, payload.as_deref());
        *v.snapshot.write().unwrap_or_else(|e| e.into_inner()) = Some(Arc::new(e));
        self.counters.estimates.fetch_add(1, Ordering::Relaxed);
        if let Some(payload) = payload {
            if wanted {
                outlet.put(payload);
            }
        }
    }

    /// Whether this instance processes and answers for `vehicle` (its hooks say; a lone engine owns
    /// every vehicle).
    pub fn owns(&self, vehicle: &str) -> bool {
        self.hooks.owns(vehicle)
    }

    /// How many vehicles the registry holds.
    pub fn vehicle_count(&self) -> usize {
        self.vehicles.read().map(|m| m.len()).unwrap_or(0)
    }

    /// Raw samples waiting in the ingest channel.
    pub fn ingest_depth(&self) -> usize {
        self.ingest_depth.len()
    }

    /// Vehicles scheduled and waiting for a worker.
    pub fn work_queue_depth(&self) -> usize {
        self.work_tx.len()
    }

    /// A vehicle leaves this instance (a fleet hands it to another member): it leaves the registry
    /// (what its inbox still holds is processed and published by the worker that has it) and its
    /// checkpoint is removed (a restart must not resurrect it here). Returns its last estimate.
    pub fn release(&self, id: &str) -> Option<Arc<EstimateMsg>> {
        let v = self
            .vehicles
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id)?;
        if let Some(dir) = &self.config.persistence.state_dir {
            let _ = std::fs::remove_file(persist::path_of(dir, id));
        }
        v.snapshot()
    }

    /// A vehicle comes to this instance with a state of its own (a fleet's takeover): it joins the
    /// registry, queries answer `snapshot` until its first estimate here, and `replay` is queued on
    /// its inbox (stamped now) and the vehicle scheduled. `false` when `limits.max_vehicles` is
    /// reached (nothing changes).
    pub fn adopt(
        &self,
        id: &str,
        state: VehicleState,
        snapshot: Option<Arc<EstimateMsg>>,
        replay: Vec<Measurement>,
    ) -> bool {
        let v = {
            let mut map = self.vehicles.write().unwrap_or_else(|e| e.into_inner());
            if map.len() >= self.config.limits.max_vehicles {
                return false;
            }
            let v = Arc::new(Vehicle::new(id, state, SavedCounters::default()));
            self.count_if_holding(&v);
            map.insert(id.to_string(), v.clone());
            v
        };
        if snapshot.is_some() {
            *v.snapshot.write().unwrap_or_else(|e| e.into_inner()) = snapshot;
        }
        let at = self.now_s();
        v.received.fetch_add(replay.len() as u64, Ordering::Relaxed);
        v.dirty.store(true, Ordering::Release);
        v.inbox
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .extend(replay.into_iter().map(|m| Input::Measurement(m, at)));
        self.schedule(&v);
        true
    }

    /// Hands the vehicles an input touched to the worker pool.
    pub fn schedule_all(&self, touched: &mut Vec<Arc<Vehicle>>) {
        for v in touched.drain(..) {
            self.schedule(&v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Alarm;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    /// A window that begins to hold samples while the housekeeping thread looks at the count and
    /// dozes off is never left for the whole nap: either the thread sees the count (and waits its
    /// short tick) or the nudge wakes it. A lost nudge would cost the nap, here 10 s.
    #[test]
    fn a_nudge_is_never_lost_to_a_doze() {
        let tick = Duration::from_millis(10);
        let nap = Duration::from_secs(10);
        for round in 0..200u64 {
            let alarm = Arc::new(Alarm::default());
            let holding = Arc::new(AtomicUsize::new(0));
            let (a, h) = (alarm.clone(), holding.clone());
            let worker = std::thread::spawn(move || {
                // (From at once to a little after the doze began.)
                let until = Instant::now() + Duration::from_micros(round % 50 * 4);
                while Instant::now() < until {
                    std::hint::spin_loop();
                }
                if h.fetch_add(1, Ordering::SeqCst) == 0 {
                    a.nudge();
                }
            });
            let t = Instant::now();
            let stopped = alarm.wait(tick, nap, || holding.load(Ordering::SeqCst) == 0);
            let waited = t.elapsed();
            worker.join().unwrap();
            assert!(!stopped);
            assert!(
                waited < Duration::from_secs(2),
                "round {round}: slept {waited:?}"
            );
        }
    }

    /// A stop ends a nap at once, and a wait after it returns at once.
    #[test]
    fn a_stop_ends_the_nap() {
        let alarm = Arc::new(Alarm::default());
        let a = alarm.clone();
        let stopper = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            a.stop();
        });
        let t = Instant::now();
        assert!(alarm.wait(Duration::from_millis(10), Duration::from_secs(10), || true));
        assert!(t.elapsed() < Duration::from_secs(5));
        stopper.join().unwrap();
        let t = Instant::now();
        assert!(alarm.wait(Duration::from_secs(10), Duration::from_secs(10), || true));
        assert!(t.elapsed() < Duration::from_secs(1));
    }
}
