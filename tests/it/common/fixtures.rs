//! Fixtures and checks that several modules use alike.

use attitude_service::attitude::Quaternion;
use attitude_service::service::config::{self, Policy, ServiceConfig, VehicleFilterConfig};
use attitude_service::vehicle::Event;
use attitude_service::wire::EstimateMsg;
use proptest::prelude::*;

/// The preset for an IMU on `P/V/imu` (`config/imu.json5`): its default filter and policy.
pub fn imu_preset() -> (VehicleFilterConfig, Policy) {
    let c = config::parse(
        include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/config/imu.json5")),
        "config/imu.json5",
    )
    .unwrap();
    (c.service.default_filter.clone(), c.service.policy.clone())
}

/// The service's default policy (reorder window, gate, health).
pub fn default_policy() -> Policy {
    ServiceConfig::default().policy
}

/// The estimates among `events`, as the service publishes them.
pub fn estimates(events: &[Event]) -> Vec<EstimateMsg> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Estimate(p) => Some(EstimateMsg::from(p)),
            _ => None,
        })
        .collect()
}

/// Any unit quaternion (proptest strategy: a normalised non-degenerate 4-vector).
pub fn unit_quaternion() -> impl Strategy<Value = Quaternion> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0).prop_filter_map(
        "non-degenerate",
        |(x, y, z, w)| {
            Quaternion::new(x, y, z, w)
                .normalized()
                .filter(|_| (x * x + y * y + z * z + w * w) > 1e-3)
        },
    )
}

/// `χ²₁₂₀` quantiles 0.0005 and 0.9995 (scipy.stats.chi2.ppf): the sum of 40 independent 3-dof NEES
/// samples, or of 20 6-dof ones, of a consistent filter lies between them with probability 0.999.
pub const CHI2_120: (f64, f64) = (75.467, 177.603);

/// `nees` (a mean NEES, as `what` says) inside `[lo, hi]`, and the bound has power: the same runs with
/// the covariance 1.5× too small or too large in σ (every NEES × 2.25 or ÷ 2.25) fall outside it.
pub fn assert_nees_with_power(what: &str, nees: f64, (lo, hi): (f64, f64)) {
    assert!(
        (lo..=hi).contains(&nees),
        "{what} {nees} outside [{lo}, {hi}]"
    );
    for scale in [2.25, 1.0 / 2.25] {
        assert!(
            !(lo..=hi).contains(&(nees * scale)),
            "{what}: with a covariance scaled by 1/{scale} ({}) it would pass [{lo}, {hi}]",
            nees * scale
        );
    }
}
