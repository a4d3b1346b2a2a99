//! The filter interface shared by every estimator of this project, and the filters behind it.
//!
//! A filter consumes a time-ordered stream of [`Measurement`]s: gyro samples (a rate held until the
//! next sample) and vector-observation sets, possibly at different rates. For each input it propagates
//! from its current time to the input's time with the held rate, then uses the input. The time handling
//! lives once, in [`Driver`]; a filter implements only [`FilterCore`] (propagate over an interval, update
//! with a set of observations, report its estimate).
//!
//! Contract of [`FilterCore`]: a method that returns `Err` leaves the filter exactly as it was, so a bad
//! input or a numerical failure never poisons the state. [`AttitudeFilter::process`] propagates to the
//! measurement's time before it updates: when the update is refused, the filter stays propagated to
//! that time (a valid state; the input is not used).

mod driver;
pub mod mekf;
pub mod qpf;
pub mod sghqf;
pub mod sigma;
mod spec;
pub mod state;
pub mod usque;

use crate::attitude::Quaternion;
use crate::sensors::{GyroNoise, GyroSample, Measurement, VectorObservation};
use nalgebra::{Matrix3, Matrix6, Vector3};
use thiserror::Error;

pub use driver::{validate, Driver, GAP_INTERVALS, SAME_INSTANT_S};
pub use mekf::Mekf;
pub use qpf::{Kernel, Qpf, QpfOptions};
pub use sghqf::Sghqf;
pub use spec::{Fiducial, FilterKind, FilterSpec, ParseFilterSpecError};
pub use state::{DriverState, FilterState, MekfState, QpfState, SghqfState, UsqueState};
pub use usque::{Usque, UsqueOptions};

/// Settings common to every filter, plus the sampling filters' own.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterConfig {
    pub spec: FilterSpec,
    /// The gyro noise the filter assumes.
    pub gyro: GyroNoise,
    /// Particle count of the QPF.
    pub particles: usize,
    /// Accuracy level of the SGHQF's sparse-grid rule, 2..=4 (exact to degree `2L − 1`).
    pub level: u8,
    /// Tuning of the QPF (kernel, bandwidth, resampling, progressive correction).
    pub qpf: QpfOptions,
    /// Tuning of USQUE (Rodrigues parameters, λ).
    pub usque: UsqueOptions,
    /// How the uncertainty grows while gyro samples are missing.
    pub gap: GapModel,
    /// Gyro errors beyond the Farrenkopf model (none by default).
    pub gyro_errors: GyroErrors,
}

/// Gyro errors of real (MEMS) gyros beyond the Farrenkopf model of [`GyroNoise`]. The default adds
/// nothing (the filters are then exactly the textbook ones).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroErrors {
    /// Rate-proportional angle noise `k`, √s: the attitude variance grows by `(k ‖ω̂‖)² Δt` per step on
    /// top of `σ_v² Δt`, for the scale-factor, misalignment and g-sensitivity errors that make a gyro
    /// worse when it turns fast (a noise model of errors that are really slow: noise scheduling, so the
    /// covariance keeps up with them).
    pub rate_noise_sqrt_s: f64,
    /// The gyro bias as a first-order Gauss–Markov process with this stationary 1σ per axis, rad/s
    /// (`β̇ = −β/τ + η_u`, `τ = 2 σ_b²/σ_u²`): its uncertainty stays bounded however long it is not
    /// observed, and the estimate relaxes to zero over `τ`. Infinite: the random walk `β̇ = η_u`.
    pub bias_limit_rad_s: f64,
}

impl Default for GyroErrors {
    fn default() -> Self {
        GyroErrors {
            rate_noise_sqrt_s: 0.0,
            bias_limit_rad_s: f64::INFINITY,
        }
    }
}

impl GyroErrors {
    pub fn validate(&self) -> Result<(), FilterError> {
        if !(self.rate_noise_sqrt_s >= 0.0 && self.rate_noise_sqrt_s.is_finite()) {
            return Err(FilterError::InvalidConfig(
                "gyro rate noise must be finite and non-negative".into(),
            ));
        }
        if !(self.bias_limit_rad_s > 0.0) {
            return Err(FilterError::InvalidConfig(
                "gyro bias limit must be positive (infinite: none)".into(),
            ));
        }
        Ok(())
    }

