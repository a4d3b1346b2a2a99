//! The JSON wire format of the service (contract v1; prose and schemas in `proto/`).
//!
//! Wire types are their own structs; they are converted into the numeric core's domain types by
//! validating functions that say exactly what is wrong ([`Rejection`]), and built from domain types for
//! output. Quaternions travel as `{"w", "x", "y", "z"}` (the body's orientation in the reference frame,
//! `b = A(q) r`), normalised to `w ≥ 0` in replies; covariances as six rows of six numbers over
//! `[δα (rad, body axes); δβ (rad/s)]`.

use crate::attitude::Quaternion;
use crate::filters::{Estimate, FilterSpec};
use crate::sensors::{Aspect, GyroSample, ImuSample, ObservationSet, VectorObservation};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Why an input or a request was refused: a stable machine-readable code and a readable message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rejection {
    pub code: RejectCode,
    pub message: String,
}

/// Stable rejection codes (the `code` field of error replies and `P/V/rejected`; the table in
/// `proto/README.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RejectCode {
    /// The payload is not UTF-8.
    InvalidUtf8,
    /// The payload is not JSON.
    InvalidJson,
    /// JSON of the wrong shape: missing or unknown fields, wrong types, wrong array lengths.
    BadRequest,
    /// NaN or infinity where a number is required.
    NonFinite,
    /// A zero or near-zero vector where a direction or field is required.
    ZeroVector,
    /// A sigma that is not positive.
    BadSigma,
    /// The payload exceeds the configured size.
    PayloadTooLarge,
    /// A batch or observation set exceeds the configured count.
    BatchTooLarge,
    /// The vehicle id is outside the contract (1–64 of `[A-Za-z0-9_-]`).
    InvalidVehicleId,
    /// The query names a vehicle the service does not know.
    UnknownVehicle,
    /// The vehicle exists but has no estimate yet (waiting for a usable vector-observation set), or
    /// an input cannot start it (a set without two non-parallel vectors).
    NotInitialized,
    /// A new vehicle beyond the configured maximum.
    TooManyVehicles,
    /// The sample is older than what the vehicle's filter already processed.
    OutOfOrder,
    /// The same sample again: a gyro sample at the time of one already accepted, or a vector set
    /// identical to one already accepted at the same time.
    Duplicate,
    /// The sample is further ahead of the vehicle's newest time than `time.max_jump_s` (a reset with
    /// `t` re-anchors the vehicle's time).
    TimeJump,
    /// A finite number outside its physical range (a rate above `limits.max_rate_rad_s`, a time beyond
    /// ±1e12 s, a vector or sigma above 1e100).
    OutOfRange,
    /// The vehicle's input queue is full.
    QueueFull,
    /// A gyro sample for a vehicle fed raw IMU samples, or an IMU sample for one fed gyro samples (one
    /// gyro per vehicle; a reset lets it switch).
    MixedInputs,
    /// The filter refused the input (numerical failure); the filter is unchanged.
    FilterError,
    /// Something failed inside the service.
    Internal,
}

impl RejectCode {
    pub const ALL: [RejectCode; 20] = [
        RejectCode::InvalidUtf8,
        RejectCode::InvalidJson,
        RejectCode::BadRequest,
        RejectCode::NonFinite,
        RejectCode::ZeroVector,
        RejectCode::BadSigma,
        RejectCode::PayloadTooLarge,
        RejectCode::BatchTooLarge,
        RejectCode::InvalidVehicleId,
        RejectCode::UnknownVehicle,
        RejectCode::NotInitialized,
        RejectCode::TooManyVehicles,
        RejectCode::OutOfOrder,
        RejectCode::Duplicate,
        RejectCode::TimeJump,
        RejectCode::OutOfRange,
        RejectCode::QueueFull,
        RejectCode::MixedInputs,
        RejectCode::FilterError,
        RejectCode::Internal,
    ];

