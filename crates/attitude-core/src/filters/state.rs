//! A filter's complete state as plain data, and the way back.
//!
//! A checkpoint saves a filter by asking it for its [`FilterState`] and restores it with
//! [`FilterState::restore`], which checks the state before it builds anything: a damaged or
//! hand-edited checkpoint gives an error, never a filter that fails later. The core does not choose a
//! file format: the service's `persist` module has checkpoint structs of its own, converted from and to
//! these types, so that a field added here is a compile error there, not a silent format change.

use super::mekf::Mekf;
use super::qpf::{Cloud, Qpf, QpfOptions};
use super::sghqf::{rule_of, Points, Sghqf};
use super::usque::{SigmaPoints, Usque, UsqueOptions};
use super::{
    is_spd, AttitudeFilter, Diagnostics, Driver, Fiducial, FilterCore, FilterError, GapModel,
    GyroErrors,
};
use crate::attitude::Quaternion;
use crate::sensors::GyroNoise;
use nalgebra::{Matrix6, Vector3, Vector6};

/// The time bookkeeping of [`Driver`]: the filter's time, the held gyro rate and the gap model.
#[derive(Clone, Debug, PartialEq)]
pub struct DriverState {
    pub t_s: Option<f64>,
    pub omega_meas_rad_s: Option<Vector3<f64>>,
    pub last_gyro_t_s: Option<f64>,
    pub last_gyro_dt_s: f64,
    pub gyro_intervals: u64,
    pub gap: GapModel,
    pub sigma_v: f64,
    pub gyro_gaps: u64,
}

/// The MEKF: reference quaternion, bias, covariance of `[δα; δβ]`.
#[derive(Clone, Debug, PartialEq)]
pub struct MekfState {
    pub gyro: GyroNoise,
    pub gyro_errors: GyroErrors,
    pub q: Quaternion,
    pub bias: Vector3<f64>,
    pub p: Matrix6<f64>,
    pub diagnostics: Diagnostics,
}

/// USQUE: the chart centre, the local state and its covariance, the sigma points awaiting an update.
#[derive(Clone, Debug, PartialEq)]
pub struct UsqueState {
    pub gyro: GyroNoise,
    pub gyro_errors: GyroErrors,
    pub options: UsqueOptions,
    pub fiducial: Fiducial,
    pub q_ref: Quaternion,
    pub x: Vector6<f64>,
    pub p: Matrix6<f64>,
    pub sigma: Option<SigmaPoints>,
    pub diagnostics: Diagnostics,
}

/// The SGHQF: as USQUE's, with the rule's level (its points and weights follow from it) and the
/// propagated points awaiting an update (one per point of the rule).
#[derive(Clone, Debug, PartialEq)]
pub struct SghqfState {
    pub gyro: GyroNoise,
    pub gyro_errors: GyroErrors,
    pub level: u8,
    pub fiducial: Fiducial,
    pub q_ref: Quaternion,
    pub x: Vector6<f64>,
    pub p: Matrix6<f64>,
    pub points: Option<Points>,
    pub diagnostics: Diagnostics,
}

/// The QPF: the particle cloud, the estimate kept beside it and the generator's state (a restored
/// filter draws exactly the numbers the saved one would have drawn).
#[derive(Clone, Debug, PartialEq)]
pub struct QpfState {
    pub fiducial: Fiducial,
    pub options: QpfOptions,
    pub gyro: GyroNoise,
    pub gyro_errors: GyroErrors,
    pub cloud: Cloud,
    pub q_prop: Quaternion,
    pub q_hat: Quaternion,
    pub beta_hat: Vector3<f64>,
    pub p_hat: Matrix6<f64>,
    pub stale: bool,
    pub rng: [u64; 4],
    pub diagnostics: Diagnostics,
}

/// Any filter's complete state.
#[derive(Clone, Debug, PartialEq)]
// Made once per checkpoint, never stored in bulk: the size of the largest variant costs nothing.
#[allow(clippy::large_enum_variant)]
pub enum FilterState {
    Mekf(DriverState, MekfState),
    Usque(DriverState, UsqueState),
    Qpf(DriverState, QpfState),
    Sghqf(DriverState, SghqfState),
}

fn invalid(what: impl Into<String>) -> FilterError {
    FilterError::InvalidConfig(format!("saved filter state: {}", what.into()))
}

fn finite(values: impl IntoIterator<Item = f64>, what: &str) -> Result<(), FilterError> {
    if values.into_iter().all(f64::is_finite) {
        Ok(())
    } else {
        Err(invalid(format!("{what} is not finite")))
    }
}

fn unit_quaternion(q: &Quaternion, what: &str) -> Result<(), FilterError> {
    let c = [q.x, q.y, q.z, q.w];
    finite(c, what)?;
    let n2: f64 = c.iter().map(|v| v * v).sum();
    if (n2 - 1.0).abs() > 1e-6 {
        return Err(invalid(format!(
            "{what} is not a unit quaternion (|q|² = {n2})"
        )));
    }
    Ok(())
}

fn spd(p: &Matrix6<f64>, what: &str) -> Result<(), FilterError> {
    if is_spd(p) {
        Ok(())
    } else {
        Err(invalid(format!("{what} is not positive definite")))
    }
}

