//! `attitude-service imu-bench`: our MEKF over a recorded IMU trial (gyro + accelerometer +
//! magnetometer), in one process and without the network, timed. The Rust half of
//! `benches/vqf_compare.py`, which runs the `vqf` package on the same samples of a BROAD trial
//! (Laidig, Caruso, Cereatti, Seel, *Data* 6(7), 2021, CC-BY-4.0) and reports the speed ratio and
//! the benchmark's errors of both.
//!
//! **Samples file** (written by the Python script), little-endian `f64` throughout: a header
//! `[n_samples, rate_hz]`, then per sample `[t, gx, gy, gz, ax, ay, az, mx, my, mz]` (s, rad/s, m/s², µT).
//!
//! **Estimates file**: little-endian `f64`, a header `[n]`, then per sample `[w, x, y, z]`: the estimate
//! after that sample, as the Hamilton quaternion of body → ENU (our [`Quaternion`]'s components,
//! ALGORITHMS.md §1), `w ≥ 0`.
//!
//! The model: the service's IMU sensor models (`crate::sensors::imu`, `config/imu.json5`), applied in
//! process exactly as a vehicle applies them to the observations of sensors named `acc` and `mag`.
//! * Reference frame: East-North-Up aligned with magnetic north (BROAD's `opt_quat` frame).
//! * Per sample `k`: one gyro measurement and one vector-observation set at `t_k`. The gyro rate of
//!   sample `k` is taken as the rate over `(t_{k−1}, t_k]` ([`GyroInterval::Preceding`], VQF's
//!   convention: its `update()` integrates `gyr` before correcting with `acc`/`mag`), so it is sent
//!   stamped `t_{k−1}` and the filter propagates to `t_k` with it before the update. (Holding it over
//!   `[t_k, t_{k+1})` instead, the project simulator's convention, lags one sample: 3.5 ms, up to 5° at
//!   BROAD's 25 rad/s.) The set holds two observations, sent raw as a client sends them:
//!   - `acc`: body = the accelerometer (m/s²), reference `[0, 0, g₀]`, σ = 0.05·g₀ (0.05 rad). The
//!     `gravity` model low-pass filters it in the reference frame (3 s) and gates `|‖a‖/g₀ − 1| > 5`
//!     (σ not inflated by the norm: with the low-pass that made BROAD worse, docs/broad.md);
//!   - `mag`: body = the magnetometer (µT), reference `m₀ [0, cos δ, −sin δ]` with the dip δ from the
//!     rest period (the angle between the mean accelerometer and mean magnetometer readings, minus
//!     90°), σ = 0.07·m₀. The `field` model suspends the sensor while the norm deviates by more than
//!     10 % or the dip by more than 10° (and 0.5 s after), and corrects the heading only.
//!
//!   `g₀` and `m₀` are the mean norms over the rest period, the first second of the trial (BROAD
//!   trials open with ≈ 40 s of rest).
//! * Gyro noise of a MEMS IMU: `σ_v = 1.5e-3 rad/s^½` (0.086 °/√s; several times a datasheet's noise
//!   density, to cover scale-factor and misalignment errors in fast rotations) and
//!   `σ_u = 3e-5 rad/s^{3/2}`. The sensor models' constants were chosen on the four BROAD trials in
//!   `../shared/data/broad` (docs/broad.md says how).
//! * Initial state: Davenport's q-method of the first sample's two observations, 0.1 rad per axis;
//!   bias 0 ± 0.01 rad/s (0.57 °/s) per axis.
//!
//! A measurement the filter refuses (non-finite, out of order, a failed update) leaves the filter as it
//! was (the [`crate::filters::FilterCore`] contract); it is counted in `rejected` and the run goes on.

use crate::attitude::{q_method, Quaternion, WahbaError};
use crate::filters::{build_filter, FilterConfig, FilterError, FilterSpec, InitialState};
use crate::sensors::imu::{FieldModel, GravityModel, LowpassState, Verdict};
use crate::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::{Matrix3, Vector3};
use std::path::Path;
use std::time::Instant;
use thiserror::Error;

/// Values per sample in the samples file: `[t, gx, gy, gz, ax, ay, az, mx, my, mz]`.
pub const VALUES_PER_SAMPLE: usize = 10;

