//! [`Driver`]: the time bookkeeping every filter shares (the held gyro rate, propagation to each
//! input's time, gyro gaps) and the checks of an input before any state changes ([`validate`]).

use super::{
    AttitudeFilter, Estimate, FilterCore, FilterError, FilterSpec, FilterState, GapModel,
    MAX_RATE_RAD_S,
};
use crate::sensors::{Aspect, GyroNoise, GyroSample, Measurement, VectorObservation};
use nalgebra::{Matrix3, Vector3};

/// Measurement times closer than this (s) are the same instant.
pub const SAME_INSTANT_S: f64 = 1e-9;

/// Holds the time and the last gyro rate, and drives a [`FilterCore`].
pub struct Driver<F: FilterCore> {
    pub(super) core: F,
    pub(super) t_s: Option<f64>,
    /// The rate measured by the last gyro sample, held until the next. Before the first sample the
    /// filter propagates with its bias estimate only (zero estimated rate) and its process noise.
    pub(super) omega_meas_rad_s: Option<Vector3<f64>>,
    /// Time of the last gyro sample, and the gyro's usual interval (a running mean that ignores
    /// gaps; the held sample's noise covers one such interval).
    pub(super) last_gyro_t_s: Option<f64>,
    pub(super) last_gyro_dt_s: f64,
    pub(super) gyro_intervals: u64,
    pub(super) gap: GapModel,
    /// ARW of the gyro model, for the held sample's noise during a gap.
    pub(super) sigma_v: f64,
    pub(super) gyro_gaps: u64,
    /// Attitude variance per axis that the next propagation adds (set by
    /// [`AttitudeFilter::gyro_interval_with`] for its interval only; not state).
    pub(super) step_extra_rad2: f64,
}

/// The interval assumed for the first gyro sample's noise, s.
const FIRST_GYRO_INTERVAL_S: f64 = 0.1;
/// A gap is this many usual gyro intervals without a sample (and at least `GapModel::after_s`).
pub const GAP_INTERVALS: f64 = 3.0;

impl<F: FilterCore> Driver<F> {
    pub fn new(core: F, t0_s: Option<f64>) -> Self {
        Driver {
            core,
            t_s: t0_s,
            omega_meas_rad_s: None,
            last_gyro_t_s: None,
            last_gyro_dt_s: FIRST_GYRO_INTERVAL_S,
            gyro_intervals: 0,
            gap: GapModel {
                after_s: f64::INFINITY,
                accel_sigma_rad_s2: 0.0,
            },
            sigma_v: 0.0,
            gyro_gaps: 0,
            step_extra_rad2: 0.0,
        }
    }

    /// With the gap model of `config`.
    pub fn with_gap(mut self, gap: GapModel, gyro: &GyroNoise) -> Self {
        self.gap = gap;
        self.sigma_v = gyro.sigma_v;
        self
    }

    pub fn core(&self) -> &F {
        &self.core
    }

    /// Time since the last gyro sample when a gap is in progress at `t_s`.
    fn gap_at(&self, t_s: f64) -> Option<f64> {
        let tg = self.last_gyro_t_s?;
        let tau = t_s - tg;
        (tau > self.gap.after_s.max(GAP_INTERVALS * self.last_gyro_dt_s)).then_some(tau)
    }

    fn propagate_to(&mut self, t_s: f64) -> Result<(), FilterError> {
        let Some(now) = self.t_s else {
            self.t_s = Some(t_s);
            return Ok(());
        };
        // Times within a nanosecond are the same instant: senders compute stamps in different ways
        // (t + dt vs k·dt) and must not see rounding refused as out of order.
        if t_s < now - SAME_INSTANT_S {
            return Err(FilterError::OutOfOrder {
                t_s,
                filter_t_s: now,
            });
        }
        let dt = t_s - now;
        if dt > 0.0 {
            let omega = match self.omega_meas_rad_s {
                Some(w) => w,
                None => self.core.bias_rad_s(),
            };
            // Inflation of a gyro gap over [now, t_s], counted from the last sample once the gap has
            // begun (so the whole gap's growth is added, not only the part after the threshold).
            let inflation = self.gap_at(t_s).map(|tau2| {
                let before = self.gap_at(now);
                let v = |tau: f64| self.gap.variance(tau, self.sigma_v, self.last_gyro_dt_s);
                (v(tau2) - v(before.unwrap_or(0.0)), before.is_none())
            });
            if let Some((var, _)) = inflation {
                if !(var.is_finite() && var >= 0.0) {
                    return Err(FilterError::NonFinite {
                        step: "gyro-gap inflation",
                    });
                }
            }
            // A failed propagation leaves the filter as it was (the core's contract); the inflation,
            // checked finite above, cannot fail.
            let extra = std::mem::take(&mut self.step_extra_rad2);
            self.core.propagate_with(&omega, dt, extra)?;
            if let Some((var, started)) = inflation {
                self.core.inflate_attitude(&(Matrix3::identity() * var));
                if started {
                    self.gyro_gaps += 1;
                }
            }
            self.t_s = Some(t_s);
        }
        Ok(())
    }
}

