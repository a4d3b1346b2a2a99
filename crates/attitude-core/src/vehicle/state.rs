//! A vehicle's whole state as plain data: what a checkpoint saves and restores. The file format is
//! the service's (`persist`), converted from and to these types; nothing here knows about bytes.

use super::policy::VehicleFilterConfig;
use super::published::GateCounts;
use super::{Held, JumpCandidate, Key, Seen, Slot, Stream, VehicleState, STREAMS};
use crate::ahrs::{Ahrs, AhrsState};
use crate::filters::{Estimate, FilterState};
use crate::sensors::model::SensorState;
use crate::sensors::{GyroSample, Measurement};
use std::collections::BTreeMap;

/// A sample waiting in the reorder window. (The wall time it arrived is not kept: after a restore
/// every held sample is released at the next flush.)
#[derive(Clone, Debug, PartialEq)]
pub struct HeldSample {
    pub t_s: f64,
    pub m: Measurement,
}

/// Every field of a [`VehicleState`]; `filter` is `None` while the vehicle is initialising.
#[derive(Clone, Debug, PartialEq)]
pub struct VehicleSnapshot {
    pub id: String,
    pub config: VehicleFilterConfig,
    pub filter: Option<FilterState>,
    pub seq: u64,
    pub generation: u64,
    pub last_t: Option<f64>,
    pub last_gyro: Option<GyroSample>,
    pub held: Vec<HeldSample>,
    /// Newest time accepted per stream (gyro, vectors, IMU).
    pub newest: [Option<f64>; STREAMS],
    pub first_t: Option<f64>,
    /// `(t, fingerprint)` of recently accepted samples per stream.
    pub recent: [Vec<(f64, u64)>; STREAMS],
    pub jump: Option<JumpCandidate>,
    pub gate: BTreeMap<String, GateCounts>,
    pub consecutive_gated: u32,
    pub consecutive_failures: u32,
    pub rollbacks: u64,
    pub reinits: BTreeMap<String, u64>,
    pub last_good: Option<Estimate>,
    pub sensor_state: BTreeMap<String, SensorState>,
    pub ahrs: Option<AhrsState>,
    pub gyro_feed: Option<Stream>,
    pub last_imu_estimate_t: Option<f64>,
}

impl VehicleState {
    /// The whole state as plain data (a checkpoint).
    pub fn snapshot(&self) -> VehicleSnapshot {
        VehicleSnapshot {
            id: self.id.to_string(),
            config: self.config.clone(),
            filter: match &self.slot {
                Slot::Initializing => None,
                Slot::Tracking(f) => Some(f.state()),
            },
            seq: self.seq,
            generation: self.generation,
            last_t: self.last_t,
            last_gyro: self.last_gyro,
            held: self
                .held
                .iter()
                .map(|h| HeldSample {
                    t_s: h.key.t_s,
                    m: h.m.clone(),
                })
                .collect(),
            newest: self.newest,
            first_t: self.first_t,
            recent: std::array::from_fn(|i| {
                self.recent[i]
                    .iter()
                    .map(|(t, seen)| (*t, seen.fingerprint()))
                    .collect()
            }),
            jump: self.jump,
            gate: self.gate.clone(),
            consecutive_gated: self.consecutive_gated,
            consecutive_failures: self.consecutive_failures,
            rollbacks: self.rollbacks,
            reinits: self.reinits.clone(),
            last_good: self.last_good.clone(),
            sensor_state: self.sensor_state.clone(),
            ahrs: self.ahrs.as_ref().map(Ahrs::state),
            gyro_feed: self.gyro_feed,
            last_imu_estimate_t: self.last_imu_estimate_t,
        }
    }

    /// The vehicle of a snapshot, its filter and pipeline checked ([`FilterState::restore`],
    /// [`Ahrs::from_state`]); held samples are released at the next flush. The history of late samples
    /// is not saved: it starts again. `Err` says what is wrong.
    pub fn restore(s: VehicleSnapshot) -> Result<VehicleState, String> {
        let slot = match s.filter {
            None => Slot::Initializing,
            Some(f) => Slot::Tracking(f.restore().map_err(|e| e.to_string())?),
        };
        let ahrs = s.ahrs.map(Ahrs::from_state).transpose()?;
        if s.held.windows(2).any(|w| w[1].t_s < w[0].t_s) {
            return Err("the reorder window is not in time order".into());
        }
        let mut held: Vec<Held> = s
            .held
            .into_iter()
            .map(|h| Held {
                key: Key::of(&h.m),
                held_at_s: f64::NEG_INFINITY,
                m: h.m,
            })
            .collect();
        // (A checkpoint of an older build has equal times in arrival order: the stable sort gives the
        // processing order.)
        held.sort_by(|a, b| {
            a.key
                .partial_cmp(&b.key)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        Ok(VehicleState {
            id: s.id.into(),
            config: s.config,
            slot,
            seq: s.seq,
            generation: s.generation,
            last_t: s.last_t,
            last_key: s.last_t.map(Key::at),
            last_gyro: s.last_gyro,
            held: held.into(),
            history: Default::default(),
            late_fused: 0,
            replaying: false,
            newest: s.newest,
            first_t: s.first_t,
            recent: s
                .recent
                .map(|r| r.into_iter().map(|(t, h)| (t, Seen::Hashed(h))).collect()),
            jump: s.jump,
            gate: s.gate,
            consecutive_gated: s.consecutive_gated,
            consecutive_failures: s.consecutive_failures,
            rollbacks: s.rollbacks,
            reinits: s.reinits,
            last_good: s.last_good,
            sensor_state: s.sensor_state,
            ahrs,
            gyro_feed: s.gyro_feed,
            last_imu_estimate_t: s.last_imu_estimate_t,
        })
    }
}
