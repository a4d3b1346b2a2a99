//! The hard-iron fit: a magnet that moves with the body adds a body-frame offset `o` to the field,
//! `m = A C + o`; a recursive least-squares fit of `(C, o)` over the readings of a window, with `A`
//! the gyro frame's attitude, tells the offset from the field once the body has turned enough
//! (crate::sensors::field::channel accepts it).

use crate::sensors::lowpass::first_order_by;
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

/// Recursive least squares with exponential forgetting for `m = A C + o`, on the structure of its
/// normal equations: with `H = [A, I]` and `A` a rotation, `HᵀH = [[I, Aᵀ], [A, I]]`, so
/// `Σ λ HᵀH = [[n I, Jᵀ], [J, n I]]` with `n = Σ λ` and `J = Σ λ A`: ten numbers per sample where
/// the dense matrix takes 36, and the same values (the dense diagonal blocks are `n I` bit for bit).
#[derive(Clone, Debug, PartialEq)]
pub struct HardIronFit {
    /// `J = Σ λ A`, `Σ λ Hᵀm`, `Σ λ mᵀm`, `n = Σ λ` (samples).
    pub j: Matrix3<f64>,
    pub rhs: Vector6<f64>,
    pub ss: f64,
    pub n: f64,
    /// Low-passed squared residual of the readings against the last solution.
    pub recent_ms: f64,
    pub solution: Option<HardIronSolution>,
}

/// A solution of [`HardIronFit`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HardIronSolution {
    /// The field in the gyro frame and the body-frame offset, in the reading's units.
    pub field_gyro: Vector3<f64>,
    pub offset: Vector3<f64>,
    /// RMS residual per axis over the window, and the offset's largest 1σ.
    pub residual_rms: f64,
    pub offset_sigma: f64,
}

impl Default for HardIronFit {
    fn default() -> Self {
        HardIronFit {
            j: Matrix3::zeros(),
            rhs: Vector6::zeros(),
            ss: 0.0,
            n: 0.0,
            recent_ms: 0.0,
            solution: None,
        }
    }
}

