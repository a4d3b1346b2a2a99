//! What a vehicle makes of a vector set before its filter sees it: the models of named sensors
//! (`service.sensors.NAME.kind`) and the innovation gate, with their counts.

use super::*;

impl VehicleState {
    /// Records the estimate after a vector set in the sensor models' state (the gravity low-pass
    /// carries its vector from it).
    pub(super) fn settle_sensors(&mut self) {
        if self.sensor_state.is_empty() {
            return;
        }
        if let Slot::Tracking(f) = &self.slot {
            let q = f.estimate().q;
            for s in self.sensor_state.values_mut() {
                s.settle(&q);
            }
        }
    }

    /// The gate counts of sensor `name` (`other` beyond the per-vehicle limit of names).
    pub(super) fn counts(&mut self, name: Option<&str>, policy: &Policy) -> &mut GateCounts {
        let name = name.unwrap_or(UNNAMED);
        let key =
            if self.gate.contains_key(name) || self.gate.len() < policy.max_sensors_per_vehicle {
                name
            } else {
                OTHER
            };
        // (A name is copied only the first time it is counted: this runs for every observation.)
        if !self.gate.contains_key(key) {
            self.gate.insert(key.to_string(), GateCounts::default());
        }
        self.gate.get_mut(key).expect("inserted above")
    }

    /// Applies the sensor models (`service.sensors.NAME.kind`, crate::sensors::model) about `prior`:
    /// observations of modelled sensors come out as unit vectors with their adapted σ (heading-only for
    /// a `field` sensor with `heading_only`), or are left out (`norm_gated`, `disturbed`, counted).
    pub(super) fn apply_models(
        &mut self,
        mut set: ObservationSet,
        prior: &Estimate,
        policy: &Policy,
    ) -> ObservationSet {
        if policy.sensor_models.is_empty() {
            return set;
        }
        let a = prior.q.attitude_matrix();
        let observations = std::mem::take(&mut set.observations);
        for o in observations {
            let Some(model) = o
                .sensor
                .as_deref()
                .and_then(|n| policy.sensor_models.get(n))
            else {
                set.observations.push(o);
                continue;
            };
            let name = o.sensor.clone().unwrap_or_default();
            // Sensor state is kept for configured names only, so it is bounded by the config.
            let state = self.sensor_state.entry(name).or_default();
            match model.apply(&o, set.t_s, &a, state) {
                Verdict::Use(used) => set.observations.push(used),
                Verdict::NormGated { .. } => {
                    self.counts(o.sensor.as_deref(), policy).norm_gated += 1;
                }
                Verdict::Disturbed { .. } | Verdict::HeldOff => {
                    self.counts(o.sensor.as_deref(), policy).disturbed += 1;
                }
                // No direction: left to the filter, which refuses what it cannot use.
                Verdict::Unusable => set.observations.push(o),
            }
        }
        set
    }

    /// The observations of `set` that pass their sensor's χ² gate about `prior`; counts both kinds.
    pub(super) fn gate(
        &mut self,
        set: &ObservationSet,
        prior: &Estimate,
        policy: &Policy,
    ) -> Vec<VectorObservation> {
        let a = prior.q.attitude_matrix();
        let p_att: Matrix3<f64> = prior.covariance.fixed_view::<3, 3>(0, 0).into_owned();
        let informative = prior
            .sigma_att_rad()
            .iter()
            .all(|s| *s < GATE_MAX_PRIOR_SIGMA_RAD);
        let mut accepted = Vec::with_capacity(set.observations.len());
        for o in &set.observations {
            let pass = match policy.gate_for(o.sensor.as_deref()) {
                _ if !informative => true,
                // A heading-only observation is not judged by the 3-dof vector gate.
                _ if o.aspect != Aspect::Full => true,
                None => true,
                Some(threshold) => {
                    // ν = b − A r, S = [b̂×] P [b̂×]ᵀ + σ² I (the MEKF's measurement model).
                    let predicted = a * o.reference;
                    let h = skew(&predicted);
                    let s = h * p_att * h.transpose() + Matrix3::identity() * (o.sigma * o.sigma);
                    let nu = o.body - predicted;
                    match s.cholesky() {
                        Some(c) => {
                            let nis = nu.dot(&c.solve(&nu));
                            // A non-finite NIS cannot be judged: let the filter decide.
                            !(nis > threshold)
                        }
                        None => true,
                    }
                }
            };
            let c = self.counts(o.sensor.as_deref(), policy);
            if pass {
                c.accepted += 1;
                accepted.push(o.clone());
            } else {
                c.gated += 1;
            }
        }
        accepted
    }
}
