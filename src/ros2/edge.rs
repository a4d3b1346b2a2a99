//! The ROS 2 edge without the network ([`Edge`]): `sensor_msgs/msg/Imu` (and `MagneticField`) in on
//! rmw_zenoh's keys or zenoh-bridge-ros2dds', `sensor_msgs/msg/Imu` out with the estimated
//! orientation. (The network side, `net.rs`: the subscriptions, the liveliness tokens of rmw_zenoh's
//! graph, the attachments and `/diagnostics`.)
//!
//! [`Edge`] has no zenoh session: the engine's dispatcher thread hands it an input's key and payload
//! and gets the same domain `ImuSample` that `P/V/imu` gives (decoded there, never in a zenoh
//! callback); a worker thread hands it each published estimate, and it builds the Imu message only when
//! its outlet says someone subscribes. The magnetometer arrives on a topic of its own: its last reading
//! waits (per vehicle, on the dispatcher thread) for the IMU sample it is paired with.

use super::config::{CovarianceFrame, Ros2Config};
use super::keys::{Ros2Format, Ros2Keys};

use super::msgs::{cdr_rejection, Header, RosImu, RosMagneticField, RosType, Stamp};
use crate::engine::{Engine, Inbound, Vehicle};
use crate::sensors::Measurement;
use crate::wire::{validate_vehicle_id, EstimateMsg, InputLimits, RejectCode, Rejection};
use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::sync::{Mutex, OnceLock};

/// The type hash a Humble publisher puts in its keys (it has no type hashes).
pub const HASH_NOT_SUPPORTED: &str = "TypeHashNotSupported";

/// IMU samples kept per vehicle until the estimate of their time is published (their stamp, rate and
/// specific force go out with it); the oldest go first.
const KEPT: usize = 1024;

/// Which input topic a message came on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ros2Input {
    Imu,
    Mag,
}

/// Where the edge's Imu messages go: zenoh in the service (`net.rs`), a collector in tests.
pub trait Ros2Outlet: Send + Sync {
    /// Whether anyone subscribes to the output topic of any vehicle.
    fn wanted(&self) -> bool;
    /// Puts one vehicle's serialised `sensor_msgs/msg/Imu`.
    fn put(&self, vehicle: &str, cdr: Vec<u8>);
}

/// An input sample kept for its estimate.
struct Kept {
    t: f64,
    stamp: Stamp,
    gyr: [f64; 3],
    acc: [f64; 3],
}

#[derive(Default)]
struct VehicleRos {
    /// The last magnetometer reading not yet paired: `(t, µT)`.
    mag: Option<(f64, [f64; 3])>,
    kept: VecDeque<Kept>,
    gyr_cov: [f64; 9],
    acc_cov: [f64; 9],
    frame_id: Option<String>,
}

/// The ROS 2 edge of one engine.
pub struct Edge {
    pub config: Ros2Config,
    pub keys: Ros2Keys,
    topics: Vec<String>,
    imu_dds: String,
    imu_hash: String,
    mag_dds: String,
    mag_hash: String,
    vehicles: Mutex<HashMap<String, VehicleRos>>,
    max_vehicles: usize,
    outlet: OnceLock<Box<dyn Ros2Outlet>>,
    /// Vehicles seen for the first time (their topics join the ROS graph).
    announce: tokio::sync::mpsc::UnboundedSender<String>,
    announced: Mutex<std::collections::HashSet<String>>,
    announcements: Mutex<Option<tokio::sync::mpsc::UnboundedReceiver<String>>>,
}

