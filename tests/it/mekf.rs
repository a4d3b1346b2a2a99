//! MEKF Jacobians by finite differences, and the filter contract (time order, bad input, positive
//! definiteness after every step).

use attitude_service::attitude::Quaternion;
use attitude_service::filters::mekf::{measurement_jacobian, transition_matrix};
use attitude_service::filters::{
    build_filter, is_spd, FilterConfig, FilterError, FilterSpec, InitialState,
};
use attitude_service::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::{Matrix3x6, Matrix6, Vector3, Vector6};

/// Propagates a perturbed state and the nominal one with the same measured rate and returns the
/// propagated error `[δα; δβ]` (the nonlinear map that `Φ` linearises).
fn propagated_error(
    dx0: &Vector6<f64>,
    q_hat: &Quaternion,
    beta_hat: &Vector3<f64>,
    omega_meas: &Vector3<f64>,
    dt: f64,
) -> Vector6<f64> {
    let dalpha0 = Vector3::new(dx0[0], dx0[1], dx0[2]);
    let dbeta0 = Vector3::new(dx0[3], dx0[4], dx0[5]);
    let q = Quaternion::from_rotation_vector(&dalpha0).compose(q_hat);
    let beta = beta_hat + dbeta0;
    let q1 = q.propagate(&(omega_meas - beta), dt);
    let q_hat1 = q_hat.propagate(&(omega_meas - beta_hat), dt);
    let e = q1.compose(&q_hat1.inverse()).to_rotation_vector();
    Vector6::new(e[0], e[1], e[2], dbeta0[0], dbeta0[1], dbeta0[2])
}

#[test]
fn phi_matches_finite_differences() {
    let q_hat = Quaternion::new(0.1, -0.3, 0.2, 0.9).normalized().unwrap();
    let beta_hat = Vector3::new(1e-4, -2e-4, 5e-5);
    for (omega_meas, dt) in [
        (Vector3::new(0.01, -0.02, 0.03), 10.0),
        (Vector3::new(0.5, 0.1, -0.2), 0.1),
        (Vector3::new(1e-9, 0.0, 0.0), 1.0), // the series branch
        (Vector3::zeros(), 1.0),
    ] {
        let omega_hat = omega_meas - beta_hat;
        let phi = transition_matrix(&omega_hat, dt);
        let eps = 1e-6;
        let mut fd = Matrix6::zeros();
        for j in 0..6 {
            let mut d = Vector6::zeros();
            d[j] = eps;
            let col = (propagated_error(&d, &q_hat, &beta_hat, &omega_meas, dt)
                - propagated_error(&(-d), &q_hat, &beta_hat, &omega_meas, dt))
                / (2.0 * eps);
            fd.set_column(j, &col);
        }
        let err = (phi - fd).abs().max();
        assert!(
            err < 1e-7 * phi.abs().max(),
            "ω = {omega_meas:?}, Δt = {dt}: |Φ − FD| = {err:e}\nΦ = {phi}\nFD = {fd}"
        );
    }
}

#[test]
fn h_matches_finite_differences() {
    let q_hat = Quaternion::new(-0.2, 0.4, 0.1, 0.8).normalized().unwrap();
    for r in [
        Vector3::new(0.3, -0.5, 0.81).normalize(),
        Vector3::new(21000.0, -8000.0, 35000.0), // a field in nT: H scales with it
    ] {
        let b_hat = q_hat.attitude_matrix() * r;
        let h = measurement_jacobian(&b_hat);
        let eps = 1e-7;
        let mut fd = Matrix3x6::zeros();
        for j in 0..3 {
            let mut d = Vector3::zeros();
            d[j] = eps;
            let plus = Quaternion::from_rotation_vector(&d)
                .compose(&q_hat)
                .attitude_matrix()
                * r;
            let minus = Quaternion::from_rotation_vector(&(-d))
                .compose(&q_hat)
                .attitude_matrix()
                * r;
            fd.set_column(j, &((plus - minus) / (2.0 * eps)));
        }
        let err = (h - fd).abs().max();
        assert!(err < 1e-6 * h.abs().max(), "|H − FD| = {err:e}");
    }
}

fn star_obs(q_true: &Quaternion, refs: &[Vector3<f64>], sigma: f64) -> Vec<VectorObservation> {
    refs.iter()
        .map(|r| VectorObservation {
            body: q_true.attitude_matrix() * r,
            reference: *r,
            sigma,
            sensor: Some("st1".into()),
            aspect: Aspect::Full,
        })
        .collect()
}

fn mekf(q0: Quaternion) -> Box<dyn attitude_service::filters::AttitudeFilter> {
    let config = FilterConfig::new("mekf".parse().unwrap(), GyroNoise::standard());
    let init = InitialState {
        t_s: Some(0.0),
        q: q0,
        sigma_att_rad: Vector3::repeat(0.01),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(1e-6),
        uniform_attitude: false,
        covariance: None,
    };
    build_filter(&config, &init, 7).unwrap()
}

