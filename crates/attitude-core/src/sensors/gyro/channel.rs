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
//!   grows linearly, not as a random walk), about the saturated axes alone (the others are measured;
//!   [`GyroChannel::saturation_variance`]), and the accelerometer and magnetometer then pull the
//!   estimate back at once.
//! * **Gaps.** An interval longer than [`GAP_INTERVALS`] usual ones (a lost batch, a stalled link,
//!   a sensor that skipped) is a gap ([`GyroChannel::gap`]). The body's rate is modelled as it has
//!   been behaving: of the recent mean square `σ_ω²` and a time scale `τ_ω` measured from how much it
//!   changes between samples (`τ_ω = σ_ω / σ_ω̇`: a rate that swings with period `P` has `P/2π`), and
//!   reverting to rest (a body that moves about a place does not keep turning one way). Over a gap of
//!   `T` the rates on both sides decay: the bridge turns by `(ω₀ + ω₁) τ_ω (1 − e^{−T/2τ_ω})` — the
//!   mean of the two rates over a short gap, not the later rate held over a long one (a body that
//!   shakes back and forth turns little in a second, however fast it shakes) — and the attitude
//!   variance grows by what such a rate could have done meanwhile: coherently while it keeps its sign
//!   (a quarter period, `τ_c = π/2 · τ_ω`), as a random walk beyond,
//!   `gap_turn_factor² · σ_ω² T · min(T, 2τ_c)` per axis (the decaying model's own variance is far
//!   smaller over half a swing, and a gap in a shake was then 3σ off).

use crate::sensors::check::non_negative;
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
    /// How much of the rotation the body could make during a gap, at the rates seen around it, the
    /// bridge may be off by.
    pub gap_turn_factor: f64,
    /// Each interval's rotation carries the coning term of the interval before,
    /// `Δθ_{k−1} × Δθ_k / 12` (see [`GyroChannel::coning_rad_s`]). Off only for a sensor that
    /// integrates its rate itself and reports the increments (strapdown-integrated output), which
    /// already holds it.
    pub coning: bool,
}

impl Default for GyroConfig {
    fn default() -> Self {
        GyroConfig {
            change_factor: 0.5,
            range_rad_s: 0.0,
            saturation_factor: 1.0,
            gap_turn_factor: 1.0,
            coning: true,
        }
    }
}

impl GyroConfig {
    pub fn validate(&self) -> Result<(), String> {
        non_negative(self.change_factor, "gyro.change_factor")?;
        non_negative(self.range_rad_s, "gyro.range_rad_s")?;
        non_negative(self.saturation_factor, "gyro.saturation_factor")?;
        non_negative(self.gap_turn_factor, "gyro.gap_turn_factor")
    }
}

/// An interval longer than this many usual ones is a gap.
pub const GAP_INTERVALS: f64 = 3.0;
/// Time constant of the usual interval's and the recent rate statistics' running means, s.
const RECENT_S: f64 = 1.0;
/// The longest correlation time a rate is given, s.
const MAX_RATE_CORRELATION_S: f64 = 2.0;

/// A gap before a sample: how it is bridged and what it could hide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gap {
    /// The time without samples, s (the interval less the sample's own usual one).
    pub blind_s: f64,
    /// The rate that bridges it (the mean of the rates on both sides), rad/s.
    pub bridge_rad_s: Vector3<f64>,
    /// The attitude variance per axis the bridge may be off by, rad².
    pub variance_rad2: f64,
}

/// A sample is saturated from this fraction of the range on.
pub const SATURATION_FRACTION: f64 = 0.98;
/// No gyro's range is below this (the smallest full scale of MEMS gyros is 125 °/s, 2.18 rad/s): a
/// repeated reading below it is quantisation, not a clipped output.
pub const MIN_INFERRED_RANGE_RAD_S: f64 = 2.0;

/// A reading repeated bit for bit below this rate is a quantised gyro at rest (BROAD's repeats for
/// seconds), not a held one: it hides next to nothing.
pub const MIN_HELD_RATE_RAD_S: f64 = 0.05;

/// Repeats of the extreme value in a row that show a clipped output.
pub const CLIP_REPEATS: u32 = 3;

