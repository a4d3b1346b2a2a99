//! The IMU sensor models (`sensors::model`, `service.sensors.NAME.kind`): heading-only updates never
//! tilt and do correct the heading, a disturbed magnetometer is detected and held off, a large
//! accelerometer norm deviation gates the accelerometer, and the service's config reads the models
//! and refuses wrong ones. (These are the models of named sensors on `P/V/vectors`; raw samples on
//! `P/V/imu` go through `crate::ahrs`, tested in `tests/it/ahrs.rs`.)

use crate::common::estimates;
use attitude_service::attitude::Quaternion;
use attitude_service::filters::{build_filter, FilterConfig, InitialState};
use attitude_service::sensors::field::FieldModel;
use attitude_service::sensors::gravity::GravityModel;
use attitude_service::sensors::model::{SensorModel, SensorState, Verdict};
use attitude_service::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use attitude_service::service::config;
use attitude_service::vehicle::VehicleState;
use nalgebra::Vector3;

const UP: Vector3<f64> = Vector3::new(0.0, 0.0, 1.0);

fn field_ref() -> Vector3<f64> {
    let dip = 65f64.to_radians();
    Vector3::new(0.0, dip.cos(), -dip.sin()) * 50.0
}

fn heading_obs(body: Vector3<f64>) -> VectorObservation {
    VectorObservation {
        body: body.normalize(),
        reference: field_ref().normalize(),
        sigma: 0.05,
        sensor: Some("mag".into()),
        aspect: Aspect::Heading(UP),
    }
}

fn filter(spec: &str, q0: Quaternion) -> Box<dyn attitude_service::filters::AttitudeFilter> {
    let mut c = FilterConfig::new(
        spec.parse().unwrap(),
        GyroNoise {
            sigma_v: 1e-3,
            sigma_u: 1e-5,
        },
    );
    c.particles = 2000;
    let initial = InitialState {
        t_s: Some(0.0),
        q: q0,
        sigma_att_rad: Vector3::repeat(0.3),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(1e-3),
        uniform_attitude: false,
        covariance: None,
    };
    build_filter(&c, &initial, 7).unwrap()
}

fn vectors(t: f64, observations: Vec<VectorObservation>) -> Measurement {
    Measurement::Vectors(ObservationSet {
        t_s: t,
        observations,
    })
}

/// The heading angle (about up) of the estimate's error against the truth, and the tilt angle.
fn heading_and_tilt_deg(truth: &Quaternion, est: &Quaternion) -> (f64, f64) {
    // Earth-frame error: body → ref of the estimate after the truth's ref → body.
    let a_t = truth.attitude_matrix();
    let a_e = est.attitude_matrix();
    let r = a_e.transpose() * a_t; // maps ref → ref
    let tilt = (r * UP).dot(&UP).clamp(-1.0, 1.0).acos().to_degrees();
    let x = r * Vector3::x();
    let heading = x[1].atan2(x[0]).to_degrees();
    (heading, tilt)
}

#[test]
fn a_heading_only_update_never_tilts_the_mekf() {
    let truth = Quaternion::from_euler_321(0.3, 0.2, -0.1);
    // The estimate is tilted by 5° and off in heading by 20°.
    let est0 = Quaternion::from_rotation_vector(&Vector3::new(0.05, -0.06, 0.35)).compose(&truth);
    let mut f = filter("mekf", est0);
    let v_before = est0.attitude_matrix() * UP;
    // A field disturbed by 30° about a horizontal axis still only turns the estimate about the vertical.
    let disturbed = Quaternion::from_rotation_vector(&Vector3::new(0.5, 0.1, 0.0))
        .attitude_matrix()
        * (truth.attitude_matrix() * field_ref());
    for k in 1..=50 {
        f.process(&vectors(k as f64 * 0.01, vec![heading_obs(disturbed)]))
            .unwrap();
    }
    let est = f.estimate().q;
    let v_after = est.attitude_matrix() * UP;
    assert!(
        (v_after - v_before).norm() < 1e-6,
        "the body-frame vertical moved by {}",
        (v_after - v_before).norm()
    );
    // And with gravity, an undisturbed field corrects a heading error (20° about the vertical). (Without
    // gravity the tilt uncertainty, which leaks into the heading, keeps the heading gain small.)
    let clean = truth.attitude_matrix() * field_ref();
    let v_true = truth.attitude_matrix() * UP;
    let est1 = Quaternion::from_rotation_vector(&(v_true * 0.35)).compose(&truth);
    let mut g = filter("mekf", est1);
    let (h0, _) = heading_and_tilt_deg(&truth, &est1);
    let gravity = VectorObservation {
        body: v_true,
        reference: UP,
        sigma: 0.02,
        sensor: Some("acc".into()),
        aspect: Aspect::Full,
    };
    for k in 1..=200 {
        g.process(&vectors(
            k as f64 * 0.01,
            vec![gravity.clone(), heading_obs(clean)],
        ))
        .unwrap();
    }
    let (h1, tilt1) = heading_and_tilt_deg(&truth, &g.estimate().q);
    assert!(h0.abs() > 15.0 && h1.abs() < 1.0, "heading {h0}° → {h1}°");
    assert!(tilt1 < 0.1, "tilt {tilt1}°");
}

