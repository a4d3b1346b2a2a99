//! Attitude from raw IMU samples (gyro, accelerometer, optional magnetometer): the sensor models of a
//! real vehicle between the samples a user sends and the filter behind [`AttitudeFilter`].
//!
//! A user sends `{t, gyr, acc, mag?}` per sample; nothing else. This module turns that stream into
//! what the filters use, the same way for every filter (MEKF, QPF, USQUE):
//!
//! * **Gyro** ([`Ahrs::step`]): the rate of sample `k` covers `(t_{k−1}, t_k]` (the convention of
//!   IMU drivers and of VQF); the filter propagates over that interval with it, plus the coning term
//!   of the interval before ([`GyroChannel::coning_rad_s`]). A reading that is its interval's mean
//!   describes the body `lag_intervals` of the interval earlier: the accelerometer's gravity and the
//!   magnetometer's reading are turned forward to the sample's time.
//! * **Gyro frame**: the gyro's rotation alone (bias removed, no correction) integrated from the start;
//!   the accelerometer's low-pass and the hard-iron fit work in it, so that no correction of the filter
//!   ever feeds back into a measurement.
//! * **Rest** ([`rest`]): a rest detector; at rest the low-passed gyro is an observation of the gyro
//!   bias ([`AttitudeFilter::observe_bias`], every `rest.interval_s`), and the accelerometer's
//!   low-pass is gravity alone.
//! * **Gravity** ([`crate::sensors::gravity::channel`]): the low-passed specific force as a tilt-only observation with a σ that
//!   follows the motion and counts its correlation.
//! * **Field** ([`crate::sensors::field::channel`]): the magnetometer as a heading-only observation, with disturbance
//!   detection, a bounded rejection, a new field accepted after sustained consistent readings, and a
//!   body-fixed (hard-iron) offset estimated and accepted when the readings prove it.
//! * **Honesty** ([`Ahrs::step`]): a variance floor for the tilt and the heading (errors of the sensors
//!   themselves that no averaging removes: accelerometer misalignment, field inhomogeneity), and a
//!   re-acquisition when a channel's innovations stay inconsistent with the filter's covariance for
//!   `recovery.after_s` (the covariance is widened so the filter can follow the sensor again; counted).
//!
//! The reference frame is East-North-Up with magnetic north: up is where gravity points away from, and
//! north is the horizontal direction of the field at the alignment (without a magnetometer, the body's
//! heading at the alignment). Numeric core: no I/O; every state is plain data (a checkpoint holds it).

mod config;
pub mod gains;
pub mod repeats;
pub mod rest;
pub mod sheet;
mod state;

use crate::attitude::{skew, Quaternion};
use crate::filters::{AttitudeFilter, Estimate, FilterError, InitialState};
use crate::sensors::field::{dip_rad, FieldChannel, HeadingObservation};
use crate::sensors::gravity::{GravityChannel, TiltObservation, UP};
use crate::sensors::gyro::channel::SATURATION_FRACTION;
use crate::sensors::gyro::{Gap, GyroChannel, GyroConfig};
use crate::sensors::heading::{heading_basis, heading_jacobian, heading_residual};
pub use crate::sensors::ImuSample;
use crate::sensors::VectorObservation;
pub use config::{AhrsConfig, InitConfig, RecoveryConfig, RestConfig};
use gains::{GainCache, IntervalGains};
use nalgebra::{Matrix2, Matrix3, Matrix6, Vector3};
use repeats::{Interpolation, MagHold};
use rest::RestDetector;
use sheet::STANDARD_G;
pub use sheet::{MeasuredNoise, NoiseMeter, Output, SensorSheet};
pub use state::{AhrsState, Phase};

/// What the pipeline has done so far and what it sees now (published with every estimate).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AhrsCounts {
    pub samples: u64,
    pub at_rest: bool,
    pub rest_samples: u64,
    pub bias_updates: u64,
    pub tilt_updates: u64,
    pub tilt_gated: u64,
    pub heading_updates: u64,
    pub mag_disturbed: bool,
    pub mag_rejected: u64,
    pub mag_new_fields: u64,
    pub mag_hard_iron_changes: u64,
    pub tilt_reacquisitions: u64,
    pub heading_reacquisitions: u64,
    /// The 1σ of the low-passed gravity direction now, rad.
    pub tilt_sigma_lp_rad: f64,
    /// Gyro samples at or beyond 98% of the range (saturated), and accelerometer samples.
    pub gyro_saturated: u64,
    pub acc_saturated: u64,
    /// Seconds since the last heading update (since the start when there was none): while it grows
    /// nothing but the gyro holds the heading, and its variance grows with the gyro's model.
    pub heading_unaided_s: f64,
    /// Gaps in the samples (an interval over three usual ones) and the time without samples in
    /// them, s.
    pub gaps: u64,
    pub blind_s: f64,
}

/// The part of a sample's interval its estimate's instant is uncertain by (1σ): the rate stands for
/// the interval, its mean or its end.
const INTERVAL_INSTANT_FRACTION: f64 = 0.5;

/// The share of a held reading's variance that stays in the gyro frame after its run's catch-up:
/// a rate that wanders by a random change per sample turns, over a run of `n`, away from the line
/// between the run's two ends by `n(n+1)(n+2)/12` changes² (a Brownian bridge), against the `n²` the
/// held rate is given (one reading: ½; two: ½; three: 5/9).
const HELD_FRAME_SHARE: f64 = 0.5;

/// A gap that may hide more than this rotation (1σ², 1°) leaves the hard-iron fit in a frame that
/// has turned wrongly: it forgets what it held.
const FIT_FORGET_RAD2: f64 = 3.0e-4;

/// A heading updated by the magnetometer within this long is aided (`diagnostics.imu.heading_aided`).
pub const HEADING_AIDED_S: f64 = 10.0;

/// The pipeline's state for one vehicle.
#[derive(Clone, Debug, PartialEq)]
pub struct Ahrs {
    phase: Phase,
    /// The last sample's time.
    t_s: Option<f64>,
    /// The gyro frame: the attitude (gyro frame → body) integrated from the gyro alone.
    q_gyro: Quaternion,
    /// The sensor as its datasheet states it (the vehicle's), and as the data measure it.
    sheet: SensorSheet,
    noise: NoiseMeter,
    gyro: GyroChannel,
    rest: RestDetector,
    gravity: GravityChannel,
    field: Option<FieldChannel>,
    since_bias_s: f64,
    /// What a published estimate adds to the filter's attitude covariance now (see
    /// [`Ahrs::published_attitude_covariance`]): the time stamp's (body frame, rad²)...
    published: Matrix3<f64>,
    /// ...and north's about the estimate's vertical (rad², 0 once rotation confirms the field).
    north_var: f64,
    tilt_inconsistent_s: f64,
    heading_inconsistent_s: f64,
    counts: AhrsCounts,
    /// The interval's gains, remembered by interval (not state: the same bits as computed afresh).
    gains: GainCache,
    /// The gap the last sample closed, until the vehicle takes it ([`Ahrs::take_gap`]; not state:
    /// the vehicle reports it at once).
    last_gap: Option<Gap>,
    /// The last samples' changes, for a hole filled in on a line ([`Interpolation`]), and the
    /// magnetometer's last new reading, for the repeats of a slower one ([`MagHold`]).
    line: Interpolation,
    mag_hold: MagHold,
}

