//! The scenarios and the simulator, tested together.

use super::*;
use crate::sensors::{GyroSample, Measurement, ObservationSet, VectorObservation};
use std::collections::HashMap;

fn sets(run: &SimulatedRun) -> impl Iterator<Item = &ObservationSet> {
    run.measurements.iter().filter_map(|m| match m {
        Measurement::Vectors(s) => Some(s),
        _ => None,
    })
}

fn gyros(run: &SimulatedRun) -> impl Iterator<Item = &GyroSample> {
    run.measurements.iter().filter_map(|m| match m {
        Measurement::Gyro(g) => Some(g),
        _ => None,
    })
}

/// Truth at an exact gyro time.
fn truth_at(run: &SimulatedRun, params: &ScenarioParams, t: f64) -> TruthSample {
    let k = (t / params.dt_gyro_s).round() as usize;
    let s = run.truth[k];
    assert_eq!(s.t_s, t);
    s
}

/// 3-2-1 Euler angles (roll, pitch, yaw) of `A = R1(φ) R2(θ) R3(ψ)`.
fn euler_321(q: &Quaternion) -> (f64, f64, f64) {
    let a = q.attitude_matrix();
    let pitch = (-a[(0, 2)]).clamp(-1.0, 1.0).asin();
    let yaw = a[(0, 1)].atan2(a[(0, 0)]);
    let roll = a[(1, 2)].atan2(a[(2, 2)]);
    (roll, pitch, yaw)
}

#[test]
fn names_parse_and_display() {
    for n in ScenarioName::ALL {
        assert_eq!(n.to_string().parse::<ScenarioName>(), Ok(n));
    }
    assert_eq!(
        "magnetometer-leo".parse::<ScenarioName>(),
        Ok(ScenarioName::MagnetometerLeo)
    );
    assert!("star_tracker".parse::<ScenarioName>().is_err());
    assert_eq!(ScenarioName::LostInSpace.to_string(), "lost-in-space");
}

#[test]
fn defaults_are_valid_and_described() {
    for n in ScenarioName::ALL {
        let p = ScenarioParams::default_for(n);
        assert_eq!(p.name, n);
        p.validate().unwrap();
        let d = p.describe();
        assert!(d.contains(n.as_str()));
        assert!(d.contains("deg/hr") && d.contains(" s "));
    }
    let st = ScenarioParams::default_for(ScenarioName::StarTracker);
    assert_eq!(st.n_gyro_steps(), 5400);
    assert!(st.describe().contains("6.000 arcsec"));
    let mag = ScenarioParams::default_for(ScenarioName::MagnetometerLeo);
    assert_eq!(mag.n_gyro_steps(), 2880);
    assert!(mag.describe().contains("50.0 nT"));
    assert_eq!(
        ScenarioParams::default_for(ScenarioName::LostInSpace).n_gyro_steps(),
        1800
    );
}

#[test]
fn deterministic_per_seed() {
    for n in ScenarioName::ALL {
        let p = ScenarioParams::default_for(n);
        let a = simulate(&p, 42);
        let b = simulate(&p, 42);
        let c = simulate(&p, 43);
        assert_eq!(a, b);
        assert_ne!(a.measurements, c.measurements);
        assert_ne!(a.initial, c.initial);
    }
}

#[test]
fn measurement_stream_layout() {
    for n in ScenarioName::ALL {
        let mut p = ScenarioParams::default_for(n);
        if n == ScenarioName::MagnetometerLeo {
            // Exercise dt_obs > dt_gyro too.
            p.dt_gyro_s = 5.0;
        }
        let run = simulate(&p, 7);
        let k_end = p.n_gyro_steps();
        let m = p.obs_every();
        assert_eq!(run.truth.len(), k_end + 1);
        for (k, s) in run.truth.iter().enumerate() {
            assert_eq!(s.t_s, k as f64 * p.dt_gyro_s);
        }
        assert_eq!(gyros(&run).count(), k_end);
        assert_eq!(sets(&run).count(), k_end / m);
        // Time ordered; at equal times the vectors come first; gyro and set times strictly increase.
        for w in run.measurements.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            assert!(a.t_s() <= b.t_s());
            if a.t_s() == b.t_s() {
                assert!(matches!(a, Measurement::Vectors(_)));
                assert!(matches!(b, Measurement::Gyro(_)));
            }
        }
        for (k, g) in gyros(&run).enumerate() {
            assert_eq!(g.t_s, k as f64 * p.dt_gyro_s);
        }
        for (j, s) in sets(&run).enumerate() {
            assert_eq!(s.t_s, ((j + 1) * m) as f64 * p.dt_gyro_s);
            assert!(!s.observations.is_empty());
        }
        assert!(matches!(run.measurements[0], Measurement::Gyro(_)));
        assert_eq!(
            run.measurements.last().unwrap().t_s(),
            k_end as f64 * p.dt_gyro_s
        );
    }
}

