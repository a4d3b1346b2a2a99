//! The raw-IMU pipeline (`crate::ahrs`), each model on a synthetic IMU whose truth is known, through the
//! very `VehicleState` the service runs (`P/V/imu` samples), with the MEKF and the particle filter:
//! rest and the gyro bias, the accelerometer's motion error and its honesty, the magnetometer's
//! disturbance, rejection budget, new field, hard iron and delay, the bounded bias, the variance floors,
//! the re-acquisition, the published time-stamp uncertainty and the same output for the same input.

use crate::common::{assert_nees_with_power, imu_preset, CHI2_120};
use attitude_service::ahrs::{Ahrs, AhrsConfig};
use attitude_service::attitude::Quaternion;
use attitude_service::filters::mekf::{bias_update, heading_update, tilt_update};
use attitude_service::filters::{build_filter, FilterConfig, GyroErrors, InitialState};
use attitude_service::sensors::heading::{heading_basis, heading_jacobian};
use attitude_service::sensors::{GyroNoise, ImuSample, Measurement};
use attitude_service::service::config::{Policy, VehicleFilterConfig};
use attitude_service::vehicle::{Event, ResetRequest, VehicleState};
use attitude_service::wire::EstimateMsg;
use nalgebra::{Matrix3, Matrix6, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

const DEG: f64 = std::f64::consts::PI / 180.0;
const G: f64 = 9.81;
const RATE_HZ: f64 = 200.0;

fn field_enu() -> Vector3<f64> {
    let dip = 66.0 * DEG;
    Vector3::new(0.0, dip.cos(), -dip.sin()) * 45.0
}

/// A synthetic IMU: a body whose body-frame rate and reference-frame linear acceleration are functions
/// of time, a gyro with a constant bias and white noise, an accelerometer and a magnetometer with
/// white noise; the magnetometer optionally with a body-fixed offset, a delay, or a place-dependent
/// disturbance. Gyro sample k is the mean rate over (t_{k−1}, t_k].
struct Imu {
    rng: Xoshiro256PlusPlus,
    q: Quaternion,
    bias: Vector3<f64>,
    gyro_noise: f64,
    acc_noise: f64,
    mag_noise: f64,
    mag_offset: Vector3<f64>,
    /// The magnetometer samples this many steps late.
    mag_delay_steps: usize,
    history: Vec<Quaternion>,
}

#[derive(Clone)]
struct Step {
    sample: ImuSample,
    truth: Quaternion,
}

impl Imu {
    fn new(seed: u64, q0: Quaternion, bias: Vector3<f64>) -> Self {
        Imu {
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            q: q0,
            bias,
            // Per sample at 200 Hz: an angle random walk of 5e-4 rad/√s, as the preset assumes.
            gyro_noise: 0.007,
            acc_noise: 0.02,
            mag_noise: 0.3,
            mag_offset: Vector3::zeros(),
            mag_delay_steps: 0,
            history: Vec::new(),
        }
    }

    fn noise(&mut self, sigma: f64) -> Vector3<f64> {
        Vector3::from_fn(|_, _| StandardNormal.sample(&mut self.rng)) * sigma
    }

    /// `n` samples from `t0` with body rate `omega(t)` and reference-frame linear acceleration
    /// `accel(t)`; `field(t)` scales/rotates the reference field (a disturbance of the place).
    fn run(
        &mut self,
        t0: f64,
        n: usize,
        omega: impl Fn(f64) -> Vector3<f64>,
        accel: impl Fn(f64) -> Vector3<f64>,
        field: impl Fn(f64) -> Vector3<f64>,
    ) -> Vec<Step> {
        let dt = 1.0 / RATE_HZ;
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            let t = t0 + k as f64 * dt;
            let w = omega(t);
            if k > 0 || t0 > 0.0 {
                self.q = self.q.propagate(&w, dt);
            }
            self.history.push(self.q);
            let a = self.q.attitude_matrix();
            let lagged = self.history[self.history.len().saturating_sub(1 + self.mag_delay_steps)]
                .attitude_matrix();
            let gyr = w + self.bias + self.noise(self.gyro_noise);
            let acc = a * (Vector3::new(0.0, 0.0, G) + accel(t)) + self.noise(self.acc_noise);
            let mag = lagged * field(t) + self.mag_offset + self.noise(self.mag_noise);
            out.push(Step {
                sample: ImuSample {
                    t_s: t,
                    gyr_rad_s: gyr,
                    acc_m_s2: acc,
                    mag: Some(mag),
                },
                truth: self.q,
            });
        }
        out
    }
}

fn still(_: f64) -> Vector3<f64> {
    Vector3::zeros()
}

/// A turning motion through many attitudes (about 1 rad/s).
fn turning(t: f64) -> Vector3<f64> {
    Vector3::new(
        0.8 * (0.7 * t).sin(),
        0.6 * (0.5 * t).cos(),
        0.9 * (0.3 * t).sin(),
    )
}

fn with_filter(mut f: VehicleFilterConfig, spec: &str, particles: usize) -> VehicleFilterConfig {
    f.filter.spec = spec.parse().unwrap();
    f.filter.particles = particles;
    f
}

/// Feeds the steps into `v`; returns the estimates published, by sample.
fn feed(v: &mut VehicleState, p: &Policy, steps: &[Step]) -> Vec<EstimateMsg> {
    let mut events = Vec::new();
    let mut out = Vec::new();
    for s in steps {
        v.on_measurement(Measurement::Imu(s.sample), 0.0, p, &mut events)
            .unwrap();
        for e in events.drain(..) {
            if let Event::Estimate(p) = e {
                out.push(EstimateMsg::from(&p));
            }
        }
    }
    v.flush_all(p, &mut events);
    out.extend(events.into_iter().filter_map(|e| match e {
        Event::Estimate(p) => Some(EstimateMsg::from(&p)),
        _ => None,
    }));
    out
}

fn q_of(m: &EstimateMsg) -> Quaternion {
    Quaternion::new(m.q.x, m.q.y, m.q.z, m.q.w)
}

fn error_deg(truth: &Quaternion, m: &EstimateMsg) -> f64 {
    truth.compose(&q_of(m).inverse()).angle() / DEG
}

/// The reference-frame error of `m` against `truth` (rotation vector, rad) and its covariance.
fn reference_error(truth: &Quaternion, m: &EstimateMsg) -> (Vector3<f64>, Matrix3<f64>) {
    let q = q_of(m);
    // Hamilton e = q_est q_true⁻¹ = Shuster q_true⁻¹ ⊗ q_est.
    let e = truth.inverse().compose(&q).canonical();
    let r = q.attitude_matrix().transpose();
    let p = Matrix3::from_fn(|i, j| m.cov[i][j]);
    (e.to_rotation_vector(), r * p * r.transpose())
}

