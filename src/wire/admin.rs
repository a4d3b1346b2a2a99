//! The simulator's truth and the administrative replies (`P/@/vehicles`, `P/@/health`).

use super::QuaternionMsg;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// `P/V/truth`, published by the simulator.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthMsg {
    pub vehicle: String,
    pub t: f64,
    pub q: QuaternionMsg,
    /// True gyro bias, rad/s.
    pub bias: [f64; 3],
}

/// One row of `P/@/vehicles`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleInfoMsg {
    pub vehicle: String,
    /// `initializing` (waiting for a usable vector set) or `tracking`.
    pub state: String,
    pub filter: String,
    pub fiducial: Option<String>,
    /// Time of the last processed measurement, s (null before the first).
    pub t: Option<f64>,
    pub received: u64,
    pub processed: u64,
    pub rejected: u64,
    pub estimates: u64,
}

/// `P/@/health` reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HealthMsg {
    pub status: String,
    pub version: String,
    pub uptime_s: f64,
    pub vehicles: usize,
    /// Measurement samples received (a batch counts its items).
    pub received: u64,
    /// Samples the filters used.
    pub processed: u64,
    pub estimates_published: u64,
    /// A subscriber of another session matches `P/*/estimate`: while none does, estimates are neither
    /// serialised nor put (queries still answer the last), so one subscribed a moment ago may miss
    /// the next until this is true.
    #[serde(default)]
    pub listened: bool,
    /// Refused inputs and requests, by code.
    pub rejected: BTreeMap<String, u64>,
    pub queries: u64,
    /// Samples waiting in the vehicles' reorder windows.
    #[serde(default)]
    pub held: u64,
    /// Observations refused by the innovation gate, re-initialisations and rolled-back filter steps,
    /// summed over the vehicles.
    #[serde(default)]
    pub gated: u64,
    #[serde(default)]
    pub reinits: u64,
    #[serde(default)]
    pub rollbacks: u64,
    /// Late samples fused by rolling back and replaying, summed over the vehicles (since each was
    /// created or restored), and the bytes their histories hold (`service.time.history_bytes` each at
    /// most).
    #[serde(default)]
    pub late_fused: u64,
    #[serde(default)]
    pub history_bytes: u64,
    /// Puts of the vehicles' inputs that zenoh reported lost and could not recover, summed
    /// (`samples_missed`).
    #[serde(default)]
    pub missed: u64,
    /// Gaps in the vehicles' gyro or raw-IMU samples (each bridged, paid for in the covariance and
    /// told as `gap`), and the seconds the raw-IMU ones hid, summed (since each was created or
    /// restored).
    #[serde(default)]
    pub gaps: u64,
    #[serde(default)]
    pub blind_s: f64,
    /// How inputs get from zenoh to the vehicles: recovery, back-pressure, refusals.
    #[serde(default)]
    pub ingest: IngestHealthMsg,
    /// Checkpointing, when a state directory is configured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoints: Option<CheckpointHealthMsg>,
    /// This instance and its fleet.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fleet: Option<FleetHealthMsg>,
}

/// `P/@/health` `ingest`: the way from zenoh to the vehicles (proto/README.md, "Loss, recovery and
/// back-pressure").
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IngestHealthMsg {
    /// The input keys are subscribed with sample-miss detection and recovery (`service.ingest.recovery`).
    pub recovery: bool,
    /// Inputs waiting for the dispatcher now, and the channel's capacity.
    pub depth: usize,
    pub capacity: usize,
    /// Inputs of plain publishers that waited for room (holding zenoh's receiving thread: back-pressure
    /// on their sender), and the seconds waited in all.
    pub waited: u64,
    pub wait_s: f64,
    /// Inputs refused on arrival for want of room (`rejected.ingest_overflow`; each told on
    /// `P/V/rejected` as `queue_full`).
    pub refused: u64,
    /// Samples of vehicles restored from checkpoints that zenoh delivered again from a publisher's
    /// cache after the restart, at or before what the checkpoint already held: skipped.
    pub redelivered: u64,
}

/// `P/@/health` `fleet`: this instance's place in its fleet.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FleetHealthMsg {
    /// `single` or `dynamic`.
    pub mode: String,
    pub group: String,
    pub instance: String,
    /// The vehicle key-expression chunk served (`*` unless statically sharded).
    pub vehicles: String,
    /// The live members of the group (dynamic mode; just this instance otherwise), sorted.
    pub members: Vec<String>,
    /// Vehicles this instance owns now.
    pub owned: usize,
    /// Vehicles taken over from another member, and handed to another member, since start.
    pub takeovers: u64,
    pub released: u64,
    /// The routes this instance owns (all 16 in single mode), and those it keeps standby data for
    /// (dynamic mode): `0`..`15` (`proto/README.md`, Routed inputs).
    pub routes_owned: Vec<u8>,
    pub routes_standby: Vec<u8>,
    /// Standby data kept for a takeover: inputs (received one by one, and senders' batches, a batch
    /// counting once), the last estimates of vehicles, and their bytes.
    pub standby_inputs: usize,
    pub standby_estimates: usize,
    pub standby_bytes: usize,
    /// Standby batches that could not be read and were dropped.
    pub standby_malformed: u64,
}

/// `P/@/health` `checkpoints`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointHealthMsg {
    pub state_dir: String,
    pub interval_s: f64,
    /// Vehicles restored at start, and checkpoint files skipped then (corrupt, unreadable, of another
    /// format version, or holding a state the core refuses).
    pub restored: u64,
    pub skipped: u64,
    /// Checkpoint files written and failed writes since start.
    pub written: u64,
    pub failed: u64,
}