impl Edge {
    /// An input on a key of the edge (the engine's dispatcher thread, through its hooks), decoded
    /// into the same measurement as `P/V/imu` and queued by the same path ([`Engine::queue`]); `None`
    /// for any other key. A magnetometer message queues nothing: it waits for the IMU sample it goes
    /// with. (Another member's vehicle: nothing kept. ROS 2 inputs are not routed, every member of a
    /// fleet receives them, and a takeover replays only the JSON leaves' inputs: a vehicle fed over ROS
    /// continues on its new owner from the last estimate and the ROS inputs from then on.)
    pub fn dispatch(
        &self,
        engine: &Engine,
        inbound: Inbound,
        decoded: &mut Vec<Measurement>,
    ) -> Option<Arc<Vehicle>> {
        let (vehicle, input, ty, hash) = self.route(&inbound.key)?;
        if !engine.owns(vehicle) {
            return None;
        }
        let limits = &engine.config.limits.input;
        let result = self.decode(vehicle, input, ty, hash, &inbound.payload, limits, decoded);
        match result {
            Ok(0) => None,
            result => engine.queue(vehicle, &inbound.key, result, decoded),
        }
    }

    pub fn new(config: Ros2Config, max_vehicles: usize) -> Edge {
        let keys = Ros2Keys::new(config.format, config.domain_id, &config.namespace);
        let mut topics = vec![config.imu_topic.clone()];
        if let Some(m) = &config.mag_topic {
            topics.push(m.clone());
        }
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        let edge = Edge {
            keys,
            topics,
            imu_dds: RosType::Imu.dds_name(),
            imu_hash: RosType::Imu.hash(),
            mag_dds: RosType::MagneticField.dds_name(),
            mag_hash: RosType::MagneticField.hash(),
            vehicles: Mutex::new(HashMap::new()),
            max_vehicles,
            outlet: OnceLock::new(),
            announce: tx,
            announced: Mutex::new(Default::default()),
            announcements: Mutex::new(Some(rx)),
            config,
        };
        for v in edge.config.vehicles.clone() {
            edge.seen(&v);
        }
        edge
    }

    /// The keys to subscribe to (the IMU topic, and the magnetometer's).
    pub fn subscriptions(&self) -> Vec<String> {
        self.topics
            .iter()
            .map(|t| self.keys.subscription(t))
            .collect()
    }

    /// Where the Imu messages go (once).
    pub fn set_outlet(&self, outlet: Box<dyn Ros2Outlet>) {
        let _ = self.outlet.set(outlet);
    }

    /// The vehicles seen for the first time, in order (taken once, by the network side).
    pub fn take_announcements(&self) -> Option<tokio::sync::mpsc::UnboundedReceiver<String>> {
        self.announcements
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take()
    }

    fn seen(&self, vehicle: &str) {
        let mut a = self.announced.lock().unwrap_or_else(|e| e.into_inner());
        if a.len() < self.max_vehicles && !a.contains(vehicle) {
            a.insert(vehicle.to_string());
            let _ = self.announce.send(vehicle.to_string());
        }
    }

