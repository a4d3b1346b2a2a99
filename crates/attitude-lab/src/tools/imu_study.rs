//! `attitude-lab imu-study`: recorded IMU trials through the vehicle pipeline of the service, in
//! one process, scored against their truth ([`crate::study::broad`]).
//!
//! Every sample goes through [`VehicleState`], the very state machine a `serve` vehicle runs (time
//! checks, the raw-IMU sensor models of [`attitude_core::ahrs`], the filter, health), with the configuration
//! read from a file (`config/imu.json5` by default) and optionally changed field by field
//! (`--set service.imu.acc.motion_gain=1.5`). Nothing of the pipeline is repeated here: a study and a
//! tuning measure what the service does.
//!
//! **Trial file** (`scripts/broad-export.py` writes it from a BROAD-layout HDF5 file), little-endian
//! `f64`: a header `[n, rate_hz, 15]`, then per sample
//! `[t, gx, gy, gz, ax, ay, az, mx, my, mz, qw, qx, qy, qz, movement]` (s, rad/s, m/s², any unit; the
//! truth as the Hamilton quaternion of body → reference, NaN where unknown; movement 1/0), then
//! optionally the truth's description as a UTF-8 JSON object ([`TruthMeta`]; without it the truth is
//! BROAD's: body → East-North-Up with magnetic north, the IMU's own body frame).
//!
//! **CSV trial** (`NAME.csv`; what a user writes from their own motion capture, docs/recordings.md):
//! lines `# key: value` for the same description (`align: both`, `truth_tilt_sigma_deg: 0.2`,
//! `truth_time_sigma_s: 0.01`), a header line naming the fifteen columns above, then one line per
//! sample; an empty truth field is unknown.

use crate::study::broad::{score_with, Align, Sample, Scores, TruthModel};
use attitude_core::attitude::Quaternion;
use attitude_core::filters::FilterSpec;
use attitude_core::sensors::{ImuSample, Measurement};
use attitude_core::vehicle::{Event, ImuDiagnostics, Published, VehicleState};
use attitude_service::cli::config::DEFAULT_CONFIG;
use attitude_service::service::config::{
    self, extends, Policy, ServiceConfig, VehicleFilterConfig,
};
use attitude_service::wire::ImuDiagnosticsMsg;
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;
use thiserror::Error;

/// Values per sample of a trial file.
pub const COLUMNS: usize = 15;

#[derive(Debug, Error)]
pub enum StudyError {
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    #[error("{path}: malformed trial file: {message}")]
    Format { path: String, message: String },
    #[error("configuration: {0}")]
    Config(String),
    #[error("{0}")]
    Usage(String),
}

/// A recorded trial: the samples, and per sample the truth (if known) and whether it is scored.
#[derive(Clone, Debug, PartialEq)]
pub struct Trial {
    pub name: String,
    pub rate_hz: f64,
    pub samples: Vec<ImuSample>,
    pub truth: Vec<Option<Quaternion>>,
    pub movement: Vec<bool>,
    /// How the truth relates to the estimator's frames and what it may be off by.
    pub truth_model: TruthModel,
    /// The set it belongs to (the name of the folder it was read from; a tuning weighs every set
    /// alike).
    pub set: String,
}

/// The description of a trial's truth, as a trial file's JSON trailer or a CSV trial's `#` lines
/// hold it (every field optional; the defaults are BROAD's).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthMeta {
    /// `none` (the truth is body → East-North-Up with magnetic north, of the IMU's body) or `both`
    /// (its own reference and body frames: each estimator is aligned on its own).
    #[serde(default)]
    pub align: Option<Align>,
    /// The truth's own tilt error, 1σ deg (default 0.2).
    #[serde(default)]
    pub truth_tilt_sigma_deg: Option<f64>,
    /// The truth's time-stamp uncertainty against the IMU, 1σ s (default 0).
    #[serde(default)]
    pub truth_time_sigma_s: Option<f64>,
    /// Where the recording comes from (attribution; not used).
    #[serde(default)]
    pub source: Option<String>,
}

