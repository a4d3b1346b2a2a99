//! What a driver or a converter repeats or makes up between a sensor's real readings, recognised in
//! the stream so that it is not taken for what the sensor saw (plain data: a checkpoint holds both).
//!
//! * [`Interpolation`]: a hole filled in on the line between two real samples (a converter that
//!   resamples onto a uniform grid); the run hides what a gap of its length would.
//! * [`MagHold`]: a magnetometer slower than the gyro whose driver repeats its last reading; the
//!   repeat is the field where the body pointed when the reading was new.

use crate::sensors::gyro::channel::MIN_HELD_RATE_RAD_S;
use crate::sensors::ImuSample;
use nalgebra::{Matrix3, Vector3};

/// Two changes are the same to this much of the reading (rounding of an interpolation in `f64`, far
/// below any sensor's resolution).
const LINE_TOLERANCE: f64 = 1e-9;

/// A converter or driver that fills missing readings by linear interpolation (onto a uniform grid,
/// say) makes samples on the line between two real ones: every channel's change from the previous
/// sample equals the change before it, to rounding. A real sensor's noise never does that on six
/// axes or more, and a noise-free simulation rarely moves gyro and accelerometer both in straight
/// lines. Such a run hides what the rate did between its ends, as a gap does.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Interpolation {
    /// The previous sample's readings (gyro, accelerometer, magnetometer or zero).
    pub last_gyr: Option<Vector3<f64>>,
    pub last_acc: Option<Vector3<f64>>,
    pub last_mag: Option<Vector3<f64>>,
    /// Their changes from the sample before.
    pub change_gyr: Option<Vector3<f64>>,
    pub change_acc: Option<Vector3<f64>>,
    pub change_mag: Option<Vector3<f64>>,
    /// Samples in a row on the line, and their time, s.
    pub run: u32,
    pub blind_s: f64,
}

impl Interpolation {
    /// Takes sample `s` over its own interval `dt_s` (after a gap, if `gap`: the gap model has it).
    /// When it lies on the line through the two before it, returns the run's unseen time before
    /// and with it, s; `run` counts the samples in a row on the line.
    pub fn step(&mut self, s: &ImuSample, dt_s: f64, gap: bool) -> Option<(f64, f64)> {
        // (A missing magnetometer reading counts as unchanged: the gyro and the accelerometer decide.)
        let now = [
            s.gyr_rad_s,
            s.acc_m_s2,
            s.mag.unwrap_or_else(Vector3::zeros),
        ];
        let last = [self.last_gyr, self.last_acc, self.last_mag];
        let before = [self.change_gyr, self.change_acc, self.change_mag];
        let change: [Option<Vector3<f64>>; 3] =
            std::array::from_fn(|i| last[i].map(|l| now[i] - l));
        let on_line = match (change, before) {
            ([Some(dg), Some(da), Some(dm)], [Some(bg), Some(ba), Some(bm)]) => {
                // Both moved (a held reading, a constant rate or a still accelerometer is not a
                // line), at a rate a held reading would be judged at, and by the same as before.
                let d = [dg, da, dm];
                let b = [bg, ba, bm];
                dg != Vector3::zeros()
                    && da != Vector3::zeros()
                    && s.gyr_rad_s.norm() > MIN_HELD_RATE_RAD_S
                    && (0..3)
                        .all(|i| (d[i] - b[i]).amax() <= LINE_TOLERANCE * now[i].amax().max(1.0))
            }
            _ => false,
        };
        [self.last_gyr, self.last_acc, self.last_mag] = now.map(Some);
        [self.change_gyr, self.change_acc, self.change_mag] = change;
        if !on_line {
            self.run = 0;
            self.blind_s = 0.0;
            return None;
        }
        self.run = self.run.saturating_add(1);
        if gap {
            // (The gap model covers this interval; the run's time starts again after it.)
            self.blind_s = 0.0;
            return None;
        }
        let was = self.blind_s;
        self.blind_s += dt_s.max(0.0);
        Some((was, self.blind_s))
    }
}

/// A magnetometer slower than the gyro, whose driver repeats its last reading with every sample
/// until a new one comes (bit for bit: a real reading's noise always changes some bit while the
/// body turns): the repeated reading was taken when the body pointed elsewhere. It is turned by the
/// rotation of the gyro frame since the reading was new (the body-fixed offset left where it is),
/// so the field channel and the heading see where the field is now, not where it was.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MagHold {
    /// The last raw reading.
    pub last_raw: Option<Vector3<f64>>,
    /// The last new reading as used (delay compensated), and the gyro frame's attitude matrix then.
    pub fresh: Option<Vector3<f64>>,
    pub fresh_frame: Option<Matrix3<f64>>,
}

impl MagHold {
    /// The reading to use for `raw` (`None`: none this sample), with the gyro frame's attitude
    /// matrix now and the body-fixed offset; `fresh` prepares a new reading.
    pub fn reading(
        &mut self,
        raw: Option<Vector3<f64>>,
        a_gyro: &Matrix3<f64>,
        offset: &Vector3<f64>,
        fresh: impl FnOnce(&Vector3<f64>) -> Vector3<f64>,
    ) -> Option<Vector3<f64>> {
        let raw = raw?;
        let held = self.last_raw == Some(raw);
        self.last_raw = Some(raw);
        match (held, self.fresh, self.fresh_frame) {
            (true, Some(m0), Some(a0)) => Some(a_gyro * (a0.transpose() * (m0 - offset)) + offset),
            _ => {
                let m = fresh(&raw);
                self.fresh = Some(m);
                self.fresh_frame = Some(*a_gyro);
                Some(m)
            }
        }
    }

    /// The last new reading and the gyro frame's attitude matrix when it was taken (what the
    /// hard-iron fit takes: a reading turned to now would carry the offset, which does not turn).
    pub fn as_taken(&self) -> Option<(Vector3<f64>, Matrix3<f64>)> {
        self.fresh.zip(self.fresh_frame)
    }
}
