//! The engine's side of a fleet (dynamic mode): which member owns a vehicle, the inputs kept on
//! standby for another member's vehicles, and the takeover when ownership moves here.

use super::*;

impl Engine {
    /// Whether this instance processes and answers for `vehicle` (any string: a wildcard chunk is
    /// owned too, so exactly one member refuses a wildcard put).
    pub fn owns(&self, vehicle: &str) -> bool {
        if let Some(shard) = &self.shard {
            let key = self.keys.vehicle(vehicle, Leaf::Gyro);
            let inside = zenoh::key_expr::KeyExpr::try_from(key.as_str())
                .map(|k| shard.intersects(&k))
                .unwrap_or(false);
            if !inside {
                return false;
            }
        }
        match self.config.fleet.mode {
            FleetMode::Single => true,
            FleetMode::Dynamic => {
                let members = self.fleet.members.read().unwrap_or_else(|e| e.into_inner());
                members.as_ref().and_then(|m| owner(vehicle, m))
                    == Some(&self.config.fleet.instance)
            }
        }
    }

    /// The live members, when known (dynamic mode).
    pub fn members(&self) -> Option<BTreeSet<String>> {
        self.fleet
            .members
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// An estimate another member published (or one read at start): kept as the starting point of a
    /// takeover. Our own vehicles' estimates are ignored; an older one never replaces a newer one.
    pub fn remember_estimate(&self, vehicle: &str, payload: &[u8]) {
        if self.config.fleet.mode != FleetMode::Dynamic || self.owns(vehicle) {
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
        let mut cache = self.fleet.cache.lock().unwrap_or_else(|e| e.into_inner());
        if cache.len() >= self.config.limits.max_vehicles && !cache.contains_key(vehicle) {
            return;
        }
        match cache.get(vehicle) {
            Some(old) if old.t > e.t => {}
            _ => {
                cache.insert(vehicle.to_string(), Arc::new(e));
            }
        }
    }

    /// Keeps an input of a vehicle another member owns for `fleet.standby_s` (dynamic mode).
    pub(super) fn keep_standby(&self, vehicle: &str, inbound: Inbound) {
        let window = self.config.fleet.standby_s;
        if self.config.fleet.mode != FleetMode::Dynamic
            || window <= 0.0
            || validate_vehicle_id(vehicle).is_err()
        {
            return;
        }
        let now = self.now_s();
        let mut standby = self.fleet.standby.lock().unwrap_or_else(|e| e.into_inner());
        if standby.len() >= self.config.limits.max_vehicles && !standby.contains_key(vehicle) {
            return;
        }
        let q = standby.entry(vehicle.to_string()).or_default();
        q.push_back((now, inbound));
        while q.len() > self.config.limits.queue_per_vehicle
            || q.front().is_some_and(|(t, _)| *t < now - window)
        {
            q.pop_front();
        }
    }

    /// Drops standby inputs older than the window (housekeeping).
    pub(super) fn trim_standby(&self) {
        let oldest = self.now_s() - self.config.fleet.standby_s;
        let mut standby = self.fleet.standby.lock().unwrap_or_else(|e| e.into_inner());
        standby.retain(|_, q| {
            while q.front().is_some_and(|(t, _)| *t < oldest) {
                q.pop_front();
            }
            !q.is_empty()
        });
    }

    /// The fleet's members changed (dispatcher thread, in order with the inputs): releases the
    /// vehicles another member now owns and takes over those this instance now owns.
    pub fn set_members(&self, members: BTreeSet<String>) {
        let changed = self.members().as_ref() != Some(&members);
        *self
            .fleet
            .members
            .write()
            .unwrap_or_else(|e| e.into_inner()) = Some(members.clone());
        if !changed {
            return;
        }
        tracing::info!(instance = %self.config.fleet.instance, ?members, "fleet members");
        for v in self.vehicles() {
            if !self.owns(&v.id) {
                self.release(&v);
            }
        }
        let candidates: BTreeSet<String> = {
            let cache = self.fleet.cache.lock().unwrap_or_else(|e| e.into_inner());
            let standby = self.fleet.standby.lock().unwrap_or_else(|e| e.into_inner());
            cache.keys().chain(standby.keys()).cloned().collect()
        };
        for id in candidates {
            if self.owns(&id) && self.vehicle(&id).is_none() {
                self.take_over(&id);
            }
        }
    }

    /// Hands a vehicle to its new owner: it leaves the registry (what its inbox still holds is
    /// processed and published), its last estimate is remembered (in case it comes back), and its
    /// checkpoint is removed (a restart must not resurrect it here).
    pub(super) fn release(&self, v: &Arc<Vehicle>) {
        self.vehicles
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&v.id);
        if let Some(e) = v.snapshot() {
            self.fleet
                .cache
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(v.id.clone(), e);
        }
        if let Some(dir) = &self.config.persistence.state_dir {
            let _ = std::fs::remove_file(persist::path_of(dir, &v.id));
        }
        self.fleet.released.fetch_add(1, Ordering::Relaxed);
        tracing::info!(vehicle = %v.id, "vehicle released to another member");
    }

    /// Starts a vehicle this instance now owns from the last estimate its previous owner published
    /// (mean and covariance; a particle filter draws its particles from them), then replays the
    /// standby inputs newer than that estimate. Without an estimate it starts from the inputs alone.
    pub(super) fn take_over(&self, id: &str) {
        let inputs = self
            .fleet
            .standby
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id)
            .unwrap_or_default();
        let cached = self
            .fleet
            .cache
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
        // (Inputs that do not decode were refused by the owner of the time.)
        let mut measurements: Vec<Measurement> = Vec::new();
        for (_, inbound) in &inputs {
            if let Some((_, leaf)) = self.keys.split(&inbound.key) {
                let _ = self.decode(leaf, &inbound.payload, &mut measurements);
            }
        }
        let base = self.config.filter_for(id);
        let (state, replay, snapshot) = match &cached {
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
        let v = {
            let mut map = self.vehicles.write().unwrap_or_else(|e| e.into_inner());
            if map.len() >= self.config.limits.max_vehicles {
                tracing::error!(
                    vehicle = id,
                    "takeover skipped: limits.max_vehicles reached"
                );
                return;
            }
            let v = Arc::new(Vehicle::new(id, state, SavedCounters::default()));
            map.insert(id.to_string(), v.clone());
            v
        };
        if snapshot.is_some() {
            // Queries answer the estimate the previous owner published until the first update here.
            *v.snapshot.write().unwrap_or_else(|e| e.into_inner()) = snapshot;
        }
        let n = replay.len();
        let at = self.now_s();
        v.received.fetch_add(n as u64, Ordering::Relaxed);
        v.dirty.store(true, Ordering::Release);
        v.inbox
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .extend(replay.into_iter().map(|m| Input::Measurement(m, at)));
        self.fleet.takeovers.fetch_add(1, Ordering::Relaxed);
        tracing::info!(
            vehicle = id,
            from_estimate = cached.as_ref().map(|e| e.t),
            replayed = n,
            "vehicle taken over"
        );
        self.schedule(&v);
    }
}
