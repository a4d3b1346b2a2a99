//! USQUE (docs/algorithms.md §3) with both fiducials: the propagation against the kinematics and the
//! MEKF's covariance recursion, consistency and convergence on a simulated problem, the error contract
//! and the wiring into `build_filter`.

use crate::common::{assert_nees_with_power, CHI2_120};
use attitude_service::attitude::Quaternion;
use attitude_service::filters::mekf::{process_noise, transition_matrix};
use attitude_service::filters::usque::{process_noise_bar, Usque, UsqueOptions};
use attitude_service::filters::{
    build_filter, is_spd, Fiducial, FilterConfig, FilterCore, FilterError, FilterKind, FilterSpec,
    InitialState,
};
use attitude_service::sensors::{
    Aspect, GyroNoise, GyroSample, GyroSimulator, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::{Matrix6, Vector3, Vector6};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

const DEG: f64 = std::f64::consts::PI / 180.0;
const DEG_PER_HOUR: f64 = DEG / 3600.0;
const FIDUCIALS: [Fiducial; 2] = [Fiducial::Propagated, Fiducial::Average];

fn spec(fiducial: Fiducial) -> FilterSpec {
    match fiducial {
        Fiducial::Propagated => "usque:propagated".parse().unwrap(),
        Fiducial::Average => "usque:average".parse().unwrap(),
    }
}

fn initial(q: Quaternion, sigma_att: f64, bias: Vector3<f64>, sigma_bias: f64) -> InitialState {
    InitialState {
        t_s: Some(0.0),
        q,
        sigma_att_rad: Vector3::repeat(sigma_att),
        bias_rad_s: bias,
        bias_sigma_rad_s: Vector3::repeat(sigma_bias),
        uniform_attitude: false,
        covariance: None,
    }
}

fn usque(fiducial: Fiducial, gyro: GyroNoise, init: &InitialState) -> Usque {
    let config = FilterConfig::new(spec(fiducial), gyro);
    Usque::new(&config, init, UsqueOptions::default()).unwrap()
}

/// Max |a − b| over a 3×3 block divided by max |b| over the same block.
fn block_rel_err(a: &Matrix6<f64>, b: &Matrix6<f64>, r: usize, c: usize) -> f64 {
    let da = a.fixed_view::<3, 3>(r, c) - b.fixed_view::<3, 3>(r, c);
    da.abs().max() / b.fixed_view::<3, 3>(r, c).abs().max()
}

#[test]
fn q_bar_matches_test_vector_d() {
    // TV-D (docs/algorithms.md §7): standard gyro, Δt = 10: USQUE Q̄ attitude 4.999916666667e-13,
    // bias 5.0e-19.
    let q = process_noise_bar(&GyroNoise::standard(), 10.0);
    assert!(
        (q[(0, 0)] - 4.999916666667e-13).abs() < 1e-24,
        "{:e}",
        q[(0, 0)]
    );
    assert!((q[(5, 5)] - 5.0e-19).abs() < 1e-30, "{:e}", q[(5, 5)]);
    assert_eq!(q[(0, 3)], 0.0);
}

/// Zero noise and a tiny P: the sigma points collapse onto the estimate and the propagated mean is the
/// kinematic propagation with the bias-corrected rate (the UT's mean differs from it by O(σ²) ≈ 1e-14).
#[test]
fn propagated_mean_matches_kinematics() {
    let q0 = Quaternion::new(
        0.216930457819,
        -0.108465228909,
        0.433860915637,
        0.867721831275,
    );
    let beta = Vector3::new(1e-4, -2e-4, 5e-5);
    let zero = GyroNoise {
        sigma_v: 0.0,
        sigma_u: 0.0,
    };
    for fid in FIDUCIALS {
        for (omega, dt) in [
            (Vector3::new(0.01, -0.02, 0.03), 10.0),
            (Vector3::new(0.5, 0.1, -0.2), 0.1),
            (Vector3::new(1e-9, 0.0, 0.0), 1.0),
            (Vector3::zeros(), 1.0),
        ] {
            let mut f = usque(fid, zero, &initial(q0, 1e-7, beta, 1e-9));
            f.propagate(&omega, dt).unwrap();
            let e = f.estimate();
            let expected = q0.propagate(&(omega - beta), dt).canonical();
            let dq = (e.q.to_vector4() - expected.to_vector4()).abs().max();
            assert!(
                dq < 1e-10,
                "{fid:?} ω = {omega:?} Δt = {dt}: |q − Ω q0| = {dq:e}"
            );
            assert!((e.bias_rad_s - beta).abs().max() < 1e-18);
            // Two propagations before an update: the second draws about the carried x̂⁻.
            f.propagate(&omega, dt).unwrap();
            let expected2 = expected.propagate(&(omega - beta), dt).canonical();
            let dq2 = (f.estimate().q.to_vector4() - expected2.to_vector4())
                .abs()
                .max();
            assert!(dq2 < 1e-10, "{fid:?} second step: {dq2:e}");
        }
    }
}

/// With a small P the unscented transform agrees with the linearisation `Φ P Φᵀ + Q` to first order.
/// Tolerance: 1e-3 relative per block, the size of the second-order terms for an attitude spread of
/// `√(n + λ) σ ≈ 0.03 rad`; it still catches any error in Φ, in the sign of the bias coupling or in the
/// noise terms (each ≥ 1e-2 of the block in these cases). Measured it is far smaller (≈ 1e-10 on the
/// attitude block, ≈ 1e-7 on the cross block): an attitude-only perturbation propagates *exactly
/// linearly* in the GRP chart (`Ω δq(δp) Ω⁻¹` only rotates `δp`, and the GRP is odd), so the only
/// curvature is the bias's, of relative size `(√7 σ_β Δt)² ≈ 1e-8`.
#[test]
fn propagated_covariance_matches_mekf_to_first_order() {
    let gyro = GyroNoise::standard();
    let q0 = Quaternion::new(0.1, -0.3, 0.2, 0.9).normalized().unwrap();
    let beta = Vector3::new(1e-4, -2e-4, 5e-5);
    for fid in FIDUCIALS {
        for (omega_meas, dt) in [
            (Vector3::new(0.01, -0.02, 0.03), 10.0),
            (Vector3::new(0.5, 0.1, -0.2), 0.1),
            (Vector3::new(0.02, 0.01, -0.01), 1.0),
            (Vector3::zeros(), 1.0),
        ] {
            let mut f = usque(fid, gyro, &initial(q0, 1e-3, beta, 1e-6));
            let omega_hat = omega_meas - beta;
            let phi = transition_matrix(&omega_hat, dt);
            let q = process_noise(&gyro, dt);
            // Two steps: the second starts from the full (correlated) P of the first.
            for step in 0..2 {
                let p0 = f.estimate().covariance;
                f.propagate(&omega_meas, dt).unwrap();
                let p1 = f.estimate().covariance;
                let lin = phi * p0 * phi.transpose() + q;
                let att = block_rel_err(&p1, &lin, 0, 0);
                let cross = block_rel_err(&p1, &lin, 0, 3);
                let bias = block_rel_err(&p1, &lin, 3, 3);
                eprintln!(
                    "{fid:?} ω̃ = {omega_meas:?} Δt = {dt} step {step}: rel err att {att:.2e} cross {cross:.2e} bias {bias:.2e}"
                );
                assert!(att < 1e-3, "attitude block {att:e}");
                assert!(cross < 1e-3, "cross block {cross:e}");
                assert!(bias < 1e-9, "bias block is linear: {bias:e}");
                assert!(is_spd(&p1));
            }
        }
    }
}

struct RunOutcome {
    /// Final attitude and bias errors and the filter's final covariance.
    error: Vector6<f64>,
    covariance: Matrix6<f64>,
    /// Number of updates after which the attitude error stayed below 0.1° to the end
    /// (`None` if it was still above at the end).
    updates_to_converge: Option<usize>,
    mean_nis_per_dof: f64,
    fallbacks: Option<u64>,
    min_concentration: Option<f64>,
}

/// Constant body rate, gyro at 10 Hz (standard noise), two unit-vector observations (σ = 1e-4 rad)
/// every second for `duration_s`, through `build_filter` (so through the Driver: ten propagations
/// before each update). Asserts that the covariance is SPD after every step.
fn simulate(
    spec: FilterSpec,
    init_error: Vector3<f64>,
    sigma_att: f64,
    seed: u64,
    duration_s: usize,
) -> RunOutcome {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
    let gyro_noise = GyroNoise::standard();
    let omega = Vector3::new(0.001, -0.0015, 0.002);
    let true_bias0 = Vector3::new(0.1, -0.1, 0.05) * DEG_PER_HOUR;
    let sigma_bias = 1.0 * DEG_PER_HOUR;
    let sigma_obs = 1e-4;
    let refs = [Vector3::x(), Vector3::new(0.0, 0.6, 0.8)];
    let mut q_true = Quaternion::new(0.3, -0.2, 0.5, 0.8).normalized().unwrap();
    let q0 = Quaternion::from_rotation_vector(&init_error).compose(&q_true);
    let config = FilterConfig::new(spec, gyro_noise);
    let mut f = build_filter(
        &config,
        &initial(q0, sigma_att, Vector3::zeros(), sigma_bias),
        seed,
    )
    .unwrap();
    assert_eq!(f.spec(), spec);
    let mut gyro = GyroSimulator::new(gyro_noise, true_bias0);
    let mut gyro_rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x9E37_79B9_7F4A_7C15);
    let per_second = 10;
    let dt = 1.0 / per_second as f64;
    let n_ticks = duration_s * per_second;
    let mut last_above = 0usize;
    let mut updates = 0usize;
    let mut nis_sum = 0.0;
    let mut nis_dof = 0usize;
    let mut min_conc: Option<f64> = None;
    for j in 0..=n_ticks {
        let t = j as f64 / per_second as f64;
        if j > 0 && j % per_second == 0 {
            let a = q_true.attitude_matrix();
            let observations = refs
                .iter()
                .map(|r| VectorObservation {
                    body: a * r + Vector3::new(normal(), normal(), normal()) * sigma_obs,
                    reference: *r,
                    sigma: sigma_obs,
                    sensor: None,
                    aspect: Aspect::Full,
                })
                .collect();
            f.process(&Measurement::Vectors(ObservationSet {
                t_s: t,
                observations,
            }))
            .unwrap_or_else(|e| panic!("{spec} update at t = {t}: {e}"));
            let e = f.estimate();
            assert!(
                is_spd(&e.covariance),
                "{spec}: covariance not SPD after the update at t = {t}"
            );
            updates += 1;
            if q_true.small_angle_error(&e.q).norm() >= 0.1 * DEG {
                last_above = updates;
            }
            if updates > duration_s / 2 {
                nis_sum += e.diagnostics.nis.unwrap();
                nis_dof += e.diagnostics.nis_dof.unwrap();
            }
        }
        if j < n_ticks {
            let omega_meas = gyro.sample(&omega, dt, &mut gyro_rng);
            f.process(&Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: omega_meas,
            }))
            .unwrap_or_else(|e| panic!("{spec} propagation to t = {t}: {e}"));
            let e = f.estimate();
            assert!(
                is_spd(&e.covariance),
                "{spec}: covariance not SPD after the propagation to t = {t}"
            );
            if let Some(c) = e.diagnostics.concentration {
                min_conc = Some(min_conc.map_or(c, |m: f64| m.min(c)));
            }
            q_true = q_true.propagate(&omega, dt);
        }
    }
    let e = f.estimate();
    assert_eq!(e.t_s, duration_s as f64);
    assert_eq!(e.diagnostics.updates as usize, duration_s);
    let att = q_true.small_angle_error(&e.q);
    let db = gyro.bias_rad_s - e.bias_rad_s;
    RunOutcome {
        error: Vector6::new(att[0], att[1], att[2], db[0], db[1], db[2]),
        covariance: e.covariance,
        updates_to_converge: (last_above < updates).then_some(last_above),
        mean_nis_per_dof: nis_sum / nis_dof as f64,
        fallbacks: e.diagnostics.fiducial_fallbacks,
        min_concentration: min_conc,
    }
}

