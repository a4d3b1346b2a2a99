//! Rest detection from the gyro and the accelerometer (the test of Laidig & Seel's VQF): both are
//! low-passed (`τ_r`); the vehicle is at rest once, for `min_duration_s` without a break, every gyro
//! sample stays within `gyr_limit` of its low-pass, the low-passed rate stays below `bias_limit` on
//! every axis (a rate that large is motion, not bias), and every accelerometer sample stays within
//! `acc_limit` of its low-pass. At rest the low-passed gyro is a direct measurement of the gyro bias.
//!
//! Unlike VQF's, a sample's deviation from the low-pass is itself low-passed over [`DEVIATION_S`]
//! before it is compared, so that the test sees the same band of the sensor's noise at any rate.

use super::RestConfig;
use crate::sensors::lowpass::Lowpass3;
use nalgebra::Vector3;

/// The time constant of the deviations' own low-pass, s: their noise is that of a band of
/// `1 / (4 τ)` = 125 Hz at most, whatever the rate. Compared sample by sample, a faster sensor's
/// deviations carry more of its noise (white noise of one density has a variance per sample that
/// grows with the rate): BROAD's accelerometer resampled to 1 kHz with its own noise density broke the
/// 0.5 m/s² limit about once a second at rest, and its 40 s of opening rest were found a third of the
/// time.
/// Below 250 Hz the low-pass changes a sample's deviation by less than 14%.
pub const DEVIATION_S: f64 = 0.002;

/// The gain of that low-pass over an interval `dt_s` (1 when there is no interval to weigh by).
pub fn deviation_gain(dt_s: f64) -> f64 {
    if dt_s > 0.0 && dt_s.is_finite() {
        1.0 - (-dt_s / DEVIATION_S).exp()
    } else {
        1.0
    }
}

/// The share of a white noise's variance that low-pass keeps: `k / (2 − k)` of a first-order
/// low-pass with gain `k`.
pub fn deviation_noise_share(dt_s: f64) -> f64 {
    let k = deviation_gain(dt_s);
    k / (2.0 - k)
}

#[derive(Clone, Debug, PartialEq)]
pub struct RestDetector {
    pub gyr_lp: Lowpass3,
    pub acc_lp: Lowpass3,
    /// The samples' deviations from those low-passes, each low-passed over [`DEVIATION_S`].
    pub gyr_dev: Vector3<f64>,
    pub acc_dev: Vector3<f64>,
    /// Time without a break of the conditions, s.
    pub still_s: f64,
    pub at_rest: bool,
}

impl RestDetector {
    pub fn new(c: &RestConfig) -> Self {
        RestDetector {
            gyr_lp: Lowpass3::new(c.lowpass_s),
            acc_lp: Lowpass3::new(c.lowpass_s),
            gyr_dev: Vector3::zeros(),
            acc_dev: Vector3::zeros(),
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
        let k = deviation_gain(dt_s);
        self.gyr_dev += (gyr - g - self.gyr_dev) * k;
        self.acc_dev += (acc - a - self.acc_dev) * k;
        if !(self.gyr_dev.iter().all(|x| x.is_finite())
            && self.acc_dev.iter().all(|x| x.is_finite()))
        {
            self.gyr_dev = Vector3::zeros();
            self.acc_dev = Vector3::zeros();
        }
        let still = self.gyr_dev.norm() < c.gyr_limit_rad_s
            && g.amax() <= c.bias_limit_rad_s
            && self.acc_dev.norm() < c.acc_limit_m_s2;
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

    /// The same sensor at 200 Hz and at 2 kHz (white noise of one density: 400 µg/√Hz, a consumer
    /// accelerometer's, and 0.01 °/s/√Hz), still: rest from `min_duration_s` on at both rates, never
    /// broken by the noise. Compared sample by sample (VQF's test), the 2 kHz accelerometer's
    /// deviations (0.12 m/s² per axis) break the 0.5 m/s² limit within seconds (this test then fails).
    #[test]
    fn a_faster_sensor_of_the_same_noise_is_still_at_rest() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let c = config();
        for rate in [200.0, 2000.0] {
            let mut rng = crate::rng::Xoshiro256PlusPlus::seed_from_u64(7);
            let dt = 1.0 / rate;
            let acc = Normal::new(0.0, 400e-6 * 9.81 * (rate / 2.0f64).sqrt()).unwrap();
            let gyr = Normal::new(0.0, 0.01f64.to_radians() * (rate / 2.0f64).sqrt()).unwrap();
            let mut d = RestDetector::new(&c);
            let (mut rest, mut after) = (0usize, 0usize);
            let n = (20.0 * rate) as usize;
            for k in 0..n {
                let g = Vector3::from_fn(|_, _| gyr.sample(&mut rng));
                let a =
                    Vector3::new(0.0, 0.0, 9.81) + Vector3::from_fn(|_, _| acc.sample(&mut rng));
                let t = k as f64 * dt;
                if d.update(&c, &g, &a, dt) {
                    rest += 1;
                }
                if t > c.min_duration_s + 1.0 {
                    after += 1;
                    assert!(d.at_rest(), "{rate} Hz: rest broken at {t:.3} s");
                }
            }
            assert!(rest >= after, "{rate} Hz: {rest} of {n}");
        }
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
