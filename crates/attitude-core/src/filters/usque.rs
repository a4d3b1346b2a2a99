//! UnScented QUaternion Estimator, USQUE (Crassidis & Markley 2003; docs/algorithms.md §3), with both
//! fiducials: the propagated central sigma point (the original USQUE) and the MMSE weighted average of
//! the propagated sigma-point quaternions (the modified USQUE of Chang, Hu & Chang 2014).
//!
//! USQUE is the sigma-point filter of [`super::sigma`] with the unscented set ([`Unscented`]): the
//! recursion, the state between propagation and update (a design choice, documented there) and the
//! rollback contract are that module's; the points, their weights, the average and the chart are here.
//!
//! Local/global structure: the state is `x = [δp; β]` (`n = 6`), `δp` the generalized Rodrigues
//! parameters ([`Grp`], default `a = 1, f = 4`) of the error `δq = q ⊗ q_ref⁻¹` about a reference
//! quaternion `q_ref`, `β` the gyro bias. `P` is the 6×6 covariance of `x` (GRP units on the attitude
//! block); [`super::FilterCore::estimate`] converts it to small-angle radians.
//!
//! # Units of `Q̄` and of the initial covariance
//!
//! `Q̄` and the initial attitude sigma are physical (rad); the attitude block is divided by `k²`,
//! `k = grp.small_angle_factor()` (`δα ≈ k δp`), to express it in GRP units. For the default
//! `a = 1, f = 4`, `k = 1` and this changes nothing.

use super::sigma::{check_gyro, on_chart, point_set, Chart, PointRule, SigmaFilter, Weighting};
use super::{
    DriverState, FilterConfig, FilterError, FilterKind, FilterState, InitialState, UsqueState,
};
use crate::attitude::{AverageAccumulator, AverageError, Grp, Quaternion, QuaternionAverage};
use nalgebra::{Matrix6, Vector6};

pub use super::sigma::{process_noise_bar, N_STATE};

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

/// Sigma points kept from a propagation for the next update.
#[derive(Clone, Debug, PartialEq)]
pub struct SigmaPoints {
    /// The global quaternions `q⁻(i)`.
    pub q: [Quaternion; N_SIGMA],
    /// The local states `χ(i) = [GRP(q⁻(i) ⊗ q_ref⁻¹); χ^β(i)]`.
    pub chi: [Vector6<f64>; N_SIGMA],
}

point_set!(SigmaPoints);

/// The unscented set: `χ(0) = x̂`, `χ(i) = x̂ ± σ(i)`, `σ` the columns of `chol((n + λ) P)`, with the
/// weights `(W₀, Wᵢ)` of the options (all positive: `λ > 0`).
#[derive(Clone, Debug)]
pub struct Unscented {
    options: UsqueOptions,
    /// `W₀` then `Wᵢ` for each other point.
    weights: [f64; N_SIGMA],
}

impl Unscented {
    pub fn new(options: UsqueOptions) -> Self {
        let (w0, wi) = options.weights();
        let mut weights = [wi; N_SIGMA];
        weights[0] = w0;
        Unscented { options, weights }
    }
}

impl PointRule for Unscented {
    const KIND: FilterKind = FilterKind::Usque;
    const PROPAGATION_SPREAD: &'static str = "propagation (sigma-point spread)";
    const UPDATE_SPREAD: &'static str = "update (sigma-point spread)";
    /// All weights are positive (`λ > 0`): the deviations scaled by `√wᵢ`.
    const WEIGHTING: Weighting = Weighting::SquareRoot;
    type Points = SigmaPoints;

    /// Any GRP of the options, converted with its `k` (the module docs).
    fn chart(&self) -> Chart {
        Chart::Grp(self.options.grp)
    }

    fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// `σ` = the columns of `chol((n + λ) cov)` (lower factor), `χ(0) = x̂`, `χ(1 + j) = x̂ + σ(j)`,
    /// `χ(1 + n + j) = x̂ − σ(j)`.
    fn draw(
        &self,
        x: &Vector6<f64>,
        q_ref: &Quaternion,
        cov: &Matrix6<f64>,
    ) -> Option<SigmaPoints> {
        if !cov.iter().all(|v| v.is_finite()) {
            return None;
        }
        let scaled = cov * (N_STATE as f64 + self.options.lambda);
        let l = scaled.cholesky()?.l();
        let mut chi = [*x; N_SIGMA];
        for j in 0..N_STATE {
            let col: Vector6<f64> = l.column(j).into_owned();
            chi[1 + j] = x + col;
            chi[1 + N_STATE + j] = x - col;
        }
        let mut q = [Quaternion::IDENTITY; N_SIGMA];
        for (qi, ci) in q.iter_mut().zip(chi.iter()) {
            *qi = on_chart(&self.options.grp, ci, q_ref);
        }
        Some(SigmaPoints { q, chi })
    }

    /// The MMSE weighted average (`M = Σ Wᵢ qᵢ qᵢᵀ`); refused when undecidable (equal top eigenvalues
    /// to rounding) or non-finite.
    fn average(
        &self,
        q: &[Quaternion],
        central: &Quaternion,
    ) -> Result<QuaternionAverage, AverageError> {
        let mut acc = AverageAccumulator::new();
        for (qi, wi) in q.iter().zip(&self.weights) {
            acc.add(qi, *wi);
        }
        acc.finish(Some(central))
    }

    fn state(u: &Usque, driver: DriverState) -> FilterState {
        FilterState::Usque(
            driver,
            UsqueState {
                gyro: u.gyro,
                gyro_errors: u.gyro_errors,
                options: u.rule.options,
                fiducial: u.fiducial,
                q_ref: u.q_ref,
                x: u.x,
                p: u.p,
                sigma: u.points.clone(),
                diagnostics: u.diagnostics.clone(),
            },
        )
    }
}

/// The USQUE state: the sigma-point filter with the unscented set.
pub type Usque = SigmaFilter<Unscented>;

impl Usque {
    /// A USQUE from the shared configuration; the fiducial is `config.spec.fiducial` (the averaged one
    /// when absent).
    pub fn new(
        config: &FilterConfig,
        initial: &InitialState,
        options: UsqueOptions,
    ) -> Result<Self, FilterError> {
        options.validate()?;
        check_gyro(&config.gyro)?;
        let usque = SigmaFilter::start(Unscented::new(options), config, initial)?;
        // The gyro error extras are checked after the initial state here, before it in the SGHQF: the
        // order each was written in, kept so that a configuration wrong twice is refused for the same
        // reason as before (build_filter checks them first anyway).
        config.gyro_errors.validate()?;
        Ok(usque)
    }

    /// The USQUE of a saved state (checked by [`FilterState::restore`]); the weights follow from
    /// the options.
    pub(in crate::filters) fn from_state(s: UsqueState) -> Self {
        SigmaFilter {
            gyro: s.gyro,
            gyro_errors: s.gyro_errors,
            fiducial: s.fiducial,
            rule: Unscented::new(s.options),
            q_ref: s.q_ref,
            x: s.x,
            p: s.p,
            points: s.sigma,
            diagnostics: s.diagnostics,
        }
    }

    pub fn options(&self) -> &UsqueOptions {
        &self.rule.options
    }

    /// True between a propagation and the update that consumes its sigma points.
    pub fn has_propagated_sigma_points(&self) -> bool {
        self.has_propagated_points()
    }
}