/// What [`Ahrs::preprocess`] hands the step.
struct Preprocessed {
    /// The interval since the previous sample, s.
    dt: f64,
    /// The gyro frame's attitude matrix (gyro frame → body).
    a_gyro: Matrix3<f64>,
    /// The low-passed vertical in the gyro frame ([`GravityChannel::up_gyro`]).
    up_gyro: Option<Vector3<f64>>,
    gains: IntervalGains,
}

impl Ahrs {
    pub fn new(c: &AhrsConfig) -> Self {
        Ahrs {
            phase: Phase::Aligning {
                t0_s: f64::NAN,
                acc: Vector3::zeros(),
                mag: Vector3::zeros(),
                n_acc: 0,
                n_mag: 0,
            },
            t_s: None,
            q_gyro: Quaternion::IDENTITY,
            sheet: SensorSheet::default(),
            noise: NoiseMeter::default(),
            gyro: GyroChannel::default(),
            rest: RestDetector::new(&c.rest),
            gravity: GravityChannel::new(&c.acc, 9.81),
            field: None,
            since_bias_s: 0.0,
            published: Matrix3::zeros(),
            north_var: 0.0,
            tilt_inconsistent_s: 0.0,
            heading_inconsistent_s: 0.0,
            counts: AhrsCounts::default(),
            gains: GainCache::default(),
            last_gap: None,
            line: Interpolation::default(),
            mag_hold: MagHold::default(),
        }
    }

    /// What the estimate `q` adds to the filter's attitude covariance when it is published (body
    /// frame, rad²): the rotation over the time-stamp uncertainty, `σ_t² ω ωᵀ`, and, until rotation
    /// confirms the field, north's ([`FieldChannel::north_variance`]) about the estimate's own
    /// vertical (exactly its vertical: a vertical off by δ would put δ² of it into the tilt).
    pub fn published_attitude_covariance(&self, q: &Quaternion) -> Matrix3<f64> {
        if self.north_var > 0.0 {
            let up = q.attitude_matrix() * UP;
            self.published + up * up.transpose() * self.north_var
        } else {
            self.published
        }
    }

    /// The time of the last sample taken.
    pub fn time_s(&self) -> Option<f64> {
        self.t_s
    }

    pub fn counts(&self) -> &AhrsCounts {
        &self.counts
    }

    /// The gap the last sample closed, once.
    pub fn take_gap(&mut self) -> Option<Gap> {
        self.last_gap.take()
    }

    /// The sensor's datasheet values the pipeline uses.
    pub fn sheet(&self) -> &SensorSheet {
        &self.sheet
    }

    /// Uses `sheet` from the next sample on.
    pub fn set_sheet(&mut self, sheet: &SensorSheet) {
        self.sheet = sheet.clone();
    }

    /// The sensors' noise as measured at rest so far.
    pub fn measured_noise(&self) -> MeasuredNoise {
        self.noise.measured()
    }

    /// How far into its interval a reading lags: the datasheet's output stage when stated, else the
    /// configuration's (the accelerometer's, the magnetometer's).
    fn lag_intervals(&self, c: &AhrsConfig) -> (f64, f64) {
        self.sheet
            .output
            .models()
            .map_or((c.acc.lag_intervals, c.mag.lag_intervals), |(lag, _)| {
                (lag, lag)
            })
    }

    /// The gyro configuration with the datasheet's range when the configuration gives none, and
    /// the coning term as the datasheet's output stage says when it is stated.
    fn gyro_config(&self, c: &AhrsConfig) -> GyroConfig {
        let mut g = c.gyro.clone();
        if let Some((_, coning)) = self.sheet.output.models() {
            g.coning = coning;
        }
        if g.range_rad_s <= 0.0 {
            g.range_rad_s = self.sheet.gyro_range_rad_s();
        }
        g
    }

    /// The rest detector's limits, no tighter than five times the sensors' per-sample noise (the
    /// datasheet's, else the measured): a noisy sensor at rest must still be found at rest.
    fn rest_config(&self, c: &AhrsConfig, dt_s: f64) -> RestConfig {
        let mut r = c.rest.clone();
        let (mut sg, mut sa) = self.noise.sample_sigmas();
        if dt_s > 0.0 {
            sg = sg.max(self.sheet.gyro_arw_rad_sqrt_s() / dt_s.sqrt());
            sa = sa.max(self.sheet.acc_noise_density_m_s2_sqrt_hz() / dt_s.sqrt());
        }
        // (The limits are on the deviations after their own low-pass, which keeps this share of a
        // sample's noise.)
        let share = rest::deviation_noise_share(dt_s).sqrt();
        r.gyr_limit_rad_s = r.gyr_limit_rad_s.max(5.0 * sg * share);
        r.acc_limit_m_s2 = r.acc_limit_m_s2.max(5.0 * sa * share);
        r
    }

    /// The field channel's reference (unit direction in the reference frame, norm, dip) and offset.
    pub fn field_reference(&self) -> Option<((Vector3<f64>, f64, f64), Vector3<f64>)> {
        self.field.as_ref().map(|f| (f.reference(), f.offset()))
    }

    /// The field channel's reference norm and dip (rad), its offset (cheaper than
    /// [`Ahrs::field_reference`]: no direction) and whether rotation has confirmed it.
    pub fn field_norm_dip_offset(&self) -> Option<(f64, f64, Vector3<f64>, bool)> {
        self.field.as_ref().map(|f| {
            let (norm, dip) = f.norm_dip();
            (norm, dip, f.offset(), f.confirmed)
        })
    }

    /// The rotation a held run hid, when this sample ends one: the run's readings repeated the rate
    /// from before it, while the rate went from that one to this sample's; the rotation over the run
    /// is then closer to the mean of the two (`(ω_k − ω_held) T_run / 2` more than was turned) than to
    /// the held rate alone. (The run's variance, added per held reading, stays: it is that of the
    /// held rate; the interpolated one is at least as good.)
    fn held_catch_up(&self, s: &ImuSample) -> Option<Vector3<f64>> {
        let held = self.gyro.held;
        let prev = self.gyro.previous?;
        if held == 0 || prev == s.gyr_rad_s {
            return None;
        }
        let run_s = f64::from(held) * self.gyro.interval_s;
        Some((s.gyr_rad_s - prev) * (0.5 * run_s))
    }

    /// The gyro frame has turned by what nobody saw (a gap's bridge, a filled hole), its variance
    /// grown from `before` to `after` (rad² per axis): what the low-pass and the hard-iron fit hold
    /// from before is turned against what comes after by as much, and the fit forgets what it held
    /// once that may exceed 1° (`FIT_FORGET_RAD2`).
    fn turned_unseen(&mut self, c: &AhrsConfig, before: f64, after: f64) {
        self.gravity.frame_var += (after - before).max(0.0);
        if before <= FIT_FORGET_RAD2 && after > FIT_FORGET_RAD2 {
            if let Some(f) = self.field.as_mut() {
                f.forget_fit(&c.mag);
            }
        }
    }

