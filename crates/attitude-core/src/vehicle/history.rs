//! Late data fused, not refused: a vehicle keeps, for `time.max_lag_s` of sample time, states of its
//! processing at bounded intervals and every sample processed since the oldest of them. A sample older
//! than what the vehicle has processed, within the lag, is fused by restoring the newest kept state
//! at or before its place in time and replaying it and every later sample, in order (as
//! robot_localization's history and PX4's delayed-fusion horizon do). The filters are deterministic
//! given their state (a particle filter's generator is part of it), so the vehicle ends exactly where
//! it would be had the sample arrived in order, bit for bit.
//!
//! **Order.** Samples are processed by [`Key`]: time, then the gyro (or IMU) sample before the vector
//! set of the same instant, then arrival. The reorder window releases in this order, a replay
//! re-processes in it; a replay is the only way an order other than the window's could be seen, so the
//! order of processing is a function of the samples, not of their arrival.
//!
//! **What a replay publishes.** Every estimate the replayed samples produce, again, marked
//! `replayed`: each carries the `seq` of the estimate it replaces (the counter is part of the kept
//! state), so a subscriber that keeps the last estimate per `seq` (or per `t`) holds exactly what an
//! in-order run publishes. Samples are counted (processed, refused) once, when first processed; the
//! late sample itself is counted when it is fused.
//!
//! **Memory.** A kept state is the filter's plain-data state ([`FilterState`]) and the rest of the
//! vehicle's processing state: about 2.6 kB for the MEKF or USQUE (5.3 kB with the IMU pipeline of a
//! vehicle fed `P/V/imu`), plus 64 bytes per particle for the QPF (the cloud). A state is kept every
//! `max_lag / KEPT_PER_LAG` of sample time, so at most `KEPT_PER_LAG + 2` are held (and the last one
//! dropped, whose allocations the next one kept reuses, counted with them); the log holds the
//! samples of the lag and one interval more (112 bytes a gyro or IMU sample). A star-tracker
//! spacecraft (10 Hz gyro, 1 Hz sets, the default 2 s lag) holds under 30 kB with a Kalman filter,
//! about 540 kB with a QPF of 1000 particles, 5.2 MB with 10⁴; a 100 Hz IMU vehicle about 78 kB
//! (`tests.rs` pins these). Everything together is capped at `time.history_bytes` per vehicle
//! (default 8 MiB): states that do not fit as often are kept more rarely, down to one per lag; when
//! even that exceeds the cap the oldest go first (the history covers less than the lag, and a sample
//! beyond what it covers is refused `out_of_order` as before); a vehicle whose single state exceeds the
//! cap keeps no history at all (a QPF of 10⁶ particles: 64 MB a state). The history is not part of a
//! checkpoint: a restored vehicle starts a new one, and until it covers the lag a sample older than the
//! restored state is refused.

use super::*;
use crate::filters::FilterState;

/// Kept states per `max_lag_s` when the byte cap allows (a replay re-processes at most this fraction
/// of the lag before the late sample).
pub const KEPT_PER_LAG: usize = 8;

/// The processing order of samples: time, then the gyro (or IMU) sample before the vector set of the
/// same instant (arrival order among equal keys).
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct Key {
    pub t_s: f64,
    rank: u8,
}

impl Key {
    pub fn of(m: &Measurement) -> Self {
        Key {
            t_s: m.t_s(),
            rank: match m {
                Measurement::Vectors(_) => 1,
                Measurement::Gyro(_) | Measurement::Imu(_) => 0,
            },
        }
    }

    /// The first key of instant `t_s` (what a vehicle restored or reset at `t_s` has processed).
    pub fn at(t_s: f64) -> Self {
        Key { t_s, rank: 0 }
    }
}

