//! The magnetometer as an observation of the heading, with what disturbs it indoors and on a vehicle.
//!
//! * **Reference from the data.** The field is known by its norm `B₀` and dip `δ₀` (angle below the
//!   horizon), taken at the alignment and adapted slowly (`reference_s`) while undisturbed. Its
//!   horizontal direction defines north: the reference frame is East-North-Up with magnetic north.
//! * **Disturbance** ([`FieldChannel::update`]): the norm and dip of the reading (dip against the
//!   accelerometer's low-passed vertical, so that no heading estimate enters), low-passed over
//!   `lowpass_s`, are compared with the reference: beyond `norm_limit` (relative) or `dip_limit_rad`
//!   the field is disturbed, and it counts as undisturbed again only after `min_undisturbed_s` in
//!   bounds. While disturbed it is not used for up to `max_rejection_s` (a budget that refills at
//!   `rejection_factor` times the rate while undisturbed); after that it is used with its σ multiplied
//!   by `rejection_factor` (a field that stays different for good must not let the heading drift
//!   forever).
//! * **A new field** (moved to another place, or a calibration that changed): readings whose norm and
//!   dip stay consistent with each other for `new_field_s` of rotation (time counted only while the
//!   vehicle turns faster than `new_field_min_rate_rad_s`, so that a disturbance seen from one
//!   attitude cannot pass) become the new reference.
//! * **A magnet that moves with the body** (hard iron): the reading is `m = A C + o` with `C` the
//!   field and `o` a body-frame offset. A recursive least-squares fit of `(C, o)` over the last
//!   `hard_iron.window_s`, with `A` the gyro frame's attitude (the gyro's rotation alone), tells a
//!   body-fixed offset from a disturbance of the place; when the field is disturbed and the fit
//!   explains the readings (small residuals, offset well determined by enough rotation, `C` with the
//!   reference's norm and dip) for `hard_iron.confirm_s`, the offset is accepted and subtracted from
//!   every reading, its uncertainty added to the heading's.
//! * **Heading only, honest σ.** An accepted reading corrects the rotation about the vertical only
//!   ([`crate::sensors::Aspect::Heading`]), every `interval_s`, with the 1σ of a heading error that is
//!   slow and correlated over `correlation_s` (`σ √(T_c / T_u)`), as field inhomogeneity is.

use super::hard_iron::HardIronFit;
use super::{dip_rad, FieldDeviation, MagConfig};
use crate::sensors::gravity::UP;
use crate::sensors::lowpass::{first_order_by, gain};
use crate::sensors::{Aspect, VectorObservation};
use nalgebra::{Matrix3, Vector3};

/// The field channel's gains over one interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldGains {
    /// `1 − e^{−Δt/τ}` for the low-passed norm and dip (`mag.lowpass_s`), the reference
    /// (`mag.reference_s`) and the hard-iron fit's recent residual (`hard_iron.recent_s`).
    pub lowpass: Option<f64>,
    pub reference: Option<f64>,
    pub fit_recent: Option<f64>,
    /// The hard-iron fit's forgetting over the interval, `e^{−Δt/T_w}` (`hard_iron.window_s`).
    pub fit_forget: f64,
}

impl FieldGains {
    /// The gains over `dt_s`.
    pub fn new(c: &MagConfig, dt_s: f64) -> Self {
        let dt = dt_s.max(0.0);
        FieldGains {
            lowpass: gain(dt, c.lowpass_s),
            reference: gain(dt, c.reference_s),
            fit_recent: gain(dt, c.hard_iron.recent_s),
            fit_forget: (-dt / c.hard_iron.window_s.max(1e-9)).exp(),
        }
    }
}

/// The unit direction north cos δ − up sin δ for the dip `δ`, north the horizontal part of `north`
/// (the y axis when it has none).
fn direction(north: &Vector3<f64>, dip: f64) -> Vector3<f64> {
    let h = (north - UP * north.dot(&UP))
        .try_normalize(1e-12)
        .unwrap_or(Vector3::y());
    h * dip.cos() - UP * dip.sin()
}

