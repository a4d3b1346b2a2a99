//! UnScented QUaternion Estimator, USQUE (Crassidis & Markley 2003; docs/algorithms.md §3), with both
//! fiducials: the propagated central sigma point (the original USQUE) and the MMSE weighted average of
//! the propagated sigma-point quaternions (the modified USQUE of Chang, Hu & Chang 2014).
//!
//! Local/global structure: the state is `x = [δp; β]` (`n = 6`), `δp` the generalized Rodrigues
//! parameters ([`Grp`], default `a = 1, f = 4`) of the error `δq = q ⊗ q_ref⁻¹` about a reference
//! quaternion `q_ref`, `β` the gyro bias. `P` is the 6×6 covariance of `x` (GRP units on the attitude
//! block); [`FilterCore::estimate`] converts it to small-angle radians.
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
//!
//! # Units of `Q̄` and of the initial covariance
//!
//! `Q̄` and the initial attitude sigma are physical (rad); the attitude block is divided by `k²`,
//! `k = grp.small_angle_factor()` (`δα ≈ k δp`), to express it in GRP units. For the default
//! `a = 1, f = 4`, `k = 1` and this changes nothing.

use super::{
    check_commit, is_spd, symmetrize, Diagnostics, Driver, Estimate, Fiducial, FilterConfig,
    FilterCore, FilterError, FilterKind, FilterSpec, FilterState, GyroErrors, InitialState,
    UsqueState,
};
use crate::attitude::{AverageAccumulator, Grp, Quaternion};
use crate::sensors::{Aspect, GyroNoise, VectorObservation};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix3x6, Matrix6, Vector3, Vector6};

/// Dimension of the local state `[δp; β]`.
pub const N_STATE: usize = 6;
/// Number of sigma points, `2n + 1`.
pub const N_SIGMA: usize = 2 * N_STATE + 1;

/// USQUE settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UsqueOptions {
    /// The local attitude-error chart. Default `a = 1, f = 4` ([`Grp::USQUE`]).
    pub grp: Grp,
    /// The sigma-point scaling `λ`; must be `> 0` (a non-positive central weight can make the averaging
    /// matrix indefinite and the covariance non-positive). Default 1.
    pub lambda: f64,
}

impl Default for UsqueOptions {
    fn default() -> Self {
        UsqueOptions {
            grp: Grp::USQUE,
            lambda: 1.0,
        }
    }
}

impl UsqueOptions {
    /// The weights `(W₀, Wᵢ) = (λ/(n + λ), 1/(2(n + λ)))`.
    pub fn weights(&self) -> (f64, f64) {
        let n = N_STATE as f64;
        (
            self.lambda / (n + self.lambda),
            1.0 / (2.0 * (n + self.lambda)),
        )
    }

    pub(super) fn validate(&self) -> Result<(), FilterError> {
        if !(self.lambda.is_finite() && self.lambda > 0.0) {
            return Err(FilterError::InvalidConfig(format!(
                "USQUE lambda must be positive and finite (got {})",
                self.lambda
            )));
        }
        let Grp { a, f } = self.grp;
        if !(a.is_finite() && a >= 0.0 && f.is_finite() && f > 0.0) {
            return Err(FilterError::InvalidConfig(format!(
                "USQUE GRP needs a ≥ 0 and f > 0, finite (got a = {a}, f = {f})"
            )));
        }
        Ok(())
    }
}

/// The USQUE process noise `Q̄ = (Δt/2) diag[(σ_v² − σ_u² Δt²/6) I₃, σ_u² I₃]` in physical units
/// (rad², rad²/s²). It is added twice (inside the sigma-point spread and after propagation), which
/// reproduces the MEKF's `Q` to first order. Its attitude part is negative for
/// `Δt > √6 σ_v/σ_u` (≈ 2450 s for the standard gyro); the spread's Cholesky then refuses if `P` does not
/// dominate it.
pub fn process_noise_bar(gyro: &GyroNoise, dt_s: f64) -> Matrix6<f64> {
    let (sv2, su2) = (gyro.sigma_v * gyro.sigma_v, gyro.sigma_u * gyro.sigma_u);
    let att = 0.5 * dt_s * (sv2 - su2 * dt_s * dt_s / 6.0);
    let bias = 0.5 * dt_s * su2;
    Matrix6::from_diagonal(&Vector6::new(att, att, att, bias, bias, bias))
}