#[test]
fn the_particle_filter_corrects_the_heading_from_a_heading_only_field() {
    let truth = Quaternion::from_euler_321(0.3, 0.2, -0.1);
    let est0 = Quaternion::from_rotation_vector(&Vector3::new(0.0, 0.0, 0.3)).compose(&truth);
    let mut f = filter("qpf:average", est0);
    let a = truth.attitude_matrix();
    let gravity = VectorObservation {
        body: a * UP,
        reference: UP,
        sigma: 0.02,
        sensor: Some("acc".into()),
        aspect: Aspect::Full,
    };
    for k in 1..=100 {
        f.process(&vectors(
            k as f64 * 0.01,
            vec![gravity.clone(), heading_obs(a * field_ref())],
        ))
        .unwrap();
    }
    let (h, tilt) = heading_and_tilt_deg(&truth, &f.estimate().q);
    assert!(h.abs() < 3.0 && tilt < 3.0, "heading {h}°, tilt {tilt}°");
}

fn mag_model() -> SensorModel {
    SensorModel::Field(FieldModel {
        sigma_norm_scale: 0.0,
        norm_limit: 0.1,
        dip_limit_rad: 10f64.to_radians(),
        holdoff_s: 0.5,
        heading_only: true,
        vertical: UP,
    })
}

fn raw(body: Vector3<f64>, reference: Vector3<f64>, sensor: &str) -> VectorObservation {
    VectorObservation {
        body,
        reference,
        sigma: 0.07 * reference.norm(),
        sensor: Some(sensor.into()),
        aspect: Aspect::Full,
    }
}

#[test]
fn a_disturbed_magnetometer_is_detected_and_held_off() {
    let truth = Quaternion::from_euler_321(1.0, 0.1, 0.2);
    let a = truth.attitude_matrix();
    let m = mag_model();
    let mut state = SensorState::default();
    let clean = raw(a * field_ref(), field_ref(), "mag");
    assert!(
        matches!(m.apply(&clean, 0.0, &a, &mut state), Verdict::Use(o) if o.aspect == Aspect::Heading(UP))
    );
    // A magnet nearby: 30 % stronger.
    let strong = raw(a * field_ref() * 1.3, field_ref(), "mag");
    assert!(matches!(
        m.apply(&strong, 0.1, &a, &mut state),
        Verdict::Disturbed { .. }
    ));
    // Same norm, 20° steeper.
    let dip = 85f64.to_radians();
    let steep = Vector3::new(0.0, dip.cos(), -dip.sin()) * 50.0;
    assert!(matches!(
        m.apply(&raw(a * steep, field_ref(), "mag"), 0.2, &a, &mut state),
        Verdict::Disturbed { .. }
    ));
    // Clean again, but within 0.5 s of the last disturbance: held off; then used.
    assert_eq!(m.apply(&clean, 0.6, &a, &mut state), Verdict::HeldOff);
    assert!(matches!(
        m.apply(&clean, 0.75, &a, &mut state),
        Verdict::Use(_)
    ));
}

#[test]
fn a_large_accelerometer_norm_deviation_gates_it() {
    let m = SensorModel::Gravity(GravityModel {
        sigma_norm_scale: 10.0,
        norm_gate: 0.5,
        lowpass_s: 0.0,
    });
    let g = Vector3::new(0.0, 0.0, 9.81);
    let a = Quaternion::IDENTITY.attitude_matrix();
    let mut state = SensorState::default();
    match m.apply(&raw(g * 1.1, g, "acc"), 0.0, &a, &mut state) {
        // σ = 0.07 · (1 + 10 · 0.1).
        Verdict::Use(o) => assert!((o.sigma - 0.14).abs() < 1e-12, "{}", o.sigma),
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        m.apply(&raw(g * 2.0, g, "acc"), 0.01, &a, &mut state),
        Verdict::NormGated { .. }
    ));
}

/// The gravity low-pass carries its vector with the gyro's rotation: a body turning at a constant rate
/// under an exact accelerometer keeps the filtered vector equal to the current reading.
#[test]
fn the_gravity_lowpass_turns_with_the_body() {
    let model = GravityModel {
        sigma_norm_scale: 0.0,
        norm_gate: f64::INFINITY,
        lowpass_s: 3.0,
    };
    let mut state = SensorState::default();
    let rate = Vector3::new(0.4, -0.3, 0.2);
    let mut q = Quaternion::from_euler_321(0.1, 0.2, 0.3);
    let g = Vector3::new(0.0, 0.0, 9.81);
    let dt = 0.01;
    let mut last = Vector3::zeros();
    for k in 0..300 {
        if k > 0 {
            q = q.propagate(&rate, dt);
        }
        let a = q.attitude_matrix();
        last = model.lowpass(&mut state.lowpass, k as f64 * dt, &(a * g), &a);
        state.settle(&q);
        assert!((last - a * g).norm() < 1e-9, "step {k}");
    }
    assert!(last.norm() > 9.0);
}

