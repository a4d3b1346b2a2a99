//! The sensor as its datasheet states it, and as the data measure it.
//!
//! * [`SensorSheet`]: what a user can state from the datasheet, in the datasheet's own units
//!   (`service.imu.sensor`, a vehicle's `sensor` in `service.vehicles`, or a reset request's). Every
//!   value is optional (0: not given). Given values add to the models (the gyro's noise density and
//!   bias instability add to the filter's gyro model in quadrature; the ranges mark saturated
//!   samples; the noises set the rest detector's floors and the magnetometer's noise floor); what is
//!   not given is measured where the data allow it, else the models assume an unknown consumer MEMS
//!   sensor (no range, noise well below the models' own errors).
//! * [`NoiseMeter`]: what the data measure at rest: the gyro's and the accelerometer's white noise
//!   (the spread of the samples about their low-pass) and the magnetometer's (half the spread of
//!   successive readings), reported with every estimate (`diagnostics.imu.measured`).

use nalgebra::Vector3;

/// A datasheet's values (0: not given).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct SensorSheet {
    /// Gyro rate noise density, °/s/√Hz (e.g. 0.005 for an MPU6050, 0.0038 for a BMI088).
    pub gyro_noise_density_deg_s_sqrt_hz: f64,
    /// Gyro bias instability, °/h (the Allan deviation's floor).
    pub gyro_bias_instability_deg_h: f64,
    /// Gyro full scale, °/s per axis (e.g. 250, 500, 1000, 2000).
    pub gyro_range_deg_s: f64,
    /// Accelerometer noise density, µg/√Hz.
    pub acc_noise_density_ug_sqrt_hz: f64,
    /// Accelerometer full scale, g per axis (e.g. 2, 4, 8, 16).
    pub acc_range_g: f64,
    /// Magnetometer noise, 1σ per axis, in the unit of the readings.
    pub mag_noise: f64,
    /// What a calibration in place left of the magnetometer's hard-iron offset, 1σ per axis, in the
    /// unit of the readings: until rotation confirms the field, north's uncertainty is that over the
    /// field's horizontal part (not given: `mag.hard_iron.unconfirmed_offset` × the field's norm, an
    /// uncalibrated sensor's).
    pub mag_offset_sigma: f64,
    /// What a sample's outputs stand for over its interval (the datasheet's output stage); when
    /// stated it replaces the configuration's `acc.lag_intervals`, `mag.lag_intervals` and
    /// `gyro.coning` for this sensor.
    pub output: Output,
}

/// What a sample's outputs stand for over the interval since the one before (crate::ahrs: the
/// readings' lag and the coning term).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Output {
    /// Not stated: the configuration's models.
    #[default]
    Unstated,
    /// Every output is its interval's mean (a decimation filter shared by the gyro and the
    /// accelerometer, as most MEMS IMUs at a reduced output rate): the readings describe the body
    /// half an interval before the time stamp, and one rotation step per interval needs the
    /// coning term.
    Mean,
    /// The gyro reports the angle it integrated over the interval itself (delta angles, a
    /// strapdown-integrated output): its increments hold the coning already; the readings are
    /// interval means.
    Increments,
    /// The outputs are the values at the time stamp (no averaging: a sensor read as it is, or a
    /// recording interpolated to its time stamps): no lag; the coning term stays (a rate between two
    /// instants turns its axis as well).
    Instant,
}

impl Output {
    /// The readings' lag (in intervals) and whether the coning term applies, when stated.
    pub fn models(self) -> Option<(f64, bool)> {
        match self {
            Output::Unstated => None,
            Output::Mean => Some((0.5, true)),
            Output::Increments => Some((0.5, false)),
            Output::Instant => Some((0.0, true)),
        }
    }

    /// The name a configuration or a reset request gives it.
    pub fn name(self) -> &'static str {
        match self {
            Output::Unstated => "unstated",
            Output::Mean => "mean",
            Output::Increments => "increments",
            Output::Instant => "instant",
        }
    }

    /// The output stage named `name` (`mean`, `increments`, `instant`).
    pub fn from_name(name: &str) -> Option<Output> {
        [Output::Mean, Output::Increments, Output::Instant]
            .into_iter()
            .find(|o| o.name() == name)
    }
}

/// Standard gravity, m/s² (a datasheet's g).
pub const STANDARD_G: f64 = 9.806_65;
/// Over how long the gyro's bias wanders by its bias instability, s (the flat of a MEMS gyro's Allan
/// deviation lies at tens to hundreds of seconds).
pub const BIAS_INSTABILITY_TIME_S: f64 = 100.0;

