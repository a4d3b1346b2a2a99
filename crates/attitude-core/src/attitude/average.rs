//! Weighted quaternion average (Markley, Cheng, Crassidis & Oshman 2007; docs/algorithms.md §4).
//!
//! The MMSE average of weighted unit quaternions is the unit eigenvector of the largest eigenvalue of
//! `M = Σ wᵢ qᵢ qᵢᵀ` (it maximises `qᵀ M q` on the unit sphere; Chang 2014, Eqs. 3–4). It is
//! invariant to the sign of each `qᵢ` and is a unit quaternion by construction: no brute-force
//! normalisation.
//!
//! nalgebra's `UnitQuaternion::mean_of` is deliberately not used: it is unweighted, can panic and
//! scrambles components (upstream PR #1430).

use super::quaternion::Quaternion;
use nalgebra::{Matrix4, SymmetricEigen, Vector4};
use thiserror::Error;

/// Why an average could not be decided. The caller keeps its previous fiducial or falls back.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum AverageError {
    #[error("no quaternions to average")]
    Empty,
    #[error("weight {index} is negative or not finite ({weight})")]
    InvalidWeight { index: usize, weight: f64 },
    #[error("quaternion {index} is not finite")]
    NonFiniteQuaternion { index: usize },
    #[error("the weights sum to zero")]
    ZeroTotalWeight,
    #[error("the symmetric eigen-solver did not converge")]
    NoConvergence,
    #[error("the largest eigenvalue is not separated from the next (relative gap {relative_gap:e}): the average is undecidable")]
    Undecidable { relative_gap: f64 },
    #[error("the signed weights sum to {total}, not a positive number")]
    NonPositiveTotal { total: f64 },
    #[error("the weighted matrix has eigenvalue {smallest:e}, beyond half its eigen-gap {gap:e}: the quadrature error exceeds what decides the average")]
    Indefinite { smallest: f64, gap: f64 },
    #[error("the average lies {angle_rad} rad from the centre, beyond the farthest point ({extent_rad} rad): the rule no longer resolves the spread")]
    OutsideCloud { angle_rad: f64, extent_rad: f64 },
}

/// A decided average with the diagnostics that say how well it is defined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuaternionAverage {
    /// The average, sign chosen for continuity with the previous estimate (or `w ≥ 0` without one).
    pub q: Quaternion,
    /// `λ₁ / Σw ∈ [¼, 1]`: 1 when every quaternion is equal, ¼ for a uniformly diffuse cloud.
    pub concentration: f64,
    /// `(λ₁ − λ₂) / Σw`: the eigen-gap that makes the average unique.
    pub gap: f64,
    /// The eigenvalues of `M`, largest first (not divided by `Σw`).
    pub eigenvalues: [f64; 4],
}

/// Relative eigen-gap below which the largest eigenvector is numerically undecidable (equal eigenvalues
/// to rounding). Deliberately tiny: a small but real gap (a ring-shaped posterior) still gives an average
/// on the ring, which measured better than falling back (docs/algorithms.md §3, QPF fiducials).
const UNDECIDABLE_RELATIVE_GAP: f64 = 1e-12;
const EIGEN_EPS: f64 = 1e-15;
const EIGEN_MAX_ITERATIONS: usize = 200;

/// Accumulates `M = Σ wᵢ qᵢ qᵢᵀ` without allocating, for callers that hold particles in their own layout.
#[derive(Clone, Debug)]
pub struct AverageAccumulator {
    m: Matrix4<f64>,
    total_weight: f64,
    count: usize,
    error: Option<AverageError>,
}

impl Default for AverageAccumulator {
    fn default() -> Self {
        Self::new()
    }
}

impl AverageAccumulator {
    pub fn new() -> Self {
        AverageAccumulator {
            m: Matrix4::zeros(),
            total_weight: 0.0,
            count: 0,
            error: None,
        }
    }

    /// Adds `w q qᵀ`. An invalid input is remembered and reported by [`AverageAccumulator::finish`].
    pub fn add(&mut self, q: &Quaternion, w: f64) {
        let index = self.count;
        self.count += 1;
        if self.error.is_some() {
            return;
        }
        if !(w.is_finite() && w >= 0.0) {
            self.error = Some(AverageError::InvalidWeight { index, weight: w });
            return;
        }
        if !q.is_finite() {
            self.error = Some(AverageError::NonFiniteQuaternion { index });
            return;
        }
        let v = q.to_vector4();
        // Symmetric rank-one update; only the upper triangle is needed, but 16 flops are cheaper than
        // the branch.
        self.m += (v * v.transpose()) * w;
        self.total_weight += w;
    }