/// The filter's assumptions (see the module documentation); [`MekfTuning::default`] is the benchmark's.
/// Every field can be overridden from JSON (`imu-bench --tuning '{"sigma_v": 2e-3}'`) for experiments.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MekfTuning {
    /// Angle random walk assumed for the MEMS gyro, rad/s^½.
    pub sigma_v: f64,
    /// Rate random walk assumed for the MEMS gyro, rad/s^{3/2}.
    pub sigma_u: f64,
    /// Base σ of the gravity direction, rad.
    pub sigma_gravity_rad: f64,
    /// Base σ of the magnetic field direction, rad.
    pub sigma_mag_rad: f64,
    /// The accelerometer's model (adaptive σ, norm gate).
    pub gravity: GravityModel,
    /// The magnetometer's model (disturbance detection, hold-off, heading-only).
    pub field: FieldModel,
    /// Use the magnetometer at all.
    pub use_mag: bool,
    /// Initial attitude 1σ per axis, rad.
    pub initial_attitude_sigma_rad: f64,
    /// Initial gyro-bias 1σ per axis, rad/s.
    pub initial_bias_sigma_rad_s: f64,
    /// Which sampling interval a gyro sample's rate covers.
    pub gyro_interval: GyroInterval,
    /// The filter (`mekf`, `qpf:average`, ...; the benchmark's is the MEKF) and a QPF's particles.
    #[serde(deserialize_with = "filter_spec", serialize_with = "filter_spec_out")]
    pub filter: FilterSpec,
    pub particles: usize,
    /// The QPF's tuning.
    pub qpf: crate::filters::QpfOptions,
}

fn filter_spec<'de, D: serde::Deserializer<'de>>(d: D) -> Result<FilterSpec, D::Error> {
    let s = <String as serde::Deserialize>::deserialize(d)?;
    s.parse().map_err(serde::de::Error::custom)
}

fn filter_spec_out<S: serde::Serializer>(spec: &FilterSpec, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&spec.to_string())
}

/// Which sampling interval the rate of gyro sample `k` (taken at `t_k`) covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GyroInterval {
    /// `(t_{k−1}, t_k]`: the sample is sent stamped `t_{k−1}`, so the filter propagates to `t_k` with it
    /// and then uses the accelerometer and magnetometer of the same sample (VQF's convention: its
    /// `update()` integrates `gyr` before correcting with `acc`/`mag`).
    Preceding,
    /// `[t_k, t_{k+1})`: the sample is stamped `t_k` and held until the next (the project's simulator).
    Following,
}

impl Default for MekfTuning {
    /// The values of `config/imu.json5` (the service's IMU preset).
    fn default() -> Self {
        MekfTuning {
            sigma_v: 1.5e-3,
            sigma_u: 3e-5,
            sigma_gravity_rad: 0.05,
            sigma_mag_rad: 0.07,
            gravity: GravityModel {
                sigma_norm_scale: 0.0,
                norm_gate: 5.0,
                lowpass_s: 3.0,
            },
            field: FieldModel {
                sigma_norm_scale: 0.0,
                norm_limit: 0.1,
                dip_limit_rad: 10f64.to_radians(),
                holdoff_s: 0.5,
                heading_only: true,
                vertical: UP,
            },
            use_mag: true,
            initial_attitude_sigma_rad: 0.1,
            initial_bias_sigma_rad_s: 0.01,
            gyro_interval: GyroInterval::Preceding,
            filter: FilterSpec {
                kind: crate::filters::FilterKind::Mekf,
                fiducial: None,
            },
            particles: 500,
            qpf: crate::filters::QpfOptions::default(),
        }
    }
}

#[derive(Debug, Error)]
pub enum ImuBenchError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("malformed samples file: {0}")]
    Format(String),
    #[error("cannot initialise from the first sample: {0}")]
    Init(#[from] WahbaError),
    #[error("filter: {0}")]
    Filter(#[from] FilterError),
    #[error("tuning: {0}")]
    Tuning(String),
}

/// One IMU sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    pub t_s: f64,
    pub gyr_rad_s: Vector3<f64>,
    pub acc_m_s2: Vector3<f64>,
    pub mag_ut: Vector3<f64>,
}

