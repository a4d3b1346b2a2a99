//! `P/V/reset`: the request and its reply.

use super::input::{some, some_number, some_object, some_vec3, Three};
use super::{EstimateMsg, QuaternionMsg, RejectCode, Rejection, MAX_TIME_S};
use crate::ahrs::{Output, SensorSheet};
use crate::filters::sghqf::LEVELS;
use crate::filters::{Fiducial, FilterKind, FilterSpec};
use crate::vehicle::{ResetOutcome, ResetRequest, TakeoverSeed, MAX_PARTICLES};
use nalgebra::{Matrix6, Vector3};
use serde::de::{self, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;

/// A sigma given as one number for every axis or three.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum PerAxis {
    One(f64),
    Three([f64; 3]),
}

/// By hand rather than `untagged`, whose one error for every fault would make a `null` axis a
/// `bad_request` instead of `non_finite`.
impl<'de> Deserialize<'de> for PerAxis {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct OneOrThree;
        impl<'de> Visitor<'de> for OneOrThree {
            type Value = PerAxis;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<PerAxis, E> {
                Ok(PerAxis::One(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<PerAxis, E> {
                Ok(PerAxis::One(v as f64))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<PerAxis, E> {
                Ok(PerAxis::One(v as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<PerAxis, A::Error> {
                Three.visit_seq(seq).map(PerAxis::Three)
            }
            // A 1σ is a number first: null is a null number (`non_finite`), as everywhere.
            fn visit_unit<E: de::Error>(self) -> Result<PerAxis, E> {
                Err(E::custom(super::input::NULL_NUMBER))
            }
        }
        d.deserialize_any(OneOrThree)
    }
}

impl PerAxis {
    pub fn to_vector(&self) -> Vector3<f64> {
        match self {
            PerAxis::One(v) => Vector3::repeat(*v),
            PerAxis::Three(v) => Vector3::new(v[0], v[1], v[2]),
        }
    }
}

/// `P/V/reset` request payload; every field optional.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetMsg {
    /// `mekf`, `usque`, `qpf` or `sghqf` (default: the vehicle's configured filter).
    #[serde(default, deserialize_with = "some")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub filter: Option<String>,
    /// `propagated` or `average` (sampling filters).
    #[serde(default, deserialize_with = "some")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fiducial: Option<String>,
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub particles: Option<usize>,
    /// The SGHQF's sparse-grid level, 2..=4.
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<u64>,
    /// The attitude; absent means initialise from the next vector-observation set.
    #[serde(default, deserialize_with = "some_object")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub q: Option<QuaternionMsg>,
    /// Attitude 1σ, deg (one value or three).
    #[serde(default, deserialize_with = "some")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_deg: Option<PerAxis>,
    /// Gyro bias, rad/s.
    #[serde(default, deserialize_with = "some_vec3")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias: Option<[f64; 3]>,
    /// Bias 1σ, rad/s (one value or three).
    #[serde(default, deserialize_with = "some")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_sigma: Option<PerAxis>,
    /// Start time, s (default: the time of the next measurement).
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t: Option<f64>,
    /// The IMU's datasheet values (a raw-IMU vehicle's): those given replace the vehicle's.
    #[serde(default, deserialize_with = "some_object")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor: Option<SensorSheetMsg>,
}

/// A sensor's datasheet values in a reset request (`proto/README.md`, "The IMU's datasheet"): each
/// optional, in the datasheet's units, positive.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSheetMsg {
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_noise_density_deg_s_sqrt_hz: Option<f64>,
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_bias_instability_deg_h: Option<f64>,
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_range_deg_s: Option<f64>,
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acc_noise_density_ug_sqrt_hz: Option<f64>,
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acc_range_g: Option<f64>,
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mag_noise: Option<f64>,
    #[serde(default, deserialize_with = "some_number")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mag_offset_sigma: Option<f64>,
    /// What a sample's outputs stand for over its interval: `mean`, `increments` or `instant`
    /// (crate::ahrs::Output).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

impl TryFrom<&SensorSheetMsg> for SensorSheet {
    type Error = Rejection;

    /// Every value finite and positive (a value not given is 0 in the sheet: not given).
    fn try_from(m: &SensorSheetMsg) -> Result<Self, Rejection> {
        let mut sheet = SensorSheet::default();
        for (v, name, at) in [
            (
                m.gyro_noise_density_deg_s_sqrt_hz,
                "gyro_noise_density_deg_s_sqrt_hz",
                &mut sheet.gyro_noise_density_deg_s_sqrt_hz,
            ),
            (
                m.gyro_bias_instability_deg_h,
                "gyro_bias_instability_deg_h",
                &mut sheet.gyro_bias_instability_deg_h,
            ),
            (
                m.gyro_range_deg_s,
                "gyro_range_deg_s",
                &mut sheet.gyro_range_deg_s,
            ),
            (
                m.acc_noise_density_ug_sqrt_hz,
                "acc_noise_density_ug_sqrt_hz",
                &mut sheet.acc_noise_density_ug_sqrt_hz,
            ),
            (m.acc_range_g, "acc_range_g", &mut sheet.acc_range_g),
            (m.mag_noise, "mag_noise", &mut sheet.mag_noise),
            (
                m.mag_offset_sigma,
                "mag_offset_sigma",
                &mut sheet.mag_offset_sigma,
            ),
        ] {
            let Some(v) = v else { continue };
            if !v.is_finite() {
                return Err(Rejection::new(
                    RejectCode::NonFinite,
                    format!("sensor.{name} must be finite"),
                ));
            }
            if !(v > 0.0) {
                return Err(Rejection::new(
                    RejectCode::OutOfRange,
                    format!("sensor.{name} must be positive, got {v}"),
                ));
            }
            *at = v;
        }
        if let Some(name) = &m.output {
            sheet.output = Output::from_name(name).ok_or_else(|| {
                Rejection::new(
                    RejectCode::BadRequest,
                    format!(
                        "sensor.output must be \"mean\" (every output its interval's mean), \"increments\" (the gyro's own angle increments) or \"instant\" (values at the time stamp), got {name:?}"
                    ),
                )
            })?;
        }
        Ok(sheet)
    }
}

/// `P/V/reset` reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetReplyMsg {
    pub vehicle: String,
    /// `initializing` or `tracking`.
    pub state: String,
    pub filter: String,
    pub fiducial: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<u8>,
    /// The new estimate when the reset gave an attitude; null while initialising.
    pub estimate: Option<EstimateMsg>,
}

impl TryFrom<&ResetMsg> for ResetRequest {
    type Error = Rejection;

    /// Every value of the request on its own: known names, particles and level in range, a unit
    /// quaternion,
    /// finite values, positive 1σ, a time within the contract's range.
    fn try_from(m: &ResetMsg) -> Result<Self, Rejection> {
        let bad = |code: RejectCode, m: String| Err(Rejection::new(code, m));
        let filter = match m.filter.as_deref() {
            None => None,
            Some(k) => match k.parse::<FilterKind>() {
                Ok(kind) => Some(kind),
                Err(_) => {
                    return bad(
                        RejectCode::BadRequest,
                        format!("filter '{k}': expected mekf, usque, qpf or sghqf"),
                    )
                }
            },
        };
        let fiducial = match m.fiducial.as_deref() {
            None => None,
            Some(f) => match f.parse::<Fiducial>() {
                Ok(fid) => Some(fid),
                Err(_) => {
                    return bad(
                        RejectCode::BadRequest,
                        format!("fiducial '{f}': expected average or propagated"),
                    )
                }
            },
        };
        if let Some(n) = m.particles {
            if !(2..=MAX_PARTICLES).contains(&n) {
                return bad(
                    RejectCode::BadRequest,
                    format!("particles must be in 2..={MAX_PARTICLES}, got {n}"),
                );
            }
        }
        let level = match m.level {
            None => None,
            Some(l) if (*LEVELS.start() as u64..=*LEVELS.end() as u64).contains(&l) => {
                Some(l as u8)
            }
            Some(l) => {
                return bad(
                    RejectCode::BadRequest,
                    format!(
                        "level must be in {}..={}, got {l}",
                        LEVELS.start(),
                        LEVELS.end()
                    ),
                )
            }
        };
        let q = m.q.map(|q| q.to_domain()).transpose()?;
        let sigma_deg = m.sigma_deg.map(|s| s.to_vector());
        if let Some(s) = sigma_deg {
            if !s.iter().all(|x| x.is_finite()) {
                return bad(RejectCode::NonFinite, "sigma_deg must be finite".into());
            }
            if !s.iter().all(|x| *x > 0.0 && *x <= 360.0) {
                return bad(RejectCode::BadSigma, "sigma_deg must be in (0, 360]".into());
            }
        }
        let bias = m.bias.map(Vector3::from);
        if bias.is_some_and(|b| !b.iter().all(|x| x.is_finite())) {
            return bad(RejectCode::NonFinite, "bias must be finite".into());
        }
        let bias_sigma = m.bias_sigma.map(|s| s.to_vector());
        if let Some(s) = bias_sigma {
            if !s.iter().all(|x| x.is_finite()) {
                return bad(RejectCode::NonFinite, "bias_sigma must be finite".into());
            }
            if !s.iter().all(|x| *x > 0.0) {
                return bad(RejectCode::BadSigma, "bias_sigma must be positive".into());
            }
        }
        if let Some(t) = m.t {
            if !t.is_finite() {
                return bad(RejectCode::NonFinite, "t must be finite".into());
            }
            if t.abs() > MAX_TIME_S {
                return bad(
                    RejectCode::OutOfRange,
                    format!("t = {t} s is beyond ±{MAX_TIME_S:e} s"),
                );
            }
        }
        Ok(ResetRequest {
            filter,
            fiducial,
            particles: m.particles,
            level,
            q,
            sigma_att_rad: sigma_deg.map(|s| s * std::f64::consts::PI / 180.0),
            bias_rad_s: bias,
            bias_sigma_rad_s: bias_sigma,
            t_s: m.t,
            sensor: m.sensor.as_ref().map(SensorSheet::try_from).transpose()?,
        })
    }
}

impl From<ResetOutcome> for ResetReplyMsg {
    fn from(o: ResetOutcome) -> Self {
        ResetReplyMsg {
            vehicle: o.vehicle,
            state: if o.tracking {
                "tracking"
            } else {
                "initializing"
            }
            .into(),
            filter: o.spec.kind.as_str().into(),
            fiducial: o.spec.fiducial.map(|f| f.as_str().into()),
            particles: o.particles,
            level: o.level,
            estimate: o.estimate.as_ref().map(EstimateMsg::from),
        }
    }
}

impl TryFrom<&EstimateMsg> for TakeoverSeed {
    type Error = Rejection;

    /// The last estimate another instance published, as the start of a takeover.
    fn try_from(e: &EstimateMsg) -> Result<Self, Rejection> {
        let bad = |m: String| Rejection::new(RejectCode::BadRequest, m);
        let spec = FilterSpec::from_parts(&e.filter, e.fiducial.as_deref())
            .map_err(|err| bad(format!("estimate of {}: {err}", e.vehicle)))?;
        TakeoverSeed {
            t_s: e.t,
            q: e.q.to_domain()?,
            bias_rad_s: Vector3::from(e.bias),
            covariance: Matrix6::from_fn(|i, j| e.cov[i][j]),
            spec,
            particles: e.diagnostics.particles,
            level: e.diagnostics.level,
            seq: e.seq,
        }
        .validated()
        .map_err(|m| bad(format!("estimate of {}: {m}", e.vehicle)))
    }
}
