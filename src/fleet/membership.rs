//! Fleet membership on the network: the route subscriptions that follow the member's `RoutePlan`,
//! and a dynamic fleet's liveliness token and the subscriber that follows the other members. (Who
//! owns which route is `assignment.rs`; the takeovers are `member.rs`'s.)

use super::assignment::Assignment;
use super::member::{Member, RoutePlan};
use crate::engine::{Engine, Task};
use crate::service::{zerr, ServiceError};
use crate::wire::keys::{Keys, ROUTES};
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::watch;
use zenoh::sample::Locality;

/// The routes an instance outside a dynamic fleet serves: those of its route set (`fleet.routes`,
/// every route unless sharded by route), and no standby.
pub fn static_plan(member: &Member) -> RoutePlan {
    RoutePlan {
        owned: (0..ROUTES as u8).filter(|&r| member.serves(r)).collect(),
        standby: Vec::new(),
    }
}

/// Resolves when `plan` changes (never without one: outside a dynamic fleet).
pub async fn plan_changed(
    plan: &mut Option<watch::Receiver<RoutePlan>>,
) -> Result<(), watch::error::RecvError> {
    match plan.as_mut() {
        Some(p) => p.changed().await,
        None => std::future::pending().await,
    }
}

/// The subscriptions that follow the routes: the routed inputs of each route owned (one for all when
/// every route is), the standby batches of each route kept (one for all when more than half are).
pub struct Routing<F> {
    keys: Keys,
    callback: F,
    /// By route; `None`: every route.
    owned: BTreeMap<Option<u8>, zenoh::pubsub::Subscriber<()>>,
    standby: BTreeMap<Option<u8>, zenoh::pubsub::Subscriber<()>>,
}

impl<F> Routing<F>
where
    F: Fn(zenoh::sample::Sample) + Clone + Send + Sync + 'static,
{
    pub fn new(keys: Keys, callback: F) -> Self {
        Routing {
            keys,
            callback,
            owned: BTreeMap::new(),
            standby: BTreeMap::new(),
        }
    }

    /// Subscribes to what `plan` needs and no more: the new subscriptions first, then the old ones
    /// undeclared, so that nothing in both is missed in between.
    pub async fn apply(
        &mut self,
        session: &zenoh::Session,
        plan: &RoutePlan,
    ) -> Result<(), ServiceError> {
        let want = |routes: &[u8], all_when: usize| -> BTreeSet<Option<u8>> {
            if routes.is_empty() {
                BTreeSet::new()
            } else if routes.len() >= all_when {
                BTreeSet::from([None])
            } else {
                routes.iter().map(|&r| Some(r)).collect()
            }
        };
        // (Every subscription of a session is matched against every sample it receives, so fewer is
        // cheaper; but a route's batches carry all its inputs, so taking those of routes not kept
        // costs more than it saves unless few are (measured: scripts/fleet-cpu.py). A member keeping
        // more than half of the routes takes every route's batches and drops the others; each
        // route's inputs stay on their own subscription.)
        let owned = want(&plan.owned, ROUTES);
        let standby = want(&plan.standby, ROUTES / 2 + 1);
        for (wanted, have, standby_batches) in [
            (&owned, &mut self.owned, false),
            (&standby, &mut self.standby, true),
        ] {
            for &r in wanted {
                if have.contains_key(&r) {
                    continue;
                }
                let key = if standby_batches {
                    self.keys.standby(r)
                } else {
                    self.keys.routed_inputs(r)
                };
                let sub = session
                    .declare_subscriber(key)
                    // (Not this instance's own batches of estimates.)
                    .allowed_origin(Locality::Remote)
                    .callback(self.callback.clone())
                    .await
                    .map_err(zerr)?;
                have.insert(r, sub);
            }
            let gone: Vec<Option<u8>> = have
                .keys()
                .filter(|r| !wanted.contains(r))
                .copied()
                .collect();
            for r in gone {
                if let Some(sub) = have.remove(&r) {
                    let _ = sub.undeclare().await;
                }
            }
        }
        tracing::debug!(owned = ?plan.owned, standby = ?plan.standby, "route subscriptions");
        Ok(())
    }

    /// Follows `plan` to its latest value.
    pub async fn follow(
        &mut self,
        session: &zenoh::Session,
        plan: &mut Option<watch::Receiver<RoutePlan>>,
    ) {
        let now = plan
            .as_mut()
            .map(|p| p.borrow_and_update().clone())
            .unwrap_or_default();
        // (A declaration that fails now is tried again at the next change; the batches of a
        // route cover its inputs meanwhile.)
        if let Err(e) = self.apply(session, &now).await {
            tracing::error!(error = %e, "route subscriptions not updated");
        }
    }

    pub async fn close(self) {
        for (_, sub) in self.owned.into_iter().chain(self.standby) {
            let _ = sub.undeclare().await;
        }
    }
}

