//! The ROS 2 edge on zenoh: the input subscriptions (their callback is the service's, which only hands
//! the raw sample to the engine), the Imu publications with rmw_zenoh's attachment, the liveliness
//! tokens of rmw_zenoh's graph (a node, and each vehicle's publisher and subscriptions), and
//! `/diagnostics`.
//!
//! Followed: rmw_zenoh (ros2/rmw_zenoh, rmw_zenoh_cpp/src/detail: liveliness_utils.cpp at
//! 3411fdec149fe0c932f24d4d79ef908eb81d7482, attachment_helpers.cpp at 534747dc, rmw_publisher_data.cpp at
//! 3e19ec73, qos.cpp at 7efeee2b); `proto/ros2.md` says what each chunk and byte is.

use super::keys::{Ros2Entity, Ros2Format};
use super::msgs::{DiagnosticArray, DiagnosticStatus, Header, KeyValue, RosType, Stamp};
use super::{Edge, Ros2Outlet};
use crate::engine::Engine;
use crate::service::ServiceError;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::Wait;

fn zerr(e: impl std::fmt::Display) -> ServiceError {
    ServiceError::Zenoh(e.to_string())
}

/// rmw_zenoh's GID of an entity: the XXH3-128 of its liveliness token's key, low 64 bits then high,
/// each little-endian.
pub fn gid_of(token: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
    let mut g = [0u8; 16];
    g[..8].copy_from_slice(&(h as u64).to_le_bytes());
    g[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    g
}

/// rmw_zenoh's attachment (zenoh-ext serialisation): the sequence number (i64), the source timestamp
/// (i64, ns since the Unix epoch), the GID as a sequence (LEB128 length 16, then its bytes): 33 bytes.
pub fn attachment(seq: i64, timestamp_ns: i64, gid: &[u8; 16]) -> [u8; 33] {
    let mut a = [0u8; 33];
    a[..8].copy_from_slice(&seq.to_le_bytes());
    a[8..16].copy_from_slice(&timestamp_ns.to_le_bytes());
    a[16] = 16;
    a[17..].copy_from_slice(gid);
    a
}

fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// The node's id within this session (rmw_zenoh numbers nodes and entities per context).
const NODE_ID: u64 = 0;
/// `/diagnostics`' publisher.
const DIAGNOSTICS_ID: u64 = 1;

/// A publisher of rmw_zenoh's kind: its key, GID and sequence number.
struct Publication {
    key: zenoh::key_expr::KeyExpr<'static>,
    /// Its entity id (a vehicle's subscriptions take the next two).
    eid: u64,
    token: String,
    gid: [u8; 16],
    seq: AtomicI64,
}

/// What the outlet and the graph share.
struct Shared {
    session: zenoh::Session,
    edge: Arc<Edge>,
    zid: String,
    anyone: Arc<AtomicBool>,
    /// Each vehicle's output publication (made at its first put or announcement).
    publications: Mutex<HashMap<String, Arc<Publication>>>,
}

impl Shared {
    fn publication(&self, vehicle: &str) -> Option<Arc<Publication>> {
        let mut p = self.publications.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(x) = p.get(vehicle) {
            return Some(x.clone());
        }
        let c = &self.edge.config;
        let keys = &self.edge.keys;
        // Three entity ids per vehicle: its publisher, its IMU and its magnetometer subscriptions.
        let eid = DIAGNOSTICS_ID + 1 + 3 * p.len() as u64;
        let topic = keys.topic_name(vehicle, &c.output_topic);
        let token = keys.endpoint_token(
            &self.zid,
            NODE_ID,
            eid,
            Ros2Entity::Publisher,
            (&c.node_namespace, &c.node_name),
            &topic,
            &RosType::Imu.dds_name(),
            &RosType::Imu.hash(),
            &c.publisher_qos,
        );
        let key = keys.topic(
            vehicle,
            &c.output_topic,
            &RosType::Imu.dds_name(),
            &RosType::Imu.hash(),
        );
        let key = zenoh::key_expr::KeyExpr::try_from(key).ok()?;
        let publication = Arc::new(Publication {
            key,
            eid,
            gid: gid_of(&token),
            token,
            seq: AtomicI64::new(1),
        });
        p.insert(vehicle.to_string(), publication.clone());
        Some(publication)
    }

    fn put(&self, publication: &Publication, cdr: Vec<u8>) {
        let mut put = self
            .session
            .put(publication.key.clone(), cdr)
            .encoding(Encoding::APPLICATION_CDR)
            .congestion_control(CongestionControl::Block)
            .allowed_destination(Locality::Remote);
        if self.edge.keys.format == Ros2Format::RmwZenoh {
            let seq = publication.seq.fetch_add(1, Ordering::Relaxed);
            put = put.attachment(attachment(seq, now_ns(), &publication.gid).to_vec());
        }
        if let Err(e) = put.wait() {
            tracing::warn!(key = %publication.key, error = %e, "ros2 put failed");
        }
    }
}

struct Outlet(Arc<Shared>);

impl Ros2Outlet for Outlet {
    fn wanted(&self) -> bool {
        self.0.anyone.load(Ordering::Relaxed)
    }
    fn put(&self, vehicle: &str, cdr: Vec<u8>) {
        if let Some(p) = self.0.publication(vehicle) {
            self.0.put(&p, cdr);
        }
    }
}

/// The running edge: what `stop` undeclares.
pub struct Ros2Net {
    subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    queryables: Vec<zenoh::query::Queryable<()>>,
    watch: zenoh::pubsub::Publisher<'static>,
    graph: tokio::task::JoinHandle<Vec<zenoh::liveliness::LivelinessToken>>,
    stop: tokio::sync::watch::Sender<bool>,
}

impl Ros2Net {
    /// Stops publishing diagnostics, leaves the ROS graph and stops taking input.
    pub async fn stop(self) {
        let _ = self.stop.send(true);
        for s in self.subscribers {
            let _ = s.undeclare().await;
        }
        for q in self.queryables {
            let _ = q.undeclare().await;
        }
        if let Ok(tokens) = self.graph.await {
            for t in tokens {
                let _ = t.undeclare().await;
            }
        }
        let _ = self.watch.undeclare().await;
    }
}

/// Starts the edge of `engine` on `session`: subscriptions with `callback` (the service's, which only
/// queues the raw sample), the output's outlet and the graph.
pub async fn start(
    session: &zenoh::Session,
    engine: &Arc<Engine>,
    edge: Arc<Edge>,
    callback: impl Fn(zenoh::sample::Sample) + Send + Sync + Clone + 'static,
) -> Result<Ros2Net, ServiceError> {
    let c = edge.config.clone();
    let keys = edge.keys.clone();
    let mut subscribers = Vec::new();
    for key in edge.subscriptions() {
        subscribers.push(
            session
                .declare_subscriber(key)
                .callback(callback.clone())
                .await
                .map_err(zerr)?,
        );
    }
    // The reset service (bridge key format: `reset.rs`): each call answered in a task of its own (it
    // waits for the vehicle's worker).
    let mut queryables = Vec::new();
    if let (Ros2Format::Bridge, Some(reset)) = (keys.format, &c.reset_service) {
        let handle = tokio::runtime::Handle::current();
        let (engine, edge) = (engine.clone(), edge.clone());
        queryables.push(
            session
                .declare_queryable(keys.topic_all(reset, "", ""))
                .callback(move |q| {
                    handle.spawn(super::reset_service::answer(
                        engine.clone(),
                        edge.clone(),
                        q,
                    ));
                })
                .await
                .map_err(zerr)?,
        );
    }
    // A publisher on every vehicle's output topic, never put on: its matching listener says whether
    // anyone subscribes (as the JSON estimates' outlets do).
    let watch = session
        .declare_publisher(keys.topic_all(
            &c.output_topic,
            &RosType::Imu.dds_name(),
            &RosType::Imu.hash(),
        ))
        .allowed_destination(Locality::Remote)
        .await
        .map_err(zerr)?;
    let anyone = crate::service::outlets::matching_flag(&watch).await?;
    let shared = Arc::new(Shared {
        session: session.clone(),
        zid: session.zid().to_string(),
        edge: edge.clone(),
        anyone,
        publications: Mutex::new(HashMap::new()),
    });
    edge.set_outlet(Box::new(Outlet(shared.clone())));
    let (stop, stopped) = tokio::sync::watch::channel(false);
    let announcements = edge.take_announcements();
    let graph = tokio::spawn(graph(shared, engine.clone(), announcements, stopped));
    tracing::info!(
        format = ?keys.format,
        domain = c.domain_id,
        inputs = ?edge.subscriptions(),
        "ros2 edge running"
    );
    Ok(Ros2Net {
        subscribers,
        queryables,
        watch,
        graph,
        stop,
    })
}

/// The node's tokens and each announced vehicle's, and `/diagnostics` every period, until stopped;
/// returns the tokens (undeclared by `stop`).
async fn graph(
    shared: Arc<Shared>,
    engine: Arc<Engine>,
    announcements: Option<tokio::sync::mpsc::UnboundedReceiver<String>>,
    mut stopped: tokio::sync::watch::Receiver<bool>,
) -> Vec<zenoh::liveliness::LivelinessToken> {
    let edge = shared.edge.clone();
    let c = edge.config.clone();
    let keys = edge.keys.clone();
    let rmw = keys.format == Ros2Format::RmwZenoh;
    let node = (c.node_namespace.as_str(), c.node_name.as_str());
    let mut tokens = Vec::new();
    let declare = |key: String| {
        let session = shared.session.clone();
        async move {
            match session.liveliness().declare_token(key.clone()).await {
                Ok(t) => Some(t),
                Err(e) => {
                    tracing::warn!(key, error = %e, "ros2: liveliness token not declared");
                    None
                }
            }
        }
    };
    let diag_hash = RosType::DiagnosticArray.hash();
    let diag_dds = RosType::DiagnosticArray.dds_name();
    let diagnostics = c.diagnostics_period_s.and_then(|_| {
        let token = keys.endpoint_token(
            &shared.zid,
            NODE_ID,
            DIAGNOSTICS_ID,
            Ros2Entity::Publisher,
            node,
            "/diagnostics",
            &diag_dds,
            &diag_hash,
            &c.publisher_qos,
        );
        let key = keys.global("/diagnostics", &diag_dds, &diag_hash);
        Some(Publication {
            key: zenoh::key_expr::KeyExpr::try_from(key).ok()?,
            eid: DIAGNOSTICS_ID,
            gid: gid_of(&token),
            token,
            seq: AtomicI64::new(1),
        })
    });
    let bridge = super::dds::bridge_id(&shared.zid);
    if let (false, Some(d)) = (rmw, &diagnostics) {
        tokens.extend(
            declare(super::dds::publisher_announcement(
                &bridge,
                d.key.as_str(),
                RosType::DiagnosticArray.name(),
                &diag_hash,
                super::dds::DIAGNOSTICS_DEPTH,
            ))
            .await,
        );
    }
    if rmw {
        let node_token = keys.node_token(&shared.zid, NODE_ID, node.0, node.1);
        tokens.extend(declare(node_token).await);
        if let Some(d) = &diagnostics {
            tokens.extend(declare(d.token.clone()).await);
        }
    }
    let diag_watch = match &diagnostics {
        Some(d) => shared
            .session
            .declare_publisher(d.key.clone())
            .allowed_destination(Locality::Remote)
            .await
            .ok(),
        None => None,
    };
    let mut announcements = announcements;
    let period = Duration::from_secs_f64(c.diagnostics_period_s.unwrap_or(3600.0));
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = stopped.changed() => break,
            v = async {
                match announcements.as_mut() {
                    Some(rx) => rx.recv().await,
                    None => std::future::pending().await,
                }
            } => {
                let Some(vehicle) = v else {
                    announcements = None;
                    continue;
                };
                if !rmw {
                    // The bridge's announcement of the vehicle's output (`dds.rs`): a bridge (or the
                    // plugin in this runtime) makes its DDS writer. The inputs' DDS readers come
                    // from the DDS side's publishers (the bridge matches their QoS: best effort or
                    // reliable, which one announced reader could not do for both).
                    let key = keys.topic(&vehicle, &c.output_topic, "", "");
                    let token = super::dds::publisher_announcement(
                        &bridge,
                        &key,
                        RosType::Imu.name(),
                        &RosType::Imu.hash(),
                        super::dds::ORIENTATION_DEPTH,
                    );
                    tokens.extend(declare(token).await);
                    if let Some(reset) = &c.reset_service {
                        let key = keys.topic(&vehicle, reset, "", "");
                        tokens.extend(declare(super::reset_service::server_announcement(&bridge, &key)).await);
                    }
                    continue;
                }
                // The vehicle's output publisher, and its input subscriptions.
                let Some(p) = shared.publication(&vehicle) else { continue };
                tokens.extend(declare(p.token.clone()).await);
                let (imu_id, mag_id) = (p.eid + 1, p.eid + 2);
                let mut inputs = vec![(imu_id, c.imu_topic.clone(), RosType::Imu)];
                if let Some(m) = &c.mag_topic {
                    inputs.push((mag_id, m.clone(), RosType::MagneticField));
                }
                for (eid, topic, ty) in inputs {
                    let token = keys.endpoint_token(
                        &shared.zid,
                        NODE_ID,
                        eid,
                        Ros2Entity::Subscription,
                        node,
                        &keys.topic_name(&vehicle, &topic),
                        &ty.dds_name(),
                        &ty.hash(),
                        &c.subscription_qos,
                    );
                    tokens.extend(declare(token).await);
                }
            }
            _ = tick.tick(), if diagnostics.is_some() => {
                let (Some(d), Some(w)) = (&diagnostics, &diag_watch) else { continue };
                if !w.matching_status().await.map(|s| s.matching()).unwrap_or(false) {
                    continue;
                }
                let cdr = diagnostic_array(&engine, &c.node_name).to_cdr();
                shared.put(d, cdr);
            }
        }
    }
    if let Some(w) = diag_watch {
        let _ = w.undeclare().await;
    }
    tokens
}

