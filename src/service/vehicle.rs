//! One vehicle's filter and what happens to each input: a closed state machine, no I/O, no locks.
//!
//! `Initializing` (no filter yet: waiting for a vector set that determines the attitude, or for a
//! reset that gives it) → `Tracking` (a filter behind the shared interface). Each input either
//! changes the state and may produce an estimate, or is refused with a [`Rejection`] and changes
//! nothing.

use super::config::{InitMode, VehicleFilterConfig};
use crate::attitude::{q_method, Quaternion};
use crate::filters::{
    build_filter, AttitudeFilter, Fiducial, FilterError, FilterKind, FilterSpec, InitialState,
};
use crate::sensors::{GyroSample, Measurement, ObservationSet};
use crate::wire::{EstimateMsg, RejectCode, Rejection, ResetMsg, ResetReplyMsg};
use nalgebra::Vector3;

/// Attitude 1σ used by a reset that gives `q` without `sigma_deg`.
pub const DEFAULT_RESET_SIGMA_DEG: f64 = 1.0;

enum Slot {
    Initializing {
        /// The last gyro sample, whose rate is held when the filter starts.
        last_gyro: Option<GyroSample>,
    },
    Tracking {
        filter: Box<dyn AttitudeFilter>,
    },
}

/// A vehicle's filter state.
pub struct VehicleState {
    id: String,
    config: VehicleFilterConfig,
    slot: Slot,
    /// Estimates published so far.
    seq: u64,
    /// Filters created so far (derives each new filter's seed).
    generation: u64,
    /// Time of the last measurement used, s.
    last_t: Option<f64>,
}

/// What an accepted input produced.
pub enum Outcome {
    /// Nothing to publish (a gyro sample, or a vector set while still initialising).
    Quiet,
    /// A new estimate to publish on `P/V/estimate`.
    Estimate(EstimateMsg),
}

fn filter_error(e: FilterError) -> Rejection {
    match e {
        FilterError::OutOfOrder { .. } => Rejection::new(RejectCode::OutOfOrder, e.to_string()),
        FilterError::InvalidMeasurement(_) => Rejection::new(RejectCode::BadRequest, e.to_string()),
        _ => Rejection::new(
            RejectCode::FilterError,
            format!("{e}; the filter is unchanged"),
        ),
    }
}

/// FNV-1a: a stable per-vehicle seed from its id.
fn seed_of(id: &str, generation: u64) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in id.bytes().chain(generation.to_le_bytes()) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

