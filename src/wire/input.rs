//! The inputs `P/V/gyro`, `P/V/vectors`, `P/V/imu`: their messages, their limits and their decoding
//! (one object or an array), each converted into the core's samples by a validating function.

use super::input_scan::{scan_batch, Scanned};
use super::{RejectCode, Rejection};
use crate::sensors::{Aspect, GyroSample, ImuSample, ObservationSet, VectorObservation};
use nalgebra::Vector3;
use serde::de::value::MapAccessDeserializer;
use serde::de::{
    self, DeserializeOwned, DeserializeSeed, IgnoredAny, MapAccess, SeqAccess, Visitor,
};
use serde::{Deserialize, Deserializer, Serialize};
use std::cell::Cell;
use std::fmt;
use std::marker::PhantomData;

/// Longest sensor name accepted.
pub const MAX_SENSOR_NAME: usize = 64;
/// Vectors shorter than this (in their own units) carry no direction.
pub const MIN_VECTOR_NORM: f64 = 1e-9;

/// `P/V/gyro`: `{"t": 12.5, "omega": [wx, wy, wz]}` (s, body rad/s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroMsg {
    #[serde(deserialize_with = "number")]
    pub t: f64,
    #[serde(deserialize_with = "vec3")]
    pub omega: [f64; 3],
}

/// One observation of `P/V/vectors`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationMsg {
    #[serde(deserialize_with = "vec3")]
    pub body: [f64; 3],
    #[serde(rename = "ref", deserialize_with = "vec3")]
    pub reference: [f64; 3],
    #[serde(deserialize_with = "number")]
    pub sigma: f64,
    #[serde(default, deserialize_with = "some")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor: Option<String>,
}

/// `P/V/vectors`: `{"t": 12.5, "obs": [..]}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VectorsMsg {
    #[serde(deserialize_with = "number")]
    pub t: f64,
    #[serde(deserialize_with = "objects")]
    pub obs: Vec<ObservationMsg>,
}

/// `P/V/imu`: one raw IMU sample, `{"t": 12.5, "gyr": [3] rad/s, "acc": [3] m/s², "mag": [3]}` (body
/// frame; `mag` in any unit, optional; the rate covers the interval since the previous sample).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuMsg {
    #[serde(deserialize_with = "number")]
    pub t: f64,
    #[serde(deserialize_with = "vec3")]
    pub gyr: [f64; 3],
    #[serde(deserialize_with = "vec3")]
    pub acc: [f64; 3],
    #[serde(default, deserialize_with = "some_vec3")]
    #[serde(skip_serializing_if = "Option::is_none")]
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