impl TruthMeta {
    /// The truth model it describes; `Err` for a value out of range.
    pub fn model(&self) -> Result<TruthModel, String> {
        let d = TruthModel::default();
        let tilt = self
            .truth_tilt_sigma_deg
            .map_or(d.tilt_sigma_rad, f64::to_radians);
        let time = self.truth_time_sigma_s.unwrap_or(d.time_sigma_s);
        if !(tilt >= 0.0 && tilt.is_finite() && time >= 0.0 && time.is_finite()) {
            return Err(format!(
                "truth_tilt_sigma_deg and truth_time_sigma_s must be finite and ≥ 0 ({tilt}, {time})"
            ));
        }
        Ok(TruthModel {
            align: self.align.unwrap_or(Align::None),
            tilt_sigma_rad: tilt,
            time_sigma_s: time,
            ..d
        })
    }
}

/// The first bytes of every HDF5 file (its format signature).
const HDF5_SIGNATURE: &[u8] = b"\x89HDF\r\n\x1a\n";

/// Parses a trial file's bytes (see the module documentation).
pub fn parse_trial(name: &str, bytes: &[u8]) -> Result<Trial, String> {
    if bytes.starts_with(HDF5_SIGNATURE) {
        // (BROAD's own files, and recordings in its layout: the natural thing to pass first.)
        return Err("it is an HDF5 file: convert it with scripts/broad-export.py (`broad-export.py \
             FILE --out DIR`, with --csv for a CSV trial), or score it through a running service with \
             `attitude-replay FILE` (docs/recordings.md)"
            .into());
    }
    let f = |k: usize| -> Option<f64> {
        bytes
            .get(8 * k..8 * k + 8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
    };
    let (Some(n), Some(rate), Some(cols)) = (f(0), f(1), f(2)) else {
        return Err(format!(
            "{} bytes is not a header of three f64 and rows",
            bytes.len()
        ));
    };
    if cols != COLUMNS as f64 {
        return Err(format!(
            "not a trial file of scripts/broad-export.py: its header's column count reads {cols:e}, \
             expected {COLUMNS} (a CSV trial must be named *.csv)"
        ));
    }
    if !(n >= 1.0 && n.fract() == 0.0) || !(rate > 0.0 && rate.is_finite()) {
        return Err(format!("bad header: n = {n}, rate = {rate}"));
    }
    let n = n as usize;
    let end = 8 * (3 + n * COLUMNS);
    if bytes.len() < end {
        return Err(format!(
            "header says {n} samples but the file holds {} values",
            bytes.len() / 8 - 3
        ));
    }
    let v: Vec<f64> = bytes[24..end]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("chunks of 8")))
        .collect();
    let meta: TruthMeta = if end < bytes.len() {
        let text = std::str::from_utf8(&bytes[end..])
            .map_err(|e| format!("the trailer after the samples is not UTF-8: {e}"))?;
        serde_json::from_str(text).map_err(|e| format!("the trailer after the samples: {e}"))?
    } else {
        TruthMeta::default()
    };
    let mut trial = Trial::empty(name, rate, meta.model()?);
    for (k, r) in v.chunks_exact(COLUMNS).enumerate() {
        trial.push_row(k, r)?;
    }
    Ok(trial)
}

impl Trial {
    fn empty(name: &str, rate_hz: f64, truth_model: TruthModel) -> Self {
        Trial {
            name: name.to_string(),
            rate_hz,
            samples: Vec::new(),
            truth: Vec::new(),
            movement: Vec::new(),
            truth_model,
            set: String::new(),
        }
    }

    /// Appends sample `k`, a row of the fifteen columns.
    fn push_row(&mut self, k: usize, r: &[f64]) -> Result<(), String> {
        if !r[..10].iter().all(|x| x.is_finite()) {
            return Err(format!("sample {k}: non-finite IMU values"));
        }
        let mag = Vector3::new(r[7], r[8], r[9]);
        self.samples.push(ImuSample {
            t_s: r[0],
            gyr_rad_s: Vector3::new(r[1], r[2], r[3]),
            acc_m_s2: Vector3::new(r[4], r[5], r[6]),
            mag: (mag != Vector3::zeros()).then_some(mag),
        });
        // Hamilton [w, x, y, z] of body → reference: this project's components (x, y, z, w).
        let q = Quaternion::new(r[11], r[12], r[13], r[10]);
        self.truth
            .push(q.is_finite().then(|| q.normalized()).flatten());
        self.movement.push(r[14] != 0.0);
        Ok(())
    }

