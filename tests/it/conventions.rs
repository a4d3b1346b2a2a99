//! Pins the conventions of docs/algorithms.md §1 and its test vectors (§7) with known numbers.

use attitude_service::attitude::{
    q_method, weighted_average, AverageAccumulator, AverageError, Grp, Quaternion,
};
use attitude_service::bounds::{steady_state, Pcrb};
use attitude_service::filters::mekf::{process_noise, transition_matrix};
use attitude_service::sensors::{Aspect, GyroNoise, VectorObservation};
use nalgebra::{Matrix3, Vector3};

const ARCSEC: f64 = std::f64::consts::PI / 180.0 / 3600.0;
const DEG_PER_HR: f64 = std::f64::consts::PI / 180.0 / 3600.0;

fn q(v: [f64; 4]) -> Quaternion {
    Quaternion::new(v[0], v[1], v[2], v[3])
}

/// Equal up to the sign of the quaternion.
fn assert_q_close(a: &Quaternion, b: [f64; 4], tol: f64) {
    let b = q(b);
    let s = if a.dot(&b) < 0.0 { -1.0 } else { 1.0 };
    let d = [a.x - s * b.x, a.y - s * b.y, a.z - s * b.z, a.w - s * b.w];
    let err = d.iter().map(|x| x.abs()).fold(0.0, f64::max);
    assert!(
        err < tol,
        "{a:?} vs ±{b:?}: max difference {err:e} > {tol:e}"
    );
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol,
        "{what}: {a} vs {b} (diff {:e})",
        (a - b).abs()
    );
}

#[test]
fn attitude_matrix_of_a_frame_rotation_about_z() {
    // 90° about z: the reference x axis is seen along body −y (a frame, not a vector, rotation).
    let h = std::f64::consts::FRAC_PI_4;
    let qz = q([0.0, 0.0, h.sin(), h.cos()]);
    let a = qz.attitude_matrix();
    let b = a * Vector3::x();
    assert!((b - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-15, "{b}");
    // A(q) = (q4² − ϱᵀϱ) I + 2ϱϱᵀ − 2 q4 [ϱ×] written out for a generic quaternion.
    let g = q([
        0.216930457819,
        -0.108465228909,
        0.433860915637,
        0.867721831275,
    ]);
    let a = g.attitude_matrix();
    let (x, y, z, w) = (g.x, g.y, g.z, g.w);
    let expected = Matrix3::new(
        w * w + x * x - y * y - z * z,
        2.0 * (x * y + z * w),
        2.0 * (x * z - y * w),
        2.0 * (x * y - z * w),
        w * w - x * x + y * y - z * z,
        2.0 * (y * z + x * w),
        2.0 * (x * z + y * w),
        2.0 * (y * z - x * w),
        w * w - x * x - y * y + z * z,
    );
    assert!((a - expected).norm() < 1e-12);
}

#[test]
fn same_numbers_as_hamilton_body_to_reference() {
    // nalgebra's UnitQuaternion is Hamilton; from (w, x, y, z) its rotation matrix R satisfies A = Rᵀ.
    let g = q([
        0.216930457819,
        -0.108465228909,
        0.433860915637,
        0.867721831275,
    ])
    .normalized()
    .unwrap();
    let h =
        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(g.w, g.x, g.y, g.z));
    let r = h.to_rotation_matrix().into_inner();
    assert!((g.attitude_matrix() - r.transpose()).norm() < 1e-14);
    // The Shuster product p ⊗ q is the Hamilton product q · p.
    let p = q([0.1, 0.2, -0.3, 0.9]).normalized().unwrap();
    let hp =
        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(p.w, p.x, p.y, p.z));
    let shuster = p.compose(&g);
    let hamilton = (h * hp).into_inner();
    assert_q_close(
        &shuster,
        [hamilton.i, hamilton.j, hamilton.k, hamilton.w],
        1e-15,
    );
}

#[test]
fn composition_error_and_small_angle_conventions() {
    let p = q([0.1, 0.2, -0.3, 0.9]).normalized().unwrap();
    let r = q([-0.4, 0.1, 0.2, 0.8]).normalized().unwrap();
    assert!(
        (p.compose(&r).attitude_matrix() - p.attitude_matrix() * r.attitude_matrix()).norm()
            < 1e-14
    );
    // δq = q ⊗ q̂⁻¹ with a small body-frame error δα gives back δα ≈ 2δϱ.
    let dalpha = Vector3::new(1e-4, -2e-4, 3e-4);
    let truth = Quaternion::from_rotation_vector(&dalpha).compose(&r);
    let e = truth.small_angle_error(&r);
    assert!((e - dalpha).norm() < 1e-11, "{e}");
    // Applying δα on the left rotates body vectors: A(q) ≈ (I − [δα×]) A(q̂).
    let lhs = truth.attitude_matrix();
    let rhs =
        (Matrix3::identity() - attitude_service::attitude::skew(&dalpha)) * r.attitude_matrix();
    assert!((lhs - rhs).norm() < 1e-7);
}

