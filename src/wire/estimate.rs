//! The outputs: `P/V/estimate` (also the `P/V/state` reply), the attitude and covariance replies,
//! error replies.

use super::input::number;
use super::{RejectCode, Rejection};
use crate::attitude::Quaternion;
use crate::filters::{Estimate, FilterSpec};
use crate::vehicle::{GateCounts, ImuDiagnostics, Published};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// `{"w", "x", "y", "z"}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuaternionMsg {
    #[serde(deserialize_with = "number")]
    pub w: f64,
    #[serde(deserialize_with = "number")]
    pub x: f64,
    #[serde(deserialize_with = "number")]
    pub y: f64,
    #[serde(deserialize_with = "number")]
    pub z: f64,
}

impl QuaternionMsg {
    /// From a domain quaternion, normalised to `w ≥ 0`.
    pub fn from_domain(q: &Quaternion) -> Self {
        let q = q.canonical();
        QuaternionMsg {
            w: q.w,
            x: q.x,
            y: q.y,
            z: q.z,
        }
    }

    /// To a unit domain quaternion; refuses non-finite or (near-)zero input.
    pub fn to_domain(&self) -> Result<Quaternion, Rejection> {
        let q = Quaternion::new(self.x, self.y, self.z, self.w);
        if !q.is_finite() {
            return Err(Rejection::new(RejectCode::NonFinite, "q must be finite"));
        }
        if (q.norm() - 1.0).abs() > 1e-3 {
            return Err(Rejection::new(
                RejectCode::BadRequest,
                format!("q must be a unit quaternion (norm {})", q.norm()),
            ));
        }
        q.normalized()
            .ok_or_else(|| Rejection::new(RejectCode::ZeroVector, "q has no direction"))
    }
}

/// What a filter knows about itself, as published. Absent fields do not apply to the filter.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnosticsMsg {
    pub propagations: u64,
    pub updates: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nis: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nis_dof: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ess: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<usize>,
    /// The sparse-grid level of an SGHQF.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<u8>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub concentration: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eigen_gap: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pc_stages: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resamples: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fiducial_fallbacks: Option<u64>,
    /// Inputs of this vehicle refused so far, by code.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub rejected: BTreeMap<String, u64>,
    /// Seconds since the last gyro sample while a gyro gap is in progress (the uncertainty is being
    /// inflated); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro_gap_s: Option<f64>,
    /// Gyro gaps so far.
    #[serde(default)]
    pub gyro_gaps: u64,
    /// Observations used and refused by the χ² innovation gate, per sensor name (`unnamed` for
    /// observations without one).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub gate: BTreeMap<String, GateCountsMsg>,
    /// Consecutive vector sets whose every observation was gated (the vehicle re-initialises at
    /// `gate.reinit_after`).
    #[serde(default)]
    pub consecutive_gated: u32,
    /// Inputs whose filter step failed numerically and was rolled back.
    #[serde(default)]
    pub rollbacks: u64,
    /// Re-initialisations by reason: `gate` (K consecutive gated sets), `health` (a non-finite or
    /// non-positive-definite state, or repeated failures).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub reinits: BTreeMap<String, u64>,
    /// Samples waiting in the reorder window.
    #[serde(default)]
    pub held: usize,
    /// Published again by a replay after a late sample: replaces the estimate of the same `seq`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub replayed: bool,
    /// Late samples fused by rolling back and replaying (since the vehicle was created or restored).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub late_fused: u64,
    /// Puts of this vehicle's inputs that zenoh reported lost on the way and could not recover from
    /// the publisher's cache (each report also a `samples_missed` on `P/V/rejected`), since the
    /// vehicle was created or restored.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub missed: u64,
    /// The raw-IMU pipeline of a vehicle fed `P/V/imu` (absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imu: Option<ImuDiagnosticsMsg>,
}

