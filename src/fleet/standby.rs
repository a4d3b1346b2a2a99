//! What a member keeps for the routes it holds but does not own (dynamic mode), and what it reads of
//! it when a route becomes its own.
//!
//! A route's standby data comes in batches (`fleet::batch`): its inputs from their senders
//! (`P/@/standby/<r>/inputs`), its estimates from its owner (`P/@/standby/<r>/estimates/<G>`). They are
//! kept as they arrive, not parsed: a takeover (`takeover.rs`) reads them. Inputs a member receives one
//! by one for a vehicle it does not own (plain keys, which every member receives, or a routed input
//! while the owner changes) are kept per vehicle. A takeover uses both, each input once: for a while
//! after it (`grace`, the longest a subscription takes to reach the senders) the route's inputs are
//! checked against those already used, by a hash of their vehicle, leaf and bytes, whether they come
//! one by one or in a batch (senders send their batches at least every second).

use super::batch;
use super::member::Member;
use crate::engine::{Engine, Inbound, Vehicle};
use crate::sensors::Measurement;
use crate::wire::keys::{route_of, Leaf, Received, ROUTES};
use crate::wire::{validate_vehicle_id, EstimateMsg};
use std::collections::{HashMap, HashSet, VecDeque};
use std::sync::atomic::Ordering;
use std::sync::Arc;

/// A route's standby data (kept while held and not owned) and its takeover's memory.
#[derive(Default)]
pub(super) struct RouteStandby {
    /// The senders' batches of the route's inputs, with their arrival (engine time, s), oldest first.
    pub(super) inputs: VecDeque<(f64, Vec<u8>)>,
    /// The last estimate of each of the route's vehicles, as its owner published it (JSON).
    pub(super) estimates: HashMap<String, (f64, Vec<u8>)>,
    /// Bytes of `inputs` and `estimates`.
    pub(super) bytes: usize,
    /// Until this engine time after a takeover, the hashes of the route's inputs already used.
    pub(super) grace_until: f64,
    pub(super) seen: HashSet<u64>,
}

impl RouteStandby {
    pub(super) fn clear(&mut self) {
        self.inputs.clear();
        self.estimates.clear();
        self.bytes = 0;
    }
}

/// Which input one is, to use it once: its vehicle, its leaf and its bytes.
pub(super) fn input_hash(vehicle: &str, leaf: Leaf, payload: &[u8]) -> u64 {
    let h = crate::rng::fnv1a(vehicle.bytes(), crate::rng::FNV_OFFSET);
    let h = crate::rng::fnv1a(leaf.as_str().bytes().chain([0xff]), h);
    crate::rng::fnv1a(payload.iter().copied(), h)
}

/// An input leaf by its name in a batch record.
pub(super) fn input_leaf(name: &str) -> Option<Leaf> {
    match name {
        "gyro" => Some(Leaf::Gyro),
        "vectors" => Some(Leaf::Vectors),
        "imu" => Some(Leaf::Imu),
        _ => None,
    }
}

impl Member {
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
    pub(super) fn trim_standby(&self, engine: &Engine) {
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