impl SensorSheet {
    pub fn validate(&self) -> Result<(), String> {
        for (v, name) in [
            (
                self.gyro_noise_density_deg_s_sqrt_hz,
                "gyro_noise_density_deg_s_sqrt_hz",
            ),
            (
                self.gyro_bias_instability_deg_h,
                "gyro_bias_instability_deg_h",
            ),
            (self.gyro_range_deg_s, "gyro_range_deg_s"),
            (
                self.acc_noise_density_ug_sqrt_hz,
                "acc_noise_density_ug_sqrt_hz",
            ),
            (self.acc_range_g, "acc_range_g"),
            (self.mag_noise, "mag_noise"),
            (self.mag_offset_sigma, "mag_offset_sigma"),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!(
                    "sensor.{name} must be finite and non-negative (0: not given), got {v}"
                ));
            }
        }
        Ok(())
    }

    /// The gyro's angle random walk, rad/√s (0: not given).
    pub fn gyro_arw_rad_sqrt_s(&self) -> f64 {
        self.gyro_noise_density_deg_s_sqrt_hz.to_radians()
    }

    /// The gyro's bias random walk from its bias instability, rad/s^1.5: the bias wanders by the
    /// instability over [`BIAS_INSTABILITY_TIME_S`] (0: not given).
    pub fn gyro_rrw_rad_s_sqrt_s(&self) -> f64 {
        (self.gyro_bias_instability_deg_h / 3600.0).to_radians() / BIAS_INSTABILITY_TIME_S.sqrt()
    }

    /// The gyro's range, rad/s (0: not given).
    pub fn gyro_range_rad_s(&self) -> f64 {
        self.gyro_range_deg_s.to_radians()
    }

    /// The accelerometer's range, m/s² (0: not given).
    pub fn acc_range_m_s2(&self) -> f64 {
        self.acc_range_g * STANDARD_G
    }

    /// The accelerometer's noise density, m/s²/√Hz (0: not given).
    pub fn acc_noise_density_m_s2_sqrt_hz(&self) -> f64 {
        self.acc_noise_density_ug_sqrt_hz * 1e-6 * STANDARD_G
    }

    /// Whether no value is given.
    pub fn is_empty(&self) -> bool {
        *self == SensorSheet::default()
    }

    /// This sheet, with the values it does not give taken from `base`.
    pub fn or(&self, base: &SensorSheet) -> SensorSheet {
        let pick = |a: f64, b: f64| if a > 0.0 { a } else { b };
        SensorSheet {
            gyro_noise_density_deg_s_sqrt_hz: pick(
                self.gyro_noise_density_deg_s_sqrt_hz,
                base.gyro_noise_density_deg_s_sqrt_hz,
            ),
            gyro_bias_instability_deg_h: pick(
                self.gyro_bias_instability_deg_h,
                base.gyro_bias_instability_deg_h,
            ),
            gyro_range_deg_s: pick(self.gyro_range_deg_s, base.gyro_range_deg_s),
            acc_noise_density_ug_sqrt_hz: pick(
                self.acc_noise_density_ug_sqrt_hz,
                base.acc_noise_density_ug_sqrt_hz,
            ),
            acc_range_g: pick(self.acc_range_g, base.acc_range_g),
            mag_noise: pick(self.mag_noise, base.mag_noise),
            mag_offset_sigma: pick(self.mag_offset_sigma, base.mag_offset_sigma),
            output: if self.output == Output::Unstated {
                base.output
            } else {
                self.output
            },
        }
    }
}

/// The white noise of the three sensors as measured at rest (per-sample variances, low-passed over
/// about [`NoiseMeter::TIME_S`] of rest), and of the magnetometer's readings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NoiseMeter {
    /// Mean squared deviation of a gyro sample from its low-pass at rest, per axis, (rad/s)².
    pub gyro_var: f64,
    /// The same for the accelerometer, (m/s²)².
    pub acc_var: f64,
    /// Half the mean squared difference of successive magnetometer readings at rest, per axis.
    pub mag_var: f64,
    /// The mean sample interval at rest, s.
    pub dt_s: f64,
    /// Rest time measured, s.
    pub rest_s: f64,
    /// The previous magnetometer reading.
    pub last_mag: Option<Vector3<f64>>,
}

/// What the meter measured, in the datasheet's units (0: not measured yet).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeasuredNoise {
    pub gyro_noise_density_deg_s_sqrt_hz: f64,
    pub acc_noise_density_ug_sqrt_hz: f64,
    pub mag_noise: f64,
    /// Seconds of rest the figures come from.
    pub rest_s: f64,
}

impl NoiseMeter {
    /// The averaging time of the variances, s.
    pub const TIME_S: f64 = 10.0;

