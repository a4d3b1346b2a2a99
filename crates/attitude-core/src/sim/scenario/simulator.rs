//! The simulator: a scenario and a seed to a truth trajectory, a time-ordered measurement stream and
//! the filter's initial estimate.
//!
//! Reproducibility: a run is drawn from `Xoshiro256PlusPlus::seed_from_u64(seed)`, split into
//! independent sub-streams with `jump()` (2¹²⁸ draws apart), in this order: initial conditions (true
//! bias, then the initial attitude error), gyro, star camera, sun sensor, magnetometer. So the same
//! `(params, seed)` gives a bit-identical [`SimulatedRun`], and enabling one sensor does not change the
//! noise drawn for another.

use crate::rng::Xoshiro256PlusPlus;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

use super::{BiasSpec, InitialError, ScenarioError, ScenarioParams};
use crate::attitude::Quaternion;
use crate::sensors::gyro::normal3;
use crate::sensors::{GyroSample, GyroSimulator, Measurement, ObservationSet, VectorObservation};

/// The truth at one gyro time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthSample {
    pub t_s: f64,
    pub q: Quaternion,
    /// The true gyro bias at `t_s`, rad/s.
    pub bias_rad_s: Vector3<f64>,
    /// The true body rate, rad/s.
    pub omega_rad_s: Vector3<f64>,
}

/// The filter's initial estimate and the 1σ it is told.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitialEstimate {
    pub q: Quaternion,
    pub sigma_att_rad: Vector3<f64>,
    pub bias_rad_s: Vector3<f64>,
    pub bias_sigma_rad_s: Vector3<f64>,
    /// The initial attitude is uniformly random (no information): filters that can should start from a
    /// uniform attitude distribution rather than from `q` with `sigma_att_rad`.
    pub uniform_attitude: bool,
}

/// One simulated run.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulatedRun {
    /// One sample per gyro time `t = k·dt_gyro`, `k = 0..=K`.
    pub truth: Vec<TruthSample>,
    /// Time ordered. At each gyro time `k < K` a [`Measurement::Gyro`] whose sample covers
    /// `[t_k, t_k + dt_gyro]`; at each observation time (every `dt_obs`, from `t = dt_obs`, up to and
    /// including `t_K`) a [`Measurement::Vectors`], placed before the gyro sample of the same time. A set
    /// that would be empty (e.g. the sun outside a limited field of view and no other sensor) is left out.
    pub measurements: Vec<Measurement>,
    pub initial: InitialEstimate,
}

impl SimulatedRun {
    /// The run of invalid parameters: no truth, no measurements, identity initial estimate.
    fn empty(params: &ScenarioParams) -> Self {
        SimulatedRun {
            truth: Vec::new(),
            measurements: Vec::new(),
            initial: InitialEstimate {
                q: Quaternion::IDENTITY,
                sigma_att_rad: params.filter_init_sigma_att_rad,
                bias_rad_s: Vector3::zeros(),
                bias_sigma_rad_s: params.filter_init_bias_sigma_rad_s,
                uniform_attitude: matches!(params.initial_error, InitialError::UniformRandom),
            },
        }
    }
}

/// A uniformly random unit quaternion (four standard normals, normalised).
fn uniform_quaternion<R: Rng + ?Sized>(rng: &mut R) -> Quaternion {
    for _ in 0..64 {
        let v = normal3(rng);
        let w: f64 = rng.sample(StandardNormal);
        if let Some(q) = Quaternion::new(v[0], v[1], v[2], w).normalized() {
            return q;
        }
    }
    Quaternion::IDENTITY
}

fn random_sign<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    if rng.random::<bool>() {
        1.0
    } else {
        -1.0
    }
}

/// Simulates `params` with `seed`. The same `(params, seed)` gives a bit-identical run.
///
/// Invalid parameters (see [`ScenarioParams::validate`]) give an empty run (no truth, no measurements)
/// rather than a panic; use [`try_simulate`] to learn why.
pub fn simulate(params: &ScenarioParams, seed: u64) -> SimulatedRun {
    try_simulate(params, seed).unwrap_or_else(|_| SimulatedRun::empty(params))
}

