//! One vehicle: the reorder window, the time checks, the innovation gate, the filter's health and the
//! ways back (re-initialisation). A closed state machine without I/O or locks; its whole state can be
//! taken out and put back as plain data ([`VehicleSnapshot`], what a checkpoint saves).
//!
//! An input first passes the time checks (duplicate, jump, older than the history reaches) and is
//! refused with a [`Rejection`] that changes nothing, or is accepted into the reorder window. Samples
//! leave the window in time order ([`Key`]) once every stream of the vehicle has reached their time,
//! or once a stream has run the window ahead (sample time), or after waiting the window since they
//! arrived (wall time: a stream that stopped does not stall the others), and only then reach the
//! filter: `Initializing` (no filter yet: waiting for a vector set that determines the attitude, or a
//! reset that gives it) → `Tracking`. A sample older than what was processed already, within
//! `time.max_lag_s`, is fused by rolling back to a kept state and replaying (`history.rs`): releasing
//! early costs a replay, never a sample. What happens to samples is reported as [`Event`]s.

use crate::ahrs::Ahrs;
use crate::attitude::{q_method, skew, Quaternion};
use crate::filters::{
    build_filter, is_spd, plausibly_spd, AttitudeFilter, Estimate, FilterError, FilterKind,
    FilterSpec, InitialState, SAME_INSTANT_S,
};
use crate::rejection::{RejectCode, Rejection};
use crate::rng::{fnv1a as fnv, fnv1a_u64, FNV_OFFSET};
use crate::sensors::model::{SensorState, Verdict};
use crate::sensors::{
    Aspect, GyroSample, ImuSample, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::{Matrix3, Vector3};
use policy::{InitMode, Policy, VehicleFilterConfig};
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

mod gate;
mod history;
pub mod policy;
mod published;
mod restart;
mod start;
mod state;
#[cfg(test)]
mod tests;

pub use history::{Key, KEPT_PER_LAG};
pub use published::{FieldReference, GateCounts, ImuDiagnostics, Published, ResetOutcome};
pub use restart::{ResetRequest, TakeoverSeed};
pub use state::{HeldSample, VehicleSnapshot};

/// Attitude 1σ used by a reset that gives `q` without `sigma_deg`.
pub const DEFAULT_RESET_SIGMA_DEG: f64 = 1.0;
/// Most particles a reset (or a takeover) may ask for.
pub const MAX_PARTICLES: usize = 1_000_000;
/// Accepted samples per stream remembered to recognise duplicates.
const RECENT: usize = 16;
/// Gate statistics of observations without a sensor name, and of names beyond the per-vehicle limit.
const UNNAMED: &str = "unnamed";
const OTHER: &str = "other";
/// Attitude 1σ after a re-initialisation from an estimate: at least 1°, at most 60° (beyond, a
/// Kalman filter's linearisation means nothing and repeated re-initialisations must not compound).
const MIN_REINIT_SIGMA_RAD: f64 = 1.0 * std::f64::consts::PI / 180.0;
const MAX_REINIT_SIGMA_RAD: f64 = 60.0 * std::f64::consts::PI / 180.0;
/// The gate judges an observation only when the prior is informative: every attitude 1σ below this
/// (a broad or multimodal particle cloud is left to its own likelihood), rad (10°).
const GATE_MAX_PRIOR_SIGMA_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;
/// Consistent samples beyond a time jump that re-anchor the vehicle's time.
pub const JUMP_CONFIRMATIONS: u32 = 3;

/// The input streams of a vehicle (they arrive on different keys and may be reordered).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    Gyro = 0,
    Vectors = 1,
    Imu = 2,
}

pub const STREAMS: usize = 3;

pub fn stream_of(m: &Measurement) -> Stream {
    match m {
        Measurement::Gyro(_) => Stream::Gyro,
        Measurement::Vectors(_) => Stream::Vectors,
        Measurement::Imu(_) => Stream::Imu,
    }
}