/// Everything processing a sample changes in a [`VehicleState`] (the arrival side, the reorder window
/// and the configuration are not: a replay leaves them alone).
#[derive(Default)]
struct Processing {
    filter: Option<FilterState>,
    seq: u64,
    generation: u64,
    last_t: Option<f64>,
    last_key: Option<Key>,
    last_gyro: Option<GyroSample>,
    gate: BTreeMap<String, GateCounts>,
    consecutive_gated: u32,
    consecutive_failures: u32,
    rollbacks: u64,
    reinits: BTreeMap<String, u64>,
    last_good: Option<Estimate>,
    sensor_state: BTreeMap<String, SensorState>,
    /// (Boxed: a vehicle fed vectors has none, and the pipeline is 1.6 kB.)
    ahrs: Option<Box<Ahrs>>,
    last_imu_estimate_t: Option<f64>,
}

/// A state kept, and where it is in the log.
struct Kept {
    /// Log position (counted since the vehicle's history began) of the first sample not in it.
    at: u64,
    /// The newest sample in it (`None`: none).
    last: Option<Key>,
    /// The time of the first sample not in it (kept states are spaced by this).
    t_s: f64,
    state: Box<Processing>,
    bytes: usize,
}

/// A processed sample.
struct Logged {
    key: Key,
    m: Measurement,
    bytes: usize,
}

/// The kept states and the samples processed since the oldest.
#[derive(Default)]
pub(super) struct History {
    kept: VecDeque<Kept>,
    log: VecDeque<Logged>,
    /// Log position of `log[0]`.
    base: u64,
    /// Bytes held, the spare's included.
    bytes: usize,
    /// The last state dropped, and its bytes, refilled by the next state kept: copying a particle
    /// cloud into arrays already there is a copy, a new one also allocates and faults fresh pages in
    /// (a 1000-particle QPF every 0.25 s of samples; BENCHMARKS.md, "The service under load"). Held
    /// only while it fits the cap, so the states held are as many as without it.
    spare: Option<(Box<Processing>, usize)>,
}

/// `dst` made equal to `src`, in place when they hold the same keys (a kept state's maps of sensor
/// names change rarely; a map's own `clone_from` allocates every node and key again).
fn copy_map<V: Clone>(dst: &mut BTreeMap<String, V>, src: &BTreeMap<String, V>) {
    if dst.len() == src.len() && dst.keys().eq(src.keys()) {
        for (d, s) in dst.values_mut().zip(src.values()) {
            d.clone_from(s);
        }
    } else {
        dst.clone_from(src);
    }
}

/// Bytes a map entry costs beyond its key and value (a B-tree node's share, roughly).
const MAP_ENTRY_OVERHEAD: usize = 48;

fn map_bytes<V>(m: &BTreeMap<String, V>) -> usize {
    m.keys()
        .map(|k| k.len() + std::mem::size_of::<(String, V)>() + MAP_ENTRY_OVERHEAD)
        .sum()
}

/// Bytes of a filter's kept state beyond the enum itself (the particle cloud: 8 arrays of f64).
fn filter_heap_bytes(particles: Option<usize>) -> usize {
    particles.map_or(0, |n| 8 * std::mem::size_of::<f64>() * n)
}

fn sample_bytes(m: &Measurement) -> usize {
    std::mem::size_of::<Logged>()
        + match m {
            Measurement::Vectors(set) => set
                .observations
                .iter()
                .map(|o| {
                    std::mem::size_of::<VectorObservation>()
                        + o.sensor.as_ref().map_or(0, String::len)
                })
                .sum(),
            _ => 0,
        }
}

/// Where a late sample goes: the kept state to restore (its index), already rebuilt and checked.
pub(super) struct Rewind {
    kept: usize,
    filter: Option<Box<dyn AttitudeFilter>>,
}

impl History {
    pub(super) fn clear(&mut self) {
        *self = History::default();
    }

    /// Bytes held (kept states and logged samples).
    pub(super) fn bytes(&self) -> usize {
        self.bytes
    }