#[test]
fn out_of_order_and_invalid_input_leave_the_filter_unchanged() {
    let mut f = mekf(Quaternion::IDENTITY);
    let refs = [Vector3::x(), Vector3::y()];
    let q_true = Quaternion::from_rotation_vector(&Vector3::new(0.002, -0.001, 0.003));
    f.process(&Measurement::Gyro(GyroSample {
        t_s: 0.0,
        omega_body_rad_s: Vector3::zeros(),
    }))
    .unwrap();
    f.process(&Measurement::Vectors(ObservationSet {
        t_s: 1.0,
        observations: star_obs(&q_true, &refs, 1e-4),
    }))
    .unwrap();
    let before = f.estimate();
    let late = Measurement::Gyro(GyroSample {
        t_s: 0.5,
        omega_body_rad_s: Vector3::zeros(),
    });
    assert!(matches!(
        f.process(&late),
        Err(FilterError::OutOfOrder { .. })
    ));
    let mut bad = star_obs(&q_true, &refs, 1e-4);
    bad[1].body[2] = f64::NAN;
    assert!(matches!(
        f.process(&Measurement::Vectors(ObservationSet {
            t_s: 2.0,
            observations: bad
        })),
        Err(FilterError::InvalidMeasurement(_))
    ));
    let mut zero_sigma = star_obs(&q_true, &refs, 1e-4);
    zero_sigma[0].sigma = 0.0;
    assert!(f
        .process(&Measurement::Vectors(ObservationSet {
            t_s: 2.0,
            observations: zero_sigma
        }))
        .is_err());
    assert_eq!(
        f.estimate(),
        before,
        "a refused input changes nothing, not even the time"
    );
}

#[test]
fn converges_and_stays_positive_definite_after_every_step() {
    let q_true = Quaternion::new(0.3, -0.2, 0.5, 0.8).normalized().unwrap();
    let omega = Vector3::new(0.001, -0.002, 0.0015);
    let mut f =
        mekf(Quaternion::from_rotation_vector(&Vector3::new(0.02, -0.01, 0.015)).compose(&q_true));
    let refs = [Vector3::x(), Vector3::new(0.0, 0.6, 0.8)];
    let mut truth = q_true;
    for k in 0..200 {
        let t = k as f64;
        f.process(&Measurement::Gyro(GyroSample {
            t_s: t,
            omega_body_rad_s: omega,
        }))
        .unwrap();
        assert!(is_spd(&f.estimate().covariance));
        truth = truth.propagate(&omega, 1.0);
        f.process(&Measurement::Vectors(ObservationSet {
            t_s: t + 1.0,
            observations: star_obs(&truth, &refs, 1e-5),
        }))
        .unwrap();
        let e = f.estimate();
        assert!(is_spd(&e.covariance), "step {k}");
        assert!(
            (e.covariance - e.covariance.transpose()).abs().max() == 0.0,
            "symmetric"
        );
    }
    let e = f.estimate();
    let err = truth.small_angle_error(&e.q).norm();
    assert!(
        err < 1e-5,
        "noise-free observations pull the error to ~0: {err:e}"
    );
    assert_eq!(e.t_s, 200.0);
    assert_eq!(e.diagnostics.updates, 200);
}

#[test]
fn filter_spec_names() {
    for (s, shown) in [
        ("mekf", "mekf"),
        ("usque", "usque:average"),
        ("usque:propagated", "usque:propagated"),
        ("qpf:average", "qpf:average"),
        ("qpf:propagated", "qpf:propagated"),
    ] {
        let spec: FilterSpec = s.parse().unwrap();
        assert_eq!(spec.to_string(), shown);
    }
    for bad in ["ekf", "mekf:average", "qpf:mean", ""] {
        assert!(bad.parse::<FilterSpec>().is_err(), "{bad}");
    }
}

#[test]
fn times_within_a_nanosecond_are_the_same_instant() {
    let mut f = mekf(Quaternion::IDENTITY);
    let t = 0.1 + 0.2; // 0.30000000000000004
    f.process(&Measurement::Gyro(GyroSample {
        t_s: t,
        omega_body_rad_s: Vector3::zeros(),
    }))
    .unwrap();
    // A sender that computes the same instant as 3 × 0.1 must not be refused.
    let same = Measurement::Gyro(GyroSample {
        t_s: 0.3,
        omega_body_rad_s: Vector3::zeros(),
    });
    assert!(0.3 < t);
    f.process(&same).unwrap();
    let earlier = Measurement::Gyro(GyroSample {
        t_s: t - 1e-6,
        omega_body_rad_s: Vector3::zeros(),
    });
    assert!(matches!(
        f.process(&earlier),
        Err(FilterError::OutOfOrder { .. })
    ));
}
