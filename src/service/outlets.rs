//! The service's outputs: the sink the workers put rejections and standby batches through, and each
//! vehicle's estimate outlet, put only while someone listens.

use super::{zerr, ServiceError};
use crate::engine::{EstimateOutlet, Outlets, Sink};
use crate::wire::keys::{Keys, Leaf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;
use zenoh::Wait;

/// A flag that says whether any subscriber matches `publisher` (a publisher declared for this alone,
/// never put on): work for an outlet nobody listens to is skipped.
pub(crate) async fn matching_flag(
    publisher: &zenoh::pubsub::Publisher<'_>,
) -> Result<Arc<AtomicBool>, ServiceError> {
    let anyone = Arc::new(AtomicBool::new(false));
    let flag = anyone.clone();
    // (Called at once with the current status when it matches, then at each change.)
    publisher
        .matching_listener()
        .callback(move |s| flag.store(s.matching(), Ordering::Relaxed))
        .background()
        .await
        .map_err(zerr)?;
    Ok(anyone)
}

/// What the workers put besides estimates, on `session`.
pub(super) fn sink(session: &zenoh::Session, keys: Keys) -> Sink {
    let publisher = session.clone();
    // Outputs are put from the worker threads (plain threads, so the synchronous `wait` is right);
    // `Block` applies back-pressure instead of silently dropping estimates. Not `express`: zenoh then
    // batches the messages that queue up while the link is busy (one write for many under load, the
    // same latency when idle) instead of a system call per message. Rejections are JSON; a fleet
    // owner's batches of estimates for its standby members are binary (`fleet::batch`).
    Arc::new(move |key: &str, payload: Vec<u8>| {
        let encoding = if keys.is_standby(key) {
            Encoding::APPLICATION_OCTET_STREAM
        } else {
            Encoding::APPLICATION_JSON
        };
        if let Err(e) = publisher
            .put(key, payload)
            .encoding(encoding)
            .congestion_control(CongestionControl::Block)
            .wait()
        {
            tracing::warn!(key, error = %e, "put failed");
        }
    })
}

/// Each vehicle's estimates, put on `P/V/estimate` (its key checked once, not at every put) while
/// any subscriber of another session matches `P/*/estimate` (this session's own, a fleet member's
/// follower of the others' estimates, takes none of them): a publisher declared on that
/// wildcard, never put on, has its matching listener keep one flag, and while it is down the engine
/// does not serialise estimates (queries still answer the last one). One publisher for all: a
/// declared publisher per vehicle would give each vehicle's put its own cached route and match, but
/// zenoh 1.10 then resolves every other, undeclared key (every input the vehicles put) against all
/// those declarations, and the service's receiving thread drowned in it (BENCHMARKS.md, issue 15).
/// Puts block under congestion rather than drop.
pub async fn estimate_outlets(
    session: &zenoh::Session,
    keys: &Keys,
) -> Result<(Outlets, zenoh::pubsub::Publisher<'static>), ServiceError> {
    struct Vehicle {
        session: zenoh::Session,
        key: KeyExpr<'static>,
        anyone: Arc<AtomicBool>,
    }
    impl EstimateOutlet for Vehicle {
        fn wanted(&self) -> bool {
            self.anyone.load(Ordering::Relaxed)
        }
        fn put(&self, payload: Vec<u8>) {
            let put = self
                .session
                .put(self.key.clone(), payload)
                .encoding(Encoding::APPLICATION_JSON)
                .congestion_control(CongestionControl::Block)
                .allowed_destination(Locality::Remote);
            if let Err(e) = put.wait() {
                tracing::warn!(key = %self.key, error = %e, "put failed");
            }
        }
    }
    let watch = session
        .declare_publisher(keys.all(Leaf::Estimate))
        .allowed_destination(Locality::Remote)
        .await
        .map_err(zerr)?;
    let anyone = matching_flag(&watch).await?;
    let session = session.clone();
    let outlets: Outlets = Arc::new(move |key: &str| match KeyExpr::try_from(key.to_string()) {
        Ok(key) => Box::new(Vehicle {
            session: session.clone(),
            key,
            anyone: anyone.clone(),
        }) as Box<dyn EstimateOutlet>,
        Err(e) => {
            // (Vehicle ids are validated before a vehicle exists: not reached.)
            tracing::error!(key, error = %e, "not a key expression; its estimates are not put");
            Box::new(Nowhere)
        }
    });
    Ok((outlets, watch))
}

/// An outlet that nobody can reach.
struct Nowhere;

impl EstimateOutlet for Nowhere {
    fn wanted(&self) -> bool {
        false
    }
    fn put(&self, _: Vec<u8>) {}
}
