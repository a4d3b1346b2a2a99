//! What the engine keeps: each vehicle's record (its inbox, its state, its last estimate and its
//! counters, the row of `P/@/vehicles` kept as plain values at each estimate, its outlet), the
//! service-wide counters and the step-time histograms the workers fill. Queries read these, never a
//! filter.

use super::Input;
use crate::filters::{FilterKind, FilterSpec};
use crate::service::persist::SavedCounters;
use crate::vehicle::{Event, VehicleState};
use crate::wire::{EstimateMsg, RejectCode, VehicleInfoMsg};
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock, RwLock};
use std::time::Duration;

/// Where the engine's outputs other than estimates go (rejections): `(key, JSON payload)`. The
/// service puts them on zenoh; tests collect them.
pub type Sink = Arc<dyn Fn(&str, Vec<u8>) + Send + Sync>;

/// One vehicle's estimates on their way out: in the service a zenoh publisher declared for the
/// vehicle's estimate key, which knows whether any subscriber matches it.
pub trait EstimateOutlet: Send + Sync {
    /// Whether anyone would receive an estimate put now. When no one would, the engine keeps the
    /// estimate for the queries and does not serialise it.
    fn wanted(&self) -> bool;
    /// Puts one serialised estimate.
    fn put(&self, payload: Vec<u8>);
    /// Whether the puts go through a publisher declared for this vehicle alone (a fast one:
    /// `service::outlets`).
    fn own_publisher(&self) -> bool {
        false
    }
}

/// Makes the outlet of a vehicle from its estimate key `P/V/estimate`, once per vehicle, when the
/// vehicle publishes its first estimate.
pub type Outlets = Arc<dyn Fn(&str) -> Box<dyn EstimateOutlet> + Send + Sync>;

/// The outlets of an engine without zenoh: every estimate is wanted and goes to the sink.
pub fn sink_outlets(sink: &Sink) -> Outlets {
    struct ToSink {
        sink: Sink,
        key: String,
    }
    impl EstimateOutlet for ToSink {
        fn wanted(&self) -> bool {
            true
        }
        fn put(&self, payload: Vec<u8>) {
            (self.sink)(&self.key, payload)
        }
    }
    let sink = sink.clone();
    Arc::new(move |key: &str| {
        Box::new(ToSink {
            sink: sink.clone(),
            key: key.to_string(),
        }) as Box<dyn EstimateOutlet>
    })
}

/// A vehicle's outlet and the size of its last serialised estimate (the next one's buffer).
#[derive(Default)]
pub(super) struct Outlet {
    pub(super) outlet: OnceLock<Box<dyn EstimateOutlet>>,
    pub(super) last_len: AtomicUsize,
}

/// What `P/@/vehicles` says of a vehicle besides its counters, stored at every estimate (before it
/// is published, so a subscriber's view and the list agree) as plain values.
pub(super) struct Info {
    tracking: AtomicBool,
    /// `t` of the newest sample used, as `f64` bits; `NO_T` before any.
    t: AtomicU64,
    estimates: AtomicU64,
    /// Changes only with a reset or a takeover.
    spec: Mutex<FilterSpec>,
}

const NO_T: u64 = u64::MAX;

impl Info {
    pub(super) fn of(state: &VehicleState) -> Self {
        let info = Info {
            tracking: AtomicBool::new(false),
            t: AtomicU64::new(NO_T),
            estimates: AtomicU64::new(0),
            spec: Mutex::new(state.spec()),
        };
        info.refresh(state);
        info
    }

    pub(super) fn refresh(&self, state: &VehicleState) {
        self.tracking.store(state.is_tracking(), Ordering::Relaxed);
        self.t
            .store(state.last_t().map_or(NO_T, f64::to_bits), Ordering::Relaxed);
        self.estimates.store(state.seq(), Ordering::Relaxed);
        let spec = state.spec();
        let mut s = self.spec.lock().unwrap_or_else(|e| e.into_inner());
        if *s != spec {
            *s = spec;
        }
    }