fn imu_diag(m: &EstimateMsg) -> &attitude_service::wire::ImuDiagnosticsMsg {
    m.diagnostics
        .imu
        .as_ref()
        .expect("an IMU vehicle's estimate has imu diagnostics")
}

// ------------------------------------------------------------------------------------------------
// Rest and the gyro bias

/// The bias estimate after `n` samples (200 Hz) still, from IMU seed `seed`: the last estimate, the
/// bias error (rad/s) and its 3-dof NEES against the published bias covariance.
fn rest_run(
    f: &VehicleFilterConfig,
    p: &Policy,
    spec: &str,
    particles: usize,
    bias: Vector3<f64>,
    seed: u64,
) -> (EstimateMsg, Vector3<f64>, f64) {
    let mut imu = Imu::new(seed, Quaternion::from_euler_321(0.2, -0.1, 1.0), bias);
    let steps = imu.run(0.0, 4000, still, still, |_| field_enu());
    let mut v = VehicleState::new("rest", with_filter(f.clone(), spec, particles));
    let est = feed(&mut v, p, &steps);
    let last = est.last().unwrap().clone();
    let err = Vector3::from(last.bias) - bias;
    let pb = Matrix3::from_fn(|i, j| last.cov[i + 3][j + 3]);
    let nees = err.dot(&pb.cholesky().unwrap().solve(&err));
    (last, err, nees)
}

/// At rest the low-passed gyro is the bias: after 20 s still, a bias of (0.5, −0.3, 0.2)°/s is known,
/// with both filters, and the vehicle says it is at rest.
///
/// * One run (IMU seed 1), both filters: the published bias 1σ is below 0.01°/s per axis (measured
///   0.0080°/s, MEKF; 0.0058–0.0078°/s, QPF) and the bias error's NEES below χ²₃(0.9995) = 17.73, a
///   gross check at 0.999 over the two (measured 1.06 and 1.00; before 2026-11-30's retuning of the
///   preset 1.33 and 7.15; one sample cannot tell a covariance 1.5× off).
/// * The MEKF's bias covariance is consistent, judged on `RUNS` = 40 independent runs (IMU seeds 1,
///   101, …, 3901), one sample per run: the mean NEES lies in `χ²₁₂₀(0.0005, 0.9995)/40 =
///   [1.887, 4.440]` with probability 0.999; measured 2.235; with the covariance scaled by 1/2.25 or
///   2.25 (σ 1.5× too small or too large) it falls outside, which the test checks.
/// * The particle filter (300 particles, the preset's zero inflation) is not: over the same 40 runs
///   its bias NEES averages 7.16 (the MEKF's 2.235), a bias cloud about 1.5–1.8× too narrow in σ at
///   rest (the largest, 29.9, is above the gross bound). That is a finding about the filter, not
///   asserted here beyond seed 1's gross check: asserting it would fail.
#[test]
fn rest_measures_the_gyro_bias() {
    let (f, p) = imu_preset();
    let bias = Vector3::new(0.5, -0.3, 0.2) * DEG;
    for (spec, n) in [("mekf", 2), ("qpf:average", 300)] {
        let (last, err, nees) = rest_run(&f, &p, spec, n, bias, 1);
        let sigma = Vector3::from_fn(|i, _| last.cov[i + 3][i + 3].sqrt());
        eprintln!(
            "{spec}: bias error {:.5?}°/s, 1σ {:.5?}°/s, NEES {nees:.2}",
            (err / DEG).as_slice(),
            (sigma / DEG).as_slice()
        );
        assert!(
            sigma.amax() < 0.01 * DEG,
            "{spec}: bias 1σ {}°/s",
            sigma / DEG
        );
        assert!(
            nees <= 17.73,
            "{spec}: bias error {}°/s, NEES {nees}",
            err / DEG
        );
        let d = imu_diag(&last);
        assert!(d.at_rest && d.bias_updates >= 15, "{spec}: {d:?}");
    }
    const RUNS: u64 = 40;
    let (lo, hi) = (CHI2_120.0 / RUNS as f64, CHI2_120.1 / RUNS as f64);
    let anees = (0..RUNS)
        .map(|k| rest_run(&f, &p, "mekf", 2, bias, 1 + 100 * k).2)
        .sum::<f64>()
        / RUNS as f64;
    eprintln!("mekf: bias ANEES {anees:.3} over {RUNS} runs (bound [{lo:.3}, {hi:.3}])");
    assert_nees_with_power("mekf: bias ANEES", anees, (lo, hi));
}

/// The rest detector does not call a turning body at rest: no bias updates while turning.
#[test]
fn a_turning_body_is_not_at_rest() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(2, Quaternion::IDENTITY, Vector3::zeros());
    let steps = imu.run(0.0, 3000, turning, still, |_| field_enu());
    let mut v = VehicleState::new("turn", f);
    let est = feed(&mut v, &p, &steps);
    let d = imu_diag(est.last().unwrap());
    assert_eq!((d.rest_samples, d.bias_updates), (0, 0), "{d:?}");
}

// ------------------------------------------------------------------------------------------------
// The Kalman updates' gains: tilt never turns the heading nor drives the vertical bias; heading never
// tilts nor drives the horizontal bias.

fn correlated_p() -> Matrix6<f64> {
    let mut p = Matrix6::identity() * 1e-4;
    for i in 0..6 {
        for j in 0..6 {
            if i != j {
                p[(i, j)] = 3e-5 * ((i + 2 * j) as f64).sin();
            }
        }
    }
    (p + p.transpose()) * 0.5 + Matrix6::identity() * 1e-4
}

#[test]
fn tilt_and_heading_gains_are_decoupled() {
    let p = correlated_p();
    assert!(p.cholesky().is_some());
    let a = Quaternion::from_euler_321(0.3, -0.4, 1.2).attitude_matrix();
    let up = Vector3::new(0.0, 0.0, 1.0);
    let v = a * up;
    // Tilt: the innovation of a slightly tilted gravity direction.
    let predicted = a * up;
    let nu = Vector3::new(0.01, -0.02, 0.0);
    let u = tilt_update(&p, &predicted, &v, 0.02, &nu).unwrap();
    let (da, db) = (
        u.correction.fixed_rows::<3>(0),
        u.correction.fixed_rows::<3>(3),
    );
    assert!(
        v.dot(&da).abs() < 1e-15,
        "tilt turned the heading: {}",
        v.dot(&da)
    );
    assert!(v.dot(&db).abs() < 1e-15, "tilt drove the vertical bias");
    assert!(da.norm() > 1e-4, "and it does tilt");
    assert!(u.covariance.cholesky().is_some());
    // Heading.
    let r = field_enu().normalize();
    let (_, e2, h) = heading_basis(&r, &up).unwrap();
    let jac = heading_jacobian(&a, &r, &e2, h);
    let u = heading_update(&p, &jac, &v, 0.02, 0.03).unwrap();
    let (da, db) = (
        u.correction.fixed_rows::<3>(0),
        u.correction.fixed_rows::<3>(3),
    );
    assert!((da - v * v.dot(&da)).norm() < 1e-15, "heading tilted");
    assert!(
        (db - v * v.dot(&db)).norm() < 1e-15,
        "heading drove the horizontal bias"
    );
    assert!(da.norm() > 1e-4);
}

