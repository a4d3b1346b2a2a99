//! The quaternion particle filter: bandwidths, the averaged fiducial's fallback, determinism,
//! rollback, and convergence from a large error with honest covariance.

use attitude_service::attitude::Quaternion;
use attitude_service::filters::{
    build_filter, is_spd, Driver, FilterConfig, FilterCore, FilterError, InitialState, Kernel, Qpf,
    QpfOptions,
};
use attitude_service::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

fn config(spec: &str, particles: usize) -> FilterConfig {
    let mut c = FilterConfig::new(spec.parse().unwrap(), GyroNoise::standard());
    c.particles = particles;
    c
}

fn initial(q: Quaternion, sigma_att_rad: f64, uniform: bool) -> InitialState {
    InitialState {
        t_s: Some(0.0),
        q,
        sigma_att_rad: Vector3::repeat(sigma_att_rad),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(1e-7),
        uniform_attitude: uniform,
        covariance: None,
    }
}

fn observations(
    q_true: &Quaternion,
    sigma: f64,
    rng: &mut Xoshiro256PlusPlus,
) -> Vec<VectorObservation> {
    let refs = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, 0.6, 0.8)];
    refs.iter()
        .map(|r| VectorObservation {
            body: q_true.attitude_matrix() * r
                + attitude_service::sensors::gyro::normal3(rng) * sigma,
            reference: *r,
            sigma,
            sensor: None,
            aspect: Aspect::Full,
        })
        .collect()
}

#[test]
fn optimal_bandwidths_match_the_reference_values() {
    assert!((Kernel::Gaussian.optimal_bandwidth(1000) - 0.4676).abs() < 1e-4);
    assert!((Kernel::Epanechnikov.optimal_bandwidth(1000) - 1.4085).abs() < 1e-4);
    // h = A N^{−1/10}
    let ratio = Kernel::Gaussian.optimal_bandwidth(10) / Kernel::Gaussian.optimal_bandwidth(1);
    assert!((ratio - 10f64.powf(-0.1)).abs() < 1e-12);
}

#[test]
fn undecidable_average_falls_back_to_the_propagated_fiducial_and_counts_it() {
    // Two particles 180° apart about x with equal weights: M has a double top eigenvalue. An observation
    // along x cannot tell them apart, so the weights stay equal and the average stays undecidable: the
    // filter must use the propagated fiducial and count it, not produce garbage.
    let flip = Quaternion::new(1.0, 0.0, 0.0, 0.0);
    let particles = [
        (Quaternion::IDENTITY, Vector3::zeros(), 1.0),
        (flip, Vector3::zeros(), 1.0),
    ];
    let mut qpf = Qpf::from_particles(
        &config("qpf:average", 2),
        QpfOptions::default(),
        &particles,
        3,
    )
    .unwrap();
    let obs = [VectorObservation {
        body: Vector3::x(),
        reference: Vector3::x(),
        sigma: 0.01,
        sensor: None,
        aspect: Aspect::Full,
    }];
    FilterCore::update(&mut qpf, &obs).unwrap();
    let e = FilterCore::estimate(&qpf);
    assert!(e.q.is_finite());
    assert!(
        e.diagnostics.fiducial_fallbacks.unwrap() >= 1,
        "{:?}",
        e.diagnostics
    );
    assert!(e.covariance.iter().all(|x| x.is_finite()));
    // A diffuse uniform cloud of many particles is not undecidable: λ₁/Σw is small but the gap is real,
    // so the average is used (no fallback), progressive correction takes several stages, and the cloud
    // ends concentrated.
    let mut diffuse = Qpf::new(
        &config("qpf:average", 4000),
        &initial(Quaternion::IDENTITY, 0.0, true),
        QpfOptions::default(),
        5,
    )
    .unwrap();
    let prior = FilterCore::estimate(&diffuse).diagnostics;
    assert_eq!(prior.fiducial_fallbacks, Some(0));
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let q_true = Quaternion::new(0.3, -0.5, 0.2, 0.78).normalized().unwrap();
    FilterCore::update(&mut diffuse, &observations(&q_true, 0.01, &mut rng)).unwrap();
    let d = FilterCore::estimate(&diffuse);
    assert!(
        d.diagnostics.pc_stages.unwrap() > 1,
        "a lost-in-space update needs progressive correction"
    );
    assert!(
        d.diagnostics.concentration.unwrap() > 0.9,
        "after the update the cloud is concentrated"
    );
    assert_eq!(d.diagnostics.fiducial_fallbacks, Some(0));
    assert!(
        q_true.compose(&d.q.inverse()).angle() < 5f64.to_radians(),
        "one update finds the attitude"
    );
}

#[test]
fn same_seed_same_filter_different_seed_different_cloud() {
    let run = |seed: u64| {
        let mut f = build_filter(
            &config("qpf:average", 300),
            &initial(Quaternion::IDENTITY, 0.01, false),
            seed,
        )
        .unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
        let q_true = Quaternion::from_rotation_vector(&Vector3::new(0.005, 0.0, -0.004));
        for k in 0..20 {
            let t = k as f64;
            f.process(&Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: Vector3::zeros(),
            }))
            .unwrap();
            f.process(&Measurement::Vectors(ObservationSet {
                t_s: t + 1.0,
                observations: observations(&q_true, 1e-3, &mut rng),
            }))
            .unwrap();
        }
        f.estimate()
    };
    assert_eq!(run(11), run(11));
    assert_ne!(run(11).q, run(12).q);
}