/// The liveliness token that makes this instance a member, and the subscriber that follows the
/// others.
pub struct Membership {
    token: zenoh::liveliness::LivelinessToken,
    watcher: zenoh::pubsub::Subscriber<()>,
}

impl Membership {
    /// Leaves the fleet (after the workers have finished: the others take over from their last
    /// estimates and replay what they kept since).
    pub async fn leave(self) {
        // (Lets the last estimates reach the others before the token's removal does.)
        tokio::time::sleep(Duration::from_millis(100)).await;
        let _ = self.watcher.undeclare().await;
        let _ = self.token.undeclare().await;
    }
}

/// Joins the dynamic fleet: finds the live members, subscribes to what it will own and hold once it
/// has joined, reads the current estimates of those routes' vehicles (so the vehicles it takes start
/// where their owners are), declares this instance's token, and follows the members from then on.
/// The engine releases and takes over routes on each change.
pub async fn join_fleet<F>(
    session: &zenoh::Session,
    engine: &Arc<Engine>,
    member: &Arc<Member>,
    tasks: &crossbeam_channel::Sender<Task>,
    routing: &mut Routing<F>,
) -> Result<Membership, ServiceError>
where
    F: Fn(zenoh::sample::Sample) + Clone + Send + Sync + 'static,
{
    let f = &engine.config.fleet;
    let keys = &engine.keys;
    let timeout = Duration::from_secs_f64(f.discovery_timeout_s);
    let members = Arc::new(std::sync::Mutex::new(BTreeSet::from([f.instance.clone()])));
    let replies = session
        .liveliness()
        .get(keys.fleet_members(&f.group))
        .timeout(timeout)
        .await
        .map_err(zerr)?;
    while let Ok(r) = replies.recv_async().await {
        if let Ok(sample) = r.result() {
            if let Some(name) = keys.member_of(&f.group, sample.key_expr().as_str()) {
                members
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .insert(name.to_string());
            }
        }
    }
    // What this instance will own and hold: subscribed to (and kept) from now on.
    let joining = members.lock().unwrap_or_else(|e| e.into_inner()).clone();
    member.prepare(engine, &joining);
    if let Some(plan) = member.route_plan() {
        let plan = plan.borrow().clone();
        routing.apply(session, &plan).await?;
    }
    if joining.len() > 1 {
        // The current estimates of the vehicles of the routes it will hold: the starting points of
        // what it takes.
        let held: Vec<u8> = Assignment::of_routes(&joining, f.routes)
            .map(|a| a.held_by(&f.instance))
            .unwrap_or_default()
            .into_iter()
            .filter(|&r| member.serves(r))
            .collect();
        let replies = session
            .get(keys.states_of_routes(&held))
            .consolidation(zenoh::query::ConsolidationMode::None)
            .timeout(timeout)
            .await
            .map_err(zerr)?;
        while let Ok(r) = replies.recv_async().await {
            if let Ok(sample) = r.result() {
                if let Some((vehicle, _)) = keys.split(sample.key_expr().as_str()) {
                    member.remember_estimate(vehicle, &sample.payload().to_bytes());
                }
            }
        }
    }
    let token = session
        .liveliness()
        .declare_token(keys.fleet_member(&f.group, &f.instance))
        .await
        .map_err(zerr)?;
    let watcher = {
        let members = members.clone();
        let tx = tasks.clone();
        let member = member.clone();
        let keys = keys.clone();
        let group = f.group.clone();
        let me = f.instance.clone();
        session
            .liveliness()
            .declare_subscriber(keys.fleet_members(&group))
            .history(true)
            .callback(move |sample: zenoh::sample::Sample| {
                let Some(name) = keys.member_of(&group, sample.key_expr().as_str()) else {
                    return;
                };
                let mut m = members.lock().unwrap_or_else(|e| e.into_inner());
                match sample.kind() {
                    zenoh::sample::SampleKind::Put => m.insert(name.to_string()),
                    zenoh::sample::SampleKind::Delete if name != me => m.remove(name),
                    _ => false,
                };
                let _ = tx.send(member.members_task(m.clone()));
            })
            .await
            .map_err(zerr)?
    };
    let initial = members.lock().unwrap_or_else(|e| e.into_inner()).clone();
    tracing::info!(instance = %f.instance, members = ?initial, "joined the fleet");
    let _ = tasks.send(member.members_task(initial));
    Ok(Membership { token, watcher })
}
