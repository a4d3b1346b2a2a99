//! The sigma-point filter: USQUE's local/global recursion (docs/algorithms.md §3) once, generic over
//! its point rule ([`PointRule`]): the unscented set of [`super::usque`] (`2n + 1` points, weights from
//! `λ`, all positive) and the sparse-grid rules of [`super::sghqf`] (a Smolyak rule's points, weights
//! of both signs). [`super::Usque`] and [`super::Sghqf`] are this filter with one rule each; what the
//! rule decides is listed on [`PointRule`], the rest (the propagation and update, the fiducial, the
//! bias update, the inflation, the estimate, the rollback contract) is here.
//!
//! Local/global structure: the state is `x = [δp; β]` (`n = 6`), `δp` the generalized Rodrigues
//! parameters of the error `δq = q ⊗ q_ref⁻¹` about a reference quaternion `q_ref` (the rule's
//! [`Chart`]), `β` the gyro bias; `P` is the 6×6 covariance of `x`.
//!
//! # State between propagation and update (design choice)
//!
//! The filter always holds `(q_ref, x̂, P)` with the estimate `q̂ = GRP⁻¹(δp̂) ⊗ q_ref`:
//!
//! * After an update (and at start) `q_ref = q̂` and `δp̂ = 0` (the reset of step 7).
//! * A propagation ends in the state `(q_ref = q_fid, x̂⁻, P⁻)` *without* folding `δp̂⁻` into the
//!   quaternion: `P⁻` is the covariance of the sigma points in the chart about `q_fid`, and `x̂⁻` is their
//!   mean in that chart, so nothing is approximated. The propagated sigma points `q⁻(i)`, `χ(i)` are kept
//!   for the update (step 6).
//! * A further propagation before any update draws its sigma points from `(x̂⁻, P⁻ + Q̄)` in the same
//!   chart: `χ(0) = x̂⁻` (its attitude part is not zero then), `q⁺(i) = GRP⁻¹(χ^δp(i)) ⊗ q_ref`. The central
//!   point is therefore always the current estimate `q̂`, so the `Propagated` fiducial is exactly the
//!   previous estimate propagated like an EKF (Chang 2014, Eq. 1). The kept sigma points are replaced.
//! * An update with no propagation since the last update (two observation sets at the same time, or an
//!   observation set at the start time) redraws the sigma points from `(x̂, P)` about `q_ref` (no `Q̄`:
//!   no time passed) and uses `q_fid = q_ref`. No average is taken there: the points are symmetric in the
//!   chart about the estimate itself.
//!
//! A successful update consumes the kept sigma points. A method that returns `Err` changes nothing
//! (everything is computed into temporaries and committed at the end), including the kept points and the
//! diagnostics.

use super::{
    check_commit, is_spd, symmetrize, Diagnostics, Driver, DriverState, Estimate, Fiducial,
    FilterConfig, FilterCore, FilterError, FilterKind, FilterSpec, FilterState, GyroErrors,
    InitialState,
};
use crate::attitude::{AverageError, Grp, Quaternion, QuaternionAverage};
use crate::sensors::{Aspect, GyroNoise, VectorObservation};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix3x6, Matrix6, Vector3, Vector6};
use std::borrow::Cow;
use std::fmt::Debug;

/// Dimension of the local state `[δp; β]`.
pub const N_STATE: usize = 6;

/// The process noise `Q̄ = (Δt/2) diag[(σ_v² − σ_u² Δt²/6) I₃, σ_u² I₃]` of USQUE (which the SGHQF
/// uses too) in physical units (rad², rad²/s²). It is added twice (inside the sigma-point spread and
/// after propagation), which reproduces the MEKF's `Q` to first order. Its attitude part is negative for
/// `Δt > √6 σ_v/σ_u` (≈ 2450 s for the standard gyro); the spread's Cholesky then refuses if `P` does not
/// dominate it.
pub fn process_noise_bar(gyro: &GyroNoise, dt_s: f64) -> Matrix6<f64> {
    let (sv2, su2) = (gyro.sigma_v * gyro.sigma_v, gyro.sigma_u * gyro.sigma_u);
    let att = 0.5 * dt_s * (sv2 - su2 * dt_s * dt_s / 6.0);
    let bias = 0.5 * dt_s * su2;
    Matrix6::from_diagonal(&Vector6::new(att, att, att, bias, bias, bias))
}

