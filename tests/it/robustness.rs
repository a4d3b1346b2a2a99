//! Robustness of one vehicle without the network: the reorder window and the time checks, gyro gaps
//! (the 3σ still holds the truth), the innovation gate and its way back, filter health, checkpoints
//! (a restored vehicle continues bit for bit), corrupt checkpoint files.

use crate::common::{default_policy as policy, estimates, scratch_dir};
use attitude_service::attitude::Quaternion;
use attitude_service::filters::{build_filter, FilterConfig, FilterKind, FilterSpec, InitialState};
use attitude_service::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use attitude_service::service::config::{Policy, ServiceConfig, VehicleFilterConfig};
use attitude_service::service::persist::{self, SavedCounters};
use attitude_service::vehicle::{Event, Key, Stream, VehicleState};
use attitude_service::wire::{EstimateMsg, RejectCode};
use nalgebra::Vector3;

const STAR_SIGMA: f64 = 1e-4;

fn config(kind: &str, particles: usize) -> VehicleFilterConfig {
    let mut c = ServiceConfig::default().default_filter;
    c.filter.spec = kind.parse().unwrap();
    c.filter.particles = particles;
    c
}

/// Three star directions fixed in the reference frame.
fn refs() -> [Vector3<f64>; 3] {
    [
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.0, 1.0, 0.0),
        Vector3::new(0.0, 0.0, 1.0),
    ]
}

fn set_at(t: f64, truth: &Quaternion, sensor: &str) -> Measurement {
    let a = truth.attitude_matrix();
    Measurement::Vectors(ObservationSet {
        t_s: t,
        observations: refs()
            .iter()
            .map(|r| VectorObservation {
                body: a * r,
                reference: *r,
                sigma: STAR_SIGMA,
                sensor: Some(sensor.into()),
                aspect: Aspect::Full,
            })
            .collect(),
    })
}

fn gyro(t: f64, w: Vector3<f64>) -> Measurement {
    Measurement::Gyro(GyroSample {
        t_s: t,
        omega_body_rad_s: w,
    })
}

fn rejections(events: &[Event]) -> Vec<RejectCode> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Rejected(_, r) => Some(r.code),
            _ => None,
        })
        .collect()
}

/// Feeds `inputs` (all at wall time 0) and returns every event; panics on a rejection at arrival.
fn feed(v: &mut VehicleState, p: &Policy, inputs: Vec<Measurement>) -> Vec<Event> {
    let mut out = Vec::new();
    for m in inputs {
        v.on_measurement(m, 0.0, p, &mut out)
            .unwrap_or_else(|r| panic!("refused: {r:?}"));
    }
    out
}

fn q_of(e: &EstimateMsg) -> [f64; 4] {
    [e.q.w, e.q.x, e.q.y, e.q.z]
}

#[test]
fn reordered_streams_are_used_in_time_order() {
    let p = policy();
    let truth = Quaternion::IDENTITY;
    let w = Vector3::new(0.0, 0.0, 1e-3);
    let arrival = vec![
        set_at(0.0, &truth, "st"),
        gyro(0.0, w),
        gyro(0.5, w),
        set_at(1.0, &truth, "st"), // ahead of the gyro stream: waits
        gyro(0.8, w),
        gyro(1.0, w),
        gyro(1.5, w),
        set_at(2.0, &truth, "st"),
        gyro(2.0, w),
    ];
    // In processing order: by time, the gyro before the set of the same instant.
    let mut sorted = arrival.clone();
    sorted.sort_by(|a, b| Key::of(a).partial_cmp(&Key::of(b)).unwrap());

    let mut a = VehicleState::new("a", config("mekf", 0));
    let ea = feed(&mut a, &p, arrival.clone());
    let no_window = Policy {
        reorder_window_s: 0.0,
        ..p.clone()
    };
    let mut b = VehicleState::new("b", config("mekf", 0));
    let eb = feed(&mut b, &no_window, sorted);
    assert!(rejections(&ea).is_empty(), "{:?}", rejections(&ea));
    let (ea, eb) = (estimates(&ea), estimates(&eb));
    assert_eq!(ea.len(), 3);
    assert_eq!(eb.len(), 3);
    for (x, y) in ea.iter().zip(&eb) {
        assert_eq!(x.t, y.t);
        assert_eq!(q_of(x), q_of(y), "the window gives the time-ordered result");
        assert_eq!(x.cov, y.cov);
    }

    // Without a window the late gyro sample (0.8 after the set at 1) is fused by a replay: the
    // estimates published again, with the seq of those they replace, are the time-ordered ones.
    let mut d = VehicleState::new("d", config("mekf", 0));
    let ed = estimates(&feed(&mut d, &no_window, arrival.clone()));
    // (Four: the gyro at 0.8 s after the set at 1 s, and each gyro sample arriving after the set of
    // its own instant, which it precedes in processing order.)
    assert_eq!(d.late_fused(), 4);
    assert!(ed.len() > 3 && ed.iter().any(|e| e.diagnostics.replayed));
    let mut last = std::collections::BTreeMap::new();
    for e in ed {
        last.insert(e.seq, e);
    }
    assert_eq!(last.len(), 3);
    for (x, y) in last.values().zip(&eb) {
        assert_eq!((x.t, q_of(x), x.cov), (y.t, q_of(y), y.cov));
    }

    // Without a window and without the history (time.max_lag_s = 0) it is refused.
    let neither = Policy {
        max_lag_s: 0.0,
        ..no_window.clone()
    };
    let mut c = VehicleState::new("c", config("mekf", 0));
    let mut out = Vec::new();
    let mut codes = Vec::new();
    for m in arrival {
        if let Err(r) = c.on_measurement(m, 0.0, &neither, &mut out) {
            codes.push(r.code);
        }
    }
    assert_eq!(codes, vec![RejectCode::OutOfOrder]);
}