impl<F: FilterCore> Driver<F> {
    /// A gyro sample after its validation: propagates to its time, then holds its rate.
    #[inline]
    fn take_gyro(&mut self, g: &GyroSample) -> Result<(), FilterError> {
        // A sample after a gap: what is left of the gap is bridged by the mean of the rates on both
        // sides (the rotation of a rate that changed evenly across it), not the earlier rate held;
        // the gap's inflation covers what a rate between them could have done besides.
        // (A refused sample leaves the held rate as it was.)
        let held = self.omega_meas_rad_s;
        if self.gap_at(g.t_s).is_some() {
            if let Some(w) = held {
                self.omega_meas_rad_s = Some(0.5 * (w + g.omega_body_rad_s));
            }
        }
        if let Err(e) = self.propagate_to(g.t_s) {
            self.omega_meas_rad_s = held;
            return Err(e);
        }
        if let Some(tg) = self.last_gyro_t_s {
            let dt = g.t_s - tg;
            if dt > SAME_INSTANT_S {
                if self.gyro_intervals == 0 {
                    self.last_gyro_dt_s = dt;
                } else if dt <= GAP_INTERVALS * self.last_gyro_dt_s {
                    self.last_gyro_dt_s += 0.1 * (dt - self.last_gyro_dt_s);
                }
                self.gyro_intervals += 1;
            }
        }
        self.last_gyro_t_s = Some(g.t_s);
        self.omega_meas_rad_s = Some(g.omega_body_rad_s);
        Ok(())
    }
}

/// [`validate`] of a gyro sample: every value finite (`0·x` is 0 for a finite `x`, NaN otherwise)
/// and the rate within [`MAX_RATE_RAD_S`], checked at once; the full checks (and their message) only
/// when that fails.
#[inline]
fn validate_gyro(g: &GyroSample) -> Result<(), FilterError> {
    let w = &g.omega_body_rad_s;
    let zero = g.t_s * 0.0 + w[0] * 0.0 + w[1] * 0.0 + w[2] * 0.0;
    if zero == 0.0 && w.amax() <= MAX_RATE_RAD_S {
        return Ok(());
    }
    validate(&Measurement::Gyro(*g))
}

fn check_finite(values: impl IntoIterator<Item = f64>, what: &str) -> Result<(), FilterError> {
    if values.into_iter().all(f64::is_finite) {
        Ok(())
    } else {
        Err(FilterError::InvalidMeasurement(format!(
            "{what} is not finite"
        )))
    }
}

/// Checks observation `i` of a set.
fn validate_observation(i: usize, o: &VectorObservation) -> Result<(), FilterError> {
    check_finite(o.body.iter().copied(), "body vector")?;
    check_finite(o.reference.iter().copied(), "reference vector")?;
    if !(o.sigma.is_finite() && o.sigma > 0.0) {
        return Err(FilterError::InvalidMeasurement(format!(
            "observation {i}: sigma must be positive and finite"
        )));
    }
    if let Aspect::Heading(up) | Aspect::Tilt(up) = &o.aspect {
        check_finite(up.iter().copied(), "vertical axis")?;
        if up.norm() == 0.0 {
            return Err(FilterError::InvalidMeasurement(format!(
                "observation {i}: zero vertical axis"
            )));
        }
    }
    if o.reference.norm() == 0.0 {
        return Err(FilterError::InvalidMeasurement(format!(
            "observation {i}: zero reference vector"
        )));
    }
    Ok(())
}

