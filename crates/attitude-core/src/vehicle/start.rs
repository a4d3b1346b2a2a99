//! How a vehicle's filter starts and starts over: from a vector set (q-method), uniformly, from an
//! estimate (re-initialisation after a failure, a fully gated run of sets or an unhealthy state), and
//! the held gyro rate a new filter continues with.

use super::*;

impl VehicleState {
    /// A failed filter step: the filter rolled itself back; after repeated failures the vehicle
    /// re-initialises from its last good estimate.
    pub(super) fn failure(
        &mut self,
        e: &FilterError,
        t_s: f64,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) -> Rejection {
        let r = filter_error(e);
        if r.code != RejectCode::FilterError {
            return r;
        }
        self.rollbacks += 1;
        self.consecutive_failures += 1;
        tracing::warn!(vehicle = %self.id, t_s, error = %e, "filter step failed and was rolled back");
        if self.consecutive_failures >= policy.reinit_after_failures {
            self.consecutive_failures = 0;
            if self.reinit_from_last_good("health", t_s, policy) {
                self.check_and_emit(policy, out);
            }
        }
        r
    }

    pub(super) fn count_reinit(&mut self, reason: &str) {
        *self.reinits.entry(reason.to_string()).or_insert(0) += 1;
    }

    /// Restarts the filter from the last good estimate with its 1σ inflated, propagated to `t_s` with
    /// the held rate. Without a good estimate the vehicle goes back to initialising. True when a
    /// filter runs afterwards.
    pub(super) fn reinit_from_last_good(
        &mut self,
        reason: &str,
        t_s: f64,
        policy: &Policy,
    ) -> bool {
        self.count_reinit(reason);
        let Some(good) = self.last_good.clone() else {
            self.slot = Slot::Initializing;
            return false;
        };
        if self.restart_from(&good, t_s, policy).is_err() {
            self.slot = Slot::Initializing;
            self.last_good = None;
            return false;
        }
        true
    }

    pub(super) fn restart_from(
        &mut self,
        e: &Estimate,
        t_s: f64,
        policy: &Policy,
    ) -> Result<(), Rejection> {
        let f = policy.reinit_sigma_factor;
        let c = &e.covariance;
        let sigma_att = e
            .sigma_att_rad()
            .map(|s| (s * f).clamp(MIN_REINIT_SIGMA_RAD, MAX_REINIT_SIGMA_RAD));
        let bias_sigma = Vector3::from_fn(|i, _| {
            (c[(i + 3, i + 3)].max(0.0).sqrt() * f).max(self.config.init_bias_sigma_rad_s[i])
        });
        self.start(InitialState {
            t_s: Some(e.t_s.min(t_s)),
            q: e.q,
            sigma_att_rad: sigma_att,
            bias_rad_s: e.bias_rad_s,
            bias_sigma_rad_s: bias_sigma,
            uniform_attitude: false,
            covariance: None,
        })?;
        self.feed_held_rate(e.t_s.min(t_s))?;
        if let Slot::Tracking(filter) = &mut self.slot {
            filter.advance_to(t_s).map_err(|e| filter_error(&e))?;
        }
        Ok(())
    }

    /// K consecutive sets were gated entirely: the filter, not the sensors, is presumed wrong. Starts
    /// again the way the vehicle started (from this set when it determines the attitude, uniformly
    /// for a uniform-init particle filter), otherwise from the current estimate with its 1σ inflated;
    /// then uses the set.
    pub(super) fn reinit_for_gate(
        &mut self,
        set: &ObservationSet,
        policy: &Policy,
    ) -> Result<(), Rejection> {
        self.count_reinit("gate");
        self.consecutive_gated = 0;
        if q_method(&set.observations).is_ok() {
            return self.start_from_vectors(set, policy);
        }
        if self.config.init == InitMode::Uniform {
            self.start_uniform(set.t_s)?;
        } else {
            let Slot::Tracking(filter) = &self.slot else {
                return Ok(());
            };
            let e = filter.estimate();
            self.restart_from(&e, set.t_s, policy)?;
        }
        if let Slot::Tracking(filter) = &mut self.slot {
            filter
                .process(&Measurement::Vectors(set.clone()))
                .map_err(|e| filter_error(&e))?;
        }
        Ok(())
    }

    pub(super) fn start(&mut self, initial: InitialState) -> Result<(), Rejection> {
        let seed = seed_of(&self.id, self.generation);
        let filter = build_filter(&self.config.filter_config(), &initial, seed).map_err(|e| {
            Rejection::new(
                RejectCode::BadRequest,
                format!("cannot start the filter: {e}"),
            )
        })?;
        self.generation += 1;
        self.slot = Slot::Tracking(filter);
        self.consecutive_failures = 0;
        Ok(())
    }

    pub(super) fn start_uniform(&mut self, t_s: f64) -> Result<(), Rejection> {
        self.start(InitialState {
            t_s: Some(t_s),
            q: Quaternion::IDENTITY,
            sigma_att_rad: Vector3::repeat(std::f64::consts::PI),
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: self.config.init_bias_sigma_rad_s,
            uniform_attitude: true,
            covariance: None,
        })?;
        self.feed_held_rate(t_s)
    }

    /// Gives a newly started filter the last gyro rate, valid from `t_s` on.
    pub(super) fn feed_held_rate(&mut self, t_s: f64) -> Result<(), Rejection> {
        let (Some(g), Slot::Tracking(filter)) = (self.last_gyro, &mut self.slot) else {
            return Ok(());
        };
        filter
            .process(&Measurement::Gyro(GyroSample {
                t_s,
                omega_body_rad_s: g.omega_body_rad_s,
            }))
            .map_err(|e| filter_error(&e))
    }

    /// Starts from the q-method solution of `set` and its covariance (the set is not used twice).
    pub(super) fn start_from_vectors(
        &mut self,
        set: &ObservationSet,
        policy: &Policy,
    ) -> Result<(), Rejection> {
        // Observations of modelled sensors as the unit vectors their models would give (no checks:
        // there is no estimate to check against yet).
        let observations: Vec<VectorObservation> = set
            .observations
            .iter()
            .map(|o| {
                let modelled = o
                    .sensor
                    .as_deref()
                    .is_some_and(|n| policy.sensor_models.contains_key(n));
                let (nb, nr) = (o.body.norm(), o.reference.norm());
                if modelled && nb > 0.0 && nr > 0.0 && nb.is_finite() && nr.is_finite() {
                    VectorObservation {
                        body: o.body / nb,
                        reference: o.reference / nr,
                        sigma: o.sigma / nr,
                        ..o.clone()
                    }
                } else {
                    o.clone()
                }
            })
            .collect();
        let solution = q_method(&observations).map_err(|e| {
            Rejection::new(
                RejectCode::NotInitialized,
                format!(
                    "vehicle {} is initialising and this set cannot start it ({e}); send a set with two or more non-parallel vectors, or reset with an attitude",
                    self.id
                ),
            )
        })?;
        let c = solution.covariance;
        let sigma = Vector3::new(c[(0, 0)].sqrt(), c[(1, 1)].sqrt(), c[(2, 2)].sqrt());
        self.start(InitialState {
            t_s: Some(set.t_s),
            q: solution.q,
            sigma_att_rad: sigma,
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: self.config.init_bias_sigma_rad_s,
            uniform_attitude: false,
            covariance: None,
        })?;
        self.feed_held_rate(set.t_s)
    }
}