fn common(gyro: &GyroNoise, errors: &GyroErrors) -> Result<(), FilterError> {
    let ok = |v: f64| v.is_finite() && v >= 0.0;
    if !(ok(gyro.sigma_v) && ok(gyro.sigma_u)) {
        return Err(invalid(
            "gyro noise densities must be non-negative and finite",
        ));
    }
    errors.validate()
}

impl DriverState {
    fn check(&self) -> Result<(), FilterError> {
        let opt = |v: Option<f64>| v.unwrap_or(0.0);
        finite(
            [opt(self.t_s), opt(self.last_gyro_t_s), self.sigma_v]
                .into_iter()
                .chain(self.omega_meas_rad_s.iter().flat_map(|w| w.iter().copied())),
            "filter time or held rate",
        )?;
        if !(self.last_gyro_dt_s > 0.0) || !(self.sigma_v >= 0.0) {
            return Err(invalid("gyro interval or noise out of range"));
        }
        Ok(())
    }
}

impl<F: FilterCore> Driver<F> {
    /// The driver's bookkeeping as plain data.
    pub(super) fn driver_state(&self) -> DriverState {
        DriverState {
            t_s: self.t_s,
            omega_meas_rad_s: self.omega_meas_rad_s,
            last_gyro_t_s: self.last_gyro_t_s,
            last_gyro_dt_s: self.last_gyro_dt_s,
            gyro_intervals: self.gyro_intervals,
            gap: self.gap,
            sigma_v: self.sigma_v,
            gyro_gaps: self.gyro_gaps,
        }
    }

    fn from_state(core: F, s: DriverState) -> Result<Self, FilterError> {
        s.check()?;
        Ok(Driver {
            core,
            t_s: s.t_s,
            omega_meas_rad_s: s.omega_meas_rad_s,
            last_gyro_t_s: s.last_gyro_t_s,
            last_gyro_dt_s: s.last_gyro_dt_s,
            gyro_intervals: s.gyro_intervals,
            gap: s.gap,
            sigma_v: s.sigma_v,
            gyro_gaps: s.gyro_gaps,
            step_extra_rad2: 0.0,
        })
    }
}

impl FilterState {
    /// The filter again, behind the shared interface, after checking the state: finite numbers,
    /// unit quaternions, positive-definite covariances, a consistent particle cloud.
    pub fn restore(self) -> Result<Box<dyn AttitudeFilter>, FilterError> {
        Ok(match self {
            FilterState::Mekf(d, s) => {
                common(&s.gyro, &s.gyro_errors)?;
                unit_quaternion(&s.q, "MEKF attitude")?;
                finite(s.bias.iter().copied(), "MEKF bias")?;
                spd(&s.p, "MEKF covariance")?;
                Box::new(Driver::from_state(Mekf::from_state(s), d)?)
            }
            FilterState::Usque(d, s) => {
                common(&s.gyro, &s.gyro_errors)?;
                s.options.validate()?;
                unit_quaternion(&s.q_ref, "USQUE chart centre")?;
                finite(s.x.iter().copied(), "USQUE state")?;
                spd(&s.p, "USQUE covariance")?;
                if let Some(sp) = &s.sigma {
                    for q in &sp.q {
                        unit_quaternion(q, "USQUE sigma point")?;
                    }
                    finite(
                        sp.chi.iter().flat_map(|c| c.iter().copied()),
                        "USQUE sigma point",
                    )?;
                }
                Box::new(Driver::from_state(Usque::from_state(s), d)?)
            }
            FilterState::Qpf(d, s) => {
                common(&s.gyro, &s.gyro_errors)?;
                s.options.validate()?;
                for (q, what) in [
                    (&s.q_prop, "QPF propagated fiducial"),
                    (&s.q_hat, "QPF estimate"),
                ] {
                    unit_quaternion(q, what)?;
                }
                finite(s.beta_hat.iter().copied(), "QPF bias")?;
                spd(&s.p_hat, "QPF covariance")?;
                s.cloud.check().map_err(invalid)?;
                Box::new(Driver::from_state(Qpf::from_state(s)?, d)?)
            }
            FilterState::Sghqf(d, s) => {
                common(&s.gyro, &s.gyro_errors)?;
                let rule = rule_of(s.level).map_err(|e| invalid(e.to_string()))?;
                unit_quaternion(&s.q_ref, "SGHQF chart centre")?;
                finite(s.x.iter().copied(), "SGHQF state")?;
                spd(&s.p, "SGHQF covariance")?;
                if let Some(pts) = &s.points {
                    if pts.q.len() != rule.len() || pts.chi.len() != rule.len() {
                        return Err(invalid(format!(
                            "SGHQF points: {} quaternions and {} local states for a rule of {}",
                            pts.q.len(),
                            pts.chi.len(),
                            rule.len()
                        )));
                    }
                    for q in &pts.q {
                        unit_quaternion(q, "SGHQF point")?;
                    }
                    finite(
                        pts.chi.iter().flat_map(|c| c.iter().copied()),
                        "SGHQF point",
                    )?;
                }
                Box::new(Driver::from_state(Sghqf::from_state(s)?, d)?)
            }
        })
    }
}