/// The local attitude-error chart of a rule, and the units of the covariance's attitude block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Chart {
    /// Any GRP `(a, f)` (USQUE): the attitude block is in GRP units. `Q̄`, an inflation and the initial
    /// covariance are physical (rad) and are divided by `k²`, `k = grp.small_angle_factor()`
    /// (`δα ≈ k δp`); the estimate's covariance is `J P J`, `J = diag(k, k, k, 1, 1, 1)`.
    Grp(Grp),
    /// The GRP `a = 1, f = 4` ([`Grp::USQUE`], `k = 1`) with the attitude block in rad and nothing
    /// converted (the SGHQF). Not `Grp(Grp::USQUE)`: the products with the diagonal scalings are the
    /// identity in value but not to the bit (`0·x` terms turn a `−0` into `+0` and spread a non-finite
    /// entry), and the SGHQF has never made them.
    Radians,
}

impl Chart {
    pub fn grp(&self) -> Grp {
        match self {
            Chart::Grp(grp) => *grp,
            Chart::Radians => Grp::USQUE,
        }
    }

    /// A physical attitude variance (rad²) in the chart's units.
    fn variance(&self, rad2: f64) -> f64 {
        match self {
            Chart::Grp(grp) => {
                let k = grp.small_angle_factor();
                rad2 / (k * k)
            }
            Chart::Radians => rad2,
        }
    }

    /// A physical attitude covariance (rad²) in the chart's units.
    fn attitude_covariance(&self, cov_rad2: &Matrix3<f64>) -> Matrix3<f64> {
        match self {
            Chart::Grp(grp) => {
                let k = grp.small_angle_factor();
                cov_rad2 / (k * k)
            }
            Chart::Radians => *cov_rad2,
        }
    }

    /// The covariance of `[δα (rad); δβ]` in the chart's units (the attitude rows and columns divided
    /// by `k`: `δp ≈ δα / k`).
    fn covariance_in_chart(&self, p: &Matrix6<f64>) -> Matrix6<f64> {
        match self {
            Chart::Grp(grp) => {
                let k = grp.small_angle_factor();
                let scale =
                    Matrix6::from_diagonal(&Vector6::new(1.0 / k, 1.0 / k, 1.0 / k, 1.0, 1.0, 1.0));
                scale * p * scale
            }
            Chart::Radians => *p,
        }
    }

    /// The covariance in the chart's units as that of `[δα (rad); δβ]`: `J P J`, `δα ≈ k δp`.
    fn covariance_in_radians(&self, p: &Matrix6<f64>) -> Matrix6<f64> {
        match self {
            Chart::Grp(grp) => {
                let k = grp.small_angle_factor();
                let j = Matrix6::from_diagonal(&Vector6::new(k, k, k, 1.0, 1.0, 1.0));
                j * p * j
            }
            Chart::Radians => *p,
        }
    }
}

/// How the weighted deviations make `P^yy` and `P^xy`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weighting {
    /// Every weight positive: the deviations are scaled by `√wᵢ` and `P^yy = G Gᵀ`, `P^xy = X Gᵀ`
    /// (USQUE, `λ > 0`).
    SquareRoot,
    /// Weights of both signs (no square root): the weights on one side of each product,
    /// `P^yy = Σ wᵢ (γᵢ − ŷ)(·)ᵀ`, `P^xy = Σ wᵢ (χᵢ − x̂)(γᵢ − ŷ)ᵀ` (the SGHQF).
    Signed,
}

/// The propagated points kept for the next update: the global quaternions `q⁻(i)` and the local states
/// `χ(i) = [GRP(q⁻(i) ⊗ q_ref⁻¹); χ^β(i)]`, one each per point of the rule.
pub trait PointSet: Clone + Debug + PartialEq + Send {
    fn q(&self) -> &[Quaternion];
    fn chi(&self) -> &[Vector6<f64>];
    fn parts_mut(&mut self) -> (&mut [Quaternion], &mut [Vector6<f64>]);
}

/// [`PointSet`] for a struct of the fields `q` and `chi` (arrays or vectors).
macro_rules! point_set {
    ($points:ty) => {
        impl $crate::filters::sigma::PointSet for $points {
            fn q(&self) -> &[$crate::attitude::Quaternion] {
                &self.q
            }

            fn chi(&self) -> &[nalgebra::Vector6<f64>] {
                &self.chi
            }

            fn parts_mut(
                &mut self,
            ) -> (
                &mut [$crate::attitude::Quaternion],
                &mut [nalgebra::Vector6<f64>],
            ) {
                (&mut self.q, &mut self.chi)
            }
        }
    };
}
pub(in crate::filters) use point_set;