    pub fn as_str(&self) -> &'static str {
        match self {
            RejectCode::InvalidUtf8 => "invalid_utf8",
            RejectCode::InvalidJson => "invalid_json",
            RejectCode::BadRequest => "bad_request",
            RejectCode::NonFinite => "non_finite",
            RejectCode::ZeroVector => "zero_vector",
            RejectCode::BadSigma => "bad_sigma",
            RejectCode::PayloadTooLarge => "payload_too_large",
            RejectCode::BatchTooLarge => "batch_too_large",
            RejectCode::InvalidVehicleId => "invalid_vehicle_id",
            RejectCode::UnknownVehicle => "unknown_vehicle",
            RejectCode::NotInitialized => "not_initialized",
            RejectCode::TooManyVehicles => "too_many_vehicles",
            RejectCode::OutOfOrder => "out_of_order",
            RejectCode::Duplicate => "duplicate",
            RejectCode::TimeJump => "time_jump",
            RejectCode::OutOfRange => "out_of_range",
            RejectCode::QueueFull => "queue_full",
            RejectCode::MixedInputs => "mixed_inputs",
            RejectCode::FilterError => "filter_error",
            RejectCode::Internal => "internal",
        }
    }
}

impl Rejection {
    pub fn new(code: RejectCode, message: impl Into<String>) -> Self {
        Rejection {
            code,
            message: message.into(),
        }
    }

    /// The error reply / rejection message for `key`.
    pub fn to_message(&self, key: &str) -> ErrorMsg {
        ErrorMsg {
            code: self.code.as_str().to_string(),
            message: self.message.clone(),
            key: key.to_string(),
        }
    }
}

/// Longest sensor name accepted.
pub const MAX_SENSOR_NAME: usize = 64;
/// Vectors shorter than this (in their own units) carry no direction.
pub const MIN_VECTOR_NORM: f64 = 1e-9;

/// A vehicle id of the contract: 1–64 characters of `[A-Za-z0-9_-]`.
pub fn validate_vehicle_id(id: &str) -> Result<(), Rejection> {
    let ok = !id.is_empty()
        && id.len() <= 64
        && id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
    if ok {
        Ok(())
    } else {
        Err(Rejection::new(
            RejectCode::InvalidVehicleId,
            format!("vehicle id '{id}' must be 1-64 characters of A-Z, a-z, 0-9, '_' and '-'"),
        ))
    }
}

// ------------------------------------------------------------------------------------------------
// Inputs

/// `P/V/gyro`: `{"t": 12.5, "omega": [wx, wy, wz]}` (s, body rad/s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroMsg {
    pub t: f64,
    pub omega: [f64; 3],
}

/// One observation of `P/V/vectors`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationMsg {
    pub body: [f64; 3],
    #[serde(rename = "ref")]
    pub reference: [f64; 3],
    pub sigma: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<String>,
}

/// `P/V/vectors`: `{"t": 12.5, "obs": [..]}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VectorsMsg {
    pub t: f64,
    pub obs: Vec<ObservationMsg>,
}

/// `P/V/imu`: one raw IMU sample, `{"t": 12.5, "gyr": [3] rad/s, "acc": [3] m/s², "mag": [3]}` (body
/// frame; `mag` in any unit, optional; the rate covers the interval since the previous sample).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuMsg {
    pub t: f64,
    pub gyr: [f64; 3],
    pub acc: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mag: Option<[f64; 3]>,
}

/// Largest accelerometer reading accepted, m/s² (1000 g: beyond any accelerometer's range).
pub const MAX_ACC_M_S2: f64 = 1e4;

impl ImuMsg {
    /// Validates the sample. A magnetometer reading of exactly `[0, 0, 0]` means "no reading" (how
    /// many drivers fill a missing one) and is taken as absent.
    pub fn to_domain(&self, limits: &InputLimits) -> Result<ImuSample, Rejection> {
        let t_s = finite_time(self.t)?;
        let gyr = finite3(&self.gyr, "gyr")?;
        if gyr.norm() > limits.max_rate_rad_s {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                format!(
                    "|gyr| = {:e} rad/s exceeds limits.max_rate_rad_s = {}",
                    gyr.norm(),
                    limits.max_rate_rad_s
                ),
            ));
        }
        let acc = finite3(&self.acc, "acc")?;
        if acc.norm() > MAX_ACC_M_S2 {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                format!(
                    "|acc| = {:e} m/s² exceeds {MAX_ACC_M_S2:e} m/s²",
                    acc.norm()
                ),
            ));
        }
        let mag = match &self.mag {
            None => None,
            Some(m) => {
                let m = finite3(m, "mag")?;
                within(m.amax(), "mag")?;
                (m != Vector3::zeros()).then_some(m)
            }
        };
        Ok(ImuSample {
            t_s,
            gyr_rad_s: gyr,
            acc_m_s2: acc,
            mag,
        })
    }
}