/// Consistency of both fiducials on `simulate`'s problem (2000 s), judged on independent runs:
/// `RUNS` = 20 seeds, each with an initial error drawn from the initial covariance (σ = 0.5° per
/// axis), its own gyro and observation noise.
///
/// * State NEES, one sample per run: the 6-dof NEES `xᵀ P⁻¹ x` of the final attitude and bias
///   error (samples of one run are correlated over hundreds of updates, the bias error's over the
///   whole run). For a consistent filter the sum over the runs is χ²(120): the mean lies in
///   `χ²₁₂₀(0.0005, 0.9995)/20 = [3.773, 8.880]` (6 is ideal) with probability 0.999; a covariance
///   1.5× too small (or too large) in σ multiplies (divides) every NEES by 2.25 and fails with
///   probability 0.9986 (0.998).
/// * NIS: the innovations of a consistent filter are white, so the NIS of the second half of every
///   run (1000 updates × 6 dof) pooled over the runs is χ²(120000), mean per dof 1 with a 1σ of
///   0.0041 (0.0183 per run). Measured per run the spread is 0.022, a little wider than white
///   (the sigma-point update is not exactly linear), so the bound is [0.98, 1.02]: 3.6σ of the
///   measured spread of the pooled mean. It tests the measurement model (here `HPHᵀ` is 0.3% of
///   `R`, so the NIS barely sees `P`): a σ 1.5× off in the update gives 2.25 or 0.44, 10% off
///   already 1.21 or 0.83.
///
/// Measured (seeds 1–20; both fiducials give the same figures, see
/// `fiducials_differ_only_through_the_bias_rate_asymmetry`): mean NEES 6.243, NIS/dof 0.99950. The
/// same runs with the covariance scaled by 1/2.25 (mean NEES 14.05) or 2.25 (2.775) fall outside
/// the NEES bound, which the test checks. (A check of every component within 3σ would fail on seed
/// 4: 3.90″ against 3σ = 3.66″, a 3.2σ error, which one of 120 components of a consistent filter
/// shows with probability 0.15.)
#[test]
fn both_fiducials_are_consistent_on_a_simple_problem() {
    const RUNS: u64 = 20;
    // χ²₁₂₀ quantiles 0.0005 and 0.9995, divided by the number of runs.
    let (lo, hi) = (CHI2_120.0 / RUNS as f64, CHI2_120.1 / RUNS as f64);
    // 1 ± 3.6 × 0.022/√20 (the measured per-run spread; χ²₁₂₀₀₀₀ alone would give ±0.0134).
    let (nis_lo, nis_hi) = (0.98, 1.02);
    for fid in FIDUCIALS {
        let mut nees_sum = 0.0;
        let mut nis_sum = 0.0;
        for seed in 1..=RUNS {
            // The initial error is a draw from the initial covariance (σ = 0.5°).
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(1000 + seed);
            let sigma0 = 0.5 * DEG;
            let mut n = || -> f64 { StandardNormal.sample(&mut rng) };
            let e0 = Vector3::new(n(), n(), n()) * sigma0;
            let out = simulate(spec(fid), e0, sigma0, seed, 2000);
            let sig = out.covariance.diagonal().map(f64::sqrt);
            let nees = out
                .covariance
                .cholesky()
                .unwrap()
                .solve(&out.error)
                .dot(&out.error);
            eprintln!(
                "{fid:?} seed {seed}: final error (arcsec) {:.3?}, 3σ (arcsec) {:.3?}, bias error (deg/hr) {:.5?}, \
                 3σ {:.5?}; NEES {nees:.2}, mean NIS/dof (2nd half) {:.3}, fallbacks {:?}, min concentration {:?}",
                (out.error.fixed_rows::<3>(0) / (DEG / 3600.0)).as_slice(),
                (sig.fixed_rows::<3>(0) * 3.0 / (DEG / 3600.0)).as_slice(),
                (out.error.fixed_rows::<3>(3) / DEG_PER_HOUR).as_slice(),
                (sig.fixed_rows::<3>(3) * 3.0 / DEG_PER_HOUR).as_slice(),
                out.mean_nis_per_dof,
                out.fallbacks,
                out.min_concentration,
            );
            nees_sum += nees;
            nis_sum += out.mean_nis_per_dof;
            match fid {
                Fiducial::Average => assert_eq!(out.fallbacks, Some(0)),
                Fiducial::Propagated => assert_eq!(out.fallbacks, None),
            }
        }
        let (anees, nis) = (nees_sum / RUNS as f64, nis_sum / RUNS as f64);
        eprintln!("{fid:?}: mean NEES {anees:.3} in [{lo:.3}, {hi:.3}], NIS/dof {nis:.5} in [{nis_lo}, {nis_hi}]");
        assert_nees_with_power(&format!("{fid:?}: mean NEES"), anees, (lo, hi));
        assert!(
            (nis_lo..=nis_hi).contains(&nis),
            "{fid:?}: NIS/dof {nis} outside [{nis_lo}, {nis_hi}]"
        );
    }
}

