//! Sparse-grid Gauss–Hermite quadrature filter, SGHQF (Jia, Xin & Cheng 2011), in USQUE's
//! local/global structure (docs/algorithms.md §3), with both fiducials: the propagated central point
//! and the weighted quaternion average of the propagated points, whose weights may be negative.
//!
//! Local state `x = [δp; β]`, `δp` the GRP (`a = 1, f = 4`, so `δα ≈ δp`: no unit conversion) of
//! `δq = q ⊗ q_ref⁻¹` about the chart centre `q_ref`. The points are those of a Smolyak rule for a
//! standard normal ([`rule`]): `χᵢ = x̂ + S ξᵢ`, `S Sᵀ = P (+ Q̄)`, with the rule's weights `wᵢ`
//! (`Σ wᵢ = 1`, some negative). Every step is USQUE's with these points and weights in place of the
//! unscented ones; the state between propagation and update, the rollback contract and the units are
//! as documented in [`super::usque`].
//!
//! **Negative weights.** `P⁻ = Σ wᵢ (χᵢ − x̂)(·)ᵀ + Q̄` and `P^yy` are not guaranteed positive
//! definite: they are symmetrised and every step commits only a positive-definite covariance (the
//! step is refused otherwise, and the vehicle's rollback and re-initialisation follow). The averaged
//! fiducial uses [`signed_average`], which says when the top eigenvector of `M = Σ wᵢ qᵢ qᵢᵀ` is not
//! to be trusted; the filter then keeps the central point for that step and counts it in
//! `diagnostics.fiducial_fallbacks`.

pub mod rule;
#[cfg(test)]
mod tests;

use super::usque::process_noise_bar;
use super::{
    check_commit, is_spd, symmetrize, Diagnostics, Driver, Estimate, Fiducial, FilterConfig,
    FilterCore, FilterError, FilterKind, FilterSpec, FilterState, GyroErrors, InitialState,
    SghqfState,
};
use crate::attitude::{signed_average, Grp, Quaternion};
use crate::sensors::{Aspect, GyroNoise, VectorObservation};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix3x6, Matrix6, Vector3, Vector6};
pub use rule::{Growth, Rule, LEVELS};

/// The level used when none is configured: exact to degree 5, 97 points.
pub const DEFAULT_LEVEL: u8 = 3;

/// The local chart (USQUE's choice, `δα ≈ δp` for small errors).
const GRP: Grp = Grp::USQUE;

/// The propagated points kept for the next update.
#[derive(Clone, Debug, PartialEq)]
pub struct Points {
    /// The global quaternions `q⁻ᵢ`.
    pub q: Vec<Quaternion>,
    /// The local states `χᵢ = [GRP(q⁻ᵢ ⊗ q_ref⁻¹); χᵢ^β]`.
    pub chi: Vec<Vector6<f64>>,
}

/// The SGHQF state.
#[derive(Clone, Debug)]
pub struct Sghqf {
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    level: u8,
    fiducial: Fiducial,
    rule: &'static Rule,
    /// The chart centre: `q̂ = GRP⁻¹(δp̂) ⊗ q_ref`.
    q_ref: Quaternion,
    /// `[δp̂; β̂]` in the chart about `q_ref` (`δp̂ = 0` after an update).
    x: Vector6<f64>,
    /// Covariance of `x` (rad², rad²/s²: the chart's `k` is 1).
    p: Matrix6<f64>,
    points: Option<Points>,
    diagnostics: Diagnostics,
}

/// The rule of `level`, or why there is none.
pub fn rule_of(level: u8) -> Result<&'static Rule, FilterError> {
    rule::standard(level).ok_or_else(|| {
        FilterError::InvalidConfig(format!(
            "SGHQF level must be in {}..={} (got {level})",
            LEVELS.start(),
            LEVELS.end()
        ))
    })
}