    pub(super) fn kind(&self) -> FilterKind {
        self.spec.lock().unwrap_or_else(|e| e.into_inner()).kind
    }

    pub(super) fn is_tracking(&self) -> bool {
        self.tracking.load(Ordering::Relaxed)
    }

    /// The seq of the vehicle's last estimate.
    pub(super) fn estimates(&self) -> u64 {
        self.estimates.load(Ordering::Relaxed)
    }

    /// The vehicle's row; `Vehicle::info` fills in the counters.
    pub(super) fn message(&self, id: &str) -> VehicleInfoMsg {
        let spec = *self.spec.lock().unwrap_or_else(|e| e.into_inner());
        let t = self.t.load(Ordering::Relaxed);
        VehicleInfoMsg {
            vehicle: id.to_string(),
            state: if self.tracking.load(Ordering::Relaxed) {
                "tracking"
            } else {
                "initializing"
            }
            .into(),
            filter: spec.kind.as_str().into(),
            fiducial: spec.fiducial.map(|f| f.as_str().into()),
            t: (t != NO_T).then(|| f64::from_bits(t)),
            received: 0,
            processed: 0,
            rejected: 0,
            estimates: self.estimates.load(Ordering::Relaxed),
        }
    }
}

/// Service-wide counters (atomics: read by queries without locks).
#[derive(Default)]
pub struct Counters {
    pub received: AtomicU64,
    pub processed: AtomicU64,
    pub estimates: AtomicU64,
    pub queries: AtomicU64,
    /// Inputs refused on arrival for want of room (each told on `P/V/rejected` as `queue_full`).
    pub ingest_overflow: AtomicU64,
    /// Puts of the vehicles' inputs that zenoh reported lost (`samples_missed`).
    pub missed: AtomicU64,
    rejected: [AtomicU64; RejectCode::ALL.len()],
    /// Checkpoints: vehicles restored and files skipped at start; files written and failed writes.
    pub restored: AtomicU64,
    pub skipped: AtomicU64,
    pub written: AtomicU64,
    pub write_failed: AtomicU64,
    /// Filter step times by filter kind (`P/@/metrics`).
    pub(super) steps: StepTimes,
}

impl Counters {
    pub fn reject(&self, code: RejectCode) {
        let i = RejectCode::ALL.iter().position(|c| *c == code).unwrap_or(0);
        self.rejected[i].fetch_add(1, Ordering::Relaxed);
    }

    /// Every code and its count, zeros included, in the order of `RejectCode::ALL`.
    pub fn rejected_counts(&self) -> impl Iterator<Item = (RejectCode, u64)> + '_ {
        RejectCode::ALL
            .iter()
            .zip(&self.rejected)
            .map(|(c, n)| (*c, n.load(Ordering::Relaxed)))
    }

    /// The step-time histograms (`P/@/metrics`).
    pub fn step_times(&self) -> &StepTimes {
        &self.steps
    }

    pub fn rejected_by_code(&self) -> BTreeMap<String, u64> {
        RejectCode::ALL
            .iter()
            .zip(&self.rejected)
            .map(|(c, n)| (c.as_str().to_string(), n.load(Ordering::Relaxed)))
            .filter(|(_, n)| *n > 0)
            .collect()
    }
}

/// Filter step times, one histogram per filter kind (labelled `filter`).
pub struct StepTimes([Histogram; 4]);

impl Default for StepTimes {
    fn default() -> Self {
        // 1 µs to 1 s by factors of 2: an MEKF propagation (~1 µs) to a particle filter's update
        // with many particles.
        StepTimes(std::array::from_fn(|_| {
            Histogram::new(exponential_buckets(1e-6, 2.0, 21))
        }))
    }
}

/// The filter kinds in the order of [`StepTimes`]; the match in `StepTimes::of` keeps it complete.
pub const KINDS: [FilterKind; 4] = [
    FilterKind::Mekf,
    FilterKind::Usque,
    FilterKind::Qpf,
    FilterKind::Sghqf,
];

