//! The service's outputs: the sink the workers put rejections and standby batches through, and each
//! vehicle's estimate outlet, put only while someone listens.

use super::{zerr, ServiceError};
use crate::engine::{EstimateOutlet, Outlets, Sink};
use crate::wire::keys::{Keys, Leaf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
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
/// BENCHMARKS.md, issue 30). A declared publisher keeps its route, but zenoh 1.10 then resolves every
/// other undeclared key (every input the vehicles put) against all the declarations, and with one
/// per vehicle of a thousand the service's receiving thread drowned in it (issue 15). So the
/// vehicles that publish fast (at least `DECLARE_MIN_RATE_HZ` over their first `DECLARE_AFTER_PUTS`
/// estimates: raw IMU streams) get a publisher of their own, at most `MAX_DECLARED` of them, and
/// the rest put on the session. Puts block under congestion rather than drop.
///
/// The keys of the first `MAX_KEYED` vehicles (each one's estimate key and plain input keys) are
/// declared as key expressions ([`KeyDeclarer`]): zenoh keeps a route for a declared key, so neither
/// a put of their estimates nor an arrival of their inputs computes one (that computation, matching
/// the key against every declaration, was a quarter of the service's CPU under 1000 MEKF vehicles at
/// 10 Hz: BENCHMARKS.md, issue 30). Unlike a publisher, a declared key expression subscribes to
/// nothing, so a thousand of them leave the other keys' routing as it was.
pub async fn estimate_outlets(
    session: &zenoh::Session,
    keys: &Keys,
) -> Result<(Outlets, zenoh::pubsub::Publisher<'static>), ServiceError> {
    struct Vehicle {
        session: zenoh::Session,
        key: KeyExpr<'static>,
        /// The keys once declared (the estimate key is put on then).
        keyed: Arc<DeclaredKeys>,
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
                    let key = self.keyed.estimate.get().unwrap_or(&self.key);
                    self.session
                        .put(key.clone(), payload)
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
    let declarer = KeyDeclarer::start(&session, keys.clone());
    let outlets: Outlets = Arc::new(move |key: &str| match KeyExpr::try_from(key.to_string()) {
        Ok(key) => Box::new(Vehicle {
            session: session.clone(),
            keyed: declarer.declare(&key),
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

/// A vehicle's keys as declared key expressions: its estimate key and its plain input keys (the
/// same key with the input leaves), undeclared when the vehicle goes.
struct DeclaredKeys {
    session: zenoh::Session,
    /// The declarer's count of keyed vehicles, when this one holds a place in it.
    slot: Option<Arc<AtomicUsize>>,
    /// Where it sends its keys to be undeclared (the declarer's thread: a vehicle may be dropped
    /// where zenoh's tables are held, and an undeclaration takes them for writing).
    queue: crossbeam_channel::Sender<Declaration>,
    /// The estimate key, `P/V/estimate`.
    key: String,
    /// The input keys, `P/V/{gyro,vectors,imu}`.
    input_keys: Vec<String>,
    estimate: OnceLock<KeyExpr<'static>>,
    inputs: Mutex<Vec<KeyExpr<'static>>>,
}

impl DeclaredKeys {
    /// Declares the keys; returns how many were.
    fn declare(&self) -> usize {
        let mut inputs = Vec::new();
        for input in &self.input_keys {
            match self.session.declare_keyexpr(input.clone()).wait() {
                Ok(k) => inputs.push(k),
                Err(e) => {
                    tracing::debug!(key = %self.key, error = %e, "cannot declare an input key")
                }
            }
        }
        let mut n = inputs.len();
        *self.inputs.lock().unwrap_or_else(|e| e.into_inner()) = inputs;
        match self.session.declare_keyexpr(self.key.clone()).wait() {
            Ok(k) => {
                let _ = self.estimate.set(k);
                n += 1;
            }
            Err(e) => {
                tracing::debug!(key = %self.key, error = %e, "cannot declare the estimate key")
            }
        }
        n
    }
}

impl Drop for DeclaredKeys {
    fn drop(&mut self) {
        let mut keys = std::mem::take(self.inputs.get_mut().unwrap_or_else(|e| e.into_inner()));
        keys.extend(self.estimate.take());
        if let Some(keyed) = &self.slot {
            keyed.fetch_sub(1, Ordering::Relaxed);
        }
        if !keys.is_empty() {
            let _ = self.queue.send(Declaration::Undeclare(keys));
        }
    }
}

/// What the declarer's thread does.
enum Declaration {
    /// Declares a vehicle's keys, unless it has gone meanwhile.
    Declare(std::sync::Weak<DeclaredKeys>),
    Undeclare(Vec<KeyExpr<'static>>),
}

/// Declares vehicles' keys on a thread of its own: a declaration takes zenoh's routing tables for
/// writing and the session scans its own declarations, so the thousand vehicles of a first burst,
/// declared on the workers as their outlets were made, held their estimates up by a third of a
/// second. (Paced at one vehicle per 2 ms, it was worse: while the declarations trickled in, the
/// service spent more CPU per estimate than with none; at `SCHED_IDLE`, [`idle_priority`], the first
/// burst is answered as without them.) A vehicle gone before its turn is skipped.
struct KeyDeclarer {
    session: zenoh::Session,
    queue: crossbeam_channel::Sender<Declaration>,
    /// Key expressions declared now (read by the tests).
    #[allow(dead_code)]
    live: Arc<AtomicUsize>,
    /// Vehicles whose keys are declared or due.
    keyed: Arc<AtomicUsize>,
    keys: Keys,
}

/// At most this many vehicles of one service have their keys declared; the others' puts compute
/// their routes as before. zenoh 1.10's session finds a key among its declarations by a linear scan,
/// under its lock: 4 000 declarations took 0.26 s here, growing with the square of their number.
const MAX_KEYED: usize = 1024;

/// Runs the calling thread only when a core would otherwise idle (Linux `SCHED_IDLE`): the
/// declarations of a first burst then wait for the burst to be answered instead of competing with it
/// for the cores. (A thread that waits on a lock a declaration holds leaves its core to it.)
fn idle_priority() {
    #[cfg(target_os = "linux")]
    {
        let param = libc::sched_param { sched_priority: 0 };
        // SAFETY: plain system call on the calling thread (pid 0) with a valid parameter.
        let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) };
        if rc != 0 {
            tracing::debug!("key declarations at normal priority (SCHED_IDLE refused)");
        }
    }
}

impl KeyDeclarer {
    fn start(session: &zenoh::Session, keys: Keys) -> Self {
        let (queue, rx) = crossbeam_channel::unbounded::<Declaration>();
        let own = session.clone();
        let live = Arc::new(AtomicUsize::new(0));
        let counted = live.clone();
        // Ends when the outlets and their vehicles (the queue's senders) are gone.
        let spawned = std::thread::Builder::new()
            .name("key-declarer".into())
            .spawn(move || {
                idle_priority();
                let live = counted;
                for job in rx {
                    match job {
                        Declaration::Declare(weak) => {
                            if let Some(keys) = weak.upgrade() {
                                live.fetch_add(keys.declare(), Ordering::Relaxed);
                            }
                        }
                        Declaration::Undeclare(keys) => {
                            for k in keys {
                                if own.undeclare(k).wait().is_ok() {
                                    live.fetch_sub(1, Ordering::Relaxed);
                                }
                            }
                        }
                    }
                }
            });
        if let Err(e) = spawned {
            tracing::warn!(error = %e, "no key-declaring thread: every put computes its route");
        }
        KeyDeclarer {
            session: session.clone(),
            queue,
            live,
            keyed: Arc::new(AtomicUsize::new(0)),
            keys,
        }
    }

    /// The keys of the vehicle whose estimate key is `key`, declared in their turn while fewer than
    /// `MAX_KEYED` vehicles have theirs.
    fn declare(&self, key: &KeyExpr<'static>) -> Arc<DeclaredKeys> {
        let slot = self
            .keyed
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| {
                (n < MAX_KEYED).then_some(n + 1)
            })
            .is_ok();
        let keys = Arc::new(DeclaredKeys {
            slot: slot.then(|| self.keyed.clone()),
            session: self.session.clone(),
            queue: self.queue.clone(),
            key: key.as_str().to_string(),
            input_keys: match self.keys.split(key.as_str()) {
                Some((vehicle, _)) => [Leaf::Gyro, Leaf::Vectors, Leaf::Imu]
                    .map(|leaf| self.keys.vehicle(vehicle, leaf))
                    .to_vec(),
                None => Vec::new(),
            },
            estimate: OnceLock::new(),
            inputs: Mutex::new(Vec::new()),
        });
        if slot {
            let _ = self.queue.send(Declaration::Declare(Arc::downgrade(&keys)));
        }
        keys
    }
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

    /// A session of its own: no scouting, no listener.
    async fn lone_session() -> zenoh::Session {
        let mut config = zenoh::Config::default();
        config
            .insert_json5("scouting/multicast/enabled", "false")
            .unwrap();
        config.insert_json5("listen/endpoints", "[]").unwrap();
        zenoh::open(config).await.unwrap()
    }

    /// A vehicle gets its own publisher at its 256th estimate when they came fast, and the service
    /// declares at most `MAX_DECLARED`; every put before and after goes out.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn fast_vehicles_get_their_own_publisher_up_to_the_cap() {
        let session = lone_session().await;
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

    /// A vehicle's estimate key and its three input keys are declared on the declarer's thread, and
    /// undeclared there once the vehicle is dropped.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_vehicles_keys_are_declared_and_undeclared_with_it() {
        let session = lone_session().await;
        let declarer = KeyDeclarer::start(&session, Keys::new("attitude"));
        let until = |what: &dyn Fn() -> bool| {
            let end = Instant::now() + std::time::Duration::from_secs(5);
            while !what() && Instant::now() < end {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            what()
        };
        let keys: Vec<_> = (0..3)
            .map(|i| {
                declarer.declare(&KeyExpr::try_from(format!("attitude/v{i}/estimate")).unwrap())
            })
            .collect();
        assert!(until(&|| declarer.live.load(Ordering::Relaxed) == 12));
        for (i, k) in keys.iter().enumerate() {
            let declared = k.estimate.get().expect("declared");
            assert_eq!(declared.as_str(), format!("attitude/v{i}/estimate"));
            let inputs = k.inputs.lock().unwrap();
            let names: Vec<&str> = inputs.iter().map(|k| k.as_str()).collect();
            assert_eq!(
                names,
                ["gyro", "vectors", "imu"].map(|l| format!("attitude/v{i}/{l}"))
            );
        }
        drop(keys);
        assert!(until(&|| declarer.live.load(Ordering::Relaxed) == 0));
        // At most MAX_KEYED vehicles hold a place; one that goes gives it to the next.
        let key = |i: usize| KeyExpr::try_from(format!("attitude/w{i}/estimate")).unwrap();
        let mut held: Vec<_> = (0..MAX_KEYED).map(|i| declarer.declare(&key(i))).collect();
        assert!(held.iter().all(|k| k.slot.is_some()));
        assert!(declarer.declare(&key(MAX_KEYED)).slot.is_none());
        held.pop();
        assert!(declarer.declare(&key(MAX_KEYED + 1)).slot.is_some());
        drop(held);
        assert!(until(&|| declarer.live.load(Ordering::Relaxed) == 0));
        session.close().await.unwrap();
    }
}
