//! The standard scenarios (docs/montecarlo.md): their names and every parameter of a scenario, with
//! the standard values of each ([`ScenarioParams::default_for`]). The parameters' checks are in
//! `validate.rs`, their description in prose in `describe.rs`, and the simulator that turns a scenario
//! and a seed into a truth trajectory, a time-ordered measurement stream and the filter's initial
//! estimate in `simulator.rs`.

mod describe;
mod simulator;
mod validate;

pub use simulator::{simulate, try_simulate, InitialEstimate, SimulatedRun, TruthSample};
pub use validate::ScenarioError;

use std::fmt;
use std::str::FromStr;

use nalgebra::Vector3;

use super::orbit::{default_sun_direction_eci, CircularOrbit, DipoleField};
use super::{ARCSEC, DEG, DEG_PER_HR};
use crate::attitude::Quaternion;
use crate::sensors::{GyroNoise, MagnetometerModel, StarCamera, SunSensor};

/// Runs longer than this many gyro steps are refused (memory guard: about 200 bytes per step).
pub const MAX_GYRO_STEPS: usize = 20_000_000;

/// The standard scenarios.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScenarioName {
    /// Crassidis & Junkins Example 7.1: star camera, 1 s, 5400 s, small initial errors.
    StarTracker,
    /// Magnetometer only in LEO, 10 s, 8 h, large initial errors.
    MagnetometerLeo,
    /// Sun sensor + magnetometer in LEO, 1 s, 1800 s, uniformly random initial attitude.
    LostInSpace,
}

impl ScenarioName {
    pub const ALL: [ScenarioName; 3] = [
        ScenarioName::StarTracker,
        ScenarioName::MagnetometerLeo,
        ScenarioName::LostInSpace,
    ];

    /// The command-line / wire name: `"star-tracker"`, `"magnetometer-leo"`, `"lost-in-space"`.
    pub fn as_str(&self) -> &'static str {
        match self {
            ScenarioName::StarTracker => "star-tracker",
            ScenarioName::MagnetometerLeo => "magnetometer-leo",
            ScenarioName::LostInSpace => "lost-in-space",
        }
    }
}

impl fmt::Display for ScenarioName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A scenario name that is not one of [`ScenarioName::ALL`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown scenario {0:?} (expected one of: star-tracker, magnetometer-leo, lost-in-space)")]
pub struct UnknownScenario(pub String);

impl FromStr for ScenarioName {
    type Err = UnknownScenario;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ScenarioName::ALL
            .into_iter()
            .find(|n| n.as_str() == s.trim())
            .ok_or_else(|| UnknownScenario(s.to_string()))
    }
}

/// How the true initial gyro bias is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BiasSpec {
    /// This bias, rad/s.
    Fixed(Vector3<f64>),
    /// Each axis independently uniform in `[−max, max]`, rad/s.
    UniformPerAxis { max_rad_s: f64 },
}

/// How the filter's initial attitude error `δq_err` is drawn; the filter starts at
/// `q_init = δq_err ⊗ q_true(0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitialError {
    /// A body-frame rotation vector with independent Gaussian components of these 1σ, rad.
    PerAxisGaussian { sigma_rad: Vector3<f64> },
    /// A 3-2-1 Euler rotation ([`Quaternion::from_euler_321`]) with these magnitudes (rad), each with an
    /// independent random sign.
    Euler321Magnitudes {
        roll_rad: f64,
        pitch_rad: f64,
        yaw_rad: f64,
    },
    /// A uniformly random attitude (four standard normals, normalised), independent of the truth.
    UniformRandom,
}

/// The truth attitude motion: always a constant body rate, propagated exactly
/// (`q(t) = δq(ω t) ⊗ q(0)`, i.e. `Quaternion::propagate(ω, t)` from `q(0)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TruthMotion {
    /// Start at `q0` (reference = inertial frame) and turn at `omega_rad_s` (body frame, rad/s).
    ConstantRate {
        q0: Quaternion,
        omega_rad_s: Vector3<f64>,
    },
    /// Earth-pointing in the scenario's orbit: `q(0)` = the LVLH attitude at `t = 0`, `ω = [0, −n, 0]`
    /// (which keeps the truth in LVLH for the whole circular orbit).
    Lvlh,
}

