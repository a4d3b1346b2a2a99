//! Inputs on their way from zenoh to the dispatcher (proto/README.md, "Loss, recovery and
//! back-pressure"): what the subscribers hand over ([`Ingest`]); each vehicle's share of the ingest
//! channel and the wait for room ([`Admission`]); and, on the dispatcher thread, what zenoh reports
//! lost and what could not be taken, counted per vehicle and told on its `P/V/rejected`. Nothing is
//! dropped without a word: an input is handed over, or its sender is slowed, or told.

use super::{Engine, Inbound, INGEST_CAPACITY};
use crate::rng::{fnv1a, FNV_OFFSET};
use crossbeam_channel::TrySendError;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// What the subscribers hand the dispatcher, in arrival order.
pub enum Ingest {
    /// An input as received. `sequenced`: it carries its publisher's sequence number (a zenoh-ext
    /// AdvancedPublisher's), so zenoh may deliver it again from the publisher's cache after this
    /// service restarts. `held`: what it holds of the channel's budgets ([`Admission`]).
    Input {
        inbound: Inbound,
        sequenced: bool,
        held: Held,
    },
    /// zenoh reports `count` puts on `key` lost between the publisher `source` and this service,
    /// not recovered.
    Missed {
        key: String,
        count: u64,
        source: String,
    },
}

impl From<Inbound> for Ingest {
    fn from(inbound: Inbound) -> Self {
        Ingest::Input {
            inbound,
            sequenced: false,
            held: Held::default(),
        }
    }
}

/// What an input holds of the ingest channel's budgets until the dispatcher takes it: bytes of all
/// inputs', and of its vehicle's share (`slot`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Held {
    slot: Option<u16>,
    bytes: u64,
}

/// Shares of the ingest channel, by a hash of the vehicle id: a few vehicles may share one; no
/// vehicle can fill the channel and starve the others.
const SLOTS: usize = 4096;
/// Bytes counted for an input besides its payload (its key, its place in the channel).
const INPUT_OVERHEAD: u64 = 128;
/// How often a waiting callback looks for room again.
const POLL: Duration = Duration::from_micros(250);

/// Why an input could not be handed over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum NoRoom {
    /// Its vehicle's inputs waiting for the dispatcher already held
    /// `service.ingest.pending_bytes_per_vehicle`.
    Share,
    /// All inputs waiting held `service.ingest.pending_bytes`, or the channel was full.
    Channel,
}

/// What the dispatcher has to tell about one key that could not be handed over in order.
#[derive(Default)]
pub(super) struct Untold {
    pub(super) refused: u64,
    pub(super) why: Option<NoRoom>,
    pub(super) missed: u64,
    pub(super) source: String,
}

/// The subscribers' side of the ingest channel: each vehicle's share, the bounded wait of a plain
/// publisher's input for room, and what could not be taken, kept for the dispatcher to tell.
pub struct Admission {
    /// Bytes of the inputs of the vehicles of each slot between a subscriber and the dispatcher, and
    /// of all of them.
    pending: Box<[AtomicU64]>,
    per_vehicle: u64,
    total: AtomicU64,
    max_total: u64,
    wait: Duration,
    capacity: usize,
    /// A callback waits for room now. One at a time: zenoh receives on a small pool of threads
    /// (two by default), and one of them always stays free for the other senders and the queries.
    waiting: AtomicBool,
    untold: Mutex<HashMap<String, Untold>>,
    any_untold: AtomicBool,
    /// Inputs that waited for room, and the nanoseconds waited.
    pub waited: AtomicU64,
    pub waited_ns: AtomicU64,
    /// Samples of restored vehicles delivered again after a restart, skipped.
    pub redelivered: AtomicU64,
}

/// Most keys kept to be told at once; beyond it a refusal is counted (`ingest_overflow`) but told
/// with the next report of its key only.
const MAX_UNTOLD_KEYS: usize = 4096;

impl Admission {
    pub(super) fn new(config: &crate::service::config::IngestConfig) -> Self {
        Admission {
            pending: (0..SLOTS).map(|_| AtomicU64::new(0)).collect(),
            per_vehicle: config.pending_bytes_per_vehicle as u64,
            total: AtomicU64::new(0),
            max_total: config.pending_bytes as u64,
            wait: Duration::from_secs_f64(config.wait_s),
            capacity: INGEST_CAPACITY,
            waiting: AtomicBool::new(false),
            untold: Mutex::new(HashMap::new()),
            any_untold: AtomicBool::new(false),
            waited: AtomicU64::new(0),
            waited_ns: AtomicU64::new(0),
            redelivered: AtomicU64::new(0),
        }
    }

    fn slot_of(vehicle: &str) -> u16 {
        (fnv1a(vehicle.bytes(), FNV_OFFSET) % SLOTS as u64) as u16
    }