/// From a 90° error with an initial σ of 90° (the MEKF is run on the same data for comparison, not
/// asserted). The first update already collapses the covariance to ~0.006° while the error is still
/// tens of degrees (the observations are precise, σ = 1e-4 rad, and a Kalman update cannot know that its
/// linear regression failed); from there the error shrinks only as fast as the process-noise-limited
/// gain allows, so reaching 0.1° takes of the order of a thousand updates and the NIS stays far above 1.
#[test]
fn both_fiducials_converge_from_a_90_degree_error() {
    for (axis, e0) in [
        ("x", Vector3::x()),
        ("z", Vector3::z()),
        ("[1,-1,1]", Vector3::new(1.0, -1.0, 1.0).normalize()),
    ] {
        for s in ["usque:propagated", "usque:average", "mekf"] {
            let spec: FilterSpec = s.parse().unwrap();
            let out = simulate(spec, e0 * 90.0 * DEG, 90.0 * DEG, 7, 2000);
            let final_deg = out.error.fixed_rows::<3>(0).norm() / DEG;
            eprintln!(
                "LARGE-ERROR {s}, 90° about {axis}: below 0.1° (and staying) after {:?} updates (1 update/s, \
                 10 propagations each); final error {:.2e}°, mean NIS/dof (2nd half) {:.1}, fallbacks {:?}, \
                 min concentration {:?}",
                out.updates_to_converge, final_deg, out.mean_nis_per_dof, out.fallbacks, out.min_concentration
            );
            if spec.kind == FilterKind::Usque {
                assert!(
                    out.updates_to_converge.is_some(),
                    "{s} about {axis}: final error {final_deg}°"
                );
                assert_eq!(
                    out.fallbacks,
                    (spec.fiducial == Some(Fiducial::Average)).then_some(0)
                );
            }
        }
    }
}

