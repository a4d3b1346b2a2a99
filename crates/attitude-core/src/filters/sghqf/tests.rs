//! Unit tests of the SGHQF's pieces that need its private state; the filter's behaviour is tested
//! in tests/it/sghqf.rs.

use super::*;
use crate::filters::FilterSpec;
use crate::sensors::GyroNoise;
use nalgebra::Vector3;

fn filter(level: u8, fiducial: &str) -> Sghqf {
    let spec: FilterSpec = format!("sghqf:{fiducial}").parse().unwrap();
    let mut config = FilterConfig::new(spec, GyroNoise::standard());
    config.level = level;
    let initial = InitialState {
        t_s: Some(0.0),
        q: Quaternion::IDENTITY,
        sigma_att_rad: Vector3::repeat(0.1),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(1e-5),
        uniform_attitude: false,
        covariance: None,
    };
    Sghqf::new(&config, &initial).unwrap()
}

#[test]
fn the_drawn_points_reproduce_the_mean_and_covariance() {
    for level in LEVELS {
        let f = filter(level, "average");
        let pts = f.draw(&f.p).unwrap();
        let w = &f.rule().weights;
        let mean: Vector6<f64> = pts.chi.iter().zip(w).map(|(c, w)| c * *w).sum();
        let cov: Matrix6<f64> = pts
            .chi
            .iter()
            .zip(w)
            .map(|(c, w)| (c - mean) * (c - mean).transpose() * *w)
            .sum();
        assert!((mean - f.x).amax() < 1e-15);
        assert!((cov - f.p).amax() < 1e-14 * f.p.amax(), "L = {level}");
        // The central point is the estimate.
        assert_eq!(pts.q[0], f.q_ref);
    }
}

#[test]
fn levels_outside_two_to_four_are_refused() {
    for level in [0, 1, 5] {
        assert!(matches!(rule_of(level), Err(FilterError::InvalidConfig(_))));
    }
}
