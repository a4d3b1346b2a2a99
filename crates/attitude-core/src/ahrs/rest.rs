//! Rest detection from the gyro and the accelerometer (the test of Laidig & Seel's VQF): both are
//! low-passed (`τ_r`); the vehicle is at rest once, for `min_duration_s` without a break, every gyro
//! sample stays within `gyr_limit` of its low-pass, the low-passed rate stays below `bias_limit` on
//! every axis (a rate that large is motion, not bias), and every accelerometer sample stays within
//! `acc_limit` of its low-pass. At rest the low-passed gyro is a direct measurement of the gyro bias.

use super::RestConfig;
use crate::sensors::lowpass::Lowpass3;
use nalgebra::Vector3;

#[derive(Clone, Debug, PartialEq)]
pub struct RestDetector {
    pub gyr_lp: Lowpass3,
    pub acc_lp: Lowpass3,
    /// Time without a break of the conditions, s.
    pub still_s: f64,
    pub at_rest: bool,
}

impl RestDetector {
    pub fn new(c: &RestConfig) -> Self {
        RestDetector {
            gyr_lp: Lowpass3::new(c.lowpass_s),
            acc_lp: Lowpass3::new(c.lowpass_s),
            still_s: 0.0,
            at_rest: false,
        }
    }

    /// Takes one sample `dt_s` after the previous; returns whether the vehicle is at rest.
    pub fn update(
        &mut self,
        c: &RestConfig,
        gyr: &Vector3<f64>,
        acc: &Vector3<f64>,
        dt_s: f64,
    ) -> bool {
        let (g, a) = Lowpass3::update_pair(&mut self.gyr_lp, gyr, &mut self.acc_lp, acc, dt_s);
        let still = (gyr - g).norm() < c.gyr_limit_rad_s
            && g.amax() <= c.bias_limit_rad_s
            && (acc - a).norm() < c.acc_limit_m_s2;
        if still {
            self.still_s += dt_s.max(0.0);
        } else {
            self.still_s = 0.0;
        }
        self.at_rest = still && self.still_s >= c.min_duration_s;
        self.at_rest
    }

    pub fn at_rest(&self) -> bool {
        self.at_rest
    }

    /// The low-passed gyro rate (the bias at rest), rad/s.
    pub fn gyr_lowpass(&self) -> Vector3<f64> {
        self.gyr_lp.value().unwrap_or_else(Vector3::zeros)
    }

    /// The low-passed specific force, m/s².
    pub fn acc_lowpass(&self) -> Vector3<f64> {
        self.acc_lp.value().unwrap_or_else(Vector3::zeros)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> RestConfig {
        RestConfig::default()
    }

    /// Still with a constant bias and small noise: rest after `min_duration_s`, with the low-pass near
    /// the bias; a turn at 10°/s breaks it at once; a bias beyond the limit is never rest.
    #[test]
    fn detects_rest_and_its_end() {
        let c = config();
        let mut d = RestDetector::new(&c);
        let dt = 0.01;
        let bias = Vector3::new(0.004, -0.002, 0.001);
        let g = Vector3::new(0.0, 0.0, 9.81);
        let mut first = None;
        for k in 0..300 {
            let n = if k % 2 == 0 { 1e-3 } else { -1e-3 };
            let rest = d.update(
                &c,
                &(bias + Vector3::repeat(n)),
                &(g + Vector3::repeat(n)),
                dt,
            );
            if rest && first.is_none() {
                first = Some(k as f64 * dt);
            }
        }
        let t = first.expect("rest detected");
        assert!((t - c.min_duration_s).abs() < 0.02, "{t}");
        assert!((d.gyr_lowpass() - bias).norm() < 1e-3);
        let turning = Vector3::new(0.0, 0.0, 10f64.to_radians());
        assert!(!d.update(&c, &(bias + turning), &g, dt));
        let mut d = RestDetector::new(&c);
        let big = Vector3::new(3f64.to_radians(), 0.0, 0.0);
        assert!((0..400).all(|_| !d.update(&c, &big, &g, dt)));
    }

    /// Shaking the accelerometer (0.8 m/s² steps) is not rest, even with a still gyro.
    #[test]
    fn shaking_is_not_rest() {
        let c = config();
        let mut d = RestDetector::new(&c);
        let g = Vector3::new(0.0, 0.0, 9.81);
        for k in 0..400 {
            let a = g + Vector3::new(if (k / 10) % 2 == 0 { 0.8 } else { -0.8 }, 0.0, 0.0);
            assert!(!d.update(&c, &Vector3::zeros(), &a, 0.01), "sample {k}");
        }
    }
}