    /// The gyro rate of every sample (body frame, rad/s).
    pub fn rates(&self) -> Vec<Vector3<f64>> {
        self.samples.iter().map(|s| s.gyr_rad_s).collect()
    }
}

/// The names of a CSV trial's fifteen columns, in order.
pub const CSV_COLUMNS: [&str; COLUMNS] = [
    "t", "gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz", "qw", "qx", "qy", "qz", "movement",
];

/// Parses a CSV trial (see the module documentation): `# key: value` lines, the header, the rows. The
/// rate is the median sample rate.
pub fn parse_csv_trial(name: &str, text: &str) -> Result<Trial, String> {
    let mut meta = serde_json::Map::new();
    let mut header: Option<Vec<usize>> = None;
    let mut rows: Vec<[f64; COLUMNS]> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(c) = line.strip_prefix('#') {
            let Some((k, v)) = c.split_once(':') else {
                continue;
            };
            let v = v.trim();
            let value = v
                .parse::<f64>()
                .map(serde_json::Value::from)
                .unwrap_or_else(|_| serde_json::Value::from(v));
            meta.insert(k.trim().to_string(), value);
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(order) = &header else {
            let mut order = Vec::with_capacity(COLUMNS);
            for c in CSV_COLUMNS {
                let at = fields
                    .iter()
                    .position(|f| *f == c)
                    .ok_or_else(|| format!("line {}: the header has no column {c:?}", i + 1))?;
                order.push(at);
            }
            header = Some(order);
            continue;
        };
        let mut r = [f64::NAN; COLUMNS];
        for (j, &at) in order.iter().enumerate() {
            let f = fields
                .get(at)
                .ok_or_else(|| format!("line {}: {} fields", i + 1, fields.len()))?;
            if !f.is_empty() {
                r[j] = f
                    .parse()
                    .map_err(|e| format!("line {}: {:?}: {e}", i + 1, f))?;
            }
        }
        rows.push(r);
    }
    if rows.is_empty() {
        return Err("no samples".into());
    }
    let meta: TruthMeta = serde_json::from_value(serde_json::Value::Object(meta))
        .map_err(|e| format!("the # lines: {e}"))?;
    let mut dt: Vec<f64> = rows.windows(2).map(|w| w[1][0] - w[0][0]).collect();
    let rate = match crate::study::broad::median(&mut dt) {
        d if d > 0.0 => 1.0 / d,
        _ => 1.0,
    };
    let mut trial = Trial::empty(name, rate, meta.model()?);
    for (k, r) in rows.iter().enumerate() {
        trial.push_row(k, r)?;
    }
    Ok(trial)
}

/// Reads a trial file; its name is the file stem.
pub fn read_trial(path: &Path) -> Result<Trial, StudyError> {
    let bytes = std::fs::read(path).map_err(|e| StudyError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let parsed = if path.extension().is_some_and(|x| x == "csv") {
        std::str::from_utf8(&bytes)
            .map_err(|e| format!("not UTF-8: {e}"))
            .and_then(|text| parse_csv_trial(&name, text))
    } else {
        parse_trial(&name, &bytes)
    };
    parsed
        .map(|mut t| {
            t.set = path
                .parent()
                .and_then(|p| p.file_name())
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            t
        })
        .map_err(|message| StudyError::Format {
            path: path.display().to_string(),
            message,
        })
}

/// The bytes of a trial file (tests; the exporter writes the same with numpy).
pub fn trial_to_bytes(t: &Trial) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 * (3 + COLUMNS * t.samples.len()));
    let mut put = |x: f64| out.extend_from_slice(&x.to_le_bytes());
    put(t.samples.len() as f64);
    put(t.rate_hz);
    put(COLUMNS as f64);
    for (k, s) in t.samples.iter().enumerate() {
        put(s.t_s);
        s.gyr_rad_s.iter().for_each(|x| put(*x));
        s.acc_m_s2.iter().for_each(|x| put(*x));
        s.mag
            .unwrap_or_else(Vector3::zeros)
            .iter()
            .for_each(|x| put(*x));
        match t.truth.get(k).copied().flatten() {
            Some(q) => [q.w, q.x, q.y, q.z].iter().for_each(|x| put(*x)),
            None => (0..4).for_each(|_| put(f64::NAN)),
        }
        put(if t.movement.get(k).copied().unwrap_or(false) {
            1.0
        } else {
            0.0
        });
    }
    if t.truth_model != TruthModel::default() {
        let m = &t.truth_model;
        let meta = TruthMeta {
            align: Some(m.align),
            truth_tilt_sigma_deg: Some(m.tilt_sigma_rad.to_degrees()),
            truth_time_sigma_s: Some(m.time_sigma_s),
            source: None,
        };
        out.extend_from_slice(
            serde_json::to_string(&meta)
                .expect("plain values serialise")
                .as_bytes(),
        );
    }
    out
}