/// What differs between the sigma-point filters: how the points and weights are formed, the chart,
/// how the quaternions are averaged, how the weighted moments are formed, the names, the saved state.
pub trait PointRule: Clone + Debug + Send + Sized {
    /// The filter this rule makes.
    const KIND: FilterKind;
    /// The step named in the refusal when the points cannot be spread (`P` not positive definite),
    /// in a propagation and in an update without one before it.
    const PROPAGATION_SPREAD: &'static str;
    const UPDATE_SPREAD: &'static str;
    const WEIGHTING: Weighting;
    /// The points kept from a propagation (the checkpoint's layout).
    type Points: PointSet;

    fn chart(&self) -> Chart;
    /// The weights `wᵢ` (`Σ wᵢ = 1`), point 0 the centre.
    fn weights(&self) -> &[f64];
    /// The points `χ(i)` about `x̂` with the covariance `cov`, and their quaternions
    /// `GRP⁻¹(χ^δp(i)) ⊗ q_ref` ([`on_chart`]); `None` when `cov` is not positive definite (or not
    /// finite). The centre `χ(0) = x̂`.
    fn draw(
        &self,
        x: &Vector6<f64>,
        q_ref: &Quaternion,
        cov: &Matrix6<f64>,
    ) -> Option<Self::Points>;
    /// The weighted average of the propagated quaternions (the `Average` fiducial), with `central` for
    /// its sign; an error when it is not to be trusted (the filter then keeps the central point).
    fn average(
        &self,
        q: &[Quaternion],
        central: &Quaternion,
    ) -> Result<QuaternionAverage, AverageError>;
    /// The filter and its driver's bookkeeping as plain data.
    fn state(filter: &SigmaFilter<Self>, driver: DriverState) -> FilterState;
}

/// A sigma-point filter with the rule `R`.
#[derive(Clone, Debug)]
pub struct SigmaFilter<R: PointRule> {
    pub(in crate::filters) gyro: GyroNoise,
    pub(in crate::filters) gyro_errors: GyroErrors,
    pub(in crate::filters) fiducial: Fiducial,
    pub(in crate::filters) rule: R,
    /// The chart centre: `q̂ = GRP⁻¹(δp̂) ⊗ q_ref`.
    pub(in crate::filters) q_ref: Quaternion,
    /// `[δp̂; β̂]` in the chart about `q_ref` (`δp̂ = 0` after an update).
    pub(in crate::filters) x: Vector6<f64>,
    /// Covariance of `x`, in the chart's units on the attitude block.
    pub(in crate::filters) p: Matrix6<f64>,
    /// The propagated points, until an update consumes them.
    pub(in crate::filters) points: Option<R::Points>,
    pub(in crate::filters) diagnostics: Diagnostics,
}

/// `GRP⁻¹(x^δp) ⊗ q_ref`: the quaternion of a local state.
pub fn on_chart(grp: &Grp, x: &Vector6<f64>, q_ref: &Quaternion) -> Quaternion {
    grp.to_quaternion(&attitude_part(x)).compose(q_ref)
}

fn attitude_part(x: &Vector6<f64>) -> Vector3<f64> {
    Vector3::new(x[0], x[1], x[2])
}

fn bias_part(x: &Vector6<f64>) -> Vector3<f64> {
    Vector3::new(x[3], x[4], x[5])
}

fn all_finite<'a>(values: impl IntoIterator<Item = &'a f64>) -> bool {
    values.into_iter().all(|v| v.is_finite())
}

/// The gyro noise densities' check of a constructor.
pub(in crate::filters) fn check_gyro(g: &GyroNoise) -> Result<(), FilterError> {
    if !(g.sigma_v.is_finite() && g.sigma_v >= 0.0 && g.sigma_u.is_finite() && g.sigma_u >= 0.0) {
        return Err(FilterError::InvalidConfig(
            "gyro noise densities must be non-negative and finite".into(),
        ));
    }
    Ok(())
}

