//! A steady-state QPF loop for profilers: `cargo run --release --example qpf_profile -- [steps] [particles]`.
use attitude_service::attitude::Quaternion;
use attitude_service::filters::{build_filter, FilterConfig, InitialState};
use attitude_service::sensors::{
    GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::Vector3;

fn main() {
    let mut args = std::env::args().skip(1);
    let steps: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(2000);
    let particles: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let mut config = FilterConfig::new("qpf:average".parse().unwrap(), GyroNoise::standard());
    config.particles = particles;
    let mut truth = Quaternion::new(0.1, -0.2, 0.3, 0.9).normalized().unwrap();
    let init = InitialState {
        t_s: Some(0.0),
        q: truth,
        sigma_att_rad: Vector3::repeat(1e-3),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(1e-6),
        uniform_attitude: false,
    };
    let mut f = build_filter(&config, &init, 1).unwrap();
    let omega = Vector3::new(0.01, -0.02, 0.005);
    let refs = [
        Vector3::x(),
        Vector3::new(0.0, 0.6, 0.8),
        Vector3::new(0.0, -0.8, 0.6),
    ];
    let start = std::time::Instant::now();
    let mut gyro_s = 0.0;
    let mut stages = 0u64;
    for k in 0..steps {
        let t = k as f64 * 0.1;
        let g0 = std::time::Instant::now();
        f.process(&Measurement::Gyro(GyroSample {
            t_s: t,
            omega_body_rad_s: omega,
        }))
        .unwrap();
        f.process(&Measurement::Gyro(GyroSample {
            t_s: t + 0.05,
            omega_body_rad_s: omega,
        }))
        .unwrap();
        gyro_s += g0.elapsed().as_secs_f64() / 2.0;
        truth = truth.propagate(&omega, 0.1);
        let a = truth.attitude_matrix();
        let observations = refs
            .iter()
            .map(|r| VectorObservation {
                body: a * r,
                reference: *r,
                sigma: 1e-4,
                sensor: None,
            })
            .collect();
        f.process(&Measurement::Vectors(ObservationSet {
            t_s: t + 0.1,
            observations,
        }))
        .unwrap();
        stages += f.estimate().diagnostics.pc_stages.unwrap_or(0) as u64;
    }
    println!(
        "mean progressive-correction stages {:.2}",
        stages as f64 / steps as f64
    );
    let per = (start.elapsed().as_secs_f64() - gyro_s) / steps as f64;
    println!("propagation alone {:.1} us", gyro_s / steps as f64 * 1e6);
    println!(
        "{:.1} us/step, {:.1} ns/particle-step, resamples {:?}",
        per * 1e6,
        per * 1e9 / particles as f64,
        f.estimate().diagnostics.resamples
    );
}