/// Each vehicle's health as `diagnostic_msgs/msg/DiagnosticStatus` (`proto/ros2.md`, "Diagnostics").
pub fn diagnostic_array(engine: &Engine, node: &str) -> DiagnosticArray {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0);
    let status = engine
        .vehicles()
        .iter()
        .map(|v| {
            let info = v.info();
            let snapshot = v.snapshot();
            let gap = snapshot.as_ref().and_then(|e| e.diagnostics.gyro_gap_s);
            let (level, message) = match (info.state.as_str(), gap) {
                ("tracking", None) => (0, "tracking".to_string()),
                ("tracking", Some(g)) => (1, format!("tracking, no gyro sample for {g:.2} s")),
                _ => (1, "initializing: no estimate yet".to_string()),
            };
            let mut values = vec![
                kv("filter", &info.filter),
                kv("state", &info.state),
                kv("received", &info.received.to_string()),
                kv("processed", &info.processed.to_string()),
                kv("rejected", &info.rejected.to_string()),
                kv("estimates", &info.estimates.to_string()),
            ];
            if let Some(t) = info.t {
                values.push(kv("t", &format!("{t:.6}")));
            }
            if let Some(e) = &snapshot {
                values.push(kv(
                    "sigma_deg",
                    &format!(
                        "{:.4} {:.4} {:.4}",
                        e.sigma_deg[0], e.sigma_deg[1], e.sigma_deg[2]
                    ),
                ));
                for (code, n) in &e.diagnostics.rejected {
                    values.push(kv(&format!("rejected.{code}"), &n.to_string()));
                }
            }
            DiagnosticStatus {
                level,
                name: format!("{node}: {}", v.id),
                message,
                hardware_id: v.id.clone(),
                values,
            }
        })
        .collect();
    DiagnosticArray {
        header: Header {
            stamp: Stamp::from_seconds(now),
            frame_id: String::new(),
        },
        status,
    }
}

fn kv(key: &str, value: &str) -> KeyValue {
    KeyValue {
        key: key.to_string(),
        value: value.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attachment_layout() {
        let a = attachment(7, -2, &[9; 16]);
        assert_eq!(a.len(), 33);
        assert_eq!(&a[..8], &7i64.to_le_bytes());
        assert_eq!(&a[8..16], &(-2i64).to_le_bytes());
        assert_eq!(a[16], 16);
        assert_eq!(&a[17..], &[9; 16]);
    }
}
