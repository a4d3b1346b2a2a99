//! The two ways a vehicle starts over from outside: a reset request, and a fleet takeover from the
//! last estimate another instance published. Both arrive as domain values, validated once at the
//! edge (`crate::wire`: `TryFrom<&ResetMsg>`, `TryFrom<&EstimateMsg>`).

use super::policy::{InitMode, Policy, VehicleFilterConfig};
use super::{
    Event, Published, ResetOutcome, Slot, VehicleState, DEFAULT_RESET_SIGMA_DEG, MAX_PARTICLES,
    STREAMS,
};
use crate::ahrs::SensorSheet;
use crate::attitude::Quaternion;
use crate::filters::sghqf::LEVELS;
use crate::filters::{is_spd, Fiducial, FilterKind, FilterSpec, InitialState};
use crate::rejection::{RejectCode, Rejection};
use crate::sensors::GyroSample;
use nalgebra::{Matrix6, Vector3};
use std::collections::VecDeque;

/// A reset request, its values checked on their own (finite, in range, known names). What depends on
/// the service's limits and on the vehicle's filter is checked by [`ResetRequest::config_for`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ResetRequest {
    /// Another filter kind; its fiducial is kept, or the default one.
    pub filter: Option<FilterKind>,
    pub fiducial: Option<Fiducial>,
    /// In `2..=MAX_PARTICLES`.
    pub particles: Option<usize>,
    /// The SGHQF's sparse-grid level, in [`crate::filters::sghqf::LEVELS`].
    pub level: Option<u8>,
    /// The attitude; absent: initialise from the next vector set (or the IMU's alignment).
    pub q: Option<Quaternion>,
    /// Attitude 1σ per axis, rad, in (0, 2π]; default [`DEFAULT_RESET_SIGMA_DEG`].
    pub sigma_att_rad: Option<Vector3<f64>>,
    /// Gyro bias, rad/s, finite.
    pub bias_rad_s: Option<Vector3<f64>>,
    /// Bias 1σ per axis, rad/s, positive.
    pub bias_sigma_rad_s: Option<Vector3<f64>>,
    /// Start time, s: re-anchors the vehicle's clock.
    pub t_s: Option<f64>,
    /// The IMU's datasheet values (validated); those given replace the vehicle's, the others stay.
    pub sensor: Option<SensorSheet>,
}

impl ResetRequest {
    /// The limits of the service: no bias (nor bias 1σ) beyond the largest rate accepted.
    fn check(&self, policy: &Policy) -> Result<(), Rejection> {
        let max = policy.max_rate_rad_s;
        if self.bias_rad_s.is_some_and(|b| b.norm() > max) {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                format!("|bias| must not exceed limits.max_rate_rad_s = {max} rad/s"),
            ));
        }
        if self.bias_sigma_rad_s.is_some_and(|s| s.amax() > max) {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                format!("bias_sigma must not exceed limits.max_rate_rad_s = {max} rad/s"),
            ));
        }
        Ok(())
    }

    /// The filter configuration of a vehicle that runs `current` after this reset (`base`: the
    /// vehicle's configured filter, whose fiducial a sampling filter takes when switched to), or why
    /// the service's limits or that filter refuse the request. Pure: the engine asks it before it
    /// creates a vehicle for a reset, the vehicle when it applies one.
    pub fn config_for(
        &self,
        current: &VehicleFilterConfig,
        base: &VehicleFilterConfig,
        policy: &Policy,
    ) -> Result<VehicleFilterConfig, Rejection> {
        self.check(policy)?;
        let mut config = current.clone();
        if let Some(kind) = self.filter {
            config.filter.spec.kind = kind;
            if kind == FilterKind::Mekf {
                config.filter.spec.fiducial = None;
            } else if config.filter.spec.fiducial.is_none() {
                config.filter.spec.fiducial = base.filter.spec.fiducial.or(Some(Fiducial::Average));
            }
            if kind != FilterKind::Qpf && config.init == InitMode::Uniform {
                config.init = InitMode::Vectors;
            }
        }
        if let Some(fiducial) = self.fiducial {
            if config.filter.spec.kind == FilterKind::Mekf {
                return Err(Rejection::new(
                    RejectCode::BadRequest,
                    "the MEKF has no fiducial".to_string(),
                ));
            }
            config.filter.spec.fiducial = Some(fiducial);
        }
        if let Some(n) = self.particles {
            config.filter.particles = n;
        }
        if let Some(l) = self.level {
            config.filter.level = l;
        }
        if let Some(s) = &self.sensor {
            config.sensor = s.or(&current.sensor);
        }
        Ok(config)
    }
}

/// Where a takeover starts: the last estimate another instance published (checked: finite, the
/// covariance positive definite).
#[derive(Clone, Debug, PartialEq)]
pub struct TakeoverSeed {
    pub t_s: f64,
    pub q: Quaternion,
    pub bias_rad_s: Vector3<f64>,
    pub covariance: Matrix6<f64>,
    pub spec: FilterSpec,
    pub particles: Option<usize>,
    pub level: Option<u8>,
    /// Estimates published so far: `seq` continues from it.
    pub seq: u64,
}

