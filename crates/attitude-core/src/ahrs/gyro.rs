//! What a gyro sample's rate may hide: the attitude variance the pipeline adds to the filter's
//! propagation over each sample's interval, beside the filter's gyro noise model.
//!
//! * **The rate within the interval.** Sample `k`'s rate is taken over `(t_{k−1}, t_k]`, but a sensor
//!   may report the mean over its interval, the rate at its end, or anything its filters make of it;
//!   a driver may repeat a reading it has not refreshed (a held sample). Between two samples the rate
//!   is not known better than its change: the rotation over the interval may be off by about
//!   `change_factor · (ω_k − ω_{k−1}) Δt` (½ for a rate sampled at the end of the interval against
//!   one averaged over it). The variance `(change_factor ‖ω_k − ω_{k−1}‖ Δt)²` is added per axis. It
//!   is tiny at a high rate in smooth motion (the change and the interval both shrink) and grows at
//!   low rates, in vibration, and after held samples, by what the samples themselves show.
//! * **Saturation.** A sample with an axis at 98% of the gyro's range or beyond (the range from the
//!   datasheet, `range_rad_s`; or inferred when a reading repeats bit for bit at the largest rate
//!   seen, as a clipped sensor's output does) only says the rate was at least the range. The rotation
//!   it hides grows with every saturated sample in a row: the `n`-th adds variance so that the run's
//!   1σ is `n · saturation_factor · range · Δt` (the excess is the same sign all along a run, so it
//!   grows linearly, not as a random walk), and the accelerometer and magnetometer then pull the
//!   estimate back at once.

use nalgebra::Vector3;

/// The gyro's settings (`service.imu.gyro`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct GyroConfig {
    /// How much of the rate's change between two samples the rotation over the interval may be off
    /// by.
    pub change_factor: f64,
    /// The sensor's range, rad/s per axis (the datasheet's full scale); 0: not given (inferred from a
    /// clipped output, when one shows).
    pub range_rad_s: f64,
    /// How far beyond the range a saturated sample's rate may be, as a fraction of the range.
    pub saturation_factor: f64,
}

impl Default for GyroConfig {
    fn default() -> Self {
        GyroConfig {
            change_factor: 0.5,
            range_rad_s: 0.0,
            saturation_factor: 0.25,
        }
    }
}

impl GyroConfig {
    pub fn validate(&self) -> Result<(), String> {
        for (v, name) in [
            (self.change_factor, "gyro.change_factor"),
            (self.range_rad_s, "gyro.range_rad_s"),
            (self.saturation_factor, "gyro.saturation_factor"),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!("{name} must be finite and non-negative, got {v}"));
            }
        }
        Ok(())
    }
}

/// A sample is saturated from this fraction of the range on.
pub const SATURATION_FRACTION: f64 = 0.98;
/// No gyro's range is below this (the smallest full scale of MEMS gyros is 125 °/s, 2.18 rad/s): a
/// repeated reading below it is quantisation, not a clipped output.
pub const MIN_INFERRED_RANGE_RAD_S: f64 = 2.0;

/// The gyro channel's state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GyroChannel {
    /// The previous sample's rate.
    pub previous: Option<Vector3<f64>>,
    /// The largest rate seen on any axis (magnitude), and whether a reading has repeated it bit for
    /// bit (a clipped output: the range is then that value).
    pub largest: f64,
    pub clipped: bool,
    /// Saturated samples in a row now, and in all.
    pub run: u32,
    pub saturated: u64,
}

impl GyroChannel {
    /// The range in use: the datasheet's, else the inferred one, else none (0).
    pub fn range(&self, c: &GyroConfig) -> f64 {
        if c.range_rad_s > 0.0 {
            c.range_rad_s
        } else if self.clipped {
            self.largest
        } else {
            0.0
        }
    }

