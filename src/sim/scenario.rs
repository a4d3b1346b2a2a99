//! The standard scenarios (docs/montecarlo.md) and the simulator that turns a scenario and a seed into a
//! truth trajectory, a time-ordered measurement stream and the filter's initial estimate.
//!
//! Reproducibility: a run is drawn from `Xoshiro256PlusPlus::seed_from_u64(seed)`, split into
//! independent sub-streams with `jump()` (2¹²⁸ draws apart), in this order: initial conditions (true
//! bias, then the initial attitude error), gyro, star camera, sun sensor, magnetometer. So the same
//! `(params, seed)` gives a bit-identical [`SimulatedRun`], and enabling one sensor does not change the
//! noise drawn for another.

use std::fmt;
use std::str::FromStr;

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;

use super::orbit::{default_sun_direction_eci, CircularOrbit, DipoleField};
use super::{ARCSEC, DEG, DEG_PER_HR};
use crate::attitude::Quaternion;
use crate::sensors::gyro::normal3;
use crate::sensors::{
    GyroNoise, GyroSample, GyroSimulator, MagnetometerModel, Measurement, ObservationSet,
    StarCamera, SunSensor, VectorObservation,
};

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

/// Why a [`ScenarioParams`] cannot be simulated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("invalid scenario parameter `{field}`: {reason}")]
pub struct ScenarioError {
    pub field: &'static str,
    pub reason: String,
}

fn invalid(field: &'static str, reason: impl Into<String>) -> ScenarioError {
    ScenarioError {
        field,
        reason: reason.into(),
    }
}

fn finite_positive(field: &'static str, x: f64) -> Result<(), ScenarioError> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("must be finite and > 0, got {x}")))
    }
}

fn finite_non_negative(field: &'static str, x: f64) -> Result<(), ScenarioError> {
    if x.is_finite() && x >= 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("must be finite and >= 0, got {x}")))
    }
}