    /// The vehicle and input topic of a key of the edge, with its type and hash chunks.
    pub fn route<'a>(&self, key: &'a str) -> Option<(&'a str, Ros2Input, &'a str, &'a str)> {
        let topics: Vec<&str> = self.topics.iter().map(String::as_str).collect();
        let (vehicle, i, ty, hash) = self.keys.split(key, &topics)?;
        Some((
            vehicle,
            if i == 0 {
                Ros2Input::Imu
            } else {
                Ros2Input::Mag
            },
            ty,
            hash,
        ))
    }

    /// rmw_zenoh's key says the type: it must be the topic's, with our hash or Humble's none.
    fn check_type(&self, input: Ros2Input, ty: &str, hash: &str) -> Result<(), Rejection> {
        if self.keys.format == Ros2Format::Bridge {
            return Ok(());
        }
        let (dds, ours, name) = match input {
            Ros2Input::Imu => (&self.imu_dds, &self.imu_hash, RosType::Imu.name()),
            Ros2Input::Mag => (&self.mag_dds, &self.mag_hash, RosType::MagneticField.name()),
        };
        if ty != dds {
            return Err(Rejection::new(
                RejectCode::BadRequest,
                format!("ros2: the key's type is {ty}; this topic takes {name} ({dds})"),
            ));
        }
        if hash != ours && hash != HASH_NOT_SUPPORTED {
            return Err(Rejection::new(
                RejectCode::BadRequest,
                format!(
                    "ros2: type hash {hash} is not that of {name} ({ours}): another definition of the \
                     type"
                ),
            ));
        }
        Ok(())
    }

    /// Decodes one input into `out` (dispatcher thread): an Imu message is one `Measurement::Imu`
    /// (with the magnetometer reading paired with it), a MagneticField message none (it waits for
    /// its IMU sample). Nothing is appended on a fault.
    #[allow(clippy::too_many_arguments)]
    pub fn decode(
        &self,
        vehicle: &str,
        input: Ros2Input,
        ty: &str,
        hash: &str,
        payload: &[u8],
        limits: &InputLimits,
        out: &mut Vec<Measurement>,
    ) -> Result<usize, Rejection> {
        if payload.len() > limits.max_payload_bytes {
            return Err(Rejection::new(
                RejectCode::PayloadTooLarge,
                format!(
                    "payload of {} bytes exceeds {}",
                    payload.len(),
                    limits.max_payload_bytes
                ),
            ));
        }
        self.check_type(input, ty, hash)?;
        validate_vehicle_id(vehicle)?;
        let mut vehicles = self.vehicles.lock().unwrap_or_else(|e| e.into_inner());
        if !vehicles.contains_key(vehicle) && vehicles.len() >= self.max_vehicles {
            return Err(Rejection::new(
                RejectCode::TooManyVehicles,
                format!(
                    "the service tracks its maximum of {} vehicles",
                    self.max_vehicles
                ),
            ));
        }
        match input {
            Ros2Input::Mag => {
                let m = RosMagneticField::from_cdr(payload)
                    .map_err(|e| cdr_rejection(RosType::MagneticField.name(), e))?;
                let reading = m.to_domain()?;
                vehicles.entry(vehicle.to_string()).or_default().mag = Some(reading);
                Ok(0)
            }
            Ros2Input::Imu => {
                let m =
                    RosImu::from_cdr(payload).map_err(|e| cdr_rejection(RosType::Imu.name(), e))?;
                let t = m.header.stamp.seconds();
                let max_age = self.config.mag_max_age_s;
                // The pending reading goes with this sample if it is near enough; one far behind is
                // dropped; one ahead waits.
                let pending = vehicles.get(vehicle).and_then(|s| s.mag);
                let mag = match pending {
                    Some((tm, v)) if (t - tm).abs() <= max_age => Some(v),
                    _ => None,
                };
                let sample = m.to_domain(mag, limits)?;
                let state = vehicles.entry(vehicle.to_string()).or_default();
                if mag.is_some() || state.mag.is_some_and(|(tm, _)| t - tm > max_age) {
                    state.mag = None;
                }
                state.gyr_cov = m.angular_velocity_covariance;
                state.acc_cov = m.linear_acceleration_covariance;
                if state.frame_id.as_deref() != Some(m.header.frame_id.as_str()) {
                    state.frame_id = Some(m.header.frame_id.clone());
                }
                if state.kept.len() == KEPT {
                    state.kept.pop_front();
                }
                state.kept.push_back(Kept {
                    t: sample.t_s,
                    stamp: m.header.stamp,
                    gyr: m.angular_velocity,
                    acc: m.linear_acceleration,
                });
                drop(vehicles);
                self.seen(vehicle);
                out.push(Measurement::Imu(sample));
                Ok(1)
            }
        }
    }

    /// A published estimate (worker thread): its Imu message, put when anyone subscribes. Estimates
    /// published again by a replay (a late sample) are not: a ROS subscriber expects time to move on.
    pub fn on_estimate(&self, vehicle: &str, e: &EstimateMsg) {
        let Some(outlet) = self.outlet.get() else {
            return;
        };
        self.seen(vehicle);
        if e.diagnostics.replayed || !outlet.wanted() {
            return;
        }
        let m = self.imu_of(vehicle, e);
        outlet.put(vehicle, m.to_cdr());
    }

    /// The `sensor_msgs/msg/Imu` of an estimate (`proto/ros2.md`, "Out").
    pub fn imu_of(&self, vehicle: &str, e: &EstimateMsg) -> RosImu {
        let mut vehicles = self.vehicles.lock().unwrap_or_else(|e| e.into_inner());
        let state = vehicles.get_mut(vehicle);
        // The sample of the estimate's time, and the covariances its vehicle's messages carry.
        let (sample, gyr_cov, acc_cov, frame) = match state {
            Some(s) => {
                while s.kept.front().is_some_and(|k| k.t < e.t) {
                    s.kept.pop_front();
                }
                let k = s.kept.front().filter(|k| k.t == e.t);
                (
                    k.map(|k| (k.stamp, k.gyr, k.acc)),
                    s.gyr_cov,
                    s.acc_cov,
                    s.frame_id.clone(),
                )
            }
            None => (None, [0.0; 9], [0.0; 9], None),
        };
        drop(vehicles);
        let frame_id = match &self.config.frame_id {
            Some(f) => f.replace("{vehicle}", vehicle),
            None => frame
                .filter(|f| !f.is_empty())
                .unwrap_or_else(|| format!("{vehicle}/imu_link")),
        };
        let q = [e.q.x, e.q.y, e.q.z, e.q.w];
        let mut orientation_covariance = [0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                orientation_covariance[3 * i + j] = e.cov[i][j];
            }
        }
        if self.config.orientation_covariance_frame == CovarianceFrame::Fixed {
            orientation_covariance = to_fixed_frame(&q, &orientation_covariance);
        }
        let mut m = RosImu {
            header: Header {
                stamp: sample
                    .map(|s| s.0)
                    .unwrap_or_else(|| Stamp::from_seconds(e.t)),
                frame_id,
            },
            orientation: q,
            orientation_covariance,
            ..RosImu::default()
        };
        match sample {
            Some((_, gyr, acc)) => {
                m.angular_velocity = [0, 1, 2].map(|i| gyr[i] - e.bias[i]);
                // The rate's noise (when the input states it) and the bias estimate's uncertainty.
                if gyr_cov.iter().any(|x| *x != 0.0) {
                    for i in 0..3 {
                        for j in 0..3 {
                            m.angular_velocity_covariance[3 * i + j] =
                                gyr_cov[3 * i + j] + e.cov[3 + i][3 + j];
                        }
                    }
                }
                m.linear_acceleration = acc;
                m.linear_acceleration_covariance = acc_cov;
            }
            None => {
                // No sample of this time came over ROS (a vehicle fed P/V/imu or P/V/gyro): REP-145's
                // "no estimate" for both.
                m.angular_velocity_covariance[0] = -1.0;
                m.linear_acceleration_covariance[0] = -1.0;
            }
        }
        m
    }
}

