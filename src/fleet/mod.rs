//! A fleet of service instances that share the vehicles (`service.fleet`, DEPLOYMENT.md): which member
//! owns which route, what the others keep to take over, and how senders feed them.
//!
//! Files: `assignment.rs` (the fleet's configuration, route sets, and `Assignment`: every route's owner
//! and holders for a member list), `member.rs` (`Member`: this instance's side, the engine's ownership
//! and standby hooks, the takeovers and the owner's batches of estimates), `membership.rs` (on zenoh:
//! the route subscriptions that follow the `RoutePlan`, the liveliness token and the watch on the
//! other members), `batch.rs` (the binary format of the standby batches), `sender.rs` (how a sender
//! feeds a fleet: routed keys and standby batches).

pub mod assignment;
pub mod batch;
pub mod member;
pub mod membership;
pub mod sender;

pub use assignment::{
    default_instance_name, owner, parse_routes, routes_text, Assignment, FleetConfig, FleetMode,
    ALL_ROUTES,
};
pub use member::{Member, RoutePlan, TAKEOVER_GRACE_S};