/// A bias observation `z = β + n` is a linear Kalman update: with `P_ββ = s² I` and `R = σ² I` the bias
/// moves by `s²/(s² + σ²)` of the innovation and its variance becomes `s² σ²/(s² + σ²)`.
#[test]
fn bias_update_is_the_linear_kalman_update() {
    let mut p = Matrix6::identity() * 1e-4;
    for i in 3..6 {
        p[(i, i)] = 4e-6;
    }
    let nu = Vector3::new(1e-3, -2e-3, 5e-4);
    let u = bias_update(&p, 1e-3, &nu).unwrap();
    let k = 4e-6 / (4e-6 + 1e-6);
    for i in 0..3 {
        assert!((u.correction[3 + i] - k * nu[i]).abs() < 1e-15);
        assert!((u.covariance[(3 + i, 3 + i)] - 4e-6 * 1e-6 / 5e-6).abs() < 1e-18);
        assert!(
            u.correction[i].abs() < 1e-15,
            "no attitude–bias correlation here"
        );
    }
}

// ------------------------------------------------------------------------------------------------
// The bounded bias (Gauss–Markov)

/// Unobserved for a long time, a random-walk bias's variance grows without end; a bounded one's
/// settles at the stationary `σ_b²`, with the MEKF and the particle filter alike.
///
/// After 200 s (≈ 12 τ) the MEKF's recursion gives σ_β = 0.997 σ_b and a mean of 7e-6 σ_b. The 2000
/// particles' biases are then independent draws from the stationary law: their sample σ is within
/// ±3.29/√(2N) = ±5.2% of σ_b at 0.999 and their mean within 3.59 σ_b/√N = 0.080 σ_b on every axis
/// (0.999 over the three). Measured (seed 3): σ_β = 0.975 σ_b, mean (0.048, −0.015, 0.009) σ_b. A σ
/// 1.5× too small or too large fails the first bound.
#[test]
fn an_unobserved_bias_stays_bounded() {
    let gyro = GyroNoise {
        sigma_v: 1e-3,
        sigma_u: 3e-3,
    };
    let limit = 0.5 * DEG;
    for spec in ["mekf", "qpf:average"] {
        let mut c = FilterConfig::new(spec.parse().unwrap(), gyro);
        c.particles = 2000;
        c.gyro_errors = GyroErrors {
            rate_noise_sqrt_s: 0.0,
            bias_limit_rad_s: limit,
        };
        let initial = InitialState {
            t_s: Some(0.0),
            q: Quaternion::IDENTITY,
            sigma_att_rad: Vector3::repeat(0.01),
            bias_rad_s: Vector3::repeat(limit),
            bias_sigma_rad_s: Vector3::repeat(1e-5),
            uniform_attitude: false,
            covariance: None,
        };
        let mut f = build_filter(&c, &initial, 3).unwrap();
        // τ = 2 σ_b²/σ_u² ≈ 17 s; 200 s is many τ.
        for k in 1..=2000 {
            f.advance_to(k as f64 * 0.1).unwrap();
        }
        let e = f.estimate();
        let s = e.covariance[(3, 3)].sqrt();
        eprintln!(
            "{spec}: σ_β/σ_b {}, β̂/σ_b {:?}",
            s / limit,
            (e.bias_rad_s / limit).as_slice()
        );
        assert!(
            (s / limit - 1.0).abs() < 0.05,
            "{spec}: σ_β {} °/s",
            s / DEG
        );
        assert!(
            e.bias_rad_s.amax() < 0.08 * limit,
            "{spec}: the bias relaxes to zero"
        );
    }
}

// ------------------------------------------------------------------------------------------------
// The accelerometer

/// The gravity direction's 1σ follows the motion the low-pass lets through: still, it is the rest σ;
/// swaying slowly (1 m/s² at 0.15 Hz, which a 3 s low-pass passes in part) it grows several times;
/// the tilt updates come every `acc.interval_s`, not every sample.
#[test]
fn the_tilt_sigma_follows_the_motion_and_updates_are_decimated() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(4, Quaternion::IDENTITY, Vector3::zeros());
    let mut steps = imu.run(0.0, 2000, still, still, |_| field_enu());
    let calm = {
        let mut v = VehicleState::new("calm", f.clone());
        let est = feed(&mut v, &p, &steps);
        imu_diag(est.last().unwrap()).clone()
    };
    let rest = p.imu.acc.rest_sigma_rad / DEG;
    assert!(
        (calm.tilt_sigma_lp_deg / rest - 1.0).abs() < 0.1,
        "{calm:?}"
    );
    let shake = |t: f64| Vector3::new((2.0 * std::f64::consts::PI * 0.15 * t).sin(), 0.0, 0.0);
    steps.extend(imu.run(10.0, 4000, still, shake, |_| field_enu()));
    let mut v = VehicleState::new("shaken", f);
    let est = feed(&mut v, &p, &steps);
    let d = imu_diag(est.last().unwrap());
    assert!(d.tilt_sigma_lp_deg > 2.0 * calm.tilt_sigma_lp_deg, "{d:?}");
    let expected = 30.0 / p.imu.acc.interval_s;
    assert!(
        (d.tilt_updates as f64 - expected).abs() <= 2.0,
        "{} tilt updates in 30 s",
        d.tilt_updates
    );
}