/// Limits applied while parsing inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InputLimits {
    pub max_payload_bytes: usize,
    /// Most samples in one batch (a JSON array).
    pub max_batch: usize,
    /// Most observations in one set.
    pub max_observations: usize,
    /// Largest gyro rate accepted, rad/s (beyond any real gyro's range; guards the filters from
    /// finite numbers that overflow).
    pub max_rate_rad_s: f64,
}

/// Largest |t| accepted, s (about 31,700 years).
pub const MAX_TIME_S: f64 = 1e12;
/// Largest vector norm or sigma accepted (their squares must stay finite).
pub const MAX_MAGNITUDE: f64 = 1e100;

impl Default for InputLimits {
    fn default() -> Self {
        InputLimits {
            max_payload_bytes: 1 << 20,
            max_batch: 10_000,
            max_observations: 64,
            max_rate_rad_s: 100.0,
        }
    }
}

fn finite3(v: &[f64; 3], what: &str) -> Result<Vector3<f64>, Rejection> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vector3::new(v[0], v[1], v[2]))
    } else {
        Err(Rejection::new(
            RejectCode::NonFinite,
            format!("{what} must be finite"),
        ))
    }
}

fn finite_time(t: f64) -> Result<f64, Rejection> {
    if !t.is_finite() {
        Err(Rejection::new(RejectCode::NonFinite, "t must be finite"))
    } else if t.abs() > MAX_TIME_S {
        Err(Rejection::new(
            RejectCode::OutOfRange,
            format!("t = {t} s is beyond ±{MAX_TIME_S:e} s"),
        ))
    } else {
        Ok(t)
    }
}

fn within(v: f64, what: &str) -> Result<(), Rejection> {
    if v > MAX_MAGNITUDE {
        Err(Rejection::new(
            RejectCode::OutOfRange,
            format!("{what} = {v:e} exceeds {MAX_MAGNITUDE:e}"),
        ))
    } else {
        Ok(())
    }
}

impl GyroMsg {
    pub fn to_domain(&self, limits: &InputLimits) -> Result<GyroSample, Rejection> {
        let omega = finite3(&self.omega, "omega")?;
        if omega.norm() > limits.max_rate_rad_s {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                format!(
                    "|omega| = {:e} rad/s exceeds limits.max_rate_rad_s = {}",
                    omega.norm(),
                    limits.max_rate_rad_s
                ),
            ));
        }
        Ok(GyroSample {
            t_s: finite_time(self.t)?,
            omega_body_rad_s: omega,
        })
    }
}

impl ObservationMsg {
    pub fn to_domain(&self, index: usize) -> Result<VectorObservation, Rejection> {
        let body = finite3(&self.body, &format!("obs[{index}].body"))?;
        let reference = finite3(&self.reference, &format!("obs[{index}].ref"))?;
        if !self.sigma.is_finite() {
            return Err(Rejection::new(
                RejectCode::NonFinite,
                format!("obs[{index}].sigma must be finite"),
            ));
        }
        if self.sigma <= 0.0 {
            return Err(Rejection::new(
                RejectCode::BadSigma,
                format!("obs[{index}].sigma must be positive, got {}", self.sigma),
            ));
        }
        within(self.sigma, &format!("obs[{index}].sigma"))?;
        for (v, name) in [(&body, "body"), (&reference, "ref")] {
            within(v.amax(), &format!("obs[{index}].{name}"))?;
            if v.norm() < MIN_VECTOR_NORM {
                return Err(Rejection::new(
                    RejectCode::ZeroVector,
                    format!("obs[{index}].{name} is a zero vector"),
                ));
            }
        }
        if let Some(s) = &self.sensor {
            if s.is_empty() || s.chars().count() > MAX_SENSOR_NAME {
                return Err(Rejection::new(
                    RejectCode::BadRequest,
                    format!("obs[{index}].sensor must be 1-{MAX_SENSOR_NAME} characters"),
                ));
            }
        }
        Ok(VectorObservation {
            body,
            reference,
            sigma: self.sigma,
            sensor: self.sensor.clone(),
            aspect: Aspect::Full,
        })
    }
}

impl VectorsMsg {
    pub fn to_domain(&self, limits: &InputLimits) -> Result<ObservationSet, Rejection> {
        let t_s = finite_time(self.t)?;
        if self.obs.is_empty() {
            return Err(Rejection::new(
                RejectCode::BadRequest,
                "obs must hold at least one observation",
            ));
        }
        if self.obs.len() > limits.max_observations {
            return Err(Rejection::new(
                RejectCode::BatchTooLarge,
                format!(
                    "{} observations in one set, at most {}",
                    self.obs.len(),
                    limits.max_observations
                ),
            ));
        }
        let observations = self
            .obs
            .iter()
            .enumerate()
            .map(|(i, o)| o.to_domain(i))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(ObservationSet { t_s, observations })
    }
}