/// The rotation matrix of the body's orientation in the fixed frame (Hamilton, `[x, y, z, w]`):
/// `v_fixed = R v_body`, `R = A(q)ᵀ`.
pub fn orientation_matrix(q: &[f64; 4]) -> [[f64; 3]; 3] {
    let [x, y, z, w] = *q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// A body-frame attitude covariance (row-major 3×3) about the fixed frame's axes: `R Σ Rᵀ`.
pub fn to_fixed_frame(q: &[f64; 4], cov: &[f64; 9]) -> [f64; 9] {
    let r = orientation_matrix(q);
    let mut out = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            let mut s = 0.0;
            for k in 0..3 {
                for l in 0..3 {
                    s += r[i][k] * cov[3 * k + l] * r[j][l];
                }
            }
            out[3 * i + j] = s;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vehicle yawed +90° (body x along the fixed y): its roll variance is about the fixed y axis.
    #[test]
    fn covariance_to_the_fixed_frame() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = [0.0, 0.0, h, h];
        let r = orientation_matrix(&q);
        let bx = [r[0][0], r[1][0], r[2][0]];
        assert!((bx[0]).abs() < 1e-15 && (bx[1] - 1.0).abs() < 1e-15);
        let cov = [4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 9.0];
        let f = to_fixed_frame(&q, &cov);
        let want = [1.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 9.0];
        for (a, b) in f.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{f:?}");
        }
    }
}
