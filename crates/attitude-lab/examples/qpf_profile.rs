//! A particle-filter loop for profilers (perf, callgrind), and the large-cloud measurement:
//! `cargo run --release --example qpf_profile -- [steps] [particles] [spec] [threads] [lost]`.
//!
//! Default: the steady state of `attitude-lab bench` (three star vectors per step). With `lost`:
//! lost in space from a single vector: one field-like direction per second (σ = 0.01 rad, its reference
//! turning as a field along an orbit) from a uniformly random start, so that the first steps reweigh a
//! diffuse cloud in many progressive-correction stages, resample and regularise. `threads` caps the
//! threads per pass (0: one per core from 65 536 particles on). Prints the wall time per step and the
//! process's CPU time over its wall time (`/proc/self/stat`): about 2 when a pass runs on both cores
//! of this machine, and below 1 when other processes take the cores.

use attitude_core::attitude::Quaternion;
use attitude_core::filters::qpf::set_max_threads;
use attitude_core::filters::{build_filter, FilterConfig, InitialState};
use attitude_core::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use attitude_lab::tools::bench::SteadyState;
use nalgebra::Vector3;

/// User + system CPU time of this process, s (Linux; 0 elsewhere).
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit(')')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // Fields 14 and 15 of stat (utime, stime), counted after the command's closing parenthesis.
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    let mut args = std::env::args().skip(1);
    let steps: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(2000);
    let particles: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let spec = args.next().unwrap_or_else(|| "qpf:average".into());
    let threads: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(0);
    let lost = args.next().is_some_and(|a| a == "lost");
    set_max_threads(threads);
    let (wall, cpu, stages, resamples) = if lost {
        let mut config = FilterConfig::new(spec.parse().expect("a filter"), GyroNoise::standard());
        config.particles = particles;
        let init = InitialState {
            t_s: Some(0.0),
            q: Quaternion::IDENTITY,
            sigma_att_rad: Vector3::repeat(std::f64::consts::PI),
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: Vector3::repeat(1e-5),
            uniform_attitude: true,
            covariance: None,
        };
        let mut f = build_filter(&config, &init, 1).expect("a filter");
        let omega = Vector3::new(0.01, -0.02, 0.03);
        let mut truth = Quaternion::new(0.3, -0.5, 0.1, 0.8).normalized().unwrap();
        let (start, cpu0) = (std::time::Instant::now(), cpu_s());
        let mut stages = 0u64;
        for k in 0..steps {
            let t = k as f64;
            f.process(&Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: omega,
            }))
            .expect("a gyro step");
            truth = truth.propagate(&omega, 1.0);
            // The reference turns (as the field does along an orbit): one vector at a time, but
            // different ones over time make the attitude observable.
            let r = Vector3::new((0.05 * t).cos(), (0.05 * t).sin(), 0.5).normalize();
            let set = ObservationSet {
                t_s: t + 1.0,
                observations: vec![VectorObservation {
                    body: truth.attitude_matrix() * r,
                    reference: r,
                    sigma: 0.01,
                    sensor: None,
                    aspect: Aspect::Full,
                }],
            };
            f.process(&Measurement::Vectors(set))
                .expect("a vector step");
            stages += f.estimate().diagnostics.pc_stages.unwrap_or(0) as u64;
        }
        let d = f.estimate().diagnostics;
        (
            start.elapsed().as_secs_f64(),
            cpu_s() - cpu0,
            stages,
            d.resamples,
        )
    } else {
        let mut s = SteadyState::new(&spec, particles).expect("a valid filter");
        let (start, cpu0) = (std::time::Instant::now(), cpu_s());
        let mut stages = 0u64;
        for _ in 0..steps {
            s.step().expect("a steady step");
            stages += s.filter.estimate().diagnostics.pc_stages.unwrap_or(0) as u64;
        }
        let d = s.filter.estimate().diagnostics;
        (
            start.elapsed().as_secs_f64(),
            cpu_s() - cpu0,
            stages,
            d.resamples,
        )
    };
    let per = wall / steps as f64;
    println!(
        "{spec}{}, {particles} particles: {:.1} us/step, {:.2} ns/particle-step, CPU/wall {:.2}, {:.2} progressive-correction stages per update, {:?} resamplings",
        if lost { " (lost in space, one vector)" } else { "" },
        per * 1e6,
        per * 1e9 / particles as f64,
        cpu / wall,
        stages as f64 / steps as f64,
        resamples
    );
}