#[test]
fn a_held_sample_is_released_by_wall_time() {
    let p = policy();
    let truth = Quaternion::IDENTITY;
    let mut v = VehicleState::new("w", config("mekf", 0));
    let mut out = feed(
        &mut v,
        &p,
        vec![gyro(0.0, Vector3::zeros()), set_at(0.0, &truth, "st")],
    );
    assert_eq!(estimates(&out).len(), 1);
    out.clear();
    v.on_measurement(set_at(1.0, &truth, "st"), 10.0, &p, &mut out)
        .unwrap();
    assert_eq!(v.held(), 1, "waits for the gyro stream");
    v.on_tick(10.0 + p.reorder_window_s / 2.0, &p, &mut out);
    assert_eq!(v.held(), 1);
    v.on_tick(10.0 + p.reorder_window_s * 1.01, &p, &mut out);
    assert_eq!(v.held(), 0);
    assert_eq!(estimates(&out).len(), 1);
}

#[test]
fn duplicates_old_samples_and_jumps_have_their_own_codes() {
    let p = policy();
    let truth = Quaternion::IDENTITY;
    let mut v = VehicleState::new("d", config("mekf", 0));
    let w = Vector3::new(0.0, 1e-3, 0.0);
    feed(
        &mut v,
        &p,
        vec![gyro(0.0, w), set_at(0.0, &truth, "st"), gyro(10.0, w)],
    );
    let mut out = Vec::new();
    let mut code = |v: &mut VehicleState, m: Measurement| {
        v.on_measurement(m, 0.0, &p, &mut out).err().map(|r| r.code)
    };
    assert_eq!(code(&mut v, gyro(10.0, w)), Some(RejectCode::Duplicate));
    assert_eq!(
        code(&mut v, gyro(10.0, Vector3::zeros())),
        Some(RejectCode::Duplicate),
        "one rate per instant"
    );
    assert_eq!(code(&mut v, set_at(10.0, &truth, "st")), None);
    assert_eq!(
        code(&mut v, set_at(10.0, &truth, "st")),
        Some(RejectCode::Duplicate)
    );
    assert_eq!(
        code(&mut v, set_at(10.0, &truth, "sun")),
        None,
        "another set at the same time is not a duplicate"
    );
    assert_eq!(code(&mut v, gyro(20.0, w)), None);
    assert_eq!(code(&mut v, set_at(20.0, &truth, "st")), None);
    assert_eq!(code(&mut v, gyro(5.0, w)), Some(RejectCode::OutOfOrder));
    // A single stray time far ahead does not move the vehicle...
    let far = 20.0 + p.max_jump_s + 100.0;
    assert_eq!(code(&mut v, gyro(far, w)), Some(RejectCode::TimeJump));
    assert_eq!(code(&mut v, gyro(21.0, w)), None);
    // ... three consistent samples beyond the jump (a real gap) are accepted from the third on.
    assert_eq!(code(&mut v, gyro(far, w)), Some(RejectCode::TimeJump));
    assert_eq!(code(&mut v, gyro(far + 1.0, w)), Some(RejectCode::TimeJump));
    assert_eq!(code(&mut v, gyro(far + 2.0, w)), None);
    assert_eq!(code(&mut v, gyro(far + 3.0, w)), None);
}

