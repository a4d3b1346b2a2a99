//! A `gravity` sensor on `P/V/vectors` (see [`crate::sensors::model`]): its low-pass and its norm gate.

use nalgebra::{Matrix3, Vector3};

use super::{norm_deviation, passes_norm_gate};
use crate::attitude::Quaternion;
use crate::sensors::check::{limit, non_negative};
use crate::sensors::model::{unit_pair, Verdict};
use crate::sensors::{Aspect, VectorObservation};

/// The accelerometer as a gravity-direction observation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GravityModel {
    /// `k`: the direction's 1σ is `σ/‖r‖ · (1 + k·d)`, `d = |‖b‖/‖r‖ − 1|`.
    pub sigma_norm_scale: f64,
    /// Largest `d` used; beyond it the observation is gated (not used).
    pub norm_gate: f64,
    /// Time constant of a low-pass filter applied to the measurement in a frame that turns with the
    /// gyro only, s (0: none). See [`GravityModel::lowpass`].
    pub lowpass_s: f64,
}

/// The state of [`GravityModel::lowpass`]: the time, the filtered measurement in the body frame of
/// that time, and the estimate after that time's update (`posterior`, which `SensorState::settle`
/// records).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LowpassState {
    pub t_s: Option<f64>,
    pub body_frame: Vector3<f64>,
    pub posterior: Option<Quaternion>,
}

impl GravityModel {
    /// Checks every value; `at` is the sensor's path in the configuration, ending with a dot
    /// (`service.sensors.NAME.`).
    pub fn validate(&self, at: &str) -> Result<(), String> {
        non_negative(self.sigma_norm_scale, &format!("{at}sigma_norm_scale"))?;
        limit(self.norm_gate, &format!("{at}norm_gate"))?;
        non_negative(self.lowpass_s, &format!("{at}lowpass_s"))
    }

    /// The low-pass filtered measurement, in the body frame. Between two sets the filtered vector is
    /// carried along with the body's rotation as the filter propagated it, `Â⁻(t) Â⁺(t₀)ᵀ` (prior at
    /// this set times the transpose of the posterior after the last one: the gyro's rotation, bias
    /// removed, without the corrections of the updates), then filtered:
    /// `f ← f + (b − f)(1 − e^{−Δt/τ})`. This is a low-pass filter in a frame that turns only with the
    /// gyro (VQF's accelerometer filter, Laidig & Seel 2023): accelerations of a vehicle that moves
    /// back and forth average out, gravity does not, and the filter's own corrections never feed back
    /// into the measurement. Returns `body` unchanged when `lowpass_s` is 0, and restarts after a time
    /// reversal or a non-finite value. `SensorState::settle` must record the posterior after each set.
    pub fn lowpass(
        &self,
        state: &mut LowpassState,
        t_s: f64,
        body: &Vector3<f64>,
        a_prior: &Matrix3<f64>,
    ) -> Vector3<f64> {
        if !(self.lowpass_s > 0.0) {
            return *body;
        }
        let next = match (state.t_s, state.posterior) {
            (Some(t0), Some(post))
                if t_s >= t0 && state.body_frame.iter().all(|x| x.is_finite()) =>
            {
                let carried = a_prior * (post.attitude_matrix().transpose() * state.body_frame);
                let k = 1.0 - (-(t_s - t0) / self.lowpass_s).exp();
                carried + (body - carried) * k
            }
            _ => *body,
        };
        if !next.iter().all(|x| x.is_finite()) {
            *state = LowpassState::default();
            return *body;
        }
        state.t_s = Some(t_s);
        state.body_frame = next;
        next
    }

    /// Judges `o` by its raw norm; the direction used is that of `direction` (the low-pass filtered
    /// measurement of [`GravityModel::lowpass`], or `o.body` itself).
    pub fn apply(&self, o: &VectorObservation, direction: &Vector3<f64>) -> Verdict {
        let Some((_, r, nb, nr)) = unit_pair(o) else {
            return Verdict::Unusable;
        };
        let b = match direction.try_normalize(0.0) {
            Some(b) if b.iter().all(|x| x.is_finite()) => b,
            _ => return Verdict::Unusable,
        };
        let d = norm_deviation(nb, nr);
        if !passes_norm_gate(d, self.norm_gate) {
            return Verdict::NormGated { deviation: d };
        }
        Verdict::Use(VectorObservation {
            body: b,
            reference: r,
            sigma: o.sigma / nr * (1.0 + self.sigma_norm_scale * d),
            sensor: o.sensor.clone(),
            aspect: Aspect::Full,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::sensors::model::tests::obs;

    #[test]
    fn gravity_sigma_grows_with_the_norm_deviation_and_gates() {
        let g = GravityModel {
            sigma_norm_scale: 10.0,
            norm_gate: 0.5,
            lowpass_s: 0.0,
        };
        let r = Vector3::new(0.0, 0.0, 9.81);
        let Verdict::Use(at_rest) = g.apply(&obs(r, r, 0.4905), &(r)) else {
            panic!("at rest")
        };
        assert!((at_rest.sigma - 0.05).abs() < 1e-12);
        assert!((at_rest.body.norm() - 1.0).abs() < 1e-12);
        let Verdict::Use(moving) = g.apply(&obs(r * 1.2, r, 0.4905), &(r * 1.2)) else {
            panic!("moving")
        };
        assert!((moving.sigma - 0.05 * 3.0).abs() < 1e-12);
        assert!(matches!(
            g.apply(&obs(r * 1.6, r, 0.49), &(r * 1.6)),
            Verdict::NormGated { deviation } if (deviation - 0.6).abs() < 1e-12
        ));
        assert_eq!(
            g.apply(&obs(Vector3::zeros(), r, 0.49), &(Vector3::zeros())),
            Verdict::Unusable
        );
    }
}