    /// Takes `bytes` of a budget holding `counter` of at most `max`; an input alone larger than the
    /// budget is taken when nothing else is held (the limits allow no payload larger than a share).
    fn take(counter: &AtomicU64, bytes: u64, max: u64) -> bool {
        counter
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
                (n == 0 || n + bytes <= max).then_some(n + bytes)
            })
            .is_ok()
    }

    fn give_back(counter: &AtomicU64, bytes: u64) {
        let _ = counter.fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
            Some(n.saturating_sub(bytes))
        });
    }

    /// Reserves room for an input of `bytes` of the vehicle of `slot` (`None`: not a vehicle's).
    fn reserve(&self, slot: Option<u16>, bytes: u64) -> Result<Held, NoRoom> {
        if let Some(s) = slot {
            if !Admission::take(&self.pending[s as usize], bytes, self.per_vehicle) {
                return Err(NoRoom::Share);
            }
        }
        if !Admission::take(&self.total, bytes, self.max_total) {
            if let Some(s) = slot {
                Admission::give_back(&self.pending[s as usize], bytes);
            }
            return Err(NoRoom::Channel);
        }
        Ok(Held { slot, bytes })
    }

    /// The dispatcher took an input that held `held`.
    pub(super) fn release(&self, held: Held) {
        if held.bytes == 0 {
            return;
        }
        if let Some(s) = held.slot {
            Admission::give_back(&self.pending[s as usize], held.bytes);
        }
        Admission::give_back(&self.total, held.bytes);
    }

    /// Hands an input of `vehicle` (`None`: not a vehicle's input key, e.g. a standby batch or a ROS
    /// 2 message: only the channel's capacity applies) to the dispatcher. Without room, an input
    /// that `may_wait` (a plain subscriber's, whose callback holds no lock of zenoh's) waits up to
    /// `service.ingest.wait_s`, one callback at a time; what still finds no room is refused and kept
    /// to be told. Returns whether it was handed over.
    pub fn offer(
        &self,
        engine: &Engine,
        tx: &crossbeam_channel::Sender<Option<Ingest>>,
        vehicle: Option<&str>,
        mut ingest: Ingest,
        may_wait: bool,
    ) -> bool {
        // (A report of samples missed is small and holds nothing.)
        let (slot, bytes) = match &ingest {
            Ingest::Input { inbound, .. } => (
                vehicle.map(Admission::slot_of),
                inbound.payload.len() as u64 + INPUT_OVERHEAD,
            ),
            Ingest::Missed { .. } => (None, 0),
        };
        let mut started: Option<std::time::Instant> = None;
        let result = loop {
            let reserved = if bytes == 0 {
                Ok(Held::default())
            } else {
                self.reserve(slot, bytes)
            };
            let why = match reserved {
                Ok(held) => {
                    if let Ingest::Input { held: h, .. } = &mut ingest {
                        *h = held;
                    }
                    match tx.try_send(Some(ingest)) {
                        Ok(()) => break Ok(()),
                        Err(TrySendError::Full(back)) => {
                            self.release(held);
                            ingest = back.expect("what was sent");
                            NoRoom::Channel
                        }
                        // (The service is stopping.)
                        Err(TrySendError::Disconnected(_)) => {
                            self.release(held);
                            break Ok(());
                        }
                    }
                }
                Err(why) => why,
            };
            let waited_enough = match started {
                Some(t) => t.elapsed() >= self.wait,
                None => {
                    if !may_wait || self.wait.is_zero() || self.waiting.swap(true, Ordering::AcqRel)
                    {
                        true
                    } else {
                        started = Some(std::time::Instant::now());
                        false
                    }
                }
            };
            if waited_enough {
                break Err((ingest, why));
            }
            std::thread::sleep(POLL);
        };
        if let Some(t) = started {
            self.waiting.store(false, Ordering::Release);
            self.waited.fetch_add(1, Ordering::Relaxed);
            self.waited_ns
                .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
        }
        match result {
            Ok(()) => true,
            Err((ingest, why)) => {
                self.keep_untold(engine, ingest, why);
                false
            }
        }
    }

    fn keep_untold(&self, engine: &Engine, ingest: Ingest, why: NoRoom) {
        let mut untold = self.untold.lock().unwrap_or_else(|e| e.into_inner());
        let (key, missed) = match ingest {
            Ingest::Input { inbound, .. } => {
                engine
                    .counters
                    .ingest_overflow
                    .fetch_add(1, Ordering::Relaxed);
                (inbound.key, None)
            }
            Ingest::Missed { key, count, source } => (key, Some((count, source))),
        };
        if untold.len() >= MAX_UNTOLD_KEYS && !untold.contains_key(&key) {
            if let Some((count, _)) = missed {
                engine.counters.missed.fetch_add(count, Ordering::Relaxed);
            }
            tracing::warn!(key, "too many keys to tell at once: counted, not told");
            return;
        }
        let u = untold.entry(key).or_default();
        match missed {
            None => {
                u.refused += 1;
                u.why = Some(why);
            }
            Some((count, source)) => {
                u.missed += count;
                u.source = source;
            }
        }
        self.any_untold.store(true, Ordering::Release);
        // (After the flag: the dispatcher woken by this nudge finds it set.)
        engine.nudge_dispatcher();
    }

    /// Bytes of the inputs waiting for the dispatcher in the share of `vehicle`, and of all.
    pub fn pending_of(&self, vehicle: &str) -> u64 {
        self.pending[Admission::slot_of(vehicle) as usize].load(Ordering::Relaxed)
    }

    pub fn pending_bytes(&self) -> u64 {
        self.total.load(Ordering::Relaxed)
    }
}