    /// Kept states and logged samples.
    pub(super) fn len(&self) -> (usize, usize) {
        (self.kept.len(), self.log.len())
    }

    fn end(&self) -> u64 {
        self.base + self.log.len() as u64
    }

    /// Drops the oldest kept state and the samples only it needed; returns the state and its bytes.
    fn drop_oldest(&mut self) -> Option<(Box<Processing>, usize)> {
        let k = self.kept.pop_front()?;
        self.bytes -= k.bytes;
        let until = self.kept.front().map_or(self.end(), |n| n.at);
        while self.base < until {
            let Some(l) = self.log.pop_front() else { break };
            self.bytes -= l.bytes;
            self.base += 1;
        }
        Some((k.state, k.bytes))
    }

    /// Keeps the history within the lag behind `last_t` (the oldest state kept is the newest one at or
    /// before the lag's start, so every sample within the lag has one) and within the byte cap (the
    /// spare goes first).
    fn trim(&mut self, last_t: Option<f64>, policy: &Policy) {
        if let Some(last_t) = last_t {
            let horizon = last_t - policy.max_lag_s;
            while self.kept.len() >= 2 && self.kept[1].last.is_some_and(|l| l.t_s < horizon) {
                if let Some((state, bytes)) = self.drop_oldest() {
                    if self.spare.is_none() && self.bytes + bytes <= policy.history_bytes {
                        self.bytes += bytes;
                        self.spare = Some((state, bytes));
                    }
                }
            }
        }
        while self.bytes > policy.history_bytes {
            if let Some((_, bytes)) = self.spare.take() {
                self.bytes -= bytes;
            } else if self.drop_oldest().is_none() {
                break;
            }
        }
    }

    /// The spare state, if there is one, taken out of the count.
    fn take_spare(&mut self) -> Option<Box<Processing>> {
        let (state, bytes) = self.spare.take()?;
        self.bytes -= bytes;
        Some(state)
    }

    /// The sample interval between kept states for states of `bytes`: the lag over
    /// [`KEPT_PER_LAG`], or over fewer when the cap does not hold that many (+2: the one before the
    /// lag's start and the one being made).
    fn interval_s(bytes: usize, policy: &Policy) -> f64 {
        let fit = policy.history_bytes / bytes.max(1);
        let per_lag = fit.saturating_sub(2).clamp(1, KEPT_PER_LAG);
        policy.max_lag_s / per_lag as f64
    }
}

impl VehicleState {
    /// Bytes the vehicle's history holds now.
    pub fn history_bytes(&self) -> usize {
        self.history.bytes()
    }

    /// Kept states and logged samples of the vehicle's history.
    pub fn history_len(&self) -> (usize, usize) {
        self.history.len()
    }

    /// Late samples fused by a replay since the vehicle was created (or restored).
    pub fn late_fused(&self) -> u64 {
        self.late_fused
    }

    /// What a kept state of this vehicle costs, estimated before making it.
    pub(super) fn kept_bytes(&self) -> usize {
        std::mem::size_of::<Kept>()
            + std::mem::size_of::<Processing>()
            + filter_heap_bytes(match self.slot {
                Slot::Tracking(_) => self.particles(),
                Slot::Initializing => None,
            })
            + self.ahrs.as_ref().map_or(0, std::mem::size_of_val)
            + map_bytes(&self.gate)
            + map_bytes(&self.reinits)
            + map_bytes(&self.sensor_state)
    }

