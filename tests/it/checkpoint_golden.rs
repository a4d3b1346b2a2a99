//! Golden checkpoints: files written once by an earlier build (`tests/data/checkpoints/`) must be read
//! back by every later build, and written back byte for byte the same. A change of the checkpoint
//! format fails here instead of silently orphaning the checkpoints of a running service: bump
//! `persist::VERSION`, keep the old files (a checkpoint of another version is refused with a clear
//! message, and the service counts it as skipped: `checkpoints_of_another_version_are_refused`, which
//! reads the files of formats 3 to 8 kept here), and add the new version's files with
//!
//!     ATTITUDE_WRITE_GOLDEN=1 cargo test --release --test it checkpoint_golden:: -- --test-threads=1
//!
//! Three vehicles: a particle filter fed raw IMU samples (particles, weights, RNG, the IMU pipeline's
//! low-passes, rest detector and field model), an MEKF fed gyro and named vector sensors (gate
//! counts, the sensor models' state) and, from format 5, an SGHQF (level 3, averaged fiducial) fed the
//! same, saved between a propagation and an update (its propagated points).

use crate::common::{imu_preset, repo, scratch_dir};
use attitude_service::attitude::Quaternion;
use attitude_service::filters::FilterState;
use attitude_service::sensors::{
    Aspect, GyroSample, ImuSample, Measurement, ObservationSet, VectorObservation,
};
use attitude_service::service::config::{self, Policy};
use attitude_service::service::persist::{self, SavedCounters};
use attitude_service::vehicle::{Event, VehicleState};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::path::PathBuf;

const VERSION: u32 = 10;
/// Formats before this one, kept to show they are refused: 3 (bincode of the core's own types), 4
/// (no SGHQF, no sparse-grid level), 5 (no gyro channel, datasheet or measured noise), 6 (no
/// driver's repeats or filled holes in the IMU pipeline), 7 (no datasheet output stage), 8 (no
/// low-pass of the rest detector's deviations) and 9 (no north variance of an unconfirmed field),
/// each with the two vehicles they all had.
const OLD_VERSIONS: [u32; 7] = [3, 4, 5, 6, 7, 8, 9];
const OLD_NAMES: [&str; 2] = ["qpf-imu", "mekf-vectors"];

fn dir() -> PathBuf {
    repo().join("tests/data/checkpoints")
}

fn truth(t: f64) -> Quaternion {
    Quaternion::from_rotation_vector(&Vector3::new(0.2 * t.sin(), 0.1 * t, 0.3 * (0.5 * t).cos()))
}

/// A slowly turning body seen by an IMU at 100 Hz (noise-free: the state is what matters here).
fn imu(k: usize) -> ImuSample {
    let t = k as f64 * 0.01;
    let (q0, q1) = (truth(t - 0.01), truth(t));
    let w = q0.inverse().compose(&q1).to_rotation_vector() / 0.01;
    let a = q1.attitude_matrix();
    let field = Vector3::new(0.0, 20.0, -40.0);
    ImuSample {
        t_s: t,
        gyr_rad_s: w,
        acc_m_s2: a * Vector3::new(0.0, 0.0, 9.81),
        mag: Some(a * field + Vector3::new(3.0, -2.0, 1.0) * (k % 3) as f64 * 0.01),
    }
}

fn gyro(k: usize) -> Measurement {
    let t = k as f64 * 0.1;
    let w = truth(t)
        .inverse()
        .compose(&truth(t + 0.1))
        .to_rotation_vector()
        / 0.1;
    Measurement::Gyro(GyroSample {
        t_s: t,
        omega_body_rad_s: w + Vector3::new(1e-4, -2e-4, 5e-5),
    })
}

fn vectors(k: usize) -> Measurement {
    let t = k as f64 * 0.1;
    let a = truth(t).attitude_matrix();
    let obs = |r: Vector3<f64>, sensor: &str, sigma: f64| VectorObservation {
        body: a * r,
        reference: r,
        sigma,
        sensor: Some(sensor.into()),
        aspect: Aspect::Full,
    };
    let mut observations = vec![
        obs(Vector3::new(0.0, 0.0, 9.81), "acc", 0.5),
        obs(Vector3::new(0.0, 20.0, -40.0), "mag", 3.0),
        obs(Vector3::new(1.0, 2.0, 3.0).normalize(), "star", 1e-3),
    ];
    if k % 7 == 3 {
        // An outlier for the gate.
        observations[2].body = -observations[2].body;
    }
    Measurement::Vectors(ObservationSet {
        t_s: t,
        observations,
    })
}