/// Honesty of the tilt under motion: a body that turns and is shaken (1.5 m/s² along changing
/// directions), for both filters. (The filter is told the synthetic sensor's truth: no scale-factor
/// error, exact time stamps. With a gyro this good the estimate averages the low-passed gravity to
/// better than its own error, so the floor at that error is a little conservative here; on the real
/// IMU of docs/broad.md the median NEES is 0.6–1.5.)
///
/// * Scale: the median of the 2-dof tilt NEES over the 55 s of motion lies in [0.7, 1.9]. χ²₂'s median
///   is 1.386; a consistent covariance scaled by 1/2.25 or 2.25 (σ 1.5× too small or too large) gives
///   3.12 or 0.62, outside. The samples (200 Hz) are correlated, so the spread of the median is
///   measured instead: over IMU seeds 5 and 21–31 it is 1.04–1.11 (MEKF) and 0.96–1.15 (QPF), a 1σ of
///   0.026 and 0.055 about 1.08, well inside.
/// * Tail: the tilt error inside its 99% ellipse on more than 97% of the samples (measured: all of
///   them, every seed). It catches errors far outside the covariance, not its scale: the covariance
///   scaled by 1/2.25 still has 100% (MEKF) and 99.1% (QPF) inside.
///
/// Measured (seed 5, the preset of issue 26 with the bias's variance in the tilt reading): median 1.342
/// (MEKF) and 1.681 (QPF), inside 99% 0.991 and 0.993; with the covariance scaled by 1/2.25, 3.02 and
/// 3.78, by 2.25, 0.596 and 0.747: the median bound rejects both, which the test checks. Seeds 21–23:
/// medians 1.35–1.58 (MEKF) and 1.71–1.89 (QPF), inside 0.982–0.987. (The seed spread in the first
/// point was measured with an earlier preset, when the medians were 1.04 and 0.96.)
#[test]
fn the_tilt_covariance_is_honest_under_motion() {
    let (mut f, mut p) = imu_preset();
    f.filter.gyro.sigma_v = 5e-4;
    f.filter.gyro_errors.rate_noise_sqrt_s = 0.0;
    p.imu.timing_sigma_s = 0.0;
    for (spec, n) in [("mekf", 2), ("qpf:average", 300)] {
        let mut imu = Imu::new(
            5,
            Quaternion::from_euler_321(0.1, 0.2, 0.3),
            Vector3::zeros(),
        );
        let shake = |t: f64| {
            Vector3::new(
                1.5 * (3.0 * t).sin(),
                1.5 * (2.3 * t).cos(),
                0.5 * (4.1 * t).sin(),
            )
        };
        let mut steps = imu.run(0.0, 2000, still, still, |_| field_enu());
        steps.extend(imu.run(10.0, 12000, |t| turning(t) * 0.5, shake, |_| field_enu()));
        let mut v = VehicleState::new("honest", with_filter(f.clone(), spec, n));
        let est = feed(&mut v, &p, &steps);
        assert_eq!(
            est.len(),
            steps.len() - (p.imu.init.duration_s * RATE_HZ) as usize
        );
        let offset = steps.len() - est.len();
        let mut nees = Vec::new();
        for (k, m) in est.iter().enumerate().skip(3000) {
            let (e, pe) = reference_error(&steps[k + offset].truth, m);
            let ph = nalgebra::Matrix2::new(pe[(0, 0)], pe[(0, 1)], pe[(1, 0)], pe[(1, 1)]);
            let th = nalgebra::Vector2::new(e[0], e[1]);
            nees.push(th.dot(&ph.cholesky().unwrap().solve(&th)));
        }
        let inside = nees.iter().filter(|v| **v <= 9.21).count() as f64 / nees.len() as f64;
        nees.sort_by(|a, b| a.total_cmp(b));
        let median = nees[nees.len() / 2];
        eprintln!("{spec}: tilt inside 99% {inside:.4}, median NEES {median:.3}");
        assert!(inside > 0.97, "{spec}: {inside} inside");
        let scale_ok = |m: f64| (0.8..=2.0).contains(&m);
        assert!(scale_ok(median), "{spec}: median NEES {median}");
        // The bound's power: the same estimates with the covariance 1.5× too small or too large in σ.
        for scale in [2.25, 1.0 / 2.25] {
            assert!(
                !scale_ok(median * scale),
                "{spec}: a covariance scaled by 1/{scale} (median NEES {}) would pass",
                median * scale
            );
        }
    }
}

// ------------------------------------------------------------------------------------------------
// The magnetometer

/// A field disturbed by a place (30 % stronger and turned by 30° for 20 s) is rejected, the heading is
/// held by the gyro (within its own growing σ), and the magnetometer is used again afterwards; the
/// heading never follows the 30° of the disturbance. Measured (seed 6): worst error 3.17° (MEKF) and
/// 1.83° (QPF, the preset's 2000 particles). Over IMU seeds 6, 106, …, 1106 the MEKF's worst is
/// 2.12–4.62°, and the particle filter's 1.02–6.05°: above 5° on one of the twelve, a finding about
/// the particle filter that this seed does not show (the bound is not widened to hide it).
#[test]
fn a_disturbed_field_is_rejected_and_the_heading_held() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(6, Quaternion::IDENTITY, Vector3::zeros());
    let disturbed = |t: f64| {
        if (20.0..40.0).contains(&t) {
            // Stronger and turned by 30° about up.
            Quaternion::from_rotation_vector(&Vector3::new(0.0, 0.0, 30.0 * DEG)).attitude_matrix()
                * field_enu()
                * 1.3
        } else {
            field_enu()
        }
    };
    let steps = imu.run(0.0, 12000, |t| turning(t) * 0.3, still, disturbed);
    for (spec, n) in [("mekf", 2), ("qpf:average", 2000)] {
        let mut v = VehicleState::new("dist", with_filter(f.clone(), spec, n));
        let est = feed(&mut v, &p, &steps);
        let offset = steps.len() - est.len();
        let worst = est
            .iter()
            .enumerate()
            .map(|(k, m)| error_deg(&steps[k + offset].truth, m))
            .skip(1000)
            .fold(0.0, f64::max);
        eprintln!("{spec}: worst error {worst:.2}°");
        assert!(worst < 5.0, "{spec}: worst error {worst}°");
        let d = imu_diag(est.last().unwrap());
        assert!(d.mag_rejected > 150, "{spec}: {d:?}");
        assert!(!d.mag_disturbed);
    }
}

/// The rejection is bounded: a field that stays different for good is used again, down-weighted,
/// after `max_rejection_s`; with the budget spent it is counted as used, not rejected.
#[test]
fn the_rejection_is_bounded() {
    let (f, mut p) = imu_preset();
    p.imu.mag.max_rejection_s = 5.0;
    // A new field that is never consistent enough to be accepted (no rotation).
    p.imu.mag.new_field_s = 1e9;
    let mut imu = Imu::new(7, Quaternion::IDENTITY, Vector3::zeros());
    let steps = imu.run(0.0, 4000, still, still, |t| {
        if t < 5.0 {
            field_enu()
        } else {
            field_enu() * 1.5
        }
    });
    let mut v = VehicleState::new("budget", f);
    let est = feed(&mut v, &p, &steps);
    let d = imu_diag(est.last().unwrap());
    assert!(d.mag_disturbed);
    let rejected_s = d.mag_rejected as f64 * p.imu.mag.interval_s;
    assert!(
        (rejected_s - 5.0).abs() < 0.3,
        "rejected for {rejected_s} s"
    );
    assert!(d.heading_updates > 40, "{d:?}");
}