/// Truth with a constant angular acceleration `acc` from `t0` on; the gyro stops at `t0`.
fn gap_error_over_sigma(kind: &str, accel_sigma: f64) -> (f64, Option<f64>, u64) {
    let mut cfg = FilterConfig::new(kind.parse::<FilterSpec>().unwrap(), GyroNoise::standard());
    cfg.particles = 2000;
    cfg.gap.accel_sigma_rad_s2 = accel_sigma;
    let init = InitialState {
        t_s: Some(0.0),
        q: Quaternion::IDENTITY,
        sigma_att_rad: Vector3::repeat(1e-4),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(1e-9),
        uniform_attitude: false,
        covariance: None,
    };
    let mut f = build_filter(&cfg, &init, 7).unwrap();
    let w0 = Vector3::new(0.01, -0.02, 0.005);
    let mut truth = Quaternion::IDENTITY;
    let dt = 0.1;
    let mut t: f64 = 0.0;
    // 10 s of gyro at 10 Hz with the truth's rate (a noiseless gyro: the error is the gap's).
    while t < 10.0 - 1e-9 {
        f.process(&gyro(t, w0)).unwrap();
        truth = truth.propagate(&w0, dt);
        t += dt;
    }
    f.process(&gyro(t, w0)).unwrap();
    // 30 s without gyro while the rate changes by 1e-4 rad/s² per axis.
    let acc = Vector3::new(1e-4, -1e-4, 1e-4);
    let t0 = t;
    let steps = 300;
    for k in 0..steps {
        let tm = (k as f64 + 0.5) * dt;
        truth = truth.propagate(&(w0 + acc * tm), dt);
    }
    f.advance_to(t0 + steps as f64 * dt).unwrap();
    let e = f.estimate();
    let err = truth.small_angle_error(&e.q);
    let s = e.sigma_att_rad();
    let worst = (0..3).map(|i| err[i].abs() / s[i]).fold(0.0, f64::max);
    (worst, e.diagnostics.gyro_gap_s, e.diagnostics.gyro_gaps)
}

#[test]
fn a_gyro_gap_inflates_the_uncertainty_honestly() {
    for kind in ["mekf", "usque", "qpf"] {
        let (worst, gap, gaps) = gap_error_over_sigma(kind, 1e-4);
        assert!(worst < 3.0, "{kind}: error {worst:.2}σ after a 30 s gap");
        let gap = gap.expect("the gap is flagged");
        assert!((gap - 30.0).abs() < 1e-6, "{kind}: gap {gap}");
        assert_eq!(gaps, 1, "{kind}");
        // Without the inflation the same gap would be dishonest: the test can fail.
        let (worst, _, _) = gap_error_over_sigma(kind, 0.0);
        assert!(worst > 10.0, "{kind}: {worst:.1}σ without inflation");
    }
}

/// The gate's threshold is the exact χ²₃ quantile of `gate.probability` (tables: 21.107 at the default
/// 0.9999, 16.266 at 0.999); 0 turns a sensor's gate off.
#[test]
fn the_gate_threshold_is_the_chi_square_quantile_of_its_probability() {
    let p = policy();
    let t = p.gate_threshold.expect("the gate is on by default");
    assert!((t - 21.1075).abs() < 1e-3, "default threshold {t}");
    let c = attitude_service::service::config::parse(
        r#"{ service: { sensors: { mag: { gate_probability: 0.999 }, sun: { gate_probability: 0 } } } }"#,
        "test",
    )
    .unwrap();
    let mag = c.service.policy.sensor_gate["mag"].expect("mag is gated");
    assert!((mag - 16.2662).abs() < 1e-3, "mag threshold {mag}");
    assert_eq!(c.service.policy.sensor_gate["sun"], None);
}