/// Sigma points kept from a propagation for the next update.
#[derive(Clone, Debug, PartialEq)]
pub struct SigmaPoints {
    /// The global quaternions `q⁻(i)`.
    pub q: [Quaternion; N_SIGMA],
    /// The local states `χ(i) = [GRP(q⁻(i) ⊗ q_ref⁻¹); χ^β(i)]`.
    pub chi: [Vector6<f64>; N_SIGMA],
}

/// The USQUE state.
#[derive(Clone, Debug)]
pub struct Usque {
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    options: UsqueOptions,
    fiducial: Fiducial,
    /// `(W₀, Wᵢ)`.
    w0: f64,
    wi: f64,
    /// The chart centre: `q̂ = GRP⁻¹(δp̂) ⊗ q_ref`.
    q_ref: Quaternion,
    /// `[δp̂; β̂]` in the chart about `q_ref` (`δp̂ = 0` after an update).
    x: Vector6<f64>,
    /// Covariance of `x`, GRP units on the attitude block.
    p: Matrix6<f64>,
    /// The propagated sigma points, until an update consumes them.
    sigma: Option<SigmaPoints>,
    diagnostics: Diagnostics,
}

impl Usque {
    /// A USQUE from the shared configuration; the fiducial is `config.spec.fiducial` (the averaged one
    /// when absent).
    pub fn new(
        config: &FilterConfig,
        initial: &InitialState,
        options: UsqueOptions,
    ) -> Result<Self, FilterError> {
        options.validate()?;
        let fiducial = config.spec.fiducial.unwrap_or(Fiducial::Average);
        let g = config.gyro;
        if !(g.sigma_v.is_finite() && g.sigma_v >= 0.0 && g.sigma_u.is_finite() && g.sigma_u >= 0.0)
        {
            return Err(FilterError::InvalidConfig(
                "gyro noise densities must be non-negative and finite".into(),
            ));
        }
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
        let k = options.grp.small_angle_factor();
        // The attitude rows and columns in GRP units (δp ≈ δα / k).
        let scale = Matrix6::from_diagonal(&Vector6::new(1.0 / k, 1.0 / k, 1.0 / k, 1.0, 1.0, 1.0));
        let p = scale * initial.covariance_matrix() * scale;
        if !is_spd(&p) {
            return Err(FilterError::InvalidConfig(
                "initial covariance is not positive definite".into(),
            ));
        }
        let b = initial.bias_rad_s;
        let (w0, wi) = options.weights();
        let diagnostics = Diagnostics {
            fiducial_fallbacks: (fiducial == Fiducial::Average).then_some(0),
            ..Diagnostics::default()
        };
        config.gyro_errors.validate()?;
        Ok(Usque {
            gyro: config.gyro,
            gyro_errors: config.gyro_errors,
            options,
            fiducial,
            w0,
            wi,
            q_ref: q,
            x: Vector6::new(0.0, 0.0, 0.0, b[0], b[1], b[2]),
            p,
            sigma: None,
            diagnostics,
        })
    }

    /// The USQUE of a saved state (checked by [`FilterState::restore`]); the weights follow from
    /// the options.
    pub(super) fn from_state(s: UsqueState) -> Self {
        let (w0, wi) = s.options.weights();
        Usque {
            gyro: s.gyro,
            gyro_errors: s.gyro_errors,
            options: s.options,
            fiducial: s.fiducial,
            w0,
            wi,
            q_ref: s.q_ref,
            x: s.x,
            p: s.p,
            sigma: s.sigma,
            diagnostics: s.diagnostics,
        }
    }

    pub fn options(&self) -> &UsqueOptions {
        &self.options
    }

    pub fn fiducial(&self) -> Fiducial {
        self.fiducial
    }

    /// True between a propagation and the update that consumes its sigma points.
    pub fn has_propagated_sigma_points(&self) -> bool {
        self.sigma.is_some()
    }