#[test]
fn tv_a1_scipy_mean() {
    let s = 0.008726535498374;
    let c = 0.999961923064171;
    let qs = [
        q([0.0, 0.0, 0.0, 1.0]),
        q([0.0, 0.0, s, c]),
        q([0.0, s, 0.0, c]),
        q([s, 0.0, 0.0, c]),
    ];
    let avg = weighted_average(&qs, &[1.0; 4], None).unwrap();
    assert_q_close(
        &avg.q,
        [
            0.002181670218128,
            0.002181670218128,
            0.002181670218128,
            0.999992860447102,
        ],
        1e-12,
    );
    let ev = avg.eigenvalues;
    assert_close(ev[0], 3.99982865624, 1e-10, "λ1");
    assert_close(ev[1], 7.6152e-5, 1e-9, "λ2");
    assert_close(ev[2], 7.6152e-5, 1e-9, "λ3");
    assert_close(ev[3], 1.9039e-5, 1e-9, "λ4");
    assert_close(
        avg.concentration,
        3.99982865624 / 4.0,
        1e-10,
        "concentration",
    );
}

#[test]
fn tv_a2_weighted_with_a_negated_input() {
    let qs = [
        q([0.0, 0.0, 0.0, 1.0]),
        q([0.087155742747658, 0.0, 0.0, 0.996194698091746]),
        q([0.0, -0.17364817766693, 0.0, -0.984807753012208]),
        q([0.0, 0.0, 0.258819045102521, 0.965925826289068]),
    ];
    let avg = weighted_average(&qs, &[0.1, 0.2, 0.3, 0.4], None).unwrap();
    assert_q_close(
        &avg.q,
        [
            0.017690458951285,
            0.052671855517375,
            0.104587475129306,
            0.992962327253419,
        ],
        1e-12,
    );
}

#[test]
fn tv_a3_symmetric_pair_and_eigenvalues() {
    let h = 20f64.to_radians();
    let qs = [
        q([0.0, 0.0, h.sin(), h.cos()]),
        q([0.0, 0.0, -h.sin(), h.cos()]),
    ];
    let avg = weighted_average(&qs, &[1.0, 1.0], None).unwrap();
    assert_q_close(&avg.q, [0.0, 0.0, 0.0, 1.0], 1e-12);
    assert_close(avg.eigenvalues[0], 2.0 * h.cos().powi(2), 1e-12, "λ1");
    assert_close(avg.eigenvalues[1], 2.0 * h.sin().powi(2), 1e-12, "λ2");
    assert_close(avg.eigenvalues[2], 0.0, 1e-12, "λ3");
}

#[test]
fn tv_a4_unequal_weights_about_one_axis() {
    let h = 45f64.to_radians();
    let qs = [q([0.0, 0.0, 0.0, 1.0]), q([0.0, 0.0, h.sin(), h.cos()])];
    let avg = weighted_average(&qs, &[1.0, 3.0], None).unwrap();
    assert_q_close(
        &avg.q,
        [0.0, 0.0, 0.584710284663765, 0.811242185175561],
        1e-12,
    );
    assert_close(
        avg.q.angle().to_degrees(),
        71.56505117707799,
        1e-10,
        "angle",
    );
}