/// (`what` names the field in a rejection; it is formatted only then.)
fn finite3(v: &[f64; 3], what: impl fmt::Display) -> Result<Vector3<f64>, Rejection> {
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

fn within(v: f64, what: impl fmt::Display) -> Result<(), Rejection> {
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
        let body = finite3(&self.body, format_args!("obs[{index}].body"))?;
        let reference = finite3(&self.reference, format_args!("obs[{index}].ref"))?;
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
        within(self.sigma, format_args!("obs[{index}].sigma"))?;
        for (v, name) in [(&body, "body"), (&reference, "ref")] {
            within(v.amax(), format_args!("obs[{index}].{name}"))?;
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

// Decoding: serde reads the text straight into the message structs, in one pass. The contract's rules
// live in the messages' `Deserialize` (`deny_unknown_fields`; serde's derive refuses a field given
// twice) and in the field readers below; `refused` turns serde's error into the contract's code.

/// The message of a `null` where a number belongs, which `shape_code` recognises.
pub(super) const NULL_NUMBER: &str = "a number is null (how many encoders write NaN)";

/// Checks size and UTF-8: the first steps of every payload.
fn text_of<'a>(payload: &'a [u8], limits: &InputLimits) -> Result<&'a str, Rejection> {
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
    std::str::from_utf8(payload).map_err(|e| {
        Rejection::new(
            RejectCode::InvalidUtf8,
            format!("payload is not UTF-8: {e}"),
        )
    })
}

/// Decodes a payload that holds exactly one item (a request), a JSON object.
pub fn decode_one<T: DeserializeOwned>(
    payload: &[u8],
    limits: &InputLimits,
) -> Result<T, Rejection> {
    let text = text_of(payload, limits)?;
    let mut de = serde_json::Deserializer::from_str(text);
    T::deserialize(ObjectOnly(&mut de))
        .and_then(|item| de.end().map(|()| item))
        .map_err(|e| refused(e, text, None, None))
}

/// Decodes a payload that holds one item or a JSON array of them (a batch), checking size and UTF-8
/// first. Every item must be valid; the first invalid one names the batch index.
pub fn decode_batch<T: DeserializeOwned + Scanned>(
    payload: &[u8],
    limits: &InputLimits,
) -> Result<Vec<T>, Rejection> {
    let mut items = Vec::new();
    decode_batch_into(payload, limits, Ok, &mut items).map(|_| items)
}

/// Decodes a payload as [`decode_batch`] does, straight into domain values: `convert` validates each
/// item as soon as it is read and its value is appended to `out` (no list of messages in between);
/// returns how many. Faults rank as in `decode_batch` (text that is not JSON, a batch over the limit,
/// an item of the wrong shape), then the first item `convert` refuses, named by its index in a batch
/// of more than one. On a fault `out` is left as it was.
///
/// The payload is read by the fast path (`scan_batch`) and, where that gives up, by serde from the
/// start: the same messages either way. So `convert` may see an item twice (once by each reader, the
/// first value discarded): it must do nothing but convert.
pub fn decode_batch_into<T: DeserializeOwned + Scanned, M>(
    payload: &[u8],
    limits: &InputLimits,
    convert: impl FnMut(T) -> Result<M, Rejection>,
    out: &mut Vec<M>,
) -> Result<usize, Rejection> {
    decode_batch_via(payload, limits, convert, out, true)
}

/// [`decode_batch_into`], with or without its fast path (the tests compare the two).
pub(super) fn decode_batch_via<T: DeserializeOwned + Scanned, M>(
    payload: &[u8],
    limits: &InputLimits,
    mut convert: impl FnMut(T) -> Result<M, Rejection>,
    out: &mut Vec<M>,
    fast: bool,
) -> Result<usize, Rejection> {
    let text = text_of(payload, limits)?;
    let start = out.len();
    // The first item `convert` refuses, with its index; later ones are still read (a fault of the
    // text outranks it) but no longer converted.
    let mut invalid: Option<(usize, Rejection)> = None;
    let mut take = |out: &mut Vec<M>, invalid: &mut Option<(usize, Rejection)>, i: usize, m: T| {
        if invalid.is_none() {
            match convert(m) {
                Ok(v) => out.push(v),
                Err(r) => *invalid = Some((i, r)),
            }
        }
    };
    let scanned = match fast {
        true => scan_batch(text, limits.max_batch, &mut |i, m| {
            take(out, &mut invalid, i, m)
        }),
        false => None,
    };
    let read = match scanned {
        Some(n) => Ok(n),
        None => {
            // Read again from the start: what the fast path handed over is forgotten.
            out.truncate(start);
            invalid = None;
            let item = Cell::new(None);
            let mut de = serde_json::Deserializer::from_str(text);
            let mut reread = |i, m| take(out, &mut invalid, i, m);
            let one_or_many = OneOrMany {
                max_batch: limits.max_batch,
                item: &item,
                each: &mut reread,
            };
            de.deserialize_any(one_or_many)
                .and_then(|n| de.end().map(|()| n))
                .map_err(|e| refused(e, text, Some(limits.max_batch), item.get()))
        }
    };
    let result = match (read, invalid) {
        (Err(r), _) => Err(r),
        (Ok(n), Some((i, r))) if n > 1 => Err(Rejection::new(
            r.code,
            format!("batch item {i}: {}", r.message),
        )),
        (Ok(_), Some((_, r))) => Err(r),
        (Ok(n), None) => Ok(n),
    };
    if result.is_err() {
        out.truncate(start);
    }
    result
}

/// The rejection of a payload serde refused. serde stops at the first fault in the text, but the
/// contract ranks faults: text that is not JSON (anywhere) before a batch over `max_batch` before a
/// value of the wrong shape. So a shape fault has the text read once more (only then; an accepted
/// payload is read once) for a syntax error further on and for the batch's length.
fn refused(
    e: serde_json::Error,
    text: &str,
    max_batch: Option<usize>,
    item: Option<usize>,
) -> Rejection {
    let not_json = |e| Rejection::new(RejectCode::InvalidJson, format!("payload is not JSON: {e}"));
    if !e.is_data() {
        return not_json(e);
    }
    match (serde_json::from_str::<Checked>(text), max_batch) {
        (Err(syntax), _) => not_json(syntax),
        (Ok(Checked(Some(n))), Some(max)) if n > max => Rejection::new(
            RejectCode::BatchTooLarge,
            format!("batch of {n} items exceeds {max}"),
        ),
        (Ok(_), _) => {
            let place = item
                .map(|i| format!("batch item {i}: "))
                .unwrap_or_default();
            Rejection::new(shape_code(&e), format!("{place}{e}"))
        }
    }
}

/// `null` where a number belongs is `non_finite` (how many encoders write NaN); every other shape
/// fault is `bad_request`. serde_json's errors carry a category but no kind, so this reads the
/// message: only our own, [`NULL_NUMBER`], which serde_json puts first (its position follows).
fn shape_code(e: &serde_json::Error) -> RejectCode {
    if e.to_string().starts_with(NULL_NUMBER) {
        RejectCode::NonFinite
    } else {
        RejectCode::BadRequest
    }
}

/// One JSON value, parsed as `serde_json::Value` would be (numbers, escapes, nesting depth; unlike
/// `IgnoredAny`, which skips them unchecked) and dropped; an array keeps its length.
struct Checked(Option<usize>);

impl<'de> Deserialize<'de> for Checked {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(Checking)
    }
}