/// What happened to the samples released by an input.
#[derive(Debug)]
pub enum Event {
    /// A sample reached the filter (or the initialisation) and was used.
    Processed(Stream),
    /// A released sample was refused by the filter (the filter is as it was before it).
    Rejected(Stream, Rejection),
    /// A new estimate to publish on `P/V/estimate`.
    Estimate(Published),
    /// A sample came after a gap in its stream (no sample for more than three usual intervals): the
    /// estimator bridged it and grew the covariance; told on `P/V/rejected` with the code `gap`.
    Gap(Stream, Rejection),
}

enum Slot {
    Initializing,
    Tracking(Box<dyn AttitudeFilter>),
}

/// The reorder window's limits at one moment ([`VehicleState::releasable`]).
#[derive(Clone, Copy)]
struct Releasable {
    window: f64,
    /// Every stream seen has reached this time (−∞ while a stream may still start earlier).
    watermark: f64,
    newest: f64,
}

impl Releasable {
    /// A sample of time `t_s` held since `held_at_s` may go at wall time `now_s`.
    fn ready(&self, t_s: f64, held_at_s: f64, now_s: f64) -> bool {
        self.window <= 0.0
            || t_s <= self.watermark + SAME_INSTANT_S
            || t_s <= self.newest - self.window
            || now_s - held_at_s >= self.window
    }
}

/// A sample in the reorder window.
struct Held {
    key: Key,
    /// Wall time it was accepted, s on the engine's clock (−∞ after a restore: released at the next
    /// flush).
    held_at_s: f64,
    m: Measurement,
}

/// Samples beyond a time jump, waiting for confirmation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JumpCandidate {
    pub t_s: f64,
    pub count: u32,
}

/// A vehicle's gate, re-initialisation, rollback and late-sample counts, and its history's bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Totals {
    pub gated: u64,
    pub reinits: u64,
    pub rollbacks: u64,
    pub late_fused: u64,
    pub history_bytes: usize,
    /// Gaps in the gyro or raw-IMU samples (bridged and paid for in the covariance), and the seconds
    /// the raw-IMU ones hid.
    pub gaps: u64,
    pub blind_s: f64,
}

/// A vehicle's complete state.
pub struct VehicleState {
    /// Shared with every estimate published (a clone per sample is a count, not an allocation).
    id: Arc<str>,
    config: VehicleFilterConfig,
    slot: Slot,
    /// Estimates published so far.
    seq: u64,
    /// Filters created so far (derives each new filter's seed).
    generation: u64,
    /// Time of the last sample used, s.
    last_t: Option<f64>,
    /// The newest sample processed, in processing order: an older one is late (`history`).
    last_key: Option<Key>,
    /// The last gyro sample used: its rate is held by a filter started or restarted later.
    last_gyro: Option<GyroSample>,
    /// The reorder window, sorted by [`Key`] (arrival order among equal keys).
    held: VecDeque<Held>,
    /// Kept states and the samples processed since, for late samples (not part of a checkpoint).
    history: history::History,
    /// Late samples fused so far (not part of a checkpoint), and whether a replay is running (its
    /// estimates are published as `replayed`).
    late_fused: u64,
    replaying: bool,
    /// Newest time accepted per stream, and the first time accepted at all.
    newest: [Option<f64>; STREAMS],
    first_t: Option<f64>,
    /// Recently accepted samples per stream: their times and what identifies them.
    recent: [VecDeque<(f64, Seen)>; STREAMS],
    jump: Option<JumpCandidate>,
    gate: BTreeMap<String, GateCounts>,
    consecutive_gated: u32,
    consecutive_failures: u32,
    rollbacks: u64,
    reinits: BTreeMap<String, u64>,
    /// The last estimate published (the point a health re-initialisation restarts from).
    last_good: Option<Estimate>,
    /// State of the sensors with a model (`service.sensors.NAME.kind`: gravity low-pass, field
    /// hold-off), by sensor name.
    sensor_state: BTreeMap<String, SensorState>,
    /// The raw-IMU pipeline of a vehicle fed `P/V/imu` (crate::ahrs).
    ahrs: Option<Ahrs>,
    /// Which gyro feeds the vehicle since its start or last reset: `P/V/gyro` or `P/V/imu` (one only).
    gyro_feed: Option<Stream>,
    /// Time of the last estimate published from an IMU sample (the rate cap).
    last_imu_estimate_t: Option<f64>,
}

