//! The accelerometer as an observation of the vertical, with its motion error treated as what it is:
//! slow and correlated.
//!
//! The specific force is low-passed (`τ_a`, second-order Butterworth) in a frame that turns with the
//! gyro only (the gyro frame of `crate::ahrs::Ahrs`; Laidig & Seel's VQF does the same), so gravity stays
//! while the accelerations of a vehicle that moves back and forth average out, and no correction of the
//! filter ever feeds back into the measurement. What does not average out is the motion the low-pass
//! lets through. The channel measures it from the data itself: a second low-pass with twice the time
//! constant lets through less of the same motion, so the difference of the two, `d`, follows the first
//! one's motion error (on BROAD's fourteen trials, with the optical attitude in place of the gyro
//! frame, the RMS of `d` was 0.5–0.75 of the RMS error of the low-passed direction, on every kind of
//! motion). The direction gets the 1σ
//!
//! `σ_lp = √(σ₀² + (κ d_rms / g)²)` (`σ_rest` in place of `σ₀` at rest), `d_rms` the RMS of the
//! horizontal part of `d` over `τ_a`,
//!
//! an error correlated over about `T_c` (`correlation_s`). It is used every `interval_s` (`T_u`) with
//! `σ = σ_lp √(T_c / T_u)`, so the filter counts the information of one independent observation per
//! `T_c`, not of every sample: this is what keeps the published tilt covariance honest.

use super::{norm_deviation, passes_norm_gate, AccConfig, UP};
use crate::sensors::lowpass::{first_order_by, gain, Lowpass3};
use crate::sensors::{Aspect, VectorObservation};
use nalgebra::{Matrix3, Vector3};

/// What the channel makes of the moment.
#[derive(Clone, Debug, PartialEq)]
pub enum TiltObservation {
    /// Not due yet.
    NotDue,
    /// Due, but the low-passed norm is too far from gravity's (counted as gated).
    NormGated,
    Use(VectorObservation),
}

#[derive(Clone, Debug, PartialEq)]
pub struct GravityChannel {
    /// The specific force in the gyro frame, low-passed with `τ_a` and with `2 τ_a`.
    pub lp: Lowpass3,
    pub lp2: Lowpass3,
    /// The low-passed square of the horizontal part of their difference, (m/s²)².
    pub motion_ms: f64,
    /// Variance of the gyro frame's own error within the low-pass, rad² (rotation the gyro could not
    /// measure, a saturated run's: the low-passed vector mixes readings from before it, turned
    /// wrongly against those after it, until the low-pass has forgotten them).
    pub frame_var: f64,
    /// Gravity's norm, learned at rest, m/s².
    pub g0: f64,
    pub since_update_s: f64,
    /// The last 1σ of the low-passed direction, rad (diagnostics).
    pub sigma_lp_rad: f64,
}

impl GravityChannel {
    pub fn new(c: &AccConfig, g0: f64) -> Self {
        GravityChannel {
            lp: Lowpass3::new(c.lowpass_s),
            lp2: Lowpass3::new(2.0 * c.lowpass_s),
            motion_ms: 0.0,
            frame_var: 0.0,
            g0,
            since_update_s: f64::INFINITY,
            sigma_lp_rad: c.sigma_rad,
        }
    }

    /// Takes one accelerometer sample (body frame, m/s²); `a_gyro` is the attitude matrix of the gyro
    /// frame (gyro frame → body), `dt_s` the interval since the previous sample.
    pub fn update(
        &mut self,
        c: &AccConfig,
        acc: &Vector3<f64>,
        a_gyro: &Matrix3<f64>,
        dt_s: f64,
        at_rest: bool,
    ) {
        self.update_by(acc, a_gyro, dt_s, at_rest, gain(dt_s, c.lowpass_s));
    }

    /// [`GravityChannel::update`] with the gain `1 − e^{−Δt/τ_a}` of its levels given
    /// (`crate::ahrs::gains`). Returns what [`GravityChannel::up_gyro`] returns now.
    #[inline]
    pub fn update_by(
        &mut self,
        acc: &Vector3<f64>,
        a_gyro: &Matrix3<f64>,
        dt_s: f64,
        at_rest: bool,
        k: Option<f64>,
    ) -> Option<Vector3<f64>> {
        let f = a_gyro.transpose() * acc;
        let (lp, lp2) = Lowpass3::update_pair(&mut self.lp, &f, &mut self.lp2, &f, dt_s);
        // (`try_normalize` with its threshold, once: 0 here, 1e-12 for `up_gyro`.)
        let n = lp.norm();
        if at_rest && n.is_finite() && n > 0.0 {
            self.g0 = first_order_by(self.g0, n, k);
        }
        let up = if n <= 0.0 { UP } else { lp / n };
        let d = lp - lp2;
        let horizontal = d - up * d.dot(&up);
        self.motion_ms = first_order_by(self.motion_ms, horizontal.norm_squared(), k);
        if !self.motion_ms.is_finite() {
            self.motion_ms = 0.0;
        }
        // The readings from before a frame error weigh less as e^{−t/τ}: its variance as e^{−2t/τ}.
        if self.frame_var > 0.0 {
            let keep = 1.0 - k.unwrap_or(1.0);
            self.frame_var *= keep * keep;
        }
        self.since_update_s += dt_s.max(0.0);
        if n <= 1e-12 {
            None
        } else {
            Some(up)
        }
    }