impl StepTimes {
    pub fn of(&self, kind: FilterKind) -> &Histogram {
        &self.0[match kind {
            FilterKind::Mekf => 0,
            FilterKind::Usque => 1,
            FilterKind::Qpf => 2,
            FilterKind::Sghqf => 3,
        }]
    }

    /// Records one input's pass through its vehicle (`elapsed`, on a worker) as one observation per
    /// sample it let through to the filter (`Event::Processed`), each an equal share: the count then
    /// matches `processed`, the sum is the time spent. An input the reorder window only held records
    /// nothing.
    pub(super) fn observe(&self, kind: FilterKind, elapsed: Duration, events: &[Event]) {
        let n = events
            .iter()
            .filter(|e| matches!(e, Event::Processed(_)))
            .count();
        if n > 0 {
            let h = self.of(kind);
            let share = elapsed.as_secs_f64() / n as f64;
            for _ in 0..n {
                h.observe(share);
            }
        }
    }
}

/// One vehicle: its inbox, its filter state, and what queries read without waiting for the filter.
pub struct Vehicle {
    pub id: String,
    pub(super) inbox: Mutex<VecDeque<Input>>,
    pub(super) scheduled: AtomicBool,
    pub(super) state: Mutex<VehicleState>,
    /// The last published estimate (queries read this, never the filter).
    pub(super) snapshot: RwLock<Option<Arc<EstimateMsg>>>,
    pub(super) info: Info,
    /// Where its estimates go (made at the first one).
    pub(super) outlet: Outlet,
    pub(super) received: AtomicU64,
    pub(super) processed: AtomicU64,
    pub(super) rejected: AtomicU64,
    /// This vehicle's refused inputs by code, reported in its estimates' diagnostics.
    pub(super) rejected_by_code: Mutex<BTreeMap<String, u64>>,
    /// Samples in the reorder window, and whether a tick is already queued.
    pub(super) held: AtomicUsize,
    pub(super) tick_queued: AtomicBool,
    /// Gate, re-initialisation and rollback totals (for `P/@/health`).
    pub(super) gated: AtomicU64,
    pub(super) reinits: AtomicU64,
    pub(super) rollbacks: AtomicU64,
    /// Late samples fused and the bytes of the history that lets it (for `P/@/health`).
    pub(super) late_fused: AtomicU64,
    pub(super) history_bytes: AtomicU64,
    /// Puts of its inputs zenoh reported lost (since it was created or restored).
    pub(super) missed: AtomicU64,
    /// Gaps in its gyro or raw-IMU samples, and the µs the raw-IMU ones hid (`Totals`).
    pub(super) gaps: AtomicU64,
    pub(super) blind_us: AtomicU64,
    /// Restored from a checkpoint: the newest sample time of each stream it held (zenoh may deliver
    /// those samples again from the publishers' caches; `Engine::skip_redelivered`).
    pub(super) restored_newest: Option<[Option<f64>; crate::vehicle::STREAMS]>,
    /// Changed since its last checkpoint.
    pub(super) dirty: AtomicBool,
}

impl Vehicle {
    pub(super) fn new(id: &str, state: VehicleState, counters: SavedCounters) -> Self {
        let info = Info::of(&state);
        let snapshot = state.estimate().map(|p| Arc::new(EstimateMsg::from(&p)));
        let v = Vehicle {
            id: id.to_string(),
            inbox: Mutex::new(VecDeque::new()),
            scheduled: AtomicBool::new(false),
            snapshot: RwLock::new(snapshot),
            info,
            outlet: Outlet::default(),
            received: AtomicU64::new(counters.received),
            processed: AtomicU64::new(counters.processed),
            rejected: AtomicU64::new(counters.rejected),
            rejected_by_code: Mutex::new(counters.rejected_by_code),
            held: AtomicUsize::new(0),
            tick_queued: AtomicBool::new(false),
            gated: AtomicU64::new(0),
            reinits: AtomicU64::new(0),
            rollbacks: AtomicU64::new(0),
            late_fused: AtomicU64::new(0),
            history_bytes: AtomicU64::new(0),
            missed: AtomicU64::new(0),
            gaps: AtomicU64::new(0),
            blind_us: AtomicU64::new(0),
            restored_newest: None,
            dirty: AtomicBool::new(false),
            state: Mutex::new(state),
        };
        {
            let state = v.state.lock().unwrap_or_else(|e| e.into_inner());
            let _ = v.refresh_totals(&state);
        }
        v
    }

