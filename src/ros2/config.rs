//! `service.ros2`: what the file says (with its defaults) and its validation.

use super::keys::Ros2Format;
use crate::wire::validate_vehicle_id;
use serde::Deserialize;

/// In which frame `orientation_covariance` is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CovarianceFrame {
    /// About the axes of the message's frame (the body, `header.frame_id`): the service's own attitude
    /// error `δα`, and how robot_localization reads an IMU's orientation covariance (it rotates it
    /// with the sensor's mounting into base_link).
    Body,
    /// About the axes of the fixed (reference) frame: `Σ_fixed = R Σ_body Rᵀ`, R the orientation.
    Fixed,
}

/// The validated `service.ros2` section.
#[derive(Clone, Debug, PartialEq)]
pub struct Ros2Config {
    pub enabled: bool,
    pub format: Ros2Format,
    /// The ROS domain (rmw_zenoh's first key chunk; the DDS domain with `format: "dds"`): the file's
    /// `domain_id`, else `ROS_DOMAIN_ID`, else 0.
    pub domain_id: u32,
    /// `format: "dds"`: zenoh-plugin-ros2dds' configuration (the `dds` section, with the domain and
    /// the node name filled in), run in the service's own zenoh runtime (`service::session`).
    pub dds: Option<serde_json::Value>,
    /// Chunks in front of the vehicle id in every topic name (`/<namespace>/<V>/imu/data`); "" none.
    pub namespace: String,
    pub imu_topic: String,
    /// `None`: no magnetometer topic.
    pub mag_topic: Option<String>,
    pub output_topic: String,
    /// `None`: the output keeps the input sample's `header.frame_id`. `{vehicle}` is replaced.
    pub frame_id: Option<String>,
    pub orientation_covariance_frame: CovarianceFrame,
    /// A magnetometer message is paired with the first IMU sample within this many seconds of it.
    pub mag_max_age_s: f64,
    pub node_name: String,
    pub node_namespace: String,
    /// Vehicles whose topics are announced to the ROS graph at start (others from their first input).
    pub vehicles: Vec<String>,
    /// The reset as a ROS 2 service (`std_srvs/srv/Trigger`, relative to `/<namespace>/V`; `reset.rs`),
    /// in the bridge key format (and so on DDS); `None`: none.
    pub reset_service: Option<String>,
    /// `/diagnostics` every this many seconds; `None`: off.
    pub diagnostics_period_s: Option<f64>,
    /// QoS chunk of the publishers' and subscriptions' liveliness tokens (rmw_zenoh's encoding).
    pub publisher_qos: String,
    pub subscription_qos: String,
}

impl Default for Ros2Config {
    fn default() -> Self {
        validate(RawRos2::default()).expect("the built-in defaults are valid")
    }
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields, default)]
pub struct RawRos2 {
    enabled: bool,
    format: String,
    domain_id: Option<u32>,
    dds: serde_json::Map<String, serde_json::Value>,
    namespace: String,
    imu_topic: String,
    mag_topic: String,
    output_topic: String,
    frame_id: String,
    orientation_covariance_frame: String,
    mag_max_age_s: f64,
    node_name: String,
    node_namespace: String,
    vehicles: Vec<String>,
    diagnostics_period_s: f64,
    reset_service: String,
}

impl Default for RawRos2 {
    fn default() -> Self {
        RawRos2 {
            enabled: false,
            format: "rmw_zenoh".into(),
            domain_id: None,
            dds: Default::default(),
            namespace: String::new(),
            imu_topic: "imu/data_raw".into(),
            mag_topic: "imu/mag".into(),
            output_topic: "imu/data".into(),
            frame_id: String::new(),
            orientation_covariance_frame: "body".into(),
            mag_max_age_s: 0.05,
            node_name: "attitude_service".into(),
            node_namespace: "/".into(),
            vehicles: Vec::new(),
            diagnostics_period_s: 1.0,
            reset_service: String::new(),
        }
    }
}

/// A topic name relative to the vehicle's namespace: chunks of `[A-Za-z0-9_]`, no leading '/'.
fn topic(name: &str, what: &str) -> Result<String, String> {
    let ok = !name.is_empty()
        && name.split('/').all(|c| {
            !c.is_empty()
                && c.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
                && !c.as_bytes()[0].is_ascii_digit()
        });
    if ok {
        Ok(name.to_string())
    } else {
        Err(format!(
            "service.ros2.{what} = {name:?}: a relative ROS topic name (chunks of A-Z, a-z, 0-9, '_', \
             not starting with a digit, separated by '/')"
        ))
    }
}