/// Named sensor models for an IMU sent as vector observations (what `config/imu.json5` held before
/// `P/V/imu`).
const PRESET: &str = r#"{
  service: {
    filter: { kind: "mekf", gyro_arw_rad_sqrt_s: 1.5e-3, gyro_rrw_rad_s_sqrt_s: 3e-5, init_bias_sigma_deg_hr: 2062.6 },
    sensors: {
      acc: { kind: "gravity", lowpass_s: 3.0, sigma_norm_scale: 0.0, norm_gate: 5.0, gate_probability: 0 },
      mag: { kind: "field", sigma_norm_scale: 0.0, norm_limit: 0.1, dip_limit_deg: 10.0, holdoff_s: 0.5,
             heading_only: true, vertical: [0, 0, 1], gate_probability: 0 },
    },
  },
}"#;

#[test]
fn the_sensor_models_load_and_wrong_sensor_options_are_refused() {
    let c = config::parse(PRESET, "sensor preset").unwrap();
    let models = &c.service.policy.sensor_models;
    assert!(matches!(models.get("acc"), Some(SensorModel::Gravity(g)) if g.lowpass_s == 3.0));
    assert!(matches!(models.get("mag"), Some(SensorModel::Field(f)) if f.heading_only));
    for bad in [
        r#"{service: {sensors: {a: {kind: "gravity", heading_only: true}}}}"#,
        r#"{service: {sensors: {a: {kind: "field", lowpass_s: 1}}}}"#,
        r#"{service: {sensors: {a: {kind: "vector", norm_limit: 1}}}}"#,
        r#"{service: {sensors: {a: {kind: "sun"}}}}"#,
        r#"{service: {sensors: {a: {kind: "field", vertical: [0, 0, 0]}}}}"#,
        r#"{service: {sensors: {a: {kind: "gravity", norm_gate: -1}}}}"#,
    ] {
        assert!(config::parse(bad, "test").is_err(), "accepted {bad}");
    }
    // The message names the setting by its path (the one wording of `sensors::check`).
    for (bad, named) in [
        (
            r#"{service: {sensors: {a: {kind: "gravity", norm_gate: -1}}}}"#,
            "service.sensors.a.norm_gate",
        ),
        (
            r#"{service: {sensors: {b: {kind: "field", dip_limit_deg: -5}}}}"#,
            "service.sensors.b.dip_limit_deg",
        ),
        (
            r#"{service: {imu: {mag: {norm_limit: 0}}}}"#,
            "mag.norm_limit",
        ),
    ] {
        let e = format!("{:#}", config::parse(bad, "test").unwrap_err());
        assert!(e.contains(named), "{e}");
    }
}

/// Through one vehicle with the preset: raw readings are modelled, a disturbed magnetometer is
/// counted in the estimate's diagnostics, and the estimate follows the truth.
#[test]
fn a_vehicle_applies_the_sensor_models_and_counts_suspensions() {
    let c = config::parse(PRESET, "sensor preset").unwrap();
    let policy = c.service.policy.clone();
    let mut v = VehicleState::new("imu", c.service.default_filter.clone());
    let truth = Quaternion::from_euler_321(0.5, 0.1, -0.2);
    let a = truth.attitude_matrix();
    let g = Vector3::new(0.0, 0.0, 9.81);
    let mut out = Vec::new();
    for k in 0..400 {
        let t = k as f64 * 0.01;
        v.on_measurement(
            Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: Vector3::zeros(),
            }),
            0.0,
            &policy,
            &mut out,
        )
        .unwrap();
        // From 2 s to 2.5 s a magnet doubles the field.
        let scale = if (2.0..2.5).contains(&t) { 2.0 } else { 1.0 };
        v.on_measurement(
            Measurement::Vectors(ObservationSet {
                t_s: t,
                observations: vec![
                    raw(a * g, g, "acc"),
                    raw(a * field_ref() * scale, field_ref(), "mag"),
                ],
            }),
            0.0,
            &policy,
            &mut out,
        )
        .unwrap();
    }
    v.flush_all(&policy, &mut out);
    let last = estimates(&out).last().unwrap().clone();
    let mag = &last.diagnostics.gate["mag"];
    // 50 disturbed sets plus the hold-off of 0.5 s after the last one.
    assert!(
        mag.disturbed >= 50 + 45 && mag.disturbed <= 50 + 51,
        "{mag:?}"
    );
    let q = Quaternion::new(last.q.x, last.q.y, last.q.z, last.q.w);
    let err = truth.compose(&q.inverse()).angle().to_degrees();
    assert!(err < 1.0, "error {err}°");
}