fn filter_error(e: &FilterError) -> Rejection {
    match e {
        FilterError::OutOfOrder { .. } => Rejection::new(RejectCode::OutOfOrder, e.to_string()),
        FilterError::InvalidMeasurement(_) => Rejection::new(RejectCode::BadRequest, e.to_string()),
        _ => Rejection::new(
            RejectCode::FilterError,
            format!("{e}; the filter was rolled back to its state before this input"),
        ),
    }
}

/// A stable per-vehicle seed from its id.
fn seed_of(id: &str, generation: u64) -> u64 {
    fnv(id.bytes().chain(generation.to_le_bytes()), FNV_OFFSET)
}

/// FNV-1a of a vector's bytes (its three numbers' little-endian bits), continuing from `h`.
fn fnv_vector(v: &Vector3<f64>, h: u64) -> u64 {
    v.iter().fold(h, |h, x| fnv1a_u64(x.to_bits(), h))
}

/// Identifies a sample's content (duplicate detection).
fn fingerprint(m: &Measurement) -> u64 {
    match m {
        Measurement::Gyro(g) => fnv_vector(&g.omega_body_rad_s, FNV_OFFSET),
        Measurement::Vectors(set) => set.observations.iter().fold(FNV_OFFSET, |h, o| {
            let h = fnv_vector(&o.body, h);
            let h = fnv_vector(&o.reference, h);
            let h = fnv1a_u64(o.sigma.to_bits(), h);
            fnv(o.sensor.as_deref().unwrap_or("").bytes().chain([0]), h)
        }),
        Measurement::Imu(s) => imu_fingerprint(s),
    }
}

fn imu_fingerprint(s: &ImuSample) -> u64 {
    let h = fnv_vector(&s.gyr_rad_s, FNV_OFFSET);
    let h = fnv_vector(&s.acc_m_s2, h);
    match &s.mag {
        Some(m) => fnv_vector(m, h),
        None => h,
    }
}

/// What the duplicate check keeps of an accepted sample: the fingerprint of a vector set, the gyro or
/// IMU sample itself, hashed only when it is needed (another sample at the same instant, a snapshot).
/// FNV-1a is serial, a byte per multiply: an IMU sample's 72 bytes cost a tenth of its whole path.
#[derive(Clone, Copy, Debug)]
enum Seen {
    Hashed(u64),
    Gyro(Vector3<f64>),
    Imu(ImuSample),
}

impl Seen {
    fn of(m: &Measurement) -> Self {
        match m {
            Measurement::Gyro(g) => Seen::Gyro(g.omega_body_rad_s),
            Measurement::Imu(s) => Seen::Imu(*s),
            Measurement::Vectors(_) => Seen::Hashed(fingerprint(m)),
        }
    }

    fn fingerprint(&self) -> u64 {
        match self {
            Seen::Hashed(h) => *h,
            Seen::Gyro(w) => fnv_vector(w, FNV_OFFSET),
            Seen::Imu(s) => imu_fingerprint(s),
        }
    }
}

/// The IMU pipeline's diagnostics as published.
fn imu_diagnostics(a: &Ahrs) -> ImuDiagnostics {
    ImuDiagnostics {
        counts: a.counts().clone(),
        field: a
            .field_norm_dip_offset()
            .map(|(norm, dip_rad, offset, confirmed)| FieldReference {
                norm,
                dip_rad,
                offset,
                confirmed,
            }),
        measured: a.measured_noise(),
    }
}