/// The sensors of a scenario besides the gyro. Each enabled sensor is sampled at every observation time.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ScenarioSensors {
    pub star_camera: Option<StarCamera>,
    /// Sees [`ScenarioParams::sun_direction_eci`].
    pub sun_sensor: Option<SunSensor>,
    /// Measures [`ScenarioParams::field`] at the orbit position (the filter receives the same model
    /// field as reference, so there is no field-model error).
    pub magnetometer: Option<MagnetometerModel>,
}

/// Every parameter of a simulated scenario. Units are in the field names.
#[derive(Clone, Debug, PartialEq)]
pub struct ScenarioParams {
    pub name: ScenarioName,
    /// Run length, s; gyro samples are taken at `t_k = k·dt_gyro`, `k = 0..K`, `K = ⌊duration/dt_gyro⌋`.
    pub duration_s: f64,
    pub dt_gyro_s: f64,
    /// A whole multiple of `dt_gyro_s`; observation sets are taken at those gyro times, from `t = dt_obs`.
    pub dt_obs_s: f64,
    pub gyro: GyroNoise,
    pub true_bias_rad_s: BiasSpec,
    pub initial_error: InitialError,
    /// The 1σ the filter is told for its initial attitude, per body axis, rad.
    pub filter_init_sigma_att_rad: Vector3<f64>,
    /// The 1σ the filter is told for its initial bias (estimate zero), per axis, rad/s.
    pub filter_init_bias_sigma_rad_s: Vector3<f64>,
    /// A run has "converged" when its error angle stays below this over the last quarter of the run, rad.
    pub convergence_threshold_rad: f64,
    pub motion: TruthMotion,
    /// The orbit (used by [`TruthMotion::Lvlh`] and by the magnetometer's field).
    pub orbit: CircularOrbit,
    pub field: DipoleField,
    /// Fixed sun direction in ECI (unit), used by the sun sensor.
    pub sun_direction_eci: Vector3<f64>,
    pub sensors: ScenarioSensors,
}