/// The vehicle of golden file `name` after the first half of its inputs, and the inputs after them.
fn vehicle(name: &str) -> (VehicleState, Policy, Vec<Measurement>) {
    let (mut f, mut p) = imu_preset();
    // The SGHQF's half ends on a gyro sample, after which its propagated points are kept.
    let extra = usize::from(name == "sghqf-vectors");
    let inputs: Vec<Measurement> = match name {
        "qpf-imu" => {
            f.filter.spec = "qpf:average".parse().unwrap();
            f.filter.particles = 64;
            (1..=400).map(|k| Measurement::Imu(imu(k))).collect()
        }
        "mekf-vectors" | "sghqf-vectors" => {
            // The defaults, with an accelerometer and a magnetometer modelled (their state is saved).
            let text = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/config/default.json5")).replace(
                "    sensors: {},",
                r#"    sensors: { acc: { kind: "gravity" }, mag: { kind: "field", heading_only: true } },"#,
            );
            let c = config::parse(&text, "default with sensor models").unwrap();
            assert!(!c.service.policy.sensor_models.is_empty());
            f = c.service.default_filter.clone();
            p = c.service.policy.clone();
            if name == "sghqf-vectors" {
                f.filter.spec = "sghqf:average".parse().unwrap();
                f.filter.level = 3;
            }
            (0..60).flat_map(|k| [gyro(k), vectors(k)]).collect()
        }
        _ => unreachable!(),
    };
    let mut v = VehicleState::new(&format!("golden-{name}"), f);
    let (first, rest) = inputs.split_at(inputs.len() / 2 + extra);
    let mut events = Vec::new();
    for m in first {
        let _ = v.on_measurement(m.clone(), 0.0, &p, &mut events);
    }
    // (Nothing held: a restored window's wall times are reset, which a byte comparison would see.)
    v.flush_all(&p, &mut events);
    (v, p, rest.to_vec())
}

fn counters() -> SavedCounters {
    SavedCounters {
        received: 123,
        processed: 120,
        rejected: 3,
        rejected_by_code: BTreeMap::from([("duplicate".to_string(), 3)]),
    }
}

fn continue_with(v: &mut VehicleState, p: &Policy, inputs: &[Measurement]) -> usize {
    let mut events = Vec::new();
    for m in inputs {
        let _ = v.on_measurement(m.clone(), 0.0, p, &mut events);
    }
    v.flush_all(p, &mut events);
    events
        .iter()
        .filter(|e| matches!(e, Event::Estimate(_)))
        .count()
}

const NAMES: [&str; 3] = ["qpf-imu", "mekf-vectors", "sghqf-vectors"];

#[test]
fn golden_checkpoints_read_back_and_write_back_the_same() {
    let write = std::env::var_os("ATTITUDE_WRITE_GOLDEN").is_some();
    for name in NAMES {
        let path = dir().join(format!("v{VERSION}-{name}.ckpt"));
        if write {
            let (v, _, _) = vehicle(name);
            std::fs::create_dir_all(dir()).unwrap();
            std::fs::write(&path, persist::encode(&v, &counters()).unwrap()).unwrap();
        }
        let bytes = std::fs::read(&path).unwrap_or_else(|e| {
            panic!(
                "{}: {e}; the golden checkpoints are part of the repository",
                path.display()
            )
        });
        let c = persist::decode(&bytes).unwrap_or_else(|e| {
            panic!(
                "{}: {e}. The checkpoint format changed: bump persist::VERSION and add this \
                 version's golden files (see the header of tests/it/checkpoint_golden.rs)",
                path.display()
            )
        });
        assert_eq!(c.state.id(), format!("golden-{name}"));
        assert_eq!(c.counters, counters());
        assert!(c.state.is_tracking(), "{name}");
        assert!(c.state.seq() > 0, "{name}");
        assert_eq!(
            persist::encode(&c.state, &c.counters).unwrap(),
            bytes,
            "{name}: written back differently: the format changed (see the header of this file)"
        );
        // The restored vehicle goes on: its estimates continue from where it stopped.
        let (_, p, rest) = vehicle(name);
        let mut v = c.state;
        let seq = v.seq();
        let published = continue_with(&mut v, &p, &rest);
        assert!(published > 0, "{name}");
        assert_eq!(v.seq(), seq + published as u64, "{name}");
        let e = v.estimate().unwrap().estimate;
        assert!(
            e.q.is_finite() && e.covariance.iter().all(|x| x.is_finite()),
            "{name}"
        );
    }
}