#[test]
fn average_sign_continuity_and_failures_without_panics() {
    let qs = [q([0.0, 0.0, 0.1, 1.0]).normalized().unwrap()];
    let prev = q([0.0, 0.0, -0.1, -1.0]).normalized().unwrap();
    let avg = weighted_average(&qs, &[1.0], Some(&prev)).unwrap();
    assert!(avg.q.dot(&prev) > 0.0, "sign follows the previous estimate");
    assert!(avg.q.w < 0.0);
    let no_prev = weighted_average(&qs, &[1.0], None).unwrap();
    assert!(no_prev.q.w > 0.0);
    assert_eq!(weighted_average(&[], &[], None), Err(AverageError::Empty));
    assert_eq!(
        weighted_average(&qs, &[0.0], None),
        Err(AverageError::ZeroTotalWeight)
    );
    assert!(matches!(
        weighted_average(&qs, &[-1.0], None),
        Err(AverageError::InvalidWeight { index: 0, .. })
    ));
    assert!(matches!(
        weighted_average(&qs, &[f64::NAN], None),
        Err(AverageError::InvalidWeight { .. })
    ));
    assert_eq!(
        weighted_average(&[q([f64::NAN, 0.0, 0.0, 1.0])], &[1.0], None),
        Err(AverageError::NonFiniteQuaternion { index: 0 })
    );
    // Two attitudes 180° apart with equal weights: λ₁ = λ₂, the average is undecidable.
    let opposite = [q([0.0, 0.0, 0.0, 1.0]), q([1.0, 0.0, 0.0, 0.0])];
    assert!(matches!(
        weighted_average(&opposite, &[1.0, 1.0], None),
        Err(AverageError::Undecidable { .. })
    ));
    // The accumulator gives the same answer as the slice function.
    let mut acc = AverageAccumulator::new();
    acc.add(&qs[0], 2.0);
    assert_eq!(acc.finish(None).unwrap().q, no_prev.q);
}

#[test]
fn tv_b_omega_propagation() {
    let w = Vector3::new(0.01, -0.02, 0.03);
    let out = Quaternion::IDENTITY.propagate(&w, 1.0);
    assert_q_close(
        &out,
        [
            0.004999708338,
            -0.009999416677,
            0.014999125015,
            0.999825005104,
        ],
        1e-12,
    );
    let q0 = q([
        0.216930457819,
        -0.108465228909,
        0.433860915637,
        0.867721831275,
    ]);
    let out = q0.propagate(&w, 1.0);
    assert_q_close(
        &out,
        [
            0.223942324718,
            -0.118207549217,
            0.445173176889,
            0.858893272233,
        ],
        1e-12,
    );
    // The explicit Ω matrix agrees with the product form.
    let m = Quaternion::omega_matrix(&w, 1.0) * q0.to_vector4();
    assert_q_close(&out, [m[0], m[1], m[2], m[3]], 1e-15);
    // Zero rate is safe and exact.
    let still = q0.propagate(&Vector3::zeros(), 10.0);
    assert_eq!(still, q0.compose(&Quaternion::IDENTITY));
    let tiny = q0.propagate(&Vector3::new(1e-300, 0.0, 0.0), 1.0);
    assert!(tiny.is_finite());
}

#[test]
fn tv_c_generalized_rodrigues_parameters() {
    let dq = q([
        0.086273015034,
        0.172546030068,
        0.172546030068,
        0.965925826289,
    ]);
    let cases = [
        (Grp::USQUE, [0.17553666345, 0.3510733269, 0.3510733269]),
        (Grp::MRP, [0.043884165862, 0.087768331725, 0.087768331725]),
        (Grp::GIBBS, [0.089316397477, 0.178632794954, 0.178632794954]),
    ];
    for (grp, expected) in cases {
        let p = grp.from_quaternion(&dq);
        for i in 0..3 {
            assert_close(p[i], expected[i], 1e-10, "GRP");
        }
        // The inverse returns the same error quaternion.
        let back = grp.to_quaternion(&p);
        assert_q_close(&back, [dq.x, dq.y, dq.z, dq.w], 1e-11);
        // The negated quaternion maps to the same parameters (shortest rotation, no shadow set).
        let p2 = grp.from_quaternion(&dq.negated());
        assert!((p - p2).norm() < 1e-15);
    }
}

#[test]
fn tv_d_mekf_transition_and_noise() {
    let w = Vector3::new(0.01, -0.02, 0.03);
    let phi = transition_matrix(&w, 10.0);
    let expected = [
        0.935754803278,
        0.283164960565,
        0.210191705951,
        -9.784844954262,
        -1.44948068655,
        -1.038038806279,
    ];
    for j in 0..6 {
        assert_close(phi[(0, j)], expected[j], 1e-11, "Φ row 1");
    }
    let qd = process_noise(&GyroNoise::standard(), 10.0);
    assert_close(qd[(0, 0)], 1.000033333333e-12, 1e-24, "Q11");
    assert_close(qd[(0, 3)], -5.0e-18, 1e-30, "Q12");
    assert_close(qd[(3, 3)], 1.0e-18, 1e-30, "Q22");
}

