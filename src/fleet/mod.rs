//! A fleet of service instances that share the vehicles (`service.fleet`, DEPLOYMENT.md): which member
//! owns which route, what the others keep to take over, and how senders feed them.
//!
//! Files: `assignment.rs` (the fleet's configuration, route sets, and `Assignment`: every route's owner
//! and holders for a member list), `member.rs` (`Member`: this instance's side: ownership, the route plan,
//! the owner's batches of estimates), `standby.rs` (what it keeps for the routes it holds but does not
//! own), `takeover.rs` (a change of members: the vehicles released and taken over), `membership.rs` (on zenoh:
//! the route subscriptions that follow the `RoutePlan`, the liveliness token and the watch on the
//! other members), `batch.rs` (the binary format of the standby batches), `sender.rs` (how a sender
//! feeds a fleet: routed keys and standby batches).

pub mod assignment;
pub mod batch;
pub mod member;
pub mod membership;
pub mod sender;
mod standby;
mod takeover;

pub use assignment::{
    default_instance_name, owner, parse_routes, routes_text, Assignment, FleetConfig, FleetMode,
    ALL_ROUTES,
};
pub use member::{Member, RoutePlan};
pub use takeover::TAKEOVER_GRACE_S;