/// The gyro channel's state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GyroChannel {
    /// The previous sample's rate.
    pub previous: Option<Vector3<f64>>,
    /// The largest rate seen on any axis (magnitude), and whether a reading has repeated it bit for
    /// bit (a clipped output: the range is then that value).
    pub largest: f64,
    pub clipped: bool,
    /// Readings in a row that repeated the largest rate on an axis (a clipped output from
    /// [`CLIP_REPEATS`] on).
    pub clip_repeats: u32,
    /// Saturated samples in a row now, and in all.
    pub run: u32,
    pub saturated: u64,
    /// The usual interval between samples (a running mean that leaves gaps out; 0 before the first),
    /// the recent mean square of the rate and of the rate's change between samples, per axis,
    /// (rad/s)².
    pub interval_s: f64,
    pub rate_ms: f64,
    pub change_ms: f64,
    /// Gaps, and the time without samples in them, s.
    pub gaps: u64,
    pub blind_s: f64,
    /// Readings in a row now that repeat the previous one bit for bit on every axis (a driver that
    /// holds its last reading when no new one is ready).
    pub held: u32,
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

    /// Whether the interval `dt_s` before sample `gyr` is a gap, and if so how to bridge it; counts
    /// it. Also keeps the usual interval (called once per sample, before [`GyroChannel::step`]).
    pub fn gap(&mut self, c: &GyroConfig, gyr: &Vector3<f64>, dt_s: f64) -> Option<Gap> {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return None;
        }
        if self.interval_s <= 0.0 {
            self.interval_s = dt_s;
            return None;
        }
        if dt_s <= GAP_INTERVALS * self.interval_s {
            let k = (dt_s / RECENT_S).min(1.0);
            self.interval_s += k * (dt_s - self.interval_s);
            return None;
        }
        let prev = self.previous?;
        let blind = dt_s - self.interval_s;
        let tau = self.rate_time_scale();
        let decay = tau * (1.0 - (-blind / (2.0 * tau)).exp());
        let bridge = (prev + gyr) * (decay / blind);
        let variance = self.unseen_turn_variance(c, blind);
        self.gaps += 1;
        self.blind_s += blind;
        Some(Gap {
            blind_s: blind,
            bridge_rad_s: bridge,
            variance_rad2: variance,
        })
    }

    /// The rate's own time scale, σ_ω / σ_ω̇ (a rate that swings with period P has P/2π): how long
    /// it keeps its value before it turns.
    fn rate_time_scale(&self) -> f64 {
        if self.change_ms > 0.0 {
            ((self.rate_ms / self.change_ms).sqrt() * self.interval_s)
                .clamp(self.interval_s, MAX_RATE_CORRELATION_S)
        } else {
            MAX_RATE_CORRELATION_S
        }
    }

    /// The attitude variance per axis (rad²) of `blind_s` seconds whose rates nobody saw (a gap, or
    /// a run of readings made up between two real ones), at the rates seen before: what such a rate
    /// could turn, coherently (σ_ω T) over as long as it keeps its sign, a quarter period (π/2 · τ,
    /// 2τ_c below), and as a random walk beyond. (A model that decays towards rest has a far
    /// smaller variance over half a swing, 2σ²τ(T − 2τ(1 − e^{−T/2τ})): a 0.14 s gap in a 4 Hz shake
    /// at 300°/s left 36° of error under an 11° σ.)
    pub fn unseen_turn_variance(&self, c: &GyroConfig, blind_s: f64) -> f64 {
        let blind = blind_s.max(0.0);
        let coherent =
            (std::f64::consts::FRAC_PI_2 * self.rate_time_scale()).min(MAX_RATE_CORRELATION_S);
        c.gap_turn_factor.powi(2) * self.rate_ms * blind * blind.min(2.0 * coherent)
    }

    /// The rate to add to sample `gyr` (bias `bias` removed from both) so that one step over its
    /// interval turns by the second-order rotation vector `Δθ_k + Δθ_{k−1} × Δθ_k / 12` (Bortz's
    /// equation to second order, the classic two-sample coning term): a rate that is its interval's
    /// mean gives the right rotation only while the axis stands still. When it turns, the rotation
    /// steps that do not commute add up, coherently in a coning motion. BROAD 07 resampled to 25 Hz
    /// drifts 4.0° in 5 s without the term and 1.3° with it (0.17° against 1.06° at 50 Hz; at 285.7
    /// Hz it is below 0.01°). The previous interval is taken as the usual one; none after a gap.
    pub fn coning_rad_s(
        &self,
        c: &GyroConfig,
        gyr: &Vector3<f64>,
        bias: &Vector3<f64>,
        after_gap: bool,
    ) -> Vector3<f64> {
        match self.previous {
            Some(prev) if c.coning && !after_gap => {
                (prev - bias).cross(&(gyr - bias)) * (self.interval_s / 12.0)
            }
            _ => Vector3::zeros(),
        }
    }

    /// The part of what [`GyroChannel::step`] just returned for sample `gyr` over `dt_s` that its
    /// saturation hides, per body axis (rad²): only the saturated axes' rates are unknown beyond
    /// the range, so the rotation they hide is about those axes alone. `None` when the sample was
    /// not saturated. (The filter takes it as an attitude inflation about those axes; spread over
    /// every axis it also spread the heading, and a particle filter's cloud then lost it.)
    pub fn saturation_variance(
        &self,
        c: &GyroConfig,
        gyr: &Vector3<f64>,
        dt_s: f64,
    ) -> Option<Vector3<f64>> {
        if self.run == 0 {
            return None;
        }
        let range = self.range(c);
        let n = f64::from(self.run);
        let step = c.saturation_factor * range * dt_s.max(0.0);
        let var = (2.0 * n - 1.0) * step * step;
        Some(gyr.map(|w| {
            if w.abs() >= SATURATION_FRACTION * range {
                var
            } else {
                0.0
            }
        }))
    }

    /// Takes sample `gyr` over an interval of `dt_s`; returns the attitude variance per axis (rad²)
    /// it adds beside the filter's gyro model.
    pub fn step(&mut self, c: &GyroConfig, gyr: &Vector3<f64>, dt_s: f64) -> f64 {
        let peak = gyr.amax();
        if let Some(prev) = self.previous {
            // A clipped output repeats the same extreme value: a reading equal to the previous on an
            // axis at the largest rate seen (and at a rate some gyro's range could be), while another
            // axis changed (a driver that repeats a whole reading holds it; it does not clip).
            // Only a run of such readings says so: a quantised gyro repeats its peak once by chance
            // (BROAD's slow rotation did, and its heading paid for the range it made up).
            if !self.clipped
                && peak >= self.largest
                && peak >= MIN_INFERRED_RANGE_RAD_S
                && *gyr != prev
                && (0..3).any(|i| gyr[i].abs() == peak && gyr[i] == prev[i])
            {
                self.clip_repeats = self.clip_repeats.saturating_add(1);
                if self.clip_repeats >= CLIP_REPEATS {
                    self.clipped = true;
                }
            } else {
                self.clip_repeats = 0;
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
        // A reading equal to the previous one on every axis, bit for bit, is a held reading, not a
        // rate that stood still (a real gyro's noise changes some bit): the rate went on changing
        // unseen, by about the recent change per sample, for as many samples as it is held.
        // (A saturated reading repeats too: its own term below covers it.)
        let range = self.range(c);
        let saturated = range > 0.0 && peak >= SATURATION_FRACTION * range;
        let held = self.previous == Some(*gyr) && gyr.norm() > MIN_HELD_RATE_RAD_S && !saturated;
        self.previous = Some(*gyr);
        let dt = dt_s.max(0.0);
        let k = (dt / RECENT_S).min(1.0);
        self.rate_ms += k * (gyr.norm_squared() / 3.0 - self.rate_ms);
        let mut var = if held {
            self.held = self.held.saturating_add(1);
            let n = f64::from(self.held);
            let step = (3.0 * self.change_ms).sqrt() * dt;
            (2.0 * n - 1.0) * step * step
        } else {
            self.held = 0;
            self.change_ms += k * (change * change / 3.0 - self.change_ms);
            (c.change_factor * change * dt).powi(2)
        };
        if saturated {
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

    /// A coning motion (the body's rate turns about its z axis, `ω = a (cos Ωt, sin Ωt, 0)`) read as
    /// each interval's mean rate at 25 Hz: one rotation step per interval drifts, the coning term
    /// takes most of it away; on the same motion with the term off, nothing is added.
    #[test]
    fn the_coning_term_takes_the_drift_of_a_coning_motion() {
        use nalgebra::Rotation3;
        let (a, big_omega, dt, fine) = (3.0, 8.0, 0.04, 400);
        let rate = |t: f64| Vector3::new((big_omega * t).cos(), (big_omega * t).sin(), 0.0) * a;
        let run = |coning: bool| {
            let c = GyroConfig {
                coning,
                ..GyroConfig::default()
            };
            let mut g = GyroChannel::default();
            let (mut exact, mut stepped) = (Rotation3::identity(), Rotation3::identity());
            for k in 1..=50 {
                let t0 = dt * f64::from(k - 1);
                let mut mean = Vector3::zeros();
                for i in 0..fine {
                    let t = t0 + dt * (f64::from(i) + 0.5) / f64::from(fine);
                    exact *= Rotation3::from_scaled_axis(rate(t) * dt / f64::from(fine));
                    mean += rate(t) / f64::from(fine);
                }
                g.gap(&c, &mean, dt);
                let extra = g.coning_rad_s(&c, &mean, &Vector3::zeros(), false);
                if !coning {
                    assert_eq!(extra, Vector3::zeros());
                }
                stepped *= Rotation3::from_scaled_axis((mean + extra) * dt);
                g.step(&c, &mean, dt);
            }
            (stepped.inverse() * exact).angle().to_degrees()
        };
        let (plain, corrected) = (run(false), run(true));
        // (Measured: 1.03° and 0.04°.)
        assert!(plain > 0.8, "2 s of coning at 25 Hz drift {plain}°");
        assert!(
            corrected < 0.1 * plain,
            "{corrected}° with the term, {plain}° without"
        );
    }

    /// A constant rate adds nothing; a change adds (½ ‖Δω‖ Δt)²; a saturated run grows its 1σ
    /// linearly: after n samples the added variances sum to (n · range · Δt)².
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
        let step = 1.0 * 4.0 * dt;
        assert!((total - 35.0 * step * step).abs() < 1e-15, "{total}");
        assert_eq!(g.saturated, 6);
        assert_eq!(g.step(&c, &w, dt) > 0.0, true);
        assert_eq!(g.run, 0);
    }

    /// What saturation hides is about the saturated axes alone, and it is the saturation's share of
    /// what `step` returned: a run on x, then on x and z (the n-th sample of a run `(2n − 1) step²`).
    #[test]
    fn saturation_hides_a_rotation_about_the_saturated_axes() {
        let c = GyroConfig {
            range_rad_s: 4.0,
            ..GyroConfig::default()
        };
        let mut g = GyroChannel::default();
        let dt = 0.01;
        let w = Vector3::new(0.3, -0.2, 0.1);
        g.step(&c, &w, dt);
        assert_eq!(g.saturation_variance(&c, &w, dt), None);
        let step2 = (1.0 * 4.0 * dt) * (1.0 * 4.0 * dt);
        let mut prev = w;
        for (n, sat) in [
            (1.0, Vector3::new(4.0, 0.5, 0.1)),
            (2.0, Vector3::new(4.0, 0.5, 0.1)),
            (3.0, Vector3::new(-4.0, 0.5, 3.95)),
        ] {
            let total = g.step(&c, &sat, dt);
            let v = g.saturation_variance(&c, &sat, dt).unwrap();
            let var = (2.0 * n - 1.0) * step2;
            assert!((v.x - var).abs() < 1e-15 && v.y == 0.0, "{v}");
            assert_eq!(v.z > 0.0, sat.z.abs() >= SATURATION_FRACTION * 4.0);
            // The rest of `step`'s variance is the rate's change.
            let change = (c.change_factor * (sat - prev).norm() * dt).powi(2);
            assert!((total - v.max() - change).abs() < 1e-15, "{total} {v}");
            prev = sat;
        }
        g.step(&c, &w, dt);
        assert_eq!(g.saturation_variance(&c, &w, dt), None);
    }

    /// A reading repeated bit for bit (a driver that holds its last one) hides the rate's change: it
    /// adds the recent change per sample, growing over a run of them like a saturated run; a rate that
    /// changes adds only its own change.
    #[test]
    fn held_readings_are_not_trusted() {
        let c = GyroConfig::default();
        let mut g = GyroChannel::default();
        let dt = 0.01;
        for k in 0..200 {
            let w = Vector3::new((0.05 * k as f64).sin(), 0.2, -0.1);
            g.step(&c, &w, dt);
        }
        let step2 = 3.0 * g.change_ms * dt * dt;
        let w = g.previous.unwrap();
        let first = g.step(&c, &w, dt);
        let second = g.step(&c, &w, dt);
        assert!(
            (first - step2).abs() < 1e-12 * step2.max(1e-30),
            "{first} {step2}"
        );
        assert!(
            (second - 3.0 * step2).abs() < 1e-9 * step2,
            "{second} {step2}"
        );
        assert_eq!(g.held, 2);
        let moved = g.step(&c, &(w + Vector3::new(0.01, 0.0, 0.0)), dt);
        assert!((moved - (0.5 * 0.01 * dt).powi(2)).abs() < 1e-18, "{moved}");
        assert_eq!(g.held, 0);
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
        // One repeat of the peak is chance (a quantised output); three in a row are a clip.
        g.step(&c, &Vector3::new(6.0, 0.1, 0.0), 0.01);
        g.step(&c, &Vector3::new(6.0, 0.12, 0.0), 0.01);
        assert!(!g.clipped);
        g.step(&c, &Vector3::new(5.9, 0.13, 0.0), 0.01);
        g.step(&c, &Vector3::new(6.0, 0.1, 0.0), 0.01);
        for k in 0..CLIP_REPEATS {
            assert!(!g.clipped, "{k}");
            g.step(
                &c,
                &Vector3::new(6.0, 0.14 + 0.01 * f64::from(k), 0.0),
                0.01,
            );
        }
        assert!(g.clipped);
        assert_eq!(g.range(&c), 6.0);
        let clip = Vector3::new(6.0, 0.3, 0.0);
        assert!(g.step(&c, &clip, 0.01) > 0.0);
        g.step(&c, &Vector3::new(7.0, 0.0, 0.0), 0.01);
        assert!(!g.clipped);
    }
}
