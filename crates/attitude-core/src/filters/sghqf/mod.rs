//! Sparse-grid Gauss–Hermite quadrature filter, SGHQF (Jia, Xin & Cheng 2011), in USQUE's
//! local/global structure (docs/algorithms.md §3), with both fiducials: the propagated central point
//! and the weighted quaternion average of the propagated points, whose weights may be negative.
//!
//! Local state `x = [δp; β]`, `δp` the GRP (`a = 1, f = 4`, so `δα ≈ δp`: no unit conversion) of
//! `δq = q ⊗ q_ref⁻¹` about the chart centre `q_ref`. The points are those of a Smolyak rule for a
//! standard normal ([`rule`]): `χᵢ = x̂ + S ξᵢ`, `S Sᵀ = P (+ Q̄)`, with the rule's weights `wᵢ`
//! (`Σ wᵢ = 1`, some negative). Every step is USQUE's with these points and weights in place of the
//! unscented ones: the SGHQF is the sigma-point filter of [`super::sigma`] with the rule
//! [`SparseGrid`]; the state between propagation and update, the rollback contract and the units are
//! as documented there and in [`super::usque`].
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

use super::sigma::{check_gyro, on_chart, point_set, Chart, PointRule, SigmaFilter, Weighting};
use super::{
    DriverState, FilterConfig, FilterError, FilterKind, FilterState, InitialState, SghqfState,
};
use crate::attitude::{signed_average, AverageError, Quaternion, QuaternionAverage};
use nalgebra::{Matrix6, Vector6};
pub use rule::{Growth, Rule, LEVELS};

/// The level used when none is configured: exact to degree 5, 97 points.
pub const DEFAULT_LEVEL: u8 = 3;

/// The propagated points kept for the next update.
#[derive(Clone, Debug, PartialEq)]
pub struct Points {
    /// The global quaternions `q⁻ᵢ`.
    pub q: Vec<Quaternion>,
    /// The local states `χᵢ = [GRP(q⁻ᵢ ⊗ q_ref⁻¹); χᵢ^β]`.
    pub chi: Vec<Vector6<f64>>,
}

point_set!(Points);

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

/// The 6-D Smolyak rule of a level: `χᵢ = x̂ + S ξᵢ`, `S` the lower Cholesky factor, with the rule's
/// weights (some negative).
#[derive(Clone, Debug)]
pub struct SparseGrid {
    level: u8,
    rule: &'static Rule,
}

impl PointRule for SparseGrid {
    const KIND: FilterKind = FilterKind::Sghqf;
    const PROPAGATION_SPREAD: &'static str = "propagation (point spread)";
    const UPDATE_SPREAD: &'static str = "update (point spread)";
    /// Weights of both signs have no square root: the weights on one side of each product.
    const WEIGHTING: Weighting = Weighting::Signed;
    type Points = Points;

    /// The local chart (USQUE's choice, `δα ≈ δp` for small errors), in rad.
    fn chart(&self) -> Chart {
        Chart::Radians
    }

    fn weights(&self) -> &[f64] {
        &self.rule.weights
    }

    /// The points `χᵢ = x̂ + S ξᵢ` (`S` the lower Cholesky factor of `cov`) and their quaternions
    /// `GRP⁻¹(χᵢ^δp) ⊗ q_ref`, or `None` when `cov` is not positive definite.
    fn draw(&self, x: &Vector6<f64>, q_ref: &Quaternion, cov: &Matrix6<f64>) -> Option<Points> {
        if !cov.iter().all(|v| v.is_finite()) {
            return None;
        }
        let s = cov.cholesky()?.l();
        let grp = self.chart().grp();
        let n = self.rule.len();
        let mut points = Points {
            q: Vec::with_capacity(n),
            chi: Vec::with_capacity(n),
        };
        for i in 0..n {
            let chi = x + s * Vector6::from_column_slice(self.rule.point(i));
            points.q.push(on_chart(&grp, &chi, q_ref));
            points.chi.push(chi);
        }
        Some(points)
    }

    /// The signed weighted average ([`signed_average`]).
    fn average(
        &self,
        q: &[Quaternion],
        central: &Quaternion,
    ) -> Result<QuaternionAverage, AverageError> {
        signed_average(q, &self.rule.weights, central)
    }

    fn state(s: &Sghqf, driver: DriverState) -> FilterState {
        FilterState::Sghqf(
            driver,
            SghqfState {
                gyro: s.gyro,
                gyro_errors: s.gyro_errors,
                level: s.rule.level,
                fiducial: s.fiducial,
                q_ref: s.q_ref,
                x: s.x,
                p: s.p,
                points: s.points.clone(),
                diagnostics: s.diagnostics.clone(),
            },
        )
    }
}

/// The SGHQF state: the sigma-point filter with a sparse-grid rule.
pub type Sghqf = SigmaFilter<SparseGrid>;

impl Sghqf {
    /// An SGHQF of `config.level`; the fiducial is `config.spec.fiducial` (the averaged one when
    /// absent).
    pub fn new(config: &FilterConfig, initial: &InitialState) -> Result<Self, FilterError> {
        let rule = rule_of(config.level)?;
        check_gyro(&config.gyro)?;
        // Before the initial state here, after it in USQUE (see `Usque::new`).
        config.gyro_errors.validate()?;
        let level = config.level;
        SigmaFilter::start(SparseGrid { level, rule }, config, initial)
    }

    /// The SGHQF of a saved state (checked by [`FilterState::restore`], which also checks the level).
    pub(in crate::filters) fn from_state(s: SghqfState) -> Result<Self, FilterError> {
        Ok(SigmaFilter {
            gyro: s.gyro,
            gyro_errors: s.gyro_errors,
            fiducial: s.fiducial,
            rule: SparseGrid {
                level: s.level,
                rule: rule_of(s.level)?,
            },
            q_ref: s.q_ref,
            x: s.x,
            p: s.p,
            points: s.points,
            diagnostics: s.diagnostics,
        })
    }

    pub fn level(&self) -> u8 {
        self.rule.level
    }

    pub fn rule(&self) -> &'static Rule {
        self.rule.rule
    }
}