/// A finite unit quaternion and a finite, positive-definite covariance. The Kalman filters check their
/// covariance in full when they update, so their estimates get only the cheap necessary conditions
/// here, every sample, in release builds ([`plausibly_spd`]); a particle filter's is a sample
/// covariance, checked nowhere else, and gets the full Cholesky.
fn healthy(e: &Estimate, kind: FilterKind) -> bool {
    let pd = match kind {
        FilterKind::Qpf => is_spd(&e.covariance),
        FilterKind::Mekf | FilterKind::Usque | FilterKind::Sghqf => plausibly_spd(&e.covariance),
    };
    // (A norm within 1e-6 of 1 is finite: a NaN or an infinite component fails the test. A bias is
    // finite when 0·b is 0 for each component.)
    let b = &e.bias_rad_s;
    (e.q.norm() - 1.0).abs() < 1e-6 && b[0] * 0.0 + b[1] * 0.0 + b[2] * 0.0 == 0.0 && pd
}

impl VehicleState {
    pub fn new(id: &str, config: VehicleFilterConfig) -> Self {
        VehicleState {
            id: id.into(),
            config,
            slot: Slot::Initializing,
            seq: 0,
            generation: 0,
            last_t: None,
            last_key: None,
            last_gyro: None,
            held: VecDeque::new(),
            history: Default::default(),
            late_fused: 0,
            replaying: false,
            newest: [None; STREAMS],
            first_t: None,
            recent: std::array::from_fn(|_| VecDeque::new()),
            jump: None,
            gate: BTreeMap::new(),
            consecutive_gated: 0,
            consecutive_failures: 0,
            rollbacks: 0,
            reinits: BTreeMap::new(),
            last_good: None,
            sensor_state: BTreeMap::new(),
            ahrs: None,
            gyro_feed: None,
            last_imu_estimate_t: None,
        }
    }

    pub fn id(&self) -> &str {
        &self.id
    }

    pub fn spec(&self) -> FilterSpec {
        self.config.filter.spec
    }

    pub fn particles(&self) -> Option<usize> {
        (self.config.filter.spec.kind == FilterKind::Qpf).then_some(self.config.filter.particles)
    }

    /// The sparse-grid level of an SGHQF.
    pub fn level(&self) -> Option<u8> {
        (self.config.filter.spec.kind == FilterKind::Sghqf).then_some(self.config.filter.level)
    }

    pub fn is_tracking(&self) -> bool {
        matches!(self.slot, Slot::Tracking(_))
    }

    pub fn last_t(&self) -> Option<f64> {
        self.last_t
    }

    pub fn seq(&self) -> u64 {
        self.seq
    }

    /// Samples waiting in the reorder window.
    pub fn held(&self) -> usize {
        self.held.len()
    }

    /// Gate, re-initialisation and rollback counts so far.
    pub fn totals(&self) -> Totals {
        Totals {
            gated: self.gate.values().map(|c| c.gated).sum(),
            reinits: self.reinits.values().sum(),
            rollbacks: self.rollbacks,
            late_fused: self.late_fused,
            history_bytes: self.history.bytes(),
            gaps: self.gaps().0,
            blind_s: self.gaps().1,
        }
    }

    /// Gaps in the vehicle's gyro feed so far (the raw-IMU pipeline's or the filter's), and the
    /// seconds the raw-IMU ones hid.
    fn gaps(&self) -> (u64, f64) {
        match (&self.ahrs, &self.slot) {
            (Some(a), _) => (a.counts().gaps, a.counts().blind_s),
            (None, Slot::Tracking(f)) => (f.gyro_gaps(), 0.0),
            (None, Slot::Initializing) => (0, 0.0),
        }
    }