/// With USQUE's symmetric sigma points and the odd GRP chart, the propagated points stay symmetric about
/// `q⁻(0)` except for a term of third order, `≈ (√(n + λ) σ_β Δt)² ‖ω̂‖Δt / 12` (the BCH even part of
/// `δq((ω̂ − δβ)Δt) δq(ω̂Δt)⁻¹`), so the weighted average of `±` pairs is `q⁻(0)` up to that term and
/// the two fiducials give the same estimate to rounding unless the bias is very uncertain, the rate
/// high and the interval long. This pins both facts: the averaging path is live, and where it matters.
#[test]
fn fiducials_differ_only_through_the_bias_rate_asymmetry() {
    let q0 = Quaternion::new(0.3, -0.2, 0.5, 0.8).normalized().unwrap();
    let run = |sig_att: f64, sig_b: f64, w: f64, dt: f64| -> f64 {
        let init = initial(q0, sig_att, Vector3::zeros(), sig_b);
        let mut a = usque(Fiducial::Propagated, GyroNoise::standard(), &init);
        let mut b = usque(Fiducial::Average, GyroNoise::standard(), &init);
        let omega = Vector3::new(w, -w, 0.5 * w);
        let o = [
            obs(q0.attitude_matrix() * Vector3::x(), Vector3::x(), 1e-3),
            obs(q0.attitude_matrix() * Vector3::y(), Vector3::y(), 1e-3),
        ];
        let mut max_diff: f64 = 0.0;
        for k in 0..20 {
            a.propagate(&omega, dt).unwrap();
            b.propagate(&omega, dt).unwrap();
            max_diff = max_diff.max(a.estimate().q.small_angle_error(&b.estimate().q).norm());
            if k % 2 == 1 {
                a.update(&o).unwrap();
                b.update(&o).unwrap();
                max_diff = max_diff.max(a.estimate().q.small_angle_error(&b.estimate().q).norm());
            }
        }
        max_diff
    };
    for (sig_att, sig_b, w, dt, lo, hi) in [
        // Typical: the same estimate to rounding, even with a 90° attitude spread.
        (0.5 * DEG, DEG_PER_HOUR, 0.002, 0.1, 0.0, 1e-12),
        (90.0 * DEG, DEG_PER_HOUR, 0.002, 0.1, 0.0, 1e-12),
        // 20 deg/hr, 0.05 rad/s, 10 s: sub-arcsecond.
        (1.0 * DEG, 20.0 * DEG_PER_HOUR, 0.05, 10.0, 1e-8, 5e-6),
        // 200 deg/hr, 0.1 rad/s, 10 s: ~20 arcsec.
        (50.0 * DEG, 200.0 * DEG_PER_HOUR, 0.1, 10.0, 1e-5, 1e-3),
    ] {
        let d = run(sig_att, sig_b, w, dt);
        eprintln!(
            "σ_att {:.1}°, σ_β {:.0} deg/hr, ω {w} rad/s, Δt {dt} s: max |q̂_propagated − q̂_average| = {d:.2e} rad",
            sig_att / DEG,
            sig_b / DEG_PER_HOUR
        );
        assert!(
            d >= lo && d < hi,
            "difference {d:e} outside [{lo:e}, {hi:e})"
        );
    }
}