/// Checks size and UTF-8 and parses JSON: the first steps of every payload.
fn decode_value(payload: &[u8], limits: &InputLimits) -> Result<serde_json::Value, Rejection> {
    if payload.len() > limits.max_payload_bytes {
        return Err(Rejection::new(
            RejectCode::PayloadTooLarge,
            format!(
                "payload of {} bytes exceeds {} bytes",
                payload.len(),
                limits.max_payload_bytes
            ),
        ));
    }
    let text = std::str::from_utf8(payload).map_err(|e| {
        Rejection::new(
            RejectCode::InvalidUtf8,
            format!("payload is not UTF-8: {e}"),
        )
    })?;
    serde_json::from_str(text)
        .map_err(|e| Rejection::new(RejectCode::InvalidJson, format!("payload is not JSON: {e}")))
}

/// A JSON value of the wrong shape; serde_json writes NaN as null, so a null number is `non_finite`.
fn shape_error(e: serde_json::Error, at: Option<usize>) -> Rejection {
    let place = at.map(|i| format!("batch item {i}: ")).unwrap_or_default();
    let message = e.to_string();
    // `null` where a number belongs is how many encoders write NaN.
    let code = if message.starts_with("invalid type: null, expected f64") {
        RejectCode::NonFinite
    } else {
        RejectCode::BadRequest
    };
    Rejection::new(code, format!("{place}{message}"))
}

/// Decodes a payload that holds exactly one item (a request).
pub fn decode_one<T: serde::de::DeserializeOwned>(
    payload: &[u8],
    limits: &InputLimits,
) -> Result<T, Rejection> {
    let v = decode_value(payload, limits)?;
    objects_only(&v, None)?;
    serde_json::from_value(v).map_err(|e| shape_error(e, None))
}

/// `null` is refused wherever it stands, also in optional fields (the schemas say so): where a number
/// belongs it is `non_finite` (how many encoders write NaN), elsewhere `bad_request`.
fn no_nulls(
    map: &serde_json::Map<String, serde_json::Value>,
    index: Option<usize>,
) -> Result<(), Rejection> {
    use serde_json::Value;
    let place = index
        .map(|i| format!("batch item {i}: "))
        .unwrap_or_default();
    for (k, v) in map {
        // A number field that is null is a NaN; a string, record or array that is null is a shape
        // error; a null inside a numeric array is a NaN again.
        let whole = match k.as_str() {
            "t" | "sigma" | "particles" | "w" | "x" | "y" | "z" => RejectCode::NonFinite,
            _ => RejectCode::BadRequest,
        };
        let null = |code, what: String| Err(Rejection::new(code, format!("{place}{what} is null")));
        match v {
            Value::Null => return null(whole, k.clone()),
            Value::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    match item {
                        Value::Null if k == "obs" => {
                            return null(RejectCode::BadRequest, format!("{k}[{i}]"))
                        }
                        Value::Null => return null(RejectCode::NonFinite, format!("{k}[{i}]")),
                        Value::Object(m) => no_nulls(m, index)?,
                        _ => {}
                    }
                }
            }
            Value::Object(m) => no_nulls(m, index)?,
            _ => {}
        }
    }
    Ok(())
}

/// Every message and nested record (`obs[]`, `q`) is a JSON object. (serde's derived structs would
/// also take an array of the fields in order, which the contract does not allow.)
fn objects_only(v: &serde_json::Value, index: Option<usize>) -> Result<(), Rejection> {
    let at = |what: &str| match index {
        Some(i) => format!("batch item {i}: {what} must be a JSON object"),
        None => format!("{what} must be a JSON object"),
    };
    let Some(map) = v.as_object() else {
        return Err(Rejection::new(RejectCode::BadRequest, at("the message")));
    };
    no_nulls(map, index)?;
    if let Some(serde_json::Value::Array(obs)) = map.get("obs") {
        if let Some(k) = obs.iter().position(|o| !o.is_object()) {
            return Err(Rejection::new(
                RejectCode::BadRequest,
                at(&format!("obs[{k}]")),
            ));
        }
    }
    if map.get("q").is_some_and(|q| q.is_array()) {
        return Err(Rejection::new(RejectCode::BadRequest, at("q")));
    }
    Ok(())
}

