//! A scenario's parameters in prose: every one, with its units (the `scenarios` command, a study's
//! report).

use nalgebra::Vector3;

use super::{BiasSpec, InitialError, ScenarioParams, TruthMotion};
use crate::sim::{ARCSEC, DEG, DEG_PER_HR};

impl ScenarioParams {
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
