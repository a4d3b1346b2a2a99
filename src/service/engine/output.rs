//! What leaves the engine: estimates, each serialised once, straight to the bytes that go out, and
//! only when someone will receive them; the vehicle's row of `P/@/vehicles`, kept as plain values at
//! each estimate and built into a message only when asked.

use super::*;
use crate::filters::{FilterKind, FilterSpec};
use std::sync::OnceLock;

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
}

/// Makes the outlet of a vehicle from its estimate key `P/V/estimate`, once per vehicle, when the
/// vehicle publishes its first estimate.
pub type Outlets = Arc<dyn Fn(&str) -> Box<dyn EstimateOutlet> + Send + Sync>;

/// The outlets of an engine without zenoh: every estimate is wanted and goes to the sink.
pub(super) fn sink_outlets(sink: &Sink) -> Outlets {
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
    outlet: OnceLock<Box<dyn EstimateOutlet>>,
    last_len: AtomicUsize,
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

impl Engine {
    /// Keeps `e` (with the vehicle's rejection counts) as the snapshot the queries answer and, when
    /// anyone subscribes to the vehicle's estimates, serialises it once and puts it.
    pub(super) fn publish_estimate(&self, v: &Vehicle, mut e: EstimateMsg) {
        {
            let rejected = v.rejected_by_code.lock().unwrap_or_else(|e| e.into_inner());
            if !rejected.is_empty() {
                e.diagnostics.rejected = rejected.clone();
            }
        }
        e.diagnostics.missed = v.missed.load(Ordering::Relaxed);
        let out = &v.outlet;
        let outlet = out
            .outlet
            .get_or_init(|| (self.outlets)(&self.keys.vehicle(&v.id, Leaf::Estimate)));
        // (In a fleet the route's standby members get every estimate, in the owner's next batch.)
        let standby = self.has_standby(&v.id);
        let wanted = outlet.wanted();
        let payload = if wanted || standby {
            let mut buf = Vec::with_capacity(out.last_len.load(Ordering::Relaxed) + 64);
            if let Err(err) = serde_json::to_writer(&mut buf, &e) {
                tracing::error!(vehicle = %v.id, %err, "cannot serialise an estimate");
                return;
            }
            out.last_len.store(buf.len(), Ordering::Relaxed);
            Some(buf)
        } else {
            None
        };
        if let Some(ros2) = &self.ros2 {
            ros2.on_estimate(&v.id, &e);
        }
        *v.snapshot.write().unwrap_or_else(|e| e.into_inner()) = Some(Arc::new(e));
        self.counters.estimates.fetch_add(1, Ordering::Relaxed);
        if let Some(payload) = payload {
            if standby {
                self.batch_estimate(&v.id, &payload);
            }
            if wanted {
                outlet.put(payload);
            }
        }
    }
}