impl HardIronFit {
    /// The dense `Σ λ HᵀH = [[n I, Jᵀ], [J, n I]]` (the form a checkpoint keeps).
    pub fn info(&self) -> Matrix6<f64> {
        let mut info = Matrix6::identity() * self.n;
        info.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&self.j.transpose());
        info.fixed_view_mut::<3, 3>(3, 0).copy_from(&self.j);
        info
    }

    /// `J` of a dense `Σ λ HᵀH` ([`HardIronFit::info`]) whose diagonal is `n`; `Err` when the
    /// matrix does not have that structure.
    pub fn j_of_info(info: &Matrix6<f64>, n: f64) -> Result<Matrix3<f64>, String> {
        let j: Matrix3<f64> = info.fixed_view::<3, 3>(3, 0).into_owned();
        let mut f = HardIronFit::default();
        (f.j, f.n) = (j, n);
        let same = info
            .iter()
            .zip(f.info().iter())
            .all(|(a, b)| a.to_bits() == b.to_bits());
        if same {
            Ok(j)
        } else {
            Err("the hard-iron fit's normal matrix is not [[n I, Jᵀ], [J, n I]]".into())
        }
    }

    /// Takes the reading `m` at the gyro frame's attitude `a_gyro`, after forgetting `λ` of what the
    /// fit holds; `k_recent` is the gain of the recent residual's low-pass ([`super::gains`]).
    #[inline]
    pub(super) fn add(
        &mut self,
        m: &Vector3<f64>,
        a_gyro: &Matrix3<f64>,
        lambda: f64,
        k_recent: Option<f64>,
    ) {
        self.j *= lambda;
        self.rhs *= lambda;
        self.ss *= lambda;
        self.n *= lambda;
        self.j += a_gyro;
        self.n += 1.0;
        let atm = a_gyro.transpose() * m;
        self.rhs += Vector6::new(atm[0], atm[1], atm[2], m[0], m[1], m[2]);
        self.ss += m.norm_squared();
        if let Some(s) = &self.solution {
            let r = m - a_gyro * s.field_gyro - s.offset;
            self.recent_ms = first_order_by(self.recent_ms, r.norm_squared() / 3.0, k_recent);
        }
        if !(all_finite(self.j.as_slice()) && (self.n * 0.0 + self.ss * 0.0) == 0.0) {
            *self = HardIronFit::default();
        }
    }

    /// The least-squares solution by the Schur complement of the field block: `S = n I − J Jᵀ/n`,
    /// `S o = b_o − J b_C/n`, `C = (b_C − Jᵀ o)/n`; the offset's covariance is `S⁻¹` times the residual
    /// variance (the lower right block of the normal matrix's inverse).
    pub(super) fn solve(&mut self) -> Option<HardIronSolution> {
        if self.n < 10.0 {
            return None;
        }
        let n = self.n;
        let b_c = Vector3::new(self.rhs[0], self.rhs[1], self.rhs[2]);
        let b_o = Vector3::new(self.rhs[3], self.rhs[4], self.rhs[5]);
        let s = Matrix3::identity() * n - self.j * self.j.transpose() / n;
        let chol = s.cholesky()?;
        let offset = chol.solve(&(b_o - self.j * b_c / n));
        let field = (b_c - self.j.transpose() * offset) / n;
        let ss = (self.ss - (field.dot(&b_c) + offset.dot(&b_o))).max(0.0);
        let dof = (3.0 * n - 6.0).max(1.0);
        let var = ss / dof;
        let offset_cov = chol.inverse() * var;
        let offset_sigma = offset_cov.symmetric_eigenvalues().amax().max(0.0).sqrt();
        let s = HardIronSolution {
            field_gyro: field,
            offset,
            residual_rms: var.sqrt(),
            offset_sigma,
        };
        if !(s.field_gyro.iter().all(|v| v.is_finite())
            && s.offset.iter().all(|v| v.is_finite())
            && s.offset_sigma.is_finite())
        {
            return None;
        }
        self.solution = Some(s);
        Some(s)
    }

    /// The RMS residual per axis over the window of the best field `C` with the offset held at `o`
    /// (`C = (b_C − Jᵀ o)/n`).
    pub(super) fn residual_with_offset(&self, o: &Vector3<f64>) -> f64 {
        if self.n < 10.0 {
            return f64::INFINITY;
        }
        let n = self.n;
        let b_c = Vector3::new(self.rhs[0], self.rhs[1], self.rhs[2]);
        let b_o = Vector3::new(self.rhs[3], self.rhs[4], self.rhs[5]);
        let jt_o = self.j.transpose() * o;
        let c = (b_c - jt_o) / n;
        // ss − 2 xᵀb + xᵀ(HᵀH)x, x = [C; o]: xᵀ(HᵀH)x = C·(n C + Jᵀ o) + o·(J C + n o).
        let quad = c.dot(&(c * n + jt_o)) + o.dot(&(self.j * c + o * n));
        let ss = self.ss - 2.0 * (c.dot(&b_c) + o.dot(&b_o)) + quad;
        (ss.max(0.0) / (3.0 * n - 3.0).max(1.0)).sqrt()
    }

    /// Keeps `weight` of what the fit has seen (a change of the field: the readings before it no longer
    /// describe the field after it).
    pub(super) fn forget(&mut self, weight: f64) {
        self.j *= weight;
        self.rhs *= weight;
        self.ss *= weight;
        self.n *= weight;
    }

    /// How much rotation about its least-turned axis the window holds: the smallest eigenvalue of
    /// `I − J̄ J̄ᵀ`, `J̄ = J / n` the window's mean attitude matrix (0 when the body never turned about
    /// some axis, 1 for attitudes spread over the sphere).
    pub fn excitation(&self) -> f64 {
        if !(self.n > 0.0) {
            return 0.0;
        }
        let jn = self.j / self.n;
        (Matrix3::identity() - jn * jn.transpose())
            .symmetric_eigenvalues()
            .min()
            .max(0.0)
    }

    /// RMS residual of the recent readings against the last solution.
    pub(super) fn recent_rms(&self) -> f64 {
        self.recent_ms.max(0.0).sqrt()
    }
}

