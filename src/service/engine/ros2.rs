//! The engine's hooks for the ROS 2 edge (`service::ros2`): its inputs decoded on the dispatcher
//! thread into the same measurements as `P/V/imu`, then queued by the same path.

use super::*;

impl Engine {
    /// The ROS 2 edge, when enabled.
    pub fn ros2(&self) -> Option<&Arc<crate::service::ros2::Edge>> {
        self.ros2.as_ref()
    }

    /// An input on a key of the ROS 2 edge (dispatcher thread); `None` for any other key. A
    /// magnetometer message queues nothing: it waits for the IMU sample it goes with.
    pub(super) fn dispatch_ros2(
        &self,
        inbound: Inbound,
        decoded: &mut Vec<Measurement>,
    ) -> Option<Arc<Vehicle>> {
        let edge = self.ros2.as_ref()?;
        let (vehicle, input, ty, hash) = edge.route(&inbound.key)?;
        // (Another member's vehicle: nothing kept. ROS 2 inputs are not routed, every member of a
        // fleet receives them, and a takeover replays only the JSON leaves' inputs: a vehicle fed over
        // ROS continues on its new owner from the last estimate and the ROS inputs from then on.)
        if !self.owns(vehicle) {
            return None;
        }
        let limits = &self.config.limits.input;
        let result = edge.decode(vehicle, input, ty, hash, &inbound.payload, limits, decoded);
        match result {
            Ok(0) => None,
            result => self.queue(vehicle, &inbound.key, result, decoded),
        }
    }
}