/// A new field (moved to another place: 20 % weaker, dip 10° steeper) that stays consistent while the
/// body turns becomes the reference after `new_field_s`.
#[test]
fn a_consistent_new_field_is_accepted() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(8, Quaternion::IDENTITY, Vector3::zeros());
    let other = {
        let dip = 76.0 * DEG;
        Vector3::new(0.0, dip.cos(), -dip.sin()) * 36.0
    };
    let steps = imu.run(
        0.0,
        14000,
        |t| turning(t) * 0.8,
        still,
        |t| {
            if t < 10.0 {
                field_enu()
            } else {
                other
            }
        },
    );
    let mut v = VehicleState::new("newfield", f);
    let est = feed(&mut v, &p, &steps);
    let d = imu_diag(est.last().unwrap());
    assert!(
        d.mag_new_fields >= 1 || d.mag_hard_iron_changes >= 1,
        "{d:?}"
    );
    assert!(!d.mag_disturbed, "{d:?}");
    assert!((d.mag_norm.unwrap() - 36.0).abs() < 2.0, "{d:?}");
    assert!((d.mag_dip_deg.unwrap() - 76.0).abs() < 2.0, "{d:?}");
}

/// A magnet attached to the body (a 20 µT offset) from t = 10 s: the offset is found while the body
/// turns, accepted and refined, and the heading over the last 40 s is several times better than with
/// the hard-iron model off (the field then stays disturbed, rejected, and finally used down-weighted);
/// in an undisturbed field no offset is ever accepted. Measured (seed 9) with the preset before issue
/// 26: 0.549° with, 69.7° without (over IMU seeds 9, 109, …, 1109: 0.39–0.67° with); with the preset of
/// issue 26 (a heading σ of 1.7°, correlated over 10 s, and a fit accepted only when it explains the
/// readings twice as well): 1.13° with, 8.86° without, hence the bounds 1.2° and 5×.
#[test]
fn a_magnet_on_the_body_is_calibrated_out() {
    let (f, p) = imu_preset();
    let offset = Vector3::new(4.0, -18.0, 8.0);
    let mut imu = Imu::new(9, Quaternion::IDENTITY, Vector3::zeros());
    let mut steps = imu.run(0.0, 2000, |t| turning(t) * 0.5, still, |_| field_enu());
    imu.mag_offset = offset;
    steps.extend(imu.run(10.0, 22000, |t| turning(t) * 0.5, still, |_| field_enu()));
    let heading_rms = |p: &Policy| {
        let mut v = VehicleState::new("magnet", f.clone());
        let est = feed(&mut v, p, &steps);
        let off = steps.len() - est.len();
        let tail = est.len() - 8000;
        let ms = est[tail..]
            .iter()
            .enumerate()
            .map(|(k, m)| reference_error(&steps[tail + k + off].truth, m).0[2].powi(2))
            .sum::<f64>()
            / 8000.0;
        (ms.sqrt() / DEG, imu_diag(est.last().unwrap()).clone())
    };
    let (with, d) = heading_rms(&p);
    let o = Vector3::from(d.mag_offset.unwrap());
    assert!((o - offset).norm() < 1.0, "offset {o} vs {offset}");
    let mut off = p.clone();
    off.imu.mag.hard_iron.enabled = false;
    let (without, _) = heading_rms(&off);
    eprintln!("heading RMS {with}° with the hard-iron fit, {without}° without");
    assert!(
        with < 1.2 && without > 5.0 * with,
        "heading RMS {with}° with, {without}° without"
    );

    let mut imu = Imu::new(10, Quaternion::IDENTITY, Vector3::zeros());
    let steps = imu.run(0.0, 18000, |t| turning(t) * 0.5, still, |_| field_enu());
    let mut v = VehicleState::new("clean", f);
    let est = feed(&mut v, &p, &steps);
    let d = imu_diag(est.last().unwrap());
    assert_eq!(d.mag_hard_iron_changes, 0, "{d:?}");
}

/// North is doubted until rotation confirms the field: a vehicle at rest publishes a heading σ that
/// allows for a hard-iron offset of half the field's norm (`mag.hard_iron.unconfirmed_offset` 0.5 over
/// cos 66°: 1.23 rad), from its first estimate on, and says `provisional`; after a reset whose datasheet states what a calibration
/// left (`sensor.mag_offset_sigma` 0.45 µT of a 45 µT field: 0.025 rad) the same samples give the same
/// attitude with a heading σ of a few degrees; once the body turns about every axis the fit confirms
/// the field and the allowance is gone.
#[test]
fn north_is_doubted_until_rotation_confirms_the_field() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(21, Quaternion::IDENTITY, Vector3::zeros());
    let mut steps = imu.run(0.0, 2000, still, still, |_| field_enu());
    let heading_sigma =
        |m: &EstimateMsg| reference_error(&Quaternion::IDENTITY, m).1[(2, 2)].sqrt();

    let doubted = feed(&mut VehicleState::new("n", f.clone()), &p, &steps);
    // (The estimate published straight from the alignment says so too.)
    let s0 = heading_sigma(&doubted[0]);
    assert!(s0 > 1.2, "heading σ at the alignment {s0} rad");
    let last = doubted.last().unwrap();
    assert_eq!(imu_diag(last).mag_reference.as_deref(), Some("provisional"));
    let s = heading_sigma(last);
    assert!(s > 1.2 && s < 1.3, "heading σ {s} rad");

    let m: attitude_service::wire::ResetMsg =
        serde_json::from_value(serde_json::json!({"sensor": {"mag_offset_sigma": 0.45}})).unwrap();
    let mut v = VehicleState::new("n", f.clone());
    v.on_reset(
        &ResetRequest::try_from(&m).unwrap(),
        &f,
        &p,
        &mut Vec::new(),
    )
    .unwrap();
    let stated = feed(&mut v, &p, &steps);
    let l = stated.last().unwrap();
    assert_eq!(l.q, last.q);
    let s = heading_sigma(l);
    assert!(s > 0.0246 && s < 0.05, "heading σ {s} rad");

    steps.extend(imu.run(10.0, 8000, |t| turning(t) * 0.5, still, |_| field_enu()));
    let turned = feed(&mut VehicleState::new("n", f), &p, &steps);
    let l = turned.last().unwrap();
    assert_eq!(imu_diag(l).mag_reference.as_deref(), Some("confirmed"));
    let s = heading_sigma(l);
    assert!(s < 0.05, "heading σ {s} rad");
}