impl<R: PointRule> SigmaFilter<R> {
    /// The filter at its start, after checking the initial state: its quaternion, sigmas and bias,
    /// and the covariance in the chart's units. The fiducial is `config.spec.fiducial` (the averaged
    /// one when absent). The gyro checks are the constructors' ([`check_gyro`], in their order).
    pub(in crate::filters) fn start(
        rule: R,
        config: &FilterConfig,
        initial: &InitialState,
    ) -> Result<Self, FilterError> {
        let q = initial.q.normalized().ok_or_else(|| {
            FilterError::InvalidConfig("initial quaternion has no direction".into())
        })?;
        let sigmas_ok = initial
            .sigma_att_rad
            .iter()
            .chain(initial.bias_sigma_rad_s.iter())
            .all(|s| s.is_finite() && *s > 0.0);
        if !sigmas_ok || !initial.bias_rad_s.iter().all(|b| b.is_finite()) {
            return Err(FilterError::InvalidConfig(
                "initial sigmas must be positive and finite, the initial bias finite".into(),
            ));
        }
        let p = rule
            .chart()
            .covariance_in_chart(&initial.covariance_matrix());
        if !is_spd(&p) {
            return Err(FilterError::InvalidConfig(
                "initial covariance is not positive definite".into(),
            ));
        }
        let fiducial = config.spec.fiducial.unwrap_or(Fiducial::Average);
        let b = initial.bias_rad_s;
        Ok(SigmaFilter {
            gyro: config.gyro,
            gyro_errors: config.gyro_errors,
            fiducial,
            rule,
            q_ref: q,
            x: Vector6::new(0.0, 0.0, 0.0, b[0], b[1], b[2]),
            p,
            points: None,
            diagnostics: Diagnostics {
                fiducial_fallbacks: (fiducial == Fiducial::Average).then_some(0),
                ..Diagnostics::default()
            },
        })
    }

    pub fn fiducial(&self) -> Fiducial {
        self.fiducial
    }

    /// True between a propagation and the update that consumes its points.
    pub fn has_propagated_points(&self) -> bool {
        self.points.is_some()
    }

    /// `Q̄` in the filter's units, with half the rate-proportional noise of [`GyroErrors`] at the
    /// estimated rate `omega_hat` and half of `extra_rad2` (`Q̄` is added twice).
    fn q_bar(&self, dt_s: f64, omega_hat: &Vector3<f64>, extra_rad2: f64) -> Matrix6<f64> {
        let chart = self.rule.chart();
        let mut q = process_noise_bar(&self.gyro, dt_s);
        let extra = 0.5 * (self.gyro_errors.rate_variance(omega_hat, dt_s) + extra_rad2);
        for i in 0..3 {
            q[(i, i)] = chart.variance(q[(i, i)] + extra);
        }
        q
    }

    /// The rule's points about the estimate with the covariance `cov` (see [`PointRule::draw`]).
    pub(in crate::filters) fn draw(&self, cov: &Matrix6<f64>) -> Option<R::Points> {
        self.rule.draw(&self.x, &self.q_ref, cov)
    }

    /// The fiducial of propagated points: the central one, or their weighted average (with its
    /// diagnostics), falling back to the central one when the average is not to be trusted
    /// (undecidable, non-finite, or with signed weights too indefinite or outside the points).
    fn fiducial_of(&self, q: &[Quaternion]) -> (Quaternion, Option<QuaternionAverage>, bool) {
        let central = q[0];
        match self.fiducial {
            Fiducial::Propagated => (central, None, false),
            Fiducial::Average => match self.rule.average(q, &central) {
                Ok(avg) => (avg.q, Some(avg), false),
                Err(_) => (central, None, true),
            },
        }
    }
}

/// The observations as full vectors: the sigma-point filters have no scalar update, so a heading- or
/// tilt-only observation is used with its full-direction likelihood (crate::sensors::heading; a heading
/// may tilt the estimate). Borrowed when every observation is full already.
fn full_vectors(observations: &[VectorObservation]) -> Cow<'_, [VectorObservation]> {
    if observations.iter().all(|o| o.aspect == Aspect::Full) {
        return Cow::Borrowed(observations);
    }
    observations
        .iter()
        .map(|o| VectorObservation {
            aspect: Aspect::Full,
            ..o.clone()
        })
        .collect()
}

