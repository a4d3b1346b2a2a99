//! This instance as a member of its fleet ([`Member`]): the routes it owns and holds (and, outside a
//! dynamic fleet, the static shard it serves), the standby data it keeps for the routes it holds but
//! does not own, the takeover when a route becomes its own, and the batches of estimates it sends its
//! routes' standby members. The engine reaches it through its hooks (`service::Node`): who owns a
//! vehicle, what a standby keeps, what happens to an estimate; a change of members runs on the
//! engine's dispatcher thread, in order with the inputs.
//!
//!
//! Files: this one (the member: ownership, the route plan, the batches of estimates), `standby.rs` (what
//! it keeps for the routes it holds), `takeover.rs` (a change of members: releases and takeovers).

use super::assignment::{Assignment, FleetConfig, FleetMode};
use super::batch::BatchWriter;
use super::standby::RouteStandby;
use crate::engine::{Engine, Inbound, Sink, Task};
use crate::service::config::ServiceConfig;
use crate::wire::keys::{route_of, Keys, Leaf, ROUTES};
use crate::wire::EstimateMsg;
use std::collections::{BTreeSet, HashMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock};

/// What the service subscribes to (dynamic mode): the routed inputs of the routes owned; the standby
/// batches of the routes held but not owned, and of the routes taken over while their grace lasts (a
/// batch sent before the takeover may hold inputs that never reached this member on their own).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RoutePlan {
    pub owned: Vec<u8>,
    pub standby: Vec<u8>,
}

/// A route's estimates waiting for the next batch to its standby members: by vehicle, whether it is
/// new since the last batch and the serialised estimate.
type Outgoing = HashMap<String, (bool, Vec<u8>)>;

/// This instance in its fleet: what it knows of the other members, the standby data it keeps and the
/// batches it sends. Every instance has one (a single instance owns the routes it serves).
pub struct Member {
    pub(super) fleet: FleetConfig,
    /// `limits.max_vehicles` and `limits.queue_per_vehicle`.
    pub(super) max_vehicles: usize,
    pub(super) queue_per_vehicle: usize,
    pub(super) keys: Keys,
    /// Where the batches of estimates go.
    pub(super) sink: Sink,
    /// `P/<shard>/x` when statically sharded (`fleet.vehicles` other than `*`).
    pub(super) shard: Option<zenoh::key_expr::OwnedKeyExpr>,
    /// The live members (this instance among them); `None` until first known: nothing is owned
    /// before, so a starting instance never processes what another member owns.
    pub(super) members: RwLock<Option<BTreeSet<String>>>,
    /// The routes' owners and holders for `members`.
    pub(super) assignment: RwLock<Option<Arc<Assignment>>>,
    /// Before joining: the assignment once this instance has joined. It holds (keeps the standby
    /// data of) the routes it will hold, and owns nothing yet.
    pub(super) prepared: RwLock<Option<Arc<Assignment>>>,
    /// Estimates read before a takeover (at start, or the last of a vehicle released), parsed.
    pub(super) cache: Mutex<HashMap<String, Arc<EstimateMsg>>>,
    /// Inputs received one by one for vehicles of routes held but not owned (plain keys, which
    /// every member receives, or a routed input during a change of owner), with their arrival
    /// (engine time, s), for `fleet.standby_s`.
    pub(super) standby: Mutex<HashMap<String, VecDeque<(f64, Inbound)>>>,
    /// Per route: its standby data (the senders' batches of its inputs, its owner's last estimates)
    /// while held, and after a takeover the inputs already used.
    pub(super) routes: Mutex<Vec<RouteStandby>>,
    /// Per route owned: each vehicle's last estimate, and whether it was published since the last
    /// batch to the route's standby members.
    pub(super) outgoing: Mutex<Vec<Outgoing>>,
    /// The routes to subscribe to, for the service (`service::run`).
    pub(super) plan: Option<tokio::sync::watch::Sender<RoutePlan>>,
    pub(super) takeovers: AtomicU64,
    pub(super) released: AtomicU64,
    /// Standby batches that could not be read.
    pub(super) malformed: AtomicU64,
    /// The housekeeping's next batch of estimates and next trim of the standby data (engine time, s).
    pub(super) next: Mutex<(f64, f64)>,
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

    /// The longest `housekeeping` may wait between two calls, s: the estimates' flush (and the
    /// standby data's trim, every second) of a dynamic member.
    pub fn housekeeping_period_s(&self) -> f64 {
        if self.dynamic() {
            self.fleet.flush_s.min(1.0)
        } else {
            f64::INFINITY
        }
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
    pub(super) fn dynamic(&self) -> bool {
        self.fleet.mode == FleetMode::Dynamic
    }

    pub(super) fn me(&self) -> &str {
        &self.fleet.instance
    }

    /// Whether `vehicle` is inside this instance's static shard (`fleet.vehicles`).
    pub(super) fn in_shard(&self, vehicle: &str) -> bool {
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
    pub(super) fn assign(&self, members: &BTreeSet<String>) -> Option<Arc<Assignment>> {
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
    pub(super) fn keeps(&self, route: u8) -> bool {
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
    pub(super) fn publish_plan(&self, now: f64) {
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
    /// [`Member::set_members`].
    pub fn prepare(&self, engine: &Engine, members: &BTreeSet<String>) {
        *self.prepared.write().unwrap_or_else(|e| e.into_inner()) = self.assign(members);
        self.publish_plan(engine.now_s());
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
}