pub fn validate(raw: RawRos2) -> Result<Ros2Config, String> {
    let format = match raw.format.as_str() {
        "rmw_zenoh" => Ros2Format::RmwZenoh,
        // DDS through the plugin in the service's runtime: the plugin maps each ROS topic onto the
        // bridge's key, so the edge speaks the bridge format.
        "bridge" | "dds" => Ros2Format::Bridge,
        other => {
            return Err(format!(
                "service.ros2.format = {other:?}: \"rmw_zenoh\", \"bridge\" or \"dds\""
            ))
        }
    };
    let domain_id = match raw.domain_id {
        Some(d) => d,
        // As ROS 2 and the bridge do: the environment's domain when the file names none.
        None => match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.trim().is_empty() => match v.trim().parse::<u32>() {
                Ok(d) => d,
                Err(_) if raw.enabled => {
                    return Err(format!(
                        "ROS_DOMAIN_ID = {v:?} (service.ros2.domain_id unset): not a domain id"
                    ))
                }
                Err(_) => 0,
            },
            _ => 0,
        },
    };
    let dds = if raw.format == "dds" {
        Some(super::dds::plugin_config(
            raw.dds,
            domain_id,
            &raw.node_name,
            &raw.node_namespace,
        )?)
    } else if !raw.dds.is_empty() {
        return Err(format!(
            "service.ros2.dds is for format \"dds\" (the format is {:?})",
            raw.format
        ));
    } else {
        None
    };
    // rmw_zenoh accepts the domain ids of ROS 2 (0–232 by REP-2000's port arithmetic; any u32 on zenoh).
    let namespace = raw.namespace.trim_matches('/').to_string();
    if !namespace.is_empty() {
        topic(&namespace, "namespace")?;
    }
    let imu_topic = topic(&raw.imu_topic, "imu_topic")?;
    let mag_topic = if raw.mag_topic.is_empty() {
        None
    } else {
        Some(topic(&raw.mag_topic, "mag_topic")?)
    };
    let output_topic = topic(&raw.output_topic, "output_topic")?;
    let reset_service = if raw.reset_service.is_empty() {
        None
    } else {
        Some(topic(&raw.reset_service, "reset_service")?)
    };
    if let Some(r) = &reset_service {
        if [Some(&imu_topic), mag_topic.as_ref(), Some(&output_topic)].contains(&Some(r)) {
            return Err("service.ros2.reset_service must differ from the topics".into());
        }
    }
    if imu_topic == output_topic || mag_topic.as_deref() == Some(output_topic.as_str()) {
        return Err("service.ros2.output_topic must differ from the input topics".into());
    }
    let orientation_covariance_frame = match raw.orientation_covariance_frame.as_str() {
        "body" => CovarianceFrame::Body,
        "fixed" => CovarianceFrame::Fixed,
        other => {
            return Err(format!(
                "service.ros2.orientation_covariance_frame = {other:?}: \"body\" or \"fixed\""
            ))
        }
    };
    if !(raw.mag_max_age_s > 0.0 && raw.mag_max_age_s <= 10.0) {
        return Err(format!(
            "service.ros2.mag_max_age_s = {}: in (0, 10]",
            raw.mag_max_age_s
        ));
    }
    topic(&raw.node_name, "node_name")
        .ok()
        .filter(|n| !n.contains('/'))
        .ok_or_else(|| {
            format!(
                "service.ros2.node_name = {:?}: one chunk of A-Z, a-z, 0-9, '_'",
                raw.node_name
            )
        })?;
    let node_namespace = if raw.node_namespace.trim_matches('/').is_empty() {
        "/".to_string()
    } else {
        topic(raw.node_namespace.trim_matches('/'), "node_namespace")?;
        format!("/{}", raw.node_namespace.trim_matches('/'))
    };
    for v in &raw.vehicles {
        validate_vehicle_id(v).map_err(|e| format!("service.ros2.vehicles: {}", e.message))?;
    }
    let diagnostics_period_s = if raw.diagnostics_period_s == 0.0 {
        None
    } else if raw.diagnostics_period_s >= 0.01 && raw.diagnostics_period_s <= 3600.0 {
        Some(raw.diagnostics_period_s)
    } else {
        return Err(format!(
            "service.ros2.diagnostics_period_s = {}: 0 (off) or in [0.01, 3600]",
            raw.diagnostics_period_s
        ));
    };
    Ok(Ros2Config {
        enabled: raw.enabled,
        format,
        domain_id,
        dds,
        namespace,
        imu_topic,
        mag_topic,
        output_topic,
        frame_id: (!raw.frame_id.is_empty()).then_some(raw.frame_id),
        orientation_covariance_frame,
        mag_max_age_s: raw.mag_max_age_s,
        node_name: raw.node_name,
        node_namespace,
        vehicles: raw.vehicles,
        diagnostics_period_s,
        reset_service,
        // Reliable, volatile, keep-last 10 (rclcpp's default publisher), in rmw_zenoh's encoding where
        // a value equal to rmw_zenoh's default is left empty: reliability, durability, history,depth,
        // deadline, lifespan, liveliness,lease.
        publisher_qos: "::,10:,:,:,,".into(),
        // Best effort, keep-last 5 (rclcpp's SensorDataQoS): matches reliable and best-effort
        // publishers alike.
        subscription_qos: "2::,5:,:,:,,".into(),
    })
}
