//! Queries: pure reads of the vehicles' snapshots, the engine's counters and the fleet member's
//! (`P/V/state`, attitude, covariance, `P/@/vehicles`, `P/@/health`). Nothing here touches a filter.

use crate::engine::{Engine, VehicleTotals, INGEST_CAPACITY};
use crate::fleet::{Assignment, FleetMode, Member};
use crate::wire::keys::ROUTES;
use crate::wire::{
    AttitudeMsg, CheckpointHealthMsg, CovarianceMsg, EstimateMsg, FleetHealthMsg, HealthMsg,
    IngestHealthMsg, RejectCode, Rejection, VehicleInfoMsg,
};
use std::sync::atomic::Ordering;
use std::sync::Arc;

/// The estimate of a known vehicle, or why there is none.
pub fn state_of(engine: &Engine, vehicle: &str) -> Result<Arc<EstimateMsg>, Rejection> {
    let v = engine.vehicle(vehicle).ok_or_else(|| {
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

pub fn attitude_of(engine: &Engine, vehicle: &str) -> Result<AttitudeMsg, Rejection> {
    state_of(engine, vehicle).map(|e| e.attitude())
}

pub fn covariance_of(engine: &Engine, vehicle: &str) -> Result<CovarianceMsg, Rejection> {
    state_of(engine, vehicle).map(|e| e.covariance())
}

/// `P/@/vehicles`: every vehicle's row, sorted by id.
pub fn vehicles(engine: &Engine) -> Vec<VehicleInfoMsg> {
    engine.vehicles().iter().map(|v| v.info()).collect()
}

/// The fleet part of `P/@/health`: `owned`, the vehicles this instance has.
pub fn fleet_health(member: &Member, owned: usize) -> FleetHealthMsg {
    let f = member.config();
    let (standby_inputs, standby_estimates, standby_bytes) = member.standby_counts();
    let (takeovers, released, malformed) = member.moves();
    let me = f.instance.as_str();
    let assignment = member.assignment();
    let served = |r: &u8| member.serves(*r);
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
            FleetMode::Dynamic => member.members().unwrap_or_default().into_iter().collect(),
        },
        owned,
        takeovers,
        released,
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
        standby_malformed: malformed,
    }
}

/// `P/@/health`: the engine's counters, its vehicles' totals summed, the ingest, the checkpoints and
/// the fleet.
pub fn health(engine: &Engine, member: &Member) -> HealthMsg {
    let c = &engine.counters;
    let vehicles = engine.vehicles();
    let totals: Vec<VehicleTotals> = vehicles.iter().map(|v| v.totals()).collect();
    let sum = |f: fn(&VehicleTotals) -> u64| totals.iter().map(f).sum::<u64>();
    let mut rejected = c.rejected_by_code();
    let overflow = c.ingest_overflow.load(Ordering::Relaxed);
    if overflow > 0 {
        rejected.insert("ingest_overflow".into(), overflow);
    }
    HealthMsg {
        status: "ok".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        uptime_s: engine.uptime_s(),
        vehicles: vehicles.len(),
        received: c.received.load(Ordering::Relaxed),
        processed: c.processed.load(Ordering::Relaxed),
        estimates_published: c.estimates.load(Ordering::Relaxed),
        listened: engine.estimates_listened(),
        rejected,
        queries: c.queries.load(Ordering::Relaxed),
        held: sum(|t| t.held as u64),
        gated: sum(|t| t.gated),
        reinits: sum(|t| t.reinits),
        rollbacks: sum(|t| t.rollbacks),
        late_fused: sum(|t| t.late_fused),
        history_bytes: sum(|t| t.history_bytes),
        missed: c.missed.load(Ordering::Relaxed),
        gaps: sum(|t| t.gaps),
        blind_s: sum(|t| t.blind_us) as f64 * 1e-6,
        ingest: IngestHealthMsg {
            recovery: engine.config.ingest.recovery,
            depth: engine.ingest_depth(),
            capacity: INGEST_CAPACITY,
            waited: engine.admission.waited.load(Ordering::Relaxed),
            wait_s: engine.admission.waited_ns.load(Ordering::Relaxed) as f64 * 1e-9,
            refused: overflow,
            redelivered: engine.admission.redelivered.load(Ordering::Relaxed),
        },
        checkpoints: engine
            .config
            .persistence
            .state_dir
            .as_ref()
            .map(|d| CheckpointHealthMsg {
                state_dir: d.display().to_string(),
                interval_s: engine.config.persistence.checkpoint_interval_s,
                restored: c.restored.load(Ordering::Relaxed),
                skipped: c.skipped.load(Ordering::Relaxed),
                written: c.written.load(Ordering::Relaxed),
                failed: c.write_failed.load(Ordering::Relaxed),
            }),
        fleet: Some(fleet_health(member, vehicles.len())),
    }
}
