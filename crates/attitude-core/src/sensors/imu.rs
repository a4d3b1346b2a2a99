//! Sensor models of an inertial measurement unit's vector sensors, as a service for real vehicles
//! needs them: an accelerometer read as the direction of gravity, and a magnetometer read as the
//! direction of the local field, both disturbed by what they see besides (motion; iron and currents).
//!
//! * **Gravity** ([`GravityModel`]): the accelerometer measures the specific force, which points up at
//!   rest. Its direction is a vector observation of the reference frame's vertical; its norm says how
//!   much else it sees: with `d = |‖b‖/‖r‖ − 1|` (the relative deviation of the measured norm from the
//!   reference norm, e.g. 9.81 m/s²) the direction's 1σ grows to `σ/‖r‖ · (1 + k·d)` rad, and an
//!   observation with `d > norm_gate` is not used at all.
//! * **Field** ([`FieldModel`]): the magnetometer's direction against the reference field. It is
//!   *disturbed* when its norm deviates from the reference norm by more than `norm_limit` (relative) or
//!   its dip (the angle below the horizontal plane, measured against the current estimate's vertical)
//!   from the reference's dip by more than `dip_limit_rad`. A disturbed observation is not used, and
//!   the service keeps the sensor suspended for `holdoff_s` after the last disturbed one. With
//!   `heading_only` the observation corrects only the rotation about the vertical (the filter sees a
//!   heading-only observation, [`super::Aspect::Heading`]), so a field error never tilts the
//!   estimate.
//!
//! **Heading-only observation.** With `up` the reference frame's vertical (unit), `e₁` the unit
//! horizontal part of the reference `r` and `e₂ = up × e₁`, the heading residual of an attitude `A`
//! (reference → body) is `ψ(A) = atan2(b·(A e₂), b·(A e₁))`: the angle about `up` from `e₁` to the
//! horizontal part of `Aᵀ b`. For the true attitude `A = A(δα) Â` (body-frame error `δα`) and an exact
//! `b`, `y = −ψ(Â) ≈ hᵀ δα` ([`heading_jacobian`]) with `hᵀ v = 1` for the body-frame vertical
//! `v = Â up`: a rotation about the vertical is seen one to one; a tilt error leaks into the heading of
//! a field with a dip (`∝ tan dip`), as in any heading from a magnetometer. `σ_ψ = σ/‖r_h‖`
//! ([`heading_sigma_rad`]). The MEKF uses `H = [hᵀ, 0₃]` (so the innovation variance counts the tilt
//! uncertainty) with its attitude gain projected on the vertical (`K_α ← v vᵀ K_α`, Joseph form, valid
//! for any gain), so the field never tilts the estimate; the particle filter weighs particles by
//! `exp(−ψᵢ²/2σ_ψ²)` (exact, so a particle's tilt is weighed by the leak too); USQUE, which has no
//! scalar update, uses the full vector instead.
//!
//! Numeric core: no I/O; no panics on any input (a non-finite input gives a typed verdict).

use nalgebra::{Matrix3, Vector3};

use super::{Aspect, VectorObservation};
use crate::attitude::Quaternion;

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
/// that time, and the estimate after that time's update (`posterior`, which [`SensorState::settle`]
/// records).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LowpassState {
    pub t_s: Option<f64>,
    pub body_frame: Vector3<f64>,
    pub posterior: Option<Quaternion>,
}

/// The magnetometer as a field-direction observation with disturbance detection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldModel {
    /// `k`: the direction's 1σ is `σ/‖r‖ · (1 + k·d)`, `d = |‖b‖/‖r‖ − 1|`.
    pub sigma_norm_scale: f64,
    /// Largest relative norm deviation `d` of an undisturbed field.
    pub norm_limit: f64,
    /// Largest deviation of the measured dip from the reference dip of an undisturbed field, rad.
    pub dip_limit_rad: f64,
    /// Time the sensor stays suspended after its last disturbed observation, s.
    pub holdoff_s: f64,
    /// Correct only the rotation about `vertical`.
    pub heading_only: bool,
    /// The reference frame's vertical (unit; up or down, only its line matters for the heading; the
    /// dip is measured below the plane perpendicular to it, positive opposite to it).
    pub vertical: Vector3<f64>,
}

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

/// `(b/‖b‖, r/‖r‖, ‖b‖/‖r‖)`, or `None` when either has no direction.
fn unit_pair(o: &VectorObservation) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
    let (nb, nr) = (o.body.norm(), o.reference.norm());
    if !(nb > 0.0 && nb.is_finite() && nr > 0.0 && nr.is_finite() && o.sigma.is_finite()) {
        return None;
    }
    Some((o.body / nb, o.reference / nr, nb / nr))
}