    /// The preprocessing every sample gets (alignment or not): gyro frame, rest, gravity low-pass.
    /// `gap`: the gap before the sample, bridged in the gyro frame as in the filter.
    fn preprocess(
        &mut self,
        c: &AhrsConfig,
        s: &ImuSample,
        bias: &Vector3<f64>,
        gap: Option<&Gap>,
        catch_up: Option<&Vector3<f64>>,
        coning_rad_s: &Vector3<f64>,
    ) -> Preprocessed {
        let dt = match self.t_s {
            Some(t) => (s.t_s - t).max(0.0),
            None => 0.0,
        };
        self.t_s = Some(s.t_s);
        self.counts.samples += 1;
        // The sample's own interval: after a gap, the reading still covers only its own.
        let own = gap.map_or(dt, |g| dt - g.blind_s);
        if dt > 0.0 {
            let mut q = self.q_gyro;
            if let Some(g) = gap {
                q = q.propagate(&(g.bridge_rad_s - bias), g.blind_s);
            }
            if let Some(r) = catch_up {
                q = q.propagate(r, 1.0);
            }
            self.q_gyro = q
                .propagate(&(s.gyr_rad_s - bias + coning_rad_s), own)
                .normalized()
                .unwrap_or(self.q_gyro);
        }
        // A saturated accelerometer reading is not gravity and not rest; its low-pass takes it, but
        // its direction may be off by what the range hid (half the range, over the low-pass).
        let acc_range = self.sheet.acc_range_m_s2();
        let acc_saturated = acc_range > 0.0 && s.acc_m_s2.amax() >= SATURATION_FRACTION * acc_range;
        let rest_config = self.rest_config(c, dt);
        let at_rest = c.rest.enabled
            && !acc_saturated
            && self
                .rest
                .update(&rest_config, &s.gyr_rad_s, &s.acc_m_s2, dt);
        self.counts.at_rest = at_rest;
        if at_rest {
            self.counts.rest_samples += 1;
            let gyr_dev = s.gyr_rad_s - self.rest.gyr_lowpass();
            let acc_dev = s.acc_m_s2 - self.rest.acc_lowpass();
            self.noise.at_rest(&gyr_dev, &acc_dev, s.mag.as_ref(), dt);
        } else {
            self.noise.moving();
        }
        if acc_saturated {
            self.counts.acc_saturated += 1;
            let share = (dt / c.acc.lowpass_s.max(1e-9)).min(1.0);
            self.gravity.frame_var +=
                (0.5 * acc_range / self.gravity.g0().max(1e-9) * share).powi(2);
        }
        let a_gyro = self.q_gyro.attitude_matrix();
        let gains = self.gains.get(c, dt);
        // The reading describes the body `lag_intervals` of its interval before the rotation just
        // integrated: its gravity is turned forward over that time (a body-frame vector turns the
        // other way, Ȧ = −[ω×] A). Gravity as the low-pass holds it, not the reading: the linear
        // acceleration in the reading is what the low-pass averages away, and turning it too cost
        // more than it gave (BROAD 16, a fast translation, at 25–50 Hz: 1.2× VQF's error → 1.9×).
        let lag = self.lag_intervals(c).0 * own;
        let acc = match self.gravity.up_body(&a_gyro) {
            Some(up) if lag > 0.0 => {
                s.acc_m_s2 - (s.gyr_rad_s - bias).cross(&up) * (self.gravity.g0() * lag)
            }
            _ => s.acc_m_s2,
        };
        let up_gyro = self
            .gravity
            .update_by(&acc, &a_gyro, dt, at_rest, gains.acc);
        Preprocessed {
            dt,
            a_gyro,
            up_gyro,
            gains,
        }
    }

    /// Takes a sample while no filter runs. Once `init.duration_s` of samples is collected, returns
    /// the initial state of the filter (attitude from the mean accelerometer and magnetometer; bias 0
    /// with `bias_sigma_rad_s`); the caller starts the filter with it at the sample's time and then
    /// hands every later sample to [`Ahrs::step`]. Restarts the alignment if a filter ran before.
    pub fn align(
        &mut self,
        c: &AhrsConfig,
        s: &ImuSample,
        bias_sigma_rad_s: &Vector3<f64>,
    ) -> Option<InitialState> {
        if self.phase == Phase::Running {
            // (The datasheet is the vehicle's, not learnt: it stays.)
            let sheet = std::mem::take(&mut self.sheet);
            *self = Ahrs::new(c);
            self.sheet = sheet;
        }
        self.preprocess(c, s, &Vector3::zeros(), None, None, &Vector3::zeros());
        self.line.step(s, 0.0, false);
        let Phase::Aligning {
            t0_s,
            acc,
            mag,
            n_acc,
            n_mag,
        } = &mut self.phase
        else {
            return None;
        };
        if t0_s.is_nan() {
            *t0_s = s.t_s;
        }
        *acc += s.acc_m_s2;
        *n_acc += 1;
        if let Some(m) = s.mag.filter(|_| c.mag.enabled) {
            *mag += m;
            *n_mag += 1;
        }
        if s.t_s - *t0_s + 1e-9 < c.init.duration_s {
            return None;
        }
        let acc = *acc / f64::from(*n_acc);
        let mag = (*n_mag > 0).then(|| *mag / f64::from(*n_mag));
        let up_b = acc.try_normalize(1e-9)?;
        // North: the horizontal part of the field; without one, the body's x (or y) axis.
        let horizontal = |v: &Vector3<f64>| (v - up_b * v.dot(&up_b)).try_normalize(1e-6);
        let from_mag = mag.as_ref().and_then(horizontal);
        let north_b = from_mag
            .or_else(|| horizontal(&Vector3::x()))
            .or_else(|| horizontal(&Vector3::y()))?;
        let east_b = north_b.cross(&up_b);
        // A (reference → body) has the body-frame images of east, north, up as columns.
        let a = Matrix3::from_columns(&[east_b, north_b, up_b]);
        let q = Quaternion::from_attitude_matrix(&a).normalized()?;
        // A start in motion: the window's mean specific force is gravity plus the motion, and the
        // body turned while it was averaged. The tilt may be off by the turn and by as much as the
        // norm shows of the motion; the heading (taken against that vertical) by that times tan(dip).
        let turned = self.q_gyro.angle();
        let norm_off = (acc.norm() / STANDARD_G - 1.0).abs();
        let moving2 = turned * turned + norm_off * norm_off;
        self.gravity = GravityChannel::new(&c.acc, acc.norm());
        // Replays the alignment window's gravity low-pass from its mean (the frames agree at the
        // start: the gyro frame is re-anchored on the aligned attitude).
        self.q_gyro = q;
        let a_gyro = q.attitude_matrix();
        self.gravity.update(&c.acc, &acc, &a_gyro, 0.0, false);
        // The heading is the field's direction across the vertical the accelerometer gave: a vertical
        // tipped by δ about north turns it by −tan(dip) δ (about east, not at all). So the heading
        // inherits the tilt's uncertainty about north times tan(dip), fully correlated with it, and
        // keeps it after the accelerometer has corrected the tilt (a tilt update never turns the
        // heading). Without a field the heading is the body's axis: no such term.
        let mut kappa = 0.0;
        if let (Some(m), true) = (mag, from_mag.is_some()) {
            let n = m.norm();
            let dip = dip_rad(&(m / n), &up_b);
            kappa = -dip.tan().clamp(-10.0, 10.0);
            self.field = Some(FieldChannel::new(n, dip, &Vector3::y()));
        }
        // (An estimate published straight from the alignment carries it too.)
        self.doubt_north(c);
        self.phase = Phase::Running;
        // Initial covariance: tilt and heading σ in the reference frame (east, north, up), rotated
        // into the body.
        let tilt2 = c.init.tilt_sigma_rad.powi(2) + moving2;
        let pe = Matrix3::new(
            tilt2,
            0.0,
            0.0,
            0.0,
            tilt2,
            kappa * tilt2,
            0.0,
            kappa * tilt2,
            c.init.heading_sigma_rad.powi(2) + kappa * kappa * tilt2,
        );
        let pb = a * pe * a.transpose();
        let mut p = Matrix6::zeros();
        p.fixed_view_mut::<3, 3>(0, 0).copy_from(&pb);
        for i in 0..3 {
            p[(i + 3, i + 3)] = bias_sigma_rad_s[i].powi(2);
        }
        crate::filters::symmetrize(&mut p);
        Some(InitialState {
            t_s: Some(s.t_s),
            q,
            sigma_att_rad: Vector3::new(pb[(0, 0)].sqrt(), pb[(1, 1)].sqrt(), pb[(2, 2)].sqrt()),
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: *bias_sigma_rad_s,
            uniform_attitude: false,
            covariance: Some(p),
        })
    }

