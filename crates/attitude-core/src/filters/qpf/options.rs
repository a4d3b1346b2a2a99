//! The QPF's tuning and its regularisation kernel.

use super::*;

/// Regularisation kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    Gaussian,
    Epanechnikov,
}

/// QPF tuning. Defaults are the values that measured well (docs/algorithms.md §3, tuning).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QpfOptions {
    pub kernel: Kernel,
    /// Scale on the optimal bandwidth `h_opt = A N^{−1/(n+4)}`; 1–2 work with the shrinkage kernel.
    pub bandwidth_scale: f64,
    /// Resample when `N_eff < resample_fraction · N`.
    pub resample_fraction: f64,
    /// Progressive correction: largest log-likelihood spread `T` applied in one stage.
    pub pc_spread: f64,
    /// Progressive correction: at most this many stages; the last applies the rest of the likelihood.
    pub pc_max_stages: u32,
    /// Relative covariance inflation per regularisation (keeps the nearly static bias cloud from
    /// collapsing; ≈ 2% made the ANEES honest).
    pub inflation: f64,
}

impl Default for QpfOptions {
    fn default() -> Self {
        QpfOptions {
            kernel: Kernel::Gaussian,
            bandwidth_scale: 1.5,
            resample_fraction: 0.5,
            pc_spread: 8.0,
            pc_max_stages: 30,
            inflation: 0.02,
        }
    }
}

impl QpfOptions {
    pub(in crate::filters) fn validate(&self) -> Result<(), FilterError> {
        let bad = |what: &str| Err(FilterError::InvalidConfig(what.to_string()));
        if !(self.bandwidth_scale > 0.0 && self.bandwidth_scale.is_finite()) {
            return bad("bandwidth_scale must be positive");
        }
        if !(self.resample_fraction > 0.0 && self.resample_fraction <= 1.0) {
            return bad("resample_fraction must be in (0, 1]");
        }
        if !(self.pc_spread > 0.0) || self.pc_max_stages == 0 {
            return bad("progressive correction needs pc_spread > 0 and pc_max_stages ≥ 1");
        }
        if !(self.inflation >= 0.0 && self.inflation < 1.0) {
            return bad("inflation must be in [0, 1)");
        }
        Ok(())
    }
}

pub(super) const STATE_DIM: f64 = 6.0;
/// `δα ≈ 4 δp` for the MRP.
pub(super) const MRP_TO_RAD: f64 = 4.0;

impl Kernel {
    /// The optimal bandwidth `h_opt = A N^{−1/(n+4)}` for `n = 6`: Gaussian `A = (4/(n+2))^{1/(n+4)}`,
    /// Epanechnikov `A = [(8/c_n)(n+4)(2√π)ⁿ]^{1/(n+4)}` with `c_n = π³/6` the volume of the unit 6-ball.
    pub fn optimal_bandwidth(&self, n_particles: usize) -> f64 {
        let n = STATE_DIM;
        let a = match self {
            Kernel::Gaussian => (4.0 / (n + 2.0)).powf(1.0 / (n + 4.0)),
            Kernel::Epanechnikov => {
                let c_n = std::f64::consts::PI.powi(3) / 6.0;
                let two_sqrt_pi = 2.0 * std::f64::consts::PI.sqrt();
                (8.0 / c_n * (n + 4.0) * two_sqrt_pi.powf(n)).powf(1.0 / (n + 4.0))
            }
        };
        a * (n_particles.max(1) as f64).powf(-1.0 / (n + 4.0))
    }

    /// Per-axis variance of a draw of the unit kernel: 1 (Gaussian), `1/(n+4)` (Epanechnikov).
    pub(super) fn unit_variance(&self) -> f64 {
        match self {
            Kernel::Gaussian => 1.0,
            Kernel::Epanechnikov => 1.0 / (STATE_DIM + 4.0),
        }
    }
}

/// `D` with `D Dᵀ = S`; a singular `S` (a collapsed cloud) gets a tiny relative jitter on its diagonal.
pub(super) fn regularization_factor(s: &Matrix6<f64>) -> Matrix6<f64> {
    if let Some(c) = s.cholesky() {
        return c.l();
    }
    let mut j = *s;
    for i in 0..6 {
        j[(i, i)] += 1e-12 * s[(i, i)].abs() + 1e-30;
    }
    j.cholesky().map(|c| c.l()).unwrap_or_else(Matrix6::zeros)
}

/// A draw from the unit multivariate Epanechnikov kernel in 6-D: `r² ~ Beta(n/2, 2)`, uniform direction.
pub(super) fn epanechnikov_draw<R: Rng>(rng: &mut R, beta: &Beta<f64>) -> Vector6<f64> {
    let dir = Vector6::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
    let n = dir.norm();
    if n == 0.0 {
        return Vector6::zeros();
    }
    let r = beta.sample(rng).sqrt();
    dir * (r / n)
}
