//! The engine with the features plugged in: [`Node`] is what `service::run` wires to zenoh, and what
//! the tests drive without it. `Features` is the engine's [`Hooks`]: the fleet member says who owns a
//! vehicle, keeps what a standby keeps and batches the estimates its standby members need; the ROS 2
//! edge decodes its own topics and turns an estimate into `sensor_msgs/Imu`.

use super::config::ServiceConfig;
use super::persist::CheckpointError;
use crate::engine::{sink_outlets, Engine, EngineThreads, Hooks, Inbound, Outlets, Sink, Vehicle};
use crate::fleet::Member;
use crate::query;
use crate::ros2::Edge;
use crate::sensors::Measurement;
use crate::wire::keys::Leaf;
use crate::wire::{EstimateMsg, HealthMsg};
use std::collections::BTreeSet;
use std::sync::Arc;

/// An engine, its fleet member and its ROS 2 edge (when `service.ros2` enables it).
#[derive(Clone)]
pub struct Node {
    pub engine: Arc<Engine>,
    pub member: Arc<Member>,
    pub ros2: Option<Arc<Edge>>,
}

impl Node {
    /// [`Node::start_with`] where every estimate is wanted and goes to `sink` too.
    pub fn start(
        config: ServiceConfig,
        sink: Sink,
    ) -> Result<(Node, EngineThreads), CheckpointError> {
        let outlets = sink_outlets(&sink);
        Node::start_with(config, sink, outlets)
    }

    /// Makes the fleet member and the ROS 2 edge of `config`, and starts the engine with them as its
    /// hooks ([`Engine::start`]): estimates go to each vehicle's outlet of `outlets`, everything else
    /// (rejections, the batches of estimates for standby members) to `sink`.
    pub fn start_with(
        config: ServiceConfig,
        sink: Sink,
        outlets: Outlets,
    ) -> Result<(Node, EngineThreads), CheckpointError> {
        let member = Arc::new(Member::new(&config, sink.clone()));
        let ros2 = config
            .ros2
            .enabled
            .then(|| Arc::new(Edge::new(config.ros2.clone(), config.limits.max_vehicles)));
        let hooks = Arc::new(Features {
            member: member.clone(),
            ros2: ros2.clone(),
        });
        let (engine, threads) = Engine::start(config, sink, outlets, hooks)?;
        Ok((
            Node {
                engine,
                member,
                ros2,
            },
            threads,
        ))
    }

    /// `P/@/health`.
    pub fn health(&self) -> HealthMsg {
        query::health(&self.engine, &self.member)
    }

    /// `P/@/metrics`, as OpenMetrics text (`ingest_depth`: raw samples waiting in the ingest
    /// channel).
    pub fn metrics_text(&self, ingest_depth: usize) -> String {
        query::metrics_text(&self.engine, &self.member, ingest_depth)
    }

    /// Tells the fleet member the live members, on the engine's dispatcher thread in order with the
    /// inputs.
    pub fn set_members(&self, threads: &EngineThreads, members: BTreeSet<String>) {
        let _ = threads.tasks.send(self.member.members_task(members));
    }
}

/// The engine's hooks: the fleet member and the ROS 2 edge.
struct Features {
    member: Arc<Member>,
    ros2: Option<Arc<Edge>>,
}

impl Hooks for Features {
    fn owns(&self, vehicle: &str) -> bool {
        self.member.owns(vehicle)
    }

    fn not_owned(&self, engine: &Engine, vehicle: &str, inbound: Inbound) {
        self.member.keep_standby(engine, vehicle, inbound);
    }

    fn used_before(&self, engine: &Engine, vehicle: &str, leaf: Leaf, payload: &[u8]) -> bool {
        self.member.used_before(engine, vehicle, leaf, payload)
    }

    fn other_input(
        &self,
        engine: &Engine,
        inbound: Inbound,
        decoded: &mut Vec<Measurement>,
        touched: &mut Vec<Arc<Vehicle>>,
    ) {
        let Err(inbound) = self.member.standby_batch(engine, inbound, decoded, touched) else {
            return;
        };
        if let Some(v) = self
            .ros2
            .as_ref()
            .and_then(|edge| edge.dispatch(engine, inbound, decoded))
        {
            touched.push(v);
        }
    }

    fn vehicle_of<'a>(&self, key: &'a str) -> Option<&'a str> {
        self.ros2
            .as_ref()
            .and_then(|edge| edge.route(key))
            .map(|(v, ..)| v)
    }

    fn wants_bytes(&self, vehicle: &str) -> bool {
        self.member.has_standby(vehicle)
    }

    fn on_estimate(&self, vehicle: &str, estimate: &EstimateMsg, bytes: Option<&[u8]>) {
        if let Some(edge) = &self.ros2 {
            edge.on_estimate(vehicle, estimate);
        }
        if let Some(bytes) = bytes {
            if self.member.has_standby(vehicle) {
                self.member.batch_estimate(vehicle, bytes);
            }
        }
    }

    fn housekeeping(&self, engine: &Engine) {
        self.member.housekeeping(engine);
    }

    fn period_s(&self) -> f64 {
        self.member.housekeeping_period_s()
    }

    fn on_shutdown(&self, engine: &Engine) {
        self.member.flush_estimates(engine);
    }
}