/// What a vehicle of the study runs: the filter configuration and the policy of a service.
#[derive(Clone, Debug)]
pub struct Setup {
    pub filter: VehicleFilterConfig,
    pub policy: Policy,
    /// The vehicle id each trial runs as (it seeds a particle filter): "study" unless told.
    pub vehicle: String,
}

impl Setup {
    /// The default filter of `service`, or `spec` (and `particles`) instead.
    pub fn new(
        service: &ServiceConfig,
        spec: Option<FilterSpec>,
        particles: Option<usize>,
    ) -> Self {
        let mut filter = service.default_filter.clone();
        if let Some(s) = spec {
            filter.filter.spec = s;
        }
        if let Some(n) = particles {
            filter.filter.particles = n;
        }
        Setup {
            filter,
            policy: service.policy.clone(),
            vehicle: "study".to_string(),
        }
    }
}

/// One trial through one vehicle.
#[derive(Clone, Debug)]
pub struct Run {
    /// The estimate published at each sample's time (None where none was).
    pub estimates: Vec<Option<Sample>>,
    pub published: usize,
    pub rejected: BTreeMap<String, u64>,
    pub seconds: f64,
    /// The pipeline's diagnostics at the end.
    pub imu: Option<ImuDiagnosticsMsg>,
    /// Per sample (where an estimate was published): the pipeline's tilt σ_lp (deg), rest and
    /// magnetic disturbance flags, and the gyro bias estimate (rad/s).
    pub series: Vec<Option<SeriesPoint>>,
}

/// The pipeline's state at one sample (for plots and analysis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeriesPoint {
    pub tilt_sigma_lp_deg: f64,
    pub at_rest: bool,
    pub mag_disturbed: bool,
    pub bias: [f64; 3],
}

/// What [`feed_trial`] reports besides the estimates it hands over.
#[derive(Clone, Debug)]
pub struct Fed {
    pub published: usize,
    pub rejected: BTreeMap<String, u64>,
}

/// Feeds every sample of `trial` into a new [`VehicleState`] as `P/V/imu` inputs (the vehicle id
/// seeds a particle filter), then flushes it; every estimate published is handed to `take` with the
/// index of the trial's sample of its time (`None` if no sample has that time); `take` may move out
/// what it keeps (the estimate is dropped after it). This is the loop the study and `imu-bench` share;
/// what they keep of each estimate is theirs.
pub fn feed_trial(
    trial: &Trial,
    setup: &Setup,
    vehicle: &str,
    mut take: impl FnMut(Option<usize>, &mut Published),
) -> Fed {
    let mut state = VehicleState::new(vehicle, setup.filter.clone());
    let mut events = Vec::new();
    let mut fed = Fed {
        published: 0,
        rejected: BTreeMap::new(),
    };
    let mut next = 0usize;
    let mut handle = |events: &mut Vec<Event>, fed: &mut Fed| {
        // (Read in place, then dropped: an event is as large as an estimate, and moving each one out
        // of the vector would copy it.)
        for e in events.iter_mut() {
            match e {
                Event::Estimate(p) => {
                    let t = p.estimate.t_s;
                    fed.published += 1;
                    // Estimates come in time order: find the sample of this time.
                    while next < trial.samples.len() && trial.samples[next].t_s < t - 1e-9 {
                        next += 1;
                    }
                    let at = (next < trial.samples.len()
                        && (trial.samples[next].t_s - t).abs() <= 1e-9)
                        .then_some(next);
                    take(at, p);
                }
                Event::Rejected(_, r) => {
                    *fed.rejected.entry(r.code.as_str().to_string()).or_insert(0) += 1;
                }
                Event::Processed(_) | Event::Gap(..) => {}
            }
        }
        events.clear();
    };
    for s in &trial.samples {
        if let Err(r) = state.on_measurement(Measurement::Imu(*s), 0.0, &setup.policy, &mut events)
        {
            *fed.rejected.entry(r.code.as_str().to_string()).or_insert(0) += 1;
        }
        handle(&mut events, &mut fed);
    }
    state.flush_all(&setup.policy, &mut events);
    handle(&mut events, &mut fed);
    fed
}