/// The samples of one trial.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuTrial {
    pub rate_hz: f64,
    pub samples: Vec<ImuSample>,
}

/// The timed run.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuBenchResult {
    pub samples: usize,
    /// Wall clock of the run (rest statistics, initialisation and the per-sample loop, including
    /// reading out each estimate), s. File reading and writing are excluded.
    pub seconds: f64,
    pub samples_per_s: f64,
    /// Measurements the filter refused (each leaves the state unchanged).
    pub rejected: usize,
    /// Accelerometer observations gated by their norm, and magnetometer observations judged disturbed
    /// or held off after a disturbance.
    pub gravity_gated: usize,
    pub field_suspended: usize,
    /// The estimate after each sample (body → ENU, Hamilton components `x, y, z, w`).
    pub estimates: Vec<Quaternion>,
}

impl ImuBenchResult {
    /// One JSON object line: `{"samples":..,"seconds":..,"samples_per_s":..,"rejected":..,"filter":"mekf"}`.
    pub fn json_line(&self) -> String {
        serde_json::json!({
            "samples": self.samples,
            "seconds": self.seconds,
            "samples_per_s": self.samples_per_s,
            "rejected": self.rejected,
            "gravity_gated": self.gravity_gated,
            "field_suspended": self.field_suspended,
            "filter": "mekf",
        })
        .to_string()
    }
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ImuBenchError + '_ {
    move |source| ImuBenchError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Parses a samples file (see the module documentation).
pub fn parse_samples(bytes: &[u8]) -> Result<ImuTrial, ImuBenchError> {
    if bytes.len() % 8 != 0 || bytes.len() < 16 {
        return Err(ImuBenchError::Format(format!(
            "{} bytes is not a header of two f64 plus whole f64 values",
            bytes.len()
        )));
    }
    let values: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("chunks of 8")))
        .collect();
    let (n, rate_hz) = (values[0], values[1]);
    if !(n >= 1.0 && n.fract() == 0.0 && n <= usize::MAX as f64) {
        return Err(ImuBenchError::Format(format!(
            "sample count {n} is not a positive integer"
        )));
    }
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(ImuBenchError::Format(format!(
            "rate {rate_hz} Hz is not positive"
        )));
    }
    let n = n as usize;
    let body = &values[2..];
    if body.len() != n * VALUES_PER_SAMPLE {
        return Err(ImuBenchError::Format(format!(
            "header says {n} samples ({} values) but the file holds {} values",
            n * VALUES_PER_SAMPLE,
            body.len()
        )));
    }
    let samples = body
        .chunks_exact(VALUES_PER_SAMPLE)
        .map(|v| ImuSample {
            t_s: v[0],
            gyr_rad_s: Vector3::new(v[1], v[2], v[3]),
            acc_m_s2: Vector3::new(v[4], v[5], v[6]),
            mag_ut: Vector3::new(v[7], v[8], v[9]),
        })
        .collect();
    Ok(ImuTrial { rate_hz, samples })
}

/// Reads a samples file.
pub fn read_samples(path: &Path) -> Result<ImuTrial, ImuBenchError> {
    parse_samples(&std::fs::read(path).map_err(io_err(path))?)
}

/// Serialises samples in the samples-file format (used by the tests; the Python script writes the
/// same bytes with numpy).
pub fn samples_to_bytes(trial: &ImuTrial) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 * (2 + VALUES_PER_SAMPLE * trial.samples.len()));
    let mut put = |x: f64| out.extend_from_slice(&x.to_le_bytes());
    put(trial.samples.len() as f64);
    put(trial.rate_hz);
    for s in &trial.samples {
        put(s.t_s);
        s.gyr_rad_s
            .iter()
            .chain(s.acc_m_s2.iter())
            .chain(s.mag_ut.iter())
            .for_each(|x| put(*x));
    }
    out
}