/// A magnetometer that samples 4 steps (20 ms) after the gyro, in turns of about 1 rad/s: with
/// `mag.delay_s` set to its delay the heading error stays small; without, it is several times larger.
/// Measured (seed 11): 0.254° with, 1.258° without; over IMU seeds 11, 111, …, 1111, 0.13–0.25° with
/// and 1.14–1.30° without. The bound of 0.35° lies between this spread and 1.5× this seed's figure
/// (0.38°); without is at least 4.5× with on every seed.
#[test]
fn the_magnetometer_delay_is_compensated() {
    let (f, p) = imu_preset();
    let run = |delay: f64| {
        let mut p = p.clone();
        p.imu.mag.delay_s = delay;
        let mut imu = Imu::new(11, Quaternion::IDENTITY, Vector3::zeros());
        imu.mag_delay_steps = 4;
        let fast = |t: f64| Vector3::new(0.3 * (0.7 * t).sin(), 0.2, 2.0 * (0.4 * t).sin());
        let steps = imu.run(0.0, 12000, fast, still, |_| field_enu());
        let mut v = VehicleState::new("delay", f.clone());
        let est = feed(&mut v, &p, &steps);
        let offset = steps.len() - est.len();
        let ms: f64 = est
            .iter()
            .enumerate()
            .skip(4000)
            .map(|(k, m)| reference_error(&steps[k + offset].truth, m).0[2].powi(2))
            .sum::<f64>()
            / (est.len() - 4000) as f64;
        ms.sqrt() / DEG
    };
    let (with, without) = (run(4.0 / RATE_HZ), run(0.0));
    eprintln!("heading RMS {with}° with the delay, {without}° without");
    assert!(
        with < 0.35 && without > 3.0 * with,
        "heading RMS {with}° with, {without}° without"
    );
}

/// A sensor whose every reading is its interval's mean, at 25 Hz, on a body in a coning motion (its
/// rate turns about body z at 8 rad/s: `ω = 3 (cos 8t, sin 8t, 0.2)` rad/s) after 3 s of rest: the
/// truth integrated finely, the readings (gyro, accelerometer, magnetometer) the means of the fine
/// ones over each interval, no noise. One rotation step per interval leaves out the coning term, a
/// steady turn about z of about 0.5°/s that the magnetometer has to pull back; with it (and the
/// readings' lag) the estimate stays close. Measured: 0.31° RMS with, 1.57° without (the tilt alone
/// 0.006° and 0.39°).
#[test]
fn a_coning_motion_at_25_hz_keeps_its_heading() {
    let (f, p) = imu_preset();
    let rate_hz = 25.0;
    let dt = 1.0 / rate_hz;
    let fine = 40;
    let omega = |t: f64| {
        if t < 3.0 {
            Vector3::zeros()
        } else {
            Vector3::new((8.0 * t).cos(), (8.0 * t).sin(), 0.2) * 3.0
        }
    };
    let g = Vector3::new(0.0, 0.0, G);
    let mut q = Quaternion::IDENTITY;
    let mut steps = Vec::new();
    for k in 0..(60.0 * rate_hz) as usize {
        let t0 = (k as f64 - 1.0) * dt;
        let (mut gyr, mut acc, mut mag) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
        for i in 0..fine {
            let t = t0 + dt * (i as f64 + 0.5) / fine as f64;
            let w = omega(t);
            if k > 0 {
                q = q.propagate(&w, dt / fine as f64);
            }
            let a = q.attitude_matrix();
            gyr += w / fine as f64;
            acc += a * g / fine as f64;
            mag += a * field_enu() / fine as f64;
        }
        steps.push(Step {
            sample: ImuSample {
                t_s: k as f64 * dt,
                gyr_rad_s: gyr,
                acc_m_s2: acc,
                mag: Some(mag),
            },
            truth: q,
        });
    }
    let run = |coning: bool| {
        let mut p = p.clone();
        p.imu.gyro.coning = coning;
        let mut v = VehicleState::new("coning", f.clone());
        let est = feed(&mut v, &p, &steps);
        let offset = steps.len() - est.len();
        let skip = (10.0 * rate_hz) as usize;
        let (mut all, mut tilt) = (0.0, 0.0);
        for (k, m) in est.iter().enumerate().skip(skip) {
            let e = reference_error(&steps[k + offset].truth, m).0;
            all += e.norm_squared();
            tilt += e.x * e.x + e.y * e.y;
        }
        let n = (est.len() - skip) as f64;
        ((all / n).sqrt() / DEG, (tilt / n).sqrt() / DEG)
    };
    let (with, without) = (run(true), run(false));
    eprintln!("RMS (3-axis, tilt) {with:?}° with the coning term, {without:?}° without");
    assert!(
        with.0 < 0.5 && without.0 > 3.0 * with.0,
        "3-axis RMS {}° with, {}° without",
        with.0,
        without.0
    );
}

// ------------------------------------------------------------------------------------------------
// Honesty mechanisms

/// Floors: after a long rest the tilt 1σ stays at `acc.floor_rad` at least and the heading 1σ at
/// `mag.floor_rad`, however many updates came (errors no averaging removes).
#[test]
fn variance_floors_hold() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(
        12,
        Quaternion::from_euler_321(0.3, 0.1, -0.5),
        Vector3::zeros(),
    );
    let steps = imu.run(0.0, 12000, still, still, |_| field_enu());
    let mut v = VehicleState::new("floor", f);
    let est = feed(&mut v, &p, &steps);
    let last = est.last().unwrap();
    let (_, pe) = reference_error(&steps.last().unwrap().truth, last);
    for i in 0..2 {
        assert!(
            pe[(i, i)].sqrt() >= p.imu.acc.floor_rad * 0.999,
            "tilt σ {}",
            pe[(i, i)].sqrt()
        );
    }
    assert!(
        pe[(2, 2)].sqrt() >= p.imu.mag.floor_rad * 0.999,
        "heading σ {}",
        pe[(2, 2)].sqrt()
    );
}