    /// The estimate `e` as published, with the vehicle's diagnostics.
    fn published(&self, e: &Estimate) -> Published {
        let mut estimate = e.clone();
        if let Some(a) = &self.ahrs {
            // An IMU vehicle's estimate carries the time-stamp's uncertainty too, and north's while
            // the field is unconfirmed (crate::ahrs).
            let mut block = estimate.covariance.fixed_view_mut::<3, 3>(0, 0);
            block += a.published_attitude_covariance(&e.q);
        }
        Published {
            vehicle: Arc::clone(&self.id),
            estimate,
            spec: self.spec(),
            particles: self.particles(),
            level: self.level(),
            seq: self.seq,
            gate: self.gate.clone(),
            consecutive_gated: self.consecutive_gated,
            rollbacks: self.rollbacks,
            reinits: self.reinits.clone(),
            held: self.held.len(),
            replayed: self.replaying,
            late_fused: self.late_fused,
            imu: self.ahrs.as_ref().map(imu_diagnostics),
        }
    }

    /// The current estimate, if the vehicle is tracking.
    pub fn estimate(&self) -> Option<Published> {
        match &self.slot {
            Slot::Tracking(filter) => Some(self.published(&filter.estimate())),
            Slot::Initializing => None,
        }
    }

    /// Publishes `e` (already checked healthy) and remembers it as the last good state.
    fn emit(&mut self, e: Estimate, out: &mut Vec<Event>) {
        self.seq += 1;
        out.push(Event::Estimate(self.published(&e)));
        self.last_good = Some(e);
    }

    /// Checks the filter's estimate; an unhealthy one never leaves: the vehicle re-initialises from
    /// its last good estimate instead. Then publishes.
    fn check_and_emit(&mut self, policy: &Policy, out: &mut Vec<Event>) {
        let Slot::Tracking(filter) = &self.slot else {
            return;
        };
        let e = filter.estimate();
        if healthy(&e, self.spec().kind) {
            self.emit(e, out);
            return;
        }
        let t = e.t_s;
        tracing::warn!(vehicle = %self.id, t, "unhealthy filter state; re-initialising");
        if self.reinit_from_last_good("health", t, policy) {
            if let Slot::Tracking(filter) = &self.slot {
                let e = filter.estimate();
                if healthy(&e, self.spec().kind) {
                    self.emit(e, out);
                }
            }
        }
    }

    fn newest_any(&self) -> Option<f64> {
        self.newest.iter().flatten().copied().reduce(f64::max)
    }