/// What the raw-IMU pipeline has done and sees now (`crate::ahrs`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuDiagnosticsMsg {
    /// IMU samples taken.
    pub samples: u64,
    /// At rest now, and samples at rest so far.
    pub at_rest: bool,
    pub rest_samples: u64,
    /// Gyro-bias updates at rest, tilt (gravity) updates, tilt updates left out by the norm gate,
    /// heading (magnetometer) updates, heading updates left out as disturbed.
    pub bias_updates: u64,
    pub tilt_updates: u64,
    pub tilt_gated: u64,
    pub heading_updates: u64,
    pub mag_rejected: u64,
    /// The magnetic field is disturbed now; new fields and hard-iron offsets accepted so far.
    pub mag_disturbed: bool,
    pub mag_new_fields: u64,
    pub mag_hard_iron_changes: u64,
    /// Times the tilt or heading covariance was widened because the innovations stayed inconsistent.
    pub tilt_reacquisitions: u64,
    pub heading_reacquisitions: u64,
    /// The 1σ the gravity direction was given at the last tilt update (motion included), deg.
    pub tilt_sigma_lp_deg: f64,
    /// The magnetic reference (norm in the magnetometer's unit, dip in deg, body-frame hard-iron
    /// offset), once there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mag_norm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mag_dip_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mag_offset: Option<[f64; 3]>,
    /// `provisional` (the reading at the start: a magnet on the body would be in it, and the published
    /// covariance allows for the north it may turn) or `confirmed` (a hard-iron fit over rotation
    /// about every axis found it), once there is a reference.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mag_reference: Option<String>,
    /// Gyro and accelerometer samples at or beyond 98% of the range (saturated).
    pub gyro_saturated: u64,
    pub acc_saturated: u64,
    /// Whether the magnetometer updated the heading within the last 10 s, and the seconds since it
    /// last did (since the start without one): an unaided heading's variance grows with the gyro.
    pub heading_aided: bool,
    pub heading_unaided_s: f64,
    /// Gaps in the samples (an interval of more than three usual ones) and the seconds they hid:
    /// each bridged by the rates on both sides and paid for in the covariance.
    #[serde(default)]
    pub gaps: u64,
    #[serde(default)]
    pub blind_s: f64,
    /// The sensors' noise as measured at rest (0 until there was rest), in a datasheet's units.
    pub measured: MeasuredNoiseMsg,
}

/// The sensors' noise measured at rest (`diagnostics.imu.measured`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredNoiseMsg {
    pub gyro_noise_density_deg_s_sqrt_hz: f64,
    pub acc_noise_density_ug_sqrt_hz: f64,
    /// In the magnetometer's unit, 1σ per axis.
    pub mag_noise: f64,
    /// Seconds of rest measured.
    pub rest_s: f64,
}

/// One sensor's gate counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateCountsMsg {
    pub accepted: u64,
    pub gated: u64,
    /// Observations of a `gravity` sensor left out because their norm deviated beyond `norm_gate`.
    /// (Always written, 0 when the sensor has no model: the schema lists every count.)
    #[serde(default)]
    pub norm_gated: u64,
    /// Observations of a `field` sensor left out as disturbed (norm or dip) or in the hold-off after a
    /// disturbance.
    #[serde(default)]
    pub disturbed: u64,
}

/// `P/V/estimate` and the `P/V/state` reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimateMsg {
    pub vehicle: String,
    pub t: f64,
    pub q: QuaternionMsg,
    /// Gyro bias, rad/s, body frame.
    pub bias: [f64; 3],
    /// 6×6 covariance, rows of `[δα (rad); δβ (rad/s)]`.
    pub cov: [[f64; 6]; 6],
    /// Attitude 1σ per body axis, deg.
    pub sigma_deg: [f64; 3],
    /// `mekf`, `usque` or `qpf`.
    pub filter: String,
    /// `propagated`, `average`, or null for the MEKF.
    pub fiducial: Option<String>,
    /// Estimates published for this vehicle so far (1 for the first).
    pub seq: u64,
    pub diagnostics: DiagnosticsMsg,
}

impl EstimateMsg {
    pub fn from_domain(
        vehicle: &str,
        spec: &FilterSpec,
        estimate: &Estimate,
        seq: u64,
        particles: Option<usize>,
    ) -> Self {
        let c = &estimate.covariance;
        let cov = std::array::from_fn(|i| std::array::from_fn(|j| c[(i, j)]));
        let s = estimate.sigma_att_rad();
        let d = &estimate.diagnostics;
        EstimateMsg {
            vehicle: vehicle.to_string(),
            t: estimate.t_s,
            q: QuaternionMsg::from_domain(&estimate.q),
            bias: [
                estimate.bias_rad_s[0],
                estimate.bias_rad_s[1],
                estimate.bias_rad_s[2],
            ],
            cov,
            sigma_deg: [s[0].to_degrees(), s[1].to_degrees(), s[2].to_degrees()],
            filter: spec.kind.as_str().to_string(),
            fiducial: spec.fiducial.map(|f| f.as_str().to_string()),
            seq,
            diagnostics: DiagnosticsMsg {
                propagations: d.propagations,
                updates: d.updates,
                nis: d.nis,
                nis_dof: d.nis_dof,
                ess: d.ess,
                particles,
                concentration: d.concentration,
                eigen_gap: d.eigen_gap,
                pc_stages: d.pc_stages,
                resamples: d.resamples,
                fiducial_fallbacks: d.fiducial_fallbacks,
                rejected: BTreeMap::new(),
                gyro_gap_s: d.gyro_gap_s,
                gyro_gaps: d.gyro_gaps,
                ..DiagnosticsMsg::default()
            },
        }
    }