/// `P^yy` (without the measurement noise) and `(P^xy)ᵀ` (`3m × 6`) from the predicted observations
/// `gamma` (a column a point), their mean `y_hat`, the points `chi` about `x`, the weights `w`.
fn moments(
    weighting: Weighting,
    mut gamma: DMatrix<f64>,
    y_hat: &DVector<f64>,
    chi: &[Vector6<f64>],
    x: &Vector6<f64>,
    w: &[f64],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut xdev = DMatrix::<f64>::zeros(N_STATE, chi.len());
    match weighting {
        Weighting::SquareRoot => {
            for (i, ci) in chi.iter().enumerate() {
                let s = w[i].sqrt();
                let mut col = gamma.column_mut(i);
                col -= y_hat;
                col *= s;
                xdev.set_column(i, &((ci - x) * s));
            }
            let pyy = &gamma * gamma.transpose();
            let pxy_t = &gamma * xdev.transpose();
            (pyy, pxy_t)
        }
        Weighting::Signed => {
            for (i, ci) in chi.iter().enumerate() {
                let mut col = gamma.column_mut(i);
                col -= y_hat;
                xdev.set_column(i, &(ci - x));
            }
            let mut weighted = gamma.clone();
            for (i, wi) in w.iter().enumerate() {
                weighted.column_mut(i).scale_mut(*wi);
            }
            let pyy = &weighted * gamma.transpose();
            let pxy_t = &weighted * xdev.transpose();
            (pyy, pxy_t)
        }
    }
}

/// The first observation whose leading block of `P^vv` is not positive definite (for the error report;
/// only evaluated on the failure path).
fn first_singular_observation(pvv: &DMatrix<f64>, m: usize) -> usize {
    (0..m)
        .find(|&j| {
            let d = 3 * (j + 1);
            pvv.view((0, 0), (d, d)).clone_owned().cholesky().is_none()
        })
        .unwrap_or(m.saturating_sub(1))
}

impl<R: PointRule> FilterCore for SigmaFilter<R> {
    fn spec(&self) -> FilterSpec {
        FilterSpec {
            kind: R::KIND,
            fiducial: Some(self.fiducial),
        }
    }

    /// Steps 1–5 of docs/algorithms.md §3 over `dt_s` with the measured rate `ω̃`, with the rule's
    /// points and weights.
    fn propagate_with(
        &mut self,
        omega_meas_rad_s: &Vector3<f64>,
        dt_s: f64,
        extra_rad2: f64,
    ) -> Result<(), FilterError> {
        if !(dt_s.is_finite() && dt_s > 0.0 && all_finite(omega_meas_rad_s.iter())) {
            return Err(FilterError::InvalidMeasurement(
                "propagation needs a finite rate and a positive, finite interval".into(),
            ));
        }
        let grp = self.rule.chart().grp();
        let q_bar = self.q_bar(dt_s, &(omega_meas_rad_s - bias_part(&self.x)), extra_rad2);
        // 1–3. The points about the estimate from P + Q̄, q⁺(i) = GRP⁻¹(χ^δp(i)) ⊗ q_ref, each
        // propagated with its own bias: q⁻(i) = Ω(ω̃ − χ^β(i)) q⁺(i).
        let mut pts = self
            .draw(&(self.p + q_bar))
            .ok_or(FilterError::NotPositiveDefinite {
                step: R::PROPAGATION_SPREAD,
            })?;
        let (q, chi) = pts.parts_mut();
        for (qi, ci) in q.iter_mut().zip(chi.iter()) {
            *qi = qi.propagate(&(omega_meas_rad_s - bias_part(ci)), dt_s);
        }
        // 4. The fiducial.
        let (q_fid, average, fallback) = self.fiducial_of(q);
        // Products of unit quaternions drift from unit norm only by rounding; remove it.
        let q_fid = q_fid.normalized().ok_or(FilterError::NonFinite {
            step: "propagation",
        })?;
        // 5. χ^δp(i) = GRP(q⁻(i) ⊗ q_fid⁻¹), x̂⁻ = Σ wᵢ χ(i), P⁻ = Σ wᵢ (χ(i) − x̂⁻)(·)ᵀ + Q̄.
        let q_fid_inv = q_fid.inverse();
        let w = self.rule.weights();
        let mut x = Vector6::zeros();
        for ((ci, qi), wi) in chi.iter_mut().zip(q.iter()).zip(w) {
            let dp = grp.from_quaternion(&qi.compose(&q_fid_inv));
            ci.fixed_rows_mut::<3>(0).copy_from(&dp);
            x += *ci * *wi;
        }
        let mut p = q_bar;
        for (ci, wi) in chi.iter().zip(w) {
            let d = ci - x;
            p += d * d.transpose() * *wi;
        }
        // A bounded (Gauss–Markov) bias reverts to zero: x_β ← φ x_β.
        let phi_b = self.gyro_errors.bias_reversion(&self.gyro, dt_s);
        if phi_b < 1.0 {
            for i in 3..6 {
                x[i] *= phi_b;
            }
            for i in 0..6 {
                for j in 3..6 {
                    p[(i, j)] *= phi_b;
                    p[(j, i)] *= phi_b;
                }
            }
        }
        symmetrize(&mut p);
        let finite =
            all_finite(x.iter()) && all_finite(p.iter()) && q.iter().all(|qi| qi.is_finite());
        check_commit("propagation", finite, &p)?;
        // Commit.
        self.q_ref = q_fid;
        self.x = x;
        self.p = p;
        self.points = Some(pts);
        let d = &mut self.diagnostics;
        d.propagations += 1;
        // After a fallback there is no decided average: its concentration and gap read `None`.
        if self.fiducial == Fiducial::Average {
            d.concentration = average.map(|a| a.concentration);
            d.eigen_gap = average.map(|a| a.gap);
            if fallback {
                d.fiducial_fallbacks = Some(d.fiducial_fallbacks.unwrap_or(0) + 1);
            }
        }
        Ok(())
    }