impl GravityModel {
    /// The low-pass filtered measurement, in the body frame. Between two sets the filtered vector is
    /// carried along with the body's rotation as the filter propagated it, `Â⁻(t) Â⁺(t₀)ᵀ` (prior at
    /// this set times the transpose of the posterior after the last one: the gyro's rotation, bias
    /// removed, without the corrections of the updates), then filtered:
    /// `f ← f + (b − f)(1 − e^{−Δt/τ})`. This is a low-pass filter in a frame that turns only with the
    /// gyro (VQF's accelerometer filter, Laidig & Seel 2023): accelerations of a vehicle that moves
    /// back and forth average out, gravity does not, and the filter's own corrections never feed back
    /// into the measurement. Returns `body` unchanged when `lowpass_s` is 0, and restarts after a time
    /// reversal or a non-finite value. [`SensorState::settle`] must record the posterior after each set.
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
        let Some((_, r, ratio)) = unit_pair(o) else {
            return Verdict::Unusable;
        };
        let b = match direction.try_normalize(0.0) {
            Some(b) if b.iter().all(|x| x.is_finite()) => b,
            _ => return Verdict::Unusable,
        };
        let d = (ratio - 1.0).abs();
        if !(d <= self.norm_gate) {
            return Verdict::NormGated { deviation: d };
        }
        Verdict::Use(VectorObservation {
            body: b,
            reference: r,
            sigma: o.sigma / o.reference.norm() * (1.0 + self.sigma_norm_scale * d),
            sensor: o.sensor.clone(),
            aspect: Aspect::Full,
        })
    }
}

/// The dip of unit `v` below the plane perpendicular to unit `up`, rad (positive opposite to `up`).
pub fn dip_rad(v: &Vector3<f64>, up: &Vector3<f64>) -> f64 {
    (-v.dot(up)).clamp(-1.0, 1.0).asin()
}

impl FieldModel {
    /// Judges `o` against the reference; `a_est` is the current estimate's attitude matrix
    /// (reference → body), which gives the body-frame vertical for the dip check.
    pub fn apply(&self, o: &VectorObservation, a_est: &Matrix3<f64>) -> Verdict {
        let Some((b, r, ratio)) = unit_pair(o) else {
            return Verdict::Unusable;
        };
        let up = match self.vertical.try_normalize(0.0) {
            Some(u) if u.iter().all(|x| x.is_finite()) => u,
            _ => return Verdict::Unusable,
        };
        let d = (ratio - 1.0).abs();
        let up_body = a_est * up;
        let dip_dev = (dip_rad(&b, &up_body) - dip_rad(&r, &up)).abs();
        if !(d <= self.norm_limit) || !(dip_dev <= self.dip_limit_rad) {
            return Verdict::Disturbed {
                norm_deviation: d,
                dip_deviation_rad: dip_dev,
            };
        }
        Verdict::Use(VectorObservation {
            body: b,
            reference: r,
            sigma: o.sigma / o.reference.norm() * (1.0 + self.sigma_norm_scale * d),
            sensor: o.sensor.clone(),
            aspect: if self.heading_only {
                Aspect::Heading(up)
            } else {
                Aspect::Full
            },
        })
    }
}

/// The heading geometry of an observation about `up`: `(e₁, e₂, ‖r_h‖)`, with `r_h` the part of
/// `reference` perpendicular to `up` (unit `up` is normalised here). `None` when the reference has no
/// horizontal part (then the observation says nothing about the heading) or `up` no direction.
pub fn heading_basis(
    reference: &Vector3<f64>,
    up: &Vector3<f64>,
) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
    let up = up.try_normalize(0.0)?;
    let rh = reference - up * reference.dot(&up);
    let n = rh.norm();
    if !(n > 1e-9 * reference.norm() && n.is_finite()) {
        return None;
    }
    let e1 = rh / n;
    Some((e1, up.cross(&e1), n))
}

/// The heading observation's 1σ, rad: `σ/‖r_h‖` (the noise of the horizontal component, per axis, over
/// its length).
pub fn heading_sigma_rad(sigma: f64, horizontal_norm: f64) -> f64 {
    sigma / horizontal_norm
}

/// `ψ(A) = atan2(b·(A e₂), b·(A e₁))`, the heading residual of the attitude `A` (see the module docs).
pub fn heading_residual(
    a: &Matrix3<f64>,
    body: &Vector3<f64>,
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
) -> f64 {
    body.dot(&(a * e2)).atan2(body.dot(&(a * e1)))
}

