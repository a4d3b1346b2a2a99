//! Queries: pure reads of the vehicles' snapshots and the counters (`P/V/state`, attitude,
//! covariance, `P/@/health`).

use super::*;

impl Engine {
    /// The estimate of a known vehicle, or why there is none.
    pub fn state_of(&self, vehicle: &str) -> Result<Arc<EstimateMsg>, Rejection> {
        let v = self.vehicle(vehicle).ok_or_else(|| {
            Rejection::new(
                RejectCode::UnknownVehicle,
                format!("no vehicle '{vehicle}' is known to this service"),
            )
        })?;
        v.snapshot().ok_or_else(|| {
            Rejection::new(
                RejectCode::NotInitialized,
                format!("vehicle '{vehicle}' has no estimate yet (waiting for a vector-observation set that determines its attitude)"),
            )
        })
    }

    pub fn attitude_of(&self, vehicle: &str) -> Result<AttitudeMsg, Rejection> {
        self.state_of(vehicle).map(|e| e.attitude())
    }

    pub fn covariance_of(&self, vehicle: &str) -> Result<CovarianceMsg, Rejection> {
        self.state_of(vehicle).map(|e| e.covariance())
    }

    pub(super) fn fleet_health(&self, owned: usize) -> FleetHealthMsg {
        let f = &self.config.fleet;
        let (standby_inputs, standby_estimates, standby_bytes) = self.standby_counts();
        let me = f.instance.as_str();
        let assignment = self.assignment();
        let served = |r: &u8| self.serves(*r);
        let routes = |of: &dyn Fn(&Assignment) -> Vec<u8>| match (f.mode, &assignment) {
            (FleetMode::Single, _) => (0..ROUTES as u8).filter(served).collect(),
            (FleetMode::Dynamic, Some(a)) => of(a).into_iter().filter(served).collect(),
            (FleetMode::Dynamic, None) => Vec::new(),
        };
        FleetHealthMsg {
            mode: f.mode.as_str().into(),
            group: f.group.clone(),
            instance: f.instance.clone(),
            vehicles: f.vehicles.clone(),
            members: match f.mode {
                FleetMode::Single => vec![f.instance.clone()],
                FleetMode::Dynamic => self.members().unwrap_or_default().into_iter().collect(),
            },
            owned,
            takeovers: self.fleet.takeovers.load(Ordering::Relaxed),
            released: self.fleet.released.load(Ordering::Relaxed),
            routes_owned: routes(&|a| a.owned_by(me)),
            routes_standby: match f.mode {
                FleetMode::Single => Vec::new(),
                FleetMode::Dynamic => routes(&|a| {
                    a.held_by(me)
                        .into_iter()
                        .filter(|&r| !a.owns(me, r))
                        .collect()
                }),
            },
            standby_inputs,
            standby_estimates,
            standby_bytes,
            standby_malformed: self.fleet.malformed.load(Ordering::Relaxed),
        }
    }

    pub fn health(&self) -> HealthMsg {
        let c = &self.counters;
        let vehicles = self.vehicles();
        let mut rejected = c.rejected_by_code();
        let overflow = c.ingest_overflow.load(Ordering::Relaxed);
        if overflow > 0 {
            rejected.insert("ingest_overflow".into(), overflow);
        }
        HealthMsg {
            status: "ok".into(),
            version: env!("CARGO_PKG_VERSION").into(),
            uptime_s: self.uptime_s(),
            vehicles: vehicles.len(),
            received: c.received.load(Ordering::Relaxed),
            processed: c.processed.load(Ordering::Relaxed),
            estimates_published: c.estimates.load(Ordering::Relaxed),
            rejected,
            queries: c.queries.load(Ordering::Relaxed),
            held: vehicles
                .iter()
                .map(|v| v.held.load(Ordering::Relaxed) as u64)
                .sum(),
            gated: vehicles
                .iter()
                .map(|v| v.gated.load(Ordering::Relaxed))
                .sum(),
            reinits: vehicles
                .iter()
                .map(|v| v.reinits.load(Ordering::Relaxed))
                .sum(),
            rollbacks: vehicles
                .iter()
                .map(|v| v.rollbacks.load(Ordering::Relaxed))
                .sum(),
            late_fused: vehicles
                .iter()
                .map(|v| v.late_fused.load(Ordering::Relaxed))
                .sum(),
            history_bytes: vehicles
                .iter()
                .map(|v| v.history_bytes.load(Ordering::Relaxed))
                .sum(),
            missed: c.missed.load(Ordering::Relaxed),
            gaps: vehicles
                .iter()
                .map(|v| v.gaps.load(Ordering::Relaxed))
                .sum(),
            blind_s: vehicles
                .iter()
                .map(|v| v.blind_us.load(Ordering::Relaxed))
                .sum::<u64>() as f64
                * 1e-6,
            ingest: IngestHealthMsg {
                recovery: self.config.ingest.recovery,
                depth: self.ingest_depth.len(),
                capacity: INGEST_CAPACITY,
                waited: self.admission.waited.load(Ordering::Relaxed),
                wait_s: self.admission.waited_ns.load(Ordering::Relaxed) as f64 * 1e-9,
                refused: overflow,
                redelivered: self.admission.redelivered.load(Ordering::Relaxed),
            },
            checkpoints: self
                .config
                .persistence
                .state_dir
                .as_ref()
                .map(|d| CheckpointHealthMsg {
                    state_dir: d.display().to_string(),
                    interval_s: self.config.persistence.checkpoint_interval_s,
                    restored: c.restored.load(Ordering::Relaxed),
                    skipped: c.skipped.load(Ordering::Relaxed),
                    written: c.written.load(Ordering::Relaxed),
                    failed: c.write_failed.load(Ordering::Relaxed),
                }),
            fleet: Some(self.fleet_health(vehicles.len())),
        }
    }
}
