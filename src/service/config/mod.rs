//! Service configuration: a JSON5 file with a `zenoh` section (passed to zenoh as is) and a `service`
//! section, parsed in two stages: raw (`deny_unknown_fields`, named defaults), then validated into
//! [`ServiceConfig`]. `config/default.json5` documents every option; a test loads it.

pub mod extends;
mod raw;

use crate::ahrs::{AhrsConfig, SensorSheet};
use crate::attitude::Grp;
use crate::filters::{
    Fiducial, FilterConfig, FilterKind, FilterSpec, GapModel, GyroErrors, Kernel, QpfOptions,
    UsqueOptions,
};
use crate::fleet::{default_instance_name, parse_routes, routes_text, FleetConfig, FleetMode};
use crate::sensors::GyroNoise;
use crate::stats::chi_square_quantile;
pub use crate::vehicle::policy::{InitMode, Policy, VehicleFilterConfig};
use crate::wire::keys::{Keys, Leaf};
use crate::wire::{validate_vehicle_id, InputLimits};
use nalgebra::Vector3;
use raw::*;
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
// Validated. (The vehicle's own: `vehicle::policy`.)

#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    pub max_vehicles: usize,
    pub queue_per_vehicle: usize,
    pub input: InputLimits,
    /// Distinct sensor names counted per vehicle; further names are counted as `other`.
    pub max_sensors_per_vehicle: usize,
}

/// Checkpoints of every vehicle's complete state.
#[derive(Clone, Debug, PartialEq)]
pub struct Persistence {
    /// Directory of the checkpoint files; `None` = no persistence.
    pub state_dir: Option<std::path::PathBuf>,
    pub checkpoint_interval_s: f64,
}

/// `P/@/metrics`.
#[derive(Clone, Debug, PartialEq)]
pub struct MetricsConfig {
    /// Vehicles with series of their own (the first by id); 0: none. Bounds the series count.
    pub max_vehicles: usize,
}

impl Default for MetricsConfig {
    fn default() -> Self {
        MetricsConfig { max_vehicles: 1000 }
    }
}

/// `service.ingest`: how inputs get from zenoh to the dispatcher (`service::ingest`, proto/README.md,
/// "Loss, recovery and back-pressure").
#[derive(Clone, Debug, PartialEq)]
pub struct IngestConfig {
    /// The input keys are subscribed by zenoh-ext AdvancedSubscribers: sample-miss detection and
    /// recovery from advanced publishers' caches, and their history when a publisher (re)appears.
    /// `false`: plain subscribers only.
    pub recovery: bool,
    /// The longest a recovery query may hold back a publisher's later samples, s (zenoh-ext's
    /// `query_timeout`, 10 s unless set).
    pub query_timeout_s: f64,
    /// Most samples asked of each publisher's cache when the service starts or a publisher
    /// (re)appears, and most of its samples held meanwhile; 0: no history.
    pub history_samples: usize,
    /// Most bytes of one vehicle's inputs between the subscribers and the dispatcher.
    pub pending_bytes_per_vehicle: usize,
    /// Most bytes of all inputs between the subscribers and the dispatcher.
    pub pending_bytes: usize,
    /// How long a plain publisher's input may wait for room before it is refused, s (the wait holds
    /// zenoh's receiving thread: back-pressure to the sender).
    pub wait_s: f64,
}