#[test]
fn the_gate_refuses_outliers_per_sensor_and_a_wrong_filter_reinitialises() {
    let p = policy();
    let truth = Quaternion::from_rotation_vector(&Vector3::new(0.1, 0.2, -0.3));
    let mut v = VehicleState::new("g", config("mekf", 0));
    let mut inputs = vec![gyro(0.0, Vector3::zeros())];
    for k in 0..20 {
        inputs.push(set_at(k as f64, &truth, "st"));
        inputs.push(gyro(k as f64 + 0.5, Vector3::zeros()));
    }
    feed(&mut v, &p, inputs);
    // One observation 5° off among good ones: gated, the others used.
    let a = truth.attitude_matrix();
    let off = Quaternion::from_rotation_vector(&Vector3::new(0.0, 0.0, 5f64.to_radians()));
    let mut obs = match set_at(20.0, &truth, "st") {
        Measurement::Vectors(s) => s.observations,
        _ => unreachable!(),
    };
    obs.push(VectorObservation {
        body: off.attitude_matrix() * a * Vector3::new(1.0, 1.0, 0.0).normalize(),
        reference: Vector3::new(1.0, 1.0, 0.0).normalize(),
        sigma: STAR_SIGMA,
        sensor: Some("sun".into()),
        aspect: Aspect::Full,
    });
    let out = feed(
        &mut v,
        &p,
        vec![
            Measurement::Vectors(ObservationSet {
                t_s: 20.0,
                observations: obs,
            }),
            gyro(20.0, Vector3::zeros()),
        ],
    );
    let e = estimates(&out)[0].clone();
    assert_eq!(e.diagnostics.gate["sun"].gated, 1);
    assert_eq!(e.diagnostics.gate["sun"].accepted, 0);
    assert_eq!(e.diagnostics.gate["st"].gated, 0);
    // (The first set started the filter: it was not gated.)
    assert_eq!(e.diagnostics.gate["st"].accepted, 20 * 3);
    let err = truth.small_angle_error(&Quaternion::new(e.q.x, e.q.y, e.q.z, e.q.w));
    assert!(
        err.norm() < 1e-3,
        "the outlier did not pull the estimate: {err}"
    );

    // The vehicle really turned by 90° (the filter is wrong, not the star tracker): every set is
    // gated until `reinit_after` in a row, then the vehicle re-initialises from the set.
    let turned =
        Quaternion::from_rotation_vector(&Vector3::new(0.0, std::f64::consts::FRAC_PI_2, 0.0))
            .compose(&truth);
    let mut last = None;
    for k in 0..p.gate_reinit_after {
        let t = 21.0 + k as f64;
        let out = feed(
            &mut v,
            &p,
            vec![set_at(t, &turned, "st"), gyro(t, Vector3::zeros())],
        );
        last = Some(estimates(&out)[0].clone());
    }
    let e = last.unwrap();
    assert_eq!(e.diagnostics.reinits.get("gate"), Some(&1));
    assert_eq!(e.diagnostics.consecutive_gated, 0);
    let err = turned.small_angle_error(&Quaternion::new(e.q.x, e.q.y, e.q.z, e.q.w));
    assert!(err.norm() < 1e-3, "tracks the new attitude: {err}");
}

#[test]
fn failed_steps_roll_back_and_repeated_failures_reinitialise_from_the_last_good_estimate() {
    let p = policy();
    let truth = Quaternion::IDENTITY;
    let mut v = VehicleState::new("h", config("mekf", 0));
    let good = estimates(&feed(
        &mut v,
        &p,
        vec![
            gyro(0.0, Vector3::zeros()),
            set_at(0.0, &truth, "st"),
            gyro(1.0, Vector3::zeros()),
        ],
    ))[0]
        .clone();
    // σ = 1e-300 makes the innovation covariance singular (σ² underflows): the MEKF refuses it.
    let poison = |t: f64| {
        let Measurement::Vectors(mut s) = set_at(t, &truth, "st") else {
            unreachable!()
        };
        for o in &mut s.observations {
            o.sigma = 1e-300;
        }
        Measurement::Vectors(s)
    };
    let mut all = Vec::new();
    for k in 0..p.reinit_after_failures {
        let out = feed(
            &mut v,
            &p,
            vec![
                poison(1.0 + k as f64),
                gyro(1.5 + k as f64, Vector3::zeros()),
            ],
        );
        assert_eq!(rejections(&out), vec![RejectCode::FilterError]);
        all.extend(out);
    }
    let e = estimates(&all);
    assert_eq!(
        e.len(),
        1,
        "the re-initialised filter's estimate is published"
    );
    let e = e[0].clone();
    assert_eq!(e.diagnostics.reinits.get("health"), Some(&1));
    assert_eq!(e.diagnostics.rollbacks, p.reinit_after_failures as u64);
    assert!(e.q.w.is_finite() && e.cov.iter().flatten().all(|x| x.is_finite()));
    // From the last good attitude, with its 1σ inflated (at least 1°).
    assert!((e.q.w - good.q.w).abs() < 1e-9);
    assert!(e.sigma_deg.iter().all(|s| *s >= 1.0 - 1e-9));
    // And it keeps tracking.
    let out = feed(
        &mut v,
        &p,
        vec![set_at(10.0, &truth, "st"), gyro(10.0, Vector3::zeros())],
    );
    assert!(rejections(&out).is_empty());
    assert!(estimates(&out)[0].sigma_deg[0] < 0.1);
}

