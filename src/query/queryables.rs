//! The service's queryables: declared from one table, answered on the service's loop one query at a
//! time (a reset in a task of its own), undeclared in the table's order. The reads behind them are
//! `reads.rs` and `metrics.rs`; here is their zenoh side: which key each reply goes on, its
//! encoding, and the error replies.

use super::metrics::{metrics_text, METRICS_ENCODING};
use super::reads;
use crate::engine::Engine;
use crate::fleet::Member;
use crate::service::{zerr, ServiceError};
use crate::wire::keys::{self, route_of, Keys, Leaf};
use crate::wire::{decode_one, ErrorMsg, RejectCode, Rejection, ResetMsg};
use serde::Serialize;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::task::Poll;
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::handlers::FifoChannelHandler;
use zenoh::key_expr::KeyExpr;
use zenoh::query::{Query, Queryable};

/// How long a reset waits for the vehicle's worker.
const RESET_TIMEOUT: Duration = Duration::from_secs(10);

/// What answers a queryable.
enum Answer {
    Attitude,
    Covariance,
    State,
    Reset,
    Vehicles,
    Health,
    Metrics,
}

/// Every queryable of the service, as (key expression, answer), in the order they are declared and
/// undeclared. (Replies go on the concrete key: a get on P/@/instance/*/health gets one per
/// instance.)
fn table(keys: &Keys, instance: &str) -> [(String, Answer); 10] {
    [
        (keys.all(Leaf::Attitude), Answer::Attitude),
        (keys.all(Leaf::Covariance), Answer::Covariance),
        (keys.all(Leaf::State), Answer::State),
        (keys.all(Leaf::Reset), Answer::Reset),
        (keys.vehicles(), Answer::Vehicles),
        (keys.health(), Answer::Health),
        (keys.instance_health(instance), Answer::Health),
        (keys.instance_vehicles(instance), Answer::Vehicles),
        (keys.metrics(), Answer::Metrics),
        (keys.instance_metrics(instance), Answer::Metrics),
    ]
}

/// The declared queryables, each with its key expression and what answers it.
pub struct Queryables {
    declared: Vec<(String, Answer, Queryable<FifoChannelHandler<Query>>)>,
    /// The queryable the next wait looks at first, so that a busy one does not starve the others.
    first: usize,
}

impl Queryables {
    /// Declares the table's queryables of `keys` for this `instance`.
    pub async fn declare(
        session: &zenoh::Session,
        keys: &Keys,
        instance: &str,
    ) -> Result<Self, ServiceError> {
        let mut declared = Vec::new();
        for (key, answer) in table(keys, instance) {
            let queryable = session.declare_queryable(key.clone()).await.map_err(zerr)?;
            declared.push((key, answer, queryable));
        }
        Ok(Queryables { declared, first: 0 })
    }

    /// The next query that comes to any of them, and which one it came to. (A queryable whose
    /// channel is closed is passed over.)
    pub async fn next(&mut self) -> (usize, Query) {
        let n = self.declared.len();
        let first = self.first;
        let mut waiting: Vec<_> = self
            .declared
            .iter()
            .map(|(_, _, queryable)| Some(queryable.recv_async()))
            .collect();
        let (i, query) = std::future::poll_fn(|cx| {
            for i in (first..n).chain(0..first) {
                let Some(recv) = waiting[i].as_mut() else {
                    continue;
                };
                match Pin::new(recv).poll(cx) {
                    Poll::Ready(Ok(query)) => return Poll::Ready((i, query)),
                    Poll::Ready(Err(_)) => waiting[i] = None,
                    Poll::Pending => {}
                }
            }
            Poll::Pending
        })
        .await;
        self.first = (i + 1) % n;
        (i, query)
    }

    /// Answers `q`, which came to the `i`-th queryable.
    /// (`ingest_depth`: raw samples waiting in the ingest channel, for `P/@/metrics`.)
    pub async fn answer(
        &self,
        engine: &Arc<Engine>,
        member: &Arc<Member>,
        ingest_depth: usize,
        i: usize,
        q: Query,
    ) {
        let (key, answer, _) = &self.declared[i];
        match answer {
            Answer::Attitude => {
                per_vehicle(engine, &q, Leaf::Attitude, |e, v| {
                    reads::attitude_of(e, v).map(|a| json(&a))
                })
                .await
            }
            Answer::Covariance => {
                per_vehicle(engine, &q, Leaf::Covariance, |e, v| {
                    reads::covariance_of(e, v).map(|c| json(&c))
                })
                .await
            }
            Answer::State => {
                per_vehicle(engine, &q, Leaf::State, |e, v| {
                    reads::state_of(e, v).map(|s| json(&*s))
                })
                .await
            }
            Answer::Reset => {
                // A reset waits for the vehicle's worker: answer it in its own task.
                let engine = engine.clone();
                tokio::spawn(async move { reset(&engine, q).await });
            }
            Answer::Vehicles => vehicles(engine, &q, key).await,
            Answer::Health => health(engine, member, &q, key).await,
            Answer::Metrics => metrics(engine, member, ingest_depth, &q, key).await,
        }
    }

    /// Undeclares them, in the table's order.
    pub async fn undeclare(self) {
        for (_, _, queryable) in self.declared {
            let _ = queryable.undeclare().await;
        }
    }
}