#[test]
fn star_tracker_frames_hold_3_to_10_stars() {
    let p = ScenarioParams::default_for(ScenarioName::StarTracker);
    let run = simulate(&p, 1);
    let mut total = 0;
    for s in sets(&run) {
        let n = s.observations.len();
        assert!((3..=10).contains(&n), "{n} stars at t = {}", s.t_s);
        total += n;
    }
    let mean = total as f64 / sets(&run).count() as f64;
    assert!((6.0..=9.0).contains(&mean), "mean {mean}");
}

#[test]
fn observation_noise_matches_sigma() {
    for n in ScenarioName::ALL {
        let p = ScenarioParams::default_for(n);
        let run = simulate(&p, 11);
        // Per sensor: (sum of squares, count, sigma).
        let mut stats: HashMap<String, (f64, f64, Vector3<f64>, f64)> = HashMap::new();
        for s in sets(&run) {
            let a = truth_at(&run, &p, s.t_s).q.attitude_matrix();
            for o in &s.observations {
                let e = o.body - a * o.reference;
                let entry = stats.entry(o.sensor.clone().unwrap()).or_insert((
                    0.0,
                    0.0,
                    Vector3::zeros(),
                    o.sigma,
                ));
                entry.0 += e.norm_squared();
                entry.1 += 3.0;
                entry.2 += e;
                assert_eq!(entry.3, o.sigma);
            }
        }
        let expected: Vec<&str> = match n {
            ScenarioName::StarTracker => vec!["st1"],
            ScenarioName::MagnetometerLeo => vec!["mag"],
            ScenarioName::LostInSpace => vec!["sun", "mag"],
        };
        assert_eq!(stats.len(), expected.len());
        for name in expected {
            let (ss, count, sum, sigma) = stats[name];
            let std = (ss / count).sqrt();
            assert!(
                (std / sigma - 1.0).abs() < 0.05,
                "{n} {name}: std {std} vs sigma {sigma}"
            );
            let mean = sum / (count / 3.0);
            assert!(
                mean.amax() < 5.0 * sigma / (count / 3.0).sqrt(),
                "{n} {name} mean {mean}"
            );
        }
    }
}

#[test]
fn reference_vectors_are_the_models() {
    let p = ScenarioParams::default_for(ScenarioName::LostInSpace);
    let run = simulate(&p, 3);
    let sun = p.sun_direction_eci.normalize();
    for s in sets(&run) {
        for o in &s.observations {
            match o.sensor.as_deref() {
                Some("sun") => assert_eq!(o.reference, sun),
                Some("mag") => {
                    let b = p.field.field_eci_nt(&p.orbit.position_eci(s.t_s), s.t_s);
                    assert_eq!(o.reference, b);
                    // 400 km: between B0 and 2 B0 times (R_E/r)³ ≈ 0.839.
                    assert!(b.norm() > 25_000.0 && b.norm() < 51_000.0);
                }
                other => panic!("unexpected sensor {other:?}"),
            }
        }
    }
}

#[test]
fn gyro_noise_statistics() {
    let mut p = ScenarioParams::default_for(ScenarioName::StarTracker);
    p.sensors = ScenarioSensors::default();
    p.duration_s = 20_000.0;
    let run = simulate(&p, 5);
    let sigma = p.gyro.discrete_rate_sigma(p.dt_gyro_s);
    let (mut sum, mut ss, mut count) = (Vector3::zeros(), 0.0, 0.0);
    for (k, g) in gyros(&run).enumerate() {
        let (t0, t1) = (run.truth[k], run.truth[k + 1]);
        assert_eq!(g.t_s, t0.t_s);
        let bias = (t0.bias_rad_s + t1.bias_rad_s) * 0.5;
        let e = g.omega_body_rad_s - t0.omega_rad_s - bias;
        sum += e;
        ss += e.norm_squared();
        count += 1.0;
    }
    let mean = sum / count;
    let std = (ss / (3.0 * count)).sqrt();
    assert!((std / sigma - 1.0).abs() < 0.05, "std {std} vs {sigma}");
    assert!(mean.amax() < 5.0 * sigma / count.sqrt(), "mean {mean}");
    // The bias random walk: increments of 1σ σ_u √Δt.
    let mut ss_b = 0.0;
    for w in run.truth.windows(2) {
        ss_b += (w[1].bias_rad_s - w[0].bias_rad_s).norm_squared();
    }
    let std_b = (ss_b / (3.0 * (run.truth.len() - 1) as f64)).sqrt();
    let expected_b = p.gyro.sigma_u * p.dt_gyro_s.sqrt();
    assert!((std_b / expected_b - 1.0).abs() < 0.05);
    assert_eq!(run.truth[0].bias_rad_s, Vector3::repeat(0.1 * DEG_PER_HR));
}