/// One trial through one vehicle ([`feed_trial`]), keeping of every estimate what the scores and the
/// series need; timed (the keeping included).
pub fn run_trial(trial: &Trial, setup: &Setup, vehicle: &str) -> Run {
    let start = Instant::now();
    let mut estimates = vec![None; trial.samples.len()];
    let mut series = vec![None; trial.samples.len()];
    // The pipeline's diagnostics of the last estimate.
    let mut imu: Option<ImuDiagnostics> = None;
    let fed = feed_trial(trial, setup, vehicle, |at, p| {
        imu = p.imu.take();
        let Some(k) = at else { return };
        // The published estimate in domain terms (its covariance is the published one, time-stamp
        // term included; the wire's form differs only by the sign of q).
        let e = &p.estimate;
        estimates[k] = Some(Sample {
            q: e.q,
            p_att: e.covariance.fixed_view::<3, 3>(0, 0).into_owned(),
        });
        if let Some(d) = &imu {
            series[k] = Some(SeriesPoint {
                tilt_sigma_lp_deg: d.counts.tilt_sigma_lp_rad.to_degrees(),
                at_rest: d.counts.at_rest,
                mag_disturbed: d.counts.mag_disturbed,
                bias: [e.bias_rad_s[0], e.bias_rad_s[1], e.bias_rad_s[2]],
            });
        }
    });
    Run {
        estimates,
        published: fed.published,
        rejected: fed.rejected,
        // (Converted for the run once, at the end.)
        imu: imu.as_ref().map(ImuDiagnosticsMsg::from),
        series,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Writes a run as CSV, one row per sample: `t, movement, q (w x y z), truth (w x y z), P_att (9),
/// tilt_sigma_lp_deg, at_rest, mag_disturbed, bias (3)` (empty fields where there is none).
pub fn series_csv(trial: &Trial, run: &Run) -> String {
    let mut s = String::from("t,movement,qw,qx,qy,qz,tw,tx,ty,tz,p00,p01,p02,p10,p11,p12,p20,p21,p22,sigma_lp_deg,at_rest,mag_disturbed,bx,by,bz\n");
    for (k, smp) in trial.samples.iter().enumerate() {
        s += &format!("{},{}", smp.t_s, u8::from(trial.movement[k]));
        match &run.estimates[k] {
            Some(e) => {
                s += &format!(",{},{},{},{}", e.q.w, e.q.x, e.q.y, e.q.z);
                match trial.truth[k] {
                    Some(t) => s += &format!(",{},{},{},{}", t.w, t.x, t.y, t.z),
                    None => s += ",,,,",
                }
                for v in e.p_att.transpose().iter() {
                    s += &format!(",{v}");
                }
            }
            None => s += &",".repeat(17),
        }
        match &run.series[k] {
            Some(p) => {
                s += &format!(
                    ",{},{},{},{},{},{}",
                    p.tilt_sigma_lp_deg,
                    u8::from(p.at_rest),
                    u8::from(p.mag_disturbed),
                    p.bias[0],
                    p.bias[1],
                    p.bias[2]
                )
            }
            None => s += &",".repeat(6),
        }
        s.push('\n');
    }
    s
}

/// A trial's result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TrialResult {
    pub trial: String,
    pub filter: String,
    #[serde(flatten)]
    pub scores: Scores,
    pub samples: usize,
    pub published: usize,
    pub rejected: BTreeMap<String, u64>,
    pub samples_per_s: f64,
    pub imu: Option<ImuDiagnosticsMsg>,
}

/// Runs and scores every trial, on all cores (one trial per thread at a time).
pub fn study(trials: &[Trial], setup: &Setup, series_dir: Option<&Path>) -> Vec<TrialResult> {
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(trials.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(vec![None; trials.len()]);
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(trial) = trials.get(i) else { break };
                let run = run_trial(trial, setup, &setup.vehicle);
                if let Some(dir) = series_dir {
                    let path = dir.join(format!("{}.csv", trial.name));
                    if let Err(e) = std::fs::write(&path, series_csv(trial, &run)) {
                        eprintln!("{}: {e}", path.display());
                    }
                }
                let scores = score_with(
                    &run.estimates,
                    &trial.truth,
                    &trial.movement,
                    Some(&trial.rates()),
                    &trial.truth_model,
                );
                let r = TrialResult {
                    trial: trial.name.clone(),
                    filter: setup.filter.filter.spec.to_string(),
                    scores,
                    samples: trial.samples.len(),
                    published: run.published,
                    rejected: run.rejected,
                    samples_per_s: trial.samples.len() as f64 / run.seconds.max(1e-9),
                    imu: run.imu,
                };
                results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(r);
            });
        }
    });
    results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .flatten()
        .collect()
}

