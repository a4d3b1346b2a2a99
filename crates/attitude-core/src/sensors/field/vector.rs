//! A `field` sensor on `P/V/vectors` (see [`crate::sensors::model`]): disturbance by norm and dip,
//! optionally heading-only.

use nalgebra::{Matrix3, Vector3};

use super::{dip_rad, FieldDeviation};
use crate::sensors::check::{limit, non_negative};
use crate::sensors::model::{unit_pair, Verdict};
use crate::sensors::{Aspect, VectorObservation};

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

impl FieldModel {
    /// Checks every value; `at` is the sensor's path in the configuration, ending with a dot
    /// (`service.sensors.NAME.`). (The dip limit is checked in radians, named as configured, in
    /// degrees.)
    pub fn validate(&self, at: &str) -> Result<(), String> {
        non_negative(self.sigma_norm_scale, &format!("{at}sigma_norm_scale"))?;
        limit(self.norm_limit, &format!("{at}norm_limit"))?;
        limit(
            self.dip_limit_rad.to_degrees(),
            &format!("{at}dip_limit_deg"),
        )?;
        non_negative(self.holdoff_s, &format!("{at}holdoff_s"))
    }

    /// Judges `o` against the reference; `a_est` is the current estimate's attitude matrix
    /// (reference → body), which gives the body-frame vertical for the dip check.
    pub fn apply(&self, o: &VectorObservation, a_est: &Matrix3<f64>) -> Verdict {
        let Some((b, r, nb, nr)) = unit_pair(o) else {
            return Verdict::Unusable;
        };
        let up = match self.vertical.try_normalize(0.0) {
            Some(u) if u.iter().all(|x| x.is_finite()) => u,
            _ => return Verdict::Unusable,
        };
        // (The measured dip against the estimate's vertical in the body frame.)
        let up_body = a_est * up;
        let deviation = FieldDeviation::between(nb, dip_rad(&b, &up_body), nr, dip_rad(&r, &up));
        if !deviation.within(self.norm_limit, self.dip_limit_rad) {
            return Verdict::Disturbed {
                norm_deviation: deviation.norm,
                dip_deviation_rad: deviation.dip_rad,
            };
        }
        Verdict::Use(VectorObservation {
            body: b,
            reference: r,
            sigma: o.sigma / nr * (1.0 + self.sigma_norm_scale * deviation.norm),
            sensor: o.sensor.clone(),
            aspect: if self.heading_only {
                Aspect::Heading(up)
            } else {
                Aspect::Full
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Quaternion;

    use crate::sensors::model::tests::obs;

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
}