    fn weight(&self, i: usize) -> f64 {
        if i == 0 {
            self.w0
        } else {
            self.wi
        }
    }

    /// `Q̄` in the filter's units (attitude block divided by `k²`), with half the rate-proportional
    /// noise of [`GyroErrors`] at the estimated rate `omega_hat` (`Q̄` is added twice).
    fn q_bar(&self, dt_s: f64, omega_hat: &Vector3<f64>, extra_rad2: f64) -> Matrix6<f64> {
        let k = self.options.grp.small_angle_factor();
        let mut q = process_noise_bar(&self.gyro, dt_s);
        let extra = 0.5 * (self.gyro_errors.rate_variance(omega_hat, dt_s) + extra_rad2);
        for i in 0..3 {
            q[(i, i)] = (q[(i, i)] + extra) / (k * k);
        }
        q
    }

    /// The columns of `chol((n + λ) cov)` (lower factor), or `None` when `cov` is not positive definite.
    fn spread(&self, cov: &Matrix6<f64>) -> Option<Matrix6<f64>> {
        if !cov.iter().all(|v| v.is_finite()) {
            return None;
        }
        let scaled = cov * (N_STATE as f64 + self.options.lambda);
        scaled.cholesky().map(|c| c.l())
    }

    /// The prior sigma points `χ(0) = x̂`, `χ(i) = x̂ ± σ(i)` and their quaternions
    /// `GRP⁻¹(χ^δp(i)) ⊗ q_ref`.
    fn draw(&self, l: &Matrix6<f64>) -> ([Vector6<f64>; N_SIGMA], [Quaternion; N_SIGMA]) {
        let mut chi = [self.x; N_SIGMA];
        for j in 0..N_STATE {
            let col: Vector6<f64> = l.column(j).into_owned();
            chi[1 + j] = self.x + col;
            chi[1 + N_STATE + j] = self.x - col;
        }
        let mut q = [Quaternion::IDENTITY; N_SIGMA];
        for (qi, ci) in q.iter_mut().zip(chi.iter()) {
            *qi = self
                .options
                .grp
                .to_quaternion(&attitude_part(ci))
                .compose(&self.q_ref);
        }
        (chi, q)
    }
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

impl FilterCore for Usque {
    fn spec(&self) -> FilterSpec {
        FilterSpec {
            kind: FilterKind::Usque,
            fiducial: Some(self.fiducial),
        }
    }

