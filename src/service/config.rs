//! Service configuration: a JSON5 file with a `zenoh` section (passed to zenoh as is) and a `service`
//! section, parsed in two stages: raw (`deny_unknown_fields`, named defaults), then validated into
//! [`ServiceConfig`]. `config/default.json5` documents every option; a test loads it.

use crate::attitude::Grp;
use crate::filters::{
    Fiducial, FilterConfig, FilterKind, FilterSpec, Kernel, QpfOptions, UsqueOptions,
};
use crate::sensors::GyroNoise;
use crate::wire::{validate_vehicle_id, InputLimits};
use nalgebra::Vector3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum ConfigError {
    #[error("cannot read {path}: {message}")]
    Read { path: String, message: String },
    #[error("{path}: not valid JSON5: {message}")]
    Syntax { path: String, message: String },
    #[error("{path}: {message}")]
    Invalid { path: String, message: String },
}

const DEG_PER_HR: f64 = std::f64::consts::PI / 180.0 / 3600.0;

// ------------------------------------------------------------------------------------------------
// Raw: what the file says.

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawFile {
    #[serde(default)]
    zenoh: Option<serde_json::Value>,
    #[serde(default)]
    service: RawService,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawService {
    key_prefix: String,
    filter: RawFilter,
    vehicles: BTreeMap<String, RawFilterOverride>,
    limits: RawLimits,
    workers: usize,
}

impl Default for RawService {
    fn default() -> Self {
        RawService {
            key_prefix: "attitude".into(),
            filter: RawFilter::default(),
            vehicles: BTreeMap::new(),
            limits: RawLimits::default(),
            workers: 0,
        }
    }
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
struct RawFilter {
    kind: String,
    fiducial: String,
    particles: usize,
    gyro_arw_rad_sqrt_s: f64,
    gyro_rrw_rad_s_sqrt_s: f64,
    init: String,
    init_bias_sigma_deg_hr: f64,
    qpf: RawQpf,
    usque: RawUsque,
}

impl Default for RawFilter {
    fn default() -> Self {
        let g = GyroNoise::standard();
        RawFilter {
            kind: "qpf".into(),
            fiducial: "average".into(),
            particles: 1000,
            gyro_arw_rad_sqrt_s: g.sigma_v,
            gyro_rrw_rad_s_sqrt_s: g.sigma_u,
            init: "vectors".into(),
            init_bias_sigma_deg_hr: 10.0,
            qpf: RawQpf::default(),
            usque: RawUsque::default(),
        }
    }
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
struct RawQpf {
    kernel: String,
    bandwidth_scale: f64,
    resample_fraction: f64,
    pc_spread: f64,
    pc_max_stages: u32,
    inflation: f64,
}

impl Default for RawQpf {
    fn default() -> Self {
        let o = QpfOptions::default();
        RawQpf {
            kernel: "gaussian".into(),
            bandwidth_scale: o.bandwidth_scale,
            resample_fraction: o.resample_fraction,
            pc_spread: o.pc_spread,
            pc_max_stages: o.pc_max_stages,
            inflation: o.inflation,
        }
    }
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
struct RawUsque {
    a: f64,
    f: f64,
    lambda: f64,
}

impl Default for RawUsque {
    fn default() -> Self {
        RawUsque {
            a: 1.0,
            f: 4.0,
            lambda: 1.0,
        }
    }
}

/// A per-vehicle override: any field of `filter`, the rest inherited.
#[derive(Debug, Deserialize, Default, Clone)]
#[serde(deny_unknown_fields)]
struct RawFilterOverride {
    kind: Option<String>,
    fiducial: Option<String>,
    particles: Option<usize>,
    gyro_arw_rad_sqrt_s: Option<f64>,
    gyro_rrw_rad_s_sqrt_s: Option<f64>,
    init: Option<String>,
    init_bias_sigma_deg_hr: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawLimits {
    max_vehicles: usize,
    queue_per_vehicle: usize,
    max_payload_bytes: usize,
    max_batch: usize,
    max_observations: usize,
}

impl Default for RawLimits {
    fn default() -> Self {
        let l = InputLimits::default();
        RawLimits {
            max_vehicles: 10_000,
            queue_per_vehicle: 4096,
            max_payload_bytes: l.max_payload_bytes,
            max_batch: l.max_batch,
            max_observations: l.max_observations,
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Validated.

/// How a vehicle's filter starts when no attitude is given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InitMode {
    /// From the first vector-observation set with two or more non-parallel vectors (q-method).
    Vectors,
    /// A particle filter starts from a uniformly random attitude at the first measurement.
    Uniform,
}

/// Everything needed to create one vehicle's filter.
#[derive(Clone, Debug, PartialEq)]
pub struct VehicleFilterConfig {
    pub filter: FilterConfig,
    pub init: InitMode,
    /// 1σ of the initial bias, rad/s.
    pub init_bias_sigma_rad_s: Vector3<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    pub max_vehicles: usize,
    pub queue_per_vehicle: usize,
    pub input: InputLimits,
}

/// The validated `service` section.
#[derive(Clone, Debug, PartialEq)]
pub struct ServiceConfig {
    /// Key prefix `P` (one or more chunks, no wildcards).
    pub key_prefix: String,
    pub default_filter: VehicleFilterConfig,
    pub overrides: BTreeMap<String, VehicleFilterConfig>,
    pub limits: Limits,
    /// Filter worker threads (the machine's cores when 0 in the file).
    pub workers: usize,
}

impl ServiceConfig {
    /// The filter configuration of one vehicle.
    pub fn filter_for(&self, vehicle: &str) -> &VehicleFilterConfig {
        self.overrides.get(vehicle).unwrap_or(&self.default_filter)
    }
}

impl Default for ServiceConfig {
    fn default() -> Self {
        validate_service(RawService::default()).expect("the built-in defaults are valid")
    }
}

/// A whole configuration file: the zenoh section as JSON (for `zenoh::Config::from_json5`) and the
/// validated service section.
#[derive(Clone, Debug)]
pub struct FileConfig {
    pub zenoh_json: String,
    pub service: ServiceConfig,
}

/// The zenoh configuration used when the file has none: an embedded peer on `tcp/127.0.0.1:7447` with
/// multicast scouting off, so nothing else has to run.
pub const DEFAULT_ZENOH_JSON: &str = r#"{"mode": "peer", "listen": {"endpoints": ["tcp/127.0.0.1:7447"]}, "scouting": {"multicast": {"enabled": false}}}"#;

pub fn load(path: &Path) -> Result<FileConfig, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Read {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    parse(&text, &path.display().to_string())
}

/// Parses a configuration text (`origin` names it in errors).
pub fn parse(text: &str, origin: &str) -> Result<FileConfig, ConfigError> {
    let value: serde_json::Value = json5::from_str(text).map_err(|e| ConfigError::Syntax {
        path: origin.to_string(),
        message: e.to_string(),
    })?;
    let invalid = |message: String| ConfigError::Invalid {
        path: origin.to_string(),
        message,
    };
    let raw: RawFile = serde_json::from_value(value).map_err(|e| invalid(e.to_string()))?;
    let zenoh_json = match raw.zenoh {
        None => DEFAULT_ZENOH_JSON.to_string(),
        Some(v @ serde_json::Value::Object(_)) => v.to_string(),
        Some(_) => return Err(invalid("`zenoh` must be an object".into())),
    };
    let service = validate_service(raw.service).map_err(invalid)?;
    Ok(FileConfig {
        zenoh_json,
        service,
    })
}

/// Key prefixes are one or more `/`-separated chunks without wildcards or `@` chunks.
pub fn validate_key_prefix(p: &str) -> Result<(), String> {
    let bad = p.is_empty()
        || p.split('/')
            .any(|c| c.is_empty() || c.starts_with('@') || c.contains(['*', '$', '?', '#']));
    if bad {
        Err(format!(
            "key_prefix '{p}' must be one or more non-empty '/'-separated chunks without '*', '$', '?', '#' or a leading '@'"
        ))
    } else {
        Ok(())
    }
}

fn validate_filter(raw: &RawFilter, at: &str) -> Result<VehicleFilterConfig, String> {
    let kind = match raw.kind.as_str() {
        "mekf" => FilterKind::Mekf,
        "usque" => FilterKind::Usque,
        "qpf" => FilterKind::Qpf,
        other => {
            return Err(format!(
                "{at}.kind: unknown filter '{other}' (mekf, usque, qpf)"
            ))
        }
    };
    let fiducial = match (kind, raw.fiducial.as_str()) {
        (FilterKind::Mekf, _) => None,
        (_, "average") => Some(Fiducial::Average),
        (_, "propagated") => Some(Fiducial::Propagated),
        (_, other) => {
            return Err(format!("{at}.fiducial: '{other}' (average, propagated)"));
        }
    };
    let positive = |v: f64, name: &str| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(format!("{at}.{name} must be positive, got {v}"))
        }
    };
    let gyro = GyroNoise {
        sigma_v: positive(raw.gyro_arw_rad_sqrt_s, "gyro_arw_rad_sqrt_s")?,
        sigma_u: positive(raw.gyro_rrw_rad_s_sqrt_s, "gyro_rrw_rad_s_sqrt_s")?,
    };
    if raw.particles < 2 || raw.particles > 1_000_000 {
        return Err(format!(
            "{at}.particles must be in 2..=1000000, got {}",
            raw.particles
        ));
    }
    let init = match raw.init.as_str() {
        "vectors" => InitMode::Vectors,
        "uniform" if kind == FilterKind::Qpf => InitMode::Uniform,
        "uniform" => {
            return Err(format!(
                "{at}.init: 'uniform' needs the particle filter (kind qpf)"
            ))
        }
        other => return Err(format!("{at}.init: '{other}' (vectors, uniform)")),
    };
    let bias_sigma = positive(raw.init_bias_sigma_deg_hr, "init_bias_sigma_deg_hr")? * DEG_PER_HR;
    let q = &raw.qpf;
    let qpf = QpfOptions {
        kernel: match q.kernel.as_str() {
            "gaussian" => Kernel::Gaussian,
            "epanechnikov" => Kernel::Epanechnikov,
            other => {
                return Err(format!(
                    "{at}.qpf.kernel: '{other}' (gaussian, epanechnikov)"
                ))
            }
        },
        bandwidth_scale: positive(q.bandwidth_scale, "qpf.bandwidth_scale")?,
        resample_fraction: q.resample_fraction,
        pc_spread: positive(q.pc_spread, "qpf.pc_spread")?,
        pc_max_stages: q.pc_max_stages,
        inflation: q.inflation,
    };
    if !(qpf.resample_fraction > 0.0 && qpf.resample_fraction <= 1.0) {
        return Err(format!("{at}.qpf.resample_fraction must be in (0, 1]"));
    }
    if qpf.pc_max_stages == 0 {
        return Err(format!("{at}.qpf.pc_max_stages must be at least 1"));
    }
    if !(qpf.inflation >= 0.0 && qpf.inflation < 1.0) {
        return Err(format!("{at}.qpf.inflation must be in [0, 1)"));
    }
    let u = &raw.usque;
    if !(u.a >= 0.0
        && u.f > 0.0
        && u.lambda > 0.0
        && u.a.is_finite()
        && u.f.is_finite()
        && u.lambda.is_finite())
    {
        return Err(format!("{at}.usque: need a ≥ 0, f > 0, lambda > 0"));
    }
    let mut filter = FilterConfig::new(FilterSpec { kind, fiducial }, gyro);
    filter.particles = raw.particles;
    filter.qpf = qpf;
    filter.usque = UsqueOptions {
        grp: Grp::new(u.a, u.f),
        lambda: u.lambda,
    };
    Ok(VehicleFilterConfig {
        filter,
        init,
        init_bias_sigma_rad_s: Vector3::repeat(bias_sigma),
    })
}

fn validate_service(raw: RawService) -> Result<ServiceConfig, String> {
    validate_key_prefix(&raw.key_prefix).map_err(|e| format!("service.{e}"))?;
    let default_filter = validate_filter(&raw.filter, "service.filter")?;
    let mut overrides = BTreeMap::new();
    for (vehicle, o) in &raw.vehicles {
        validate_vehicle_id(vehicle).map_err(|e| format!("service.vehicles: {}", e.message))?;
        let mut f = raw.filter.clone();
        if let Some(v) = &o.kind {
            f.kind = v.clone();
        }
        if let Some(v) = &o.fiducial {
            f.fiducial = v.clone();
        }
        if let Some(v) = o.particles {
            f.particles = v;
        }
        if let Some(v) = o.gyro_arw_rad_sqrt_s {
            f.gyro_arw_rad_sqrt_s = v;
        }
        if let Some(v) = o.gyro_rrw_rad_s_sqrt_s {
            f.gyro_rrw_rad_s_sqrt_s = v;
        }
        if let Some(v) = &o.init {
            f.init = v.clone();
        }
        if let Some(v) = o.init_bias_sigma_deg_hr {
            f.init_bias_sigma_deg_hr = v;
        }
        overrides.insert(
            vehicle.clone(),
            validate_filter(&f, &format!("service.vehicles.{vehicle}"))?,
        );
    }
    let l = &raw.limits;
    for (v, name) in [
        (l.max_vehicles, "max_vehicles"),
        (l.queue_per_vehicle, "queue_per_vehicle"),
        (l.max_payload_bytes, "max_payload_bytes"),
        (l.max_batch, "max_batch"),
        (l.max_observations, "max_observations"),
    ] {
        if v == 0 {
            return Err(format!("service.limits.{name} must be at least 1"));
        }
    }
    let workers = if raw.workers == 0 {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    } else {
        raw.workers
    };
    Ok(ServiceConfig {
        key_prefix: raw.key_prefix,
        default_filter,
        overrides,
        limits: Limits {
            max_vehicles: l.max_vehicles,
            queue_per_vehicle: l.queue_per_vehicle,
            input: InputLimits {
                max_payload_bytes: l.max_payload_bytes,
                max_batch: l.max_batch,
                max_observations: l.max_observations,
            },
        },
        workers,
    })
}