    /// Takes a sample with a running filter: propagation over `(t_prev, t]` with the sample's rate,
    /// then the bias at rest, the tilt and the heading as they fall due, each followed by the honesty
    /// checks. A refused filter step leaves the filter as it was (the [`AttitudeFilter`] contract) and
    /// ends the step with its error.
    pub fn step(
        &mut self,
        c: &AhrsConfig,
        s: &ImuSample,
        filter: &mut dyn AttitudeFilter,
    ) -> Result<(), FilterError> {
        if self.phase != Phase::Running {
            // A filter started otherwise (a reset with an attitude, a fleet takeover): the pipeline
            // adopts its estimate as the gyro frame's start and learns the field from the next
            // reading, expressed with that estimate.
            let e = filter.estimate();
            self.q_gyro = e.q;
            self.gravity = GravityChannel::new(&c.acc, s.acc_m_s2.norm().max(1e-6));
            self.field = None;
            self.phase = Phase::Running;
        }
        let t_prev = self.t_s.unwrap_or(s.t_s);
        // The gyro frame never removes more than the rest detector's bias limit per axis: a filter
        // whose bias estimate ran away (an inconsistent start) must not spin the frame the
        // accelerometer and the hard-iron fit are kept in.
        let limit = c.rest.bias_limit_rad_s;
        let bias = filter.bias_rad_s().map(|b| b.clamp(-limit, limit));
        let gyro_config = self.gyro_config(c);
        // A gap before this sample: bridged by the rates on both sides, its variance what it hid.
        let gap = self.gyro.gap(&gyro_config, &s.gyr_rad_s, s.t_s - t_prev);
        let catch_up = self.held_catch_up(s);
        // The interval's rotation to second order (the coning term), in the gyro frame and the filter.
        let coning = self
            .gyro
            .coning_rad_s(&gyro_config, &s.gyr_rad_s, &bias, gap.is_some());
        let Preprocessed {
            dt,
            a_gyro,
            up_gyro,
            gains,
        } = self.preprocess(c, s, &bias, gap.as_ref(), catch_up.as_ref(), &coning);
        let omega = s.gyr_rad_s - bias;
        // A sample stands for its whole interval: the instant its estimate describes is uncertain by
        // the sender's time stamp and by a part of the interval (the rate may be the interval's mean
        // or its end's), a rotation about the turn axis that a low rate makes large.
        let instant =
            c.timing_sigma_s.powi(2) + (INTERVAL_INSTANT_FRACTION * self.gyro.interval_s).powi(2);
        self.published = omega * omega.transpose() * instant;
        self.counts.heading_unaided_s += dt;
        let mut t_from = t_prev;
        if let Some(g) = &gap {
            // The gyro frame crossed the gap on the bridge too: what the low-pass and the fit hold
            // from before it is turned against what comes after by as much as the bridge is off.
            self.turned_unseen(c, 0.0, g.variance_rad2);
            self.counts.gaps = self.gyro.gaps;
            self.counts.blind_s = self.gyro.blind_s;
            self.last_gap = Some(*g);
            t_from = t_prev + g.blind_s;
            filter.gyro_interval_with(t_prev, &g.bridge_rad_s, t_from, g.variance_rad2)?;
        }
        // The sample's own interval (after a gap, the part the bridge did not cover): its rate, its
        // readings' lag and a filled run's time count over it.
        let own = s.t_s - t_from;
        // The rate over (t_prev, t]: held from t_prev, then the filter moves to t, with what the
        // sample may hide beside the gyro model (the rate's change, saturation).
        let hidden = self.gyro.step(&gyro_config, &s.gyr_rad_s, own);
        let saturation = self
            .gyro
            .saturation_variance(&gyro_config, &s.gyr_rad_s, own);
        // A sample on the line through the two before it: the run of such samples is a gap that
        // someone filled in (`Interpolation`). What it hides grows as a gap's would over the run's
        // time, in the filter and in the gyro frame (as across a gap).
        let hidden = match self.line.step(s, own, gap.is_some()) {
            Some((was, now)) => {
                let before = self.gyro.unseen_turn_variance(&gyro_config, was);
                let after = self.gyro.unseen_turn_variance(&gyro_config, now);
                self.turned_unseen(c, before, after);
                hidden + (after - before).max(0.0)
            }
            None => hidden,
        };
        if self.gyro.run == 0 && self.gyro.held > 0 {
            // A held reading turns the gyro frame by the stale rate: what the low-pass holds from
            // before is turned against what comes after by what the catch-up (`held_catch_up`) will
            // not restore, the run's deviation from a line between the rates on both sides, about
            // half the held rate's variance. (Left out, 30% of the samples held had the tilt inside
            // its 99% ellipse 82% of the time, median NEES 2.8.)
            self.gravity.frame_var += HELD_FRAME_SHARE * hidden;
        }
        if self.gyro.run > 0 {
            // The gyro frame turned by less than the body: what the low-pass and the hard-iron fit
            // hold from before is turned wrongly against what comes after.
            self.gravity.frame_var += hidden;
            if self.gyro.run == 1 {
                if let Some(f) = self.field.as_mut() {
                    f.forget_fit(&c.mag);
                }
            }
        }
        self.counts.gyro_saturated = self.gyro.saturated;
        // The catch-up of a held run is turned over this sample's interval, beside its own rate.
        let rate = match catch_up {
            Some(r) if own > 0.0 => s.gyr_rad_s + coning + r / own,
            _ => s.gyr_rad_s + coning,
        };
        // (What saturation hides is about the saturated axes alone: apart from the rest.)
        match saturation {
            Some(v) => {
                filter.gyro_interval_with(t_from, &rate, s.t_s, (hidden - v.max()).max(0.0))?;
                filter.inflate_attitude(&Matrix3::from_diagonal(&v))?;
            }
            None => filter.gyro_interval_with(t_from, &rate, s.t_s, hidden)?,
        }
        let at_rest = self.counts.at_rest;
        // Bias at rest.
        self.since_bias_s += dt;
        if at_rest && self.since_bias_s + 1e-9 >= c.rest.interval_s {
            self.since_bias_s = 0.0;
            filter.observe_bias(s.t_s, &self.rest.gyr_lowpass(), c.rest.bias_sigma_rad_s)?;
            self.counts.bias_updates += 1;
        }
        // Tilt.
        // The low-pass lives in the gyro frame, which the bias estimate turns: while the bias is
        // unsure (a start in motion, before it is learned) its variance across the vertical enters
        // the reading (`GravityChannel::observation`). Read only when a reading is due, and the
        // estimate it is read from is the update's prior (a particle filter's costs a pass).
        let mut estimate = None;
        let bias_across = |up: &Vector3<f64>| {
            let e = estimate.insert(filter.estimate());
            let pb: Matrix3<f64> = e.covariance.fixed_view::<3, 3>(3, 3).into_owned();
            (pb.trace() - (up.transpose() * pb * up)[0]) * 0.5
        };
        match self
            .gravity
            .observation(&c.acc, &a_gyro, at_rest, bias_across)
        {
            TiltObservation::NotDue => {}
            TiltObservation::NormGated => self.counts.tilt_gated += 1,
            TiltObservation::Use(o) => {
                self.counts.tilt_sigma_lp_rad = self.gravity.last_sigma_lp();
                let prior = estimate.unwrap_or_else(|| filter.estimate());
                // Consistency of the low-passed direction itself (its own σ, not the σ that spreads
                // its information over the correlation time).
                let nis = tilt_nis(&prior, &o, self.gravity.last_sigma_lp());
                self.tilt_inconsistent_s = if nis > c.recovery.tilt_nis {
                    self.tilt_inconsistent_s + c.acc.interval_s
                } else {
                    0.0
                };
                update(filter, s.t_s, o)?;
                self.counts.tilt_updates += 1;
                let post = filter.estimate();
                if self.tilt_inconsistent_s >= c.recovery.after_s {
                    self.tilt_inconsistent_s = 0.0;
                    self.counts.tilt_reacquisitions += 1;
                    floor(filter, &post, Axes::Tilt, c.recovery.tilt_sigma_rad)?;
                } else {
                    let lp = c.acc.floor_lp_factor * self.gravity.last_sigma_lp();
                    floor(filter, &post, Axes::Tilt, c.acc.floor_rad.max(lp))?;
                }
            }
        }
        // Heading. A vehicle aligned without a field learns it from its first reading.
        if let (Some(mag), None, true) = (s.mag, &self.field, c.mag.enabled) {
            self.field = learn_field(&filter.estimate(), &mag);
        }
        let omega = s.gyr_rad_s - bias;
        let offset = self
            .field
            .as_ref()
            .map_or_else(Vector3::zeros, |f| f.offset());
        // The magnetometer's lag: its delay, and the part of the interval its reading stands for.
        let mag_lag = c.mag.delay_s + self.lag_intervals(c).1 * own;
        let mag = self.mag_hold.reading(s.mag, &a_gyro, &offset, |m| {
            // Turned forward over the magnetometer's lag: the body turned by ω δ since it sampled,
            // and a body-frame vector seen from it turns the other way, Ȧ = −[ω×] A.
            m - omega.cross(m) * mag_lag
        });
        let fit_reading = self
            .mag_hold
            .as_taken()
            .unwrap_or((Vector3::zeros(), a_gyro));
        if let (Some(mag), Some(field), true) = (mag, self.field.as_mut(), c.mag.enabled) {
            if let (Some(up_b), Some(up_g)) = (self.gravity.up_body(&a_gyro), up_gyro) {
                let rate = self.rest.gyr_lowpass() - bias;
                if let Some(jump) = field.update_by(
                    &c.mag,
                    &mag,
                    &up_b,
                    &up_g,
                    (&fit_reading.0, &fit_reading.1),
                    rate.norm(),
                    self.gravity.frame_var.sqrt(),
                    dt,
                    &gains.field,
                ) {
                    // A new offset turns the readings by `jump`: the heading the old ones gave may
                    // be wrong by as much.
                    let e = filter.estimate();
                    let a = e.q.attitude_matrix();
                    let p: Matrix3<f64> = e.covariance.fixed_view::<3, 3>(0, 0).into_owned();
                    let now = (a.transpose() * p * a)[(2, 2)].max(0.0);
                    floor(filter, &e, Axes::Heading, (now + jump * jump).sqrt())?;
                }
            }
            self.counts.mag_disturbed = field.disturbed();
            self.counts.mag_new_fields = field.new_fields;
            self.counts.mag_hard_iron_changes = field.hard_iron_changes;
            // The magnetometer's noise (the datasheet's, else the measured) as it remains in the
            // channel's low-passed norm (a first-order low-pass keeps Δt/2τ of a white variance).
            let mag_noise = if self.sheet.mag_noise > 0.0 {
                self.sheet.mag_noise
            } else {
                self.noise.measured().mag_noise
            };
            let noise_norm = mag_noise * (dt / (2.0 * c.mag.lowpass_s.max(1e-9))).min(1.0).sqrt();
            match field.observation(
                &c.mag,
                &mag,
                omega.norm(),
                self.gravity.frame_var.sqrt(),
                noise_norm,
            ) {
                HeadingObservation::NotDue => {}
                HeadingObservation::Rejected => self.counts.mag_rejected += 1,
                HeadingObservation::Use(mut o, sigma_psi) => {
                    let prior = filter.estimate();
                    // The heading is read against the estimate's vertical: a tilt error δ turns it
                    // by about δ tan(dip). The filter's own tilt variance enters the reading's σ, so
                    // a heading read while the tilt is unsure (a start, a gap, a saturated gyro) is
                    // weighed as such, not as a clean one.
                    let a = prior.q.attitude_matrix();
                    let p: Matrix3<f64> = prior.covariance.fixed_view::<3, 3>(0, 0).into_owned();
                    let pe = a.transpose() * p * a;
                    let tilt_var = Matrix2::new(pe[(0, 0)], pe[(0, 1)], pe[(1, 0)], pe[(1, 1)])
                        .symmetric_eigenvalues()
                        .max()
                        .max(0.0);
                    let dip = field.norm_dip().1;
                    let sigma_psi = {
                        let widened = (sigma_psi * sigma_psi
                            + tilt_var * dip.tan().powi(2).min(100.0))
                        .sqrt();
                        if sigma_psi > 0.0 {
                            o.sigma *= widened / sigma_psi;
                        }
                        widened
                    };
                    // Consistency with the reading's own heading σ (not the one that spreads its
                    // information over the correlation time).
                    let nis = heading_nis(&prior, &o, sigma_psi);
                    self.heading_inconsistent_s = if nis > c.recovery.heading_nis {
                        self.heading_inconsistent_s + c.mag.interval_s
                    } else {
                        0.0
                    };
                    update(filter, s.t_s, o)?;
                    self.counts.heading_updates += 1;
                    self.counts.heading_unaided_s = 0.0;
                    let post = filter.estimate();
                    if self.heading_inconsistent_s >= c.recovery.after_s {
                        self.heading_inconsistent_s = 0.0;
                        self.counts.heading_reacquisitions += 1;
                        floor(filter, &post, Axes::Heading, c.recovery.heading_sigma_rad)?;
                    } else {
                        floor(filter, &post, Axes::Heading, c.mag.floor_rad)?;
                    }
                }
            }
        }
        self.doubt_north(c);
        Ok(())
    }

