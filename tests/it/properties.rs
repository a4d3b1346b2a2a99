//! The identities of docs/algorithms.md §1 and the invariances of the attitude math, as property
//! tests.

use crate::common::unit_quaternion;
use attitude_service::attitude::{weighted_average, Grp, Quaternion};
use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;

fn rotation_vector(max_angle: f64) -> impl Strategy<Value = Vector3<f64>> {
    (
        -max_angle..max_angle,
        -max_angle..max_angle,
        -max_angle..max_angle,
    )
        .prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn trace_identity(p in unit_quaternion(), q in unit_quaternion()) {
        // tr(A(p)ᵀ A(q)) = 4 (pᵀq)² − 1
        let lhs = (p.attitude_matrix().transpose() * q.attitude_matrix()).trace();
        let rhs = 4.0 * p.dot(&q).powi(2) - 1.0;
        prop_assert!((lhs - rhs).abs() < 1e-12);
    }

    #[test]
    fn composition_is_matrix_product(p in unit_quaternion(), q in unit_quaternion()) {
        let lhs = p.compose(&q).attitude_matrix();
        let rhs = p.attitude_matrix() * q.attitude_matrix();
        prop_assert!((lhs - rhs).abs().max() < 1e-13);
        prop_assert!((p.compose(&q).norm() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn sign_does_not_change_the_attitude(q in unit_quaternion()) {
        prop_assert!((q.attitude_matrix() - q.negated().attitude_matrix()).abs().max() < 1e-15);
        let a = q.attitude_matrix();
        prop_assert!((a * a.transpose() - Matrix3::identity()).abs().max() < 1e-14);
        prop_assert!((a.determinant() - 1.0).abs() < 1e-13);
    }

    #[test]
    fn inverse_and_identity(q in unit_quaternion()) {
        let e = q.compose(&q.inverse());
        prop_assert!((e.w.abs() - 1.0).abs() < 1e-14 && e.vector().norm() < 1e-14);
    }

    #[test]
    fn matrix_round_trip(q in unit_quaternion()) {
        let back = Quaternion::from_attitude_matrix(&q.attitude_matrix());
        prop_assert!((back.dot(&q).abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rotation_vector_round_trip(v in rotation_vector(1.8)) {
        // |v| < π: the rotation vector is unique.
        let q = Quaternion::from_rotation_vector(&v);
        prop_assert!((q.norm() - 1.0).abs() < 1e-15);
        prop_assert!((q.to_rotation_vector() - v).norm() < 1e-12);
        prop_assert!((q.angle() - v.norm()).abs() < 1e-12);
    }

    #[test]
    fn propagation_composes_and_keeps_the_norm(q in unit_quaternion(), w in rotation_vector(0.5), dt in 0.0f64..3.0) {
        let once = q.propagate(&w, dt);
        let twice = q.propagate(&w, dt / 2.0).propagate(&w, dt / 2.0);
        prop_assert!((once.dot(&twice).abs() - 1.0).abs() < 1e-13);
        prop_assert!((once.norm() - 1.0).abs() < 1e-14);
        // The body sees a reference vector turn by −ω×: A(t+dt) = A(δq(ω dt)) A(t).
        let a = Quaternion::from_rotation_vector(&(w * dt)).attitude_matrix() * q.attitude_matrix();
        prop_assert!((once.attitude_matrix() - a).abs().max() < 1e-13);
    }

    #[test]
    fn grp_round_trip_for_any_a_and_f(dq in unit_quaternion(), a in 0.0f64..1.0, f in 0.5f64..5.0) {
        let grp = Grp::new(a, f);
        let dq = dq.canonical();
        // Avoid the chart's singularity at δq4 = −a (only reachable for a = 0 at 180°).
        prop_assume!(dq.w + a > 1e-3);
        let p = grp.from_quaternion(&dq);
        let back = grp.to_quaternion(&p);
        prop_assert!((back.norm() - 1.0).abs() < 1e-12, "unit by construction");
        prop_assert!((back.dot(&dq) - 1.0).abs() < 1e-11);
        // −δq gives the same parameters (shortest rotation; for the MRP no shadow set: ‖p‖ ≤ 1).
        let p2 = grp.from_quaternion(&dq.negated());
        prop_assert!((p - p2).norm() < 1e-12 * (1.0 + p.norm()));
    }

    #[test]
    fn mrp_stays_in_the_unit_ball_and_shadow_is_the_same_attitude(dq in unit_quaternion()) {
        let p = Grp::MRP.from_quaternion(&dq);
        prop_assert!(p.norm() <= 1.0 + 1e-12);
        prop_assume!(p.norm() > 1e-3);
        let s = attitude_service::attitude::rodrigues::mrp_shadow(&p);
        // The shadow set maps (through the general inverse, δq4 < 0 branch) to −δq: same attitude.
        let n2 = s.norm_squared();
        let w = (1.0 - n2) / (1.0 + n2);
        let v = s * (2.0 / (1.0 + n2));
        let qs = Quaternion::new(v[0], v[1], v[2], w);
        prop_assert!((qs.attitude_matrix() - dq.attitude_matrix()).abs().max() < 1e-11);
    }

    #[test]
    fn small_rotations_grp_scale(v in rotation_vector(1e-4)) {
        let dq = Quaternion::from_rotation_vector(&v);
        for grp in [Grp::MRP, Grp::USQUE] {
            let p = grp.from_quaternion(&dq);
            prop_assert!((p * grp.small_angle_factor() - v).norm() < 1e-9);
        }
    }

    #[test]
    fn average_is_sign_invariant_and_exact_for_equal_inputs(
        qs in prop::collection::vec(unit_quaternion(), 1..20),
        ws in prop::collection::vec(0.01f64..1.0, 20),
        flips in prop::collection::vec(any::<bool>(), 20),
    ) {
        let w = &ws[..qs.len()];
        let flipped: Vec<Quaternion> = qs.iter().zip(&flips).map(|(q, f)| if *f { q.negated() } else { *q }).collect();
        if let (Ok(a), Ok(b)) = (weighted_average(&qs, w, None), weighted_average(&flipped, w, None)) {
            prop_assert!((a.q.dot(&b.q) - 1.0).abs() < 1e-9);
            prop_assert!(a.concentration >= 0.25 - 1e-12 && a.concentration <= 1.0 + 1e-12);
            prop_assert!((a.q.norm() - 1.0).abs() < 1e-12);
        }
        let same = vec![qs[0]; qs.len()];
        let avg = weighted_average(&same, w, Some(&qs[0])).unwrap();
        prop_assert!((avg.q.dot(&qs[0]) - 1.0).abs() < 1e-12);
        prop_assert!((avg.concentration - 1.0).abs() < 1e-12);
    }

    #[test]
    fn average_never_panics_on_garbage(
        raw in prop::collection::vec((any::<f64>(), any::<f64>(), any::<f64>(), any::<f64>(), any::<f64>()), 0..8),
    ) {
        let qs: Vec<Quaternion> = raw.iter().map(|r| Quaternion::new(r.0, r.1, r.2, r.3)).collect();
        let ws: Vec<f64> = raw.iter().map(|r| r.4).collect();
        let _ = weighted_average(&qs, &ws, None);
    }
}

proptest! {
    #[test]
    fn half_angle_series_matches_the_trigonometric_form(theta in 0.0f64..0.06) {
        let (s, c) = attitude_service::attitude::quaternion::half_angle_terms(theta * theta);
        let exact_s = if theta == 0.0 { 0.5 } else { (theta / 2.0).sin() / theta };
        prop_assert!((s - exact_s).abs() <= 2.0 * f64::EPSILON * 0.5, "{s} vs {exact_s}");
        prop_assert!((c - (theta / 2.0).cos()).abs() <= 2.0 * f64::EPSILON);
    }
}
