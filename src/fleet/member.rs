//! This instance as a member of its fleet ([`Member`]): the routes it owns and holds (and, outside a
//! dynamic fleet, the static shard it serves), the standby data it keeps for the routes it holds but
//! does not own, the takeover when a route becomes its own, and the batches of estimates it sends its
//! routes' standby members. The engine reaches it through its hooks (`service::Node`): who owns a
//! vehicle, what a standby keeps, what happens to an estimate; a change of members runs on the
//! engine's dispatcher thread, in order with the inputs.
//!
//! A route's standby data comes in batches (`wire::batch`): its inputs from their senders
//! (`P/@/standby/<r>/inputs`), its estimates from its owner (`P/@/standby/<r>/estimates/<G>`). They are
//! kept as they arrive, not parsed: a takeover reads them. Inputs a member receives one by one for a
//! vehicle it does not own (plain keys, which every member receives, or a routed input while the
//! owner changes) are kept per vehicle. A takeover uses both, each input once: for a while after it
//! (`grace`, the longest a subscription takes to reach the senders) the route's inputs are checked
//! against those already used, by a hash of their vehicle, leaf and bytes, whether they come one by
//! one or in a batch (senders send their batches at least every second).

use super::assignment::{Assignment, FleetConfig, FleetMode};
use super::batch::{self, BatchWriter};
use crate::engine::{Engine, Inbound, Sink, Task, Vehicle};
use crate::sensors::Measurement;
use crate::service::config::ServiceConfig;
use crate::vehicle::{TakeoverSeed, VehicleState};
use crate::wire::keys::{route_of, Keys, Leaf, Received, ROUTES};
use crate::wire::{validate_vehicle_id, EstimateMsg};
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock};

/// How long after a takeover a route's inputs are checked against those already used, s: longer than a
/// subscription takes to reach the senders plus a sender's interval between batches (at most 1 s; the
/// senders here send every 0.25 s).
pub const TAKEOVER_GRACE_S: f64 = 2.0;

/// A route's standby data (kept while held and not owned) and its takeover's memory.
#[derive(Default)]
struct RouteStandby {
    /// The senders' batches of the route's inputs, with their arrival (engine time, s), oldest first.
    inputs: VecDeque<(f64, Vec<u8>)>,
    /// The last estimate of each of the route's vehicles, as its owner published it (JSON).
    estimates: HashMap<String, (f64, Vec<u8>)>,
    /// Bytes of `inputs` and `estimates`.
    bytes: usize,
    /// Until this engine time after a takeover, the hashes of the route's inputs already used.
    grace_until: f64,
    seen: HashSet<u64>,
}

impl RouteStandby {
    fn clear(&mut self) {
        self.inputs.clear();
        self.estimates.clear();
        self.bytes = 0;
    }
}

/// What the service subscribes to (dynamic mode): the routed inputs of the routes owned; the standby
/// batches of the routes held but not owned, and of the routes taken over while their grace lasts (a
/// batch sent before the takeover may hold inputs that never reached this member on their own).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RoutePlan {
    pub owned: Vec<u8>,
    pub standby: Vec<u8>,
}

/// Which input one is, to use it once: its vehicle, its leaf and its bytes.
fn input_hash(vehicle: &str, leaf: Leaf, payload: &[u8]) -> u64 {
    let h = crate::rng::fnv1a(vehicle.bytes(), crate::rng::FNV_OFFSET);
    let h = crate::rng::fnv1a(leaf.as_str().bytes().chain([0xff]), h);
    crate::rng::fnv1a(payload.iter().copied(), h)
}

/// An input leaf by its name in a batch record.
fn input_leaf(name: &str) -> Option<Leaf> {
    match name {
        "gyro" => Some(Leaf::Gyro),
        "vectors" => Some(Leaf::Vectors),
        "imu" => Some(Leaf::Imu),
        _ => None,
    }
}

/// A route's estimates waiting for the next batch to its standby members: by vehicle, whether it is
/// new since the last batch and the serialised estimate.
type Outgoing = HashMap<String, (bool, Vec<u8>)>;

