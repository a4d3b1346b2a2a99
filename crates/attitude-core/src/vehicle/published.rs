//! What a vehicle hands out, in domain terms: a published estimate with the vehicle's own diagnostics,
//! and the outcome of a reset. The wire (`crate::wire`) turns them into messages, once, at the edge.

use crate::ahrs::{AhrsCounts, MeasuredNoise};
use crate::filters::{Estimate, FilterSpec};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::sync::Arc;

/// One sensor's gate counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GateCounts {
    pub accepted: u64,
    pub gated: u64,
    /// Observations of a `gravity` sensor left out because their norm deviated beyond `norm_gate`.
    pub norm_gated: u64,
    /// Observations of a `field` sensor left out as disturbed (norm or dip) or in the hold-off after a
    /// disturbance.
    pub disturbed: u64,
}

/// The raw-IMU pipeline's magnetic reference: norm (the magnetometer's unit), dip (rad), body-frame
/// hard-iron offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldReference {
    pub norm: f64,
    pub dip_rad: f64,
    pub offset: Vector3<f64>,
    /// Confirmed by rotation (a hard-iron fit found it); else the reading of the start.
    pub confirmed: bool,
}

/// What the raw-IMU pipeline has done and sees now.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuDiagnostics {
    pub counts: AhrsCounts,
    /// Once there is one.
    pub field: Option<FieldReference>,
    /// The sensors' noise measured at rest.
    pub measured: MeasuredNoise,
}

/// An estimate as the vehicle publishes it.
#[derive(Clone, Debug, PartialEq)]
pub struct Published {
    pub vehicle: Arc<str>,
    /// The filter's estimate; an IMU vehicle's attitude covariance includes the time-stamp
    /// uncertainty (`crate::ahrs`).
    pub estimate: Estimate,
    pub spec: FilterSpec,
    /// The particle count of a particle filter.
    pub particles: Option<usize>,
    /// The sparse-grid level of an SGHQF.
    pub level: Option<u8>,
    /// Estimates published for this vehicle so far (1 for the first).
    pub seq: u64,
    /// Gate counts by sensor name.
    pub gate: BTreeMap<String, GateCounts>,
    pub consecutive_gated: u32,
    pub rollbacks: u64,
    /// Re-initialisations by reason.
    pub reinits: BTreeMap<String, u64>,
    /// Samples waiting in the reorder window.
    pub held: usize,
    /// Published again by a replay after a late sample: it replaces the estimate of the same `seq`.
    pub replayed: bool,
    /// Late samples the vehicle has fused by a replay (since it was created or restored).
    pub late_fused: u64,
    /// A vehicle fed raw IMU samples.
    pub imu: Option<ImuDiagnostics>,
}

/// A reset applied: the filter the vehicle runs now and, when the reset gave an attitude, its first
/// estimate (published too).
#[derive(Clone, Debug, PartialEq)]
pub struct ResetOutcome {
    pub vehicle: String,
    pub tracking: bool,
    pub spec: FilterSpec,
    pub particles: Option<usize>,
    pub level: Option<u8>,
    pub estimate: Option<Published>,
}
