//! The heading-only observation (`Aspect::Heading`), the same for both paths: a `field` sensor with
//! `heading_only` on `P/V/vectors` and the raw-IMU pipeline's magnetometer.
//!
//! **Heading-only observation.** With `up` the reference frame's vertical (unit), `e₁` the unit
//! horizontal part of the reference `r` and `e₂ = up × e₁`, the heading residual of an attitude `A`
//! (reference → body) is `ψ(A) = atan2(b·(A e₂), b·(A e₁))`: the angle about `up` from `e₁` to the
//! horizontal part of `Aᵀ b`. For the true attitude `A = A(δα) Â` (body-frame error `δα`) and an exact
//! `b`, `y = −ψ(Â) ≈ hᵀ δα` ([`heading_jacobian`]) with `hᵀ v = 1` for the body-frame vertical
//! `v = Â up`: a rotation about the vertical is seen one to one; a tilt error leaks into the heading of
//! a field with a dip (`∝ tan dip`), as in any heading from a magnetometer. `σ_ψ = σ/‖r_h‖`
//! ([`heading_sigma_rad`]). The MEKF uses `H = [hᵀ, 0₃]` (so the innovation variance counts the tilt
//! uncertainty) with its attitude gain projected on the vertical (`K_α ← v vᵀ K_α`, Joseph form, valid
//! for any gain), so the field never tilts the estimate; the particle filter weighs particles by
//! `exp(−ψᵢ²/2σ_ψ²)` (exact, so a particle's tilt is weighed by the leak too); USQUE, which has no

use nalgebra::{Matrix3, Vector3};

/// The heading geometry of an observation about `up`: `(e₁, e₂, ‖r_h‖)`, with `r_h` the part of
/// `reference` perpendicular to `up` (unit `up` is normalised here). `None` when the reference has no
/// horizontal part (then the observation says nothing about the heading) or `up` no direction.
pub fn heading_basis(
    reference: &Vector3<f64>,
    up: &Vector3<f64>,
) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
    let up = up.try_normalize(0.0)?;
    let rh = reference - up * reference.dot(&up);
    let n = rh.norm();
    if !(n > 1e-9 * reference.norm() && n.is_finite()) {
        return None;
    }
    let e1 = rh / n;
    Some((e1, up.cross(&e1), n))
}

/// The heading observation's 1σ, rad: `σ/‖r_h‖` (the noise of the horizontal component, per axis, over
/// its length).
pub fn heading_sigma_rad(sigma: f64, horizontal_norm: f64) -> f64 {
    sigma / horizontal_norm
}

/// `ψ(A) = atan2(b·(A e₂), b·(A e₁))`, the heading residual of the attitude `A` (see the module docs).
pub fn heading_residual(
    a: &Matrix3<f64>,
    body: &Vector3<f64>,
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
) -> f64 {
    body.dot(&(a * e2)).atan2(body.dot(&(a * e1)))
}

/// The attitude Jacobian `h` of `y = −ψ(Â)` ([`heading_residual`]) about the estimate `Â`, evaluated at
/// the predicted measurement `b̂ = Â r`: `h = −((Â e₂) × b̂) / ‖r_h‖`, so `y ≈ hᵀ δα` for the body-frame
/// error `δα` (`A = A(δα) Â`). Its component along the body-frame vertical
/// `v = Â up` is 1 (`hᵀ v = 1`); its horizontal components are the leak of a tilt error into the
/// heading of a field with a dip (`∝ tan dip`). `reference` is the unit reference, `horizontal` its
/// horizontal norm.
pub fn heading_jacobian(
    a: &Matrix3<f64>,
    reference: &Vector3<f64>,
    e2: &Vector3<f64>,
    horizontal: f64,
) -> Vector3<f64> {
    let b_hat = a * reference;
    // (Â e₂)ᵀ [b̂×] δα = (Â e₂)·(b̂ × δα) = ((Â e₂) × b̂)·δα.
    -((a * e2).cross(&b_hat)) / horizontal
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Quaternion;

    /// `y = −ψ(Â)` against [`heading_jacobian`] by central differences, with `A_true = A(δα) Â`; its
    /// vertical component is 1.
    #[test]
    fn heading_jacobian_matches_finite_differences() {
        let dip = 65f64.to_radians();
        let r = Vector3::new(0.0, dip.cos(), -dip.sin());
        let up = Vector3::new(0.0, 0.0, 1.0);
        let (e1, e2, r_h) = heading_basis(&r, &up).unwrap();
        let truth = Quaternion::from_euler_321(0.7, 0.4, -0.3);
        let a_true = truth.attitude_matrix();
        let b = a_true * r;
        let eps = 1e-6;
        for k in 0..3 {
            // Â = A(δα)ᵀ A_true for δα = ±ε e_k.
            let y = |s: f64| {
                let mut da = Vector3::zeros();
                da[k] = s * eps;
                let est = Quaternion::from_rotation_vector(&da)
                    .inverse()
                    .compose(&truth);
                -heading_residual(&est.attitude_matrix(), &b, &e1, &e2)
            };
            let numeric = (y(1.0) - y(-1.0)) / (2.0 * eps);
            let analytic = heading_jacobian(&a_true, &r, &e2, r_h)[k];
            assert!(
                (numeric - analytic).abs() < 1e-6,
                "axis {k}: {numeric} vs {analytic}"
            );
        }
        let h = heading_jacobian(&a_true, &r, &e2, r_h);
        assert!((h.dot(&(a_true * up)) - 1.0).abs() < 1e-12);
    }
}
