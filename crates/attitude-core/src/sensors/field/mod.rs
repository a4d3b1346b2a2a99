//! The magnetometer read as the direction of the local field, on both paths: a `field` sensor on
//! `P/V/vectors` ([`vector`], applied by `vehicle::VehicleState::apply_models`) and the raw-IMU
//! pipeline's field channel ([`channel`]: the reference learned from the data, disturbance, new
//! fields, the hard-iron fit of [`hard_iron`]; settings in [`config`]). What the two share is here: the
//! dip and the test of a reading against a reference by its norm and dip. Both read the heading with
//! [`crate::sensors::heading`].

pub mod channel;
pub mod config;
pub mod hard_iron;
pub mod vector;

pub use channel::{FieldChannel, FieldGains, HeadingObservation};
pub use config::{HardIronConfig, MagConfig};
pub use hard_iron::{HardIronFit, HardIronSolution};
pub use vector::FieldModel;

use nalgebra::Vector3;

/// The dip of unit `v` below the plane perpendicular to unit `up`, rad (positive opposite to `up`).
pub fn dip_rad(v: &Vector3<f64>, up: &Vector3<f64>) -> f64 {
    (-v.dot(up)).clamp(-1.0, 1.0).asin()
}

/// How far a field reading is from a reference: its norm's relative deviation `|n/n₀ − 1|` and its
/// dip's deviation, rad.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldDeviation {
    pub norm: f64,
    pub dip_rad: f64,
}

impl FieldDeviation {
    /// The deviation of a reading of norm `norm` and dip `dip` (rad) from a reference's.
    pub fn between(norm: f64, dip: f64, reference_norm: f64, reference_dip: f64) -> Self {
        FieldDeviation {
            norm: (norm / reference_norm - 1.0).abs(),
            dip_rad: (dip - reference_dip).abs(),
        }
    }

    /// Whether the reading is the reference's field: its norm within `norm_limit` (relative) and its
    /// dip within `dip_limit_rad`. A NaN never is.
    pub fn within(&self, norm_limit: f64, dip_limit_rad: f64) -> bool {
        self.norm <= norm_limit && self.dip_rad <= dip_limit_rad
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use nalgebra::Vector3;

    /// A field of 45 (µT) with dip `dip_deg`, its horizontal part along y (the channels' tests).
    pub(crate) fn field(dip_deg: f64) -> Vector3<f64> {
        let d = dip_deg.to_radians();
        Vector3::new(0.0, d.cos(), -d.sin()) * 45.0
    }

    /// The one test of a reading against a reference that both paths use: relative in the norm,
    /// inclusive at the limits, never within for a NaN or a reference without a norm.
    #[test]
    fn a_field_deviation_is_relative_and_a_nan_is_never_within() {
        use super::FieldDeviation;
        let d = FieldDeviation::between(55.0, 0.5, 50.0, 0.4);
        assert!((d.norm - 0.1).abs() < 1e-15 && (d.dip_rad - 0.1).abs() < 1e-15);
        assert!(d.within(0.11, 0.11) && !d.within(0.09, 0.2) && !d.within(0.2, 0.09));
        assert!(!FieldDeviation::between(f64::NAN, 0.5, 50.0, 0.4).within(1.0, 1.0));
        assert!(!FieldDeviation::between(50.0, 0.5, 0.0, 0.4).within(1e9, 1.0));
        assert!(FieldDeviation::between(50.0, 0.4, 50.0, 0.4).within(0.0, 0.0));
    }
}