/// The attitude and bias blocks of `Q̄` applied twice match the MEKF's `Q` when the noise dominates
/// (tiny P). The cross block matches only as `θ = ‖ω̂‖Δt → 0`: the MEKF's `Q₁₂ = −σ_u²Δt²/2 I` neglects
/// the rotation during the interval while USQUE's `Φ₁₂ Q̄₂₂` keeps part of it (relative difference ≈ θ/2).
#[test]
fn process_noise_matches_mekf_q_to_first_order() {
    let gyro = GyroNoise::standard();
    let q0 = Quaternion::new(0.1, -0.3, 0.2, 0.9).normalized().unwrap();
    let beta = Vector3::new(1e-4, -2e-4, 5e-5);
    for (omega_meas, dt) in [
        (Vector3::new(0.01, -0.02, 0.03), 10.0),
        (Vector3::new(0.5, 0.1, -0.2), 0.1),
        (Vector3::new(0.02, 0.01, -0.01), 1.0),
        (Vector3::zeros(), 1.0),
    ] {
        for fid in FIDUCIALS {
            let mut f = usque(fid, gyro, &initial(q0, 1e-9, beta, 1e-13));
            let omega_hat = omega_meas - beta;
            let theta = omega_hat.norm() * dt;
            let phi = transition_matrix(&omega_hat, dt);
            let p0 = f.estimate().covariance;
            f.propagate(&omega_meas, dt).unwrap();
            let p1 = f.estimate().covariance;
            let lin = phi * p0 * phi.transpose() + process_noise(&gyro, dt);
            let (att, cross, bias) = (
                block_rel_err(&p1, &lin, 0, 0),
                block_rel_err(&p1, &lin, 0, 3),
                block_rel_err(&p1, &lin, 3, 3),
            );
            eprintln!("noise-dominated {fid:?} θ = {theta:.2e}: rel err att {att:.2e} cross {cross:.2e} bias {bias:.2e}");
            assert!(att < 1e-3 && bias < 1e-9, "att {att:e} bias {bias:e}");
            assert!(
                cross < 0.6 * theta + 1e-6,
                "cross {cross:e} vs θ = {theta:e}"
            );
        }
    }
}

