//! The service's outputs: the sink the workers put rejections and standby batches through, and each
//! vehicle's estimate outlet, put only while someone listens.

use super::{zerr, ServiceError};
use crate::engine::{EstimateOutlet, Outlets, Sink};
use crate::wire::keys::{Keys, Leaf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Instant;
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

/// A vehicle whose estimates come this fast gets a publisher of its own once it has put this many.
const DECLARE_AFTER_PUTS: u64 = 256;
const DECLARE_MIN_RATE_HZ: f64 = 50.0;
/// At most this many vehicles of one service get one.
const MAX_DECLARED: usize = 64;

/// Each vehicle's estimates, put on `P/V/estimate` (its key checked once, not at every put) while
/// any subscriber of another session matches `P/*/estimate` (this session's own, a fleet member's
/// follower of the others' estimates, takes none of them): a publisher declared on that
/// wildcard, never put on, has its matching listener keep one flag, and while it is down the engine
/// does not serialise estimates (queries still answer the last one).
///
/// A put on an undeclared key has zenoh compute the key's route at every put (under 100 raw IMU
/// samples per message, an estimate each, that was 29% of the service's CPU, and the put 42%:
/// BENCHMARKS.md, issue 30). A declared publisher keeps its route. zenoh 1.10.2 as published then
/// resolved every other undeclared key (every input the vehicles put) against all the declarations,
/// and with one per vehicle of a thousand the service's receiving thread drowned in it (issue 15);
/// the vendored zenoh looks the key up instead (vendor/README.md), so that cliff is gone, and a
/// publisher for each of a thousand 10 Hz vehicles saves only a few per cent. So the vehicles that
/// publish fast (at least `DECLARE_MIN_RATE_HZ` over their first `DECLARE_AFTER_PUTS` estimates: raw
/// IMU streams) get a publisher of their own, at most `MAX_DECLARED` of them (the session still
/// scans its own declarations at each one), and the rest put on the session. Puts block under
/// congestion rather than drop.
pub async fn estimate_outlets(
    session: &zenoh::Session,
    keys: &Keys,
) -> Result<(Outlets, zenoh::pubsub::Publisher<'static>), ServiceError> {
    struct Vehicle {
        session: zenoh::Session,
        key: KeyExpr<'static>,
        anyone: Arc<AtomicBool>,
        declared: Arc<AtomicUsize>,
        /// Puts so far and the time of the first (for the rate), then the publisher once declared.
        puts: AtomicU64,
        first: OnceLock<Instant>,
        publisher: OnceLock<zenoh::pubsub::Publisher<'static>>,
    }
    impl Vehicle {
        /// Declares the vehicle's own publisher when its estimates have come fast enough and the
        /// service has room for one more (once; a failed declaration keeps the session's puts).
        fn count_put(&self) {
            let first = *self.first.get_or_init(Instant::now);
            if self.puts.fetch_add(1, Ordering::Relaxed) + 1 != DECLARE_AFTER_PUTS {
                return;
            }
            let rate = DECLARE_AFTER_PUTS as f64 / first.elapsed().as_secs_f64().max(1e-9);
            if rate < DECLARE_MIN_RATE_HZ
                || self
                    .declared
                    .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| {
                        (n < MAX_DECLARED).then_some(n + 1)
                    })
                    .is_err()
            {
                return;
            }
            match self
                .session
                .declare_publisher(self.key.clone())
                .encoding(Encoding::APPLICATION_JSON)
                .congestion_control(CongestionControl::Block)
                .allowed_destination(Locality::Remote)
                .wait()
            {
                Ok(p) => {
                    tracing::debug!(key = %self.key, rate, "estimates on a declared publisher");
                    let _ = self.publisher.set(p);
                }
                Err(e) => {
                    self.declared.fetch_sub(1, Ordering::Relaxed);
                    tracing::warn!(key = %self.key, error = %e, "cannot declare a publisher; putting on the session");
                }
            }
        }
    }
    impl Drop for Vehicle {
        /// A vehicle removed gives its place back (zenoh undeclares its publisher as it drops).
        fn drop(&mut self) {
            if self.publisher.get().is_some() {
                self.declared.fetch_sub(1, Ordering::Relaxed);
            }
        }
    }
    impl EstimateOutlet for Vehicle {
        fn wanted(&self) -> bool {
            self.anyone.load(Ordering::Relaxed)
        }
        fn put(&self, payload: Vec<u8>) {
            let result = match self.publisher.get() {
                Some(p) => p.put(payload).wait(),
                None => {
                    self.count_put();
                    self.session
                        .put(self.key.clone(), payload)
                        .encoding(Encoding::APPLICATION_JSON)
                        .congestion_control(CongestionControl::Block)
                        .allowed_destination(Locality::Remote)
                        .wait()
                }
            };
            if let Err(e) = result {
                tracing::warn!(key = %self.key, error = %e, "put failed");
            }
        }
        fn own_publisher(&self) -> bool {
            self.publisher.get().is_some()
        }
    }
    let watch = session
        .declare_publisher(keys.all(Leaf::Estimate))
        .allowed_destination(Locality::Remote)
        .await
        .map_err(zerr)?;
    let anyone = matching_flag(&watch).await?;
    let session = session.clone();
    let declared = Arc::new(AtomicUsize::new(0));
    let outlets: Outlets = Arc::new(move |key: &str| match KeyExpr::try_from(key.to_string()) {
        Ok(key) => Box::new(Vehicle {
            session: session.clone(),
            key,
            anyone: anyone.clone(),
            declared: declared.clone(),
            puts: AtomicU64::new(0),
            first: OnceLock::new(),
            publisher: OnceLock::new(),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A vehicle gets its own publisher at its 256th estimate when they came fast, and the service
    /// declares at most `MAX_DECLARED`; every put before and after goes out.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn fast_vehicles_get_their_own_publisher_up_to_the_cap() {
        let mut config = zenoh::Config::default();
        config
            .insert_json5("scouting/multicast/enabled", "false")
            .unwrap();
        config.insert_json5("listen/endpoints", "[]").unwrap();
        let session = zenoh::open(config).await.unwrap();
        let (outlets, _watch) = estimate_outlets(&session, &Keys::new("attitude"))
            .await
            .unwrap();
        let put = |o: &dyn EstimateOutlet, n: u64| {
            for _ in 0..n {
                o.put(b"{}".to_vec());
            }
        };
        let first = outlets("attitude/v0/estimate");
        put(first.as_ref(), DECLARE_AFTER_PUTS - 1);
        assert!(!first.own_publisher());
        put(first.as_ref(), 1);
        assert!(first.own_publisher());
        put(first.as_ref(), 10);
        let others: Vec<_> = (1..=MAX_DECLARED)
            .map(|i| outlets(&format!("attitude/v{i}/estimate")))
            .collect();
        for o in &others {
            put(o.as_ref(), DECLARE_AFTER_PUTS);
        }
        let declared = others.iter().filter(|o| o.own_publisher()).count();
        assert_eq!(declared, MAX_DECLARED - 1, "the cap counts the first one");
        assert!(!others.last().unwrap().own_publisher());
        // A vehicle removed gives its place to the next fast one.
        drop(first);
        let next = outlets("attitude/next/estimate");
        put(next.as_ref(), DECLARE_AFTER_PUTS);
        assert!(next.own_publisher());
        session.close().await.unwrap();
    }
}