    /// Copies the state's totals for the queries; returns whether the vehicle began (`Some(true)`)
    /// or ceased (`Some(false)`) to hold samples in its reorder window.
    pub(super) fn refresh_totals(&self, state: &VehicleState) -> Option<bool> {
        let t = state.totals();
        let held = state.held();
        let before = self.held.swap(held, Ordering::Relaxed);
        self.gated.store(t.gated, Ordering::Relaxed);
        self.reinits.store(t.reinits, Ordering::Relaxed);
        self.rollbacks.store(t.rollbacks, Ordering::Relaxed);
        self.late_fused.store(t.late_fused, Ordering::Relaxed);
        self.history_bytes
            .store(t.history_bytes as u64, Ordering::Relaxed);
        self.gaps.store(t.gaps, Ordering::Relaxed);
        self.blind_us
            .store((t.blind_s * 1e6) as u64, Ordering::Relaxed);
        ((before > 0) != (held > 0)).then_some(held > 0)
    }

    pub(super) fn counters(&self) -> SavedCounters {
        SavedCounters {
            received: self.received.load(Ordering::Relaxed),
            processed: self.processed.load(Ordering::Relaxed),
            rejected: self.rejected.load(Ordering::Relaxed),
            rejected_by_code: self
                .rejected_by_code
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .clone(),
        }
    }

    pub fn snapshot(&self) -> Option<Arc<EstimateMsg>> {
        self.snapshot.read().map(|s| s.clone()).unwrap_or(None)
    }

    /// Its counters and totals now (for `P/@/health` and `P/@/metrics`).
    pub fn totals(&self) -> VehicleTotals {
        let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
        VehicleTotals {
            received: load(&self.received),
            processed: load(&self.processed),
            estimates: self.info.estimates(),
            held: self.held.load(Ordering::Relaxed),
            gated: load(&self.gated),
            reinits: load(&self.reinits),
            rollbacks: load(&self.rollbacks),
            late_fused: load(&self.late_fused),
            history_bytes: load(&self.history_bytes),
            missed: load(&self.missed),
            gaps: load(&self.gaps),
            blind_us: load(&self.blind_us),
        }
    }

    /// Its refused inputs by code.
    pub fn rejected_by_code(&self) -> BTreeMap<String, u64> {
        self.rejected_by_code
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Inputs waiting in its inbox.
    pub fn inbox_len(&self) -> usize {
        self.inbox.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// Its filter's kind now.
    pub fn kind(&self) -> FilterKind {
        self.info.kind()
    }

    /// Whether it has an estimate (tracking) or not yet (initializing).
    pub fn is_tracking(&self) -> bool {
        self.info.is_tracking()
    }

    pub fn info(&self) -> VehicleInfoMsg {
        let mut info = self.info.message(&self.id);
        info.received = self.received.load(Ordering::Relaxed);
        info.processed = self.processed.load(Ordering::Relaxed);
        info.rejected = self.rejected.load(Ordering::Relaxed);
        info
    }
}

/// A vehicle's counters and totals at one moment, as plain values.
#[derive(Clone, Copy, Debug, Default)]
pub struct VehicleTotals {
    pub received: u64,
    pub processed: u64,
    /// The seq of its last estimate.
    pub estimates: u64,
    /// Samples in its reorder window.
    pub held: usize,
    pub gated: u64,
    pub reinits: u64,
    pub rollbacks: u64,
    pub late_fused: u64,
    pub history_bytes: u64,
    pub missed: u64,
    pub gaps: u64,
    pub blind_us: u64,
}