impl VehicleState {
    pub fn new(id: &str, config: VehicleFilterConfig) -> Self {
        VehicleState {
            id: id.to_string(),
            config,
            slot: Slot::Initializing { last_gyro: None },
            seq: 0,
            generation: 0,
            last_t: None,
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

    pub fn is_tracking(&self) -> bool {
        matches!(self.slot, Slot::Tracking { .. })
    }

    pub fn last_t(&self) -> Option<f64> {
        self.last_t
    }

    pub fn seq(&self) -> u64 {
        self.seq
    }

    fn start(&mut self, initial: InitialState) -> Result<(), Rejection> {
        let seed = seed_of(&self.id, self.generation);
        let filter = build_filter(&self.config.filter, &initial, seed).map_err(|e| {
            Rejection::new(
                RejectCode::BadRequest,
                format!("cannot start the filter: {e}"),
            )
        })?;
        self.generation += 1;
        self.slot = Slot::Tracking { filter };
        Ok(())
    }

    fn publish(&mut self) -> Outcome {
        let Slot::Tracking { filter } = &self.slot else {
            return Outcome::Quiet;
        };
        self.seq += 1;
        Outcome::Estimate(EstimateMsg::from_domain(
            &self.id,
            &filter.spec(),
            &filter.estimate(),
            self.seq,
            self.particles(),
        ))
    }

    /// The current estimate, if the vehicle is tracking.
    pub fn estimate(&self) -> Option<EstimateMsg> {
        match &self.slot {
            Slot::Tracking { filter } => Some(EstimateMsg::from_domain(
                &self.id,
                &filter.spec(),
                &filter.estimate(),
                self.seq,
                self.particles(),
            )),
            Slot::Initializing { .. } => None,
        }
    }

    pub fn on_measurement(&mut self, m: Measurement) -> Result<Outcome, Rejection> {
        let t = m.t_s();
        if let Some(last) = self.last_t.filter(|_| !self.is_tracking()) {
            if t < last {
                return Err(Rejection::new(
                    RejectCode::OutOfOrder,
                    format!("measurement at t = {t} s is older than the last one ({last} s)"),
                ));
            }
        }
        if !self.is_tracking() && self.config.init == InitMode::Uniform {
            // A particle filter that starts from a uniformly random attitude at its first measurement.
            let held = self.held_gyro();
            self.start_uniform(t)?;
            if let Some(g) = held {
                self.feed_held_rate(&g, t)?;
            }
        }
        let is_vectors = matches!(m, Measurement::Vectors(_));
        let outcome = match (&mut self.slot, m) {
            (Slot::Tracking { filter }, m) => {
                filter.process(&m).map_err(filter_error)?;
                if is_vectors {
                    self.publish()
                } else {
                    Outcome::Quiet
                }
            }
            (Slot::Initializing { last_gyro }, Measurement::Gyro(g)) => {
                *last_gyro = Some(g);
                Outcome::Quiet
            }
            (Slot::Initializing { last_gyro }, Measurement::Vectors(set)) => {
                let held = *last_gyro;
                self.start_from_vectors(&set, held)?;
                self.publish()
            }
        };
        self.last_t = Some(self.last_t.map_or(t, |l| l.max(t)));
        Ok(outcome)
    }

    fn held_gyro(&self) -> Option<GyroSample> {
        match &self.slot {
            Slot::Initializing { last_gyro } => *last_gyro,
            Slot::Tracking { .. } => None,
        }
    }

    fn start_uniform(&mut self, t_s: f64) -> Result<(), Rejection> {
        self.start(InitialState {
            t_s: Some(t_s),
            q: Quaternion::IDENTITY,
            sigma_att_rad: Vector3::repeat(std::f64::consts::PI),
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: self.config.init_bias_sigma_rad_s,
            uniform_attitude: true,
        })
    }

    /// The held gyro rate at the start time: the last sample's rate, valid from `t_s` on.
    fn feed_held_rate(&mut self, g: &GyroSample, t_s: f64) -> Result<(), Rejection> {
        if let Slot::Tracking { filter } = &mut self.slot {
            filter
                .process(&Measurement::Gyro(GyroSample {
                    t_s,
                    omega_body_rad_s: g.omega_body_rad_s,
                }))
                .map_err(filter_error)?;
        }
        Ok(())
    }

    /// Starts from the q-method solution of `set` and its covariance (the set is not used twice).
    fn start_from_vectors(
        &mut self,
        set: &ObservationSet,
        held: Option<GyroSample>,
    ) -> Result<(), Rejection> {
        let solution = q_method(&set.observations).map_err(|e| {
            Rejection::new(
                RejectCode::NotInitialized,
                format!(
                    "vehicle {} is initialising and this set cannot start it ({e}); send a set with two or more non-parallel vectors, or reset with an attitude",
                    self.id
                ),
            )
        })?;
        let c = solution.covariance;
        let sigma = Vector3::new(c[(0, 0)].sqrt(), c[(1, 1)].sqrt(), c[(2, 2)].sqrt());
        self.start(InitialState {
            t_s: Some(set.t_s),
            q: solution.q,
            sigma_att_rad: sigma,
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: self.config.init_bias_sigma_rad_s,
            uniform_attitude: false,
        })?;
        if let Some(g) = held {
            self.feed_held_rate(&g, set.t_s)?;
        }
        Ok(())
    }

    /// Applies a reset request (already parsed); refuses invalid parameters without changing anything.
    pub fn on_reset(
        &mut self,
        req: &ResetMsg,
        base: &VehicleFilterConfig,
    ) -> Result<ResetReplyMsg, Rejection> {
        let bad = |code: RejectCode, m: String| Err(Rejection::new(code, m));
        let mut config = self.config.clone();
        if let Some(kind) = &req.filter {
            let spec: FilterSpec = match kind.as_str() {
                "mekf" | "usque" | "qpf" => {
                    kind.parse()
                        .map_err(|e: crate::filters::ParseFilterSpecError| {
                            Rejection::new(RejectCode::BadRequest, e.to_string())
                        })?
                }
                other => {
                    return bad(
                        RejectCode::BadRequest,
                        format!("filter '{other}': expected mekf, usque or qpf"),
                    )
                }
            };
            config.filter.spec.kind = spec.kind;
            if spec.kind == FilterKind::Mekf {
                config.filter.spec.fiducial = None;
            } else if config.filter.spec.fiducial.is_none() {
                config.filter.spec.fiducial = base.filter.spec.fiducial.or(Some(Fiducial::Average));
            }
            if spec.kind != FilterKind::Qpf && config.init == InitMode::Uniform {
                config.init = InitMode::Vectors;
            }
        }
        if let Some(f) = &req.fiducial {
            let fid = match f.as_str() {
                "average" => Fiducial::Average,
                "propagated" => Fiducial::Propagated,
                other => {
                    return bad(
                        RejectCode::BadRequest,
                        format!("fiducial '{other}': expected average or propagated"),
                    )
                }
            };
            if config.filter.spec.kind == FilterKind::Mekf {
                return bad(RejectCode::BadRequest, "the MEKF has no fiducial".into());
            }
            config.filter.spec.fiducial = Some(fid);
        }
        if let Some(n) = req.particles {
            if !(2..=1_000_000).contains(&n) {
                return bad(
                    RejectCode::BadRequest,
                    format!("particles must be in 2..=1000000, got {n}"),
                );
            }
            config.filter.particles = n;
        }
        let q = req.q.map(|q| q.to_domain()).transpose()?;
        let sigma_deg = req.sigma_deg.map(|s| s.to_vector());
        if let Some(s) = sigma_deg {
            if !s.iter().all(|x| x.is_finite()) {
                return bad(RejectCode::NonFinite, "sigma_deg must be finite".into());
            }
            if !s.iter().all(|x| *x > 0.0 && *x <= 360.0) {
                return bad(RejectCode::BadSigma, "sigma_deg must be in (0, 360]".into());
            }
        }
        let bias = match req.bias {
            Some(b) if b.iter().all(|x| x.is_finite()) => Vector3::new(b[0], b[1], b[2]),
            Some(_) => return bad(RejectCode::NonFinite, "bias must be finite".into()),
            None => Vector3::zeros(),
        };
        let bias_sigma = match req.bias_sigma.map(|s| s.to_vector()) {
            Some(s) if !s.iter().all(|x| x.is_finite()) => {
                return bad(RejectCode::NonFinite, "bias_sigma must be finite".into())
            }
            Some(s) if !s.iter().all(|x| *x > 0.0) => {
                return bad(RejectCode::BadSigma, "bias_sigma must be positive".into())
            }
            Some(s) => s,
            None => config.init_bias_sigma_rad_s,
        };
        if let Some(t) = req.t {
            if !t.is_finite() {
                return bad(RejectCode::NonFinite, "t must be finite".into());
            }
        }
        // Everything is valid: apply.
        let previous = std::mem::replace(&mut self.config, config);
        match q {
            Some(q) => {
                let sigma = sigma_deg.unwrap_or(Vector3::repeat(DEFAULT_RESET_SIGMA_DEG))
                    * std::f64::consts::PI
                    / 180.0;
                let initial = InitialState {
                    t_s: req.t.or(self.last_t),
                    q,
                    sigma_att_rad: sigma,
                    bias_rad_s: bias,
                    bias_sigma_rad_s: bias_sigma,
                    uniform_attitude: false,
                };
                if let Err(e) = self.start(initial) {
                    self.config = previous;
                    return Err(e);
                }
                if let Some(t) = req.t {
                    self.last_t = Some(t);
                }
            }
            None => {
                self.slot = Slot::Initializing { last_gyro: None };
                if req.t.is_some() {
                    self.last_t = req.t;
                }
            }
        }
        let estimate = match self.publish() {
            Outcome::Estimate(e) => Some(e),
            Outcome::Quiet => None,
        };
        Ok(ResetReplyMsg {
            vehicle: self.id.clone(),
            state: if self.is_tracking() {
                "tracking"
            } else {
                "initializing"
            }
            .into(),
            filter: self.spec().kind.as_str().into(),
            fiducial: self.spec().fiducial.map(|f| f.as_str().into()),
            particles: self.particles(),
            estimate,
        })
    }
}