    /// The processing state written over `p`, reusing its allocations (the filter's through
    /// [`AttitudeFilter::state_into`]).
    fn processing_into(&self, p: &mut Processing) {
        let Processing {
            filter,
            seq,
            generation,
            last_t,
            last_key,
            last_gyro,
            gate,
            consecutive_gated,
            consecutive_failures,
            rollbacks,
            reinits,
            last_good,
            sensor_state,
            ahrs,
            last_imu_estimate_t,
        } = p;
        match (&self.slot, filter.as_mut()) {
            (Slot::Tracking(f), Some(s)) => f.state_into(s),
            (Slot::Tracking(f), None) => *filter = Some(f.state()),
            (Slot::Initializing, _) => *filter = None,
        }
        *seq = self.seq;
        *generation = self.generation;
        *last_t = self.last_t;
        *last_key = self.last_key;
        *last_gyro = self.last_gyro;
        copy_map(gate, &self.gate);
        *consecutive_gated = self.consecutive_gated;
        *consecutive_failures = self.consecutive_failures;
        *rollbacks = self.rollbacks;
        copy_map(reinits, &self.reinits);
        last_good.clone_from(&self.last_good);
        copy_map(sensor_state, &self.sensor_state);
        match (ahrs.as_deref_mut(), &self.ahrs) {
            (Some(kept), Some(a)) => kept.clone_from(a),
            (_, a) => *ahrs = a.clone().map(Box::new),
        }
        *last_imu_estimate_t = self.last_imu_estimate_t;
    }

    /// Is `key` older than what the vehicle has processed?
    pub(super) fn is_late(&self, key: Key) -> bool {
        self.last_key.is_some_and(|last| key < last)
    }

    /// Whether a late sample can be fused, and from which kept state; otherwise why not (`out_of_order`
    /// beyond the lag or the history, `duplicate` for a sample the log already holds). Changes nothing.
    pub(super) fn rewind_for(
        &self,
        m: &Measurement,
        key: Key,
        policy: &Policy,
    ) -> Result<Rewind, Rejection> {
        let t = key.t_s;
        let last = self.last_t.unwrap_or(f64::NEG_INFINITY);
        let refuse = |why: String| {
            Err(Rejection::new(
                RejectCode::OutOfOrder,
                format!(
                    "t = {t} s is older than the vehicle's last processed sample ({last} s) {why}"
                ),
            ))
        };
        if !(t >= last - policy.max_lag_s) {
            return refuse(format!(
                "by more than time.max_lag_s = {} s",
                policy.max_lag_s
            ));
        }
        let h = &self.history;
        let Some(k) = h.kept.iter().rposition(|k| k.last.is_none_or(|l| l <= key)) else {
            return refuse(format!(
                "and its history does not reach back that far ({})",
                match h.kept.front().and_then(|k| k.last) {
                    Some(l) => format!("it starts after t = {} s", l.t_s),
                    None => "it keeps none: time.history_bytes is too small for this vehicle's state, or it was just restored".into(),
                }
            ));
        };
        // The log covers every sample since the oldest kept state: a sample processed already is a
        // duplicate, as the recent-sample check would say of a newer one.
        let stream = stream_of(m);
        let from = h.log.partition_point(|l| l.key.t_s < t - SAME_INSTANT_S);
        for l in h.log.range(from..) {
            if l.key.t_s > t + SAME_INSTANT_S {
                break;
            }
            let same_stream = stream_of(&l.m) == stream;
            if same_stream && (stream != Stream::Vectors || fingerprint(&l.m) == fingerprint(m)) {
                return Err(Rejection::new(
                    RejectCode::Duplicate,
                    format!("a sample of this stream at t = {t} s was already processed"),
                ));
            }
        }
        let filter = match &h.kept[k].state.filter {
            None => None,
            Some(f) => Some(f.clone().restore().map_err(|e| {
                Rejection::new(
                    RejectCode::OutOfOrder,
                    format!("t = {t} s is older than the vehicle's last processed sample and its kept state cannot be restored ({e})"),
                )
            })?),
        };
        Ok(Rewind { kept: k, filter })
    }