#[test]
fn tv_e_q_method_recovers_the_truth() {
    let truth = q([
        0.207390338946,
        -0.414780677892,
        0.311085508419,
        0.829561355784,
    ]);
    let s3 = 1.0 / 3f64.sqrt();
    let refs = [
        Vector3::x(),
        Vector3::y(),
        Vector3::z(),
        Vector3::new(s3, s3, s3),
    ];
    let expected_body = [
        [0.462365591398, -0.688172043011, -0.559139784946],
        [0.344086021505, 0.720430107527, -0.602150537634],
        [0.817204301075, 0.086021505376, 0.569892473118],
        [0.937418179007, 0.068288741517, -0.341443707585],
    ];
    let a = truth.attitude_matrix();
    let obs: Vec<VectorObservation> = refs
        .iter()
        .zip(expected_body)
        .map(|(r, e)| {
            let b = a * r;
            for i in 0..3 {
                assert_close(b[i], e[i], 1e-11, "A(q_true) r");
            }
            VectorObservation {
                body: b,
                reference: *r,
                sigma: 1e-3,
                sensor: None,
                aspect: Aspect::Full,
            }
        })
        .collect();
    let sol = q_method(&obs).unwrap();
    assert_q_close(&sol.q, [truth.x, truth.y, truth.z, truth.w], 1e-12);
    // Its covariance is the static bound; for these four vectors it is finite and positive.
    assert!(sol.covariance.cholesky().is_some());
    // Parallel vectors do not determine the attitude.
    let parallel = vec![obs[0].clone(), obs[0].clone()];
    assert!(q_method(&parallel).is_err());
}

#[test]
fn tv_f_average_removes_the_mean_local_error() {
    let raw = [
        [0.02, 0.01, 0.0, 1.0],
        [-0.01, 0.03, 0.01, 1.0],
        [0.0, -0.02, 0.02, 1.0],
        [0.03, 0.0, -0.01, 1.0],
    ];
    let qs: Vec<Quaternion> = raw.iter().map(|v| q(*v).normalized().unwrap()).collect();
    let w = [0.4, 0.3, 0.2, 0.1];
    let avg = weighted_average(&qs, &w, None).unwrap();
    assert_q_close(
        &avg.q,
        [
            0.008002236534,
            0.008999457716,
            0.005997941163,
            0.999909495241,
        ],
        1e-12,
    );
    let mut mean = Vector3::zeros();
    for (qi, wi) in qs.iter().zip(w) {
        let p = Grp::MRP.from_quaternion(&qi.compose(&avg.q.inverse()));
        assert!(p.norm() > 1e-3, "each error is ~1e-2");
        mean += p * wi;
    }
    let expected = [-1.25e-6, -7.85e-7, 8.47e-7];
    for i in 0..3 {
        assert_close(mean[i], expected[i], 0.01e-6, "weighted MRP mean");
    }
}

#[test]
fn tv_h_steady_state_closed_form() {
    let g = GyroNoise::standard();
    let s = steady_state(&g, 6.0 * ARCSEC, 1.0);
    assert_close(s.sigma_att_rad / ARCSEC, 0.6506, 5e-5, "σθ (Δt = 1 s)");
    assert_close(
        s.sigma_bias_rad_s / DEG_PER_HR,
        0.00215,
        5e-6,
        "σβ (Δt = 1 s)",
    );
    let s10 = steady_state(&g, 6.0 * ARCSEC, 10.0);
    assert_close(s10.sigma_att_rad / ARCSEC, 1.2342, 5e-5, "σθ (Δt = 10 s)");
}

#[test]
fn pcrb_three_axis_check_matches_the_closed_form() {
    // A quaternion-output star tracker of 6″ per axis is three orthogonal unit vectors of 6″·√2 each
    // (information σ⁻²(I − bbᵀ) summed over an orthonormal triad is 2σ⁻² I).
    let g = GyroNoise::standard();
    let sigma_vec = 6.0 * ARCSEC * 2f64.sqrt();
    let omega = Vector3::new(0.0, -2.0 * std::f64::consts::PI / (91.5 * 60.0), 0.0);
    let mut truth = Quaternion::IDENTITY;
    let mut pcrb = Pcrb::from_sigmas(
        g,
        &Vector3::repeat(0.1f64.to_radians()),
        &Vector3::repeat(0.2 * DEG_PER_HR),
    );
    for _ in 0..5400 {
        pcrb.propagate(&omega, 1.0);
        truth = truth.propagate(&omega, 1.0);
        for r in [Vector3::x(), Vector3::y(), Vector3::z()] {
            pcrb.observe(&truth, &r, sigma_vec);
        }
    }
    let s = pcrb.sigma_att_rad() / ARCSEC;
    for i in 0..3 {
        assert_close(s[i], 0.6506, 2e-4, "PCRB steady state per axis");
    }
    let sb = pcrb.covariance()[(4, 4)].sqrt() / DEG_PER_HR;
    assert_close(sb, 0.00215, 2e-5, "PCRB bias steady state");
}