fn obs(body: Vector3<f64>, reference: Vector3<f64>, sigma: f64) -> VectorObservation {
    VectorObservation {
        body,
        reference,
        sigma,
        sensor: None,
        aspect: Aspect::Full,
    }
}

#[test]
fn a_failed_update_leaves_the_state_unchanged() {
    let q0 = Quaternion::new(0.3, -0.2, 0.5, 0.8).normalized().unwrap();
    let good = [
        obs(q0.attitude_matrix() * Vector3::x(), Vector3::x(), 1e-4),
        obs(q0.attitude_matrix() * Vector3::y(), Vector3::y(), 1e-4),
    ];
    // Finite but singular: a zero reference vector with zero noise gives γ(i) = 0 for every sigma point,
    // so P^vv = 0.
    let singular = obs(Vector3::x(), Vector3::zeros(), 0.0);
    for fid in FIDUCIALS {
        for propagate_first in [true, false] {
            let mut f = usque(
                fid,
                GyroNoise::standard(),
                &initial(q0, 0.01, Vector3::zeros(), 1e-6),
            );
            if propagate_first {
                f.propagate(&Vector3::new(0.01, 0.0, -0.01), 1.0).unwrap();
            }
            let reference = f.clone();
            let before = f.estimate();
            let r = f.update(std::slice::from_ref(&singular));
            assert_eq!(
                r,
                Err(FilterError::SingularInnovation { index: 0 }),
                "{fid:?}"
            );
            let r = f.update(&[good[0].clone(), singular.clone()]);
            assert_eq!(
                r,
                Err(FilterError::SingularInnovation { index: 1 }),
                "{fid:?}"
            );
            assert_eq!(
                f.estimate(),
                before,
                "{fid:?}: a refused update changes nothing"
            );
            assert_eq!(
                f.has_propagated_sigma_points(),
                propagate_first,
                "the kept sigma points survive"
            );
            // And the next good update is the one the untouched filter would have done.
            let mut g = reference;
            f.update(&good).unwrap();
            g.update(&good).unwrap();
            assert_eq!(f.estimate(), g.estimate());
            assert!(!f.has_propagated_sigma_points());
            // A second update at the same time redraws the sigma points about the estimate.
            f.update(&good).unwrap();
            assert_eq!(f.estimate().diagnostics.updates, 2);
            assert!(is_spd(&f.estimate().covariance));
        }
    }
}