/// The attitude Jacobian `h` of `y = −ψ(Â)` ([`heading_residual`]) about the estimate `Â`, evaluated at
/// the predicted measurement `b̂ = Â r`: `h = −((Â e₂) × b̂) / ‖r_h‖`, so `y ≈ hᵀ δα` for the body-frame
/// error `δα` (`A = A(δα) Â`). Its component along the body-frame vertical
/// `v = Â up` is 1 (`hᵀ v = 1`); its horizontal components are the leak of a tilt error into the
/// heading of a field with a dip (`∝ tan dip`). `reference` is the unit reference, `horizontal` its
/// horizontal norm.
pub fn heading_jacobian(
    a: &Matrix3<f64>,
    reference: &Vector3<f64>,
    e2: &Vector3<f64>,
    horizontal: f64,
) -> Vector3<f64> {
    let b_hat = a * reference;
    // (Â e₂)ᵀ [b̂×] δα = (Â e₂)·(b̂ × δα) = ((Â e₂) × b̂)·δα.
    -((a * e2).cross(&b_hat)) / horizontal
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs(body: Vector3<f64>, reference: Vector3<f64>, sigma: f64) -> VectorObservation {
        VectorObservation {
            body,
            reference,
            sigma,
            sensor: Some("s".into()),
            aspect: Aspect::Full,
        }
    }

    fn field() -> FieldModel {
        FieldModel {
            sigma_norm_scale: 10.0,
            norm_limit: 0.1,
            dip_limit_rad: 5f64.to_radians(),
            holdoff_s: 1.0,
            heading_only: true,
            vertical: Vector3::z(),
        }
    }

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

    #[test]
    fn field_disturbance_by_norm_and_dip() {
        let dip = 60f64.to_radians();
        let r = Vector3::new(0.0, dip.cos(), -dip.sin()) * 50.0;
        let q = Quaternion::from_euler_321(0.3, -0.2, 1.1);
        let a = q.attitude_matrix();
        let m = field();
        let Verdict::Use(u) = m.apply(&obs(a * r, r, 5.0), &a) else {
            panic!("clean")
        };
        assert_eq!(u.aspect, Aspect::Heading(Vector3::z()));
        assert!((u.sigma - 0.1).abs() < 1e-12);
        assert!(matches!(
            m.apply(&obs(a * r * 1.2, r, 5.0), &a),
            Verdict::Disturbed { .. }
        ));
        // Same norm, dip 70°.
        let d2 = 70f64.to_radians();
        let r2 = Vector3::new(0.0, d2.cos(), -d2.sin()) * 50.0;
        assert!(matches!(
            m.apply(&obs(a * r2, r, 5.0), &a),
            Verdict::Disturbed { dip_deviation_rad, .. } if (dip_deviation_rad - 10f64.to_radians()).abs() < 1e-9
        ));
    }

    /// `y = −ψ(Â)` against [`heading_jacobian`] by central differences, with `A_true = A(δα) Â`; its
    /// vertical component is 1.
    #[test]
    fn heading_jacobian_matches_finite_differences() {
        let dip = 65f64.to_radians();
        let r = Vector3::new(0.0, dip.cos(), -dip.sin());
        let up = Vector3::new(0.0, 0.0, 1.0);
        let (e1, e2, r_h) = heading_basis(&r, &up).unwrap();
        let truth = Quaternion::from_euler_321(0.7, 0.4, -0.3);
        let a_true = truth.attitude_matrix();
        let b = a_true * r;
        let eps = 1e-6;
        for k in 0..3 {
            // Â = A(δα)ᵀ A_true for δα = ±ε e_k.
            let y = |s: f64| {
                let mut da = Vector3::zeros();
                da[k] = s * eps;
                let est = Quaternion::from_rotation_vector(&da)
                    .inverse()
                    .compose(&truth);
                -heading_residual(&est.attitude_matrix(), &b, &e1, &e2)
            };
            let numeric = (y(1.0) - y(-1.0)) / (2.0 * eps);
            let analytic = heading_jacobian(&a_true, &r, &e2, r_h)[k];
            assert!(
                (numeric - analytic).abs() < 1e-6,
                "axis {k}: {numeric} vs {analytic}"
            );
        }
        let h = heading_jacobian(&a_true, &r, &e2, r_h);
        assert!((h.dot(&(a_true * up)) - 1.0).abs() < 1e-12);
    }
}