/// The trial files named by `paths` (files, or directories whose `*.trial` files are taken, sorted).
pub fn trial_paths(paths: &[PathBuf]) -> Result<Vec<PathBuf>, StudyError> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| StudyError::Io {
                    path: p.display().to_string(),
                    message: e.to_string(),
                })?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "trial" || x == "csv"))
                .collect();
            found.sort();
            out.extend(found);
        } else {
            out.push(p.clone());
        }
    }
    if out.is_empty() {
        return Err(StudyError::Usage(
            "no trial files (export them with scripts/broad-export.py)".into(),
        ));
    }
    Ok(out)
}

/// A configuration file with `--set PATH=JSON` overrides.
pub fn load_config(path: &Path, sets: &[String]) -> Result<ServiceConfig, StudyError> {
    let text = std::fs::read_to_string(path).map_err(|e| StudyError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let overrides = parse_sets(sets)?;
    config::parse_with(&text, &path.display().to_string(), &overrides)
        .map(|f| f.service)
        .map_err(|e| StudyError::Config(e.to_string()))
}

/// `PATH=VALUE` pairs; the value is JSON (`1.5`, `true`, `"mekf"`), or a plain string.
pub fn parse_sets(sets: &[String]) -> Result<Vec<(String, serde_json::Value)>, StudyError> {
    sets.iter()
        .map(|s| {
            let (k, v) = s
                .split_once('=')
                .ok_or_else(|| StudyError::Usage(format!("--set {s}: expected PATH=VALUE")))?;
            let value = serde_json::from_str(v)
                .unwrap_or_else(|_| serde_json::Value::String(v.to_string()));
            Ok((k.trim().to_string(), value))
        })
        .collect()
}

/// A markdown table of results.
pub fn table(results: &[TrialResult]) -> String {
    let mut s = String::from(
        "| trial | filter | total ° | heading ° | incl. ° | tilt in 99% | tilt NEES med. | heading in 99% | 3-axis in 99% | heading offset ° | samples/s |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in results {
        let c = &r.scores;
        s += &format!(
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.3} | {:.2} | {:.3} | {:.3} | {:+.2} | {:.0} |\n",
            r.trial,
            r.filter,
            c.total_rmse_deg,
            c.heading_rmse_deg,
            c.inclination_rmse_deg,
            c.tilt_in99,
            c.tilt_nees_median,
            c.heading_in99,
            c.att_in99,
            c.heading_offset_deg,
            r.samples_per_s
        );
    }
    s
}

// ------------------------------------------------------------------------------------------------
// Tuning by a written procedure: coordinate descent over a grid, and leave-one-out.

/// One tuned parameter: a configuration path and its candidate values.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TuneParameter {
    pub path: String,
    pub values: Vec<f64>,
}