    /// North itself, while rotation has not confirmed the field: the filter keeps the heading the
    /// readings give (consistent with each other at one attitude), but the reference they give may
    /// be turned by an offset they cannot reveal yet; the published estimate says so.
    fn doubt_north(&mut self, c: &AhrsConfig) {
        self.north_var = match (self.field.as_ref(), c.mag.enabled) {
            (Some(f), true) => f.north_variance(
                &c.mag,
                (self.sheet.mag_offset_sigma > 0.0).then_some(self.sheet.mag_offset_sigma),
            ),
            _ => 0.0,
        };
    }
}

/// A field channel whose reference is the reading `mag` seen from the estimate `e`: its norm, its dip
/// and, as north, its horizontal direction in the reference frame.
fn learn_field(e: &Estimate, mag: &Vector3<f64>) -> Option<FieldChannel> {
    let a = e.q.attitude_matrix();
    let r = (a.transpose() * mag).try_normalize(1e-12)?;
    let dip = dip_rad(&r, &UP);
    let north = r - UP * r.dot(&UP);
    (north.norm() > 1e-6).then(|| FieldChannel::new(mag.norm(), dip, &north))
}

fn update(
    filter: &mut dyn AttitudeFilter,
    t_s: f64,
    o: VectorObservation,
) -> Result<(), FilterError> {
    filter.observe(t_s, &o)
}