/// This instance in its fleet: what it knows of the other members, the standby data it keeps and the
/// batches it sends. Every instance has one (a single instance owns the routes it serves).
pub struct Member {
    fleet: FleetConfig,
    /// `limits.max_vehicles` and `limits.queue_per_vehicle`.
    max_vehicles: usize,
    queue_per_vehicle: usize,
    keys: Keys,
    /// Where the batches of estimates go.
    sink: Sink,
    /// `P/<shard>/x` when statically sharded (`fleet.vehicles` other than `*`).
    shard: Option<zenoh::key_expr::OwnedKeyExpr>,
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
    routes: Mutex<Vec<RouteStandby>>,
    /// Per route owned: each vehicle's last estimate, and whether it was published since the last
    /// batch to the route's standby members.
    outgoing: Mutex<Vec<Outgoing>>,
    /// The routes to subscribe to, for the service (`service::run`).
    plan: Option<tokio::sync::watch::Sender<RoutePlan>>,
    takeovers: AtomicU64,
    released: AtomicU64,
    /// Standby batches that could not be read.
    malformed: AtomicU64,
    /// The housekeeping's next batch of estimates and next trim of the standby data (engine time, s).
    next: Mutex<(f64, f64)>,
}

impl Member {
    /// This instance's side of the fleet `config.fleet`; its batches of estimates go to `sink`.
    pub fn new(config: &ServiceConfig, sink: Sink) -> Member {
        let keys = Keys::new(&config.key_prefix).with_vehicles(&config.fleet.vehicles);
        let shard = (config.fleet.vehicles != "*")
            .then(|| zenoh::key_expr::OwnedKeyExpr::try_from(keys.all(Leaf::Gyro)).ok())
            .flatten();
        Member {
            fleet: config.fleet.clone(),
            max_vehicles: config.limits.max_vehicles,
            queue_per_vehicle: config.limits.queue_per_vehicle,
            keys,
            sink,
            shard,
            members: RwLock::new(None),
            assignment: RwLock::new(None),
            prepared: RwLock::new(None),
            cache: Mutex::new(HashMap::new()),
            standby: Mutex::new(HashMap::new()),
            routes: Mutex::new((0..ROUTES).map(|_| Default::default()).collect()),
            outgoing: Mutex::new((0..ROUTES).map(|_| Default::default()).collect()),
            plan: (config.fleet.mode == FleetMode::Dynamic)
                .then(|| tokio::sync::watch::Sender::new(RoutePlan::default())),
            takeovers: AtomicU64::new(0),
            released: AtomicU64::new(0),
            malformed: AtomicU64::new(0),
            next: Mutex::new((config.fleet.flush_s, 1.0)),
        }
    }

    /// A standby batch (`P/@/standby/<r>/...`, dispatcher thread): kept, or after a takeover its
    /// inputs not yet used queued (their vehicles pushed on `touched`). Any other key is handed back.
    pub fn standby_batch(
        &self,
        engine: &Engine,
        inbound: Inbound,
        decoded: &mut Vec<Measurement>,
        touched: &mut Vec<Arc<Vehicle>>,
    ) -> Result<(), Inbound> {
        match self.keys.classify(&inbound.key) {
            Some(Received::StandbyInputs(r)) => {
                let key = inbound.key.clone();
                self.standby_inputs(engine, r, &key, inbound.payload, decoded, touched);
                Ok(())
            }
            Some(Received::StandbyEstimates(r, group)) => {
                self.standby_estimates(engine, r, group, &inbound.key, &inbound.payload);
                Ok(())
            }
            _ => Err(inbound),
        }
    }

    /// The task that tells this member the fleet's live members, run on the engine's dispatcher
    /// thread in order with the inputs ([`Member::set_members`]).
    pub fn members_task(self: &Arc<Self>, members: BTreeSet<String>) -> Task {
        let member = self.clone();
        Box::new(move |engine: &Engine| member.set_members(engine, members))
    }

    /// The fleet's configuration.
    pub fn config(&self) -> &FleetConfig {
        &self.fleet
    }

