//! The block-structured kernels against the dense algebra they replace, on random cases: the dense
//! Joseph-form updates (Cholesky solve of the 3×3 innovation covariance, gain projected, then
//! `(I − KH) P (I − KH)ᵀ + K R Kᵀ`) and the dense `Φ P Φᵀ + Q`, kept here as the oracle.

use super::kernels::{self, Cov};
use super::{bias_update, heading_update, joseph_update, noise, tilt_update, transition_matrix};
use crate::attitude::{skew, Quaternion};
use crate::filters::{is_spd, plausibly_spd, symmetrize, GyroErrors};
use crate::sensors::GyroNoise;
use nalgebra::{Matrix3, Matrix3x6, Matrix6, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

// ------------------------------------------------------------------------------------------------
// The oracle: the dense implementation as it was.

struct Dense {
    covariance: Matrix6<f64>,
    nis: f64,
    correction: Vector6<f64>,
    /// The condition number of `S`: the dense solve's own error is ~eps times it.
    cond: f64,
}

fn cond(s: &Matrix3<f64>) -> f64 {
    let e = s.symmetric_eigenvalues();
    e.amax() / e.amin()
}

fn dense_vector(
    p: &Matrix6<f64>,
    b: &Vector3<f64>,
    sigma: f64,
    nu: &Vector3<f64>,
    vertical: Option<&Vector3<f64>>,
) -> Option<Dense> {
    let mut h = Matrix3x6::zeros();
    h.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(b));
    let r = sigma * sigma;
    let pht = p * h.transpose();
    let s = h * pht + Matrix3::identity() * r;
    let chol = s.cholesky()?;
    let mut gain = chol.solve(&pht.transpose()).transpose();
    if let Some(v) = vertical {
        let proj = Matrix3::identity() - v * v.transpose();
        let ka = proj * gain.fixed_view::<3, 3>(0, 0);
        let kb = proj * gain.fixed_view::<3, 3>(3, 0);
        gain.fixed_view_mut::<3, 3>(0, 0).copy_from(&ka);
        gain.fixed_view_mut::<3, 3>(3, 0).copy_from(&kb);
    }
    let ikh = Matrix6::identity() - gain * h;
    let mut covariance = ikh * p * ikh.transpose() + gain * gain.transpose() * r;
    symmetrize(&mut covariance);
    Some(Dense {
        covariance,
        nis: nu.dot(&chol.solve(nu)),
        correction: gain * nu,
        cond: cond(&s),
    })
}

fn dense_bias(p: &Matrix6<f64>, sigma: f64, nu: &Vector3<f64>) -> Option<Dense> {
    let mut h = Matrix3x6::zeros();
    h.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&Matrix3::identity());
    let r = sigma * sigma;
    let pht = p * h.transpose();
    let s = h * pht + Matrix3::identity() * r;
    let chol = s.cholesky()?;
    let gain = chol.solve(&pht.transpose()).transpose();
    let ikh = Matrix6::identity() - gain * h;
    let mut covariance = ikh * p * ikh.transpose() + gain * gain.transpose() * r;
    symmetrize(&mut covariance);
    Some(Dense {
        covariance,
        nis: nu.dot(&chol.solve(nu)),
        correction: gain * nu,
        cond: cond(&s),
    })
}

fn dense_heading(
    p: &Matrix6<f64>,
    h_att: &Vector3<f64>,
    v: &Vector3<f64>,
    sigma_psi: f64,
    nu: f64,
) -> Option<Dense> {
    let h = Vector6::new(h_att[0], h_att[1], h_att[2], 0.0, 0.0, 0.0);
    let r = sigma_psi * sigma_psi;
    let ph = p * h;
    let s = h.dot(&ph) + r;
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let mut gain = ph / s;
    let ka = v * v.dot(&Vector3::new(gain[0], gain[1], gain[2]));
    let kb = v * v.dot(&Vector3::new(gain[3], gain[4], gain[5]));
    for i in 0..3 {
        gain[i] = ka[i];
        gain[i + 3] = kb[i];
    }
    let ikh = Matrix6::identity() - gain * h.transpose();
    let mut covariance = ikh * p * ikh.transpose() + gain * gain.transpose() * r;
    symmetrize(&mut covariance);
    Some(Dense {
        covariance,
        nis: nu * nu / s,
        correction: gain * nu,
        cond: 1.0,
    })
}

