//! The checks of a scenario's parameters: what can be simulated.

use nalgebra::Vector3;

use super::{BiasSpec, InitialError, ScenarioParams, TruthMotion, MAX_GYRO_STEPS};

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
}