/// The angle (rad, in [0, π]) between the horizontal parts (perpendicular to `up`) of two readings.
fn heading_change(a: &Vector3<f64>, b: &Vector3<f64>, up: &Vector3<f64>) -> f64 {
    let ha = a - up * a.dot(up);
    let hb = b - up * b.dot(up);
    let (na, nb) = (ha.norm(), hb.norm());
    if !(na > 0.0 && nb > 0.0) {
        return std::f64::consts::PI;
    }
    (ha.cross(&hb).dot(up)).atan2(ha.dot(&hb)).abs()
}

/// What the channel makes of the moment.
#[derive(Clone, Debug, PartialEq)]
pub enum HeadingObservation {
    NotDue,
    /// Due, but the field is disturbed and within its rejection budget.
    Rejected,
    /// The observation, and the heading 1σ of the reading itself (before the correlation's spread).
    Use(VectorObservation, f64),
}

#[derive(Clone, Debug, PartialEq)]
pub struct FieldChannel {
    /// The reference field in the reference frame: a unit direction whose horizontal part is north (the
    /// direction as last set: at the start or by a new field; [`FieldChannel::direction_now`] is the
    /// direction at the current dip), norm (reading units), dip (rad).
    pub direction: Vector3<f64>,
    pub norm: f64,
    pub dip: f64,
    /// The accepted body-frame offset (hard iron) and its 1σ, reading units.
    pub offset: Vector3<f64>,
    pub offset_sigma: f64,
    /// Low-passed norm and dip of the corrected reading.
    pub lp_norm: f64,
    pub lp_dip: f64,
    pub lp_ready: bool,
    pub disturbed: bool,
    pub undisturbed_s: f64,
    /// Rejection time used from the budget, s.
    pub rejected_s: f64,
    pub candidate_norm: f64,
    pub candidate_dip: f64,
    pub candidate_s: f64,
    pub fit: HardIronFit,
    pub fit_ok_s: f64,
    pub since_update_s: f64,
    pub since_solve_s: f64,
    /// Counts: accepted new fields and hard-iron offsets.
    pub new_fields: u64,
    pub hard_iron_changes: u64,
    /// Whether the reference has been confirmed by rotation: a hard-iron fit over enough rotation
    /// found the field it describes, with the offset in use. Until then the reference is the reading
    /// of one place and attitude, which a magnet on the body or a disturbance at the start may have
    /// made; a well-determined fit may then replace it (`FieldChannel::judge_fit`).
    pub confirmed: bool,
}

impl FieldChannel {
    /// The channel for a reference field of `norm` with dip `dip_rad`, its horizontal part along
    /// `north` (a unit horizontal vector of the reference frame).
    pub fn new(norm: f64, dip_rad: f64, north: &Vector3<f64>) -> Self {
        let mut f = FieldChannel {
            direction: Vector3::zeros(),
            norm,
            dip: dip_rad,
            offset: Vector3::zeros(),
            offset_sigma: 0.0,
            lp_norm: norm,
            lp_dip: dip_rad,
            lp_ready: false,
            disturbed: false,
            undisturbed_s: 0.0,
            rejected_s: 0.0,
            candidate_norm: norm,
            candidate_dip: dip_rad,
            candidate_s: 0.0,
            fit: HardIronFit::default(),
            fit_ok_s: 0.0,
            since_update_s: f64::INFINITY,
            since_solve_s: 0.0,
            new_fields: 0,
            hard_iron_changes: 0,
            confirmed: false,
        };
        f.set_reference(norm, dip_rad, north);
        f
    }

    fn set_reference(&mut self, norm: f64, dip: f64, north: &Vector3<f64>) {
        self.norm = norm;
        self.dip = dip;
        self.direction = direction(north, dip);
    }