fn run_inputs(
    v: &mut VehicleState,
    p: &Policy,
    from: usize,
    to: usize,
    truth: &Quaternion,
) -> Vec<EstimateMsg> {
    let w = Vector3::new(1e-3, -2e-3, 5e-4);
    let mut inputs = Vec::new();
    for k in from..to {
        let t = k as f64;
        inputs.push(gyro(t, w));
        inputs.push(set_at(t, &truth.propagate(&w, t), "st"));
    }
    estimates(&feed(v, p, inputs))
}

#[test]
fn a_checkpoint_restores_the_vehicle_bit_for_bit() {
    let p = policy();
    let truth = Quaternion::from_rotation_vector(&Vector3::new(0.3, -0.1, 0.2));
    for kind in ["qpf:average", "usque", "mekf"] {
        let mut a = VehicleState::new("ck", config(kind, 300));
        run_inputs(&mut a, &p, 0, 20, &truth);
        let counters = SavedCounters {
            received: 40,
            processed: 39,
            rejected: 1,
            ..Default::default()
        };
        let bytes = persist::encode(&a, &counters).unwrap();
        let restored = persist::decode(&bytes).unwrap();
        assert_eq!(restored.counters, counters);
        let mut b = restored.state;
        assert_eq!(
            a.estimate(),
            b.estimate(),
            "{kind}: same estimate after the restore"
        );
        // Continuing both gives identical estimates: particles, weights and RNG state were saved.
        let ea = run_inputs(&mut a, &p, 20, 40, &truth);
        let eb = run_inputs(&mut b, &p, 20, 40, &truth);
        assert_eq!(ea.len(), 20);
        assert_eq!(ea, eb, "{kind}");
    }
}

#[test]
fn corrupt_or_partial_checkpoints_are_reported_and_skipped() {
    let p = policy();
    let dir = scratch_dir("ckpt");
    std::fs::create_dir_all(&dir).unwrap();
    let mut v = VehicleState::new("good", config("mekf", 0));
    run_inputs(&mut v, &p, 0, 3, &Quaternion::IDENTITY);
    let bytes = persist::encode(&v, &SavedCounters::default()).unwrap();
    persist::write_atomic(&dir, "good", &bytes).unwrap();
    // A partial write, a flipped byte, garbage, and a file under another vehicle's name.
    std::fs::write(persist::path_of(&dir, "partial"), &bytes[..bytes.len() / 2]).unwrap();
    let mut flipped = bytes.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x40;
    std::fs::write(persist::path_of(&dir, "flipped"), &flipped).unwrap();
    std::fs::write(persist::path_of(&dir, "garbage"), b"not a checkpoint").unwrap();
    std::fs::write(persist::path_of(&dir, "renamed"), &bytes).unwrap();
    let (good, bad) = persist::load_dir(&dir).unwrap();
    assert_eq!(good.len(), 1);
    assert_eq!(good[0].state.id(), "good");
    assert_eq!(bad.len(), 4, "{bad:?}");
    for (bytes, what) in [(&bytes[..10], "short"), (&flipped[..], "crc")] {
        assert!(persist::decode(bytes).is_err(), "{what}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn rejections_at_release_name_their_stream() {
    // A vector set that cannot start a vehicle is refused when it leaves the window.
    let p = policy();
    let mut v = VehicleState::new("s", config("mekf", 0));
    let mut out = Vec::new();
    let single = Measurement::Vectors(ObservationSet {
        t_s: 0.0,
        observations: vec![VectorObservation {
            body: Vector3::x(),
            reference: Vector3::x(),
            sigma: 1e-3,
            sensor: None,
            aspect: Aspect::Full,
        }],
    });
    v.on_measurement(single, 0.0, &p, &mut out).unwrap();
    // At the start the set waits (a gyro stream may still begin earlier), at most the window.
    assert!(out.is_empty());
    v.on_tick(p.reorder_window_s * 1.01, &p, &mut out);
    match &out[..] {
        [Event::Rejected(Stream::Vectors, r)] => assert_eq!(r.code, RejectCode::NotInitialized),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        config("qpf", 10).filter.spec.kind,
        FilterKind::Qpf
    ));
}
