//! The inputs `P/V/gyro`, `P/V/vectors`, `P/V/imu`: their messages, their limits and their decoding
//! (one object or an array), each converted into the core's samples by a validating function.

use super::{RejectCode, Rejection};
use crate::sensors::{Aspect, GyroSample, ImuSample, ObservationSet, VectorObservation};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Longest sensor name accepted.
pub const MAX_SENSOR_NAME: usize = 64;
/// Vectors shorter than this (in their own units) carry no direction.
pub const MIN_VECTOR_NORM: f64 = 1e-9;

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
    match serde_json::from_str::<Strict>(text) {
        Ok(Strict(v)) => Ok(v),
        // (A duplicate key is well-formed JSON the contract refuses: a shape error.)
        Err(e) if e.is_data() => Err(Rejection::new(RejectCode::BadRequest, e.to_string())),
        Err(e) => Err(Rejection::new(
            RejectCode::InvalidJson,
            format!("payload is not JSON: {e}"),
        )),
    }
}

/// A JSON value parsed with every object's keys unique: JSON allows a key twice and
/// `serde_json::Value` would keep the last; the contract refuses it (`bad_request`).
struct Strict(serde_json::Value);

impl<'de> serde::Deserialize<'de> for Strict {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{Error, MapAccess, SeqAccess, Visitor};
        use serde_json::Value;
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Strict;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON value")
            }
            fn visit_bool<E: Error>(self, b: bool) -> Result<Strict, E> {
                Ok(Strict(Value::Bool(b)))
            }
            fn visit_i64<E: Error>(self, n: i64) -> Result<Strict, E> {
                Ok(Strict(Value::from(n)))
            }
            fn visit_u64<E: Error>(self, n: u64) -> Result<Strict, E> {
                Ok(Strict(Value::from(n)))
            }
            fn visit_f64<E: Error>(self, n: f64) -> Result<Strict, E> {
                Ok(Strict(Value::from(n)))
            }
            fn visit_str<E: Error>(self, s: &str) -> Result<Strict, E> {
                Ok(Strict(Value::String(s.to_string())))
            }
            fn visit_string<E: Error>(self, s: String) -> Result<Strict, E> {
                Ok(Strict(Value::String(s)))
            }
            fn visit_unit<E: Error>(self) -> Result<Strict, E> {
                Ok(Strict(Value::Null))
            }
            fn visit_none<E: Error>(self) -> Result<Strict, E> {
                Ok(Strict(Value::Null))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Strict, A::Error> {
                let mut items = Vec::new();
                while let Some(Strict(v)) = seq.next_element()? {
                    items.push(v);
                }
                Ok(Strict(Value::Array(items)))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Strict, A::Error> {
                let mut m = serde_json::Map::new();
                while let Some(k) = map.next_key::<String>()? {
                    let Strict(v) = map.next_value()?;
                    if m.insert(k.clone(), v).is_some() {
                        return Err(A::Error::custom(format!(
                            "the key \"{k}\" appears twice in one object"
                        )));
                    }
                }
                Ok(Strict(Value::Object(m)))
            }
        }
        d.deserialize_any(V)
    }
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