    /// Keeps `hard_iron.restart_weight` of what the hard-iron fit has seen (the gyro frame it was
    /// kept in has just turned wrongly: a saturated gyro).
    pub fn forget_fit(&mut self, c: &MagConfig) {
        self.fit.forget(c.hard_iron.restart_weight);
        self.fit_ok_s = 0.0;
    }

    /// The reference direction now: north (the horizontal part of `direction`, which only a new field
    /// turns) at the current dip. The reference adapts its dip at every undisturbed sample; its
    /// direction is formed here, when an observation or a caller uses it (a `sin_cos` per use, not per
    /// sample).
    pub fn direction_now(&self) -> Vector3<f64> {
        direction(&self.direction, self.dip)
    }

    /// The reference direction (unit, reference frame), norm and dip.
    pub fn reference(&self) -> (Vector3<f64>, f64, f64) {
        (self.direction_now(), self.norm, self.dip)
    }

    /// The reference's norm and dip.
    pub fn norm_dip(&self) -> (f64, f64) {
        (self.norm, self.dip)
    }

    pub fn disturbed(&self) -> bool {
        self.disturbed
    }

    pub fn offset(&self) -> Vector3<f64> {
        self.offset
    }

    fn within(&self, c: &MagConfig, norm: f64, dip: f64, ref_norm: f64, ref_dip: f64) -> bool {
        self.within_by(c, norm, dip, ref_norm, ref_dip, 0.0)
    }

    /// [`FieldChannel::within`] with the dip limit widened by what the vertical it is measured
    /// against may be off by (`up_sigma_rad`, 1σ: 2.5σ of it).
    fn within_by(
        &self,
        c: &MagConfig,
        norm: f64,
        dip: f64,
        ref_norm: f64,
        ref_dip: f64,
        up_sigma_rad: f64,
    ) -> bool {
        FieldDeviation::between(norm, dip, ref_norm, ref_dip)
            .within(c.norm_limit, c.dip_limit_rad + 2.5 * up_sigma_rad)
    }