struct Checking;

impl<'de> Visitor<'de> for Checking {
    type Value = Checked;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Checked, A::Error> {
        let mut n = 0;
        while seq.next_element::<Checked>()?.is_some() {
            n += 1;
        }
        Ok(Checked(Some(n)))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Checked, A::Error> {
        while map.next_entry::<Checked, Checked>()?.is_some() {}
        Ok(Checked(None))
    }
    fn visit_bool<E>(self, _: bool) -> Result<Checked, E> {
        Ok(Checked(None))
    }
    fn visit_i64<E>(self, _: i64) -> Result<Checked, E> {
        Ok(Checked(None))
    }
    fn visit_u64<E>(self, _: u64) -> Result<Checked, E> {
        Ok(Checked(None))
    }
    fn visit_f64<E>(self, _: f64) -> Result<Checked, E> {
        Ok(Checked(None))
    }
    fn visit_str<E>(self, _: &str) -> Result<Checked, E> {
        Ok(Checked(None))
    }
    fn visit_unit<E>(self) -> Result<Checked, E> {
        Ok(Checked(None))
    }
}

/// The top level of a `decode_batch` payload: one message (an object) or a non-empty array of at most
/// `max_batch` of them, each handed to `each` with its index as it is read; the value is their count.
/// `item` tells `refused` which item failed.
struct OneOrMany<'a, T> {
    max_batch: usize,
    item: &'a Cell<Option<usize>>,
    each: &'a mut dyn FnMut(usize, T),
}