/// Writes the estimates file: `[n]` then `[w, x, y, z]` per sample, little-endian `f64`.
pub fn write_estimates(path: &Path, estimates: &[Quaternion]) -> Result<(), ImuBenchError> {
    let mut out = Vec::with_capacity(8 * (1 + 4 * estimates.len()));
    out.extend_from_slice(&(estimates.len() as f64).to_le_bytes());
    for q in estimates {
        for x in [q.w, q.x, q.y, q.z] {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    std::fs::write(path, out).map_err(io_err(path))
}

/// The field model taken from the rest period (the first second).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestReference {
    /// Mean accelerometer norm, m/s².
    pub g0: f64,
    /// Mean magnetometer norm, µT.
    pub m0: f64,
    /// Magnetic dip (positive: the field points below the horizon), rad.
    pub dip_rad: f64,
    /// Unit field direction in ENU aligned with magnetic north: `[0, cos δ, −sin δ]`.
    pub mag_reference: Vector3<f64>,
}

/// Rest statistics over the first second of the trial (at least one sample).
pub fn rest_reference(trial: &ImuTrial) -> Result<RestReference, ImuBenchError> {
    let count = (trial.rate_hz.round() as usize).clamp(1, trial.samples.len());
    let rest = &trial.samples[..count];
    let (mut acc, mut mag, mut g0, mut m0) = (Vector3::zeros(), Vector3::zeros(), 0.0, 0.0);
    for s in rest {
        acc += s.acc_m_s2;
        mag += s.mag_ut;
        g0 += s.acc_m_s2.norm();
        m0 += s.mag_ut.norm();
    }
    let k = count as f64;
    let (g0, m0) = (g0 / k, m0 / k);
    let (an, mn) = (acc.norm(), mag.norm());
    if !(an > 0.0 && mn > 0.0 && an.is_finite() && mn.is_finite() && g0 > 0.0 && m0 > 0.0) {
        return Err(ImuBenchError::Format(
            "the rest period has no usable accelerometer or magnetometer reading".into(),
        ));
    }
    let angle = (acc.dot(&mag) / (an * mn)).clamp(-1.0, 1.0).acos();
    let dip_rad = angle - std::f64::consts::FRAC_PI_2;
    if !(dip_rad.abs() < std::f64::consts::FRAC_PI_2 - 1e-3) {
        return Err(ImuBenchError::Format(
            "the rest field is parallel to gravity: heading is unobservable".into(),
        ));
    }
    Ok(RestReference {
        g0,
        m0,
        dip_rad,
        mag_reference: Vector3::new(0.0, dip_rad.cos(), -dip_rad.sin()),
    })
}

const UP: Vector3<f64> = Vector3::new(0.0, 0.0, 1.0);

/// The two raw observations of one sample as a client that computes the references sends them on
/// `P/V/vectors` (`config/imu.json5`):
/// the accelerometer against `[0, 0, g₀]` with `σ = σ_g g₀`, the magnetometer against `m₀ [0, cos δ, −sin δ]`
/// with `σ = σ_m m₀` (so that the direction σ at the reference norm is `σ_g`, `σ_m` rad).
fn raw_observations(
    s: &ImuSample,
    rest: &RestReference,
    tuning: &MekfTuning,
) -> [VectorObservation; 2] {
    [
        VectorObservation {
            body: s.acc_m_s2,
            reference: UP * rest.g0,
            sigma: tuning.sigma_gravity_rad * rest.g0,
            sensor: Some("acc".into()),
            aspect: Aspect::Full,
        },
        VectorObservation {
            body: s.mag_ut,
            reference: rest.mag_reference * rest.m0,
            sigma: tuning.sigma_mag_rad * rest.m0,
            sensor: Some("mag".into()),
            aspect: Aspect::Full,
        },
    ]
}

/// The field sensor's suspension state (the service's per-sensor hold-off).
#[derive(Default)]
struct FieldState {
    last_disturbed_t_s: Option<f64>,
    lowpass: LowpassState,
}

impl FieldState {
    /// The posterior for the gravity low-pass (`SensorState::settle`).
    fn lowpass_settle(&mut self, posterior: &Quaternion) {
        if self.lowpass.t_s.is_some() {
            self.lowpass.posterior = Some(*posterior);
        }
    }
}

/// The observations of one sample after the sensor models (the service's `gravity` and `field`
/// sensor kinds); counts gated and suspended ones.
fn observations(
    s: &ImuSample,
    rest: &RestReference,
    tuning: &MekfTuning,
    a_est: &Matrix3<f64>,
    field_state: &mut FieldState,
    result: &mut ImuBenchResult,
    out: &mut Vec<VectorObservation>,
) {
    out.clear();
    let [acc, mag] = raw_observations(s, rest, tuning);
    let direction = tuning
        .gravity
        .lowpass(&mut field_state.lowpass, s.t_s, &acc.body, a_est);
    match tuning.gravity.apply(&acc, &direction) {
        Verdict::Use(o) => out.push(o),
        Verdict::NormGated { .. } => result.gravity_gated += 1,
        _ => {}
    }
    if !tuning.use_mag {
        return;
    }
    match tuning.field.apply(&mag, a_est) {
        Verdict::Use(o) => {
            let held = field_state
                .last_disturbed_t_s
                .is_some_and(|t| s.t_s - t < tuning.field.holdoff_s);
            if held {
                result.field_suspended += 1;
            } else {
                out.push(o);
            }
        }
        Verdict::Disturbed { .. } => {
            field_state.last_disturbed_t_s = Some(s.t_s);
            result.field_suspended += 1;
        }
        _ => {}
    }
}

/// The MEKF configuration and initial state of this benchmark (see the module documentation).
pub fn mekf_setup(
    trial: &ImuTrial,
    rest: &RestReference,
    tuning: &MekfTuning,
) -> Result<(FilterConfig, InitialState), ImuBenchError> {
    let first = trial
        .samples
        .first()
        .ok_or_else(|| ImuBenchError::Format("no samples".into()))?;
    let obs: Vec<VectorObservation> = raw_observations(first, rest, tuning)
        .into_iter()
        .map(|o| VectorObservation {
            body: o.body.normalize(),
            reference: o.reference.normalize(),
            sigma: o.sigma / o.reference.norm(),
            ..o
        })
        .collect();
    let q0 = q_method(&obs)?.q;
    let spec = tuning.filter;
    let gyro = GyroNoise {
        sigma_v: tuning.sigma_v,
        sigma_u: tuning.sigma_u,
    };
    let initial = InitialState {
        t_s: Some(first.t_s),
        q: q0,
        sigma_att_rad: Vector3::repeat(tuning.initial_attitude_sigma_rad),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(tuning.initial_bias_sigma_rad_s),
        uniform_attitude: false,
        covariance: None,
    };
    let mut config = FilterConfig::new(spec, gyro);
    config.particles = tuning.particles;
    config.qpf = tuning.qpf;
    Ok((config, initial))
}

/// Runs the MEKF with the benchmark's tuning over every sample of `trial`, timed (see
/// [`ImuBenchResult::seconds`]).
pub fn run_mekf(trial: &ImuTrial) -> Result<ImuBenchResult, ImuBenchError> {
    run_mekf_with(trial, &MekfTuning::default())
}

/// [`run_mekf`] with another tuning.
pub fn run_mekf_with(
    trial: &ImuTrial,
    tuning: &MekfTuning,
) -> Result<ImuBenchResult, ImuBenchError> {
    let start = Instant::now();
    let rest = rest_reference(trial)?;
    let (config, initial) = mekf_setup(trial, &rest, tuning)?;
    let mut filter = build_filter(&config, &initial, 0)?;
    let mut result = ImuBenchResult {
        samples: trial.samples.len(),
        seconds: 0.0,
        samples_per_s: 0.0,
        rejected: 0,
        gravity_gated: 0,
        field_suspended: 0,
        estimates: Vec::with_capacity(trial.samples.len()),
    };
    let mut field_state = FieldState::default();
    // One observation set reused for every sample (no allocation per sample).
    let mut set = ObservationSet {
        t_s: initial.t_s.unwrap_or(0.0),
        observations: Vec::with_capacity(2),
    };
    let mut previous_t_s = initial.t_s.unwrap_or(0.0);
    for s in &trial.samples {
        let gyro = Measurement::Gyro(GyroSample {
            t_s: match tuning.gyro_interval {
                GyroInterval::Preceding => previous_t_s,
                GyroInterval::Following => s.t_s,
            },
            omega_body_rad_s: s.gyr_rad_s,
        });
        previous_t_s = s.t_s;
        if filter.process(&gyro).is_err() {
            result.rejected += 1;
        }
        if filter.advance_to(s.t_s).is_err() {
            result.rejected += 1;
        }
        let a_est = filter.estimate().q.attitude_matrix();
        set.t_s = s.t_s;
        observations(
            s,
            &rest,
            tuning,
            &a_est,
            &mut field_state,
            &mut result,
            &mut set.observations,
        );
        let vectors = Measurement::Vectors(set);
        if filter.process(&vectors).is_err() {
            result.rejected += 1;
        }
        let Measurement::Vectors(back) = vectors else {
            unreachable!("built as Vectors above")
        };
        set = back;
        let q = filter.estimate().q;
        field_state.lowpass_settle(&q);
        result.estimates.push(q);
    }
    result.seconds = start.elapsed().as_secs_f64();
    result.samples_per_s = if result.seconds > 0.0 {
        result.samples as f64 / result.seconds
    } else {
        f64::INFINITY
    };
    Ok(result)
}

/// Reads a samples file and runs the MEKF over it (file reading is not timed).
pub fn run_mekf_on_samples(path: &Path) -> Result<ImuBenchResult, ImuBenchError> {
    run_mekf(&read_samples(path)?)
}

/// `attitude-service imu-bench --samples FILE [--estimates-out FILE] [--tuning JSON]`: runs the MEKF
/// over the samples file (with the tuning's fields overridden by the JSON object, if given), writes the
/// estimates when asked, and returns the JSON line to print
/// (`{"samples":..,"seconds":..,"samples_per_s":..,"rejected":..,"filter":"mekf",..}`).
pub fn main_entry(
    samples: &Path,
    estimates_out: Option<&Path>,
    tuning: Option<&str>,
) -> Result<String, ImuBenchError> {
    let tuning: MekfTuning = match tuning {
        Some(json) => {
            serde_json::from_str(json).map_err(|e| ImuBenchError::Tuning(e.to_string()))?
        }
        None => MekfTuning::default(),
    };
    let result = run_mekf_with(&read_samples(samples)?, &tuning)?;
    if let Some(out) = estimates_out {
        write_estimates(out, &result.estimates)?;
    }
    Ok(result.json_line())
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE_HZ: f64 = 100.0;
    const G: f64 = 9.81;

    /// 1 s at rest, then 4 s at a constant body rate, with a constant gyro bias and exact
    /// (noise-free) accelerometer and magnetometer readings; gyro sample `k` is the rate over
    /// `(t_{k−1}, t_k]` (the BROAD/VQF convention). Returns the trial and the true attitudes.
    fn synthetic(bias: Vector3<f64>) -> (ImuTrial, Vec<Quaternion>) {
        let dt = 1.0 / RATE_HZ;
        let dip = 60f64.to_radians();
        let field_enu = Vector3::new(0.0, dip.cos(), -dip.sin()) * 50.0;
        let gravity_enu = Vector3::new(0.0, 0.0, G);
        let rate = Vector3::new(0.3, -0.2, 0.5);
        let mut q = Quaternion::from_euler_321(0.1, -0.05, 0.7);
        let (mut samples, mut truth) = (Vec::new(), Vec::new());
        for k in 0..(5.0 * RATE_HZ) as usize {
            let t = k as f64 * dt;
            // The rate over (t − dt, t].
            let omega = if t < 1.0 + 1e-9 {
                Vector3::zeros()
            } else {
                rate
            };
            if k > 0 {
                q = q.propagate(&omega, dt);
            }
            let a = q.attitude_matrix();
            samples.push(ImuSample {
                t_s: t,
                gyr_rad_s: omega + bias,
                acc_m_s2: a * gravity_enu,
                mag_ut: a * field_enu,
            });
            truth.push(q);
        }
        (
            ImuTrial {
                rate_hz: RATE_HZ,
                samples,
            },
            truth,
        )
    }

    fn biased() -> (ImuTrial, Vec<Quaternion>) {
        synthetic(Vector3::new(0.004, -0.003, 0.002))
    }

    fn error_deg(truth: &Quaternion, estimate: &Quaternion) -> f64 {
        truth.compose(&estimate.inverse()).angle().to_degrees()
    }

    #[test]
    fn rest_reference_recovers_the_dip() {
        let (trial, _) = biased();
        let rest = rest_reference(&trial).unwrap();
        assert!((rest.dip_rad.to_degrees() - 60.0).abs() < 1e-9);
        assert!((rest.g0 - G).abs() < 1e-9 && (rest.m0 - 50.0).abs() < 1e-9);
    }

    #[test]
    fn mekf_tracks_a_synthetic_trial_through_the_files() {
        let (trial, truth) = biased();
        let dir = std::env::temp_dir().join(format!("imu_bench_test_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let samples_path = dir.join("samples.bin");
        let estimates_path = dir.join("estimates.bin");
        std::fs::write(&samples_path, samples_to_bytes(&trial)).unwrap();

        let line = main_entry(&samples_path, Some(&estimates_path), None).unwrap();
        let json: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(json["samples"], 500);
        assert_eq!(json["rejected"], 0);
        assert!(json["samples_per_s"].as_f64().unwrap() > 0.0);
        assert!(json["seconds"].as_f64().unwrap() > 0.0);

        let bytes = std::fs::read(&estimates_path).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let values: Vec<f64> = bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(values.len(), 1 + 4 * 500);
        assert_eq!(values[0], 500.0);
        let last = &values[1 + 4 * 499..];
        let q_last = Quaternion::new(last[1], last[2], last[3], last[0]);
        let err = error_deg(truth.last().unwrap(), &q_last);
        assert!(err < 1.0, "final attitude error {err}°");
        // The file carries the Hamilton body → ENU quaternion: it rotates the body-frame field reading
        // into the ENU field (r = A(q)ᵀ b).
        let s = trial.samples.last().unwrap();
        let r = q_last.attitude_matrix().transpose() * s.acc_m_s2 / G;
        assert!((r - Vector3::new(0.0, 0.0, 1.0)).norm() < 0.02, "{r}");
    }

    #[test]
    fn mekf_result_holds_one_estimate_per_sample() {
        let (trial, truth) = biased();
        let result = run_mekf(&trial).unwrap();
        assert_eq!(result.estimates.len(), trial.samples.len());
        // Initialised by the q-method of exact vectors: right from the first sample.
        assert!(error_deg(&truth[0], &result.estimates[0]) < 0.1);
        let worst = truth
            .iter()
            .zip(&result.estimates)
            .map(|(t, e)| error_deg(t, e))
            .fold(0.0, f64::max);
        assert!(worst < 2.0, "worst error {worst}°");
    }

    /// With the vector observations made uninformative the filter follows the gyro alone: exact under
    /// the matching interval convention, one sample's rotation late under the other.
    #[test]
    fn gyro_interval_convention_matters() {
        let (trial, truth) = synthetic(Vector3::zeros());
        let gyro_only = MekfTuning {
            sigma_gravity_rad: 1e6,
            sigma_mag_rad: 1e6,
            initial_bias_sigma_rad_s: 1e-9,
            ..MekfTuning::default()
        };
        let last = |interval| {
            let tuning = MekfTuning {
                gyro_interval: interval,
                ..gyro_only
            };
            let r = run_mekf_with(&trial, &tuning).unwrap();
            error_deg(truth.last().unwrap(), r.estimates.last().unwrap())
        };
        let preceding = last(GyroInterval::Preceding);
        let following = last(GyroInterval::Following);
        assert!(preceding < 1e-3, "preceding: {preceding}°");
        // One sample at ‖ω‖ = 0.62 rad/s and 100 Hz is 0.36°.
        assert!((following - 0.36).abs() < 0.05, "following: {following}°");
    }

    #[test]
    fn malformed_files_are_refused() {
        let (trial, _) = biased();
        let bytes = samples_to_bytes(&trial);
        assert!(matches!(
            parse_samples(&bytes[..bytes.len() - 8]),
            Err(ImuBenchError::Format(_))
        ));
        assert!(matches!(
            parse_samples(&bytes[..12]),
            Err(ImuBenchError::Format(_))
        ));
        let mut zero_rate = bytes.clone();
        zero_rate[8..16].copy_from_slice(&0f64.to_le_bytes());
        assert!(matches!(
            parse_samples(&zero_rate),
            Err(ImuBenchError::Format(_))
        ));
        assert_eq!(parse_samples(&bytes).unwrap(), trial);
    }
}