/// `νᵀ S⁻¹ ν` of a tilt observation about the estimate `e` with the observation's 1σ `sigma`:
/// `ν = b − Â r`, `S = [b̂×] P_α [b̂×]ᵀ + σ² I` (the MEKF's measurement model; the same for every
/// filter).
fn tilt_nis(e: &Estimate, o: &VectorObservation, sigma: f64) -> f64 {
    let a = e.q.attitude_matrix();
    let predicted = a * o.reference;
    let h = skew(&predicted);
    let p: Matrix3<f64> = e.covariance.fixed_view::<3, 3>(0, 0).into_owned();
    let s = h * p * h.transpose() + Matrix3::identity() * (sigma * sigma);
    let nu = o.body - predicted;
    s.cholesky().map_or(0.0, |c| nu.dot(&c.solve(&nu)))
}

/// `y²/S` of a heading observation about the estimate `e` with the heading 1σ `sigma`: `y = −ψ(Â)`,
/// `S = hᵀ P_α h + σ_ψ²`.
fn heading_nis(e: &Estimate, o: &VectorObservation, sigma: f64) -> f64 {
    let Some(up) = o.aspect.heading_axis() else {
        return 0.0;
    };
    let Some((e1, e2, horizontal)) = heading_basis(&o.reference, up) else {
        return 0.0;
    };
    let a = e.q.attitude_matrix();
    let h = heading_jacobian(&a, &o.reference, &e2, horizontal);
    let y = -heading_residual(&a, &o.body, &e1, &e2);
    let p: Matrix3<f64> = e.covariance.fixed_view::<3, 3>(0, 0).into_owned();
    let s = h.dot(&(p * h)) + sigma * sigma;
    if s > 0.0 {
        y * y / s
    } else {
        0.0
    }
}

/// Which part of the attitude error a floor applies to, in the reference frame.
#[derive(Clone, Copy)]
enum Axes {
    /// The horizontal axes (east, north): the tilt.
    Tilt,
    /// The vertical: the heading.
    Heading,
}

