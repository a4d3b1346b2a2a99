//! The network service: zenoh subscribers and queryables around the [`crate::engine::Engine`].
//!
//! `run(session, config, shutdown)` is the whole service, wired here: the outlets
//! ([`outlets`]), the engine with its fleet member and ROS 2 edge ([`Node`]), the inputs
//! ([`ingest`]), the ROS 2 edge on zenoh ([`crate::ros2::net`]), the route subscriptions and fleet
//! membership ([`crate::fleet::membership`]), the queryables ([`crate::query::queryables`]), then
//! one `select!` loop over the queries, the route plan and the shutdown signal. The rest of this
//! folder: the configuration ([`config`]), the zenoh session ([`session`]), the checkpoints
//! ([`persist`]). Subscriber callbacks only
//! hand raw samples to the engine's bounded ingest channel; filters run on the engine's worker
//! threads, never on zenoh's threads or the async runtime.

pub mod config;
pub mod ingest;
mod node;
pub mod outlets;
pub mod persist;
pub mod session;

pub use node::Node;

use crate::fleet::membership::{self, Routing};
use crate::fleet::FleetMode;
use crate::query::queryables::Queryables;
use crate::wire::keys::{Keys, Leaf};
use config::ServiceConfig;
use std::future::Future;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum ServiceError {
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error("HTTP (zenoh's REST plugin): {0}")]
    Http(String),
    #[error("state directory: {0}")]
    State(#[from] persist::CheckpointError),
}

pub(crate) fn zerr(e: impl std::fmt::Display) -> ServiceError {
    ServiceError::Zenoh(e.to_string())
}

/// Runs the service on `session` until `shutdown` resolves, then stops taking input, lets the workers
/// finish, and closes the session.
pub async fn run(
    session: zenoh::Session,
    config: ServiceConfig,
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServiceError> {
    let sink = outlets::sink(&session, Keys::new(&config.key_prefix));
    let (outlets, estimates_watch) = outlets::estimate_outlets(
        &session,
        &Keys::new(&config.key_prefix).with_vehicles(&config.fleet.vehicles),
    )
    .await?;
    let (node, threads) = Node::start_with(config, sink, outlets)?;
    let Node {
        engine,
        member,
        ros2,
    } = node;
    let keys = engine.keys.clone();

    // The inputs (`service::ingest`): AdvancedSubscribers for the publishers that number their
    // samples, plain subscribers for the others; every callback hands the raw sample to the engine.
    let intake = ingest::Intake::new(engine.clone(), threads.ingest.clone(), &session);
    let callback = {
        let intake = intake.clone();
        move |sample: zenoh::sample::Sample| intake.plain(sample)
    };
    let inputs = ingest::InputSubscriptions::declare(
        &session,
        &[Leaf::Gyro, Leaf::Vectors, Leaf::Imu].map(|l| keys.all(l)),
        &engine.config.ingest,
        &intake,
    )
    .await?;
    // The ROS 2 edge (service.ros2): its inputs go through the same callback. (Not routed: every
    // member of a fleet receives them, and the owner of the vehicle uses them.)
    let ros2 = match ros2 {
        Some(edge) => {
            Some(crate::ros2::net::start(&session, &engine, edge, callback.clone()).await?)
        }
        None => None,
    };
    // Routed inputs (`P/V/<leaf>/<r>`): a single instance takes every route; a member of a dynamic
    // fleet the routes it owns, and the standby batches of those it keeps, as they change (see
    // `membership::join_fleet`).
    let dynamic = engine.config.fleet.mode == FleetMode::Dynamic;
    let mut routing = Routing::new(keys.clone(), callback.clone());
    if !dynamic {
        routing
            .apply(&session, &membership::static_plan(&member))
            .await?;
    }
    let instance = engine.config.fleet.instance.clone();
    let mut queryables = Queryables::declare(&session, &keys, &instance).await?;
    // (Following the route plan before joining: the first change after the join comes from the
    // members' thread at any moment, and a receiver made after it would take it as seen, leaving the
    // routes taken over without their input subscriptions until the next change.)
    let mut plan = member.route_plan();
    let joined = if dynamic {
        Some(
            membership::join_fleet(&session, &engine, &member, &threads.tasks, &mut routing)
                .await?,
        )
    } else {
        None
    };
    tracing::info!(
        prefix = keys.prefix(),
        instance = %instance,
        fleet = engine.config.fleet.mode.as_str(),
        vehicles = keys.vehicle_pattern(),
        "attitude-service running"
    );

    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            _ = &mut shutdown => break,
            Ok(()) = membership::plan_changed(&mut plan) => routing.follow(&session, &mut plan).await,
            (i, q) = queryables.next() => {
                queryables.answer(&engine, &member, threads.ingest.len(), i, q).await
            }
        }
    }
    tracing::info!("shutting down");
    // Stop taking input first, then let the workers finish (their last estimates are published),
    // then leave the fleet (the others take over from those estimates and replay what they kept
    // since), then close the session.
    inputs.undeclare().await;
    if let Some(r) = ros2 {
        r.stop().await;
    }
    routing.close().await;
    queryables.undeclare().await;
    let _ = tokio::task::spawn_blocking(move || threads.shutdown()).await;
    let _ = estimates_watch.undeclare().await;
    if let Some(m) = joined {
        m.leave().await;
    }
    session.close().await.map_err(zerr)?;
    Ok(())
}