#[test]
fn invalid_configuration_is_refused() {
    let init = initial(Quaternion::IDENTITY, 0.01, Vector3::zeros(), 1e-6);
    let config = FilterConfig::new(spec(Fiducial::Average), GyroNoise::standard());
    for lambda in [0.0, -1.0, -6.5, f64::NAN, f64::INFINITY] {
        let options = UsqueOptions {
            lambda,
            ..UsqueOptions::default()
        };
        assert!(
            matches!(
                Usque::new(&config, &init, options),
                Err(FilterError::InvalidConfig(_))
            ),
            "λ = {lambda} must be refused"
        );
    }
    for bad in [0.0, -0.01, f64::NAN, f64::INFINITY] {
        let mut i = init.clone();
        i.sigma_att_rad[1] = bad;
        assert!(matches!(
            Usque::new(&config, &i, UsqueOptions::default()),
            Err(FilterError::InvalidConfig(_))
        ));
        let mut i = init.clone();
        i.bias_sigma_rad_s[2] = bad;
        assert!(matches!(
            Usque::new(&config, &i, UsqueOptions::default()),
            Err(FilterError::InvalidConfig(_))
        ));
    }
    let mut i = init.clone();
    i.q = Quaternion::new(0.0, 0.0, 0.0, 0.0);
    assert!(matches!(
        Usque::new(&config, &i, UsqueOptions::default()),
        Err(FilterError::InvalidConfig(_))
    ));
    assert!(Usque::new(
        &config,
        &init,
        UsqueOptions {
            lambda: 0.5,
            ..UsqueOptions::default()
        }
    )
    .is_ok());
    // A refused propagation leaves the filter unchanged.
    let mut f = Usque::new(&config, &init, UsqueOptions::default()).unwrap();
    let before = f.estimate();
    assert!(f.propagate(&Vector3::new(f64::NAN, 0.0, 0.0), 1.0).is_err());
    assert!(f.propagate(&Vector3::zeros(), 0.0).is_err());
    assert_eq!(f.estimate(), before);
}