    /// The low-passed direction of up in the body frame (unit), if there is one.
    pub fn up_body(&self, a_gyro: &Matrix3<f64>) -> Option<Vector3<f64>> {
        let lp = self.lp.value()?;
        (a_gyro * lp).try_normalize(1e-12)
    }

    /// The low-passed direction of up in the gyro frame (unit).
    pub fn up_gyro(&self) -> Option<Vector3<f64>> {
        self.lp.value()?.try_normalize(1e-12)
    }

    /// Gravity's norm as learned, m/s².
    pub fn g0(&self) -> f64 {
        self.g0
    }

    /// The RMS of the horizontal difference of the two low-passes, m/s².
    pub fn motion_rms(&self) -> f64 {
        self.motion_ms.max(0.0).sqrt()
    }

    /// The 1σ of the low-passed direction now (`σ_lp`), rad.
    pub fn sigma_lp(&self, c: &AccConfig, at_rest: bool) -> f64 {
        // (The motion term counts at rest too: a slow sway without rotation passes the rest test.)
        let base = if at_rest {
            c.rest_sigma_rad
        } else {
            c.sigma_rad
        };
        let motion = c.motion_gain * self.motion_rms() / self.g0.max(1e-9);
        (base * base + motion * motion + self.frame_var).sqrt()
    }

    /// The tilt observation when one is due (every `interval_s`). `bias_across(up_body)`: the gyro
    /// bias's variance per axis across the vertical, rad²/s², asked only when a reading is due.
    ///
    /// The low-pass lives in the gyro frame, which the bias estimate turns: a bias off by `δb` turns
    /// it by `δb` a second, and the readings the low-pass holds are on average its time constant old,
    /// so its vertical is off by about `δb⊥ τ`. That variance joins the frame's error for this reading
    /// only (it is the filter's now, not a history the low-pass carries). It matters when the bias is
    /// unsure: a start in motion, with no rest to learn it (the attached-magnet excerpt, the bias
    /// 0.5°/s off for tens of seconds, had the tilt inside its 99% ellipse 88% of the time).
    pub fn observation(
        &mut self,
        c: &AccConfig,
        a_gyro: &Matrix3<f64>,
        at_rest: bool,
        bias_across: impl FnOnce(&Vector3<f64>) -> f64,
    ) -> TiltObservation {
        if self.since_update_s + 1e-9 < c.interval_s {
            return TiltObservation::NotDue;
        }
        self.since_update_s = 0.0;
        let Some(lp) = self.lp.value() else {
            return TiltObservation::NotDue;
        };
        let Some(body) = (a_gyro * lp).try_normalize(1e-12) else {
            return TiltObservation::NotDue;
        };
        if !passes_norm_gate(norm_deviation(lp.norm(), self.g0), c.norm_gate) {
            return TiltObservation::NormGated;
        }
        let bias_var = bias_across(&body).max(0.0) * self.lp.tau_s * self.lp.tau_s;
        let frame_var = self.frame_var + bias_var;
        let sigma = (self.sigma_lp(c, at_rest).powi(2) + bias_var).sqrt();
        self.sigma_lp_rad = sigma;
        // Each update's information is spread over the time its error stays the same: the sensor's
        // and the motion's over correlation_s; the gyro frame's own error (a gap's bridge, a
        // saturated run) over the low-pass's memory, the whole time the low-passed vector holds it
        // (spread over correlation_s instead, a 36° error after a gap in a shake was taken as
        // independent evidence ten times a second, and the covariance shrank to a third of it).
        let interval = c.interval_s.max(1e-9);
        let own = (sigma * sigma - frame_var).max(0.0);
        let sigma = (own * (c.correlation_s / interval).max(1.0)
            + frame_var * (self.lp.tau_s / interval).max(1.0))
        .sqrt();
        TiltObservation::Use(VectorObservation {
            body,
            reference: UP,
            sigma,
            // (No name: nothing reads it, and one would be an allocation per update.)
            sensor: None,
            aspect: Aspect::Tilt(UP),
        })
    }

    pub fn last_sigma_lp(&self) -> f64 {
        self.sigma_lp_rad
    }
}
