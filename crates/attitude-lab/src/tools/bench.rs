//! `attitude-lab bench`: each filter's per-step cost on this machine (gyro propagation + an update
//! with three vector observations, in steady state), with the MEKF as the baseline measured in the same
//! run. The criterion benchmarks (`benches/filters.rs`) use the same steady-state generator.

use attitude_core::attitude::Quaternion;
use attitude_core::filters::{
    build_filter, AttitudeFilter, FilterConfig, FilterError, InitialState,
};
use attitude_core::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::Vector3;
use serde::Serialize;
use std::time::{Duration, Instant};

/// Time between steps, s.
pub const STEP_S: f64 = 0.1;

/// A filter in steady state and the generator of its next (gyro, vectors) pair: a constant-rate truth
/// and three unit-vector observations (σ = 1e-4 rad) per step.
pub struct SteadyState {
    pub filter: Box<dyn AttitudeFilter>,
    truth: Quaternion,
    t: f64,
    omega: Vector3<f64>,
}

impl SteadyState {
    pub fn new(spec: &str, particles: usize) -> Result<Self, FilterError> {
        let spec = spec
            .parse()
            .map_err(|e: attitude_core::filters::ParseFilterSpecError| {
                FilterError::InvalidConfig(e.to_string())
            })?;
        let mut config = FilterConfig::new(spec, GyroNoise::standard());
        config.particles = particles.max(2);
        let truth = Quaternion::new(0.1, -0.2, 0.3, 0.9)
            .normalized()
            .unwrap_or(Quaternion::IDENTITY);
        let init = InitialState {
            t_s: Some(0.0),
            q: truth,
            sigma_att_rad: Vector3::repeat(1e-3),
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: Vector3::repeat(1e-6),
            uniform_attitude: false,
            covariance: None,
        };
        let mut s = SteadyState {
            filter: build_filter(&config, &init, 1)?,
            truth,
            t: 0.0,
            omega: Vector3::new(0.01, -0.02, 0.005),
        };
        for _ in 0..50 {
            s.step()?;
        }
        Ok(s)
    }

    /// The next step's measurements (advances the truth).
    pub fn measurements(&mut self) -> (Measurement, Measurement) {
        let gyro = Measurement::Gyro(GyroSample {
            t_s: self.t,
            omega_body_rad_s: self.omega,
        });
        self.truth = self.truth.propagate(&self.omega, STEP_S);
        self.t += STEP_S;
        let a = self.truth.attitude_matrix();
        let refs = [
            Vector3::x(),
            Vector3::new(0.0, 0.6, 0.8),
            Vector3::new(0.0, -0.8, 0.6),
        ];
        let observations = refs
            .iter()
            .map(|r| VectorObservation {
                body: a * r,
                reference: *r,
                sigma: 1e-4,
                sensor: None,
                aspect: Aspect::Full,
            })
            .collect();
        (
            gyro,
            Measurement::Vectors(ObservationSet {
                t_s: self.t,
                observations,
            }),
        )
    }

    pub fn step(&mut self) -> Result<(), FilterError> {
        let (g, v) = self.measurements();
        self.filter.process(&g)?;
        self.filter.process(&v)
    }
}

/// Mean time of one step of `spec`, measured over about `budget` (the measurement generation is
/// excluded).
pub fn time_step(spec: &str, particles: usize, budget: Duration) -> Result<Duration, FilterError> {
    let mut s = SteadyState::new(spec, particles)?;
    let mut spent = Duration::ZERO;
    let mut steps = 0u32;
    while spent < budget || steps < 10 {
        let (g, v) = s.measurements();
        let start = Instant::now();
        s.filter.process(&g)?;
        s.filter.process(&v)?;
        spent += start.elapsed();
        steps += 1;
    }
    Ok(spent / steps)
}

/// The `bench --json` object.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub particles: usize,
    /// The instruction set of the particle filter's kernels and its threads per pass.
    pub isa: String,
    pub qpf_threads: usize,
    pub mekf_us_per_step: f64,
    pub usque_us_per_step: f64,
    pub usque_propagated_us_per_step: f64,
    pub qpf_us_per_step: f64,
    pub qpf_propagated_us_per_step: f64,
    pub qpf_ns_per_particle_step: f64,
    /// Each filter's cost over the MEKF's, measured in the same run.
    pub usque_over_mekf: f64,
    pub qpf_over_mekf: f64,
}

/// Measures every filter (about `budget` each; QPF at `particles`).
pub fn run(particles: usize, budget: Duration) -> Result<BenchReport, FilterError> {
    let us = |d: Duration| d.as_secs_f64() * 1e6;
    let mekf = us(time_step("mekf", 2, budget)?);
    let usque = us(time_step("usque:average", 2, budget)?);
    let usque_p = us(time_step("usque:propagated", 2, budget)?);
    let qpf = us(time_step("qpf:average", particles, budget)?);
    let qpf_p = us(time_step("qpf:propagated", particles, budget)?);
    Ok(BenchReport {
        particles,
        isa: attitude_core::simd::Isa::active().name().to_string(),
        qpf_threads: attitude_core::filters::qpf::auto_threads(particles),
        mekf_us_per_step: mekf,
        usque_us_per_step: usque,
        usque_propagated_us_per_step: usque_p,
        qpf_us_per_step: qpf,
        qpf_propagated_us_per_step: qpf_p,
        qpf_ns_per_particle_step: qpf * 1e3 / particles as f64,
        usque_over_mekf: usque / mekf,
        qpf_over_mekf: qpf / mekf,
    })
}

impl BenchReport {
    pub fn table(&self) -> String {
        format!(
            "filter step (gyro + 3 vectors), this machine; particle filter: {}, {} thread(s)\n\
             {:<28} {:>10.2} µs   1.00× (baseline)\n\
             {:<28} {:>10.2} µs {:>6.2}×\n\
             {:<28} {:>10.2} µs {:>6.2}×\n\
             {:<28} {:>10.2} µs {:>6.1}×   {:.1} ns per particle-step\n\
             {:<28} {:>10.2} µs {:>6.1}×\n",
            self.isa,
            self.qpf_threads,
            "mekf",
            self.mekf_us_per_step,
            "usque:average",
            self.usque_us_per_step,
            self.usque_over_mekf,
            "usque:propagated",
            self.usque_propagated_us_per_step,
            self.usque_propagated_us_per_step / self.mekf_us_per_step,
            format!("qpf:average ({} particles)", self.particles),
            self.qpf_us_per_step,
            self.qpf_over_mekf,
            self.qpf_ns_per_particle_step,
            format!("qpf:propagated ({})", self.particles),
            self.qpf_propagated_us_per_step,
            self.qpf_propagated_us_per_step / self.mekf_us_per_step,
        )
    }
}

/// One point of the particle filter's cost curve (`bench --curve`).
#[derive(Clone, Debug, Serialize)]
pub struct CurvePoint {
    pub particles: usize,
    pub threads: usize,
    pub qpf_us_per_step: f64,
    pub qpf_ns_per_particle_step: f64,
}

/// `qpf:average` at each particle count, about `budget` each.
pub fn curve(counts: &[usize], budget: Duration) -> Result<Vec<CurvePoint>, FilterError> {
    counts
        .iter()
        .map(|&n| {
            let t = time_step("qpf:average", n, budget)?.as_secs_f64();
            Ok(CurvePoint {
                particles: n,
                threads: attitude_core::filters::qpf::auto_threads(n),
                qpf_us_per_step: t * 1e6,
                qpf_ns_per_particle_step: t * 1e9 / n as f64,
            })
        })
        .collect()
}