/// Widens the attitude covariance of `e` so that its reference-frame tilt (or heading) 1σ is at least
/// `sigma_rad` on every axis of that part (`P_ref = Âᵀ P Â`).
fn floor(
    filter: &mut dyn AttitudeFilter,
    e: &Estimate,
    axes: Axes,
    sigma_rad: f64,
) -> Result<(), FilterError> {
    if !(sigma_rad > 0.0) {
        return Ok(());
    }
    let a = e.q.attitude_matrix();
    let p: Matrix3<f64> = e.covariance.fixed_view::<3, 3>(0, 0).into_owned();
    let pe = a.transpose() * p * a;
    let floor2 = sigma_rad * sigma_rad;
    let mut add = Matrix3::zeros();
    match axes {
        Axes::Tilt => {
            let block = Matrix2::new(pe[(0, 0)], pe[(0, 1)], pe[(1, 0)], pe[(1, 1)]);
            let eig = block.symmetric_eigen();
            for k in 0..2 {
                let lack = floor2 - eig.eigenvalues[k];
                if lack > 0.0 {
                    let v = eig.eigenvectors.column(k);
                    let v3 = Vector3::new(v[0], v[1], 0.0);
                    add += v3 * v3.transpose() * lack;
                }
            }
        }
        Axes::Heading => {
            let lack = floor2 - pe[(2, 2)];
            if lack > 0.0 {
                add[(2, 2)] = lack;
            }
        }
    }
    if add.amax() > 0.0 {
        let body = a * add * a.transpose();
        filter.inflate_attitude(&((body + body.transpose()) * 0.5))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// The attitude a still, level-or-tilted body aligns to from `acc_ref` (the specific force in
    /// the reference frame: gravity, or gravity plus a motion) and a field of dip `dip_rad`, with the
    /// body's attitude `a_true` (reference → body).
    fn aligned(a_true: &Matrix3<f64>, acc_ref: &Vector3<f64>, dip_rad: f64) -> InitialState {
        let c = AhrsConfig::default();
        let field = Vector3::new(0.0, dip_rad.cos(), -dip_rad.sin()) * 48.0;
        let mut ahrs = Ahrs::new(&c);
        for k in 0..=20 {
            let s = ImuSample {
                t_s: 0.01 * f64::from(k),
                gyr_rad_s: Vector3::zeros(),
                acc_m_s2: a_true * acc_ref,
                mag: Some(a_true * field),
            };
            if let Some(init) = ahrs.align(&c, &s, &Vector3::repeat(0.01)) {
                return init;
            }
        }
        panic!("no alignment within 0.2 s");
    }

    /// A repeated reading of a slower magnetometer is the field where it was when the reading was
    /// new: turned by the gyro frame's rotation since, with the body-fixed offset left in place, it
    /// is the reading the body would give now. A new reading is taken as it is (with the delay's turn).
    #[test]
    fn a_repeated_magnetometer_reading_is_turned_to_now() {
        let field_g = Vector3::new(18.0, 5.0, -42.0);
        let offset = Vector3::new(3.0, -7.0, 2.0);
        let a_at = |k: usize| {
            Rotation3::from_scaled_axis(Vector3::new(0.2, -0.1, 1.0) * (0.05 * k as f64))
                .into_inner()
        };
        let mut hold = MagHold::default();
        let raw = a_at(0) * field_g + offset;
        let delayed = |m: &Vector3<f64>| m * 1.0;
        assert_eq!(
            hold.reading(Some(raw), &a_at(0), &offset, delayed),
            Some(raw)
        );
        for k in 1..6 {
            let now = hold.reading(Some(raw), &a_at(k), &offset, delayed).unwrap();
            let truth = a_at(k) * field_g + offset;
            assert!((now - truth).norm() < 1e-9, "{k}: {now} against {truth}");
            assert!((raw - truth).norm() > 0.5, "the reading did go stale");
        }
        // A new reading resets the hold; no reading, nothing.
        let fresh = a_at(6) * field_g + offset + Vector3::new(0.01, 0.0, 0.0);
        assert_eq!(
            hold.reading(Some(fresh), &a_at(6), &offset, delayed),
            Some(fresh)
        );
        assert_eq!(hold.reading(None, &a_at(7), &offset, delayed), None);
    }

    /// A hole filled in on the line between two real samples is seen from its second made-up sample
    /// to the real one that ends it (the first lies on the line only with the next); a noisy sensor,
    /// a held reading, a still body and a constant spin are never seen as one.
    #[test]
    fn a_filled_hole_is_seen_and_real_samples_are_not() {
        use rand::SeedableRng;
        let mut rng = crate::rng::Xoshiro256PlusPlus::seed_from_u64(7);
        let mut noise = || {
            let mut n = || crate::rng::standard_normal(&mut rng);
            Vector3::new(n(), n(), n())
        };
        let sample = |k: usize, gyr: Vector3<f64>, acc: Vector3<f64>| ImuSample {
            t_s: 0.01 * k as f64,
            gyr_rad_s: gyr,
            acc_m_s2: acc,
            mag: Some(Vector3::new(20.0, 0.0, -40.0) + acc * 0.1),
        };
        let real: Vec<ImuSample> = (0..40)
            .map(|k| {
                let w = Vector3::new(0.5, -0.3, 1.0 + 0.02 * k as f64) + noise() * 0.003;
                sample(k, w, Vector3::new(0.3, 0.1, 9.8) + noise() * 0.02)
            })
            .collect();
        let mut line = Interpolation::default();
        assert!(
            real.iter().all(|s| line.step(s, 0.01, false).is_none()),
            "noise is no line"
        );
        // Samples 20..30 lost and made up on the line between 19 and 30.
        let mut filled = real.clone();
        for k in 20..30 {
            let f = (k - 19) as f64 / 11.0;
            let (a, b) = (&real[19], &real[30]);
            filled[k] = ImuSample {
                t_s: filled[k].t_s,
                gyr_rad_s: a.gyr_rad_s + (b.gyr_rad_s - a.gyr_rad_s) * f,
                acc_m_s2: a.acc_m_s2 + (b.acc_m_s2 - a.acc_m_s2) * f,
                mag: Some(a.mag.unwrap() + (b.mag.unwrap() - a.mag.unwrap()) * f),
            };
        }
        let mut line = Interpolation::default();
        let runs: Vec<u32> = filled
            .iter()
            .map(|s| {
                line.step(s, 0.01, false);
                line.run
            })
            .collect();
        assert_eq!(&runs[..21], &[0; 21][..], "{runs:?}");
        assert_eq!(
            &runs[21..31],
            &(1..=10).collect::<Vec<u32>>()[..],
            "{runs:?}"
        );
        assert_eq!(runs[31], 0, "{runs:?}");
        // Held readings, a still body, a constant spin: nothing moves on a line.
        for s in [
            sample(0, Vector3::new(0.4, 0.2, 0.1), Vector3::new(0.0, 0.0, 9.8)),
            sample(0, Vector3::zeros(), Vector3::new(0.0, 0.0, 9.8)),
        ] {
            let mut line = Interpolation::default();
            for k in 0..10 {
                let s = ImuSample {
                    t_s: 0.01 * k as f64,
                    ..s
                };
                assert_eq!(line.step(&s, 0.01, false), None);
            }
        }
        let mut line = Interpolation::default();
        for k in 0..10 {
            // A rate ramp about the vertical with the accelerometer still (a noise-free spin-up).
            let s = sample(
                k,
                Vector3::new(0.0, 0.0, 0.1 * k as f64),
                Vector3::new(0.0, 0.0, 9.8),
            );
            assert_eq!(line.step(&ImuSample { mag: None, ..s }, 0.01, false), None);
        }
    }

    /// A steady turn about a nearly horizontal axis at 25 Hz, the accelerometer's readings their
    /// interval's means (by 400 sub-steps), through the pipeline's preprocessing with `c` and `sheet`:
    /// how far the low-passed vertical ends from the true one, and `|ω| Δt / 2`, how far a reading
    /// taken as of its time stamp puts it, both in degrees.
    fn vertical_off_in_a_turn(c: &AhrsConfig, sheet: &SensorSheet) -> (f64, f64) {
        let dt = 0.04;
        let omega = Vector3::new(1.5, 0.0, 0.2);
        let a0 = Rotation3::from_euler_angles(0.2, -0.1, 0.7).into_inner();
        // Ȧ = −[ω×] A with ω constant in the body: A(t) = exp(−[ω×] t) A₀.
        let a_at = |t: f64| Rotation3::from_scaled_axis(-omega * t).into_inner() * a0;
        let g = Vector3::new(0.0, 0.0, STANDARD_G);
        // The interval's mean, (t − Δt, t].
        let mean = |t: f64| {
            (0..400)
                .map(|i| a_at(t - dt + dt * (f64::from(i) + 0.5) / 400.0) * g)
                .sum::<Vector3<f64>>()
                / 400.0
        };
        let mut ahrs = Ahrs::new(c);
        ahrs.set_sheet(sheet);
        for k in 0..500 {
            let t = dt * f64::from(k);
            let s = ImuSample {
                t_s: t,
                gyr_rad_s: omega,
                acc_m_s2: mean(t),
                mag: None,
            };
            ahrs.preprocess(c, &s, &Vector3::zeros(), None, None, &Vector3::zeros());
        }
        // The gyro frame is the body's at the first sample: up there is A₀ ẑ.
        let off = ahrs.gravity.up_gyro().unwrap().angle(&(a0 * Vector3::z()));
        (off.to_degrees(), (omega.norm() * dt / 2.0).to_degrees())
    }

    /// A reading that is its interval's mean describes the body half an interval before the rotation
    /// integrated to its time stamp. In a steady turn about a horizontal axis, gravity stands still
    /// in the gyro frame, and readings taken as of their time stamp put it `|ω| Δt / 2` off: 1.7° at
    /// 25 Hz and 1.5 rad/s, a tilt error the low-pass keeps for as long as the turn lasts. Turned
    /// forward by half the interval, the low-passed vertical is the true one.
    #[test]
    fn a_reading_of_its_intervals_mean_is_turned_to_the_sample_time() {
        let off = |lag_intervals: f64| {
            let mut c = AhrsConfig::default();
            c.acc.lag_intervals = lag_intervals;
            vertical_off_in_a_turn(&c, &SensorSheet::default())
        };
        let (lagging, expected) = off(0.0);
        let (turned, _) = off(0.5);
        assert!(
            (lagging / expected - 1.0).abs() < 0.1,
            "as of the time stamp: {lagging}° off, expected {expected}°"
        );
        assert!(turned < 0.03, "turned forward: {turned}° off");
    }

    /// A datasheet that states its output stage replaces the configuration's lag and coning term for
    /// its sensor: readings that are interval means, sent by a vehicle whose sheet says `instant`,
    /// keep the half-interval lag (1.7° of vertical in this turn) although the configuration would
    /// turn them, and a sheet that says `mean` turns them although the configuration says 0; an
    /// `increments` gyro gets no coning term, the others keep the configuration's.
    #[test]
    fn a_datasheets_output_stage_replaces_the_configured_lag_and_coning() {
        let off = |config_lag: f64, output: Output| {
            let mut c = AhrsConfig::default();
            c.acc.lag_intervals = config_lag;
            c.mag.lag_intervals = config_lag;
            let sheet = SensorSheet {
                output,
                ..SensorSheet::default()
            };
            vertical_off_in_a_turn(&c, &sheet)
        };
        // Not stated: the configuration decides.
        assert!(off(0.5, Output::Unstated).0 < 0.03);
        let (lagging, expected) = off(0.0, Output::Unstated);
        assert!((lagging / expected - 1.0).abs() < 0.1);
        // Stated: the sheet decides, whatever the configuration says.
        let (instant, _) = off(0.5, Output::Instant);
        assert!(
            (instant / expected - 1.0).abs() < 0.1,
            "instant: {instant}° off, expected {expected}°"
        );
        assert!(off(0.0, Output::Mean).0 < 0.03);
        assert!(off(0.0, Output::Increments).0 < 0.03);
        // The magnetometer's lag and the coning term follow the same sheet.
        let c = AhrsConfig::default();
        let mut ahrs = Ahrs::new(&c);
        for (output, lags, coning) in [
            (
                Output::Unstated,
                (c.acc.lag_intervals, c.mag.lag_intervals),
                c.gyro.coning,
            ),
            (Output::Mean, (0.5, 0.5), true),
            (Output::Increments, (0.5, 0.5), false),
            (Output::Instant, (0.0, 0.0), true),
        ] {
            ahrs.set_sheet(&SensorSheet {
                output,
                ..SensorSheet::default()
            });
            assert_eq!(ahrs.lag_intervals(&c), lags, "{output:?}");
            assert_eq!(ahrs.gyro_config(&c).coning, coning, "{output:?}");
        }
        // A vehicle's sheet over the service's: stated wins, unstated falls back.
        let service = SensorSheet {
            output: Output::Increments,
            ..SensorSheet::default()
        };
        assert_eq!(
            SensorSheet::default().or(&service).output,
            Output::Increments
        );
        let vehicle = SensorSheet {
            output: Output::Instant,
            ..SensorSheet::default()
        };
        assert_eq!(vehicle.or(&service).output, Output::Instant);
        for o in [Output::Mean, Output::Increments, Output::Instant] {
            assert_eq!(Output::from_name(o.name()), Some(o));
        }
        assert_eq!(Output::from_name("unstated"), None);
        assert_eq!(Output::from_name("Mean"), None);
    }

    /// The alignment's heading comes from the field across the accelerometer's vertical, so a
    /// vertical tipped about north turns it by −tan(dip) times the tip. The initial covariance must
    /// say so: checked against the alignment itself by finite differences, for dips of both signs.
    /// (Before, the heading's variance ignored it: at a dip of 66° a 2° tilt σ leaves the heading
    /// uncertain by 4.5°, which the filter believed to be 2°.)
    #[test]
    fn the_initial_covariance_carries_the_tilt_into_the_heading() {
        let a_true = Rotation3::from_euler_angles(0.3, -0.2, 1.1).into_inner();
        let g = Vector3::new(0.0, 0.0, STANDARD_G);
        let c = AhrsConfig::default();
        for dip_deg in [66.0_f64, -40.0, 5.0] {
            let dip = dip_deg.to_radians();
            let base = aligned(&a_true, &g, dip);
            let a0 = base.q.attitude_matrix();
            // The accelerometer's vertical tipped about north (a horizontal acceleration east).
            let tip = 1e-4;
            let tipped = Rotation3::from_axis_angle(&Vector3::y_axis(), tip) * g;
            let a1 = aligned(&a_true, &tipped, dip).q.attitude_matrix();
            // The aligned reference frame's turn, in reference coordinates.
            let r = a0.transpose() * a1;
            let phi = Vector3::new(
                r[(2, 1)] - r[(1, 2)],
                r[(0, 2)] - r[(2, 0)],
                r[(1, 0)] - r[(0, 1)],
            ) * 0.5;
            let kappa = phi.z / phi.y;
            assert!(
                (kappa + dip.tan()).abs() < 1e-3 * (1.0 + dip.tan().abs()),
                "dip {dip_deg}°: the heading turns by {kappa} × the tip, expected −tan(dip) = {}",
                -dip.tan()
            );
            assert!(phi.x.abs() < 1e-3 * tip, "no turn about east: {phi:?}");
            // The covariance in the reference frame: the same coupling, and the heading's own σ beside it.
            let p: Matrix3<f64> = base
                .covariance
                .unwrap()
                .fixed_view::<3, 3>(0, 0)
                .into_owned();
            let pe = a0.transpose() * p * a0;
            let tilt2 = c.init.tilt_sigma_rad.powi(2);
            assert!((pe[(1, 1)] / tilt2 - 1.0).abs() < 1e-9, "{pe}");
            assert!((pe[(1, 2)] / (kappa * tilt2) - 1.0).abs() < 1e-3, "{pe}");
            let heading2 = pe[(2, 2)] - kappa * kappa * tilt2;
            assert!(
                (heading2 / c.init.heading_sigma_rad.powi(2) - 1.0).abs() < 1e-2,
                "{pe}"
            );
            assert!(pe[(0, 1)].abs() < 1e-12 && pe[(0, 2)].abs() < 1e-12, "{pe}");
        }
    }
}
