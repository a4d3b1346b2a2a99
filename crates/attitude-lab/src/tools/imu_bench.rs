//! `attitude-lab imu-bench`: one recorded IMU trial through a vehicle of the service, in one process
//! and without the network, timed: the Rust half of `benches/vqf_compare.py`, which runs the `vqf`
//! package on the same samples of a BROAD trial (Laidig, Caruso, Cereatti, Seel, *Data* 6(7), 2021,
//! CC-BY-4.0) and reports the speed ratio and the benchmark's errors of both.
//!
//! Nothing of the pipeline is here: the samples go as `P/V/imu` inputs through
//! [`crate::tools::imu_study::feed_trial`], i.e. the service's `VehicleState` with the sensor models of
//! [`attitude_core::ahrs`] and the configuration of a file (`config/imu.json5` by default), and every estimate
//! the vehicle publishes comes back here ([`bench_trial`]), which keeps its attitude (what the
//! estimates file holds; the study keeps the covariance and a series as well). The input is a trial
//! file of `scripts/broad-export.py` ([`crate::tools::imu_study`] documents it).
//!
//! **Estimates file**: little-endian `f64`, a header `[n]`, then per sample `[w, x, y, z]`: the estimate
//! published at that sample's time, as the Hamilton quaternion of body → East-North-Up (our
//! [`Quaternion`]'s components), `w ≥ 0`; NaN for the samples of the alignment, which have none.

use super::imu_study::{feed_trial, load_config, read_trial, Setup, StudyError, Trial};
use attitude_core::attitude::Quaternion;
use attitude_core::filters::FilterSpec;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// One timed run of [`bench_trial`].
#[derive(Clone, Debug)]
pub struct BenchRun {
    /// The attitude published at each sample's time (None where none was).
    pub attitudes: Vec<Option<Quaternion>>,
    pub published: usize,
    pub rejected: BTreeMap<String, u64>,
    /// The whole per-sample loop: the vehicle, its estimates, what is kept of them.
    pub seconds: f64,
}

/// The trial through one vehicle ([`feed_trial`]), timed, keeping the attitude of every published
/// estimate: the loop `imu-bench` times and `examples/imu_profile.rs` profiles.
pub fn bench_trial(trial: &Trial, setup: &Setup, vehicle: &str) -> BenchRun {
    let start = Instant::now();
    let mut attitudes = vec![None; trial.samples.len()];
    let fed = feed_trial(trial, setup, vehicle, |at, p| {
        if let Some(k) = at {
            attitudes[k] = Some(p.estimate.q);
        }
    });
    BenchRun {
        attitudes,
        published: fed.published,
        rejected: fed.rejected,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Writes the estimates file (see the module documentation).
pub fn write_estimates(path: &Path, estimates: &[Option<Quaternion>]) -> Result<(), StudyError> {
    let mut out = Vec::with_capacity(8 * (1 + 4 * estimates.len()));
    out.extend_from_slice(&(estimates.len() as f64).to_le_bytes());
    for q in estimates {
        let v = match q {
            Some(q) => {
                let q = q.canonical();
                [q.w, q.x, q.y, q.z]
            }
            None => [f64::NAN; 4],
        };
        for x in v {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    std::fs::write(path, out).map_err(|e| StudyError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

/// `attitude-lab imu-bench --trial FILE [--config FILE] [--set PATH=JSON]... [--filter SPEC]
/// [--estimates-out FILE]`: runs the trial through one vehicle, timed (the whole per-sample loop,
/// estimates included; file reading and writing excluded), and returns the JSON line to print:
/// `{"samples", "seconds", "samples_per_s", "published", "rejected", "filter"}`.
pub fn main_entry(
    trial: &Path,
    config: &Path,
    sets: &[String],
    filter: Option<FilterSpec>,
    estimates_out: Option<&Path>,
) -> Result<String, StudyError> {
    let service = load_config(config, sets)?;
    let setup = Setup::new(&service, filter, None);
    let trial = read_trial(trial)?;
    let run = bench_trial(&trial, &setup, "bench");
    if let Some(out) = estimates_out {
        write_estimates(out, &run.attitudes)?;
    }
    let rejected: u64 = run.rejected.values().sum();
    Ok(serde_json::json!({
        "samples": trial.samples.len(),
        "seconds": run.seconds,
        "samples_per_s": trial.samples.len() as f64 / run.seconds.max(1e-12),
        "published": run.published,
        "rejected": rejected,
        "filter": setup.filter.filter.spec.to_string(),
    })
    .to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::imu_study::{trial_to_bytes, Trial};
    use attitude_core::sensors::ImuSample;
    use nalgebra::Vector3;

    /// 3 s at rest, then 4 s at a constant rate, exact readings; gyro sample k is the rate over
    /// (t_{k−1}, t_k].
    fn synthetic() -> Trial {
        let rate = 100.0;
        let dt = 1.0 / rate;
        let dip = 60f64.to_radians();
        let field = Vector3::new(0.0, dip.cos(), -dip.sin()) * 50.0;
        let g = Vector3::new(0.0, 0.0, 9.81);
        let w = Vector3::new(0.3, -0.2, 0.5);
        let mut q = Quaternion::from_euler_321(0.1, -0.05, 0.7);
        let mut t = Trial {
            name: "synthetic".into(),
            rate_hz: rate,
            samples: Vec::new(),
            truth: Vec::new(),
            movement: Vec::new(),
            truth_model: Default::default(),
            set: String::new(),
        };
        for k in 0..700 {
            let time = k as f64 * dt;
            let omega = if time <= 3.0 + 1e-9 {
                Vector3::zeros()
            } else {
                w
            };
            if k > 0 {
                q = q.propagate(&omega, dt);
            }
            let a = q.attitude_matrix();
            t.samples.push(ImuSample {
                t_s: time,
                gyr_rad_s: omega,
                acc_m_s2: a * g,
                mag: Some(a * field),
            });
            t.truth.push(Some(q));
            t.movement.push(time > 3.0);
        }
        t
    }

    #[test]
    fn a_trial_through_the_files() {
        let trial = synthetic();
        let dir = std::env::temp_dir().join(format!("imu_bench_test_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (input, output) = (dir.join("t.trial"), dir.join("e.bin"));
        std::fs::write(&input, trial_to_bytes(&trial)).unwrap();
        let config = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/imu.json5"
        ));
        let line = main_entry(&input, config, &[], None, Some(&output)).unwrap();
        let json: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(json["samples"], 700);
        assert_eq!(json["rejected"], 0);
        assert_eq!(json["filter"], "mekf");
        // One estimate per sample after the 0.1 s alignment (its last sample starts the filter).
        assert_eq!(json["published"], 700 - 10);
        let bytes = std::fs::read(&output).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let v: Vec<f64> = bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(v.len(), 1 + 4 * 700);
        assert!(v[1].is_nan(), "no estimate during the alignment");
        let last = &v[1 + 4 * 699..];
        let q = Quaternion::new(last[1], last[2], last[3], last[0]);
        let err = trial.truth[699]
            .unwrap()
            .compose(&q.inverse())
            .angle()
            .to_degrees();
        assert!(err < 1.0, "final error {err}°");
    }
}