#[test]
fn truth_motion() {
    // Star tracker: identity at t = 0, rotation about −y at 2π/5490 rad/s.
    let p = ScenarioParams::default_for(ScenarioName::StarTracker);
    let run = simulate(&p, 2);
    assert_eq!(run.truth[0].q, Quaternion::IDENTITY);
    let w = 2.0 * std::f64::consts::PI / 5490.0;
    for s in run.truth.iter().step_by(97) {
        let expected = Quaternion::from_rotation_vector(&Vector3::new(0.0, -w * s.t_s, 0.0));
        assert!(expected.small_angle_error(&s.q).norm() < 1e-12);
        assert_eq!(s.omega_rad_s, Vector3::new(0.0, -w, 0.0));
    }
    // LVLH scenarios stay Earth-pointing in the orbit.
    for n in [ScenarioName::MagnetometerLeo, ScenarioName::LostInSpace] {
        let p = ScenarioParams::default_for(n);
        let run = simulate(&p, 2);
        for s in &run.truth {
            let lvlh = p.orbit.lvlh_attitude(s.t_s);
            assert!(
                lvlh.small_angle_error(&s.q).norm() < 1e-9,
                "{n} t {}",
                s.t_s
            );
            assert!((s.q.norm() - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn star_tracker_initial_error_is_small_gaussian() {
    let p = ScenarioParams::default_for(ScenarioName::StarTracker);
    let n = 400;
    let mut ss = Vector3::zeros();
    for seed in 0..n {
        let mut short = p.clone();
        short.duration_s = 2.0;
        let run = simulate(&short, seed);
        let e = run.initial.q.small_angle_error(&run.truth[0].q);
        ss += e.component_mul(&e);
        assert_eq!(run.initial.bias_rad_s, Vector3::zeros());
        assert_eq!(run.initial.sigma_att_rad, Vector3::repeat(0.1 * DEG));
        assert_eq!(
            run.initial.bias_sigma_rad_s,
            Vector3::repeat(0.2 * DEG_PER_HR)
        );
        assert!(!run.initial.uniform_attitude);
    }
    // q_init ⊗ q_true⁻¹ is the drawn error δq_err: 1σ 0.1° per axis.
    let rms = (ss / n as f64).map(f64::sqrt) / DEG;
    for i in 0..3 {
        assert!((rms[i] / 0.1 - 1.0).abs() < 0.15, "rms {rms}");
    }
}

#[test]
fn magnetometer_leo_initial_error_has_the_euler_magnitudes() {
    let p = ScenarioParams::default_for(ScenarioName::MagnetometerLeo);
    let mut signs_seen = std::collections::HashSet::new();
    for seed in 0..64 {
        let mut short = p.clone();
        short.duration_s = 20.0;
        let run = simulate(&short, seed);
        let q_true = run.truth[0].q;
        // δq_err = q_init ⊗ q_true⁻¹.
        let dq = run.initial.q.compose(&q_true.inverse());
        let (r, pi, y) = euler_321(&dq);
        assert!((r.abs() - 50.0 * DEG).abs() < 1e-9, "roll {}", r / DEG);
        assert!((pi.abs() - 50.0 * DEG).abs() < 1e-9, "pitch {}", pi / DEG);
        assert!((y.abs() - 160.0 * DEG).abs() < 1e-9, "yaw {}", y / DEG);
        signs_seen.insert((r > 0.0, pi > 0.0, y > 0.0));
        // Bias within ±20 deg/hr, estimate starts at zero.
        assert!(run.truth[0].bias_rad_s.amax() <= 20.0 * DEG_PER_HR);
        assert_eq!(run.initial.bias_rad_s, Vector3::zeros());
        assert_eq!(run.initial.sigma_att_rad, Vector3::repeat(90.0 * DEG));
    }
    assert_eq!(signs_seen.len(), 8);
}

#[test]
fn lost_in_space_initial_attitude_is_uniform_and_bias_uniform() {
    let mut p = ScenarioParams::default_for(ScenarioName::LostInSpace);
    p.duration_s = 3.0;
    let n = 2000;
    let (mut sum_angle, mut sum_bias, mut max_bias) = (0.0, Vector3::zeros(), 0.0f64);
    let mut ss_bias = 0.0;
    for seed in 0..n {
        let run = simulate(&p, seed);
        assert!(run.initial.uniform_attitude);
        assert_eq!(
            run.initial.sigma_att_rad,
            Vector3::repeat(std::f64::consts::PI)
        );
        sum_angle += run.initial.q.compose(&run.truth[0].q.inverse()).angle();
        let b = run.truth[0].bias_rad_s;
        sum_bias += b;
        ss_bias += b.norm_squared();
        max_bias = max_bias.max(b.amax());
    }
    // Angle of a uniform rotation: mean π/2 + 2/π.
    let mean_angle = sum_angle / n as f64;
    let expected = std::f64::consts::FRAC_PI_2 + 2.0 / std::f64::consts::PI;
    assert!(
        (mean_angle - expected).abs() < 0.05,
        "{mean_angle} vs {expected}"
    );
    // Uniform in ±5 deg/hr: std max/√3.
    let max = 5.0 * DEG_PER_HR;
    assert!(max_bias <= max && max_bias > 0.95 * max);
    assert!((sum_bias / n as f64).amax() < 0.1 * max);
    let std = (ss_bias / (3.0 * n as f64)).sqrt();
    assert!((std / (max / 3f64.sqrt()) - 1.0).abs() < 0.05);
}

#[test]
fn sensor_streams_are_independent() {
    // Adding the sun sensor does not change the magnetometer noise or the gyro.
    let p = ScenarioParams::default_for(ScenarioName::LostInSpace);
    let mut mag_only = p.clone();
    mag_only.sensors.sun_sensor = None;
    let (a, b) = (simulate(&p, 9), simulate(&mag_only, 9));
    let mags = |run: &SimulatedRun| -> Vec<VectorObservation> {
        sets(run)
            .flat_map(|s| s.observations.iter())
            .filter(|o| o.sensor.as_deref() == Some("mag"))
            .cloned()
            .collect()
    };
    assert_eq!(mags(&a), mags(&b));
    assert_eq!(gyros(&a).collect::<Vec<_>>(), gyros(&b).collect::<Vec<_>>());
    assert_eq!(a.truth, b.truth);
    assert_eq!(a.initial, b.initial);
}

#[test]
fn invalid_parameters_are_reported_not_panicked() {
    let base = ScenarioParams::default_for(ScenarioName::MagnetometerLeo);
    let cases: Vec<fn(&mut ScenarioParams)> = vec![
        |p| p.dt_gyro_s = 0.0,
        |p| p.dt_gyro_s = f64::NAN,
        |p| p.dt_obs_s = 15.0,
        |p| p.dt_obs_s = 3.0,
        |p| p.duration_s = -1.0,
        |p| p.duration_s = 5.0,
        |p| p.duration_s = f64::INFINITY,
        |p| p.duration_s = 1e12,
        |p| p.gyro.sigma_v = -1.0,
        |p| {
            p.true_bias_rad_s = BiasSpec::UniformPerAxis {
                max_rad_s: f64::NAN,
            }
        },
        |p| p.filter_init_sigma_att_rad[1] = 0.0,
        |p| p.convergence_threshold_rad = 0.0,
        |p| p.sensors.magnetometer = Some(MagnetometerModel { sigma_nt: 0.0 }),
        |p| p.orbit.altitude_m = -7.0e6,
        |p| {
            p.motion = TruthMotion::ConstantRate {
                q0: Quaternion::new(0.0, 0.0, 0.0, 0.0),
                omega_rad_s: Vector3::zeros(),
            }
        },
        |p| {
            p.sensors.sun_sensor = Some(SunSensor::default());
            p.sun_direction_eci = Vector3::zeros();
        },
    ];
    for (i, f) in cases.iter().enumerate() {
        let mut p = base.clone();
        f(&mut p);
        assert!(p.validate().is_err(), "case {i}");
        assert!(try_simulate(&p, 1).is_err(), "case {i}");
        let run = simulate(&p, 1);
        assert!(
            run.truth.is_empty() && run.measurements.is_empty(),
            "case {i}"
        );
    }
    // A gyro-only run is fine.
    let mut p = base.clone();
    p.sensors = ScenarioSensors::default();
    let run = simulate(&p, 1);
    assert_eq!(sets(&run).count(), 0);
    assert_eq!(gyros(&run).count(), 2880);
}