impl Sghqf {
    /// An SGHQF of `config.level`; the fiducial is `config.spec.fiducial` (the averaged one when
    /// absent).
    pub fn new(config: &FilterConfig, initial: &InitialState) -> Result<Self, FilterError> {
        let rule = rule_of(config.level)?;
        let fiducial = config.spec.fiducial.unwrap_or(Fiducial::Average);
        let g = config.gyro;
        if !(g.sigma_v.is_finite() && g.sigma_v >= 0.0 && g.sigma_u.is_finite() && g.sigma_u >= 0.0)
        {
            return Err(FilterError::InvalidConfig(
                "gyro noise densities must be non-negative and finite".into(),
            ));
        }
        config.gyro_errors.validate()?;
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
        let p = initial.covariance_matrix();
        if !is_spd(&p) {
            return Err(FilterError::InvalidConfig(
                "initial covariance is not positive definite".into(),
            ));
        }
        let b = initial.bias_rad_s;
        Ok(Sghqf {
            gyro: g,
            gyro_errors: config.gyro_errors,
            level: config.level,
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

    /// The SGHQF of a saved state (checked by [`FilterState::restore`], which also checks the level).
    pub(super) fn from_state(s: SghqfState) -> Result<Self, FilterError> {
        Ok(Sghqf {
            gyro: s.gyro,
            gyro_errors: s.gyro_errors,
            level: s.level,
            fiducial: s.fiducial,
            rule: rule_of(s.level)?,
            q_ref: s.q_ref,
            x: s.x,
            p: s.p,
            points: s.points,
            diagnostics: s.diagnostics,
        })
    }

    pub fn level(&self) -> u8 {
        self.level
    }

    pub fn fiducial(&self) -> Fiducial {
        self.fiducial
    }

    pub fn rule(&self) -> &'static Rule {
        self.rule
    }

    /// True between a propagation and the update that consumes its points.
    pub fn has_propagated_points(&self) -> bool {
        self.points.is_some()
    }

    /// `Q̄` (USQUE's, added twice) with half the rate-proportional noise of [`GyroErrors`].
    fn q_bar(&self, dt_s: f64, omega_hat: &Vector3<f64>, extra_rad2: f64) -> Matrix6<f64> {
        let mut q = process_noise_bar(&self.gyro, dt_s);
        let extra = 0.5 * (self.gyro_errors.rate_variance(omega_hat, dt_s) + extra_rad2);
        for i in 0..3 {
            q[(i, i)] += extra;
        }
        q
    }

    /// The points `χᵢ = x̂ + S ξᵢ` (`S` the lower Cholesky factor of `cov`) and their quaternions
    /// `GRP⁻¹(χᵢ^δp) ⊗ q_ref`, or `None` when `cov` is not positive definite.
    fn draw(&self, cov: &Matrix6<f64>) -> Option<Points> {
        if !cov.iter().all(|v| v.is_finite()) {
            return None;
        }
        let s = cov.cholesky()?.l();
        let n = self.rule.len();
        let mut points = Points {
            q: Vec::with_capacity(n),
            chi: Vec::with_capacity(n),
        };
        for i in 0..n {
            let chi = self.x + s * Vector6::from_column_slice(self.rule.point(i));
            points
                .q
                .push(GRP.to_quaternion(&attitude_part(&chi)).compose(&self.q_ref));
            points.chi.push(chi);
        }
        Some(points)
    }

    /// The fiducial of propagated points: the central one, or their signed weighted average (with
    /// its diagnostics), falling back to the central one when the average is not to be trusted.
    fn fiducial_of(&self, q: &[Quaternion]) -> (Quaternion, Option<(f64, f64)>, bool) {
        let central = q[0];
        match self.fiducial {
            Fiducial::Propagated => (central, None, false),
            Fiducial::Average => match signed_average(q, &self.rule.weights, &central) {
                Ok(avg) => (avg.q, Some((avg.concentration, avg.gap)), false),
                Err(_) => (central, None, true),
            },
        }
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

/// The observations as full vectors: like USQUE, the SGHQF has no scalar update, so a heading- or
/// tilt-only observation is used with its full-direction likelihood.
fn full_vectors(observations: &[VectorObservation]) -> Vec<VectorObservation> {
    observations
        .iter()
        .map(|o| VectorObservation {
            aspect: Aspect::Full,
            ..o.clone()
        })
        .collect()
}

impl FilterCore for Sghqf {
    fn spec(&self) -> FilterSpec {
        FilterSpec {
            kind: FilterKind::Sghqf,
            fiducial: Some(self.fiducial),
        }
    }

    /// USQUE's steps 1–5 with the rule's points and weights (docs/algorithms.md §3, SGHQF).
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
        let q_bar = self.q_bar(dt_s, &(omega_meas_rad_s - bias_part(&self.x)), extra_rad2);
        // 1–3. The points about the estimate, each propagated with its own bias.
        let mut pts = self
            .draw(&(self.p + q_bar))
            .ok_or(FilterError::NotPositiveDefinite {
                step: "propagation (point spread)",
            })?;
        for (qi, ci) in pts.q.iter_mut().zip(pts.chi.iter()) {
            *qi = qi.propagate(&(omega_meas_rad_s - bias_part(ci)), dt_s);
        }
        // 4. The fiducial.
        let (q_fid, average, fallback) = self.fiducial_of(&pts.q);
        let q_fid = q_fid.normalized().ok_or(FilterError::NonFinite {
            step: "propagation",
        })?;
        // 5. Local errors about the fiducial, their weighted mean and covariance.
        let q_fid_inv = q_fid.inverse();
        let w = &self.rule.weights;
        let mut x = Vector6::zeros();
        for ((ci, qi), wi) in pts.chi.iter_mut().zip(pts.q.iter()).zip(w) {
            let dp = GRP.from_quaternion(&qi.compose(&q_fid_inv));
            ci.fixed_rows_mut::<3>(0).copy_from(&dp);
            x += *ci * *wi;
        }
        let mut p = q_bar;
        for (ci, wi) in pts.chi.iter().zip(w) {
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
            all_finite(x.iter()) && all_finite(p.iter()) && pts.q.iter().all(|q| q.is_finite());
        check_commit("propagation", finite, &p)?;
        // Commit.
        self.q_ref = q_fid;
        self.x = x;
        self.p = p;
        self.points = Some(pts);
        let d = &mut self.diagnostics;
        d.propagations += 1;
        if self.fiducial == Fiducial::Average {
            d.concentration = average.map(|a| a.0);
            d.eigen_gap = average.map(|a| a.1);
            if fallback {
                d.fiducial_fallbacks = Some(d.fiducial_fallbacks.unwrap_or(0) + 1);
            }
        }
        Ok(())
    }

    /// USQUE's steps 6–7 with the stacked observations (`3m` rows): with signed weights
    /// `P^yy = Σ wᵢ (γᵢ − ŷ)(·)ᵀ` and `P^xy` are products with the weights on one side; then, with
    /// `L = chol(P^vv)`, `K ν = (L⁻¹ P^xyᵀ)ᵀ L⁻¹ ν` and `K P^vv Kᵀ = (L⁻¹ P^xyᵀ)ᵀ (L⁻¹ P^xyᵀ)`.
    fn update(&mut self, observations: &[VectorObservation]) -> Result<(), FilterError> {
        if observations.is_empty() {
            return Ok(());
        }
        let observations = full_vectors(observations);
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
                    step: "update (point spread)",
                })?;
                &drawn
            }
        };
        let (n, m) = (self.rule.len(), observations.len());
        let rows = 3 * m;
        let w = &self.rule.weights;
        let mut gamma = DMatrix::<f64>::zeros(rows, n);
        for (i, qi) in pts.q.iter().enumerate() {
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
        let mut xdev = DMatrix::<f64>::zeros(6, n);
        for (i, ci) in pts.chi.iter().enumerate() {
            let mut col = gamma.column_mut(i);
            col -= &y_hat;
            xdev.set_column(i, &(ci - self.x));
        }
        let mut weighted = gamma.clone();
        for (i, wi) in w.iter().enumerate() {
            weighted.column_mut(i).scale_mut(*wi);
        }
        let mut pvv = &weighted * gamma.transpose();
        for (j, o) in observations.iter().enumerate() {
            for r in 0..3 {
                pvv[(3 * j + r, 3 * j + r)] += o.sigma * o.sigma;
            }
        }
        let pvv = (&pvv + pvv.transpose()) * 0.5;
        let pxy_t = &weighted * xdev.transpose(); // (P^xy)ᵀ, 3m × 6
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
        // 7. q̂⁺ = GRP⁻¹(δp̂⁺) ⊗ q_ref, then δp̂⁺ = 0.
        let q_new = GRP
            .to_quaternion(&attitude_part(&x))
            .compose(&self.q_ref)
            .normalized()
            .ok_or(FilterError::NonFinite { step: "update" })?;
        let finite = q_new.is_finite() && all_finite(x.iter()) && nis.is_finite();
        check_commit("update", finite, &p)?;
        self.q_ref = q_new;
        self.x = Vector6::new(0.0, 0.0, 0.0, x[3], x[4], x[5]);
        self.p = p;
        self.points = None;
        self.diagnostics.updates += 1;
        self.diagnostics.nis = Some(nis);
        self.diagnostics.nis_dof = Some(rows);
        Ok(())
    }

    /// A linear Kalman update (`H = [0₃, I₃]`, exact for any Gaussian filter), Joseph form; the
    /// attitude correction is folded into the chart centre and the kept points are dropped.
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
        let q_new = GRP
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
        self.points = None;
        Ok(())
    }