async fn vehicles(engine: &Engine, q: &Query, key: &str) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    reply(q, key, json(&reads::vehicles(engine))).await;
}

async fn health(engine: &Engine, member: &Member, q: &Query, key: &str) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    reply(q, key, json(&reads::health(engine, member))).await;
}

/// `P/@/metrics`: encoded off the async runtime's threads (it walks every vehicle).
async fn metrics(
    engine: &Arc<Engine>,
    member: &Arc<Member>,
    ingest_depth: usize,
    q: &Query,
    key: &str,
) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    let (e, m) = (engine.clone(), member.clone());
    let text = tokio::task::spawn_blocking(move || metrics_text(&e, &m, ingest_depth))
        .await
        .unwrap_or_default();
    if let Err(e) = q
        .reply(key, text)
        .encoding(Encoding::from(METRICS_ENCODING))
        .await
    {
        tracing::warn!(key, error = %e, "reply failed");
    }
}

fn json<T: Serialize + ?Sized>(value: &T) -> Vec<u8> {
    serde_json::to_vec(value).unwrap_or_else(|e| {
        format!(r#"{{"code":"internal","message":"cannot serialise: {e}","key":""}}"#).into_bytes()
    })
}

async fn reply(q: &Query, key: &str, payload: Vec<u8>) {
    if let Err(e) = q
        .reply(key, payload)
        .encoding(Encoding::APPLICATION_JSON)
        .await
    {
        tracing::warn!(key, error = %e, "reply failed");
    }
}

async fn reply_err(q: &Query, r: &Rejection) {
    let msg: ErrorMsg = crate::wire::ToMessage::to_message(r, q.key_expr().as_str());
    if let Err(e) = q
        .reply_err(json(&msg))
        .encoding(Encoding::APPLICATION_JSON)
        .await
    {
        tracing::warn!(error = %e, "error reply failed");
    }
}

/// A get on `P/V/<leaf>`: one vehicle (an error when it is unknown or has no estimate), or, when the
/// vehicle chunk is a wildcard, one reply per matching vehicle that has an estimate, each on its
/// concrete key.
async fn per_vehicle(
    engine: &Engine,
    q: &Query,
    leaf: Leaf,
    answer: impl Fn(&Engine, &str) -> Result<Vec<u8>, Rejection>,
) {
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    let asked = q.key_expr().clone();
    if let Some((vehicle, _)) = engine.keys.split(asked.as_str()) {
        if !vehicle.contains(['*', '$']) {
            if !engine.owns(vehicle) {
                // Another member of the fleet answers (the query is finalised without a reply).
                return;
            }
            match answer(engine, vehicle) {
                Ok(payload) => reply(q, asked.as_str(), payload).await,
                Err(r) => {
                    engine.counters.reject(r.code);
                    reply_err(q, &r).await
                }
            }
            return;
        }
    }
    // `?routes=07a`: only the vehicles of these routes (a joining fleet member's get).
    let routes: Option<Vec<u8>> = q.parameters().get("routes").map(|s| {
        s.chars()
            .filter_map(|c| keys::parse_route(&c.to_string()))
            .collect()
    });
    for v in engine.vehicles() {
        if routes
            .as_ref()
            .is_some_and(|r| !r.contains(&route_of(&v.id)))
        {
            continue;
        }
        let key = engine.keys.vehicle(&v.id, leaf);
        let matches = KeyExpr::try_from(key.as_str())
            .map(|k| k.intersects(&asked))
            .unwrap_or(false);
        if matches {
            if let Ok(payload) = answer(engine, &v.id) {
                reply(q, &key, payload).await;
            }
        }
    }
}

async fn reset(engine: &Engine, q: Query) {
    let key = q.key_expr().as_str().to_string();
    // Another member of the fleet owns this vehicle and answers (a wildcard is refused by one).
    if let Some((vehicle, _)) = engine.keys.split(&key) {
        if !engine.owns(vehicle) {
            return;
        }
    }
    engine.counters.queries.fetch_add(1, Ordering::Relaxed);
    let fail = |code: RejectCode, m: String| Rejection::new(code, m);
    let result: Result<Vec<u8>, Rejection> = async {
        let (vehicle, _) = engine
            .keys
            .split(&key)
            .filter(|(v, _)| !v.contains(['*', '$']))
            .ok_or_else(|| {
                fail(
                    RejectCode::BadRequest,
                    "reset one vehicle at a time: P/V/reset with a concrete V".into(),
                )
            })?;
        let req: ResetMsg = match q.payload() {
            Some(p) if !p.is_empty() => decode_one(&p.to_bytes(), &engine.config.limits.input)?,
            _ => ResetMsg::default(),
        };
        let rx = engine.request_reset(vehicle, req)?;
        match tokio::time::timeout(RESET_TIMEOUT, rx).await {
            Ok(Ok(Ok(reply))) => Ok(json(&reply)),
            Ok(Ok(Err(r))) => Err(r),
            Ok(Err(_)) | Err(_) => Err(fail(
                RejectCode::Internal,
                "the vehicle's worker did not answer the reset".into(),
            )),
        }
    }
    .await;
    match result {
        Ok(payload) => reply(&q, &key, payload).await,
        Err(r) => {
            engine.counters.reject(r.code);
            reply_err(&q, &r).await
        }
    }
}