    /// The attitude variance per axis added over `dt_s` at the estimated rate `omega`: `(k ‖ω‖)² Δt`.
    pub fn rate_variance(&self, omega_rad_s: &Vector3<f64>, dt_s: f64) -> f64 {
        let k = self.rate_noise_sqrt_s;
        if k == 0.0 {
            return 0.0;
        }
        k * k * omega_rad_s.norm_squared() * dt_s
    }

    /// `1/τ` of the Gauss–Markov bias, `τ = 2 σ_b²/σ_u²` (0 for a random walk): `φ = e^{−Δt/τ}`.
    pub fn bias_reversion_rate(&self, gyro: &GyroNoise) -> f64 {
        let sb = self.bias_limit_rad_s;
        if !sb.is_finite() || gyro.sigma_u <= 0.0 {
            return 0.0;
        }
        gyro.sigma_u * gyro.sigma_u / (2.0 * sb * sb)
    }

    /// `φ = e^{−Δt/τ}` of the Gauss–Markov bias, `τ = 2 σ_b²/σ_u²` (1 for a random walk).
    pub fn bias_reversion(&self, gyro: &GyroNoise, dt_s: f64) -> f64 {
        let sb = self.bias_limit_rad_s;
        if !sb.is_finite() || gyro.sigma_u <= 0.0 {
            return 1.0;
        }
        let tau = 2.0 * sb * sb / (gyro.sigma_u * gyro.sigma_u);
        (-dt_s / tau).exp()
    }
}

/// The uncertainty added while no gyro sample arrives.
///
/// Between samples the last measured rate is held. Once the time since the last sample exceeds
/// `after_s` and [`GAP_INTERVALS`] of the gyro's usual interval, the held rate is no longer trusted to the gyro's noise model: the rate may have changed
/// by an unknown angular acceleration (1σ `accel_sigma_rad_s2` per axis, constant over the gap), and the
/// held sample's own noise (`σ_v²/Δt_g`, with `Δt_g` the interval it covered) is integrated over the
/// whole gap. After a gap of `τ` the added attitude variance per axis is
/// `σ_a² τ⁴/4 + (σ_v²/Δt_g) τ²`, added segment by segment as the filter propagates, counted from the
/// last sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapModel {
    /// A gap starts no sooner than this after the last gyro sample, s.
    pub after_s: f64,
    /// 1σ of the unknown angular acceleration during a gap, rad/s² per axis.
    pub accel_sigma_rad_s2: f64,
}

impl Default for GapModel {
    fn default() -> Self {
        GapModel {
            after_s: 1.0,
            accel_sigma_rad_s2: 1e-4,
        }
    }
}

impl GapModel {
    /// Attitude variance per axis accumulated `tau_s` after the last gyro sample (`dt_g` its interval).
    fn variance(&self, tau_s: f64, sigma_v: f64, dt_g_s: f64) -> f64 {
        let a = self.accel_sigma_rad_s2;
        a * a * tau_s.powi(4) / 4.0 + sigma_v * sigma_v / dt_g_s * tau_s * tau_s
    }
}

impl FilterConfig {
    pub fn new(spec: FilterSpec, gyro: GyroNoise) -> Self {
        FilterConfig {
            spec,
            gyro,
            particles: 1000,
            level: sghqf::DEFAULT_LEVEL,
            qpf: QpfOptions::default(),
            usque: UsqueOptions::default(),
            gap: GapModel::default(),
            gyro_errors: GyroErrors::default(),
        }
    }
}

/// What a filter is told about the vehicle at the start.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialState {
    /// Start time, s; `None` takes the time of the first measurement.
    pub t_s: Option<f64>,
    pub q: Quaternion,
    /// 1σ of the attitude error about each body axis, rad.
    pub sigma_att_rad: Vector3<f64>,
    pub bias_rad_s: Vector3<f64>,
    pub bias_sigma_rad_s: Vector3<f64>,
    /// Nothing is known about the attitude: a particle filter draws it uniformly; a Kalman filter uses
    /// `q` with `sigma_att_rad`.
    pub uniform_attitude: bool,
    /// A full 6×6 covariance of `[δα (rad); δβ (rad/s)]` in place of the two diagonals (a start from a
    /// published estimate, e.g. a fleet takeover); it must be symmetric positive definite.
    pub covariance: Option<Matrix6<f64>>,
}