    /// Adds particles held as separate component slices (same length), in one tight loop over the
    /// ten distinct entries of `M`. The weights must be finite and non-negative (a particle filter's
    /// normalised weights); a non-finite input is still caught, when the average is decided.
    pub fn add_slices(&mut self, x: &[f64], y: &[f64], z: &[f64], w: &[f64], weights: &[f64]) {
        let n = x
            .len()
            .min(y.len())
            .min(z.len())
            .min(w.len())
            .min(weights.len());
        let (mut xx, mut xy, mut xz, mut xw, mut yy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut yz, mut yw, mut zz, mut zw, mut ww, mut total) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let k = weights[i];
            let (a, b, c, d) = (x[i] * k, y[i] * k, z[i] * k, w[i] * k);
            xx += a * x[i];
            xy += a * y[i];
            xz += a * z[i];
            xw += a * w[i];
            yy += b * y[i];
            yz += b * z[i];
            yw += b * w[i];
            zz += c * z[i];
            zw += c * w[i];
            ww += d * w[i];
            total += k;
        }
        let m = Matrix4::new(
            xx, xy, xz, xw, xy, yy, yz, yw, xz, yz, zz, zw, xw, yw, zw, ww,
        );
        if !(m.iter().all(|v| v.is_finite()) && total.is_finite() && total >= 0.0) {
            if self.error.is_none() {
                self.error = Some(AverageError::NonFiniteQuaternion { index: self.count });
            }
        }
        self.m += m;
        self.total_weight += total;
        self.count += n;
    }

    /// An accumulator holding sums made elsewhere (a vectorised pass over particles): the ten
    /// distinct entries of `M` (`xx xy xz xw yy yz yw zz zw ww`), `Σw` and the count. Non-finite sums
    /// are reported by [`AverageAccumulator::finish`], as for [`AverageAccumulator::add_slices`].
    pub fn from_sums(m: [f64; 10], total_weight: f64, count: usize) -> Self {
        let [xx, xy, xz, xw, yy, yz, yw, zz, zw, ww] = m;
        let mut acc = AverageAccumulator::new();
        acc.m = Matrix4::new(
            xx, xy, xz, xw, xy, yy, yz, yw, xz, yz, zz, zw, xw, yw, zw, ww,
        );
        if !(acc.m.iter().all(|v| v.is_finite()) && total_weight.is_finite() && total_weight >= 0.0)
        {
            acc.error = Some(AverageError::NonFiniteQuaternion { index: 0 });
        }
        acc.total_weight = total_weight;
        acc.count = count;
        acc
    }

    /// Decides the average. `previous` fixes the sign (`q̄ᵀ q_prev ≥ 0`).
    pub fn finish(&self, previous: Option<&Quaternion>) -> Result<QuaternionAverage, AverageError> {
        if let Some(e) = &self.error {
            return Err(e.clone());
        }
        if self.count == 0 {
            return Err(AverageError::Empty);
        }
        if !(self.total_weight > 0.0) {
            return Err(AverageError::ZeroTotalWeight);
        }
        largest_eigenvector(&self.m, self.total_weight, previous)
    }
}

/// The weighted average of `quaternions` with `weights` (same length; not necessarily normalised).
pub fn weighted_average(
    quaternions: &[Quaternion],
    weights: &[f64],
    previous: Option<&Quaternion>,
) -> Result<QuaternionAverage, AverageError> {
    let mut acc = AverageAccumulator::new();
    for (q, &w) in quaternions.iter().zip(weights) {
        acc.add(q, w);
    }
    if quaternions.len() != weights.len() {
        // A length mismatch is a caller bug; report it as the first weight that is missing.
        let index = quaternions.len().min(weights.len());
        return Err(AverageError::InvalidWeight {
            index,
            weight: f64::NAN,
        });
    }
    acc.finish(previous)
}

/// The eigenvalues of a symmetric 4×4 matrix, largest first, and the unit eigenvector of the largest.
/// Shared with the q-method (`wahba`), whose matrix is symmetric but indefinite.
pub(crate) fn top_eigenpair(m: &Matrix4<f64>) -> Result<(Vector4<f64>, [f64; 4]), AverageError> {
    if m.iter().any(|x| !x.is_finite()) {
        return Err(AverageError::NoConvergence);
    }
    let eig = SymmetricEigen::try_new(*m, EIGEN_EPS, EIGEN_MAX_ITERATIONS)
        .ok_or(AverageError::NoConvergence)?;
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let lambda = order.map(|i| eig.eigenvalues[i]);
    if lambda.iter().any(|l| !l.is_finite()) {
        return Err(AverageError::NoConvergence);
    }
    let v: Vector4<f64> = eig.eigenvectors.column(order[0]).into_owned();
    let n = v.norm();
    if !(n.is_finite() && n > 0.5) {
        return Err(AverageError::NoConvergence);
    }
    Ok((v / n, lambda))
}