#[test]
fn a_refused_update_rolls_back() {
    let mut f = Driver::new(
        Qpf::new(
            &config("qpf:propagated", 200),
            &initial(Quaternion::IDENTITY, 0.01, false),
            QpfOptions::default(),
            1,
        )
        .unwrap(),
        Some(0.0),
    );
    let before = attitude_service::filters::AttitudeFilter::estimate(&f);
    let bad = Measurement::Vectors(ObservationSet {
        t_s: 0.0,
        observations: vec![VectorObservation {
            body: Vector3::new(f64::INFINITY, 0.0, 0.0),
            reference: Vector3::x(),
            sigma: 1e-3,
            sensor: None,
            aspect: Aspect::Full,
        }],
    });
    assert!(matches!(
        attitude_service::filters::AttitudeFilter::process(&mut f, &bad),
        Err(FilterError::InvalidMeasurement(_))
    ));
    assert_eq!(
        attitude_service::filters::AttitudeFilter::estimate(&f),
        before
    );
    // Bad options are refused up front.
    let mut o = QpfOptions::default();
    o.bandwidth_scale = 0.0;
    assert!(Qpf::new(
        &config("qpf", 100),
        &initial(Quaternion::IDENTITY, 0.01, false),
        o,
        1
    )
    .is_err());
    assert!(Qpf::new(
        &config("qpf", 1),
        &initial(Quaternion::IDENTITY, 0.01, false),
        QpfOptions::default(),
        1
    )
    .is_err());
}

#[test]
fn converges_from_a_large_error_with_an_honest_covariance() {
    for (spec, kernel) in [
        ("qpf:average", Kernel::Gaussian),
        ("qpf:propagated", Kernel::Epanechnikov),
    ] {
        let q_true0 = Quaternion::new(0.1, 0.2, -0.3, 0.9).normalized().unwrap();
        let omega = Vector3::new(0.0, -0.0011, 0.0);
        // 120° initial error about an oblique axis, told σ = 90°.
        let q0 = Quaternion::from_rotation_vector(
            &(Vector3::new(1.0, -1.0, 1.0).normalize() * 120f64.to_radians()),
        )
        .compose(&q_true0);
        let mut cfg = config(spec, 1000);
        cfg.qpf.kernel = kernel;
        let mut f = build_filter(&cfg, &initial(q0, 90f64.to_radians(), false), 21).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
        let mut q_true = q_true0;
        let sigma = 1e-3;
        let mut nees = Vec::new();
        for k in 0..300 {
            let t = k as f64;
            f.process(&Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: omega,
            }))
            .unwrap();
            q_true = q_true.propagate(&omega, 1.0);
            f.process(&Measurement::Vectors(ObservationSet {
                t_s: t + 1.0,
                observations: observations(&q_true, sigma, &mut rng),
            }))
            .unwrap();
            let e = f.estimate();
            assert!(is_spd(&e.covariance), "{spec}: step {k}");
            if k >= 100 {
                let err = q_true.small_angle_error(&e.q);
                let p = e.covariance.fixed_view::<3, 3>(0, 0).into_owned();
                nees.push(err.dot(&p.cholesky().unwrap().solve(&err)));
            }
        }
        let e = f.estimate();
        let err = q_true.compose(&e.q.inverse()).angle();
        assert!(
            err < 0.1f64.to_radians(),
            "{spec}: final error {}°",
            err.to_degrees()
        );
        let anees = nees.iter().sum::<f64>() / nees.len() as f64;
        // One run: a loose but meaningful consistency check (an overconfident cloud gives tens).
        assert!(
            anees > 0.5 && anees < 8.0,
            "{spec}: time-averaged NEES {anees}"
        );
        assert!(e.diagnostics.resamples.unwrap() > 0);
        assert!(e.diagnostics.ess.unwrap() > 1.0);
    }
}

#[test]
fn the_estimate_between_updates_follows_the_cloud_and_changes_nothing() {
    for spec in ["qpf:average", "qpf:propagated"] {
        let mut f = build_filter(
            &config(spec, 500),
            &initial(Quaternion::IDENTITY, 0.01, false),
            2,
        )
        .unwrap();
        let omega = Vector3::new(0.0, 0.0, 0.05);
        // No gyro sample yet: the driver propagates with the bias estimate alone.
        f.process(&Measurement::Gyro(GyroSample {
            t_s: 1.0,
            omega_body_rad_s: omega,
        }))
        .unwrap();
        f.process(&Measurement::Gyro(GyroSample {
            t_s: 11.0,
            omega_body_rad_s: omega,
        }))
        .unwrap();
        let a = f.estimate();
        assert_eq!(
            a,
            f.estimate(),
            "{spec}: asking twice gives the same answer"
        );
        // 10 s at 0.05 rad/s about z: the cloud's estimate turned 0.5 rad with it.
        let expected = Quaternion::from_rotation_vector(&Vector3::new(0.0, 0.0, 0.5));
        assert!(
            expected.compose(&a.q.inverse()).angle() < 0.03,
            "{spec}: {:?}",
            a.q
        );
        assert!(is_spd(&a.covariance));
        assert_eq!(a.t_s, 11.0);
    }
}