impl InitialState {
    /// The initial covariance: `covariance` when given, otherwise the diagonal of the two sigmas.
    pub fn covariance_matrix(&self) -> Matrix6<f64> {
        if let Some(p) = self.covariance {
            return p;
        }
        let mut p = Matrix6::zeros();
        for i in 0..3 {
            p[(i, i)] = self.sigma_att_rad[i].powi(2);
            p[(i + 3, i + 3)] = self.bias_sigma_rad_s[i].powi(2);
        }
        p
    }
}

/// What a filter knows about itself. Fields a filter does not have are `None`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// Gyro propagations and vector updates processed.
    pub propagations: u64,
    pub updates: u64,
    /// Normalised innovation squared of the last update and its degrees of freedom (Kalman filters).
    pub nis: Option<f64>,
    pub nis_dof: Option<usize>,
    /// Effective sample size `1/Σwᵢ²` of the last update (particle filter).
    pub ess: Option<f64>,
    /// Concentration `λ₁/Σw` and eigen-gap of the last quaternion average (averaged fiducial).
    pub concentration: Option<f64>,
    pub eigen_gap: Option<f64>,
    /// Progressive-correction stages of the last update and resamplings so far (particle filter).
    pub pc_stages: Option<u32>,
    pub resamples: Option<u64>,
    /// Times the averaged fiducial was undecidable and the propagated one was used instead.
    pub fiducial_fallbacks: Option<u64>,
    /// Time since the last gyro sample when it exceeds the gap threshold (a gyro gap is in progress:
    /// the held rate is used and the attitude uncertainty is inflated), s.
    pub gyro_gap_s: Option<f64>,
    /// Gyro gaps seen so far.
    pub gyro_gaps: u64,
}

/// A filter's estimate at its current time.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    pub t_s: f64,
    pub q: Quaternion,
    pub bias_rad_s: Vector3<f64>,
    /// Covariance of `[δα (rad, body frame); δβ (rad/s)]`.
    pub covariance: Matrix6<f64>,
    pub diagnostics: Diagnostics,
}

impl Estimate {
    /// 1σ of the attitude error per body axis, rad.
    pub fn sigma_att_rad(&self) -> Vector3<f64> {
        Vector3::new(
            self.covariance[(0, 0)].max(0.0).sqrt(),
            self.covariance[(1, 1)].max(0.0).sqrt(),
            self.covariance[(2, 2)].max(0.0).sqrt(),
        )
    }
}