    /// The kept points no longer describe the inflated distribution: the next update redraws them.
    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) {
        let mut block = self.p.fixed_view_mut::<3, 3>(0, 0);
        block += cov_rad2;
        self.points = None;
    }

    fn state(driver: &Driver<Self>) -> FilterState {
        let s = driver.core();
        FilterState::Sghqf(
            driver.driver_state(),
            SghqfState {
                gyro: s.gyro,
                gyro_errors: s.gyro_errors,
                level: s.level,
                fiducial: s.fiducial,
                q_ref: s.q_ref,
                x: s.x,
                p: s.p,
                points: s.points.clone(),
                diagnostics: s.diagnostics.clone(),
            },
        )
    }

    /// `q̂ = GRP⁻¹(δp̂) ⊗ q_ref`, `β̂` and `P` (already in rad: the chart's `k` is 1).
    fn estimate(&self) -> Estimate {
        let q = GRP
            .to_quaternion(&attitude_part(&self.x))
            .compose(&self.q_ref);
        Estimate {
            t_s: 0.0,
            q: q.normalized().unwrap_or(q).canonical(),
            bias_rad_s: bias_part(&self.x),
            covariance: self.p,
            diagnostics: self.diagnostics.clone(),
        }
    }
}

/// The first observation whose leading block of `P^vv` is not positive definite (for the error
/// report; only evaluated on the failure path).
fn first_singular_observation(pvv: &DMatrix<f64>, m: usize) -> usize {
    (0..m)
        .find(|&j| {
            let d = 3 * (j + 1);
            pvv.view((0, 0), (d, d)).clone_owned().cholesky().is_none()
        })
        .unwrap_or(m.saturating_sub(1))
}