/// `Φ` with the trigonometric coefficients (a series only below θ = 1e-5).
fn dense_phi(w: &Vector3<f64>, dt: f64) -> Matrix6<f64> {
    let n = w.norm();
    let theta = n * dt;
    let wx = skew(w);
    let wx2 = wx * wx;
    let (c1, c2, c3) = if theta < 1e-5 {
        let t2 = dt * dt;
        (
            dt * (1.0 - theta * theta / 6.0),
            t2 / 2.0 * (1.0 - theta * theta / 12.0),
            t2 * dt / 6.0 * (1.0 - theta * theta / 20.0),
        )
    } else {
        (
            theta.sin() / n,
            (1.0 - theta.cos()) / (n * n),
            (theta - theta.sin()) / (n * n * n),
        )
    };
    let mut phi = Matrix6::identity();
    let a = Matrix3::identity() - wx * c1 + wx2 * c2;
    let b = wx * c2 - Matrix3::identity() * dt - wx2 * c3;
    phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&a);
    phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&b);
    phi
}

// ------------------------------------------------------------------------------------------------
// Random cases

/// A random symmetric positive-definite covariance with an attitude block of 1e-8…1e-2 rad², a bias
/// block of 1e-14…1e-6 (rad/s)² and correlations of every size.
fn random_p(rng: &mut Xoshiro256PlusPlus) -> Matrix6<f64> {
    let a = Matrix6::from_fn(|_, _| rng.random::<f64>() * 2.0 - 1.0);
    let c = a * a.transpose() + Matrix6::identity() * rng.random::<f64>().powi(3);
    let scale: [f64; 6] = std::array::from_fn(|i| {
        let (lo, hi) = if i < 3 { (-8.0, -2.0) } else { (-14.0, -6.0) };
        10f64.powf(0.5 * (lo + (hi - lo) * rng.random::<f64>()))
    });
    let mut p = Matrix6::from_fn(|i, j| c[(i, j)] * scale[i] * scale[j]);
    symmetrize(&mut p);
    assert!(is_spd(&p));
    p
}

fn unit(rng: &mut Xoshiro256PlusPlus) -> Vector3<f64> {
    loop {
        let v = Vector3::from_fn(|_, _| rng.random::<f64>() * 2.0 - 1.0);
        if (0.1..=1.0).contains(&v.norm()) {
            return v.normalize();
        }
    }
}

/// Every entry within `tol` of the reference, relative to `√(Pᵢᵢ Pⱼⱼ)` of the prior or the reference,
/// whichever is larger (a projected gain is not optimal: it may add variance).
fn assert_cov_close(got: &Matrix6<f64>, want: &Matrix6<f64>, prior: &Matrix6<f64>, tol: f64) {
    let var = |i: usize| prior[(i, i)].max(want[(i, i)]);
    for i in 0..6 {
        for j in 0..6 {
            let scale = (var(i) * var(j)).sqrt();
            let d = (got[(i, j)] - want[(i, j)]).abs();
            assert!(
                d <= tol * scale,
                "P[{i}][{j}]: {} vs {} (|Δ| = {d:e}, scale {scale:e})",
                got[(i, j)],
                want[(i, j)]
            );
        }
    }
    assert_eq!(got, &got.transpose(), "exactly symmetric");
}

fn assert_update_close(
    got: &super::ScalarUpdate,
    want: &Dense,
    prior: &Matrix6<f64>,
    case: usize,
    tol: f64,
) {
    let tol = tol + 1e-15 * want.cond;
    assert_cov_close(&got.covariance, &want.covariance, prior, tol);
    assert!(
        (got.nis - want.nis).abs() <= tol * want.nis.max(1e-300),
        "case {case}: NIS {} vs {}",
        got.nis,
        want.nis
    );
    for i in 0..6 {
        let scale = prior[(i, i)].max(want.covariance[(i, i)]).sqrt() * want.nis.sqrt().max(1.0);
        let d = (got.correction[i] - want.correction[i]).abs();
        assert!(
            d <= tol * scale,
            "case {case}: correction[{i}] {} vs {}",
            got.correction[i],
            want.correction[i]
        );
    }
}

const CASES: usize = 2000;
/// "To rounding": the two computations sum in different orders, and an update removes most of a
/// variance (P falls by up to ~1e6 at σ² ≪ P), so both lose digits to cancellation: 1e-13 of the
/// prior's scale, plus ~eps times the condition of the dense 3×3 solve (the largest difference seen
/// over these cases is below 1e-14).
const TOL: f64 = 1e-13;