/// Decodes a payload that holds one item or a JSON array of them (a batch), checking size and UTF-8
/// first. Every item must be valid; the first invalid one names the batch index.
pub fn decode_batch<T: serde::de::DeserializeOwned>(
    payload: &[u8],
    limits: &InputLimits,
) -> Result<Vec<T>, Rejection> {
    match decode_value(payload, limits)? {
        serde_json::Value::Array(items) => {
            if items.is_empty() {
                return Err(Rejection::new(RejectCode::BadRequest, "empty batch"));
            }
            if items.len() > limits.max_batch {
                return Err(Rejection::new(
                    RejectCode::BatchTooLarge,
                    format!(
                        "batch of {} items exceeds {}",
                        items.len(),
                        limits.max_batch
                    ),
                ));
            }
            items
                .into_iter()
                .enumerate()
                .map(|(i, v)| {
                    objects_only(&v, Some(i))?;
                    serde_json::from_value(v).map_err(|e| shape_error(e, Some(i)))
                })
                .collect()
        }
        v => {
            objects_only(&v, None)?;
            Ok(vec![
                serde_json::from_value(v).map_err(|e| shape_error(e, None))?
            ])
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Outputs

/// `{"w", "x", "y", "z"}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuaternionMsg {
    pub w: f64,
    pub x: f64,
    pub y: f64,
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
}

/// One sensor's gate counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateCountsMsg {
    pub accepted: u64,
    pub gated: u64,
    /// Observations of a `gravity` sensor left out because their norm deviated beyond `norm_gate`.
    /// (Always written: a checkpoint holds these counts in bincode, which has no optional fields.)
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

/// Error replies and `P/V/rejected`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorMsg {
    pub code: String,
    pub message: String,
    pub key: String,
}

/// A sigma given as one number for every axis or three.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum PerAxis {
    One(f64),
    Three([f64; 3]),
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
    /// `mekf`, `usque` or `qpf` (default: the vehicle's configured filter).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filter: Option<String>,
    /// `propagated` or `average` (sampling filters).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fiducial: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<usize>,
    /// The attitude; absent means initialise from the next vector-observation set.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q: Option<QuaternionMsg>,
    /// Attitude 1σ, deg (one value or three).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_deg: Option<PerAxis>,
    /// Gyro bias, rad/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias: Option<[f64; 3]>,
    /// Bias 1σ, rad/s (one value or three).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_sigma: Option<PerAxis>,
    /// Start time, s (default: the time of the next measurement).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t: Option<f64>,
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
    /// The new estimate when the reset gave an attitude; null while initialising.
    pub estimate: Option<EstimateMsg>,
}

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
    /// Checkpointing, when a state directory is configured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoints: Option<CheckpointHealthMsg>,
    /// This instance and its fleet.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fleet: Option<FleetHealthMsg>,
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
    /// Inputs of other members' vehicles kept for a takeover, and their last estimates.
    pub standby_inputs: usize,
    pub standby_estimates: usize,
}