    /// Steps 6–7 of docs/algorithms.md §3 with the stacked observations (`3m` rows), in one batch:
    /// `P^yy` and `P^xy` by the rule's [`Weighting`]; then, with `L = chol(P^vv)`,
    /// `M = L⁻¹ (P^xy)ᵀ` and `z = L⁻¹ ν`: `K ν = Mᵀ z`, `K P^vv Kᵀ = Mᵀ M` and the NIS is `zᵀ z`, so the
    /// gain is never formed and `P^vv` never inverted.
    ///
    /// An empty set changes nothing (the kept points stay). Non-finite observations are refused;
    /// `σ = 0` is not (the Driver refuses it): it makes `P^vv` singular only where the points do not
    /// spread the prediction, which is reported as `SingularInnovation` with the first observation
    /// whose leading block fails.
    fn update(&mut self, observations: &[VectorObservation]) -> Result<(), FilterError> {
        let observations = full_vectors(observations);
        if observations.is_empty() {
            return Ok(());
        }
        for (i, o) in observations.iter().enumerate() {
            if !all_finite(o.body.iter()) || !all_finite(o.reference.iter()) || !o.sigma.is_finite()
            {
                return Err(FilterError::InvalidMeasurement(format!(
                    "observation {i} is not finite"
                )));
            }
        }
        let drawn;
        let pts = match &self.points {
            Some(p) => p,
            // No propagation since the last update: redraw about q_ref from (x̂, P).
            None => {
                drawn = self.draw(&self.p).ok_or(FilterError::NotPositiveDefinite {
                    step: R::UPDATE_SPREAD,
                })?;
                &drawn
            }
        };
        let (q, chi) = (pts.q(), pts.chi());
        let m = observations.len();
        let rows = 3 * m;
        let w = self.rule.weights();
        // γ(i) = [A(q⁻(i)) r_j]_j, ŷ = Σ wᵢ γ(i).
        let mut gamma = DMatrix::<f64>::zeros(rows, q.len());
        for (i, qi) in q.iter().enumerate() {
            let a = qi.attitude_matrix();
            for (j, o) in observations.iter().enumerate() {
                gamma
                    .fixed_view_mut::<3, 1>(3 * j, i)
                    .copy_from(&(a * o.reference));
            }
        }
        let mut y_hat = DVector::<f64>::zeros(rows);
        for (i, wi) in w.iter().enumerate() {
            y_hat.axpy(*wi, &gamma.column(i), 1.0);
        }
        let (mut pvv, pxy_t) = moments(R::WEIGHTING, gamma, &y_hat, chi, &self.x, w);
        for (j, o) in observations.iter().enumerate() {
            for r in 0..3 {
                pvv[(3 * j + r, 3 * j + r)] += o.sigma * o.sigma;
            }
        }
        let pvv = (&pvv + pvv.transpose()) * 0.5;
        let Some(chol) = pvv.clone().cholesky() else {
            return Err(FilterError::SingularInnovation {
                index: first_singular_observation(&pvv, m),
            });
        };
        let l = chol.l();
        let mut nu = DVector::<f64>::zeros(rows);
        for (j, o) in observations.iter().enumerate() {
            for r in 0..3 {
                nu[3 * j + r] = o.body[r] - y_hat[3 * j + r];
            }
        }
        let (Some(z), Some(mm)) = (
            l.solve_lower_triangular(&nu),
            l.solve_lower_triangular(&pxy_t),
        ) else {
            return Err(FilterError::SingularInnovation { index: 0 });
        };
        let nis = z.dot(&z);
        let dx_dyn = mm.transpose() * &z;
        let reduction = mm.transpose() * &mm;
        let x = self.x + Vector6::from_fn(|r, _| dx_dyn[r]);
        let mut p = self.p - Matrix6::from_fn(|r, c| reduction[(r, c)]);
        symmetrize(&mut p);
        // 7. q̂⁺ = GRP⁻¹(δp̂⁺) ⊗ q_fid, then δp̂⁺ = 0 (q_fid is q_ref: see the module docs).
        let q_new = on_chart(&self.rule.chart().grp(), &x, &self.q_ref)
            .normalized()
            .ok_or(FilterError::NonFinite { step: "update" })?;
        let finite = q_new.is_finite() && all_finite(x.iter()) && nis.is_finite();
        check_commit("update", finite, &p)?;
        // Commit.
        self.q_ref = q_new;
        self.x = Vector6::new(0.0, 0.0, 0.0, x[3], x[4], x[5]);
        self.p = p;
        self.points = None;
        self.diagnostics.updates += 1;
        self.diagnostics.nis = Some(nis);
        self.diagnostics.nis_dof = Some(rows);
        Ok(())
    }