    /// Accepts a sample into the reorder window (or refuses it, changing nothing) and processes what
    /// the window releases; a late sample within the lag is fused at once (`history`). `now_s` is the
    /// wall time the sample arrived at the service, s: the window's wall-time limit counts from it, so
    /// time spent queued behind other work never releases anything early.
    pub fn on_measurement(
        &mut self,
        m: Measurement,
        now_s: f64,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) -> Result<(), Rejection> {
        let stream = stream_of(&m);
        let t = m.t_s();
        let seen = Seen::of(&m);
        // (A sample after the newest of its stream cannot repeat one: the scan is skipped.)
        let in_order = self.newest[stream as usize].is_some_and(|n| t > n + SAME_INSTANT_S);
        let same = if in_order {
            None
        } else {
            self.recent[stream as usize]
                .iter()
                .find(|(rt, _)| (rt - t).abs() <= SAME_INSTANT_S)
        };
        match (stream, same) {
            (Stream::Imu, Some((_, rfp))) => {
                return Err(Rejection::new(
                    RejectCode::Duplicate,
                    if rfp.fingerprint() == seen.fingerprint() {
                        format!("the IMU sample at t = {t} s was already accepted")
                    } else {
                        format!("a different IMU sample at t = {t} s was already accepted; one sample per instant")
                    },
                ))
            }
            (Stream::Gyro, Some((_, rfp))) => {
                return Err(Rejection::new(
                    RejectCode::Duplicate,
                    if rfp.fingerprint() == seen.fingerprint() {
                        format!("the gyro sample at t = {t} s was already accepted")
                    } else {
                        format!("a different gyro sample at t = {t} s was already accepted; one rate per instant")
                    },
                ))
            }
            (Stream::Vectors, Some(_))
                if self.recent[1].iter().any(|(rt, rfp)| {
                    (rt - t).abs() <= SAME_INSTANT_S && rfp.fingerprint() == seen.fingerprint()
                }) =>
            {
                return Err(Rejection::new(
                    RejectCode::Duplicate,
                    format!("this vector set (t = {t} s) was already accepted"),
                ))
            }
            _ => {}
        }
        if let (Stream::Gyro | Stream::Imu, Some(feed)) = (stream, self.gyro_feed) {
            if feed != stream {
                let (this, other) = match stream {
                    Stream::Imu => ("an IMU sample", "gyro samples (P/V/gyro)"),
                    _ => ("a gyro sample", "raw IMU samples (P/V/imu)"),
                };
                return Err(Rejection::new(
                    RejectCode::MixedInputs,
                    format!("{this} for vehicle {}, which is fed {other}: one gyro per vehicle (a reset lets it switch)", self.id),
                ));
            }
        }
        let key = Key::of(&m);
        let rewind = if self.is_late(key) {
            match self.rewind_for(&m, key, policy) {
                Ok(r) => Some(r),
                // Without a history to put it in its place, a sample of the instant last processed
                // is still used (after it), as it always was: equal times are no reason to refuse.
                Err(r)
                    if r.code == RejectCode::OutOfOrder
                        && self.last_t.is_some_and(|l| t >= l - SAME_INSTANT_S) =>
                {
                    None
                }
                Err(r) => return Err(r),
            }
        } else {
            None
        };
        if let Some(newest) = self.newest_any() {
            if t > newest + policy.max_jump_s {
                // Consistent samples beyond the jump confirm a new time base (a real gap in the data);
                // a single stray time does not move the vehicle.
                let c = match self.jump {
                    Some(j) if (t - j.t_s).abs() <= policy.max_jump_s => JumpCandidate {
                        t_s: t.max(j.t_s),
                        count: j.count + 1,
                    },
                    _ => JumpCandidate { t_s: t, count: 1 },
                };
                if c.count < JUMP_CONFIRMATIONS {
                    self.jump = Some(c);
                    return Err(Rejection::new(
                        RejectCode::TimeJump,
                        format!(
                            "t = {t} s is {:.3} s ahead of the vehicle's newest sample ({newest} s), beyond time.max_jump_s = {} s; {} consistent samples (or a reset with t) accept the new time",
                            t - newest,
                            policy.max_jump_s,
                            JUMP_CONFIRMATIONS
                        ),
                    ));
                }
                tracing::info!(vehicle = %self.id, t, newest, "time jump confirmed");
            }
        }
        self.jump = None;
        if matches!(stream, Stream::Gyro | Stream::Imu) {
            self.gyro_feed = Some(stream);
        }
        let recent = &mut self.recent[stream as usize];
        if recent.len() == RECENT {
            recent.pop_front();
        }
        recent.push_back((t, seen));
        let n = &mut self.newest[stream as usize];
        *n = Some(n.map_or(t, |x| x.max(t)));
        self.first_t.get_or_insert(t);
        if let Some(rewind) = rewind {
            self.replay(rewind, m, policy, out);
            return Ok(());
        }
        if self.held.is_empty() && self.releasable(policy).ready(t, now_s, now_s) {
            // In order with nothing waiting: the window would take the sample and give it back at
            // once (the common case of one in-order stream), so it goes straight through.
            self.step(m, false, policy, out);
            return Ok(());
        }
        let at = self.held.partition_point(|h| h.key <= key);
        self.held.insert(
            at,
            Held {
                key,
                held_at_s: now_s,
                m,
            },
        );
        self.release(now_s, policy, false, out);
        Ok(())
    }

    /// Releases what the window allows at wall time `now_s` (the periodic flush; `now_s` is when the
    /// tick was queued, so a tick that waited behind the vehicle's inputs releases nothing early).
    pub fn on_tick(&mut self, now_s: f64, policy: &Policy, out: &mut Vec<Event>) {
        self.release(now_s, policy, false, out);
    }