impl ScenarioParams {
    /// The standard parameters of a scenario (listed in docs/montecarlo.md, "Scenarios").
    pub fn default_for(name: ScenarioName) -> Self {
        let orbit = CircularOrbit::default();
        let base = ScenarioParams {
            name,
            duration_s: 0.0,
            dt_gyro_s: 1.0,
            dt_obs_s: 1.0,
            gyro: GyroNoise::standard(),
            true_bias_rad_s: BiasSpec::Fixed(Vector3::zeros()),
            initial_error: InitialError::UniformRandom,
            filter_init_sigma_att_rad: Vector3::repeat(std::f64::consts::PI),
            filter_init_bias_sigma_rad_s: Vector3::repeat(DEG_PER_HR),
            convergence_threshold_rad: DEG,
            motion: TruthMotion::Lvlh,
            orbit,
            field: DipoleField::default(),
            sun_direction_eci: default_sun_direction_eci(),
            sensors: ScenarioSensors::default(),
        };
        match name {
            ScenarioName::StarTracker => ScenarioParams {
                duration_s: 5400.0,
                dt_gyro_s: 1.0,
                dt_obs_s: 1.0,
                true_bias_rad_s: BiasSpec::Fixed(Vector3::repeat(0.1 * DEG_PER_HR)),
                initial_error: InitialError::PerAxisGaussian {
                    sigma_rad: Vector3::repeat(0.1 * DEG),
                },
                filter_init_sigma_att_rad: Vector3::repeat(0.1 * DEG),
                filter_init_bias_sigma_rad_s: Vector3::repeat(0.2 * DEG_PER_HR),
                convergence_threshold_rad: 10.0 * ARCSEC,
                motion: TruthMotion::ConstantRate {
                    q0: Quaternion::IDENTITY,
                    omega_rad_s: Vector3::new(
                        0.0,
                        -2.0 * std::f64::consts::PI / (91.5 * 60.0),
                        0.0,
                    ),
                },
                sensors: ScenarioSensors {
                    star_camera: Some(StarCamera::default()),
                    ..ScenarioSensors::default()
                },
                ..base
            },
            ScenarioName::MagnetometerLeo => ScenarioParams {
                duration_s: 8.0 * 3600.0,
                dt_gyro_s: 10.0,
                dt_obs_s: 10.0,
                true_bias_rad_s: BiasSpec::UniformPerAxis {
                    max_rad_s: 20.0 * DEG_PER_HR,
                },
                initial_error: InitialError::Euler321Magnitudes {
                    roll_rad: 50.0 * DEG,
                    pitch_rad: 50.0 * DEG,
                    yaw_rad: 160.0 * DEG,
                },
                // Deliberately too small to describe a 160° error: a linearised filter cannot represent
                // this prior, which is what the scenario tests.
                filter_init_sigma_att_rad: Vector3::repeat(90.0 * DEG),
                filter_init_bias_sigma_rad_s: Vector3::repeat(20.0 * DEG_PER_HR),
                convergence_threshold_rad: DEG,
                motion: TruthMotion::Lvlh,
                sensors: ScenarioSensors {
                    magnetometer: Some(MagnetometerModel::default()),
                    ..ScenarioSensors::default()
                },
                ..base
            },
            ScenarioName::LostInSpace => ScenarioParams {
                duration_s: 1800.0,
                dt_gyro_s: 1.0,
                dt_obs_s: 1.0,
                true_bias_rad_s: BiasSpec::UniformPerAxis {
                    max_rad_s: 5.0 * DEG_PER_HR,
                },
                initial_error: InitialError::UniformRandom,
                filter_init_sigma_att_rad: Vector3::repeat(std::f64::consts::PI),
                filter_init_bias_sigma_rad_s: Vector3::repeat(5.0 * DEG_PER_HR),
                convergence_threshold_rad: DEG,
                motion: TruthMotion::Lvlh,
                sensors: ScenarioSensors {
                    sun_sensor: Some(SunSensor::default()),
                    magnetometer: Some(MagnetometerModel::default()),
                    ..ScenarioSensors::default()
                },
                ..base
            },
        }
    }

    /// The number `K` of gyro intervals (`⌊duration/dt_gyro⌋`, tolerant of rounding). Zero for invalid
    /// parameters.
    pub fn n_gyro_steps(&self) -> usize {
        let r = self.duration_s / self.dt_gyro_s;
        if !(r.is_finite() && r >= 0.0) {
            return 0;
        }
        let k = (r * (1.0 + 1e-12)).floor();
        if k > MAX_GYRO_STEPS as f64 {
            MAX_GYRO_STEPS + 1
        } else {
            k as usize
        }
    }

    /// Observations are taken every this many gyro steps (`dt_obs/dt_gyro`, rounded). Zero for invalid
    /// parameters.
    pub fn obs_every(&self) -> usize {
        let r = self.dt_obs_s / self.dt_gyro_s;
        if !(r.is_finite() && r >= 0.5) || r > MAX_GYRO_STEPS as f64 {
            return 0;
        }
        r.round() as usize
    }

    /// The true attitude at `t = 0` and the (constant) true body rate, rad/s.
    pub fn truth_initial_attitude_and_rate(&self) -> (Quaternion, Vector3<f64>) {
        match self.motion {
            TruthMotion::ConstantRate { q0, omega_rad_s } => {
                (q0.normalized().unwrap_or(Quaternion::IDENTITY), omega_rad_s)
            }
            TruthMotion::Lvlh => (
                self.orbit.lvlh_attitude(0.0),
                self.orbit.lvlh_body_rate_rad_s(),
            ),
        }
    }
}

#[cfg(test)]
mod tests;