    /// Steps 1–5 of docs/algorithms.md §3 over `dt_s` with the measured rate `ω̃`.
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
        let grp = self.options.grp;
        let q_bar = self.q_bar(dt_s, &(omega_meas_rad_s - bias_part(&self.x)), extra_rad2);
        // 1. σ = ± columns of chol((n + λ)(P + Q̄)).
        let l = self
            .spread(&(self.p + q_bar))
            .ok_or(FilterError::NotPositiveDefinite {
                step: "propagation (sigma-point spread)",
            })?;
        // 2–3. q⁺(i) = GRP⁻¹(χ^δp(i)) ⊗ q_ref, q⁻(i) = Ω(ω̃ − χ^β(i)) q⁺(i).
        let (mut chi, mut q) = self.draw(&l);
        for (qi, ci) in q.iter_mut().zip(chi.iter()) {
            *qi = qi.propagate(&(omega_meas_rad_s - bias_part(ci)), dt_s);
        }
        // 4. The fiducial.
        let central = q[0];
        let mut average = None;
        let mut fallback = false;
        let q_fid = match self.fiducial {
            Fiducial::Propagated => central,
            Fiducial::Average => {
                let mut acc = AverageAccumulator::new();
                for (i, qi) in q.iter().enumerate() {
                    acc.add(qi, self.weight(i));
                }
                match acc.finish(Some(&central)) {
                    Ok(avg) => {
                        average = Some(avg);
                        avg.q
                    }
                    // Undecidable (equal top eigenvalues to rounding) or non-finite: use q⁻(0).
                    Err(_) => {
                        fallback = true;
                        central
                    }
                }
            }
        };
        // Products of unit quaternions drift from unit norm only by rounding; remove it.
        let q_fid = q_fid.normalized().ok_or(FilterError::NonFinite {
            step: "propagation",
        })?;
        // 5. χ^δp(i) = GRP(q⁻(i) ⊗ q_fid⁻¹), x̂⁻ = Σ Wᵢ χ(i), P⁻ = Σ Wᵢ (χ(i) − x̂⁻)(·)ᵀ + Q̄.
        let q_fid_inv = q_fid.inverse();
        let mut x = Vector6::zeros();
        for (i, (ci, qi)) in chi.iter_mut().zip(q.iter()).enumerate() {
            let dp = grp.from_quaternion(&qi.compose(&q_fid_inv));
            ci.fixed_rows_mut::<3>(0).copy_from(&dp);
            x += *ci * self.weight(i);
        }
        let mut p = q_bar;
        for (i, ci) in chi.iter().enumerate() {
            let d = ci - x;
            p += d * d.transpose() * self.weight(i);
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
        self.sigma = Some(SigmaPoints { q, chi });
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

    /// Steps 6–7 of docs/algorithms.md §3 with the stacked observations (`3m` rows), in one batch.
    ///
    /// With `L = chol(P^vv)`, `M = L⁻¹ (P^xy)ᵀ` and `z = L⁻¹ ν`: `K ν = Mᵀ z`, `K P^vv Kᵀ = Mᵀ M` and the
    /// NIS is `zᵀ z`, so the gain is never formed and `P^vv` never inverted.
    ///
    /// An empty set changes nothing (the kept sigma points stay). Non-finite observations are refused;
    /// `σ = 0` is not (the Driver refuses it): it makes `P^vv` singular only where the sigma points do
    /// not spread the prediction, which is reported as `SingularInnovation` with the first observation
    /// whose leading block fails.
    fn update(&mut self, observations: &[VectorObservation]) -> Result<(), FilterError> {
        // USQUE has no scalar update: a heading-only observation is used as the full vector
        // (crate::sensors::imu; it may tilt the estimate).
        let owned: Vec<VectorObservation>;
        // A tilt-only observation is used as the full vector too (its likelihood is the full one).
        let observations = if observations.iter().any(|o| o.aspect != Aspect::Full) {
            owned = observations
                .iter()
                .map(|o| VectorObservation {
                    aspect: Aspect::Full,
                    ..o.clone()
                })
                .collect();
            &owned[..]
        } else {
            observations
        };
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
        let (chi, q) = match &self.sigma {
            Some(s) => (&s.chi, &s.q),
            None => {
                // No propagation since the last update: redraw about q_ref from (x̂, P).
                let l = self
                    .spread(&self.p)
                    .ok_or(FilterError::NotPositiveDefinite {
                        step: "update (sigma-point spread)",
                    })?;
                drawn = self.draw(&l);
                (&drawn.0, &drawn.1)
            }
        };
        let m = observations.len();
        let rows = 3 * m;
        // γ(i) = [A(q⁻(i)) r_j]_j, ŷ = Σ Wᵢ γ(i).
        let mut gamma = DMatrix::<f64>::zeros(rows, N_SIGMA);
        for (i, qi) in q.iter().enumerate() {
            let a = qi.attitude_matrix();
            for (j, o) in observations.iter().enumerate() {
                gamma
                    .fixed_view_mut::<3, 1>(3 * j, i)
                    .copy_from(&(a * o.reference));
            }
        }
        let mut y_hat = DVector::<f64>::zeros(rows);
        for i in 0..N_SIGMA {
            y_hat.axpy(self.weight(i), &gamma.column(i), 1.0);
        }
        // Weighted deviations: P^yy = G Gᵀ, P^xy = X Gᵀ (all weights are positive since λ > 0).
        let mut g = gamma;
        let mut xdev = DMatrix::<f64>::zeros(N_STATE, N_SIGMA);
        for (i, ci) in chi.iter().enumerate() {
            let s = self.weight(i).sqrt();
            let mut col = g.column_mut(i);
            col -= &y_hat;
            col *= s;
            xdev.set_column(i, &((ci - self.x) * s));
        }
        let mut pvv = &g * g.transpose();
        for (j, o) in observations.iter().enumerate() {
            for r in 0..3 {
                pvv[(3 * j + r, 3 * j + r)] += o.sigma * o.sigma;
            }
        }
        let pvv = (&pvv + pvv.transpose()) * 0.5;
        let pxy_t = &g * xdev.transpose(); // (P^xy)ᵀ, 3m × 6
        let chol = match pvv.clone().cholesky() {
            Some(c) => c,
            None => {
                return Err(FilterError::SingularInnovation {
                    index: first_singular_observation(&pvv, m),
                })
            }
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
        let dx = Vector6::from_fn(|r, _| dx_dyn[r]);
        let mut p = self.p - Matrix6::from_fn(|r, c| reduction[(r, c)]);
        symmetrize(&mut p);
        let x = self.x + dx;
        // 7. q̂⁺ = GRP⁻¹(δp̂⁺) ⊗ q_fid, then δp̂⁺ = 0 (q_fid is q_ref: see the module docs).
        let q_new = self
            .options
            .grp
            .to_quaternion(&attitude_part(&x))
            .compose(&self.q_ref)
            .normalized()
            .ok_or(FilterError::NonFinite { step: "update" })?;
        let finite = q_new.is_finite() && all_finite(x.iter()) && nis.is_finite();
        check_commit("update", finite, &p)?;
        // Commit.
        self.q_ref = q_new;
        self.x = Vector6::new(0.0, 0.0, 0.0, x[3], x[4], x[5]);
        self.p = p;
        self.sigma = None;
        self.diagnostics.updates += 1;
        self.diagnostics.nis = Some(nis);
        self.diagnostics.nis_dof = Some(rows);
        Ok(())
    }

    /// `q̂ = GRP⁻¹(δp̂) ⊗ q_ref`, `β̂`, and `J P J` with `J = diag(k, k, k, 1, 1, 1)`, `δα ≈ k δp`.
    /// A linear Kalman update (`H = [0₃, I₃]`: exact for any Gaussian filter), Joseph form; the
    /// attitude correction is folded into the chart centre as after a vector update, and the kept sigma
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
        let q_new = self
            .options
            .grp
            .to_quaternion(&attitude_part(&x))
            .compose(&self.q_ref)
            .normalized()
            .ok_or(FilterError::NonFinite {
                step: "bias update",
            })?;
        check_commit("bias update", q_new.is_finite() && all_finite(x.iter()), &p)?;
        self.q_ref = q_new;
        self.x = Vector6::new(0.0, 0.0, 0.0, x[3], x[4], x[5]);
        self.p = p;
        self.sigma = None;
        Ok(())
    }

    /// In the filter's units (`δα ≈ k δp`); the kept sigma points no longer describe the inflated
    /// distribution, so the next update redraws them.
    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) {
        let k = self.options.grp.small_angle_factor();
        let mut block = self.p.fixed_view_mut::<3, 3>(0, 0);
        block += cov_rad2 / (k * k);
        self.sigma = None;
    }

    fn state(driver: &Driver<Self>) -> FilterState {
        let u = driver.core();
        FilterState::Usque(
            driver.driver_state(),
            UsqueState {
                gyro: u.gyro,
                gyro_errors: u.gyro_errors,
                options: u.options,
                fiducial: u.fiducial,
                q_ref: u.q_ref,
                x: u.x,
                p: u.p,
                sigma: u.sigma.clone(),
                diagnostics: u.diagnostics.clone(),
            },
        )
    }

    fn estimate(&self) -> Estimate {
        let k = self.options.grp.small_angle_factor();
        let j = Matrix6::from_diagonal(&Vector6::new(k, k, k, 1.0, 1.0, 1.0));
        let q = self
            .options
            .grp
            .to_quaternion(&attitude_part(&self.x))
            .compose(&self.q_ref);
        let q = q.normalized().unwrap_or(q).canonical();
        Estimate {
            t_s: 0.0,
            q,
            bias_rad_s: bias_part(&self.x),
            covariance: j * self.p * j,
            diagnostics: self.diagnostics.clone(),
        }
    }
}