/// Re-acquisition: a filter that is 15° off in tilt while claiming 0.01° (started so by a reset, with a
/// bias it is sure of too), with the variance floors off so that nothing else widens it, sees its tilt innovations stay inconsistent,
/// widens its tilt covariance (counted) and follows the accelerometer back to the truth.
///
/// Measured (IMU seed 13) with the preset before issue 26: 0.909° with the re-acquisition, 2.11°
/// without (on other seeds the error without it was 0.09–1.7°, often smaller than with it: a finding,
/// left as it was); with the preset of issue 26 the filter comes back without it too (below).
#[test]
fn an_overconfident_tilt_is_reacquired() {
    let (mut f, mut p) = imu_preset();
    f.filter.gyro.sigma_v = 1e-8;
    f.filter.gyro_errors.rate_noise_sqrt_s = 0.0;
    p.imu.acc.floor_rad = 0.0;
    p.imu.acc.floor_lp_factor = 0.0;
    let truth0 = Quaternion::from_euler_321(0.1, -0.2, 0.4);
    let mut imu = Imu::new(13, truth0, Vector3::zeros());
    let steps = imu.run(1.0, 8000, still, still, |_| field_enu());
    let wrong =
        Quaternion::from_rotation_vector(&Vector3::new(15.0 * DEG, 0.0, 0.0)).compose(&truth0);
    let req: attitude_service::wire::ResetMsg = serde_json::from_value(serde_json::json!({
        "q": {"w": wrong.w, "x": wrong.x, "y": wrong.y, "z": wrong.z},
        "sigma_deg": [0.01, 0.01, 0.01],
        "bias_sigma": [1e-5, 1e-5, 1e-5],
        "t": 1.0,
    }))
    .unwrap();
    let req = ResetRequest::try_from(&req).unwrap();
    // The tilt error 15 s in (the heading, pulled away while the tilt was wrong, comes back slowly).
    let run = |p: &Policy| {
        let mut v = VehicleState::new("wrong", f.clone());
        v.on_reset(&req, &f, p, &mut Vec::new()).unwrap();
        let est = feed(&mut v, p, &steps[..3000]);
        let last = est.last().unwrap().clone();
        let (e, _) = reference_error(&steps[2999].truth, &last);
        (e.xy().norm() / DEG, imu_diag(&last).clone())
    };
    let (err, d) = run(&p);
    assert!(d.tilt_reacquisitions >= 1, "{d:?}");
    assert!(err < 1.0, "tilt error {err}°");
    // Without the re-acquisition the preset of issue 26 comes back too (0.10° at 15 s, 0.01° with the
    // accelerometer's σ of the preset before it, which was stuck at 2.11°): what else widens the tilt
    // now (the gyro channel's terms, the published instant) is enough here. The re-acquisition is
    // still what a filter needs that claims far less than its error; the test checks it acts.
}

/// A sensor's output stage (`sensor.output`: `mean`, `increments`, `instant`) is a datasheet value like
/// the others: the service's (`service.imu.sensor`), a vehicle's over it (`service.vehicles.V.sensor`)
/// and a reset request's over the vehicle's; a name not among the three is refused with the setting
/// named. The reset's reaches the pipeline: an `increments` gyro (no coning term added) turns the same
/// stream into other estimates than the configuration's models.
#[test]
fn a_sensors_output_stage_comes_from_its_configuration_and_its_reset() {
    use attitude_service::ahrs::Output;
    use attitude_service::service::config;
    let c = config::parse(
        r#"{service: {imu: {sensor: {output: "increments"}},
                      vehicles: {a: {sensor: {output: "instant"}}, b: {sensor: {gyro_range_deg_s: 500}}}}}"#,
        "test",
    )
    .unwrap();
    assert_eq!(c.service.default_filter.sensor.output, Output::Increments);
    assert_eq!(c.service.filter_for("a").sensor.output, Output::Instant);
    assert_eq!(c.service.filter_for("b").sensor.output, Output::Increments);
    assert_eq!(c.service.filter_for("b").sensor.gyro_range_deg_s, 500.0);
    let e = format!(
        "{:#}",
        config::parse(
            r#"{service: {imu: {sensor: {output: "averaged"}}}}"#,
            "test"
        )
        .unwrap_err()
    );
    assert!(e.contains("averaged") && e.contains("mean"), "{e}");

    let reset = |output: &str| {
        let m: attitude_service::wire::ResetMsg =
            serde_json::from_value(serde_json::json!({"sensor": {"output": output}})).unwrap();
        ResetRequest::try_from(&m)
    };
    assert_eq!(
        reset("instant").unwrap().sensor.map(|s| s.output),
        Some(Output::Instant)
    );
    let r = reset("sideways").unwrap_err();
    assert_eq!(r.code, attitude_service::wire::RejectCode::BadRequest);
    assert!(
        r.message.contains("sensor.output") && r.message.contains("sideways"),
        "{}",
        r.message
    );

    // Through a vehicle: the same turning stream, with the configuration's models (coning on) and
    // after a reset that says the gyro's outputs are its own increments.
    let (f, p) = imu_preset();
    let mut imu = Imu::new(16, Quaternion::IDENTITY, Vector3::zeros());
    let steps = imu.run(0.0, 2000, |t| turning(t) * 0.8, still, |_| field_enu());
    let configured = feed(&mut VehicleState::new("o", f.clone()), &p, &steps);
    let mut v = VehicleState::new("o", f.clone());
    v.on_reset(&reset("increments").unwrap(), &f, &p, &mut Vec::new())
        .unwrap();
    let increments = feed(&mut v, &p, &steps);
    let (a, b) = (configured.last().unwrap(), increments.last().unwrap());
    assert!(b.q.w.is_finite() && a.q != b.q, "{:?} {:?}", a.q, b.q);
}

/// The published covariance adds the time-stamp uncertainty `σ_t² ω ωᵀ` to the filter's: the same
/// vehicle with and without it differs by exactly that at the last sample.
#[test]
fn the_timing_uncertainty_is_published() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(14, Quaternion::IDENTITY, Vector3::zeros());
    let steps = imu.run(
        0.0,
        1000,
        |_| Vector3::new(0.0, 0.0, 2.0),
        still,
        |_| field_enu(),
    );
    let mut off = p.clone();
    off.imu.timing_sigma_s = 0.0;
    let with = feed(&mut VehicleState::new("t", f.clone()), &p, &steps);
    let without = feed(&mut VehicleState::new("t", f), &off, &steps);
    let (a, b) = (with.last().unwrap(), without.last().unwrap());
    assert_eq!(a.q, b.q);
    // ω − β̂ ≈ (0, 0, 2) rad/s: the zz entry grows by (2 σ_t)², the others by nearly nothing.
    let st = p.imu.timing_sigma_s;
    assert!((a.cov[2][2] - b.cov[2][2] - 4.0 * st * st).abs() < 0.01 * 4.0 * st * st);
    assert!((a.cov[0][0] - b.cov[0][0]).abs() < 1e-3 * 4.0 * st * st);
}

// ------------------------------------------------------------------------------------------------
// The same input, the same output