/// What the tuning minimises and over what (`config/imu-tuning.json5`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TuneSpec {
    pub parameters: Vec<TuneParameter>,
    /// Passes of coordinate descent at most (it stops earlier when a pass changes nothing).
    pub passes: usize,
    /// Honesty penalties: per trial, `tilt_weight · max(0, tilt_in99_min − tilt_in99)` and
    /// `nees_weight · max(0, nees_min − median NEES)`.
    pub tilt_in99_min: f64,
    pub tilt_weight: f64,
    pub nees_min: f64,
    pub nees_weight: f64,
    /// The same for the 3-axis error: `att_weight · max(0, att_in99_min − att_in99)`.
    #[serde(default)]
    pub att_in99_min: f64,
    #[serde(default)]
    pub att_weight: f64,
    /// Optional: a peer's RMSEs on the same trials (`{"TRIAL": {"total_rmse_deg": .., "inclination_rmse_deg":
    /// ..}}`, a path relative to the specification) and the weight of a trial's loss against it:
    /// `reference_weight · (max(0, ln(total/peer)) + max(0, ln(incl./peer)))` (the targets are per trial).
    #[serde(default)]
    pub reference: Option<String>,
    #[serde(default)]
    pub reference_weight: f64,
    /// The reference's figures by trial (read by the command, not written in the specification).
    #[serde(skip)]
    pub reference_scores: BTreeMap<String, (f64, f64)>,
}

/// The objective over the trials `which` (indices into `scores`): the mean of
/// `ln(total RMSE) + ln(inclination RMSE)` (the log of the geometric means, so every trial counts
/// by its ratio, not its size) plus the mean honesty penalty.
pub fn objective(spec: &TuneSpec, trials: &[Trial], scores: &[Scores], which: &[usize]) -> f64 {
    // Every set weighs alike, and every trial alike within its set.
    let mut per_set: BTreeMap<&str, usize> = BTreeMap::new();
    for &i in which {
        *per_set.entry(trials[i].set.as_str()).or_insert(0) += 1;
    }
    let mut sum = 0.0;
    for &i in which {
        let s = &scores[i];
        let weight = 1.0 / (per_set.len() * per_set[trials[i].set.as_str()]) as f64;
        let accuracy = s.total_rmse_deg.ln() + s.inclination_rmse_deg.ln();
        let mut penalty = spec.tilt_weight * (spec.tilt_in99_min - s.tilt_in99).max(0.0)
            + spec.nees_weight * (spec.nees_min - s.tilt_nees_median).max(0.0)
            + spec.att_weight * (spec.att_in99_min - s.att_in99).max(0.0);
        if let Some((total, incl)) = spec.reference_scores.get(&trials[i].name) {
            penalty += spec.reference_weight
                * ((s.total_rmse_deg / total).ln().max(0.0)
                    + (s.inclination_rmse_deg / incl).ln().max(0.0));
        }
        let v = accuracy + penalty;
        sum += weight * if v.is_finite() { v } else { 1e6 };
    }
    sum
}

/// Evaluations of parameter points, remembered (folds of a leave-one-out share most of them).
pub struct Tuner<'a> {
    text: String,
    origin: String,
    base_sets: Vec<(String, serde_json::Value)>,
    spec: &'a TuneSpec,
    trials: &'a [Trial],
    filter: Option<FilterSpec>,
    memo: BTreeMap<Vec<u64>, Vec<Scores>>,
    pub evaluations: usize,
}

impl<'a> Tuner<'a> {
    pub fn new(
        config: &Path,
        sets: &[String],
        spec: &'a TuneSpec,
        trials: &'a [Trial],
        filter: Option<FilterSpec>,
    ) -> Result<Self, StudyError> {
        let text = std::fs::read_to_string(config).map_err(|e| StudyError::Io {
            path: config.display().to_string(),
            message: e.to_string(),
        })?;
        Ok(Tuner {
            text,
            origin: config.display().to_string(),
            base_sets: parse_sets(sets)?,
            spec,
            trials,
            filter,
            memo: BTreeMap::new(),
            evaluations: 0,
        })
    }

    /// The configuration overrides of a point (index per parameter).
    pub fn overrides(&self, point: &[usize]) -> Vec<(String, serde_json::Value)> {
        let mut o = self.base_sets.clone();
        for (p, &k) in self.spec.parameters.iter().zip(point) {
            o.push((p.path.clone(), serde_json::json!(p.values[k])));
        }
        o
    }

    /// Every trial's scores at `point`.
    pub fn scores(&mut self, point: &[usize]) -> Result<Vec<Scores>, StudyError> {
        let key: Vec<u64> = point.iter().map(|&k| k as u64).collect();
        if let Some(s) = self.memo.get(&key) {
            return Ok(s.clone());
        }
        let service = config::parse_with(&self.text, &self.origin, &self.overrides(point))
            .map_err(|e| StudyError::Config(e.to_string()))?
            .service;
        let setup = Setup::new(&service, self.filter, None);
        let scores: Vec<Scores> = study(self.trials, &setup, None)
            .into_iter()
            .map(|r| r.scores)
            .collect();
        self.evaluations += 1;
        self.memo.insert(key, scores.clone());
        Ok(scores)
    }