impl<'de, T: Deserialize<'de>> Visitor<'de> for OneOrMany<'_, T> {
    type Value = usize;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON object or an array of them")
    }
    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<usize, A::Error> {
        (self.each)(0, T::deserialize(MapAccessDeserializer::new(map))?);
        Ok(1)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<usize, A::Error> {
        let mut n = 0;
        loop {
            self.item.set(Some(n));
            if n == self.max_batch {
                // One more is one too many, whatever it holds (`refused` counts them all).
                if seq.next_element::<IgnoredAny>()?.is_some() {
                    return Err(de::Error::custom("batch too large"));
                }
                break;
            }
            match seq.next_element_seed(Object(PhantomData))? {
                Some(m) => (self.each)(n, m),
                None => break,
            }
            n += 1;
        }
        self.item.set(None);
        if n == 0 {
            return Err(de::Error::custom("empty batch"));
        }
        Ok(n)
    }
}

/// A message or record (`obs[]`, `q`) read from a JSON object only: serde's derived structs would also
/// take an array of the field values, which the contract refuses.
struct Object<T>(PhantomData<T>);

impl<'de, T: Deserialize<'de>> DeserializeSeed<'de> for Object<T> {
    type Value = T;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<T, D::Error> {
        T::deserialize(ObjectOnly(d))
    }
}

/// A deserializer that reads a map whatever it is asked for (a derived struct asks for a struct).
struct ObjectOnly<D>(D);

impl<'de, D: Deserializer<'de>> Deserializer<'de> for ObjectOnly<D> {
    type Error = D::Error;
    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, D::Error> {
        self.0.deserialize_map(visitor)
    }
    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf option
        unit unit_struct newtype_struct seq tuple tuple_struct map struct enum identifier ignored_any
    }
}

// Field readers (`deserialize_with`). `null` is refused everywhere, also in optional fields: where a
// number belongs with `NULL_NUMBER`, elsewhere by the type's own error.

/// A number (`f64`, or `usize` for a count); `null` is `NULL_NUMBER`.
pub(super) fn number<'de, D: Deserializer<'de>, T: Deserialize<'de>>(d: D) -> Result<T, D::Error> {
    Option::<T>::deserialize(d)?.ok_or_else(|| de::Error::custom(NULL_NUMBER))
}

/// An optional number: present means a number.
pub(super) fn some_number<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    number(d).map(Some)
}

/// An optional field of another type: present means not `null`.
pub(super) fn some<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    T::deserialize(d).map(Some)
}

/// An optional record, a JSON object.
pub(super) fn some_object<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    Object(PhantomData).deserialize(d).map(Some)
}

/// An array of records, each a JSON object.
pub(super) fn objects<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Vec<T>, D::Error> {
    struct Records<T>(PhantomData<T>);
    impl<'de, T: Deserialize<'de>> Visitor<'de> for Records<T> {
        type Value = Vec<T>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("an array of JSON objects")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            let mut items = Vec::new();
            while let Some(m) = seq.next_element_seed(Object(PhantomData))? {
                items.push(m);
            }
            Ok(items)
        }
    }
    d.deserialize_seq(Records(PhantomData))
}

/// Three numbers, `[x, y, z]`.
pub(super) fn vec3<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    d.deserialize_tuple(3, Three)
}

/// An optional `[x, y, z]`.
pub(super) fn some_vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    vec3(d).map(Some)
}

/// The visitor of `[x, y, z]` (also of [`super::PerAxis`]'s array).
pub(super) struct Three;

impl<'de> Visitor<'de> for Three {
    type Value = [f64; 3];
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an array of 3 numbers")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[f64; 3], A::Error> {
        let mut v = [0.0; 3];
        for (i, x) in v.iter_mut().enumerate() {
            *x = seq
                .next_element::<Number>()?
                .ok_or_else(|| de::Error::invalid_length(i, &self))?
                .0;
        }
        // serde_json takes a fourth element for a syntax error (it expects the array's end): count
        // them, a wrong length.
        let mut n = 3;
        while seq.next_element::<IgnoredAny>()?.is_some() {
            n += 1;
        }
        if n > 3 {
            return Err(de::Error::invalid_length(n, &self));
        }
        Ok(v)
    }
}

/// An element of `[x, y, z]`.
struct Number(f64);

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        number(d).map(Number)
    }
}
