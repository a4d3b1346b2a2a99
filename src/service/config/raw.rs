//! What the configuration file says, as it says it (serde's view of config/default.json5): every
//! section with its defaults. `super` validates it into the service's and the vehicles' types.

use super::{IngestConfig, MetricsConfig};
use crate::ahrs::{InitConfig, RecoveryConfig, RestConfig, SensorSheet};
use crate::filters::{GapModel, QpfOptions};
use crate::fleet::FleetConfig;
use crate::sensors::field::{FieldModel, MagConfig};
use crate::sensors::gravity::{AccConfig, GravityModel};
use crate::sensors::gyro::GyroConfig;
use crate::sensors::model::SensorModel;
use crate::sensors::GyroNoise;
use crate::wire::InputLimits;
use serde::Deserialize;
use std::collections::BTreeMap;

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFile {
    #[serde(default)]
    pub(super) zenoh: Option<serde_json::Value>,
    #[serde(default)]
    pub(super) service: RawService,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawService {
    pub(super) key_prefix: String,
    pub(super) filter: RawFilter,
    pub(super) vehicles: BTreeMap<String, RawFilterOverride>,
    pub(super) limits: RawLimits,
    pub(super) workers: usize,
    pub(super) time: RawTime,
    pub(super) gate: RawGate,
    pub(super) sensors: BTreeMap<String, RawSensor>,
    pub(super) imu: RawImu,
    pub(super) health: RawHealth,
    pub(super) persistence: RawPersistence,
    pub(super) fleet: RawFleet,
    pub(super) metrics: RawMetrics,
    pub(super) ingest: RawIngest,
    pub(super) ros2: crate::ros2::RawRos2,
}

impl Default for RawService {
    fn default() -> Self {
        RawService {
            key_prefix: "attitude".into(),
            filter: RawFilter::default(),
            vehicles: BTreeMap::new(),
            limits: RawLimits::default(),
            workers: 0,
            time: RawTime::default(),
            gate: RawGate::default(),
            sensors: BTreeMap::new(),
            imu: RawImu::default(),
            health: RawHealth::default(),
            persistence: RawPersistence::default(),
            fleet: RawFleet::default(),
            metrics: RawMetrics::default(),
            ingest: RawIngest::default(),
            ros2: Default::default(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawMetrics {
    pub(super) max_vehicles: usize,
}

impl Default for RawMetrics {
    fn default() -> Self {
        RawMetrics {
            max_vehicles: MetricsConfig::default().max_vehicles,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawIngest {
    pub(super) recovery: bool,
    pub(super) query_timeout_s: f64,
    pub(super) history_samples: usize,
    pub(super) pending_bytes_per_vehicle: usize,
    pub(super) pending_bytes: usize,
    pub(super) wait_s: f64,
}

impl Default for RawIngest {
    fn default() -> Self {
        let d = IngestConfig::default();
        RawIngest {
            recovery: d.recovery,
            query_timeout_s: d.query_timeout_s,
            history_samples: d.history_samples,
            pending_bytes_per_vehicle: d.pending_bytes_per_vehicle,
            pending_bytes: d.pending_bytes,
            wait_s: d.wait_s,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawFleet {
    pub(super) mode: String,
    pub(super) group: String,
    pub(super) instance: Option<String>,
    pub(super) vehicles: String,
    pub(super) routes: String,
    pub(super) standby_s: f64,
    pub(super) standby_bytes: usize,
    pub(super) flush_s: f64,
    pub(super) discovery_timeout_s: f64,
}

impl Default for RawFleet {
    fn default() -> Self {
        let d = FleetConfig::single("");
        RawFleet {
            mode: d.mode.as_str().into(),
            group: d.group,
            instance: None,
            vehicles: d.vehicles,
            routes: "all".into(),
            standby_s: d.standby_s,
            standby_bytes: d.standby_bytes,
            flush_s: d.flush_s,
            discovery_timeout_s: d.discovery_timeout_s,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawTime {
    pub(super) reorder_window_s: f64,
    pub(super) max_jump_s: f64,
    pub(super) max_lag_s: f64,
    pub(super) history_bytes: usize,
}

impl Default for RawTime {
    fn default() -> Self {
        RawTime {
            reorder_window_s: 0.2,
            max_jump_s: 3600.0,
            max_lag_s: 2.0,
            history_bytes: 8 << 20,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawGate {
    pub(super) probability: f64,
    pub(super) reinit_after: u32,
}

impl Default for RawGate {
    fn default() -> Self {
        RawGate {
            probability: 0.9999,
            reinit_after: 10,
        }
    }
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSensor {
    pub(super) gate_probability: Option<f64>,
    /// "vector" (default), "gravity" or "field" (crate::sensors::model).
    pub(super) kind: Option<String>,
    pub(super) sigma_norm_scale: Option<f64>,
    pub(super) norm_gate: Option<f64>,
    pub(super) lowpass_s: Option<f64>,
    pub(super) norm_limit: Option<f64>,
    pub(super) dip_limit_deg: Option<f64>,
    pub(super) holdoff_s: Option<f64>,
    pub(super) heading_only: Option<bool>,
    pub(super) vertical: Option<[f64; 3]>,
}

/// The model of one `service.sensors.NAME` entry (`None` for a plain vector sensor).
pub(super) fn sensor_model(name: &str, s: &RawSensor) -> Result<Option<SensorModel>, String> {
    let at = |field: &str| format!("service.sensors.{name}.{field}");
    let kind = s.kind.as_deref().unwrap_or("vector");
    let only = |ok: bool, field: &str, present: bool| -> Result<(), String> {
        if present && !ok {
            Err(format!(
                "{} is not an option of a '{kind}' sensor",
                at(field)
            ))
        } else {
            Ok(())
        }
    };
    let (g, f) = (kind == "gravity", kind == "field");
    only(g || f, "sigma_norm_scale", s.sigma_norm_scale.is_some())?;
    only(g, "norm_gate", s.norm_gate.is_some())?;
    only(g, "lowpass_s", s.lowpass_s.is_some())?;
    only(f, "norm_limit", s.norm_limit.is_some())?;
    only(f, "dip_limit_deg", s.dip_limit_deg.is_some())?;
    only(f, "holdoff_s", s.holdoff_s.is_some())?;
    only(f, "heading_only", s.heading_only.is_some())?;
    only(f, "vertical", s.vertical.is_some())?;
    match kind {
        "vector" => Ok(None),
        "gravity" => {
            let model = GravityModel {
                sigma_norm_scale: s.sigma_norm_scale.unwrap_or(0.0),
                norm_gate: s.norm_gate.unwrap_or(f64::INFINITY),
                lowpass_s: s.lowpass_s.unwrap_or(0.0),
            };
            model.validate(&at(""))?;
            Ok(Some(SensorModel::Gravity(model)))
        }
        "field" => {
            let v = s.vertical.unwrap_or([0.0, 0.0, 1.0]);
            let vertical = nalgebra::Vector3::from(v);
            let n = vertical.norm();
            if !(n > 0.0 && n.is_finite()) {
                return Err(format!(
                    "{} must be a finite non-zero vector",
                    at("vertical")
                ));
            }
            let model = FieldModel {
                sigma_norm_scale: s.sigma_norm_scale.unwrap_or(0.0),
                norm_limit: s.norm_limit.unwrap_or(f64::INFINITY),
                dip_limit_rad: s.dip_limit_deg.unwrap_or(f64::INFINITY).to_radians(),
                holdoff_s: s.holdoff_s.unwrap_or(0.0),
                heading_only: s.heading_only.unwrap_or(false),
                vertical: vertical / n,
            };
            model.validate(&at(""))?;
            Ok(Some(SensorModel::Field(model)))
        }
        other => Err(format!(
            "{} must be \"vector\", \"gravity\" or \"field\", got \"{other}\"",
            at("kind")
        )),
    }
}

/// `service.imu`: the raw-IMU pipeline (crate::ahrs) and how often an IMU vehicle publishes.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawImu {
    /// Most estimates per second an IMU vehicle publishes (0: one per sample).
    pub(super) max_estimate_rate_hz: f64,
    pub(super) timing_sigma_s: f64,
    pub(super) init: InitConfig,
    /// The IMU's datasheet values for every vehicle (crate::ahrs::SensorSheet).
    pub(super) sensor: SensorSheet,
    pub(super) gyro: GyroConfig,
    pub(super) rest: RestConfig,
    pub(super) acc: AccConfig,
    pub(super) mag: MagConfig,
    pub(super) recovery: RecoveryConfig,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawHealth {
    pub(super) reinit_after_failures: u32,
    pub(super) reinit_sigma_factor: f64,
}

impl Default for RawHealth {
    fn default() -> Self {
        RawHealth {
            reinit_after_failures: 3,
            reinit_sigma_factor: 10.0,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawPersistence {
    pub(super) state_dir: Option<String>,
    pub(super) checkpoint_interval_s: f64,
}

impl Default for RawPersistence {
    fn default() -> Self {
        RawPersistence {
            state_dir: None,
            checkpoint_interval_s: 10.0,
        }
    }
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawGap {
    pub(super) after_s: f64,
    pub(super) accel_sigma_rad_s2: f64,
}

impl Default for RawGap {
    fn default() -> Self {
        let g = GapModel::default();
        RawGap {
            after_s: g.after_s,
            accel_sigma_rad_s2: g.accel_sigma_rad_s2,
        }
    }
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawFilter {
    pub(super) kind: String,
    pub(super) fiducial: String,
    pub(super) particles: usize,
    pub(super) level: u64,
    pub(super) gyro_arw_rad_sqrt_s: f64,
    pub(super) gyro_rrw_rad_s_sqrt_s: f64,
    pub(super) init: String,
    pub(super) init_bias_sigma_deg_hr: f64,
    pub(super) gyro_rate_noise_sqrt_s: f64,
    pub(super) gyro_bias_limit_deg_s: Option<f64>,
    pub(super) qpf: RawQpf,
    pub(super) usque: RawUsque,
    pub(super) gap: RawGap,
}

impl Default for RawFilter {
    fn default() -> Self {
        let g = GyroNoise::standard();
        RawFilter {
            kind: "qpf".into(),
            fiducial: "average".into(),
            particles: 1000,
            level: crate::filters::sghqf::DEFAULT_LEVEL as u64,
            gyro_arw_rad_sqrt_s: g.sigma_v,
            gyro_rrw_rad_s_sqrt_s: g.sigma_u,
            init: "vectors".into(),
            init_bias_sigma_deg_hr: 10.0,
            gyro_rate_noise_sqrt_s: 0.0,
            gyro_bias_limit_deg_s: None,
            qpf: RawQpf::default(),
            usque: RawUsque::default(),
            gap: RawGap::default(),
        }
    }
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawQpf {
    pub(super) kernel: String,
    pub(super) bandwidth_scale: f64,
    pub(super) resample_fraction: f64,
    pub(super) pc_spread: f64,
    pub(super) pc_max_stages: u32,
    pub(super) inflation: f64,
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
pub(super) struct RawUsque {
    pub(super) a: f64,
    pub(super) f: f64,
    pub(super) lambda: f64,
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
pub(super) struct RawFilterOverride {
    pub(super) kind: Option<String>,
    pub(super) fiducial: Option<String>,
    pub(super) particles: Option<usize>,
    pub(super) level: Option<u64>,
    pub(super) gyro_arw_rad_sqrt_s: Option<f64>,
    pub(super) gyro_rrw_rad_s_sqrt_s: Option<f64>,
    pub(super) init: Option<String>,
    pub(super) init_bias_sigma_deg_hr: Option<f64>,
    pub(super) gyro_rate_noise_sqrt_s: Option<f64>,
    pub(super) gyro_bias_limit_deg_s: Option<f64>,
    /// The vehicle's IMU datasheet (crate::ahrs::SensorSheet), over `service.imu.sensor`.
    pub(super) sensor: Option<SensorSheet>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawLimits {
    pub(super) max_vehicles: usize,
    pub(super) queue_per_vehicle: usize,
    pub(super) max_payload_bytes: usize,
    pub(super) max_batch: usize,
    pub(super) max_observations: usize,
    pub(super) max_rate_rad_s: f64,
    pub(super) max_sensors_per_vehicle: usize,
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
            max_rate_rad_s: l.max_rate_rad_s,
            max_sensors_per_vehicle: 16,
        }
    }
}