    /// Vehicles taken over, released to other members, and standby batches that could not be read.
    pub fn moves(&self) -> (u64, u64, u64) {
        (
            self.takeovers.load(Ordering::Relaxed),
            self.released.load(Ordering::Relaxed),
            self.malformed.load(Ordering::Relaxed),
        )
    }

    /// The housekeeping's share (every tick): the batches of estimates every `fleet.flush_s`, the
    /// standby data trimmed every second.
    pub fn housekeeping(&self, engine: &Engine) {
        let now = engine.now_s();
        let (flush, trim) = {
            let next = self.next.lock().unwrap_or_else(|e| e.into_inner());
            let flush = now >= next.0;
            let trim = now >= next.1;
            (flush, trim)
        };
        if flush {
            self.flush_estimates(engine);
            self.next.lock().unwrap_or_else(|e| e.into_inner()).0 =
                engine.now_s() + self.fleet.flush_s;
        }
        if trim {
            self.trim_standby(engine);
            self.next.lock().unwrap_or_else(|e| e.into_inner()).1 = engine.now_s() + 1.0;
        }
    }
}

impl Member {
    fn dynamic(&self) -> bool {
        self.fleet.mode == FleetMode::Dynamic
    }

    fn me(&self) -> &str {
        &self.fleet.instance
    }

    /// Whether `vehicle` is inside this instance's static shard (`fleet.vehicles`).
    fn in_shard(&self, vehicle: &str) -> bool {
        let Some(shard) = &self.shard else {
            return true;
        };
        let key = self.keys.vehicle(vehicle, Leaf::Gyro);
        zenoh::key_expr::KeyExpr::try_from(key.as_str())
            .map(|k| shard.intersects(&k))
            .unwrap_or(false)
    }

    /// Whether this instance processes and answers for `vehicle` (any string: a wildcard chunk is
    /// owned too, so exactly one member refuses a wildcard put): in its shard (its vehicle pattern and
    /// its routes) and, in a dynamic fleet, the owner of its route.
    pub fn owns(&self, vehicle: &str) -> bool {
        self.in_shard(vehicle) && self.owns_route(route_of(vehicle))
    }

    /// Whether this instance (or its group) serves `route` (`fleet.routes`).
    pub fn serves(&self, route: u8) -> bool {
        self.fleet.routes & (1 << route) != 0
    }

    /// The assignment of the routes served among `members`.
    fn assign(&self, members: &BTreeSet<String>) -> Option<Arc<Assignment>> {
        Assignment::of_routes(members, self.fleet.routes).map(Arc::new)
    }

    /// Whether this instance owns `route`: one it serves, and in a dynamic fleet one assigned to it.
    pub fn owns_route(&self, route: u8) -> bool {
        if !self.serves(route) {
            return false;
        }
        if !self.dynamic() {
            return true;
        }
        let a = self.assignment.read().unwrap_or_else(|e| e.into_inner());
        a.as_ref().is_some_and(|a| a.owns(self.me(), route))
    }

    /// Whether this instance keeps `route`'s standby data: it holds the route, now or once joined,
    /// and does not own it.
    fn keeps(&self, route: u8) -> bool {
        if !self.dynamic() || !self.serves(route) || self.owns_route(route) {
            return false;
        }
        let me = self.me();
        let holds = |a: &RwLock<Option<Arc<Assignment>>>| {
            a.read()
                .unwrap_or_else(|e| e.into_inner())
                .as_ref()
                .is_some_and(|a| a.holds(me, route) && a.has_standby(route))
        };
        holds(&self.assignment) || holds(&self.prepared)
    }