fn largest_eigenvector(
    m: &Matrix4<f64>,
    total_weight: f64,
    previous: Option<&Quaternion>,
) -> Result<QuaternionAverage, AverageError> {
    // Divide by Σw so that the solver's absolute epsilon is meaningful whatever the weights' scale.
    let (v, lambda) = top_eigenpair(&(m / total_weight))?;
    let gap = lambda[0] - lambda[1];
    let relative_gap = if lambda[0] > 0.0 {
        gap / lambda[0]
    } else {
        0.0
    };
    if relative_gap <= UNDECIDABLE_RELATIVE_GAP {
        return Err(AverageError::Undecidable { relative_gap });
    }
    let q = Quaternion::from_vector4(&v);
    let q = match previous {
        Some(p) if q.dot(p) < 0.0 => q.negated(),
        Some(_) => q,
        None => q.canonical(),
    };
    Ok(QuaternionAverage {
        q,
        concentration: lambda[0],
        gap,
        eigenvalues: lambda.map(|l| l * total_weight),
    })
}

/// The weighted average when some weights are negative (a sparse-grid quadrature rule's;
/// docs/algorithms.md §4), about the rule's central point `centre`.
///
/// `M = Σ wᵢ qᵢ qᵢᵀ` with `Σ wᵢ > 0`. By the trace identity `Σ wᵢ ‖A(q) − A(qᵢ)‖²_F = 8 (Σ wᵢ − qᵀ M q)`
/// whatever the signs, so the unit eigenvector of the largest *algebraic* eigenvalue still minimises
/// the weighted attitude cost; but that cost is no longer a sum of non-negative terms, and `M` is a
/// quadrature estimate of the true second moment `E[q qᵀ]` (positive semi-definite). The average is
/// taken as the right answer only when nothing shows the estimate too poor to decide it:
///
/// * `λ₁` separated from `λ₂` (as for [`weighted_average`]): else [`AverageError::Undecidable`];
/// * no negative eigenvalue beyond half the gap: `E[q qᵀ]` has none, so by Weyl's inequality the
///   quadrature error is at least `−λ₄`, and by Davis–Kahan an error of half the gap can turn the top
///   eigenvector anywhere: else [`AverageError::Indefinite`];
/// * the average no farther from `centre` (in angle on S³) than the farthest point: for a spread the
///   rule no longer resolves, the top eigenvector jumps from the centre to a direction no point is
///   near (measured: beyond ≈ 70° of isotropic spread at `L = 2`): else [`AverageError::OutsideCloud`].
///
/// The sign is chosen with `q̄ᵀ centre ≥ 0`.
pub fn signed_average(
    quaternions: &[Quaternion],
    weights: &[f64],
    centre: &Quaternion,
) -> Result<QuaternionAverage, AverageError> {
    if quaternions.is_empty() {
        return Err(AverageError::Empty);
    }
    let mut m = Matrix4::zeros();
    let mut total = 0.0;
    let mut extent: f64 = 0.0;
    for (index, (q, &w)) in quaternions.iter().zip(weights).enumerate() {
        if !w.is_finite() {
            return Err(AverageError::InvalidWeight { index, weight: w });
        }
        if !q.is_finite() {
            return Err(AverageError::NonFiniteQuaternion { index });
        }
        let v = q.to_vector4();
        m += (v * v.transpose()) * w;
        total += w;
        extent = extent.max(angle_on_sphere(q, centre));
    }
    if quaternions.len() != weights.len() {
        let index = quaternions.len().min(weights.len());
        return Err(AverageError::InvalidWeight {
            index,
            weight: f64::NAN,
        });
    }
    if !(total > 0.0) {
        return Err(AverageError::NonPositiveTotal { total });
    }
    let (v, lambda) = top_eigenpair(&(m / total))?;
    let gap = lambda[0] - lambda[1];
    let relative_gap = if lambda[0] > 0.0 {
        gap / lambda[0]
    } else {
        0.0
    };
    if relative_gap <= UNDECIDABLE_RELATIVE_GAP {
        return Err(AverageError::Undecidable { relative_gap });
    }
    if -lambda[3] >= 0.5 * gap {
        return Err(AverageError::Indefinite {
            smallest: lambda[3],
            gap,
        });
    }
    let mut q = Quaternion::from_vector4(&v);
    if q.dot(centre) < 0.0 {
        q = q.negated();
    }
    let angle_rad = angle_on_sphere(&q, centre);
    // (A little slack: for a cloud of one point the average is that point to rounding.)
    if angle_rad > extent + 1e-9 {
        return Err(AverageError::OutsideCloud {
            angle_rad,
            extent_rad: extent,
        });
    }
    Ok(QuaternionAverage {
        q,
        concentration: lambda[0],
        gap,
        eigenvalues: lambda.map(|l| l * total),
    })
}

/// The angle between two unit quaternions as points of S³ up to sign, `acos |p·q|` (half the
/// rotation angle between them), as `2 asin(‖p ∓ q‖/2)`: accurate for small angles, where `acos` is not.
fn angle_on_sphere(p: &Quaternion, q: &Quaternion) -> f64 {
    let q = if p.dot(q) < 0.0 { q.negated() } else { *q };
    let d = p.to_vector4() - q.to_vector4();
    2.0 * (0.5 * d.norm()).min(1.0).asin()
}