    /// Processes every held sample, in time order.
    pub fn flush_all(&mut self, policy: &Policy, out: &mut Vec<Event>) {
        self.release(0.0, policy, true, out);
    }

    fn release(&mut self, now_s: f64, policy: &Policy, all: bool, out: &mut Vec<Event>) {
        let limits = self.releasable(policy);
        while let Some(first) = self.held.front() {
            if !(all || limits.ready(first.key.t_s, first.held_at_s, now_s)) {
                break;
            }
            let Some(h) = self.held.pop_front() else {
                break;
            };
            self.step(h.m, false, policy, out);
        }
    }

    /// What the reorder window releases now ([`Releasable::ready`]).
    fn releasable(&self, policy: &Policy) -> Releasable {
        let window = policy.reorder_window_s;
        // Every stream seen has reached this time: nothing older can still come (each stream is in
        // order on its own key). During the vehicle's first window a stream not seen yet may still
        // start earlier, so it holds the others; after it, a vehicle without that stream (vectors
        // only, say) does not wait for it.
        let newest = self.newest_any().unwrap_or(f64::NEG_INFINITY);
        // (Of the two gyro streams only the vehicle's own can still come: P/V/imu and P/V/gyro are
        // never mixed.)
        let imu = self.gyro_feed == Some(Stream::Imu);
        let expected = [!imu, true, imu];
        let starting = self
            .newest
            .iter()
            .zip(expected)
            .any(|(n, e)| e && n.is_none())
            && self.first_t.is_some_and(|f| newest - f < window);
        let watermark = if starting {
            f64::NEG_INFINITY
        } else {
            self.newest
                .iter()
                .flatten()
                .copied()
                .reduce(f64::min)
                .unwrap_or(f64::NEG_INFINITY)
        };
        Releasable {
            window,
            watermark,
            newest,
        }
    }

    /// Uses one released sample.
    fn process(&mut self, m: Measurement, policy: &Policy, out: &mut Vec<Event>) {
        let stream = stream_of(&m);
        let t = m.t_s();
        let (gaps_before, blind_before) = self.gaps();
        let previous_gyro_t = self.last_gyro.map(|g| g.t_s);
        // (An IMU vehicle aligns from its samples, whatever the filter's init mode.)
        if !self.is_tracking() && self.config.init == InitMode::Uniform && stream != Stream::Imu {
            // A particle filter that starts from a uniformly random attitude at its first sample.
            if let Err(r) = self.start_uniform(t) {
                out.push(Event::Rejected(stream, r));
                return;
            }
        }
        let result = match m {
            Measurement::Gyro(g) => self.process_gyro(g, policy, out),
            Measurement::Vectors(set) => {
                let r = self.process_vectors(set, policy, out);
                self.settle_sensors();
                r
            }
            Measurement::Imu(s) => self.process_imu(s, policy, out),
        };
        // The filter's time may have advanced even when the input was refused (a failed update
        // after its propagation): later samples are judged against it.
        let filter_t = match &self.slot {
            Slot::Tracking(f) => f.time_s(),
            Slot::Initializing => None,
        };
        let newest = [self.last_t, filter_t]
            .into_iter()
            .flatten()
            .reduce(f64::max);
        match result {
            Ok(()) => {
                self.last_t = Some(newest.map_or(t, |l| l.max(t)));
                out.push(Event::Processed(stream));
                let (gaps, blind) = self.gaps();
                if gaps > gaps_before && !self.replaying {
                    let hid = match stream {
                        Stream::Imu => format!("{:.3} s without a sample", blind - blind_before),
                        _ => previous_gyro_t.map_or_else(
                            || "a gap".to_string(),
                            |p| format!("{:.3} s since the previous sample", t - p),
                        ),
                    };
                    out.push(Event::Gap(
                        stream,
                        Rejection::new(
                            RejectCode::Gap,
                            format!("a gap before t = {t} s ({hid}): bridged by the rates on both sides, the covariance grown by what the body could have turned; the sample was used"),
                        ),
                    ));
                }
            }
            Err(r) => {
                self.last_t = newest;
                out.push(Event::Rejected(stream, r));
            }
        }
    }