    /// Takes sample `gyr` over an interval of `dt_s`; returns the attitude variance per axis (rad²)
    /// it adds beside the filter's gyro model.
    pub fn step(&mut self, c: &GyroConfig, gyr: &Vector3<f64>, dt_s: f64) -> f64 {
        let peak = gyr.amax();
        if let Some(prev) = self.previous {
            // A clipped output repeats the same extreme value: a reading equal to the previous on an
            // axis at the largest rate seen (and at a rate some gyro's range could be), while another
            // axis changed (a driver that repeats a whole reading holds it; it does not clip).
            if !self.clipped
                && peak >= self.largest
                && peak >= MIN_INFERRED_RANGE_RAD_S
                && *gyr != prev
                && (0..3).any(|i| gyr[i].abs() == peak && gyr[i] == prev[i])
            {
                self.clipped = true;
            }
        }
        if peak > self.largest {
            self.largest = peak;
            if self.clipped && c.range_rad_s <= 0.0 {
                // A larger value than the supposed ceiling: it was not one.
                self.clipped = false;
            }
        }
        let change = self.previous.map_or(0.0, |p| (gyr - p).norm());
        self.previous = Some(*gyr);
        let dt = dt_s.max(0.0);
        let mut var = (c.change_factor * change * dt).powi(2);
        let range = self.range(c);
        if range > 0.0 && peak >= SATURATION_FRACTION * range {
            self.run = self.run.saturating_add(1);
            self.saturated += 1;
            let n = f64::from(self.run);
            let step = c.saturation_factor * range * dt;
            // The run's 1σ is n · step: this sample adds (n² − (n−1)²) step².
            var += (2.0 * n - 1.0) * step * step;
        } else {
            self.run = 0;
        }
        var
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A constant rate adds nothing; a change adds (½ ‖Δω‖ Δt)²; a saturated run grows its 1σ
    /// linearly: after n samples the added variances sum to (n · ¼ · range · Δt)².
    #[test]
    fn change_and_saturation_variances() {
        let c = GyroConfig {
            range_rad_s: 4.0,
            ..GyroConfig::default()
        };
        let mut g = GyroChannel::default();
        let dt = 0.01;
        let w = Vector3::new(0.3, -0.2, 0.1);
        assert_eq!(g.step(&c, &w, dt), 0.0);
        assert_eq!(g.step(&c, &w, dt), 0.0);
        let w2 = w + Vector3::new(0.0, 0.4, 0.0);
        let v = g.step(&c, &w2, dt);
        assert!((v - (0.5 * 0.4 * dt).powi(2)).abs() < 1e-18, "{v}");
        let sat = Vector3::new(4.0, 0.0, 0.0);
        g.step(&c, &sat, dt);
        let mut total = 0.0;
        for _ in 0..5 {
            total += g.step(&c, &sat, dt);
        }
        // Runs of 2..6: Σ (2n − 1) step² = (36 − 1) step².
        let step = 0.25 * 4.0 * dt;
        assert!((total - 35.0 * step * step).abs() < 1e-15, "{total}");
        assert_eq!(g.saturated, 6);
        assert_eq!(g.step(&c, &w, dt) > 0.0, true);
        assert_eq!(g.run, 0);
    }

    /// Without a range: a reading that repeats the largest rate seen bit for bit is a clipped output
    /// (the range is inferred); a larger rate afterwards shows it was not; a smooth peak is never
    /// taken for one.
    #[test]
    fn a_clipped_output_is_recognised() {
        let c = GyroConfig::default();
        let mut g = GyroChannel::default();
        for k in 0..200 {
            let w = Vector3::new(5.0 * (k as f64 * 0.05).sin(), 0.1, 0.0);
            g.step(&c, &w, 0.01);
        }
        assert!(!g.clipped);
        assert_eq!(g.range(&c), 0.0);
        // A held sample (the whole reading repeated) is not a clip.
        let held = Vector3::new(5.5, 0.2, 0.0);
        g.step(&c, &held, 0.01);
        g.step(&c, &held, 0.01);
        assert!(!g.clipped);
        g.step(&c, &Vector3::new(6.0, 0.1, 0.0), 0.01);
        let clip = Vector3::new(6.0, 0.12, 0.0);
        g.step(&c, &clip, 0.01);
        assert!(g.clipped);
        assert_eq!(g.range(&c), 6.0);
        assert!(g.step(&c, &clip, 0.01) > 0.0);
        g.step(&c, &Vector3::new(7.0, 0.0, 0.0), 0.01);
        assert!(!g.clipped);
    }
}