    /// Fuses late sample `m`: back to the kept state of `rewind`, then `m` and every later sample in
    /// order. The estimates are published again (`replayed`).
    pub(super) fn replay(
        &mut self,
        rewind: Rewind,
        m: Measurement,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) {
        let h = &mut self.history;
        while h.kept.len() > rewind.kept + 1 {
            if let Some(k) = h.kept.pop_back() {
                h.bytes -= k.bytes;
            }
        }
        let at = h.kept[rewind.kept].at;
        let keep = (at - h.base) as usize;
        let mut again: Vec<Logged> = h.log.drain(keep..).collect();
        h.bytes -= again.iter().map(|l| l.bytes).sum::<usize>();
        let s = &h.kept[rewind.kept].state;
        self.slot = match rewind.filter {
            Some(f) => Slot::Tracking(f),
            None => Slot::Initializing,
        };
        self.seq = s.seq;
        self.generation = s.generation;
        self.last_t = s.last_t;
        self.last_key = s.last_key;
        self.last_gyro = s.last_gyro;
        self.gate = s.gate.clone();
        self.consecutive_gated = s.consecutive_gated;
        self.consecutive_failures = s.consecutive_failures;
        self.rollbacks = s.rollbacks;
        self.reinits = s.reinits.clone();
        self.last_good = s.last_good.clone();
        self.sensor_state = s.sensor_state.clone();
        self.ahrs = s.ahrs.as_deref().cloned();
        self.last_imu_estimate_t = s.last_imu_estimate_t;
        let key = Key::of(&m);
        let i = again.partition_point(|l| l.key <= key);
        let bytes = sample_bytes(&m);
        again.insert(i, Logged { key, m, bytes });
        self.late_fused += 1;
        self.replaying = true;
        for (j, l) in again.into_iter().enumerate() {
            self.step(l.m, j != i, policy, out);
        }
        self.replaying = false;
    }

    /// Processes one sample in order: keeps a state first when one is due, logs the sample after.
    /// `again`: the sample was processed (and counted) before; only its estimates are published.
    pub(super) fn step(
        &mut self,
        m: Measurement,
        again: bool,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) {
        let key = Key::of(&m);
        let history = policy.max_lag_s > 0.0;
        if history {
            self.keep_state_if_due(key, policy);
        }
        let from = out.len();
        let logged =
            (history && !self.history.kept.is_empty()).then(|| (sample_bytes(&m), m.clone()));
        self.process(m, policy, out);
        if again {
            let mut i = from;
            while i < out.len() {
                if matches!(
                    out[i],
                    Event::Processed(_) | Event::Rejected(..) | Event::Gap(..)
                ) {
                    out.remove(i);
                } else {
                    i += 1;
                }
            }
        }
        self.last_key = Some(self.last_key.map_or(key, |l| if key > l { key } else { l }));
        if let Some((bytes, m)) = logged {
            self.history.log.push_back(Logged { key, m, bytes });
            self.history.bytes += bytes;
        }
        if history {
            self.history.trim(self.last_t, policy);
        }
    }

    /// Keeps the state before the sample of `key` when the last one kept is an interval older (or
    /// there is none), and when it fits the byte cap.
    fn keep_state_if_due(&mut self, key: Key, policy: &Policy) {
        // (The interval is judged by the newest kept state's bytes: a state's size changes only with a
        // reset, which empties the history, or a sensor's first use, and counting it walks the
        // vehicle's maps, a cost on every sample otherwise.)
        if let Some(k) = self.history.kept.back() {
            if key.t_s - k.t_s < History::interval_s(k.bytes, policy) {
                return;
            }
        }
        let bytes = self.kept_bytes();
        if bytes > policy.history_bytes {
            // Even one does not fit: no history (a late sample is refused).
            if !self.history.kept.is_empty() {
                self.history.clear();
            }
            return;
        }
        let mut state = self.history.take_spare().unwrap_or_default();
        self.processing_into(&mut state);
        let kept = Kept {
            at: self.history.end(),
            last: self.last_key,
            t_s: key.t_s,
            state,
            bytes,
        };
        self.history.bytes += bytes;
        self.history.kept.push_back(kept);
    }
}