#[test]
fn build_filter_reports_the_spec_and_diagnostics() {
    let q0 = Quaternion::new(0.3, -0.2, 0.5, 0.8).normalized().unwrap();
    let refs = [Vector3::x(), Vector3::new(0.0, 0.6, 0.8)];
    for (s, fid) in [
        ("usque:propagated", Fiducial::Propagated),
        ("usque:average", Fiducial::Average),
        ("usque", Fiducial::Average),
    ] {
        let spec: FilterSpec = s.parse().unwrap();
        let config = FilterConfig::new(spec, GyroNoise::standard());
        let mut f = build_filter(&config, &initial(q0, 0.01, Vector3::zeros(), 1e-6), 0).unwrap();
        assert_eq!(f.spec().fiducial, Some(fid));
        let set = |t_s: f64| {
            Measurement::Vectors(ObservationSet {
                t_s,
                observations: refs
                    .iter()
                    .map(|r| obs(q0.attitude_matrix() * r, *r, 1e-4))
                    .collect(),
            })
        };
        // An update at the start time (no propagation), a gyro sample, two sets at t = 1 (the second
        // without a propagation before it).
        f.process(&set(0.0)).unwrap();
        f.process(&Measurement::Gyro(GyroSample {
            t_s: 0.0,
            omega_body_rad_s: Vector3::zeros(),
        }))
        .unwrap();
        f.process(&set(1.0)).unwrap();
        f.process(&set(1.0)).unwrap();
        let e = f.estimate();
        assert_eq!(e.t_s, 1.0);
        assert_eq!(e.diagnostics.propagations, 1);
        assert_eq!(e.diagnostics.updates, 3);
        assert_eq!(e.diagnostics.nis_dof, Some(6));
        assert!(e.diagnostics.nis.unwrap().is_finite());
        let err = q0.small_angle_error(&e.q).norm();
        eprintln!(
            "{s}: error after noise-free updates {err:e} rad, posterior σ {:.3e} rad, NIS {:?}",
            e.sigma_att_rad().min(),
            e.diagnostics.nis
        );
        // Not exactly zero: the sigma-point mean ŷ of rotated unit vectors is shorter than the unit
        // vector (a second-order effect of the ±√7·0.01 rad spread at the first update), and that
        // innovation along b leaks into the correction through P^vv. It is a few percent of the
        // posterior σ.
        let sigma_min = e.sigma_att_rad().min();
        assert!(
            err < 0.1 * sigma_min,
            "error {err:e} vs posterior σ {sigma_min:e}"
        );
        match fid {
            Fiducial::Average => {
                assert_eq!(e.diagnostics.fiducial_fallbacks, Some(0));
                let c = e.diagnostics.concentration.unwrap();
                assert!(c > 0.99 && c <= 1.0 + 1e-12, "concentration {c}");
                assert!(e.diagnostics.eigen_gap.unwrap() > 0.99);
            }
            Fiducial::Propagated => {
                assert_eq!(e.diagnostics.fiducial_fallbacks, None);
                assert_eq!(e.diagnostics.concentration, None);
            }
        }
    }
}
