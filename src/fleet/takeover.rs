//! A change of the fleet's members, on the engine's dispatcher thread in order with the inputs: the
//! routes are assigned again; this member releases the vehicles of the routes it no longer owns, takes
//! over the routes it now owns (each vehicle from its previous owner's last estimate, replaying the
//! inputs kept since, each once), and forgets the standby data of the routes it no longer keeps.

use super::batch;
use super::member::Member;
use super::standby::{input_hash, input_leaf};
use crate::engine::{Engine, Inbound, Vehicle};
use crate::sensors::Measurement;
use crate::vehicle::{TakeoverSeed, VehicleState};
use crate::wire::keys::{route_of, Leaf, Received, ROUTES};
use crate::wire::{validate_vehicle_id, EstimateMsg};
use std::collections::{BTreeMap, BTreeSet, HashSet, VecDeque};
use std::sync::atomic::Ordering;
use std::sync::Arc;

/// How long after a takeover a route's inputs are checked against those already used, s: longer than a
/// subscription takes to reach the senders plus a sender's interval between batches (at most 1 s; the
/// senders here send every 0.25 s).
pub const TAKEOVER_GRACE_S: f64 = 2.0;

impl Member {
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
}