/// As [`simulate`], reporting invalid parameters.
pub fn try_simulate(params: &ScenarioParams, seed: u64) -> Result<SimulatedRun, ScenarioError> {
    params.validate()?;
    let k_end = params.n_gyro_steps();
    let obs_every = params.obs_every();
    let dt = params.dt_gyro_s;

    // Independent sub-streams.
    let mut master = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut next_stream = || {
        let s = master.clone();
        master.jump();
        s
    };
    let mut rng_init = next_stream();
    let mut rng_gyro = next_stream();
    let mut rng_star = next_stream();
    let mut rng_sun = next_stream();
    let mut rng_mag = next_stream();

    // Initial conditions.
    let bias0 = match params.true_bias_rad_s {
        BiasSpec::Fixed(b) => b,
        BiasSpec::UniformPerAxis { max_rad_s } => {
            Vector3::from_fn(|_, _| (2.0 * rng_init.random::<f64>() - 1.0) * max_rad_s)
        }
    };
    let (q0, omega) = params.truth_initial_attitude_and_rate();
    let dq_err = match params.initial_error {
        InitialError::PerAxisGaussian { sigma_rad } => {
            Quaternion::from_rotation_vector(&normal3(&mut rng_init).component_mul(&sigma_rad))
        }
        InitialError::Euler321Magnitudes {
            roll_rad,
            pitch_rad,
            yaw_rad,
        } => {
            let sr = random_sign(&mut rng_init);
            let sp = random_sign(&mut rng_init);
            let sy = random_sign(&mut rng_init);
            Quaternion::from_euler_321(sr * roll_rad, sp * pitch_rad, sy * yaw_rad)
        }
        InitialError::UniformRandom => uniform_quaternion(&mut rng_init),
    };
    let q_init = dq_err
        .compose(&q0)
        .normalized()
        .unwrap_or(Quaternion::IDENTITY);
    let initial = InitialEstimate {
        q: q_init,
        sigma_att_rad: params.filter_init_sigma_att_rad,
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: params.filter_init_bias_sigma_rad_s,
        uniform_attitude: matches!(params.initial_error, InitialError::UniformRandom),
    };

    let sun_ref = {
        let n = params.sun_direction_eci.norm();
        params.sun_direction_eci / n
    };
    let n_obs = k_end / obs_every;
    let mut truth = Vec::with_capacity(k_end + 1);
    let mut measurements = Vec::with_capacity(k_end + n_obs);
    let mut gyro = GyroSimulator::new(params.gyro, bias0);

    for k in 0..=k_end {
        let t = k as f64 * dt;
        // Exact for a constant rate: q(t) = δq(ω t) ⊗ q(0).
        let q = q0.propagate(&omega, t);
        truth.push(TruthSample {
            t_s: t,
            q,
            bias_rad_s: gyro.bias_rad_s,
            omega_rad_s: omega,
        });
        if k > 0 && k % obs_every == 0 {
            let mut observations: Vec<VectorObservation> = Vec::new();
            if let Some(cam) = &params.sensors.star_camera {
                observations.extend(cam.observe(&q, &mut rng_star));
            }
            if let Some(sun) = &params.sensors.sun_sensor {
                observations.extend(sun.observe(&q, &sun_ref, &mut rng_sun));
            }
            if let Some(mag) = &params.sensors.magnetometer {
                let field = params.field.field_eci_nt(&params.orbit.position_eci(t), t);
                observations.push(mag.observe(&q, &field, &mut rng_mag));
            }
            if !observations.is_empty() {
                measurements.push(Measurement::Vectors(ObservationSet {
                    t_s: t,
                    observations,
                }));
            }
        }
        if k < k_end {
            let w = gyro.sample(&omega, dt, &mut rng_gyro);
            measurements.push(Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: w,
            }));
        }
    }

    Ok(SimulatedRun {
        truth,
        measurements,
        initial,
    })
}
