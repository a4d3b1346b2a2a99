//! Attitude from one set of vector observations: Davenport's q-method and its covariance.
//!
//! Used to initialise a filter when no attitude is given, and as a test oracle (test vector TV-E,
//! docs/algorithms.md §7).

use super::average::top_eigenpair;
use super::quaternion::{skew, Quaternion};
use crate::sensors::VectorObservation;
use nalgebra::{Matrix3, Matrix4, Vector3};
use thiserror::Error;

#[derive(Clone, Debug, Error, PartialEq)]
pub enum WahbaError {
    #[error("need at least two vector observations, got {0}")]
    TooFewObservations(usize),
    #[error("observation {index} has a non-finite component or a non-positive sigma")]
    InvalidObservation { index: usize },
    #[error("the observations are parallel: the attitude about their common axis is unobservable")]
    Unobservable,
    #[error("the eigen-solver did not converge")]
    NoConvergence,
}

/// A single-epoch attitude solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WahbaSolution {
    pub q: Quaternion,
    /// Covariance of the body-frame small-angle error, rad²:
    /// `P = [Σ σⱼ⁻² (‖bⱼ‖² I − bⱼ bⱼᵀ)]⁻¹` with `bⱼ = A(q) rⱼ` (static bound: docs/algorithms.md §5).
    pub covariance: Matrix3<f64>,
}

/// Davenport's q-method with weights `aⱼ = σⱼ⁻²`: `B = Σ aⱼ bⱼ rⱼᵀ`, `K = [[B + Bᵀ − tr(B) I, z], [zᵀ, tr B]]`,
/// `z = Σ aⱼ bⱼ × rⱼ`; the optimal quaternion is the eigenvector of `K`'s largest eigenvalue.
pub fn q_method(observations: &[VectorObservation]) -> Result<WahbaSolution, WahbaError> {
    if observations.len() < 2 {
        return Err(WahbaError::TooFewObservations(observations.len()));
    }
    let mut b = Matrix3::zeros();
    let mut z = Vector3::zeros();
    let mut scale = 0.0;
    for (index, o) in observations.iter().enumerate() {
        let finite = o
            .body
            .iter()
            .chain(o.reference.iter())
            .all(|x| x.is_finite());
        if !(finite && o.sigma.is_finite() && o.sigma > 0.0) {
            return Err(WahbaError::InvalidObservation { index });
        }
        let a = 1.0 / (o.sigma * o.sigma);
        b += o.body * o.reference.transpose() * a;
        z += o.body.cross(&o.reference) * a;
        scale += a * o.body.norm() * o.reference.norm();
    }
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(WahbaError::Unobservable);
    }
    let sigma = b.trace();
    let s = b + b.transpose();
    let mut k = Matrix4::zeros();
    k.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(s - Matrix3::identity() * sigma));
    k.fixed_view_mut::<3, 1>(0, 3).copy_from(&z);
    k.fixed_view_mut::<1, 3>(3, 0).copy_from(&z.transpose());
    k[(3, 3)] = sigma;
    let (v, _) = top_eigenpair(&(k / scale)).map_err(|_| WahbaError::NoConvergence)?;
    let q = Quaternion::from_vector4(&v).canonical();
    let a = q.attitude_matrix();
    let mut info = Matrix3::zeros();
    for o in observations {
        let bp = a * o.reference;
        // σ⁻² (‖b‖² I − b bᵀ) = −σ⁻² [b×]².
        info -= skew(&bp) * skew(&bp) / (o.sigma * o.sigma);
    }
    let covariance = info
        .cholesky()
        .filter(|c| c.l().diagonal().iter().all(|d| *d > 0.0))
        .map(|c| c.inverse())
        .ok_or(WahbaError::Unobservable)?;
    // Parallel vectors leave an information matrix that is singular to rounding; Cholesky may still
    // succeed with a tiny pivot, so also check the conditioning.
    let eig = info.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if !(lo > hi * 1e-12) {
        return Err(WahbaError::Unobservable);
    }
    Ok(WahbaSolution { q, covariance })
}