    /// Takes one sample at rest: the deviations of the gyro and the accelerometer from their
    /// low-passes, the magnetometer's reading (if any), and the interval. Outside rest call
    /// [`NoiseMeter::moving`].
    pub fn at_rest(
        &mut self,
        gyr_dev: &Vector3<f64>,
        acc_dev: &Vector3<f64>,
        mag: Option<&Vector3<f64>>,
        dt_s: f64,
    ) {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return;
        }
        self.rest_s += dt_s;
        // A mean over the first TIME_S of rest, then a low-pass over TIME_S.
        let k = (dt_s / self.rest_s.min(Self::TIME_S)).min(1.0);
        let mix = |v: &mut f64, x: f64| {
            if x.is_finite() {
                *v += k * (x - *v);
            }
        };
        mix(&mut self.gyro_var, gyr_dev.norm_squared() / 3.0);
        mix(&mut self.acc_var, acc_dev.norm_squared() / 3.0);
        mix(&mut self.dt_s, dt_s);
        if let Some(m) = mag {
            if let Some(prev) = self.last_mag {
                if *m != prev {
                    mix(&mut self.mag_var, (m - prev).norm_squared() / 6.0);
                }
            }
            self.last_mag = Some(*m);
        }
    }

    /// Takes a sample in motion (the magnetometer's successive readings are no longer comparable).
    pub fn moving(&mut self) {
        self.last_mag = None;
    }

    /// The measured noises (densities from the per-sample spread and the interval).
    pub fn measured(&self) -> MeasuredNoise {
        if !(self.rest_s > 0.0 && self.dt_s > 0.0) {
            return MeasuredNoise::default();
        }
        let density = |var: f64| (var.max(0.0) * self.dt_s).sqrt();
        MeasuredNoise {
            gyro_noise_density_deg_s_sqrt_hz: density(self.gyro_var).to_degrees(),
            acc_noise_density_ug_sqrt_hz: density(self.acc_var) / STANDARD_G * 1e6,
            mag_noise: self.mag_var.max(0.0).sqrt(),
            rest_s: self.rest_s,
        }
    }

    /// The per-sample 1σ of the gyro and the accelerometer: measured, or 0.
    pub fn sample_sigmas(&self) -> (f64, f64) {
        if self.rest_s > 0.0 {
            (self.gyro_var.max(0.0).sqrt(), self.acc_var.max(0.0).sqrt())
        } else {
            (0.0, 0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// White noise of known densities at 200 Hz: the meter recovers them to a few percent (the
    /// deviation from a low-pass of 0.5 s keeps all but 1% of the variance at this rate), in the
    /// datasheet's units; the conversions of a sheet are the datasheet's.
    #[test]
    fn measures_known_white_noise() {
        let mut rng = crate::rng::Xoshiro256PlusPlus::seed_from_u64(3);
        let rate = 200.0;
        let dt: f64 = 1.0 / rate;
        let gyro_nd = 0.01f64.to_radians(); // 0.01 °/s/√Hz
        let acc_nd = 150e-6 * STANDARD_G; // 150 µg/√Hz
        let ng = Normal::new(0.0, gyro_nd / dt.sqrt()).unwrap();
        let na = Normal::new(0.0, acc_nd / dt.sqrt()).unwrap();
        let nm = Normal::new(0.0, 0.3).unwrap();
        let mut m = NoiseMeter::default();
        for _ in 0..20_000 {
            let g = Vector3::from_fn(|_, _| ng.sample(&mut rng));
            let a = Vector3::from_fn(|_, _| na.sample(&mut rng));
            let mag = Vector3::new(20.0, 5.0, -40.0) + Vector3::from_fn(|_, _| nm.sample(&mut rng));
            m.at_rest(&g, &a, Some(&mag), dt);
        }
        let r = m.measured();
        assert!(
            (r.gyro_noise_density_deg_s_sqrt_hz / 0.01 - 1.0).abs() < 0.05,
            "{r:?}"
        );
        assert!(
            (r.acc_noise_density_ug_sqrt_hz / 150.0 - 1.0).abs() < 0.05,
            "{r:?}"
        );
        assert!((r.mag_noise / 0.3 - 1.0).abs() < 0.05, "{r:?}");
        let sheet = SensorSheet {
            gyro_noise_density_deg_s_sqrt_hz: 0.005,
            gyro_bias_instability_deg_h: 36.0,
            gyro_range_deg_s: 500.0,
            acc_range_g: 4.0,
            ..SensorSheet::default()
        };
        assert!((sheet.gyro_arw_rad_sqrt_s() - 8.726_646e-5).abs() < 1e-9);
        assert!((sheet.gyro_range_rad_s() - 8.726_646).abs() < 1e-6);
        assert!((sheet.acc_range_m_s2() - 39.2266).abs() < 1e-9);
        // 36 °/h = 0.01 °/s over 100 s: 1.745e-4 rad/s / 10 √s.
        assert!((sheet.gyro_rrw_rad_s_sqrt_s() - 1.745_329e-5).abs() < 1e-10);
        assert!(sheet.validate().is_ok());
        let bad = SensorSheet {
            acc_range_g: -1.0,
            ..SensorSheet::default()
        };
        assert!(bad.validate().is_err());
    }
}