/// True when every value is finite: `0·x` is 0 for a finite `x` and NaN otherwise, summed in four
/// lanes (no early exit, no serial chain: it vectorises).
fn all_finite(values: &[f64]) -> bool {
    let mut lanes = [0.0; 4];
    let chunks = values.chunks_exact(4);
    let rest: f64 = chunks.remainder().iter().map(|v| v * 0.0).sum();
    for c in chunks {
        for i in 0..4 {
            lanes[i] += c[i] * 0.0;
        }
    }
    lanes.iter().sum::<f64>() + rest == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Quaternion;

    use crate::sensors::field::tests::field;

    /// The fit on its structure against the dense normal equations it replaces (the pipeline before
    /// issue 15): the same `Σ λ HᵀH`, bit for bit; the same solution, residual, offset σ and residual
    /// with a given offset to rounding; the dense form converts back, and one without the structure is
    /// refused.
    #[test]
    fn the_structured_fit_is_the_dense_one() {
        let (window, dt) = (10.0, 0.0035);
        let lambda = (-dt / window as f64).exp();
        let mut fit = HardIronFit::default();
        let (mut info, mut rhs, mut ss) = (Matrix6::<f64>::zeros(), Vector6::<f64>::zeros(), 0.0);
        let offset = Vector3::new(3.0, -20.0, 8.0);
        let mut q = Quaternion::IDENTITY;
        for k in 0..3000 {
            let t = k as f64 * dt;
            let w = Vector3::new((0.7 * t).sin(), (0.5 * t).cos(), 0.8 * (0.3 * t).sin());
            q = q.propagate(&w, dt);
            let a = q.attitude_matrix();
            let wobble = Vector3::new((13.0 * t).sin(), (7.0 * t).cos(), (3.0 * t).sin()) * 0.3;
            let m = a * field(65.0) + offset + wobble;
            fit.add(&m, &a, lambda, None);
            info *= lambda;
            rhs *= lambda;
            ss *= lambda;
            let mut hth = Matrix6::identity();
            hth.fixed_view_mut::<3, 3>(0, 3).copy_from(&a.transpose());
            hth.fixed_view_mut::<3, 3>(3, 0).copy_from(&a);
            info += hth;
            let atm = a.transpose() * m;
            rhs += Vector6::new(atm[0], atm[1], atm[2], m[0], m[1], m[2]);
            ss += m.norm_squared();
        }
        let bits = |m: &Matrix6<f64>| m.map(f64::to_bits);
        assert_eq!(bits(&fit.info()), bits(&info));
        assert_eq!(fit.rhs.map(f64::to_bits), rhs.map(f64::to_bits));
        assert_eq!(fit.ss.to_bits(), ss.to_bits());
        // The dense solution (the code this replaced).
        let chol = info.cholesky().unwrap();
        let x = chol.solve(&rhs);
        let var = (ss - x.dot(&rhs)).max(0.0) / (3.0 * fit.n - 6.0);
        let cov = chol.inverse().fixed_view::<3, 3>(3, 3) * var;
        let sigma = cov.symmetric_eigenvalues().amax().sqrt();
        let s = fit.solve().unwrap();
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * b.abs().max(1e-300);
        for i in 0..3 {
            assert!(
                close(s.field_gyro[i], x[i], 1e-10),
                "{} {}",
                s.field_gyro,
                x
            );
            assert!(close(s.offset[i], x[i + 3], 1e-10), "{} {}", s.offset, x);
        }
        assert!(close(s.residual_rms, var.sqrt(), 1e-8));
        assert!(
            close(s.offset_sigma, sigma, 1e-9),
            "{} {sigma}",
            s.offset_sigma
        );
        assert!((s.offset - offset).norm() < 0.5);
        let o = Vector3::new(1.0, -18.0, 7.0);
        let c = (Vector3::new(rhs[0], rhs[1], rhs[2]) - info.fixed_view::<3, 3>(0, 3) * o)
            / info[(0, 0)];
        let xo = Vector6::new(c[0], c[1], c[2], o[0], o[1], o[2]);
        let dense = ((ss - 2.0 * xo.dot(&rhs) + xo.dot(&(info * xo))) / (3.0 * fit.n - 3.0)).sqrt();
        assert!(close(fit.residual_with_offset(&o), dense, 1e-9));
        assert_eq!(HardIronFit::j_of_info(&info, fit.n), Ok(fit.j));
        let mut off = info;
        off[(0, 1)] = 1e-3;
        assert!(HardIronFit::j_of_info(&off, fit.n).is_err());
    }
}