    /// The live members, when known (dynamic mode).
    pub fn members(&self) -> Option<BTreeSet<String>> {
        self.members
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// The current assignment of the routes, when the members are known (dynamic mode).
    pub fn assignment(&self) -> Option<Arc<Assignment>> {
        self.assignment
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// The routes to subscribe to, as they change (dynamic mode; `None` in single mode).
    pub fn route_plan(&self) -> Option<tokio::sync::watch::Receiver<RoutePlan>> {
        self.plan.as_ref().map(|p| p.subscribe())
    }

    /// Tells the service the routes to subscribe to, when they changed (`now`: the engine time).
    fn publish_plan(&self, now: f64) {
        let Some(plan) = &self.plan else {
            return;
        };
        let me = self.me();
        let current = self.assignment();
        let prepared = self
            .prepared
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        let mut p = RoutePlan::default();
        let grace: Vec<bool> = {
            let routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
            routes.iter().map(|r| r.grace_until >= now).collect()
        };
        for r in (0..ROUTES as u8).filter(|&r| self.serves(r)) {
            if current.as_ref().is_some_and(|a| a.owns(me, r)) {
                p.owned.push(r);
                if grace[r as usize] {
                    p.standby.push(r);
                }
            } else if self.keeps(r) {
                p.standby.push(r);
            } else if prepared.as_ref().is_some_and(|a| a.owns(me, r)) {
                // (About to own it: its inputs start arriving before the takeover, kept meanwhile.)
                p.owned.push(r);
            }
        }
        plan.send_if_modified(|old| {
            let changed = *old != p;
            *old = p;
            changed
        });
    }

    /// Before joining (dynamic mode): the members this instance is about to join, itself among them.
    /// It keeps the standby data of the routes it will hold from now on, and owns nothing until
    /// [`Engine::set_members`].
    pub fn prepare(&self, engine: &Engine, members: &BTreeSet<String>) {
        *self.prepared.write().unwrap_or_else(|e| e.into_inner()) = self.assign(members);
        self.publish_plan(engine.now_s());
    }

    /// An estimate read from the network (a starting member's get on `P/*/state`): kept as the starting
    /// point of a takeover. Our own vehicles' estimates are ignored; an older one never replaces a
    /// newer one.
    pub fn remember_estimate(&self, vehicle: &str, payload: &[u8]) {
        if !self.dynamic() || self.owns(vehicle) || !self.in_shard(vehicle) {
            return;
        }
        let e: EstimateMsg = match serde_json::from_slice(payload) {
            Ok(e) => e,
            Err(err) => {
                tracing::debug!(vehicle, %err, "an estimate that does not parse is not remembered");
                return;
            }
        };
        if e.vehicle != vehicle || validate_vehicle_id(vehicle).is_err() {
            return;
        }
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        if cache.len() >= self.max_vehicles && !cache.contains_key(vehicle) {
            return;
        }
        match cache.get(vehicle) {
            Some(old) if old.t > e.t => {}
            _ => {
                cache.insert(vehicle.to_string(), Arc::new(e));
            }
        }
    }

    /// Keeps an input received on its own for a vehicle of a route held but not owned, for
    /// `fleet.standby_s` (dynamic mode).
    pub fn keep_standby(&self, engine: &Engine, vehicle: &str, inbound: Inbound) {
        let window = self.fleet.standby_s;
        if window <= 0.0 || validate_vehicle_id(vehicle).is_err() || !self.keeps(route_of(vehicle))
        {
            return;
        }
        let now = engine.now_s();
        let mut standby = self.standby.lock().unwrap_or_else(|e| e.into_inner());
        if standby.len() >= self.max_vehicles && !standby.contains_key(vehicle) {
            return;
        }
        let q = standby.entry(vehicle.to_string()).or_default();
        q.push_back((now, inbound));
        while q.len() > self.queue_per_vehicle || q.front().is_some_and(|(t, _)| *t < now - window)
        {
            q.pop_front();
        }
    }

    /// Whether an input of an owned vehicle was already used by a takeover of its route (and, while
    /// the takeover's grace lasts, remembers it as used).
    pub fn used_before(&self, engine: &Engine, vehicle: &str, leaf: Leaf, payload: &[u8]) -> bool {
        if !self.dynamic() {
            return false;
        }
        let now = engine.now_s();
        let mut routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
        let rs = &mut routes[route_of(vehicle) as usize];
        if rs.grace_until < now {
            if !rs.seen.is_empty() {
                rs.seen = HashSet::new();
            }
            return false;
        }
        !rs.seen.insert(input_hash(vehicle, leaf, payload))
    }

    /// A sender's batch of route `route`'s inputs: kept while the route is held and not owned; after
    /// a takeover of the route, its inputs not yet used go to their vehicles (pushed on `touched`).
    fn standby_inputs(
        &self,
        engine: &Engine,
        route: u8,
        key: &str,
        payload: Vec<u8>,
        decoded: &mut Vec<Measurement>,
        touched: &mut Vec<Arc<Vehicle>>,
    ) {
        if !self.dynamic() {
            return;
        }
        if self.owns_route(route) {
            let grace = {
                let routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
                routes[route as usize].grace_until >= engine.now_s()
            };
            if !grace {
                return;
            }
            for rec in batch::records(&payload) {
                let Ok(rec) = rec else {
                    self.malformed_batch(key, &payload);
                    break;
                };
                let Some(leaf) = input_leaf(rec.leaf) else {
                    continue;
                };
                if route_of(rec.vehicle) != route || !self.owns(rec.vehicle) {
                    continue;
                }
                if self.used_before(engine, rec.vehicle, leaf, rec.payload) {
                    continue;
                }
                let key = self.keys.routed(rec.vehicle, leaf);
                if let Some(v) = engine.accept(rec.vehicle, leaf, &key, rec.payload, decoded) {
                    touched.push(v);
                }
            }
            return;
        }
        if !self.keeps(route) {
            return;
        }
        if batch::check(&payload).is_err() {
            self.malformed_batch(key, &payload);
            return;
        }
        let now = engine.now_s();
        let cap = self.fleet.standby_bytes / ROUTES;
        let mut routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
        let rs = &mut routes[route as usize];
        rs.bytes += payload.len();
        rs.inputs.push_back((now, payload));
        while rs.bytes > cap {
            let Some((_, old)) = rs.inputs.pop_front() else {
                break;
            };
            rs.bytes -= old.len();
        }
    }

    /// Route `route`'s owner's batch of estimates (group `group`): the last of each vehicle kept while
    /// the route is held and not owned.
    fn standby_estimates(
        &self,
        engine: &Engine,
        route: u8,
        group: &str,
        key: &str,
        payload: &[u8],
    ) {
        if !self.dynamic() || group != self.fleet.group || !self.keeps(route) {
            return;
        }
        let now = engine.now_s();
        let max = self.max_vehicles;
        let mut routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
        let rs = &mut routes[route as usize];
        for rec in batch::records(payload) {
            let Ok(rec) = rec else {
                drop(routes);
                self.malformed_batch(key, payload);
                return;
            };
            if rec.leaf != Leaf::Estimate.as_str()
                || route_of(rec.vehicle) != route
                || validate_vehicle_id(rec.vehicle).is_err()
                || !self.in_shard(rec.vehicle)
            {
                continue;
            }
            if rs.estimates.len() >= max && !rs.estimates.contains_key(rec.vehicle) {
                continue;
            }
            rs.bytes += rec.payload.len();
            if let Some((_, old)) = rs
                .estimates
                .insert(rec.vehicle.to_string(), (now, rec.payload.to_vec()))
            {
                rs.bytes -= old.len();
            }
        }
    }

    fn malformed_batch(&self, key: &str, payload: &[u8]) {
        self.malformed.fetch_add(1, Ordering::Relaxed);
        let why = batch::check(payload).err().map(|e| e.to_string());
        tracing::warn!(key, error = ?why, "a standby batch that cannot be read is dropped");
    }

    /// Drops standby data older than the window (housekeeping).
    fn trim_standby(&self, engine: &Engine) {
        let oldest = engine.now_s() - self.fleet.standby_s;
        {
            let mut standby = self.standby.lock().unwrap_or_else(|e| e.into_inner());
            standby.retain(|_, q| {
                while q.front().is_some_and(|(t, _)| *t < oldest) {
                    q.pop_front();
                }
                !q.is_empty()
            });
        }
        let now = engine.now_s();
        let mut ended = false;
        {
            let mut routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
            for rs in routes.iter_mut() {
                while rs.inputs.front().is_some_and(|(t, _)| *t < oldest) {
                    if let Some((_, old)) = rs.inputs.pop_front() {
                        rs.bytes -= old.len();
                    }
                }
                if rs.grace_until < now && rs.grace_until > 0.0 {
                    // A takeover's grace ended: its batches are no longer needed.
                    rs.grace_until = 0.0;
                    rs.seen = HashSet::new();
                    ended = true;
                }
            }
        }
        if ended {
            self.publish_plan(now);
        }
    }

    /// Keeps a serialised estimate for the next batch to its route's standby members, when this
    /// instance owns the route and the route has any: the last of each vehicle (a takeover starts from
    /// the last one; those before it are not needed).
    pub fn batch_estimate(&self, vehicle: &str, payload: &[u8]) {
        let route = route_of(vehicle);
        let mut out = self.outgoing.lock().unwrap_or_else(|e| e.into_inner());
        let pending = &mut out[route as usize];
        // (The vehicle's buffer is reused: no allocation per estimate.)
        match pending.get_mut(vehicle) {
            Some((fresh, buf)) => {
                *fresh = true;
                buf.clear();
                buf.extend_from_slice(payload);
            }
            None => {
                pending.insert(vehicle.to_string(), (true, payload.to_vec()));
            }
        }
    }

    /// Whether the estimates of `vehicle` go to standby members too (dynamic mode, a route with some).
    pub fn has_standby(&self, vehicle: &str) -> bool {
        self.dynamic()
            && self
                .assignment()
                .is_some_and(|a| a.has_standby(route_of(vehicle)))
    }

    /// Sends every route's estimates published since the last batch to its standby members
    /// (housekeeping, every `fleet.flush_s`; and at shutdown).
    pub fn flush_estimates(&self, engine: &Engine) {
        if !self.dynamic() {
            return;
        }
        let batches: Vec<(u8, Vec<u8>)> = {
            let mut out = self.outgoing.lock().unwrap_or_else(|e| e.into_inner());
            let mut batches = Vec::new();
            for (r, pending) in out.iter_mut().enumerate() {
                let mut w = BatchWriter::default();
                for (vehicle, (fresh, buf)) in pending.iter_mut().filter(|(_, (f, _))| *f) {
                    w.push(vehicle, Leaf::Estimate.as_str(), buf);
                    *fresh = false;
                }
                if !w.is_empty() {
                    batches.push((r as u8, w.take()));
                }
                // (Vehicles gone from the route: their buffers go too.)
                if pending.len() > 2 * engine.vehicle_count() + 64 {
                    pending.retain(|v, _| engine.vehicle(v).is_some());
                }
            }
            batches
        };
        for (r, b) in batches {
            (self.sink)(&self.keys.standby_estimates(r, &self.fleet.group), b);
        }
    }

    /// The fleet's members changed (dispatcher thread, in order with the inputs): the routes are
    /// assigned again; this instance releases the vehicles of the routes it no longer owns, takes
    /// over the routes it now owns, and drops the standby data of the routes it no longer keeps.
    pub fn set_members(&self, engine: &Engine, members: BTreeSet<String>) {
        let changed = self.members().as_ref() != Some(&members);
        let new = self.assign(&members);
        *self.members.write().unwrap_or_else(|e| e.into_inner()) = Some(members.clone());
        let old = std::mem::replace(
            &mut *self.assignment.write().unwrap_or_else(|e| e.into_inner()),
            new.clone(),
        );
        // (Prepared routes were kept for this: what follows uses them.)
        let prepared = self
            .prepared
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .take();
        if !changed && prepared.is_none() {
            return;
        }
        let me = self.me().to_string();
        tracing::info!(instance = %me, ?members, owned = ?new.as_ref().map(|a| a.owned_by(&me)), "fleet members");
        for v in engine.vehicles() {
            if !self.owns(&v.id) {
                self.release(engine, &v);
            }
        }
        for r in (0..ROUTES as u8).filter(|&r| self.serves(r)) {
            let now_owned = new.as_ref().is_some_and(|a| a.owns(&me, r));
            let was_owned = old.as_ref().is_some_and(|a| a.owns(&me, r));
            if now_owned && !was_owned {
                self.take_over_route(engine, r);
            } else if !now_owned && !self.keeps(r) {
                self.drop_route(r);
            }
        }
        self.publish_plan(engine.now_s());
    }

    /// Forgets the standby data of a route no longer kept.
    fn drop_route(&self, route: u8) {
        self.routes.lock().unwrap_or_else(|e| e.into_inner())[route as usize].clear();
        self.standby
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .retain(|v, _| route_of(v) != route);
        self.cache
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .retain(|v, _| route_of(v) != route);
    }

    /// Hands a vehicle to its new owner: it leaves the registry (what its inbox still holds is
    /// processed and published), its last estimate is remembered (in case it comes back), and its
    /// checkpoint is removed (a restart must not resurrect it here).
    fn release(&self, engine: &Engine, v: &Arc<Vehicle>) {
        if let Some(e) = engine.release(&v.id) {
            self.cache
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(v.id.clone(), e);
        }
        self.released.fetch_add(1, Ordering::Relaxed);
        tracing::info!(vehicle = %v.id, "vehicle released to another member");
    }

    /// Takes over route `route`: every vehicle of it this instance has data for starts from its last
    /// estimate and replays the inputs kept since; the route's inputs are then checked against those
    /// used until the grace ends.
    fn take_over_route(&self, engine: &Engine, route: u8) {
        let now = engine.now_s();
        let grace = TAKEOVER_GRACE_S;
        let (batches, estimates) = {
            let mut routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
            let rs = &mut routes[route as usize];
            let batches = std::mem::take(&mut rs.inputs);
            let estimates = std::mem::take(&mut rs.estimates);
            rs.clear();
            rs.grace_until = now + grace;
            rs.seen = HashSet::new();
            (batches, estimates)
        };
        // Each vehicle's inputs: those received on their own, then the batches', each once.
        let mut inputs: BTreeMap<String, Vec<(Leaf, Vec<u8>)>> = BTreeMap::new();
        let mut seen = HashSet::new();
        let singles: Vec<(String, VecDeque<(f64, Inbound)>)> = {
            let mut standby = self.standby.lock().unwrap_or_else(|e| e.into_inner());
            let ids: Vec<String> = standby
                .keys()
                .filter(|v| route_of(v) == route)
                .cloned()
                .collect();
            ids.into_iter()
                .filter_map(|v| standby.remove(&v).map(|q| (v, q)))
                .collect()
        };
        for (v, q) in singles {
            for (_, inbound) in q {
                if let Some(Received::Vehicle { leaf, .. }) = self.keys.classify(&inbound.key) {
                    if seen.insert(input_hash(&v, leaf, &inbound.payload)) {
                        inputs
                            .entry(v.clone())
                            .or_default()
                            .push((leaf, inbound.payload));
                    }
                }
            }
        }
        for (_, b) in &batches {
            for rec in batch::records(b).map_while(Result::ok) {
                let Some(leaf) = input_leaf(rec.leaf) else {
                    continue;
                };
                if route_of(rec.vehicle) != route || validate_vehicle_id(rec.vehicle).is_err() {
                    continue;
                }
                if seen.insert(input_hash(rec.vehicle, leaf, rec.payload)) {
                    inputs
                        .entry(rec.vehicle.to_string())
                        .or_default()
                        .push((leaf, rec.payload.to_vec()));
                }
            }
        }
        let cached: Vec<String> = {
            let cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
            cache
                .keys()
                .filter(|v| route_of(v) == route)
                .cloned()
                .collect()
        };
        let mut ids: BTreeSet<String> = inputs.keys().cloned().collect();
        ids.extend(estimates.keys().cloned());
        ids.extend(cached);
        let mut estimates = estimates;
        for id in ids {
            if !self.owns(&id) || engine.vehicle(&id).is_some() {
                continue;
            }
            let raw = estimates.remove(&id).map(|(_, e)| e);
            self.take_over(engine, &id, raw, inputs.remove(&id).unwrap_or_default());
        }
        self.routes.lock().unwrap_or_else(|e| e.into_inner())[route as usize].seen = seen;
    }

    /// Starts a vehicle this instance now owns from the last estimate its previous owner published
    /// (mean and covariance; a particle filter draws its particles from them): the newer of the one in
    /// the owner's batches (`raw`) and one read otherwise; then replays the inputs newer than it.
    /// Without an estimate it starts from the inputs alone.
    fn take_over(
        &self,
        engine: &Engine,
        id: &str,
        raw: Option<Vec<u8>>,
        inputs: Vec<(Leaf, Vec<u8>)>,
    ) {
        let cached = self
            .cache
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
        let streamed = raw.and_then(|b| match serde_json::from_slice::<EstimateMsg>(&b) {
            Ok(e) if e.vehicle == id => Some(Arc::new(e)),
            _ => None,
        });
        let start = match (cached, streamed) {
            (Some(a), Some(b)) => Some(if b.t >= a.t { b } else { a }),
            (a, b) => a.or(b),
        };
        // (Inputs that do not decode were refused by the owner of the time.)
        let mut measurements: Vec<Measurement> = Vec::new();
        for (leaf, payload) in &inputs {
            let _ = engine.decode(*leaf, payload, &mut measurements);
        }
        // In time order (the vehicle would reorder them anyway, at the cost of replays).
        measurements.sort_by(|a, b| a.t_s().total_cmp(&b.t_s()));
        let base = engine.config.filter_for(id);
        let (state, replay, snapshot) = match &start {
            Some(e) => {
                let t0 = e.t + crate::filters::SAME_INSTANT_S;
                let last_gyro = measurements
                    .iter()
                    .filter_map(|m| match m {
                        Measurement::Gyro(g) if g.t_s <= t0 => Some(*g),
                        _ => None,
                    })
                    .reduce(|a, b| if b.t_s >= a.t_s { b } else { a });
                let seed = TakeoverSeed::try_from(e.as_ref());
                match seed.and_then(|seed| VehicleState::take_over(id, base, &seed, last_gyro)) {
                    Ok(state) => {
                        let newer: Vec<Measurement> =
                            measurements.into_iter().filter(|m| m.t_s() > t0).collect();
                        (state, newer, Some(e.clone()))
                    }
                    Err(r) => {
                        tracing::warn!(vehicle = id, error = %r.message, "cannot start from the last estimate; starting afresh");
                        (VehicleState::new(id, base.clone()), measurements, None)
                    }
                }
            }
            None => (VehicleState::new(id, base.clone()), measurements, None),
        };
        let n = replay.len();
        // (Queries answer the estimate the previous owner published until the first update here.)
        if !engine.adopt(id, state, snapshot, replay) {
            tracing::error!(
                vehicle = id,
                "takeover skipped: limits.max_vehicles reached"
            );
            return;
        }
        self.takeovers.fetch_add(1, Ordering::Relaxed);
        tracing::info!(
            vehicle = id,
            from_estimate = start.as_ref().map(|e| e.t),
            replayed = n,
            "vehicle taken over"
        );
    }

    /// Standby data kept now: inputs (received on their own, and in batches, as batches) and
    /// estimates (for `P/@/health`).
    pub fn standby_counts(&self) -> (usize, usize, usize) {
        let singles: usize = self
            .standby
            .lock()
            .map(|s| s.values().map(|q| q.len()).sum())
            .unwrap_or(0);
        let routes = self.routes.lock().unwrap_or_else(|e| e.into_inner());
        let batches: usize = routes.iter().map(|r| r.inputs.len()).sum();
        let estimates: usize = routes.iter().map(|r| r.estimates.len()).sum::<usize>()
            + self.cache.lock().map(|c| c.len()).unwrap_or(0);
        (
            singles + batches,
            estimates,
            routes.iter().map(|r| r.bytes).sum(),
        )
    }
}