#[test]
fn full_and_tilt_updates_equal_the_dense_joseph_form() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(15);
    for case in 0..CASES {
        let p = random_p(&mut rng);
        // A unit direction, or a field in nT: H scales with it.
        let norm = if case % 4 == 3 { 5e4 } else { 1.0 };
        let b = unit(&mut rng) * norm;
        let sigma = norm * 10f64.powf(-5.0 + 4.0 * rng.random::<f64>());
        let nu = Vector3::from_fn(|_, _| (rng.random::<f64>() - 0.5) * 0.02 * norm);
        let want = dense_vector(&p, &b, sigma, &nu, None).unwrap();
        let got = joseph_update(&p, &b, sigma, Some(&nu)).unwrap();
        assert_update_close(&got, &want, &p, case, TOL);
        // Tilt: the vertical is the observed direction itself, or any other.
        let v = if case % 2 == 0 {
            b / norm
        } else {
            unit(&mut rng)
        };
        let want = dense_vector(&p, &b, sigma, &nu, Some(&v)).unwrap();
        let got = tilt_update(&p, &b, &v, sigma, &nu).unwrap();
        assert_update_close(&got, &want, &p, case, TOL);
    }
}

#[test]
fn heading_and_bias_updates_equal_the_dense_joseph_form() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(16);
    for case in 0..CASES {
        let p = random_p(&mut rng);
        let v = unit(&mut rng);
        // hᵀv = 1 and a horizontal leak of up to tan 80°.
        let leak = v.cross(&unit(&mut rng)) * 5.0 * rng.random::<f64>();
        let h = v + leak;
        let sigma = 10f64.powf(-4.0 + 3.0 * rng.random::<f64>());
        let nu = (rng.random::<f64>() - 0.5) * 0.1;
        let want = dense_heading(&p, &h, &v, sigma, nu).unwrap();
        let got = heading_update(&p, &h, &v, sigma, nu).unwrap();
        assert_update_close(&got, &want, &p, case, TOL);
        let sigma = 10f64.powf(-8.0 + 5.0 * rng.random::<f64>());
        let nu = Vector3::from_fn(|_, _| (rng.random::<f64>() - 0.5) * 1e-3);
        let want = dense_bias(&p, sigma, &nu).unwrap();
        let got = bias_update(&p, sigma, &nu).unwrap();
        assert_update_close(&got, &want, &p, case, TOL);
    }
}

/// A singular innovation covariance is refused as before: no noise on a vector observation (`σ²`
/// underflows), and the covariance of a refused update is left as it was.
#[test]
fn singular_innovations_are_refused() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
    let p = random_p(&mut rng);
    // (The dense form found S singular only when rounding made it exactly so, as along an axis.)
    assert!(dense_vector(&p, &Vector3::x(), 1e-300, &Vector3::zeros(), None).is_none());
    let b = unit(&mut rng);
    assert!(joseph_update(&p, &b, 1e-300, Some(&Vector3::zeros())).is_none());
    assert!(tilt_update(&p, &b, &b, 0.0, &Vector3::zeros()).is_none());
    let mut c: Cov = p.data.0;
    let mut bad = c;
    bad[0][0] = -1.0;
    let before = bad;
    assert!(kernels::heading(&mut bad, &[1.0, 0.0, 0.0], &[1.0, 0.0, 0.0], 1e-9, 0.1).is_none());
    assert_eq!(bad, before);
    assert!(kernels::vector(&mut c, &[f64::NAN, 0.0, 0.0], 0.1, &[0.0; 3], None).is_none());
    assert_eq!(c, p.data.0);
}

