//! The models of named sensors on `P/V/vectors` (`service.sensors.NAME.kind`): what a vehicle makes
//! of an observation of a `gravity` or a `field` sensor before its filter sees it
//! (`vehicle::VehicleState::apply_models`), and the state each keeps.
//!
//! * **Gravity** ([`GravityModel`], [`super::gravity::vector`]): the accelerometer measures the specific
//!   force, which points up at rest. Its direction is a vector observation of the reference frame's
//!   vertical; its norm says how much else it sees: with `d = |‖b‖/‖r‖ − 1|` (the relative deviation of
//!   the measured norm from the reference norm, e.g. 9.81 m/s², [`super::gravity::norm_deviation`]) the
//!   direction's 1σ grows to `σ/‖r‖ · (1 + k·d)` rad, and an observation with `d > norm_gate` is not
//!   used at all.
//! * **Field** ([`FieldModel`]): the magnetometer's direction against the reference field. It is
//!   *disturbed* when its norm deviates from the reference norm by more than `norm_limit` (relative) or
//!   its dip (the angle below the horizontal plane, measured against the current estimate's vertical)
//!   from the reference's dip by more than `dip_limit_rad`. A disturbed observation is not used, and
//!   the service keeps the sensor suspended for `holdoff_s` after the last disturbed one. With
//!   `heading_only` the observation corrects only the rotation about the vertical (the filter sees a
//!   heading-only observation, [`super::Aspect::Heading`]), so a field error never tilts the
//!   estimate.
//!
//! The raw-IMU pipeline reads the same two sensors with the same tests (the norm gate, the field's
//! norm and dip against its reference, [`super::field::FieldDeviation`]) and the same heading
//! observation ([`super::heading`]), in channels of their own (`super::gravity::channel`,
//! `super::field::channel`): there the gyro's own rotation is known sample by sample, so the
//! low-pass and the field's reference live in the gyro frame and are learned from the data; here an
//! observation comes alone, with its reference, and is judged against the filter's estimate.
//!
//! Numeric core: no I/O; no panics on any input (a non-finite input gives a typed verdict).

use nalgebra::{Matrix3, Vector3};

use super::field::FieldModel;
use super::gravity::{GravityModel, LowpassState};
use super::VectorObservation;
use crate::attitude::Quaternion;

/// The model of a named sensor (`service.sensors.NAME.kind`); a sensor without one is a plain vector
/// observation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SensorModel {
    Gravity(GravityModel),
    Field(FieldModel),
}

/// A vehicle's state of one modelled sensor: the gravity low-pass, the field's last disturbance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorState {
    pub lowpass: LowpassState,
    pub last_disturbed_t_s: Option<f64>,
}

/// What a model makes of one observation.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// Use this observation (unit vectors, adapted σ in rad).
    Use(VectorObservation),
    /// A gravity observation whose norm deviates too far (`deviation` = `d`).
    NormGated { deviation: f64 },
    /// A field observation judged disturbed: relative norm deviation and dip deviation (rad; NaN
    /// when not computed).
    Disturbed {
        norm_deviation: f64,
        dip_deviation_rad: f64,
    },
    /// A field observation that is clean but within the hold-off after a disturbance.
    HeldOff,
    /// Body or reference has no direction (zero or non-finite): unusable.
    Unusable,
}

impl SensorState {
    /// Records the estimate after the set just used (or refused): the low-pass filter carries its
    /// vector from this attitude to the next set's prior.
    pub fn settle(&mut self, posterior: &Quaternion) {
        if self.lowpass.t_s.is_some() {
            self.lowpass.posterior = Some(*posterior);
        }
    }
}

impl SensorModel {
    /// Applies the model to `o` at `t_s` with the current estimate's attitude matrix `a_est`, updating
    /// the sensor's `state` (low-pass; last disturbance, after which a field stays suspended for
    /// `holdoff_s`).
    pub fn apply(
        &self,
        o: &VectorObservation,
        t_s: f64,
        a_est: &Matrix3<f64>,
        state: &mut SensorState,
    ) -> Verdict {
        match self {
            SensorModel::Gravity(g) => {
                let direction = g.lowpass(&mut state.lowpass, t_s, &o.body, a_est);
                g.apply(o, &direction)
            }
            SensorModel::Field(f) => {
                let verdict = f.apply(o, a_est);
                match verdict {
                    Verdict::Disturbed { .. } => {
                        state.last_disturbed_t_s = Some(t_s);
                        verdict
                    }
                    Verdict::Use(_)
                        if state
                            .last_disturbed_t_s
                            .is_some_and(|t| t_s >= t && t_s - t < f.holdoff_s) =>
                    {
                        Verdict::HeldOff
                    }
                    other => other,
                }
            }
        }
    }
}

/// `(b/‖b‖, r/‖r‖, ‖b‖, ‖r‖)`, or `None` when either has no direction.
pub(super) fn unit_pair(o: &VectorObservation) -> Option<(Vector3<f64>, Vector3<f64>, f64, f64)> {
    let (nb, nr) = (o.body.norm(), o.reference.norm());
    if !(nb > 0.0 && nb.is_finite() && nr > 0.0 && nr.is_finite() && o.sigma.is_finite()) {
        return None;
    }
    Some((o.body / nb, o.reference / nr, nb, nr))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sensors::Aspect;

    /// A full-direction observation of sensor "s" (the models' tests).
    pub(crate) fn obs(
        body: Vector3<f64>,
        reference: Vector3<f64>,
        sigma: f64,
    ) -> VectorObservation {
        VectorObservation {
            body,
            reference,
            sigma,
            sensor: Some("s".into()),
            aspect: Aspect::Full,
        }
    }
}