    /// Coordinate descent from `start` over the trials `which`: each parameter in turn takes its best
    /// value with the others held, until a pass changes nothing (or `passes`). Ties keep the current
    /// value, so the result does not depend on the order of equal candidates.
    pub fn descend(&mut self, start: &[usize], which: &[usize]) -> Result<Vec<usize>, StudyError> {
        let mut point = start.to_vec();
        let mut best = objective(self.spec, self.trials, &self.scores(&point)?, which);
        for _ in 0..self.spec.passes.max(1) {
            let mut changed = false;
            for p in 0..point.len() {
                for k in 0..self.spec.parameters[p].values.len() {
                    if k == point[p] {
                        continue;
                    }
                    let mut candidate = point.clone();
                    candidate[p] = k;
                    let v = objective(self.spec, self.trials, &self.scores(&candidate)?, which);
                    if v < best - 1e-12 {
                        best = v;
                        point = candidate;
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        Ok(point)
    }
}

/// The configuration file at `path` as the service reads it: its `extends` chain resolved and laid
/// over the built-in defaults (`config/default.json5`), so an option the file does not state has the
/// value it takes (a preset states only what it changes).
pub fn effective_config(path: &Path) -> Result<serde_json::Value, StudyError> {
    let text = std::fs::read_to_string(path).map_err(|e| StudyError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let invalid = |e: config::ConfigError| StudyError::Config(e.to_string());
    let file = config::resolve(&text, &path.display().to_string()).map_err(invalid)?;
    let defaults =
        config::resolve(DEFAULT_CONFIG, "built-in default configuration").map_err(invalid)?;
    Ok(extends::merge(defaults, file))
}

/// The start of the descent: for each parameter, the candidate nearest to the value the
/// configuration gives it (`config`: the file with its `extends` resolved, laid over the built-in
/// defaults, [`effective_config`]), else the first.
pub fn start_point(spec: &TuneSpec, config: &serde_json::Value) -> Vec<usize> {
    spec.parameters
        .iter()
        .map(|p| {
            let mut at = config;
            for key in p.path.split('.') {
                at = &at[key];
            }
            match at.as_f64() {
                Some(v) => p
                    .values
                    .iter()
                    .enumerate()
                    .min_by(|a, b| (a.1 - v).abs().total_cmp(&(b.1 - v).abs()))
                    .map_or(0, |(k, _)| k),
                None => 0,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trial file of `rows` samples at 100 Hz (every column 0 but the accelerometer's z and the
    /// truth's w).
    fn trial_bytes(rows: usize, cols: f64) -> Vec<u8> {
        let mut v = vec![rows as f64, 100.0, cols];
        for k in 0..rows {
            let mut r = [0.0; COLUMNS];
            r[0] = k as f64 * 0.01;
            r[6] = 9.81;
            r[10] = 1.0;
            v.extend(r);
        }
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn a_trial_file_is_read_and_other_files_are_named_for_what_they_are() {
        let t = parse_trial("t", &trial_bytes(3, COLUMNS as f64)).expect("a trial file");
        assert_eq!((t.samples.len(), t.rate_hz), (3, 100.0));
        // An HDF5 file (BROAD's): what it is and how to convert it, not a column count read from
        // its signature.
        let mut h5 = HDF5_SIGNATURE.to_vec();
        h5.extend([0u8; 64]);
        let e = parse_trial("h", &h5).unwrap_err();
        assert!(
            e.starts_with("it is an HDF5 file") && e.contains("broad-export.py"),
            "{e}"
        );
        // Anything else with a wrong header: said in a number one can read.
        let e = parse_trial("x", &trial_bytes(3, 14.0)).unwrap_err();
        assert!(e.contains("column count reads 1.4e1, expected 15"), "{e}");
        let e = parse_trial(
            "x",
            b"t,gx,gy,gz,ax,ay,az,mx,my,mz,qw,qx,qy,qz,movement\n0,0",
        )
        .unwrap_err();
        assert!(
            e.starts_with("not a trial file") && !e.contains("0.0000"),
            "{e}"
        );
    }
}