#[derive(Clone, Debug, Error, PartialEq)]
pub enum FilterError {
    #[error("measurement at t = {t_s} s is older than the filter time {filter_t_s} s")]
    OutOfOrder { t_s: f64, filter_t_s: f64 },
    #[error("invalid measurement: {0}")]
    InvalidMeasurement(String),
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    #[error("innovation covariance is not positive definite (observation {index})")]
    SingularInnovation { index: usize },
    #[error("covariance lost positive definiteness after {step}")]
    NotPositiveDefinite { step: &'static str },
    #[error("non-finite state after {step}")]
    NonFinite { step: &'static str },
    #[error("all particle weights vanished")]
    WeightsVanished,
}

/// What every filter implements; the time bookkeeping is [`Driver`]'s.
pub trait FilterCore: Send {
    fn spec(&self) -> FilterSpec;
    /// Propagates over `dt_s > 0` with the measured rate `omega_meas_rad_s` (the gyro bias is the
    /// filter's to remove).
    fn propagate(&mut self, omega_meas_rad_s: &Vector3<f64>, dt_s: f64) -> Result<(), FilterError> {
        self.propagate_with(omega_meas_rad_s, dt_s, 0.0)
    }
    /// [`FilterCore::propagate`] with `extra_rad2` of attitude variance per axis added over the step
    /// beside the gyro model's own (what a sample's rate may hide: a saturated axis, the rate's
    /// change over the interval); the same bits as `propagate` for 0.
    fn propagate_with(
        &mut self,
        omega_meas_rad_s: &Vector3<f64>,
        dt_s: f64,
        extra_rad2: f64,
    ) -> Result<(), FilterError>;
    /// Updates with the observations taken at the current time.
    fn update(&mut self, observations: &[VectorObservation]) -> Result<(), FilterError>;
    /// The estimate (its `t_s` is filled in by the driver).
    fn estimate(&self) -> Estimate;
    /// The current gyro-bias estimate, rad/s (cheaper than a whole estimate for a particle filter).
    fn bias_rad_s(&self) -> Vector3<f64> {
        self.estimate().bias_rad_s
    }
    /// Updates with a direct observation of the gyro bias, `z = β + n`, `n ~ N(0, σ² I₃)` (rad/s; e.g.
    /// the mean gyro rate while the vehicle is known to be at rest).
    fn update_bias(&mut self, z_rad_s: &Vector3<f64>, sigma_rad_s: f64) -> Result<(), FilterError>;
    /// Adds `cov_rad2` to the covariance of the body-frame attitude error (uncertainty the gyro model
    /// does not know of: a gyro gap, a re-acquisition). `cov_rad2` is finite, symmetric and positive
    /// semi-definite.
    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>);
    /// The whole filter (with its driver's bookkeeping) as plain data, for a checkpoint.
    fn state(driver: &Driver<Self>) -> FilterState
    where
        Self: Sized;
    /// [`FilterCore::state`] written over `into`, reusing its allocations where the filter has
    /// large ones (the particle cloud); the same value as `state`.
    fn state_into(driver: &Driver<Self>, into: &mut FilterState)
    where
        Self: Sized,
    {
        *into = Self::state(driver);
    }
}

/// Object-safe interface every filter is used through.
pub trait AttitudeFilter: Send {
    fn spec(&self) -> FilterSpec;
    /// The filter's time, s (`None` before the first measurement when no start time was given).
    fn time_s(&self) -> Option<f64>;
    /// Gaps in the gyro samples so far (`filter.gap`): each bridged and paid for in the covariance.
    fn gyro_gaps(&self) -> u64;
    /// Propagates to the measurement's time, then uses it.
    fn process(&mut self, measurement: &Measurement) -> Result<(), FilterError>;
    /// Propagates to `t_s` (no later than the next measurement's time) without using a measurement.
    fn advance_to(&mut self, t_s: f64) -> Result<(), FilterError>;
    /// A gyro rate measured over `(t_prev_s, t_s]` (a raw IMU sample's): exactly
    /// `process(&Measurement::Gyro(GyroSample { t_s: t_prev_s, omega_body_rad_s }))` and then
    /// `advance_to(t_s)`, in one call (the raw-IMU pipeline makes one per sample).
    fn gyro_interval(
        &mut self,
        t_prev_s: f64,
        omega_body_rad_s: &Vector3<f64>,
        t_s: f64,
    ) -> Result<(), FilterError> {
        self.process(&Measurement::Gyro(GyroSample {
            t_s: t_prev_s,
            omega_body_rad_s: *omega_body_rad_s,
        }))?;
        self.advance_to(t_s)
    }
    /// [`AttitudeFilter::gyro_interval`] with `extra_rad2` of attitude variance per axis added over
    /// the interval beside the gyro model's own ([`FilterCore::propagate_with`]); exactly
    /// `gyro_interval` for 0.
    fn gyro_interval_with(
        &mut self,
        t_prev_s: f64,
        omega_body_rad_s: &Vector3<f64>,
        t_s: f64,
        extra_rad2: f64,
    ) -> Result<(), FilterError> {
        self.gyro_interval(t_prev_s, omega_body_rad_s, t_s)?;
        if extra_rad2 > 0.0 {
            self.inflate_attitude(&(Matrix3::identity() * extra_rad2))?;
        }
        Ok(())
    }
    /// One vector observation taken at `t_s`: exactly `process` of the set of that one observation,
    /// without making the set (the raw-IMU pipeline's tilt and heading updates).
    fn observe(&mut self, t_s: f64, observation: &VectorObservation) -> Result<(), FilterError> {
        self.process(&Measurement::Vectors(crate::sensors::ObservationSet {
            t_s,
            observations: vec![observation.clone()],
        }))
    }
    /// Propagates to `t_s`, then updates with a direct observation of the gyro bias
    /// ([`FilterCore::update_bias`]).
    fn observe_bias(
        &mut self,
        t_s: f64,
        z_rad_s: &Vector3<f64>,
        sigma_rad_s: f64,
    ) -> Result<(), FilterError>;
    /// Adds `cov_rad2` to the attitude-error covariance now ([`FilterCore::inflate_attitude`]);
    /// refused unless finite and symmetric positive semi-definite.
    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) -> Result<(), FilterError>;
    /// The gyro-bias estimate, rad/s (cheaper than [`AttitudeFilter::estimate`]).
    fn bias_rad_s(&self) -> Vector3<f64>;
    fn estimate(&self) -> Estimate;
    /// The filter's complete state as plain data, for a checkpoint ([`FilterState::restore`]
    /// rebuilds the filter from it).
    fn state(&self) -> FilterState;
    /// [`AttitudeFilter::state`] written over `into`, reusing its allocations
    /// ([`FilterCore::state_into`]).
    fn state_into(&self, into: &mut FilterState);
}