    /// Takes one reading (body frame); `up_body` is the accelerometer's low-passed vertical in the body
    /// frame, `up_gyro` the same in the gyro frame, `a_gyro` the gyro frame's attitude matrix,
    /// `rate_rad_s` the low-passed turn rate, `up_sigma_rad` what the low-passed vertical may be off
    /// by beyond its usual error (the gyro frame's own error after a saturated gyro).
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        c: &MagConfig,
        mag: &Vector3<f64>,
        up_body: &Vector3<f64>,
        up_gyro: &Vector3<f64>,
        a_gyro: &Matrix3<f64>,
        rate_rad_s: f64,
        up_sigma_rad: f64,
        dt_s: f64,
    ) -> Option<f64> {
        let g = FieldGains::new(c, dt_s);
        self.update_by(
            c,
            mag,
            up_body,
            up_gyro,
            (mag, a_gyro),
            rate_rad_s,
            up_sigma_rad,
            dt_s,
            &g,
        )
    }

    /// [`FieldChannel::update`] with the gains of the interval given (`crate::ahrs::gains`), and the
    /// reading the hard-iron fit takes with the gyro frame's attitude matrix when it was taken (a
    /// repeated reading of a slower magnetometer gives the fit the reading when it was new, not the
    /// reading turned to now: the turn would carry the offset, which does not turn). Returns the
    /// heading change (rad) that a newly accepted offset makes to this reading, when one was accepted:
    /// the estimate's heading may be wrong by that much.
    #[allow(clippy::too_many_arguments)]
    pub fn update_by(
        &mut self,
        c: &MagConfig,
        mag: &Vector3<f64>,
        up_body: &Vector3<f64>,
        up_gyro: &Vector3<f64>,
        (fit_mag, a_gyro): (&Vector3<f64>, &Matrix3<f64>),
        rate_rad_s: f64,
        up_sigma_rad: f64,
        dt_s: f64,
        g: &FieldGains,
    ) -> Option<f64> {
        let dt = dt_s.max(0.0);
        self.since_update_s += dt;
        self.since_solve_s += dt;
        if c.hard_iron.enabled {
            self.fit.add(fit_mag, a_gyro, g.fit_forget, g.fit_recent);
        }
        let m = mag - self.offset;
        let n = m.norm();
        if !(n > 0.0 && n.is_finite()) {
            return None;
        }
        let dip = dip_rad(&(m / n), up_body);
        // (Norm and dip filtered alike: one gain each for the low-pass and the reference.)
        let (k_lp, k_ref) = (g.lowpass, g.reference);
        if self.lp_ready {
            self.lp_norm = first_order_by(self.lp_norm, n, k_lp);
            self.lp_dip = first_order_by(self.lp_dip, dip, k_lp);
        } else {
            (self.lp_norm, self.lp_dip, self.lp_ready) = (n, dip, true);
        }
        let (ln, ld) = (self.lp_norm, self.lp_dip);
        if self.within_by(c, ln, ld, self.norm, self.dip, up_sigma_rad) {
            self.undisturbed_s += dt;
            if self.undisturbed_s >= c.min_undisturbed_s {
                self.disturbed = false;
                // (The direction follows the dip where it is used: `direction_now`.)
                self.norm = first_order_by(self.norm, ln, k_ref);
                self.dip = first_order_by(self.dip, ld, k_ref);
            }
        } else {
            if !self.disturbed && c.hard_iron.enabled {
                self.fit.forget(c.hard_iron.restart_weight);
                self.fit_ok_s = 0.0;
            }
            self.undisturbed_s = 0.0;
            self.disturbed = true;
        }
        // A new field: consistent readings over enough rotation.
        if self.within_by(
            c,
            ln,
            ld,
            self.candidate_norm,
            self.candidate_dip,
            up_sigma_rad,
        ) {
            if rate_rad_s >= c.new_field_min_rate_rad_s {
                self.candidate_s += dt;
            }
            self.candidate_norm = first_order_by(self.candidate_norm, ln, k_ref);
            self.candidate_dip = first_order_by(self.candidate_dip, ld, k_ref);
            if self.disturbed && self.candidate_s >= c.new_field_s {
                let h = self.direction - UP * self.direction.dot(&UP);
                self.set_reference(self.candidate_norm, self.candidate_dip, &h);
                self.disturbed = false;
                self.undisturbed_s = c.min_undisturbed_s;
                self.new_fields += 1;
            }
        } else {
            self.candidate_s = 0.0;
            self.candidate_norm = ln;
            self.candidate_dip = ld;
        }
        let mut jump = None;
        if c.hard_iron.enabled && self.since_solve_s >= c.hard_iron.solve_interval_s {
            let interval = self.since_solve_s;
            self.since_solve_s = 0.0;
            if let Some(old) = self.judge_fit(c, up_gyro, interval) {
                jump = Some(heading_change(&(mag - old), &(mag - self.offset), up_body));
            }
        }
        // The rejection budget.
        if self.disturbed {
            self.rejected_s += dt;
        } else {
            self.rejected_s = (self.rejected_s - c.rejection_factor * dt).max(0.0);
        }
        jump
    }

    /// Accepts the hard-iron fit once it has explained the readings for `confirm_s` with an offset
    /// that differs from the accepted one; returns the offset it replaced when it accepts one.
    /// (Whether the field looks disturbed does not matter: a small offset passes the norm and dip
    /// checks at many attitudes and still turns the heading.)
    ///
    /// A fit explains the readings when the window turned enough about every axis (`min_excitation`),
    /// the offset is well determined and the residuals are small, and its field has the reference's
    /// norm and dip. A reference not yet confirmed by rotation (the reading of one place and attitude)
    /// does not bind the fit: a fit that explains the readings over enough rotation with another field
    /// replaces it (a magnet on the body, or a disturbed place, at the start), and one that finds the
    /// reference and the offset in use confirms it.
    fn judge_fit(
        &mut self,
        c: &MagConfig,
        up_gyro: &Vector3<f64>,
        interval_s: f64,
    ) -> Option<Vector3<f64>> {
        let h = &c.hard_iron;
        let Some(s) = self.fit.solve() else {
            self.fit_ok_s = 0.0;
            return None;
        };
        let field_norm = s.field_gyro.norm();
        let field_dip = if field_norm > 0.0 {
            dip_rad(&(s.field_gyro / field_norm), up_gyro)
        } else {
            f64::NAN
        };
        // (An unconfirmed reference's norm may hold an offset: the fit's own field sets the scale.)
        let scale = if self.confirmed {
            self.norm
        } else {
            field_norm
        }
        .max(1e-12);
        let determined = self.fit.excitation() >= h.min_excitation
            && s.offset_sigma <= h.max_offset_sigma * scale
            && s.residual_rms <= h.max_residual * scale
            && self.fit.recent_rms() <= h.max_residual * scale;
        let within_reference = self.within(c, field_norm, field_dip, self.norm, self.dip);
        let explains = determined && (within_reference || !self.confirmed);
        let change = (s.offset - self.offset).norm();
        if determined && within_reference && change < h.min_change * scale {
            self.confirmed = true;
        }
        if explains && self.hard_iron_changes > 0 && change < h.min_change * scale {
            // A magnet that was accepted keeps being calibrated as more rotation is seen: the fit
            // close to the accepted offset refines it over `confirm_s`.
            let k = (interval_s / h.confirm_s.max(interval_s)).min(1.0);
            self.offset += (s.offset - self.offset) * k;
            self.offset_sigma += (s.offset_sigma - self.offset_sigma) * k;
        }
        let improvement = if within_reference {
            h.min_improvement
        } else {
            h.replace_improvement
        };
        let good = explains
            && change >= (h.min_change * scale).max(3.0 * s.offset_sigma)
            // The new offset must explain the window clearly better than the accepted one (field
            // inhomogeneity along a path also fits a small offset, but hardly better than none).
            && self.fit.residual_with_offset(&self.offset) >= improvement * s.residual_rms;
        if !good {
            // (A moment's doubt, e.g. one fast turn, does not undo the evidence gathered: it takes
            // twice as long off as on.)
            self.fit_ok_s = (self.fit_ok_s - 2.0 * interval_s).max(0.0);
            return None;
        }
        self.fit_ok_s += interval_s;
        if self.fit_ok_s < h.confirm_s {
            return None;
        }
        let old = self.offset;
        self.offset = s.offset;
        self.offset_sigma = s.offset_sigma;
        self.fit_ok_s = 0.0;
        self.hard_iron_changes += 1;
        if !within_reference {
            // The reference was the reading of one place: the fit's field replaces its norm and dip
            // (north stays the reference frame's).
            let north = self.direction - UP * self.direction.dot(&UP);
            self.set_reference(field_norm, field_dip, &north);
            self.candidate_norm = field_norm;
            self.candidate_dip = field_dip;
        }
        self.confirmed = true;
        // The corrected readings are judged afresh.
        self.lp_ready = false;
        self.disturbed = false;
        self.undisturbed_s = c.min_undisturbed_s;
        self.candidate_s = 0.0;
        Some(old)
    }

    /// The variance (rad²) of the reference's north about the vertical that the readings cannot yet
    /// reveal: until rotation confirms the reference, the reading it was taken from may hold a
    /// body-fixed offset, 1σ per axis `stated` (what the user says a calibration left, in the
    /// readings' unit) or, not stated, `hard_iron.unconfirmed_offset` × the norm, whose part across
    /// the horizontal field turns north by about that over the field's horizontal part (capped at a
    /// heading uniform on the circle, `π/√3`). 0 once confirmed: the accepted offset's own
    /// uncertainty is in every observation's σ.
    pub fn north_variance(&self, c: &MagConfig, stated: Option<f64>) -> f64 {
        if self.confirmed {
            return 0.0;
        }
        let horizontal = self.dip.cos().abs().max(1e-3);
        let relative = match stated {
            Some(s) => s / self.norm.max(1e-12),
            None => c.hard_iron.unconfirmed_offset,
        };
        let sigma = (relative / horizontal).min(std::f64::consts::PI / 3f64.sqrt());
        sigma * sigma
    }

    /// The heading observation when one is due (every `interval_s`), from the reading `mag` taken at
    /// the turn rate `rate_rad_s`.
    pub fn observation(
        &mut self,
        c: &MagConfig,
        mag: &Vector3<f64>,
        rate_rad_s: f64,
        up_sigma_rad: f64,
        noise_norm: f64,
    ) -> HeadingObservation {
        if self.since_update_s + 1e-9 < c.interval_s {
            return HeadingObservation::NotDue;
        }
        self.since_update_s = 0.0;
        let mut weight = 1.0;
        if self.disturbed {
            if self.rejected_s <= c.max_rejection_s {
                return HeadingObservation::Rejected;
            }
            weight = c.rejection_factor;
        }
        let Some(body) = (mag - self.offset).try_normalize(1e-12) else {
            return HeadingObservation::NotDue;
        };
        let horizontal = self.dip.cos().abs().max(1e-3);
        // The heading 1σ: the field's own, and what the offset's uncertainty turns into.
        let offset_heading = self.offset_sigma / (self.norm * horizontal).max(1e-12);
        let timing = c.delay_sigma_s * rate_rad_s;
        // A field that deviates from the reference by a relative norm δn and a dip δd is disturbed by
        // a field of about δn·B along it and δd·B across it; a disturbance of no preferred direction
        // turns the horizontal part by as much again: about √(δn² + δd²)·B / B_h of heading.
        let deviation = if self.lp_ready {
            // (Beyond what the low-passed readings' own noise makes of the norm: `noise_norm`, 1σ.)
            let dn = (((self.lp_norm - self.norm).abs() - 2.5 * noise_norm).max(0.0))
                / self.norm.max(1e-12);
            // (Less what the vertical the dip is measured against may be off by.)
            let dd = ((self.lp_dip - self.dip).abs() - 2.5 * up_sigma_rad).max(0.0);
            c.deviation_gain * (dn * dn + dd * dd).sqrt() / horizontal
        } else {
            0.0
        };
        let sigma_psi = (c.sigma_rad * c.sigma_rad
            + offset_heading * offset_heading
            + timing * timing
            + deviation * deviation)
            .sqrt()
            * weight;
        let spread = sigma_psi * (c.correlation_s / c.interval_s.max(1e-9)).max(1.0).sqrt();
        HeadingObservation::Use(
            VectorObservation {
                body,
                reference: self.direction_now(),
                // heading_sigma_rad(σ, ‖r_h‖) = σ/‖r_h‖ = σ_ψ.
                sigma: spread * horizontal,
                // (No name: nothing reads it, and one would be an allocation per update.)
                sensor: None,
                aspect: Aspect::Heading(UP),
            },
            sigma_psi,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Quaternion;

    use crate::sensors::field::tests::field;

    /// A body-fixed offset of 20 µT seen while the body turns through many attitudes: the fit finds it
    /// to a fraction of a µT and the channel accepts it after the confirmation time; before that the
    /// field is disturbed and rejected.
    #[test]
    fn hard_iron_offset_is_found_and_accepted() {
        let c = MagConfig::default();
        let mut ch = FieldChannel::new(45.0, 65f64.to_radians(), &Vector3::y());
        let offset = Vector3::new(3.0, -20.0, 8.0);
        let dt = 0.01;
        let mut q = Quaternion::IDENTITY;
        let mut accepted_at = None;
        let mut rejected = 0;
        for k in 0..6000 {
            let t = k as f64 * dt;
            let w = Vector3::new((0.7 * t).sin(), (0.5 * t).cos(), 0.8 * (0.3 * t).sin());
            q = q.propagate(&w, dt);
            let a = q.attitude_matrix();
            // The gyro frame is the reference frame here (a perfect gyro).
            let m = a * field(65.0) + offset;
            ch.update(&c, &m, &(a * UP), &UP, &a, w.norm(), 0.0, dt);
            if let HeadingObservation::Rejected = ch.observation(&c, &m, 0.0, 0.0, 0.0) {
                rejected += 1;
            }
            if accepted_at.is_none() && ch.hard_iron_changes > 0 {
                accepted_at = Some(t);
            }
        }
        let t = accepted_at.expect("offset accepted");
        assert!(t < 30.0, "accepted after {t} s");
        assert!(rejected > 0);
        assert!((ch.offset() - offset).norm() < 0.5, "{}", ch.offset());
        assert!(!ch.disturbed());
    }

    /// The undisturbed field is never disturbed and never changes its offset; a 30 % stronger field
    /// is disturbed at once and rejected.
    #[test]
    fn disturbance_by_norm() {
        let c = MagConfig::default();
        let mut ch = FieldChannel::new(45.0, 65f64.to_radians(), &Vector3::y());
        let a = Quaternion::from_euler_321(0.2, -0.1, 0.5).attitude_matrix();
        for _ in 0..500 {
            ch.update(&c, &(a * field(65.0)), &(a * UP), &UP, &a, 0.0, 0.0, 0.01);
            assert!(!ch.disturbed());
            assert!(matches!(
                ch.observation(&c, &(a * field(65.0)), 0.0, 0.0, 0.0),
                HeadingObservation::Use(..) | HeadingObservation::NotDue
            ));
        }
        assert_eq!(ch.offset(), Vector3::zeros());
        for _ in 0..100 {
            ch.update(
                &c,
                &(a * field(65.0) * 1.3),
                &(a * UP),
                &UP,
                &a,
                0.0,
                0.0,
                0.01,
            );
        }
        assert!(ch.disturbed());
        assert_eq!(
            ch.observation(&c, &(a * field(65.0) * 1.3), 0.0, 0.0, 0.0),
            HeadingObservation::Rejected
        );
    }

    /// A pendulum swings about one axis: an offset along that axis cannot be told from the field's
    /// own component along it. Here the readings are those of an offset of 6 µT along the swing axis,
    /// and just as well (to 0.2 µT: the slight wobble is all that tells them apart, and any field
    /// inhomogeneity is larger) those of a field with a 6 µT component along that axis and no
    /// offset. The channel must not decide: with the excitation requirement it accepts nothing; the
    /// same channel without it accepts the offset (as it did, wrongly, on the RepoIMU pendulum,
    /// whose heading then ran away).
    #[test]
    fn a_swing_about_one_axis_never_accepts_an_offset() {
        let run = |min_excitation: f64| {
            let mut c = MagConfig::default();
            c.hard_iron.min_excitation = min_excitation;
            let mut ch = FieldChannel::new(45.0, 65f64.to_radians(), &Vector3::y());
            let dt = 0.02;
            for k in 0..10_000 {
                let t = k as f64 * dt;
                let angle = 0.5 * (1.3 * t).sin();
                let wobble = 0.03 * (0.37 * t).sin();
                let q = Quaternion::from_rotation_vector(&(Vector3::x() * angle))
                    .compose(&Quaternion::from_rotation_vector(&(Vector3::y() * wobble)));
                let a = q.attitude_matrix();
                let m = a * field(65.0) + Vector3::new(6.0, 0.0, 0.0);
                ch.update(&c, &m, &(a * UP), &UP, &a, 0.0, 0.0, dt);
            }
            (ch.hard_iron_changes, ch.fit.excitation())
        };
        let (changes, excitation) = run(MagConfig::default().hard_iron.min_excitation);
        assert!(excitation < 0.01, "{excitation}");
        assert_eq!(changes, 0);
        assert!(run(0.0).0 > 0);
    }

    /// A magnet on the body from the start: the reference taken from the first reading holds its
    /// offset. Once the body has turned enough, the fit replaces that reference with the field it
    /// finds (its norm and dip), accepts the offset, confirms the reference, and reports how much the
    /// correction turns the heading of the reading. Until then north's variance allows for that turn
    /// (within its 99% interval); once confirmed it is 0.
    #[test]
    fn a_magnet_from_the_start_replaces_the_provisional_reference() {
        let c = MagConfig::default();
        let offset = Vector3::new(10.0, -25.0, 30.0);
        let first = field(65.0) + offset;
        let up = Vector3::new(0.0, 0.0, 1.0);
        let dip = dip_rad(&first.normalize(), &up);
        let mut ch = FieldChannel::new(first.norm(), dip, &Vector3::y());
        assert!(!ch.confirmed);
        let north_sigma = ch.north_variance(&c, None).sqrt();
        let dt = 0.01;
        let mut q = Quaternion::IDENTITY;
        let mut jump = None;
        for k in 0..6000 {
            let t = k as f64 * dt;
            let w = Vector3::new((0.7 * t).sin(), (0.5 * t).cos(), 0.8 * (0.3 * t).sin());
            q = q.propagate(&w, dt);
            let a = q.attitude_matrix();
            let m = a * field(65.0) + offset;
            if let Some(j) = ch.update(&c, &m, &(a * UP), &UP, &a, w.norm(), 0.0, dt) {
                jump.get_or_insert(j);
            }
        }
        assert_eq!(ch.hard_iron_changes, 1);
        assert!(ch.confirmed);
        assert!((ch.offset() - offset).norm() < 0.5, "{}", ch.offset());
        assert!((ch.norm - 45.0).abs() < 0.5, "{}", ch.norm);
        assert!((ch.dip - 65f64.to_radians()).abs() < 0.01, "{}", ch.dip);
        let j = jump.expect("the acceptance reports the heading change");
        assert!(j > 0.05, "{j}");
        assert!(j <= 2.576 * north_sigma, "{j} against 1σ {north_sigma}");
        assert_eq!(ch.north_variance(&c, None), 0.0);
    }

    /// North's variance before rotation confirms the field: the offset's 1σ (a fraction of the norm,
    /// or as the user states it in the readings' unit) over the horizontal part of the field, capped
    /// at a heading uniform on the circle; none for a magnetometer calibrated in place
    /// (`unconfirmed_offset` 0).
    #[test]
    fn north_variance_of_an_unconfirmed_field() {
        let mut c = MagConfig::default();
        c.hard_iron.unconfirmed_offset = 0.2;
        let ch = FieldChannel::new(45.0, 60f64.to_radians(), &Vector3::y());
        // 0.2 / cos 60° = 0.4 rad.
        assert!((ch.north_variance(&c, None) - 0.16).abs() < 1e-12);
        // 0.45 µT stated: 0.01 of the norm, 0.02 rad.
        assert!((ch.north_variance(&c, Some(0.45)) - 4e-4).abs() < 1e-12);
        let steep = FieldChannel::new(45.0, 85f64.to_radians(), &Vector3::y());
        let uniform = std::f64::consts::PI / 3f64.sqrt();
        assert!((steep.north_variance(&c, None) - uniform * uniform).abs() < 1e-12);
        c.hard_iron.unconfirmed_offset = 0.0;
        assert_eq!(ch.north_variance(&c, None), 0.0);
    }
}