    fn process_gyro(
        &mut self,
        g: GyroSample,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) -> Result<(), Rejection> {
        if let Slot::Tracking(filter) = &mut self.slot {
            if let Err(e) = filter.process(&Measurement::Gyro(g)) {
                return Err(self.failure(&e, g.t_s, policy, out));
            }
        }
        // (Only a successful update clears the failure count: propagations say nothing of it.)
        self.last_gyro = Some(g);
        Ok(())
    }

    /// One raw IMU sample through the pipeline (crate::ahrs): aligns the vehicle, then drives its
    /// filter; publishes an estimate per sample (at most one per `policy.imu_estimate_interval_s`).
    fn process_imu(
        &mut self,
        s: ImuSample,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) -> Result<(), Rejection> {
        let ahrs = self.ahrs.get_or_insert_with(|| Ahrs::new(&policy.imu));
        if ahrs.sheet() != &self.config.sensor {
            ahrs.set_sheet(&self.config.sensor);
        }
        match &mut self.slot {
            Slot::Initializing => {
                let Some(initial) = ahrs.align(&policy.imu, &s, &self.config.init_bias_sigma_rad_s)
                else {
                    return Ok(());
                };
                self.start(initial)?;
            }
            Slot::Tracking(filter) => {
                if let Err(e) = ahrs.step(&policy.imu, &s, filter.as_mut()) {
                    return Err(self.failure(&e, s.t_s, policy, out));
                }
                self.consecutive_failures = 0;
            }
        }
        let due = match self.last_imu_estimate_t {
            Some(t0) => s.t_s - t0 + SAME_INSTANT_S >= policy.imu_estimate_interval_s,
            None => true,
        };
        if due {
            self.last_imu_estimate_t = Some(s.t_s);
            self.check_and_emit(policy, out);
        }
        Ok(())
    }

    fn process_vectors(
        &mut self,
        set: ObservationSet,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) -> Result<(), Rejection> {
        let Slot::Tracking(filter) = &mut self.slot else {
            self.start_from_vectors(&set, policy)?;
            self.check_and_emit(policy, out);
            return Ok(());
        };
        if let Err(e) = filter.advance_to(set.t_s) {
            return Err(self.failure(&e, set.t_s, policy, out));
        }
        let prior = filter.estimate();
        let set = self.apply_models(set, &prior, policy);
        if set.observations.is_empty() {
            // Every observation was left out by its sensor's model (counted there): the propagated
            // estimate is published, and nothing speaks against the filter.
            self.check_and_emit(policy, out);
            return Ok(());
        }
        let accepted = self.gate(&set, &prior, policy);
        if accepted.is_empty() {
            self.consecutive_gated += 1;
            if policy.gate_reinit_after > 0 && self.consecutive_gated >= policy.gate_reinit_after {
                tracing::info!(vehicle = %self.id, t = set.t_s, n = self.consecutive_gated, "every observation gated repeatedly; re-initialising");
                self.reinit_for_gate(&set, policy)?;
            }
            // The propagated estimate is still published: one estimate per vector set, with the
            // gating visible in its diagnostics.
            self.check_and_emit(policy, out);
            return Ok(());
        }
        self.consecutive_gated = 0;
        let used = Measurement::Vectors(ObservationSet {
            t_s: set.t_s,
            observations: accepted,
        });
        let Slot::Tracking(filter) = &mut self.slot else {
            unreachable!("tracking was checked above");
        };
        if let Err(e) = filter.process(&used) {
            return Err(self.failure(&e, set.t_s, policy, out));
        }
        self.consecutive_failures = 0;
        self.check_and_emit(policy, out);
        Ok(())
    }
}