    /// A linear Kalman update (`H = [0₃, I₃]`: exact for any Gaussian filter), Joseph form; the
    /// attitude correction is folded into the chart centre as after a vector update, and the kept
    /// points are dropped (the next update redraws them).
    fn update_bias(&mut self, z_rad_s: &Vector3<f64>, sigma_rad_s: f64) -> Result<(), FilterError> {
        let nu = z_rad_s - bias_part(&self.x);
        let mut h = Matrix3x6::zeros();
        h.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&Matrix3::identity());
        let r = sigma_rad_s * sigma_rad_s;
        let pht = self.p * h.transpose();
        let chol = (h * pht + Matrix3::identity() * r)
            .cholesky()
            .ok_or(FilterError::SingularInnovation { index: 0 })?;
        let gain = chol.solve(&pht.transpose()).transpose();
        let ikh = Matrix6::identity() - gain * h;
        let mut p = ikh * self.p * ikh.transpose() + gain * gain.transpose() * r;
        symmetrize(&mut p);
        let x = self.x + gain * nu;
        let q_new = on_chart(&self.rule.chart().grp(), &x, &self.q_ref)
            .normalized()
            .ok_or(FilterError::NonFinite {
                step: "bias update",
            })?;
        check_commit("bias update", q_new.is_finite() && all_finite(x.iter()), &p)?;
        self.q_ref = q_new;
        self.x = Vector6::new(0.0, 0.0, 0.0, x[3], x[4], x[5]);
        self.p = p;
        self.points = None;
        Ok(())
    }

    /// In the chart's units; the kept points no longer describe the inflated distribution, so the
    /// next update redraws them.
    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) {
        let mut block = self.p.fixed_view_mut::<3, 3>(0, 0);
        block += self.rule.chart().attitude_covariance(cov_rad2);
        self.points = None;
    }

    fn state(driver: &Driver<Self>) -> FilterState {
        R::state(driver.core(), driver.driver_state())
    }

    /// `q̂ = GRP⁻¹(δp̂) ⊗ q_ref`, `β̂`, and the covariance of `[δα (rad); δβ]` ([`Chart`]).
    fn estimate(&self) -> Estimate {
        let q = on_chart(&self.rule.chart().grp(), &self.x, &self.q_ref);
        Estimate {
            t_s: 0.0,
            q: q.normalized().unwrap_or(q).canonical(),
            bias_rad_s: bias_part(&self.x),
            covariance: self.rule.chart().covariance_in_radians(&self.p),
            diagnostics: self.diagnostics.clone(),
        }
    }
}