    pub fn attitude(&self) -> AttitudeMsg {
        AttitudeMsg {
            vehicle: self.vehicle.clone(),
            t: self.t,
            q: self.q,
            sigma_deg: self.sigma_deg,
        }
    }

    pub fn covariance(&self) -> CovarianceMsg {
        CovarianceMsg {
            vehicle: self.vehicle.clone(),
            t: self.t,
            cov: self.cov,
            sigma_deg: self.sigma_deg,
        }
    }
}

/// `P/V/attitude` reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttitudeMsg {
    pub vehicle: String,
    pub t: f64,
    pub q: QuaternionMsg,
    pub sigma_deg: [f64; 3],
}

/// `P/V/covariance` reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CovarianceMsg {
    pub vehicle: String,
    pub t: f64,
    pub cov: [[f64; 6]; 6],
    pub sigma_deg: [f64; 3],
}

impl From<&GateCounts> for GateCountsMsg {
    fn from(c: &GateCounts) -> Self {
        GateCountsMsg {
            accepted: c.accepted,
            gated: c.gated,
            norm_gated: c.norm_gated,
            disturbed: c.disturbed,
        }
    }
}

impl From<&ImuDiagnostics> for ImuDiagnosticsMsg {
    fn from(d: &ImuDiagnostics) -> Self {
        let c = &d.counts;
        ImuDiagnosticsMsg {
            samples: c.samples,
            at_rest: c.at_rest,
            rest_samples: c.rest_samples,
            bias_updates: c.bias_updates,
            tilt_updates: c.tilt_updates,
            tilt_gated: c.tilt_gated,
            heading_updates: c.heading_updates,
            mag_rejected: c.mag_rejected,
            mag_disturbed: c.mag_disturbed,
            mag_new_fields: c.mag_new_fields,
            mag_hard_iron_changes: c.mag_hard_iron_changes,
            tilt_reacquisitions: c.tilt_reacquisitions,
            heading_reacquisitions: c.heading_reacquisitions,
            tilt_sigma_lp_deg: c.tilt_sigma_lp_rad.to_degrees(),
            mag_norm: d.field.map(|f| f.norm),
            mag_dip_deg: d.field.map(|f| f.dip_rad.to_degrees()),
            mag_offset: d.field.map(|f| [f.offset[0], f.offset[1], f.offset[2]]),
            mag_reference: d.field.map(|f| {
                if f.confirmed {
                    "confirmed"
                } else {
                    "provisional"
                }
                .to_string()
            }),
            gyro_saturated: c.gyro_saturated,
            acc_saturated: c.acc_saturated,
            heading_aided: c.heading_unaided_s <= crate::ahrs::HEADING_AIDED_S,
            heading_unaided_s: c.heading_unaided_s,
            gaps: c.gaps,
            blind_s: c.blind_s,
            measured: MeasuredNoiseMsg {
                gyro_noise_density_deg_s_sqrt_hz: d.measured.gyro_noise_density_deg_s_sqrt_hz,
                acc_noise_density_ug_sqrt_hz: d.measured.acc_noise_density_ug_sqrt_hz,
                mag_noise: d.measured.mag_noise,
                rest_s: d.measured.rest_s,
            },
        }
    }
}

impl From<&Published> for EstimateMsg {
    /// The estimate and the vehicle's diagnostics (`diagnostics.rejected` is the service's to fill).
    fn from(p: &Published) -> Self {
        EstimateMsg::from(p.clone())
    }
}

impl From<Published> for EstimateMsg {
    /// As `From<&Published>`, taking the maps over instead of copying them (every estimate).
    fn from(p: Published) -> Self {
        let mut msg =
            EstimateMsg::from_domain(&p.vehicle, &p.spec, &p.estimate, p.seq, p.particles);
        let d = &mut msg.diagnostics;
        d.gate = p
            .gate
            .into_iter()
            .map(|(k, c)| (k, GateCountsMsg::from(&c)))
            .collect();
        d.consecutive_gated = p.consecutive_gated;
        d.rollbacks = p.rollbacks;
        d.reinits = p.reinits;
        d.held = p.held;
        d.replayed = p.replayed;
        d.late_fused = p.late_fused;
        d.imu = p.imu.as_ref().map(ImuDiagnosticsMsg::from);
        d.level = p.level;
        msg
    }
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}