/// Largest gyro rate a filter takes, rad/s.
pub const MAX_RATE_RAD_S: f64 = 1e100;

/// Builds a filter behind the shared interface. `seed` seeds the filter's own RNG (sampling filters).
pub fn build_filter(
    config: &FilterConfig,
    initial: &InitialState,
    seed: u64,
) -> Result<Box<dyn AttitudeFilter>, FilterError> {
    config.gyro_errors.validate()?;
    // Variances are squares of these: they must stay finite.
    let sane = |v: &Vector3<f64>| v.iter().all(|x| (x * x).is_finite());
    if !sane(&initial.sigma_att_rad)
        || !sane(&initial.bias_sigma_rad_s)
        || !sane(&initial.bias_rad_s)
    {
        return Err(FilterError::InvalidConfig(
            "initial sigmas and bias must be finite with finite squares".into(),
        ));
    }
    if let Some(p) = &initial.covariance {
        if !is_spd(p) {
            return Err(FilterError::InvalidConfig(
                "the initial covariance must be symmetric positive definite".into(),
            ));
        }
    }
    match config.spec.kind {
        FilterKind::Mekf => Ok(Box::new(
            Driver::new(Mekf::new(config, initial)?, initial.t_s)
                .with_gap(config.gap, &config.gyro),
        )),
        FilterKind::Usque => Ok(Box::new(
            Driver::new(Usque::new(config, initial, config.usque)?, initial.t_s)
                .with_gap(config.gap, &config.gyro),
        )),
        FilterKind::Qpf => Ok(Box::new(
            Driver::new(Qpf::new(config, initial, config.qpf, seed)?, initial.t_s)
                .with_gap(config.gap, &config.gyro),
        )),
        FilterKind::Sghqf => Ok(Box::new(
            Driver::new(Sghqf::new(config, initial)?, initial.t_s)
                .with_gap(config.gap, &config.gyro),
        )),
    }
}

/// Symmetrises a covariance in place: `P ← (P + Pᵀ)/2`.
pub fn symmetrize(p: &mut Matrix6<f64>) {
    *p = (*p + p.transpose()) * 0.5;
}

/// True when `p` is finite, symmetric to rounding and positive definite (Cholesky succeeds).
pub fn is_spd(p: &Matrix6<f64>) -> bool {
    p.iter().all(|x| x.is_finite()) && p.cholesky().is_some()
}

/// The necessary conditions of positive definiteness: finite, a positive diagonal, every correlation
/// within ±1 (`Pᵢⱼ² ≤ Pᵢᵢ Pⱼⱼ`, upper triangle: the filters keep their covariances symmetric). They catch what a failed step leaves (a NaN, a variance driven
/// negative) at a fraction of a Cholesky's cost: release builds check a Kalman filter's estimate with
/// them before it is published, every sample (the filter checked its covariance in full when it last
/// updated, and a propagation keeps it positive definite); debug builds and the core's tests run the
/// full Cholesky ([`is_spd`]) as well.
pub fn plausibly_spd(p: &Matrix6<f64>) -> bool {
    let a = &p.data.0;
    // Finite: 0·x is 0 for a finite x and NaN otherwise, summed in six lanes (it vectorises).
    let mut lanes = [0.0; 6];
    for row in a {
        for j in 0..6 {
            lanes[j] += row[j] * 0.0;
        }
    }
    let mut ok = lanes.iter().sum::<f64>() == 0.0;
    for i in 0..6 {
        ok &= a[i][i] > 0.0;
        for j in i + 1..6 {
            ok &= a[i][j] * a[i][j] <= a[i][i] * a[j][j];
        }
    }
    if cfg!(any(debug_assertions, test)) {
        ok &= is_spd(p);
    }
    ok
}

/// The check before a filter step commits (nothing is changed when it fails): the step's new values
/// are `finite`, its covariance `p` is positive definite.
pub(crate) fn check_commit(
    step: &'static str,
    finite: bool,
    p: &Matrix6<f64>,
) -> Result<(), FilterError> {
    if !finite {
        return Err(FilterError::NonFinite { step });
    }
    if !is_spd(p) {
        return Err(FilterError::NotPositiveDefinite { step });
    }
    Ok(())
}