/// Checks a measurement before any state changes.
pub fn validate(measurement: &Measurement) -> Result<(), FilterError> {
    check_finite([measurement.t_s()], "time")?;
    match measurement {
        Measurement::Gyro(g) => {
            check_finite(g.omega_body_rad_s.iter().copied(), "gyro rate")?;
            // Beyond this a rotation angle's square overflows; no gyro measures anything near it.
            if g.omega_body_rad_s.amax() > MAX_RATE_RAD_S {
                return Err(FilterError::InvalidMeasurement(format!(
                    "gyro rate above {MAX_RATE_RAD_S:e} rad/s"
                )));
            }
            Ok(())
        }
        Measurement::Vectors(set) => {
            for (i, o) in set.observations.iter().enumerate() {
                validate_observation(i, o)?;
            }
            Ok(())
        }
        Measurement::Imu(_) => Err(FilterError::InvalidMeasurement(
            "a raw IMU sample is not a filter input: it goes through the sensor models of crate::ahrs"
                .into(),
        )),
    }
}

impl<F: FilterCore> AttitudeFilter for Driver<F> {
    fn spec(&self) -> FilterSpec {
        self.core.spec()
    }

    fn time_s(&self) -> Option<f64> {
        self.t_s
    }

    fn gyro_gaps(&self) -> u64 {
        self.gyro_gaps
    }

    fn process(&mut self, measurement: &Measurement) -> Result<(), FilterError> {
        if let Measurement::Gyro(g) = measurement {
            validate_gyro(g)?;
            return self.take_gyro(g);
        }
        validate(measurement)?;
        self.propagate_to(measurement.t_s())?;
        match measurement {
            // (Taken above.)
            Measurement::Gyro(_) => Ok(()),
            Measurement::Vectors(set) if set.observations.is_empty() => Ok(()),
            Measurement::Vectors(set) => self.core.update(&set.observations),
            // (Refused by `validate` above.)
            Measurement::Imu(_) => Ok(()),
        }
    }

    fn advance_to(&mut self, t_s: f64) -> Result<(), FilterError> {
        check_finite([t_s], "time")?;
        self.propagate_to(t_s)
    }

    fn gyro_interval(
        &mut self,
        t_prev_s: f64,
        omega_body_rad_s: &Vector3<f64>,
        t_s: f64,
    ) -> Result<(), FilterError> {
        self.gyro_interval_with(t_prev_s, omega_body_rad_s, t_s, 0.0)
    }

    fn gyro_interval_with(
        &mut self,
        t_prev_s: f64,
        omega_body_rad_s: &Vector3<f64>,
        t_s: f64,
        extra_rad2: f64,
    ) -> Result<(), FilterError> {
        let g = GyroSample {
            t_s: t_prev_s,
            omega_body_rad_s: *omega_body_rad_s,
        };
        validate_gyro(&g)?;
        check_finite([t_s, extra_rad2], "time and extra variance")?;
        self.take_gyro(&g)?;
        // (Only the move over this interval adds it; a failed step leaves nothing pending.)
        self.step_extra_rad2 = extra_rad2.max(0.0);
        let r = self.propagate_to(t_s);
        self.step_extra_rad2 = 0.0;
        r
    }

    fn observe(&mut self, t_s: f64, observation: &VectorObservation) -> Result<(), FilterError> {
        check_finite([t_s], "time")?;
        validate_observation(0, observation)?;
        self.propagate_to(t_s)?;
        self.core.update(std::slice::from_ref(observation))
    }