#[test]
fn propagation_equals_the_dense_product() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(18);
    let gyro = GyroNoise {
        sigma_v: 3e-3,
        sigma_u: 3e-5,
    };
    let errors = GyroErrors {
        rate_noise_sqrt_s: 2e-3,
        bias_limit_rad_s: 0.0175,
    };
    for case in 0..CASES {
        let p0 = random_p(&mut rng);
        // Rotations per step from 1e-9 rad to 3 rad: both branches of the coefficients.
        let dt = [3.5e-3, 0.01, 0.1, 1.0][case % 4];
        let theta = 10f64.powf(-9.0 + 9.5 * rng.random::<f64>());
        let w = unit(&mut rng) * (theta / dt);
        let extra = errors.rate_variance(&w, dt);
        let phi_b = if case % 3 == 0 {
            1.0
        } else {
            (-dt * errors.bias_reversion_rate(&gyro) * 1e4).exp()
        };
        // The dense reference.
        let phi = dense_phi(&w, dt);
        let q = super::process_noise(&gyro, dt);
        let mut want = phi * p0 * phi.transpose() + q;
        for i in 0..3 {
            want[(i, i)] += extra;
        }
        if phi_b < 1.0 {
            for i in 0..6 {
                for j in 3..6 {
                    want[(i, j)] *= phi_b;
                    want[(j, i)] *= phi_b;
                }
            }
        }
        symmetrize(&mut want);
        let (a, b) = kernels::phi_blocks(&w.into(), dt);
        let got = kernels::propagate(&p0.data.0, &a, &b, &noise(&gyro, dt), extra, phi_b);
        let got = Matrix6::from_data(nalgebra::ArrayStorage(got));
        // The dense Φ's c₃ = (θ − sin θ)/‖ω‖³ loses ~eps/θ² of itself to cancellation; the series does not.
        assert_cov_close(&got, &want, &p0, 1e-12);
        // The dense c₂ = (1 − cos θ)/‖ω‖² loses ~eps/θ² of itself, an error of ~eps Δt/θ in c₂ [ω×].
        let d = (transition_matrix(&w, dt) - phi).abs().max();
        let tol = 1e-15 * dt.max(1.0) + 1e-15 * dt / theta.min(1.0);
        assert!(d <= tol, "case {case}: |ΔΦ| = {d:e}, θ = {theta:e}");
    }
}

/// The series and the trigonometric coefficients agree near θ = 0.1 rad on either side and below it,
/// to rounding (c₂ and c₃ to what the trigonometric form's cancellation leaves, ~eps/θ²).
#[test]
fn phi_coefficients_are_continuous_at_the_series_bound() {
    for dt in [3.5e-3, 1.0] {
        for theta in [0.0999999, 0.1, 0.1000001, 0.05, 0.02] {
            let w2 = (theta / dt) * (theta / dt);
            let (c1, c2, c3) = kernels::phi_coefficients(w2, dt);
            let w = w2.sqrt();
            let (s, c) = (w * dt).sin_cos();
            let trig = (s / w, (1.0 - c) / w2, (w * dt - s) / (w2 * w));
            assert!((c1 / trig.0 - 1.0).abs() < 1e-15, "{theta}: c1");
            assert!(
                (c2 / trig.1 - 1.0).abs() < 1e-16 / (theta * theta),
                "{theta}: c2"
            );
            assert!(
                (c3 / trig.2 - 1.0).abs() < 1e-15 / (theta * theta),
                "{theta}: c3 {c3} vs {}",
                trig.2
            );
        }
    }
}

/// The cheap check (a Kalman estimate's health before it is published, in release builds) refuses a NaN,
/// a negative variance, a correlation beyond ±1; it passes a positive-definite covariance.
#[test]
fn plausibility_check() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(19);
    let p = random_p(&mut rng);
    assert!(plausibly_spd(&p));
    let mut nan = p;
    (nan[(1, 4)], nan[(4, 1)]) = (f64::NAN, f64::NAN);
    assert!(!plausibly_spd(&nan));
    let mut negative = p;
    negative[(5, 5)] = -negative[(5, 5)];
    assert!(!plausibly_spd(&negative));
    let mut correlated = p;
    let c = 1.01 * (p[(0, 0)] * p[(3, 3)]).sqrt();
    (correlated[(0, 3)], correlated[(3, 0)]) = (c, c);
    assert!(!plausibly_spd(&correlated));
    let mut infinite = p;
    infinite[(2, 2)] = f64::INFINITY;
    assert!(!plausibly_spd(&infinite));
    let mut lower = p;
    lower[(4, 0)] = f64::NAN;
    assert!(!plausibly_spd(&lower), "a NaN in either triangle");
}

/// The quaternion and `Φ` of one step agree with each other: `Φ₁₁` is the rotation `δq(ω̂ Δt)` makes of
/// a body-frame error (`A(δq)`), for the series branch and the trigonometric one.
#[test]
fn phi11_is_the_step_rotation() {
    for (w, dt) in [
        (Vector3::new(3.0, -1.0, 2.0), 3.5e-3),
        (Vector3::new(0.3, 0.5, -0.2), 1.0),
    ] {
        let a = Quaternion::from_rotation_vector(&(w * dt)).attitude_matrix();
        let phi = transition_matrix(&w, dt);
        let d = (phi.fixed_view::<3, 3>(0, 0) - a).abs().max();
        assert!(d < 1e-15, "|Φ₁₁ − A(δq)| = {d:e}");
    }
}