/// A recording through a new vehicle, through the same vehicle after a reset with a time, and through a
/// new vehicle of the same id with the samples arriving in other batches: identical estimates, with
/// the MEKF and the particle filter (its seed comes from the vehicle id and resets with the vehicle).
#[test]
fn the_same_input_gives_the_same_output() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(15, Quaternion::IDENTITY, Vector3::new(0.01, 0.0, -0.01));
    let steps = imu.run(0.0, 3000, |t| turning(t) * 0.4, still, |_| field_enu());
    for (spec, n) in [("mekf", 2), ("qpf:average", 200)] {
        let config = with_filter(f.clone(), spec, n);
        let first = feed(&mut VehicleState::new("same", config.clone()), &p, &steps);
        // Again, after a reset that re-anchors the time before the recording.
        let mut v = VehicleState::new("same", config.clone());
        feed(&mut v, &p, &steps[..500]);
        let req = ResetRequest {
            t_s: Some(-1.0),
            ..ResetRequest::default()
        };
        v.on_reset(&req, &config, &p, &mut Vec::new()).unwrap();
        let again = feed(&mut v, &p, &steps);
        assert_eq!(first.len(), again.len(), "{spec}");
        for (a, b) in first.iter().zip(&again) {
            assert_eq!(
                (a.t, a.q, a.cov, a.bias),
                (b.t, b.q, b.cov, b.bias),
                "{spec}"
            );
        }
    }
}

/// The pipeline's state is plain data: a vehicle checkpointed mid-recording and restored continues
/// exactly as the one that was not (with the particle filter, particles and RNG included, and the
/// pipeline's memory of a slower magnetometer's repeats and of a filled hole it is in the middle of).
#[test]
fn a_checkpoint_continues_exactly() {
    use attitude_service::service::persist;
    let (f, p) = imu_preset();
    let config = with_filter(f, "qpf:average", 200);
    let mut imu = Imu::new(16, Quaternion::IDENTITY, Vector3::zeros());
    let mut steps = imu.run(0.0, 2000, |t| turning(t) * 0.4, still, |_| field_enu());
    // A magnetometer four times slower than the gyro, its driver repeating the last reading, and a
    // hole filled in on a line across the checkpoint: the pipeline's memory of both is state too.
    for k in 0..steps.len() {
        if k % 4 != 0 {
            steps[k].sample.mag = steps[k - 1].sample.mag;
        }
    }
    let (a0, a1) = (steps[995].sample, steps[1006].sample);
    for (k, step) in steps.iter_mut().enumerate().take(1006).skip(996) {
        let f = (k - 995) as f64 / 11.0;
        let line = |x: &Vector3<f64>, y: &Vector3<f64>| x + (y - x) * f;
        step.sample.gyr_rad_s = line(&a0.gyr_rad_s, &a1.gyr_rad_s);
        step.sample.acc_m_s2 = line(&a0.acc_m_s2, &a1.acc_m_s2);
        step.sample.mag = Some(line(&a0.mag.unwrap(), &a1.mag.unwrap()));
    }
    let mut a = VehicleState::new("ck", config.clone());
    feed(&mut a, &p, &steps[..1000]);
    let bytes = persist::encode(&a, &Default::default()).unwrap();
    let mut b = persist::decode(&bytes).unwrap().state;
    let ra = feed(&mut a, &p, &steps[1000..]);
    let rb = feed(&mut b, &p, &steps[1000..]);
    assert_eq!(ra.len(), rb.len());
    for (x, y) in ra.iter().zip(&rb) {
        assert_eq!((x.t, x.q, x.cov), (y.t, y.q, y.cov));
    }
    let _ = Ahrs::new(&AhrsConfig::default());
}

/// A driver that repeats its last reading when no new one is ready (a held reading) hides how the
/// rate changed meanwhile. Here the body's rate ramps up about the vertical (2 rad/s² for 3 s, after
/// 3 s at rest) with every other reading held, and no magnetometer: the heading is the gyro's alone.
/// Turning the held rate over the held intervals leaves the heading short by `α Δt²` per held
/// reading, 0.86° after the ramp; the pipeline turns a run's catch-up, `(ω_k − ω_held) T_run / 2`,
/// with the next fresh reading (the rate went from the held one to the new one), and the error stays
/// that of the unheld run (measured: MEKF 0.18° unheld, 1.09° held without the catch-up, 0.25°
/// with it; the particle filter, 500 particles, 0.69° and 0.11°). Both filters; the error is also
/// inside the published 3σ (of the three axes together).
#[test]
fn held_readings_are_caught_up() {
    let (f, p) = imu_preset();
    let mut imu = Imu::new(3, Quaternion::IDENTITY, Vector3::zeros());
    let mut steps = imu.run(0.0, 600, still, still, |_| field_enu());
    steps.extend(imu.run(
        3.0,
        600,
        |t| Vector3::new(0.0, 0.0, 2.0 * (t - 3.0)),
        still,
        |_| field_enu(),
    ));
    for s in &mut steps {
        s.sample.mag = None;
    }
    let mut held = steps.clone();
    for k in (601..held.len()).step_by(2) {
        let prev = held[k - 1].sample;
        let s = &mut held[k].sample;
        (s.gyr_rad_s, s.acc_m_s2) = (prev.gyr_rad_s, prev.acc_m_s2);
    }
    for (spec, n) in [("mekf", 2), ("qpf:average", 500)] {
        // Without a magnetometer the reference's north is the body's heading at the start, not the
        // simulation's: the error is measured from where it stood at the end of the rest.
        let run = |steps: &[Step]| {
            let mut v = VehicleState::new("held", with_filter(f.clone(), spec, n));
            let est = feed(&mut v, &p, steps);
            // (The estimates begin after the alignment: found by their time.)
            let at = |k: usize| est.iter().find(|m| m.t == steps[k].sample.t_s).unwrap();
            let err = |k: usize| steps[k].truth.inverse().compose(&q_of(at(k)));
            let last = est.len() - 1;
            let drift = err(599).inverse().compose(&err(steps.len() - 1)).angle() / DEG;
            let sigma = (0..3).map(|i| est[last].cov[i][i]).sum::<f64>().sqrt() / DEG;
            (drift, sigma)
        };
        let (plain, _) = run(&steps);
        let (with_held, sigma) = run(&held);
        eprintln!("{spec}: drift {plain:.3}° unheld, {with_held:.3}° held (1σ {sigma:.3}°)");
        // (The particle filter's heading carries its Monte-Carlo error, 0.69° unheld at 500
        // particles: the bound is against the larger of the unheld drift and 0.25°.)
        assert!(plain < 1.0, "{spec}: {plain}° without held readings");
        assert!(
            with_held <= plain.max(0.25) + 0.3,
            "{spec}: {with_held}° with every other reading held, {plain}° without"
        );
        assert!(
            with_held < 3.0 * sigma,
            "{spec}: {with_held}° against a 1σ of {sigma}°"
        );
    }
}