    fn observe_bias(
        &mut self,
        t_s: f64,
        z_rad_s: &Vector3<f64>,
        sigma_rad_s: f64,
    ) -> Result<(), FilterError> {
        check_finite([t_s, sigma_rad_s], "bias observation time and sigma")?;
        check_finite(z_rad_s.iter().copied(), "bias observation")?;
        if !(sigma_rad_s > 0.0) {
            return Err(FilterError::InvalidMeasurement(
                "bias observation: sigma must be positive".into(),
            ));
        }
        self.propagate_to(t_s)?;
        self.core.update_bias(z_rad_s, sigma_rad_s)
    }

    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) -> Result<(), FilterError> {
        let symmetric = (cov_rad2 - cov_rad2.transpose()).amax() <= 1e-12 * cov_rad2.amax();
        let psd = cov_rad2
            .symmetric_eigenvalues()
            .iter()
            .all(|l| *l >= -1e-15);
        if !(cov_rad2.iter().all(|x| x.is_finite()) && symmetric && psd) {
            return Err(FilterError::InvalidMeasurement(
                "attitude inflation must be finite, symmetric and positive semi-definite".into(),
            ));
        }
        self.core.inflate_attitude(cov_rad2);
        Ok(())
    }

    fn bias_rad_s(&self) -> Vector3<f64> {
        self.core.bias_rad_s()
    }

    fn estimate(&self) -> Estimate {
        let mut e = self.core.estimate();
        e.t_s = self.t_s.unwrap_or(0.0);
        e.diagnostics.gyro_gap_s = self.t_s.and_then(|t| self.gap_at(t));
        e.diagnostics.gyro_gaps = self.gyro_gaps;
        e
    }

    fn state(&self) -> FilterState {
        F::state(self)
    }

    fn state_into(&self, into: &mut FilterState) {
        F::state_into(self, into)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{build_filter, FilterConfig, FilterSpec, InitialState};
    use crate::attitude::Quaternion;
    use crate::sensors::VectorObservation;
    use crate::sensors::{Aspect, GyroNoise, GyroSample, Measurement, ObservationSet};
    use nalgebra::Vector3;

    /// The raw-IMU pipeline's calls are exactly the general ones: `gyro_interval` is `process` of the
    /// gyro sample then `advance_to`, `observe` is `process` of a set of one, for every filter, bit
    /// for bit (estimates, particles' moments and errors alike).
    #[test]
    fn the_pipelines_calls_are_the_general_ones() {
        for spec in ["mekf", "usque", "qpf:average"] {
            let spec: FilterSpec = spec.parse().unwrap();
            let mut config = FilterConfig::new(
                spec,
                GyroNoise {
                    sigma_v: 3e-3,
                    sigma_u: 3e-5,
                },
            );
            config.particles = 200;
            let initial = InitialState {
                t_s: Some(0.0),
                q: Quaternion::from_euler_321(0.3, -0.2, 0.1),
                sigma_att_rad: Vector3::repeat(0.05),
                bias_rad_s: Vector3::zeros(),
                bias_sigma_rad_s: Vector3::repeat(0.01),
                uniform_attitude: false,
                covariance: None,
            };
            let mut a = build_filter(&config, &initial, 7).unwrap();
            let mut b = build_filter(&config, &initial, 7).unwrap();
            let dt = 0.0035;
            for k in 1..400 {
                let (t0, t) = ((k - 1) as f64 * dt, k as f64 * dt);
                let w = Vector3::new((0.01 * k as f64).sin(), 0.3, -0.2);
                // A time stamp out of order now and then: both refuse it alike.
                let t = if k % 150 == 0 { t0 - 1.0 } else { t };
                let ra = a.gyro_interval(t0, &w, t);
                let rb = b
                    .process(&Measurement::Gyro(GyroSample {
                        t_s: t0,
                        omega_body_rad_s: w,
                    }))
                    .and_then(|()| b.advance_to(t));
                assert_eq!(ra, rb, "{spec} sample {k}");
                if k % 29 == 0 {
                    let o = VectorObservation {
                        body: Vector3::new(0.1, 0.05 * (k as f64).cos(), 1.0).normalize(),
                        reference: Vector3::z(),
                        sigma: 0.01,
                        sensor: None,
                        aspect: if k % 58 == 0 {
                            Aspect::Tilt(Vector3::z())
                        } else {
                            Aspect::Full
                        },
                    };
                    let t = a.time_s().unwrap();
                    let ra = a.observe(t, &o);
                    let rb = b.process(&Measurement::Vectors(ObservationSet {
                        t_s: t,
                        observations: vec![o],
                    }));
                    assert_eq!(ra, rb, "{spec} sample {k}");
                }
                assert_eq!(
                    format!("{:?}", a.estimate()),
                    format!("{:?}", b.estimate()),
                    "{spec} sample {k}"
                );
            }
        }
    }
}
