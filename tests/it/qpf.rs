//! The quaternion particle filter: bandwidths, the averaged fiducial's fallback, determinism,
//! rollback, and convergence from a large error with honest covariance.

use crate::common::{assert_nees_with_power, CHI2_120};
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

/// A vehicle's history refills a dropped state in place (`state_into`, keeping the cloud's arrays):
/// written over an older state of the same filter, over a cloud of another size and over another
/// filter's state, it is exactly `state()`, and restores to the same filter.
#[test]
fn a_state_written_over_another_is_the_state() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let q_true = Quaternion::from_rotation_vector(&Vector3::new(0.005, 0.0, -0.004));
    let mut run = |spec: &str, particles: usize, steps: usize| {
        let mut f = build_filter(
            &config(spec, particles),
            &initial(Quaternion::IDENTITY, 0.01, false),
            7,
        )
        .unwrap();
        for k in 0..steps {
            let t = k as f64;
            f.process(&Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: Vector3::new(0.01, 0.0, 0.0),
            }))
            .unwrap();
            f.process(&Measurement::Vectors(ObservationSet {
                t_s: t + 0.5,
                observations: observations(&q_true, 1e-3, &mut rng),
            }))
            .unwrap();
        }
        f
    };
    let f = run("qpf:average", 300, 6);
    let want = f.state();
    for older in [
        run("qpf:average", 300, 2).state(),
        run("qpf:propagated", 500, 3).state(),
        run("qpf:average", 100, 1).state(),
        run("mekf", 0, 2).state(),
    ] {
        let mut s = older;
        f.state_into(&mut s);
        assert_eq!(s, want);
        assert_eq!(s.restore().unwrap().estimate(), f.estimate());
    }
    let m = run("mekf", 0, 3);
    let mut s = want.clone();
    m.state_into(&mut s);
    assert_eq!(s, m.state());
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

/// One run from a large error: the truth turns at 0.0011 rad/s about y from a fixed attitude; the
/// filter starts 120° off about an axis drawn from `seed` and is told σ = 90° per axis; two vectors of
/// σ = 1e-3 rad every second for 300 s (`observations`, noise from `seed`), filter RNG seed `seed`.
/// Asserts the covariance is SPD after every step; returns the final attitude NEES `δαᵀ P_att⁻¹ δα`,
/// the final error angle (rad) and the final estimate.
fn large_error_run(
    spec: &str,
    kernel: Kernel,
    seed: u64,
) -> (f64, f64, attitude_service::filters::Estimate) {
    let q_true0 = Quaternion::new(0.1, 0.2, -0.3, 0.9).normalized().unwrap();
    let omega = Vector3::new(0.0, -0.0011, 0.0);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let axis = attitude_service::sensors::gyro::normal3(&mut rng).normalize();
    let q0 = Quaternion::from_rotation_vector(&(axis * 120f64.to_radians())).compose(&q_true0);
    let mut cfg = config(spec, 1000);
    cfg.qpf.kernel = kernel;
    let mut f = build_filter(&cfg, &initial(q0, 90f64.to_radians(), false), seed).unwrap();
    let mut q_true = q_true0;
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
            observations: observations(&q_true, 1e-3, &mut rng),
        }))
        .unwrap();
        assert!(
            is_spd(&f.estimate().covariance),
            "{spec} seed {seed}: step {k}"
        );
    }
    let e = f.estimate();
    let err = q_true.small_angle_error(&e.q);
    let p = e.covariance.fixed_view::<3, 3>(0, 0).into_owned();
    let nees = err.dot(&p.cholesky().unwrap().solve(&err));
    (nees, q_true.compose(&e.q.inverse()).angle(), e)
}

/// Convergence from 120° told σ = 90°, and the consistency of the cloud's covariance once converged,
/// for both fiducials (each with one kernel).
///
/// Consistency is judged on independent runs, one sample per run: the attitude NEES at the end
/// (t = 300 s) of `RUNS` = 40 runs (seeds 1–40: initial-error axis, measurement noise and particles).
/// Samples of one run are not independent (with σ = 1e-3 rad and the standard gyro the error's
/// correlation time is far longer than the run, the error is an average of all the observations so
/// far), so a time average of one run is no better than one sample. For a consistent filter the
/// sum of the 40 NEES is χ²(120): the ANEES (the mean) lies in `χ²₁₂₀(0.0005, 0.9995)/40 =
/// [1.887, 4.440]` with probability 0.999. A cloud 1.5× too narrow in σ multiplies every NEES by
/// 2.25 and fails this bound with probability 0.9986 (one 1.5× too wide, with 0.998).
///
/// Measured (this seed set): ANEES 2.801 with `qpf:average` (Gaussian kernel) and 2.600 with
/// `qpf:propagated` (Epanechnikov). The same runs with the attitude covariance scaled by 1/2.25
/// (ANEES × 2.25: 6.30 and 5.85) or by 2.25 (1.245 and 1.156) fall outside the bound, which the test
/// checks. Convergence: every run's final error is below 0.1° (measured: 0.0097° at worst; a run
/// that lost lock is degrees off).
#[test]
fn converges_from_a_large_error_with_an_honest_covariance() {
    const RUNS: u64 = 40;
    // χ²₁₂₀ quantiles 0.0005 and 0.9995 (scipy.stats.chi2.ppf), divided by the number of runs.
    let (lo, hi) = (CHI2_120.0 / RUNS as f64, CHI2_120.1 / RUNS as f64);
    for (spec, kernel) in [
        ("qpf:average", Kernel::Gaussian),
        ("qpf:propagated", Kernel::Epanechnikov),
    ] {
        let mut nees_sum = 0.0;
        let mut worst: f64 = 0.0;
        for seed in 1..=RUNS {
            let (nees, err, e) = large_error_run(spec, kernel, seed);
            nees_sum += nees;
            worst = worst.max(err);
            assert!(
                err < 0.1f64.to_radians(),
                "{spec} seed {seed}: final error {}°",
                err.to_degrees()
            );
            assert!(e.diagnostics.resamples.unwrap() > 0);
            assert!(e.diagnostics.ess.unwrap() > 1.0);
        }
        let anees = nees_sum / RUNS as f64;
        eprintln!(
            "{spec}: ANEES {anees:.3} over {RUNS} runs (bound [{lo:.3}, {hi:.3}]), worst final error {:.4}°",
            worst.to_degrees()
        );
        assert_nees_with_power(&format!("{spec}: ANEES"), anees, (lo, hi));
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