impl Default for IngestConfig {
    fn default() -> Self {
        IngestConfig {
            recovery: true,
            query_timeout_s: 1.0,
            history_samples: 1000,
            pending_bytes_per_vehicle: 8 << 20,
            pending_bytes: 256 << 20,
            wait_s: 0.5,
        }
    }
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
    pub policy: Policy,
    pub persistence: Persistence,
    pub fleet: FleetConfig,
    pub metrics: MetricsConfig,
    pub ingest: IngestConfig,
    /// The ROS 2 edge (off unless enabled).
    pub ros2: crate::ros2::Ros2Config,
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

/// Parses a configuration text (`origin` names it in errors, and is the file whose directory a
/// top-level `extends` is relative to: see [`extends`]).
pub fn parse(text: &str, origin: &str) -> Result<FileConfig, ConfigError> {
    parse_with(text, origin, &[])
}

/// A configuration text as its values, before any check: the JSON5 parsed and its `extends` chain
/// (config/README.md) resolved, the base files under this one's values.
pub fn resolve(text: &str, origin: &str) -> Result<serde_json::Value, ConfigError> {
    let value: serde_json::Value = json5::from_str(text).map_err(|e| ConfigError::Syntax {
        path: origin.to_string(),
        message: e.to_string(),
    })?;
    extends::resolve(value, origin, &extends::read_file).map_err(|message| ConfigError::Invalid {
        path: origin.to_string(),
        message,
    })
}

/// [`parse`] with values replaced before validation: `("service.imu.acc.sigma_rad", 0.004)` sets that
/// field (creating the objects on its path), as if the file said so (studies and tuning).
pub fn parse_with(
    text: &str,
    origin: &str,
    overrides: &[(String, serde_json::Value)],
) -> Result<FileConfig, ConfigError> {
    let invalid = |message: String| ConfigError::Invalid {
        path: origin.to_string(),
        message,
    };
    let mut value = resolve(text, origin)?;
    for (path, v) in overrides {
        let mut at = &mut value;
        for key in path.split('.') {
            let serde_json::Value::Object(map) = at else {
                return Err(invalid(format!(
                    "override {path}: {key} is not in an object"
                )));
            };
            at = map
                .entry(key.to_string())
                .or_insert_with(|| serde_json::Value::Object(Default::default()));
        }
        *at = v.clone();
    }
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
    let kind: FilterKind = raw.kind.parse().map_err(|_| {
        format!(
            "{at}.kind: unknown filter '{}' (mekf, usque, qpf)",
            raw.kind
        )
    })?;
    // (The MEKF has no fiducial: the configured one is ignored, the default "average" included.)
    let fiducial = match kind {
        FilterKind::Mekf => None,
        _ => Some(
            raw.fiducial
                .parse::<Fiducial>()
                .map_err(|_| format!("{at}.fiducial: '{}' (average, propagated)", raw.fiducial))?,
        ),
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
    let levels = crate::filters::sghqf::LEVELS;
    if !(*levels.start() as u64..=*levels.end() as u64).contains(&raw.level) {
        return Err(format!(
            "{at}.level must be in {}..={}, got {}",
            levels.start(),
            levels.end(),
            raw.level
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
    filter.level = raw.level as u8;
    filter.qpf = qpf;
    filter.usque = UsqueOptions {
        grp: Grp::new(u.a, u.f),
        lambda: u.lambda,
    };
    filter.gyro_errors = GyroErrors {
        rate_noise_sqrt_s: raw.gyro_rate_noise_sqrt_s,
        bias_limit_rad_s: raw
            .gyro_bias_limit_deg_s
            .map_or(f64::INFINITY, f64::to_radians),
    };
    filter
        .gyro_errors
        .validate()
        .map_err(|e| format!("{at}: {e} (gyro_rate_noise_sqrt_s, gyro_bias_limit_deg_s)"))?;
    let g = &raw.gap;
    if !(g.after_s > 0.0 && g.accel_sigma_rad_s2 >= 0.0 && g.accel_sigma_rad_s2.is_finite()) {
        return Err(format!(
            "{at}.gap: need after_s > 0 and a finite accel_sigma_rad_s2 >= 0"
        ));
    }
    filter.gap = GapModel {
        after_s: g.after_s,
        accel_sigma_rad_s2: g.accel_sigma_rad_s2,
    };
    Ok(VehicleFilterConfig {
        filter,
        init,
        init_bias_sigma_rad_s: Vector3::repeat(bias_sigma),
        sensor: SensorSheet::default(),
    })
}

fn validate_service(raw: RawService) -> Result<ServiceConfig, String> {
    validate_key_prefix(&raw.key_prefix).map_err(|e| format!("service.{e}"))?;
    let mut default_filter = validate_filter(&raw.filter, "service.filter")?;
    raw.imu
        .sensor
        .validate()
        .map_err(|e| format!("service.imu.{e}"))?;
    default_filter.sensor = raw.imu.sensor.clone();
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
        if let Some(v) = o.level {
            f.level = v;
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
        if let Some(v) = o.gyro_rate_noise_sqrt_s {
            f.gyro_rate_noise_sqrt_s = v;
        }
        if o.gyro_bias_limit_deg_s.is_some() {
            f.gyro_bias_limit_deg_s = o.gyro_bias_limit_deg_s;
        }
        let at = format!("service.vehicles.{vehicle}");
        let mut config = validate_filter(&f, &at)?;
        if let Some(s) = &o.sensor {
            s.validate().map_err(|e| format!("{at}.{e}"))?;
        }
        // The vehicle's datasheet values, the service's where it gives none.
        config.sensor = o
            .sensor
            .as_ref()
            .map_or_else(|| raw.imu.sensor.clone(), |s| s.or(&raw.imu.sensor));
        overrides.insert(vehicle.clone(), config);
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
    if !(l.max_rate_rad_s > 0.0 && l.max_rate_rad_s.is_finite()) {
        return Err("service.limits.max_rate_rad_s must be positive".into());
    }
    if l.max_sensors_per_vehicle == 0 {
        return Err("service.limits.max_sensors_per_vehicle must be at least 1".into());
    }
    let t = &raw.time;
    if !(t.reorder_window_s >= 0.0 && t.reorder_window_s <= 60.0) {
        return Err("service.time.reorder_window_s must be in [0, 60]".into());
    }
    if !(t.max_jump_s > 0.0) {
        return Err("service.time.max_jump_s must be positive".into());
    }
    if !(t.max_lag_s >= 0.0 && t.max_lag_s <= 3600.0) {
        return Err("service.time.max_lag_s must be in [0, 3600]".into());
    }
    let threshold = |p: f64, at: &str| -> Result<Option<f64>, String> {
        if p == 0.0 {
            Ok(None)
        } else if let Some(x) = chi_square_quantile(3.0, p) {
            Ok(Some(x))
        } else {
            Err(format!("{at} must be 0 (off) or in (0, 1), got {p}"))
        }
    };
    let mut sensor_gate = BTreeMap::new();
    let mut sensor_models = BTreeMap::new();
    for (name, s) in &raw.sensors {
        if let Some(m) = sensor_model(name, s)? {
            sensor_models.insert(name.clone(), m);
        }
        if let Some(p) = s.gate_probability {
            sensor_gate.insert(
                name.clone(),
                threshold(p, &format!("service.sensors.{name}.gate_probability"))?,
            );
        }
    }
    let h = &raw.health;
    if !(h.reinit_sigma_factor >= 1.0 && h.reinit_sigma_factor.is_finite()) {
        return Err("service.health.reinit_sigma_factor must be at least 1".into());
    }
    let pz = &raw.persistence;
    if !(pz.checkpoint_interval_s > 0.0 && pz.checkpoint_interval_s.is_finite()) {
        return Err("service.persistence.checkpoint_interval_s must be positive".into());
    }
    let imu = AhrsConfig {
        timing_sigma_s: raw.imu.timing_sigma_s,
        init: raw.imu.init.clone(),
        gyro: raw.imu.gyro.clone(),
        rest: raw.imu.rest.clone(),
        acc: raw.imu.acc.clone(),
        mag: raw.imu.mag.clone(),
        recovery: raw.imu.recovery.clone(),
    };
    imu.validate().map_err(|e| format!("service.imu.{e}"))?;
    let rate = raw.imu.max_estimate_rate_hz;
    if !(rate >= 0.0 && rate.is_finite()) {
        return Err(format!(
            "service.imu.max_estimate_rate_hz must be 0 (every sample) or positive, got {rate}"
        ));
    }
    let policy = Policy {
        imu,
        imu_estimate_interval_s: if rate > 0.0 { 1.0 / rate } else { 0.0 },
        reorder_window_s: t.reorder_window_s,
        max_jump_s: t.max_jump_s,
        max_lag_s: t.max_lag_s,
        history_bytes: t.history_bytes,
        gate_threshold: threshold(raw.gate.probability, "service.gate.probability")?,
        sensor_gate,
        sensor_models,
        gate_reinit_after: raw.gate.reinit_after,
        reinit_after_failures: h.reinit_after_failures.max(1),
        reinit_sigma_factor: h.reinit_sigma_factor,
        max_sensors_per_vehicle: l.max_sensors_per_vehicle,
        max_rate_rad_s: l.max_rate_rad_s,
    };
    let persistence = Persistence {
        state_dir: pz.state_dir.as_ref().map(std::path::PathBuf::from),
        checkpoint_interval_s: pz.checkpoint_interval_s,
    };
    let workers = if raw.workers == 0 {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    } else {
        raw.workers
    };
    let fleet = validate_fleet(&raw.key_prefix, raw.fleet)?;
    let ingest = validate_ingest(&raw.ingest, raw.limits.max_payload_bytes)?;
    let ros2 = crate::ros2::config::validate(raw.ros2)?;
    if ros2.enabled {
        ros2_keys_apart(&raw.key_prefix, &ros2)?;
    }
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
                max_rate_rad_s: l.max_rate_rad_s,
            },
            max_sensors_per_vehicle: l.max_sensors_per_vehicle,
        },
        workers,
        policy,
        persistence,
        fleet,
        metrics: MetricsConfig {
            max_vehicles: raw.metrics.max_vehicles,
        },
        ingest,
        ros2,
    })
}

fn validate_ingest(i: &RawIngest, max_payload: usize) -> Result<IngestConfig, String> {
    // (A recovery that holds a publisher back longer than a sender's `Block` waits (5 s) or the
    // zenoh lease (10 s) would close links; the history's samples are held in memory per publisher.)
    if !(i.query_timeout_s > 0.0 && i.query_timeout_s <= 60.0) {
        return Err("service.ingest.query_timeout_s must be in (0, 60]".into());
    }
    if i.history_samples > 1_000_000 {
        return Err("service.ingest.history_samples must be at most 1000000".into());
    }
    // (At least one largest payload, or such a payload could never be taken.)
    if i.pending_bytes_per_vehicle < max_payload {
        return Err(format!(
            "service.ingest.pending_bytes_per_vehicle must be at least service.limits.max_payload_bytes ({max_payload})"
        ));
    }
    if i.pending_bytes < i.pending_bytes_per_vehicle {
        return Err(
            "service.ingest.pending_bytes must be at least service.ingest.pending_bytes_per_vehicle".into(),
        );
    }
    if !(i.wait_s >= 0.0 && i.wait_s <= 2.0) {
        return Err("service.ingest.wait_s must be in [0, 2] (a longer wait risks the senders' links: zenoh closes a link whose Block put waits 5 s)".into());
    }
    Ok(IngestConfig {
        recovery: i.recovery,
        query_timeout_s: i.query_timeout_s,
        history_samples: i.history_samples,
        pending_bytes_per_vehicle: i.pending_bytes_per_vehicle,
        pending_bytes: i.pending_bytes,
        wait_s: i.wait_s,
    })
}

/// The ROS 2 edge's subscriptions must not reach the service's own inputs (nor the reverse): the
/// dispatcher reads a key as a vehicle's input first, so a ROS message on an overlapping key would be
/// refused as JSON (e.g. the bridge format with `namespace` equal to `key_prefix` and a topic `imu`).
fn ros2_keys_apart(prefix: &str, ros2: &crate::ros2::Ros2Config) -> Result<(), String> {
    use crate::ros2::Ros2Keys;
    use zenoh::key_expr::KeyExpr;
    let keys = Keys::new(prefix);
    let ours = [
        keys.all(Leaf::Gyro),
        keys.all(Leaf::Vectors),
        keys.all(Leaf::Imu),
        keys.routed_inputs(None),
        keys.standby(None),
    ];
    let edge = Ros2Keys::new(ros2.format, ros2.domain_id, &ros2.namespace);
    for topic in std::iter::once(&ros2.imu_topic).chain(ros2.mag_topic.as_ref()) {
        let theirs = edge.subscription(topic);
        let Ok(t) = KeyExpr::try_from(theirs.as_str()) else {
            return Err(format!("service.ros2: {theirs:?} is not a key expression"));
        };
        for o in &ours {
            let o = KeyExpr::try_from(o.as_str()).map_err(|e| e.to_string())?;
            if t.intersects(&o) {
                return Err(format!(
                    "service.ros2: the ROS 2 topic keys {theirs} overlap the service's inputs {o} \
                     (service.key_prefix {prefix:?}): give service.ros2.namespace (or the topics) \
                     another first chunk"
                ));
            }
        }
    }
    Ok(())
}

/// Applies `serve --routes` over the file's `service.fleet.routes`.
pub fn override_routes(config: &mut ServiceConfig, routes: &str) -> Result<(), String> {
    config.fleet.routes =
        parse_routes(routes).map_err(|e| format!("service.fleet.routes '{routes}': {e}"))?;
    Ok(())
}

/// Applies the command line's fleet options (`serve --fleet --group --instance --vehicles`) over the
/// file's, validated like the file's.
pub fn override_fleet(
    config: &mut ServiceConfig,
    dynamic: bool,
    group: Option<String>,
    instance: Option<String>,
    vehicles: Option<String>,
) -> Result<(), String> {
    let f = &config.fleet;
    let raw = RawFleet {
        mode: if dynamic { "dynamic" } else { f.mode.as_str() }.into(),
        group: group.unwrap_or_else(|| f.group.clone()),
        instance: Some(instance.unwrap_or_else(|| f.instance.clone())),
        vehicles: vehicles.unwrap_or_else(|| f.vehicles.clone()),
        routes: routes_text(f.routes),
        standby_s: f.standby_s,
        standby_bytes: f.standby_bytes,
        flush_s: f.flush_s,
        discovery_timeout_s: f.discovery_timeout_s,
    };
    config.fleet = validate_fleet(&config.key_prefix, raw)?;
    Ok(())
}

fn validate_fleet(prefix: &str, raw: RawFleet) -> Result<FleetConfig, String> {
    let mode = match raw.mode.as_str() {
        "single" => FleetMode::Single,
        "dynamic" => FleetMode::Dynamic,
        other => {
            return Err(format!(
                "service.fleet.mode '{other}': expected single or dynamic"
            ))
        }
    };
    let chunk = |value: &str, what: &str| {
        if crate::wire::validate_vehicle_id(value).is_err() {
            Err(format!(
                "service.fleet.{what} '{value}' must be one key chunk of 1-64 characters from [A-Za-z0-9_-]"
            ))
        } else {
            Ok(())
        }
    };
    chunk(&raw.group, "group")?;
    let instance = match raw.instance {
        Some(i) => {
            chunk(&i, "instance")?;
            i
        }
        None => default_instance_name(),
    };
    // The vehicle pattern is one chunk of a key expression: `*`, `a$*`, `sc1`, ...
    let vehicles = raw.vehicles;
    // (The subscription it will be part of, built where every key expression is built.)
    let probe = Keys::new(prefix).with_vehicles(&vehicles).all(Leaf::Gyro);
    if vehicles.is_empty()
        || vehicles.contains('/')
        || vehicles.starts_with('@')
        || zenoh::key_expr::KeyExpr::try_from(probe.as_str()).is_err()
    {
        return Err(format!(
            "service.fleet.vehicles '{vehicles}' must be one chunk of a key expression (e.g. *, a$*, sc1)"
        ));
    }
    let routes = parse_routes(&raw.routes)
        .map_err(|e| format!("service.fleet.routes '{}': {e}", raw.routes))?;
    if !(raw.standby_s.is_finite() && raw.standby_s >= 0.0) {
        return Err("service.fleet.standby_s must be finite and non-negative".into());
    }
    if !(raw.flush_s.is_finite() && raw.flush_s > 0.0 && raw.flush_s <= 1.0) {
        return Err("service.fleet.flush_s must be in (0, 1] s".into());
    }
    if raw.standby_bytes == 0 {
        return Err("service.fleet.standby_bytes must be positive".into());
    }
    if !(raw.discovery_timeout_s.is_finite() && raw.discovery_timeout_s > 0.0) {
        return Err("service.fleet.discovery_timeout_s must be positive".into());
    }
    Ok(FleetConfig {
        mode,
        group: raw.group,
        instance,
        vehicles,
        routes,
        standby_s: raw.standby_s,
        standby_bytes: raw.standby_bytes,
        flush_s: raw.flush_s,
        discovery_timeout_s: raw.discovery_timeout_s,
    })
}