impl TakeoverSeed {
    /// Checks what the constructors of the edge cannot: finite values and a usable covariance.
    pub fn validated(self) -> Result<Self, String> {
        if !(self.t_s.is_finite()
            && self.bias_rad_s.iter().all(|b| b.is_finite())
            && is_spd(&self.covariance))
        {
            return Err(
                "time, bias and covariance must be finite, the covariance positive definite".into(),
            );
        }
        Ok(self)
    }
}

impl VehicleState {
    /// Starts a vehicle from the last estimate another instance published for it (a fleet takeover):
    /// its mean and full covariance (a particle filter draws its particles from them), the filter it
    /// ran, its time and its estimate count, so subscribers see `seq` continue. `last_gyro` is the
    /// last gyro sample at or before the estimate's time: its rate is held from there. Counted in
    /// `diagnostics.reinits.takeover`.
    pub fn take_over(
        id: &str,
        base: &VehicleFilterConfig,
        seed: &TakeoverSeed,
        last_gyro: Option<GyroSample>,
    ) -> Result<Self, Rejection> {
        let mut config = base.clone();
        config.filter.spec = seed.spec;
        if seed.spec.kind == FilterKind::Qpf {
            if let Some(n) = seed.particles {
                // (Bounded like a reset's: the estimate arrived over the network.)
                config.filter.particles = n.clamp(2, MAX_PARTICLES);
            }
        }
        if seed.spec.kind == FilterKind::Sghqf {
            if let Some(l) = seed.level {
                config.filter.level = l.clamp(*LEVELS.start(), *LEVELS.end());
            }
        }
        let mut state = VehicleState::new(id, config);
        let c = &seed.covariance;
        let sigma = |i: usize| c[(i, i)].sqrt();
        state.start(InitialState {
            t_s: Some(seed.t_s),
            q: seed.q,
            sigma_att_rad: Vector3::new(sigma(0), sigma(1), sigma(2)),
            bias_rad_s: seed.bias_rad_s,
            bias_sigma_rad_s: Vector3::new(sigma(3), sigma(4), sigma(5)),
            uniform_attitude: false,
            covariance: Some(seed.covariance),
        })?;
        state.last_gyro = last_gyro;
        state.feed_held_rate(seed.t_s)?;
        state.seq = seed.seq;
        state.last_t = Some(seed.t_s);
        state.last_key = Some(super::Key::at(seed.t_s));
        state.count_reinit("takeover");
        if let Slot::Tracking(filter) = &state.slot {
            state.last_good = Some(filter.estimate());
        }
        Ok(state)
    }

    /// Applies a reset request; refuses it without changing anything when the vehicle's filter cannot
    /// take it (a fiducial for the MEKF) or a limit forbids it. Samples still in the reorder window
    /// arrived before the reset and are used first.
    pub fn on_reset(
        &mut self,
        req: &ResetRequest,
        base: &VehicleFilterConfig,
        policy: &Policy,
        out: &mut Vec<Event>,
    ) -> Result<ResetOutcome, Rejection> {
        let config = req.config_for(&self.config, base, policy)?;
        // Everything is valid: use what arrived before the reset, then apply it.
        self.flush_all(policy, out);
        let previous = std::mem::replace(&mut self.config, config);
        // A reset starts the vehicle over: its filters draw the seeds of a new vehicle, so the same
        // inputs after a reset give the same estimates as into a new vehicle.
        self.generation = 0;
        match req.q {
            Some(q) => {
                let sigma = req.sigma_att_rad.unwrap_or(
                    Vector3::repeat(DEFAULT_RESET_SIGMA_DEG) * std::f64::consts::PI / 180.0,
                );
                let initial = InitialState {
                    t_s: req.t_s.or(self.last_t),
                    q,
                    sigma_att_rad: sigma,
                    bias_rad_s: req.bias_rad_s.unwrap_or_else(Vector3::zeros),
                    bias_sigma_rad_s: req
                        .bias_sigma_rad_s
                        .unwrap_or(self.config.init_bias_sigma_rad_s),
                    uniform_attitude: false,
                    covariance: None,
                };
                if let Err(e) = self.start(initial) {
                    self.config = previous;
                    return Err(e);
                }
            }
            None => self.slot = Slot::Initializing,
        }
        // Nothing before a reset is replayed after it.
        self.history.clear();
        if let Some(t) = req.t_s {
            // A reset with a time re-anchors the vehicle's clock (the way back after a jump).
            self.last_t = Some(t);
            self.last_key = Some(super::Key::at(t));
            self.newest = [None; STREAMS];
            self.first_t = None;
            self.recent = std::array::from_fn(|_| VecDeque::new());
        }
        // The IMU pipeline starts again, and the vehicle may switch between P/V/gyro and P/V/imu.
        self.ahrs = None;
        self.gyro_feed = None;
        self.last_imu_estimate_t = None;
        self.jump = None;
        self.consecutive_gated = 0;
        self.consecutive_failures = 0;
        self.last_good = None;
        let estimate: Option<Published> = match &self.slot {
            Slot::Tracking(filter) => {
                let e = filter.estimate();
                let mut events = Vec::new();
                self.emit(e, &mut events);
                events.into_iter().find_map(|ev| match ev {
                    Event::Estimate(p) => Some(p),
                    _ => None,
                })
            }
            Slot::Initializing => None,
        };
        Ok(ResetOutcome {
            vehicle: self.id.to_string(),
            tracking: self.is_tracking(),
            spec: self.spec(),
            particles: self.particles(),
            level: self.level(),
            estimate,
        })
    }
}