/// `P/@/health` `checkpoints`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointHealthMsg {
    pub state_dir: String,
    pub interval_s: f64,
    /// Vehicles restored at start, and checkpoint files skipped then (corrupt or unreadable).
    pub restored: u64,
    pub skipped: u64,
    /// Checkpoint files written and failed writes since start.
    pub written: u64,
    pub failed: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> InputLimits {
        InputLimits::default()
    }

    #[test]
    fn one_or_many() {
        let one: Vec<GyroMsg> =
            decode_batch(br#"{"t": 1.0, "omega": [0, 0, 0.1]}"#, &lim()).unwrap();
        assert_eq!(one.len(), 1);
        let two: Vec<GyroMsg> = decode_batch(
            br#"[{"t": 1.0, "omega": [0, 0, 0.1]}, {"t": 2.0, "omega": [0, 0, 0.2]}]"#,
            &lim(),
        )
        .unwrap();
        assert_eq!(two[1].omega[2], 0.2);
    }

    #[test]
    fn every_bad_input_has_its_code() {
        let cases: Vec<(&[u8], RejectCode)> = vec![
            (b"\xff\xfe", RejectCode::InvalidUtf8),
            (b"{not json", RejectCode::InvalidJson),
            (br#"{"t": 1.0}"#, RejectCode::BadRequest),
            (br#"{"t": "x", "omega": [0,0,0]}"#, RejectCode::BadRequest),
            (br#"{"t": 1.0, "omega": [0,0]}"#, RejectCode::BadRequest),
            (
                br#"{"t": 1.0, "omega": [0,0,0], "extra": 1}"#,
                RejectCode::BadRequest,
            ),
            (br#"{"t": null, "omega": [0,0,0]}"#, RejectCode::NonFinite),
            (br#"[]"#, RejectCode::BadRequest),
        ];
        for (payload, code) in cases {
            let r = decode_batch::<GyroMsg>(payload, &lim()).unwrap_err();
            assert_eq!(
                r.code,
                code,
                "{:?}: {}",
                String::from_utf8_lossy(payload),
                r.message
            );
        }
        let small = InputLimits {
            max_payload_bytes: 10,
            ..lim()
        };
        assert_eq!(
            decode_batch::<GyroMsg>(br#"{"t": 1.0, "omega": [0,0,0]}"#, &small)
                .unwrap_err()
                .code,
            RejectCode::PayloadTooLarge
        );
        let few = InputLimits {
            max_batch: 1,
            ..lim()
        };
        assert_eq!(
            decode_batch::<GyroMsg>(
                br#"[{"t": 1, "omega": [0,0,0]}, {"t": 2, "omega": [0,0,0]}]"#,
                &few
            )
            .unwrap_err()
            .code,
            RejectCode::BatchTooLarge
        );
    }

    #[test]
    fn observation_validation() {
        let ok = ObservationMsg {
            body: [1.0, 0.0, 0.0],
            reference: [0.0, 1.0, 0.0],
            sigma: 1e-3,
            sensor: None,
        };
        assert!(ok.to_domain(0).is_ok());
        let code = |o: ObservationMsg| o.to_domain(0).unwrap_err().code;
        assert_eq!(
            code(ObservationMsg {
                sigma: 0.0,
                ..ok.clone()
            }),
            RejectCode::BadSigma
        );
        assert_eq!(
            code(ObservationMsg {
                sigma: -1.0,
                ..ok.clone()
            }),
            RejectCode::BadSigma
        );
        assert_eq!(
            code(ObservationMsg {
                sigma: f64::NAN,
                ..ok.clone()
            }),
            RejectCode::NonFinite
        );
        assert_eq!(
            code(ObservationMsg {
                body: [0.0; 3],
                ..ok.clone()
            }),
            RejectCode::ZeroVector
        );
        assert_eq!(
            code(ObservationMsg {
                reference: [1e-12, 0.0, 0.0],
                ..ok.clone()
            }),
            RejectCode::ZeroVector
        );
        assert_eq!(
            code(ObservationMsg {
                body: [f64::INFINITY, 0.0, 0.0],
                ..ok.clone()
            }),
            RejectCode::NonFinite
        );
        assert_eq!(
            code(ObservationMsg {
                sensor: Some(String::new()),
                ..ok.clone()
            }),
            RejectCode::BadRequest
        );
        let set = VectorsMsg {
            t: 1.0,
            obs: vec![],
        };
        assert_eq!(
            set.to_domain(&lim()).unwrap_err().code,
            RejectCode::BadRequest
        );
        let many = VectorsMsg {
            t: 1.0,
            obs: vec![ok; 65],
        };
        assert_eq!(
            many.to_domain(&lim()).unwrap_err().code,
            RejectCode::BatchTooLarge
        );
    }

    #[test]
    fn vehicle_ids() {
        for ok in ["sc1", "A-b_9", &"x".repeat(64)] {
            assert!(validate_vehicle_id(ok).is_ok(), "{ok}");
        }
        for bad in ["", "a.b", "a b", "é", &"x".repeat(65), "@"] {
            assert_eq!(
                validate_vehicle_id(bad).unwrap_err().code,
                RejectCode::InvalidVehicleId,
                "{bad}"
            );
        }
    }

    #[test]
    fn quaternion_wire_convention() {
        let q = Quaternion::new(0.1, -0.2, 0.3, -0.9).normalized().unwrap();
        let m = QuaternionMsg::from_domain(&q);
        assert!(m.w > 0.0, "replies normalise w ≥ 0");
        assert_eq!(m.x, -q.x);
        let json = serde_json::to_string(&m).unwrap();
        assert!(json.starts_with(r#"{"w":"#), "{json}");
        assert!(QuaternionMsg {
            w: 2.0,
            x: 0.0,
            y: 0.0,
            z: 0.0
        }
        .to_domain()
        .is_err());
    }
}