fn all_finite_positive(field: &'static str, v: &Vector3<f64>) -> Result<(), ScenarioError> {
    if v.iter().all(|x| x.is_finite() && *x > 0.0) {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("every component must be finite and > 0, got {v:?}"),
        ))
    }
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

    /// Checks that the parameters can be simulated.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        finite_positive("duration_s", self.duration_s)?;
        finite_positive("dt_gyro_s", self.dt_gyro_s)?;
        finite_positive("dt_obs_s", self.dt_obs_s)?;
        let k = self.n_gyro_steps();
        if k == 0 {
            return Err(invalid("duration_s", "shorter than one gyro interval"));
        }
        if k > MAX_GYRO_STEPS {
            return Err(invalid(
                "duration_s",
                format!("more than {MAX_GYRO_STEPS} gyro steps"),
            ));
        }
        let m = self.obs_every();
        if m == 0 || ((m as f64) * self.dt_gyro_s - self.dt_obs_s).abs() > 1e-9 * self.dt_obs_s {
            return Err(invalid(
                "dt_obs_s",
                format!(
                    "must be a whole multiple of dt_gyro_s = {} s, got {} s",
                    self.dt_gyro_s, self.dt_obs_s
                ),
            ));
        }
        finite_non_negative("gyro.sigma_v", self.gyro.sigma_v)?;
        finite_non_negative("gyro.sigma_u", self.gyro.sigma_u)?;
        match self.true_bias_rad_s {
            BiasSpec::Fixed(b) => {
                if !b.iter().all(|x| x.is_finite()) {
                    return Err(invalid("true_bias_rad_s", "must be finite"));
                }
            }
            BiasSpec::UniformPerAxis { max_rad_s } => {
                finite_non_negative("true_bias_rad_s.max_rad_s", max_rad_s)?
            }
        }
        match self.initial_error {
            InitialError::PerAxisGaussian { sigma_rad } => {
                if !sigma_rad.iter().all(|x| x.is_finite() && *x >= 0.0) {
                    return Err(invalid(
                        "initial_error.sigma_rad",
                        "must be finite and >= 0",
                    ));
                }
            }
            InitialError::Euler321Magnitudes {
                roll_rad,
                pitch_rad,
                yaw_rad,
            } => {
                if ![roll_rad, pitch_rad, yaw_rad].iter().all(|x| x.is_finite()) {
                    return Err(invalid("initial_error", "Euler angles must be finite"));
                }
            }
            InitialError::UniformRandom => {}
        }
        all_finite_positive("filter_init_sigma_att_rad", &self.filter_init_sigma_att_rad)?;
        all_finite_positive(
            "filter_init_bias_sigma_rad_s",
            &self.filter_init_bias_sigma_rad_s,
        )?;
        finite_positive("convergence_threshold_rad", self.convergence_threshold_rad)?;
        match self.motion {
            TruthMotion::ConstantRate { q0, omega_rad_s } => {
                if q0.normalized().is_none() {
                    return Err(invalid("motion.q0", "must be a non-zero finite quaternion"));
                }
                if !omega_rad_s.iter().all(|x| x.is_finite()) {
                    return Err(invalid("motion.omega_rad_s", "must be finite"));
                }
            }
            TruthMotion::Lvlh => self.validate_orbit()?,
        }
        if let Some(cam) = &self.sensors.star_camera {
            finite_positive("star_camera.sigma_rad", cam.sigma_rad)?;
            finite_non_negative("star_camera.half_angle_rad", cam.half_angle_rad)?;
            let n = cam.boresight_body.norm();
            if !(n.is_finite() && n > 0.0) {
                return Err(invalid(
                    "star_camera.boresight_body",
                    "must be non-zero and finite",
                ));
            }
            if cam.catalogue.is_empty() {
                return Err(invalid("star_camera.catalogue", "is empty"));
            }
        }
        if let Some(sun) = &self.sensors.sun_sensor {
            finite_positive("sun_sensor.sigma_rad", sun.sigma_rad)?;
            let n = self.sun_direction_eci.norm();
            if !(n.is_finite() && n > 0.0) {
                return Err(invalid("sun_direction_eci", "must be non-zero and finite"));
            }
            if sun.fov_half_angle_rad.is_nan() {
                return Err(invalid("sun_sensor.fov_half_angle_rad", "is NaN"));
            }
        }
        if let Some(mag) = &self.sensors.magnetometer {
            finite_positive("magnetometer.sigma_nt", mag.sigma_nt)?;
            self.validate_orbit()?;
            finite_non_negative("field.b0_nt", self.field.b0_nt)?;
            if ![
                self.field.tilt_rad,
                self.field.lon0_rad,
                self.field.earth_rate_rad_s,
            ]
            .iter()
            .all(|x| x.is_finite())
            {
                return Err(invalid("field", "angles and rate must be finite"));
            }
        }
        Ok(())
    }

    fn validate_orbit(&self) -> Result<(), ScenarioError> {
        finite_positive("orbit.radius", self.orbit.radius_m())?;
        if ![
            self.orbit.inclination_rad,
            self.orbit.raan_rad,
            self.orbit.arg_lat0_rad,
        ]
        .iter()
        .all(|x| x.is_finite())
        {
            return Err(invalid("orbit", "angles must be finite"));
        }
        Ok(())
    }

    /// Every parameter, with units, as a human-readable multi-line table.
    pub fn describe(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let v3 = |v: &Vector3<f64>, scale: f64| {
            format!(
                "[{:.4}, {:.4}, {:.4}]",
                v[0] / scale,
                v[1] / scale,
                v[2] / scale
            )
        };
        let _ = writeln!(s, "scenario `{}`", self.name);
        let _ = writeln!(
            s,
            "  timing:          {} s run, gyro every {} s, observations every {} s ({} gyro steps)",
            self.duration_s,
            self.dt_gyro_s,
            self.dt_obs_s,
            self.n_gyro_steps()
        );
        let _ = writeln!(
            s,
            "  gyro noise:      sigma_v = {:.4e} rad/s^1/2 (ARW), sigma_u = {:.4e} rad/s^3/2 (RRW); \
             per-sample white sigma {:.4e} rad/s",
            self.gyro.sigma_v,
            self.gyro.sigma_u,
            self.gyro.discrete_rate_sigma(self.dt_gyro_s)
        );
        let _ = match self.true_bias_rad_s {
            BiasSpec::Fixed(b) => {
                writeln!(s, "  true gyro bias:  fixed {} deg/hr", v3(&b, DEG_PER_HR))
            }
            BiasSpec::UniformPerAxis { max_rad_s } => writeln!(
                s,
                "  true gyro bias:  uniform in +/-{:.4} deg/hr per axis",
                max_rad_s / DEG_PER_HR
            ),
        };
        let (q0, w) = self.truth_initial_attitude_and_rate();
        let _ = match self.motion {
            TruthMotion::ConstantRate { .. } => writeln!(
                s,
                "  truth motion:    constant body rate {} deg/s from q0 = [x {:.6}, y {:.6}, z {:.6}, w {:.6}] (inertial)",
                v3(&w, DEG),
                q0.x,
                q0.y,
                q0.z,
                q0.w
            ),
            TruthMotion::Lvlh => writeln!(
                s,
                "  truth motion:    Earth-pointing LVLH (z nadir, y = -orbit normal), body rate {} deg/s",
                v3(&w, DEG)
            ),
        };
        let _ = match self.initial_error {
            InitialError::PerAxisGaussian { sigma_rad } => writeln!(
                s,
                "  initial error:   Gaussian rotation vector, 1-sigma {} deg per body axis",
                v3(&sigma_rad, DEG)
            ),
            InitialError::Euler321Magnitudes {
                roll_rad,
                pitch_rad,
                yaw_rad,
            } => writeln!(
                s,
                "  initial error:   3-2-1 Euler roll/pitch/yaw of magnitudes {:.3}/{:.3}/{:.3} deg, random signs",
                roll_rad / DEG,
                pitch_rad / DEG,
                yaw_rad / DEG
            ),
            InitialError::UniformRandom => writeln!(
                s,
                "  initial error:   uniformly random attitude (lost in space)"
            ),
        };
        let _ = writeln!(
            s,
            "  filter prior:    attitude 1-sigma {} deg, bias 0 with 1-sigma {} deg/hr",
            v3(&self.filter_init_sigma_att_rad, DEG),
            v3(&self.filter_init_bias_sigma_rad_s, DEG_PER_HR)
        );
        let _ = writeln!(
            s,
            "  convergence:     error angle below {:.4} deg ({:.2} arcsec) over the last quarter of the run",
            self.convergence_threshold_rad / DEG,
            self.convergence_threshold_rad / ARCSEC
        );
        if let Some(cam) = &self.sensors.star_camera {
            let _ = writeln!(
                s,
                "  star camera:     sigma {:.3} arcsec, {:.3} deg half-angle cone about body {}, at most {} stars, \
                 catalogue of {} stars (seed {}, jitter {} of the lattice spacing)",
                cam.sigma_rad / ARCSEC,
                cam.half_angle_rad / DEG,
                v3(&cam.boresight_body, 1.0),
                cam.max_stars,
                cam.catalogue.len(),
                cam.catalogue.seed(),
                cam.catalogue.jitter_fraction()
            );
        }
        if let Some(sun) = &self.sensors.sun_sensor {
            let _ = writeln!(
                s,
                "  sun sensor:      sigma {:.4} deg, field of view half angle {:.1} deg about body {}; \
                 sun fixed at ECI {}",
                sun.sigma_rad / DEG,
                sun.fov_half_angle_rad / DEG,
                v3(&sun.boresight_body, 1.0),
                v3(&self.sun_direction_eci, 1.0)
            );
        }
        if let Some(mag) = &self.sensors.magnetometer {
            let _ = writeln!(
                s,
                "  magnetometer:    sigma {:.1} nT on a tilted dipole: B0 {:.0} nT at the equator surface, \
                 tilt {:.2} deg, pole RA at t=0 {:.2} deg, Earth rate {:.7e} rad/s",
                mag.sigma_nt,
                self.field.b0_nt,
                self.field.tilt_rad / DEG,
                self.field.lon0_rad / DEG,
                self.field.earth_rate_rad_s
            );
        }
        if matches!(self.motion, TruthMotion::Lvlh) || self.sensors.magnetometer.is_some() {
            let _ = writeln!(
                s,
                "  orbit:           circular, altitude {:.1} km, inclination {:.2} deg, RAAN {:.2} deg, \
                 argument of latitude at t=0 {:.2} deg, rate {:.6e} rad/s (period {:.2} min)",
                self.orbit.altitude_m / 1000.0,
                self.orbit.inclination_rad / DEG,
                self.orbit.raan_rad / DEG,
                self.orbit.arg_lat0_rad / DEG,
                self.orbit.rate_rad_s(),
                self.orbit.period_s() / 60.0
            );
        }
        s
    }
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

#[cfg(test)]
mod tests {
    use super::*;
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
}