#[test]
fn a_checkpoint_restored_continues_like_the_vehicle_that_wrote_it() {
    for name in NAMES {
        let (mut a, p, rest) = vehicle(name);
        let mut b = persist::decode(&persist::encode(&a, &counters()).unwrap())
            .unwrap()
            .state;
        continue_with(&mut a, &p, &rest);
        continue_with(&mut b, &p, &rest);
        assert_eq!(a.estimate(), b.estimate(), "{name}");
    }
}

#[test]
fn checkpoints_of_another_version_are_refused() {
    assert_eq!(persist::VERSION, VERSION);
    let bytes = std::fs::read(dir().join(format!("v{VERSION}-qpf-imu.ckpt"))).unwrap();
    let newer = {
        let mut b = bytes.clone();
        b[8..12].copy_from_slice(&(VERSION + 1).to_le_bytes());
        b
    };
    assert_eq!(
        persist::decode(&newer)
            .err()
            .expect("a newer version is refused"),
        format!(
            "format version {}, this service reads {VERSION}",
            VERSION + 1
        )
    );
    // The real files of the previous format, through the directory loader: reported with the reason
    // and skipped, the good one restored.
    let tmp = scratch_dir("golden");
    std::fs::create_dir_all(&tmp).unwrap();
    for old_version in OLD_VERSIONS {
        for name in OLD_NAMES {
            let old = std::fs::read(dir().join(format!("v{old_version}-{name}.ckpt"))).unwrap();
            assert_eq!(old[8..12], old_version.to_le_bytes());
            std::fs::write(tmp.join(format!("golden-v{old_version}-{name}.ckpt")), old).unwrap();
        }
    }
    std::fs::write(tmp.join("golden-qpf-imu.ckpt"), &bytes).unwrap();
    let (good, bad) = persist::load_dir(&tmp).unwrap();
    std::fs::remove_dir_all(&tmp).unwrap();
    assert_eq!(good.len(), 1);
    assert_eq!(bad.len(), OLD_VERSIONS.len() * OLD_NAMES.len());
    for b in &bad {
        let b = b.to_string();
        assert!(
            OLD_VERSIONS.iter().any(|old| b.contains(&format!(
                "format version {old}, written by an earlier build: this build reads \
                 format {VERSION} only, the vehicle starts afresh"
            ))),
            "{b}"
        );
    }
}

/// A checkpoint that decodes but holds a state no filter could be in (a damaged or hand-edited file
/// with a valid CRC) is refused with the reason, never restored into a filter that fails later.
#[test]
fn a_damaged_state_is_refused_with_its_reason() {
    for name in NAMES {
        let (v, _, _) = vehicle(name);
        let mut s = v.snapshot();
        let Some(f) = s.filter.as_mut() else {
            panic!("{name} is tracking")
        };
        let reason = match f {
            FilterState::Mekf(_, m) => {
                m.q.w *= 2.0;
                "MEKF attitude is not a unit quaternion"
            }
            FilterState::Qpf(_, q) => {
                q.cloud.w[0] += 0.5;
                "particle weights are not normalised"
            }
            FilterState::Sghqf(_, s) => {
                s.q_ref.w *= 2.0;
                "SGHQF chart centre is not a unit quaternion"
            }
            FilterState::Usque(..) => unreachable!(),
        };
        let e = VehicleState::restore(s).err().expect("refused");
        assert!(e.contains(reason), "{name}: {e}");
        // And the snapshot of a good vehicle restores to the same vehicle.
        let again = VehicleState::restore(v.snapshot()).unwrap();
        assert_eq!(again.snapshot(), v.snapshot(), "{name}");
    }
}