impl Admission {
    /// What the subscribers could not hand over since the last call, by key (the dispatcher tells it).
    pub(super) fn take_untold(&self) -> Option<HashMap<String, Untold>> {
        if !self.any_untold.swap(false, Ordering::AcqRel) {
            return None;
        }
        Some(std::mem::take(
            &mut *self.untold.lock().unwrap_or_else(|e| e.into_inner()),
        ))
    }

    /// The capacity of the ingest channel, in inputs.
    pub(super) fn capacity(&self) -> usize {
        self.capacity
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vehicle_cannot_take_more_than_its_share_nor_all_more_than_the_total() {
        let config = crate::service::config::IngestConfig {
            pending_bytes_per_vehicle: 300,
            pending_bytes: 500,
            ..Default::default()
        };
        let a = Admission::new(&config);
        let (s, t) = (Some(Admission::slot_of("v")), Some(Admission::slot_of("w")));
        assert_ne!(s, t);
        let held: Vec<Held> = (0..3).map(|_| a.reserve(s, 100).unwrap()).collect();
        assert_eq!(a.reserve(s, 1).unwrap_err(), NoRoom::Share);
        a.release(held[0]);
        let again = a.reserve(s, 100).unwrap();
        // Another vehicle has its own share, within the total.
        let w = a.reserve(t, 200).unwrap();
        assert_eq!(a.reserve(t, 100).unwrap_err(), NoRoom::Channel);
        assert_eq!((a.pending_of("v"), a.pending_bytes()), (300, 500));
        for h in [held[1], held[2], again, w] {
            a.release(h);
        }
        assert_eq!((a.pending_of("v"), a.pending_bytes()), (0, 0));
        // An input larger than a share alone is taken when nothing else is held.
        let big = a.reserve(s, 400).unwrap();
        assert!(a.reserve(s, 1).is_err());
        a.release(big);
        // (What a test sends straight into the channel held nothing and releases nothing.)
        a.release(Held::default());
        assert_eq!(a.pending_bytes(), 0);
    }

    /// An input refused on arrival is told at once though the dispatcher dozes (a second between
    /// looks while idle): the refusal nudges it. Without the nudge each round would wait up to the
    /// doze, and three rounds all inside 200 ms would be a chance of about 1 in 100.
    #[test]
    fn a_refusal_wakes_the_dozing_dispatcher() {
        use crate::engine::{Engine, Inbound, Sink};
        use crate::service::config::ServiceConfig;
        use std::sync::{Arc, Mutex};
        use std::time::{Duration, Instant};
        let mut config = ServiceConfig::default();
        config.ingest.pending_bytes_per_vehicle = 64;
        config.ingest.wait_s = 0.0;
        let told: Arc<Mutex<Vec<(String, Instant)>>> = Arc::default();
        let t = told.clone();
        let sink: Sink = Arc::new(move |key: &str, _: Vec<u8>| {
            if key.ends_with("/rejected") {
                t.lock().unwrap().push((key.to_string(), Instant::now()));
            }
        });
        let (engine, threads) = Engine::start_alone(config, sink).unwrap();
        // The vehicle's share is full (as while its inputs wait for the dispatcher).
        let _full = engine
            .admission
            .reserve(Some(Admission::slot_of("a")), 64)
            .unwrap();
        for round in 0..3u64 {
            // (Long enough for the dispatcher to be in its doze.)
            std::thread::sleep(Duration::from_millis(50 + 70 * round));
            let key = engine.keys.vehicle("a", crate::wire::keys::Leaf::Gyro);
            let input = Ingest::Input {
                inbound: Inbound {
                    key,
                    payload: vec![b' '; 1000],
                },
                sequenced: false,
                held: Held::default(),
            };
            let offered = Instant::now();
            assert!(!engine
                .admission
                .offer(&engine, &threads.ingest, Some("a"), input, false));
            let deadline = offered + Duration::from_secs(3);
            let at = loop {
                if let Some((_, at)) = told.lock().unwrap().get(round as usize) {
                    break *at;
                }
                assert!(Instant::now() < deadline, "round {round}: never told");
                std::thread::sleep(Duration::from_millis(1));
            };
            let waited = at - offered;
            assert!(
                waited < Duration::from_millis(200),
                "round {round}: told after {waited:?}"
            );
        }
        threads.shutdown();
    }
}
