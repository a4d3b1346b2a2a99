//! The ROS 2 edge (`service.ros2`, `proto/ros2.md`, docs/ros2.md): `sensor_msgs/msg/Imu` (and
//! `MagneticField`) in, on rmw_zenoh's keys or zenoh-bridge-ros2dds', `sensor_msgs/msg/Imu` out with the
//! estimated orientation.
//!
//! Files: `msgs.rs` (the ROS 2 messages and their REP-2016 type hashes; an Imu into the same `ImuMsg`
//! as `P/V/imu`), `cdr.rs` (plain CDR: reader, writer), `keys.rs` (the edge's key expressions and
//! rmw_zenoh's liveliness tokens), `config.rs` (`service.ros2`), `edge.rs` (`Edge`, no zenoh: an
//! input's key and CDR to the domain sample on the engine's dispatcher thread, magnetometer pairing,
//! an estimate to `sensor_msgs/Imu`), `net.rs` (the zenoh side: subscriptions, publications with
//! rmw_zenoh's attachment, the graph's tokens, `/diagnostics`), `reset_service.rs` (the reset as a ROS
//! 2 service, std_srvs/Trigger), `dds.rs` (format "dds": zenoh-plugin-ros2dds's configuration, the
//! bridge's announcement tokens).

pub mod cdr;
pub mod config;
pub mod dds;
pub mod edge;
pub mod keys;
pub mod msgs;
pub mod net;
pub mod reset_service;

pub use config::{CovarianceFrame, RawRos2, Ros2Config};
pub use edge::{Edge, Ros2Input, Ros2Outlet, HASH_NOT_SUPPORTED};
pub use keys::{Ros2Entity, Ros2Format, Ros2Keys};
pub use msgs::*;
