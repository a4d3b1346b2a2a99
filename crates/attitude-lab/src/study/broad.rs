//! Scores of an attitude estimate against an optical truth, as the BROAD benchmark defines them, and how
//! honest the estimate's covariance is about its error. The Python replay client
//! (`attitude-replay`, `clients/python/src/attitude_client/replay.py`) computes the same figures; `tests/python/test_broad_metric.py` holds the
//! two together.
//!
//! **Accuracy** (BROAD's `example_code/broad_utils.py`): with the Hamilton quaternions of body → reference
//! (East-North-Up with magnetic north) and `e = q_est q_true⁻¹` (`e_w ≥ 0`), the total error `2 acos e_w`,
//! the heading error `2 atan |e_z / e_w|` and the inclination error `2 acos √(e_w² + e_z²)`, each as an RMSE
//! in degrees over the `movement` samples (samples without truth left out). No heading alignment.
//!
//! **Honesty.** The estimate's covariance of the body-frame attitude error `P` is turned into the
//! reference frame (`R P Rᵀ`, `R` body → reference of the estimate); the error is the rotation vector
//! `θ` of `e` (a reference-frame error):
//! * tilt: `θ_h` (east, north) against its 2×2 block plus `(0.2°)² I` for the truth's own tilt error (its
//!   accelerometer-free optical tilt differs from gravity by 0.06–0.34° per trial); `NEES = θ_hᵀ P_h⁻¹ θ_h`.
//!   Reported: the fraction of movement samples with NEES within the 99% quantile of χ²₂ (9.21; an honest
//!   filter: 0.99) and the median NEES (an honest filter: 1.39, the median of χ²₂; far below means an
//!   inflated covariance, far above an overconfident one);
//! * heading: `θ_z` after removing the trial's constant heading offset (its mean over the movement
//!   samples: the angle between the optical frame's north and the magnetic north the estimate is
//!   aligned to, a property of the recording and not of the estimator; reported too), within 2.576 σ
//!   of the vertical variance (99%).
//!
//! Errors on real recordings are strongly autocorrelated: about one independent sample per 10 s.

use attitude_core::attitude::Quaternion;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

/// χ²₂ 99% quantile.
pub const CHI2_2_99: f64 = 9.210_340_371_976_182;
/// Two-sided 99% of a normal.
pub const Z_99: f64 = 2.575_829_303_548_901;
/// The truth's own tilt error, rad (see the module documentation).
pub const TRUTH_TILT_SIGMA_RAD: f64 = 0.2 * std::f64::consts::PI / 180.0;

/// One estimate: the attitude (this project's quaternion: its components are the Hamilton quaternion
/// of body → reference) and the covariance of the body-frame attitude error, rad².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub q: Quaternion,
    pub p_att: Matrix3<f64>,
}

/// How a recording's truth relates to the estimator's frames, and what the truth itself may be off by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthModel {
    pub align: Align,
    /// The truth's own tilt error (1σ per horizontal axis), rad: added to the tilt block of the
    /// covariance when honesty is scored.
    pub tilt_sigma_rad: f64,
    /// The truth's time-stamp uncertainty against the IMU's clock (1σ), s: the truth is then off by
    /// the rotation over it, `σ_t² ω ωᵀ` about the turn axis, added to the covariance when honesty is
    /// scored.
    pub time_sigma_s: f64,
    /// With [`Align::Both`], the fraction of samples left out of the alignment's fit, those with the
    /// largest error ([`trimmed_alignment`]); 0 (the default) fits on every movement sample.
    pub align_trim: f64,
}

impl Default for TruthModel {
    /// BROAD's: the truth in East-North-Up with magnetic north, the body the IMU's, 0.2° of tilt.
    fn default() -> Self {
        TruthModel {
            align: Align::None,
            tilt_sigma_rad: TRUTH_TILT_SIGMA_RAD,
            time_sigma_s: 0.0,
            align_trim: 0.0,
        }
    }
}

/// Which frames of the truth differ from the estimator's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Align {
    /// The truth is body → East-North-Up with magnetic north, of the IMU's body (BROAD): no
    /// alignment; honesty removes the recording's constant heading offset (optical against magnetic
    /// north).
    None,
    /// The truth has its own reference and body frames: each estimator is aligned on its own by the
    /// constant rotations `L` (reference) and `R` (body) with `q_truth ≈ L·q_est·R` (Hamilton) over
    /// the movement samples ([`alignment`]), and scored against the truth carried into its frames,
    /// `L⁻¹·q_truth·R⁻¹`. What is scored is drift and inconsistency, not the absolute heading.
    Both,
}

/// The constant rotations of [`Align::Both`]: `q_truth ≈ L·q_est·R` (Hamilton products of body →
/// reference quaternions; `L` turns the estimator's reference frame into the truth's, `R` the truth's
/// body frame into the estimator's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    pub reference: Quaternion,
    pub body: Quaternion,
}

/// The Hamilton product `a·b` of two quaternions in this project's type (whose Shuster product is the
/// Hamilton product reversed).
fn ham(a: &Quaternion, b: &Quaternion) -> Quaternion {
    b.compose(a)
}

impl Alignment {
    /// The truth carried into the estimator's frames: `L⁻¹·q_truth·R⁻¹`.
    pub fn truth_in_estimator_frames(&self, truth: &Quaternion) -> Quaternion {
        ham(&ham(&self.reference.inverse(), truth), &self.body.inverse())
    }
}

/// The alignment of an estimator's output to the truth over the movement samples. `R` starts from the
/// relative rotations alone (a hand–eye problem: `q_est,i⁻¹·q_est,j = R·(q_true,i⁻¹·q_true,j)·R⁻¹`, so
/// `R` turns the truth's rotation vectors into the estimate's; `body_start`), then alternately the
/// weighted quaternion average of `L = q_truth·R⁻¹·q_est⁻¹` with `R` held and of
/// `R = q_est⁻¹·L⁻¹·q_truth` with `L` held, until neither moves by more than 1e-9 rad (at most 50
/// rounds). (Alternating from `R = 1` alone can stop far off when the frames differ by a half turn,
/// as a pendulum's do.) `None` without a pair to align.
pub fn alignment(
    estimates: &[Option<Sample>],
    truth: &[Option<Quaternion>],
    movement: &[bool],
) -> Option<Alignment> {
    let pairs: Vec<(Quaternion, Quaternion)> = estimates
        .iter()
        .zip(truth)
        .zip(movement)
        .filter_map(|((e, t), m)| match (e, t, m) {
            (Some(e), Some(t), true) => Some((e.q, *t)),
            _ => None,
        })
        .collect();
    if pairs.is_empty() {
        return None;
    }
    let average_l = |r: &Quaternion, previous: Option<&Quaternion>| {
        let mut acc = attitude_core::attitude::AverageAccumulator::new();
        for (e, t) in &pairs {
            acc.add(&ham(&ham(t, &r.inverse()), &e.inverse()), 1.0);
        }
        acc.finish(previous).ok().map(|a| a.q)
    };
    let mut r = body_start(&pairs);
    let mut l = average_l(&r, None)?;
    for _ in 0..50 {
        let l_new = average_l(&r, Some(&l))?;
        let mut acc = attitude_core::attitude::AverageAccumulator::new();
        for (e, t) in &pairs {
            acc.add(&ham(&ham(&e.inverse(), &l_new.inverse()), t), 1.0);
        }
        let r_new = acc.finish(Some(&r)).ok()?.q;
        let moved = ham(&l_new, &l.inverse())
            .angle()
            .max(ham(&r_new, &r.inverse()).angle());
        (l, r) = (l_new, r_new);
        if moved < 1e-9 {
            break;
        }
    }
    Some(Alignment {
        reference: l,
        body: r,
    })
}

/// [`alignment`] fitted without the `trim` fraction of the movement samples whose error is largest:
/// fitted on all, the samples' errors ranked, fitted again on the rest, five times (or until the
/// samples kept stop changing). The squared-error fit lets a few large errors turn the frames: on a
/// pendulum whose gyro saturates (RepoIMU segment 3), swings with 20–50° of error tilted the fitted
/// frames by about 2°, and every calm sample then looked 2–3° off (docs/recordings.md). A constant
/// mounting and reference rotation is what the calm majority agrees on; the trimmed samples are
/// still scored. `trim` 0 is [`alignment`].
pub fn trimmed_alignment(
    estimates: &[Option<Sample>],
    truth: &[Option<Quaternion>],
    movement: &[bool],
    trim: f64,
) -> Option<Alignment> {
    let mut a = alignment(estimates, truth, movement)?;
    if !(trim > 0.0 && trim < 1.0) {
        return Some(a);
    }
    let mut kept: Vec<bool> = movement.to_vec();
    for _ in 0..5 {
        let errors: Vec<(usize, f64)> = (0..movement.len())
            .filter_map(|i| match (estimates.get(i)?, truth.get(i)?, movement[i]) {
                (Some(e), Some(t), true) => {
                    let tt = a.truth_in_estimator_frames(t);
                    Some((i, ham(&e.q, &tt.inverse()).angle()))
                }
                _ => None,
            })
            .collect();
        let mut sorted: Vec<f64> = errors.iter().map(|&(_, x)| x).collect();
        sorted.sort_by(f64::total_cmp);
        let keep = ((1.0 - trim) * sorted.len() as f64).ceil() as usize;
        let Some(&limit) = sorted.get(keep.saturating_sub(1)) else {
            return Some(a);
        };
        let mut next = vec![false; movement.len()];
        for &(i, x) in &errors {
            next[i] = x <= limit;
        }
        if next == kept {
            break;
        }
        kept = next;
        a = alignment(estimates, truth, &kept)?;
    }
    Some(a)
}

/// The start of [`alignment`]'s `R`: with the pairs of samples `(i, i + 16)`, the rotation that best
/// turns the rotation vectors of the truth's relative rotations into the estimate's (Wahba's problem,
/// solved by an SVD; the vectors weigh by their angle). The identity without rotation.
fn body_start(pairs: &[(Quaternion, Quaternion)]) -> Quaternion {
    const STEP: usize = 16;
    let mut b = Matrix3::zeros();
    for w in pairs.windows(STEP + 1) {
        let ((e0, t0), (e1, t1)) = (w[0], w[STEP]);
        let ve = ham(&e0.inverse(), &e1).to_rotation_vector();
        let vt = ham(&t0.inverse(), &t1).to_rotation_vector();
        b += ve * vt.transpose();
    }
    if b.amax() == 0.0 || !b.iter().all(|v| v.is_finite()) {
        return Quaternion::IDENTITY;
    }
    let svd = b.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Quaternion::IDENTITY;
    };
    let d = (u * v_t).determinant().signum();
    let m = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    // m is the Hamilton rotation matrix of R; this project's attitude matrix is its transpose.
    Quaternion::from_attitude_matrix(&m.transpose())
        .normalized()
        .unwrap_or(Quaternion::IDENTITY)
}

/// A trial's scores.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scores {
    pub total_rmse_deg: f64,
    pub heading_rmse_deg: f64,
    pub inclination_rmse_deg: f64,
    /// Fraction of movement samples whose tilt error lies within the 99% ellipse, and the median NEES.
    pub tilt_in99: f64,
    pub tilt_nees_median: f64,
    /// Fraction of movement samples whose heading error (offset removed) lies within 99%.
    pub heading_in99: f64,
    /// Fraction of movement samples whose 3-axis error (heading offset removed) lies within the 99%
    /// ellipsoid (χ²₃), and the median of that NEES (honest: 2.37).
    #[serde(default)]
    pub att_in99: f64,
    #[serde(default)]
    pub att_nees_median: f64,
    /// The removed constant heading offset (the heading errors' inverse-variance weighted mean), deg.
    pub heading_offset_deg: f64,
    /// With [`Align::Both`], the angles of the alignment's rotations `L` and `R`, deg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub align_reference_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub align_body_deg: Option<f64>,
    /// Movement samples scored (with truth and an estimate).
    pub scored: usize,
}

/// The Hamilton `[w, x, y, z]` of `e = q_est q_true⁻¹`, `w ≥ 0`. With this project's convention
/// (`q` holds the Hamilton components of body → reference), `q_est q_true⁻¹` in Hamilton's product is
/// `true⁻¹ ⊗ est` in Shuster's (`A(p ⊗ q) = A(p) A(q)`, the order reversed).
pub fn error_quaternion(estimate: &Quaternion, truth: &Quaternion) -> [f64; 4] {
    let e = truth.inverse().compose(estimate);
    let s = if e.w < 0.0 { -1.0 } else { 1.0 };
    [s * e.w, s * e.x, s * e.y, s * e.z]
}

/// χ²₃ 99% quantile.
pub const CHI2_3_99: f64 = 11.344_866_730_144_373;

/// Scores the estimates against the truth over the `movement` samples, BROAD's way (no alignment, the
/// truth's tilt error 0.2°). Samples without an estimate or without truth are left out.
pub fn score(
    estimates: &[Option<Sample>],
    truth: &[Option<Quaternion>],
    movement: &[bool],
) -> Scores {
    score_with(estimates, truth, movement, None, &TruthModel::default())
}

/// Scores the estimates against the truth over the `movement` samples with the truth's frames and
/// errors as `model` says; `rates` (body frame, rad/s, per sample) turn the truth's time-stamp
/// uncertainty into an angle. Samples without an estimate or without truth are left out.
pub fn score_with(
    estimates: &[Option<Sample>],
    truth: &[Option<Quaternion>],
    movement: &[bool],
    rates: Option<&[Vector3<f64>]>,
    model: &TruthModel,
) -> Scores {
    let n = estimates.len().min(truth.len()).min(movement.len());
    let aligned = match model.align {
        Align::None => None,
        Align::Both => trimmed_alignment(estimates, truth, movement, model.align_trim),
    };
    let mut tot = Vec::new();
    let mut head = Vec::new();
    let mut incl = Vec::new();
    let mut nees = Vec::new();
    let mut thetas = Vec::new();
    let mut psi = Vec::new();
    let mut psi_sigma = Vec::new();
    let mut covs = Vec::new();
    let truth2 = model.tilt_sigma_rad * model.tilt_sigma_rad;
    let t2 = model.time_sigma_s * model.time_sigma_s;
    for k in 0..n {
        let (Some(est), Some(tq), true) = (&estimates[k], &truth[k], movement[k]) else {
            continue;
        };
        let tq = match &aligned {
            Some(a) => a.truth_in_estimator_frames(tq),
            None => *tq,
        };
        let e = error_quaternion(&est.q, &tq);
        let (w, z) = (e[0].min(1.0), e[3]);
        tot.push(2.0 * w.acos());
        head.push(2.0 * (z / w).abs().atan());
        incl.push(2.0 * (w * w + z * z).sqrt().min(1.0).acos());
        // The rotation vector of e (reference frame).
        let v = Vector3::new(e[1], e[2], e[3]);
        let s = v.norm();
        let theta = if s > 0.0 {
            v * (2.0 * s.atan2(w) / s)
        } else {
            Vector3::zeros()
        };
        // R: body → reference of the estimate = A(q̂)ᵀ.
        let r = est.q.attitude_matrix().transpose();
        let mut pe = r * est.p_att * r.transpose();
        pe[(0, 0)] += truth2;
        pe[(1, 1)] += truth2;
        if let Some(w) = rates.and_then(|r| r.get(k)) {
            let wr = r * w;
            pe += wr * wr.transpose() * t2;
        }
        let ph = Matrix2::new(pe[(0, 0)], pe[(0, 1)], pe[(1, 0)], pe[(1, 1)]);
        let th = Vector2::new(theta[0], theta[1]);
        nees.push(match ph.cholesky() {
            Some(c) => th.dot(&c.solve(&th)),
            None => f64::INFINITY,
        });
        psi.push(theta[2]);
        psi_sigma.push(pe[(2, 2)].max(0.0).sqrt());
        thetas.push(theta);
        covs.push(pe);
    }
    let rmse = |x: &[f64]| {
        if x.is_empty() {
            return f64::NAN;
        }
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64)
            .sqrt()
            .to_degrees()
    };
    let m = psi.len();
    // The constant heading offset (the truth's north against the estimator's, which nothing in the
    // data fixes) is the one the published σ make most likely: the mean of the heading errors
    // weighted by their inverse variances. An unweighted mean would let a phase that the estimator
    // itself declares uncertain (a reference not yet confirmed, σ of tens of degrees) move the
    // offset, and count every confident sample after it as wrong.
    let offset = if m > 0 {
        let (mut sw, mut swx) = (0.0, 0.0);
        for (p, s) in psi.iter().zip(&psi_sigma) {
            let w = 1.0 / (s * s).max(1e-12);
            sw += w;
            swx += w * p;
        }
        swx / sw
    } else {
        f64::NAN
    };
    let heading_in = psi
        .iter()
        .zip(&psi_sigma)
        .filter(|(p, s)| (*p - offset).abs() <= Z_99 * **s)
        .count();
    let tilt_in = nees.iter().filter(|v| **v <= CHI2_2_99).count();
    let mut att_nees: Vec<f64> = thetas
        .iter()
        .zip(&covs)
        .map(|(th, p)| {
            let th = Vector3::new(th[0], th[1], th[2] - offset);
            match p.cholesky() {
                Some(c) => th.dot(&c.solve(&th)),
                None => f64::INFINITY,
            }
        })
        .collect();
    let att_in = att_nees.iter().filter(|v| **v <= CHI2_3_99).count();
    Scores {
        total_rmse_deg: rmse(&tot),
        heading_rmse_deg: rmse(&head),
        inclination_rmse_deg: rmse(&incl),
        tilt_in99: fraction(tilt_in, m),
        tilt_nees_median: median(&mut nees),
        heading_in99: fraction(heading_in, m),
        att_in99: fraction(att_in, m),
        att_nees_median: median(&mut att_nees),
        heading_offset_deg: offset.to_degrees(),
        align_reference_deg: aligned.map(|a| a.reference.angle().to_degrees()),
        align_body_deg: aligned.map(|a| a.body.angle().to_degrees()),
        scored: m,
    }
}

fn fraction(k: usize, n: usize) -> f64 {
    if n == 0 {
        f64::NAN
    } else {
        k as f64 / n as f64
    }
}

/// The median (the mean of the two middle values for an even count; NaN for none).
pub fn median(x: &mut [f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    x.sort_by(|a, b| a.total_cmp(b));
    let n = x.len();
    if n % 2 == 1 {
        x[n / 2]
    } else {
        0.5 * (x[n / 2 - 1] + x[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEG: f64 = std::f64::consts::PI / 180.0;

    /// BROAD's decomposition on known rotations: a pure heading error of 3° (about up) is 3° total and
    /// heading, 0 inclination; a pure tilt of 2° about east is 2° total and inclination, 0 heading.
    #[test]
    fn broad_metric_on_known_errors() {
        let truth = Quaternion::from_euler_321(0.3, -0.2, 1.0);
        // A Hamilton error e applied on the reference side: est = e · truth (Hamilton) = truth ⊗ e
        // (Shuster).
        let about = |axis: Vector3<f64>, deg: f64| {
            let e = Quaternion::from_rotation_vector(&(axis * (deg * DEG)));
            truth.compose(&e)
        };
        let t = [Some(truth)];
        let mv = [true];
        let at = |q: Quaternion| {
            [Some(Sample {
                q,
                p_att: Matrix3::identity() * 1e-6,
            })]
        };
        let s = score(&at(about(Vector3::z(), 3.0)), &t, &mv);
        assert!((s.total_rmse_deg - 3.0).abs() < 1e-9, "{s:?}");
        assert!((s.heading_rmse_deg - 3.0).abs() < 1e-9);
        assert!(s.inclination_rmse_deg.abs() < 1e-6);
        let s = score(&at(about(Vector3::x(), 2.0)), &t, &mv);
        assert!((s.total_rmse_deg - 2.0).abs() < 1e-9);
        assert!(s.heading_rmse_deg.abs() < 1e-6);
        assert!((s.inclination_rmse_deg - 2.0).abs() < 1e-9);
    }

    /// A recording whose truth has its own frames, and an estimator exact but for 8% of the samples
    /// (bursts of 20–40° about one axis, as after a saturated swing): the fit on every sample lets
    /// the bursts turn the frames, and every good sample then looks off; left out of the fit
    /// (`align_trim` 0.1), the frames come out exact and the good samples score zero.
    #[test]
    fn a_trimmed_alignment_is_not_turned_by_a_few_large_errors() {
        let l = Quaternion::from_euler_321(2.0, 0.3, -0.4);
        let r = Quaternion::from_euler_321(-0.7, 3.0, 0.2);
        let n = 2000;
        let mut est = Vec::with_capacity(n);
        let mut truth = Vec::with_capacity(n);
        let mut bad = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f64 * 0.05;
            let q = Quaternion::from_euler_321(0.9 * t.sin(), 0.4 * (0.7 * t).cos(), 0.3 * t);
            truth.push(Some(ham(&ham(&l, &q), &r)));
            // Every 25th run of 2 out of 25 samples: a 20–40° error about the body's x.
            let burst = i % 25 < 2;
            let e = if burst {
                let a = (20.0 + (i % 50) as f64 * 0.4) * DEG;
                ham(&q, &Quaternion::from_rotation_vector(&(Vector3::x() * a)))
            } else {
                q
            };
            bad.push(burst);
            est.push(Some(Sample {
                q: e,
                p_att: Matrix3::identity() * 1e-6,
            }));
        }
        let movement = vec![true; n];
        let off = |a: &Alignment| {
            ham(&a.reference, &l.inverse())
                .angle()
                .max(ham(&a.body, &r.inverse()).angle())
                / DEG
        };
        let plain = alignment(&est, &truth, &movement).unwrap();
        assert!(
            off(&plain) > 0.5,
            "the squared-error fit is turned: {}°",
            off(&plain)
        );
        let trimmed = trimmed_alignment(&est, &truth, &movement, 0.1).unwrap();
        assert!(
            off(&trimmed) < 1e-6,
            "the trimmed fit: {}° off",
            off(&trimmed)
        );
        assert_eq!(trimmed_alignment(&est, &truth, &movement, 0.0), Some(plain));
        // Scored: the good samples have no error, the bursts keep theirs (every sample is scored).
        let model = |trim| TruthModel {
            align: Align::Both,
            align_trim: trim,
            ..TruthModel::default()
        };
        let good: Vec<bool> = bad.iter().map(|b| !b).collect();
        let s = score_with(&est, &truth, &good, None, &model(0.0));
        assert!(
            s.total_rmse_deg < 1e-6,
            "good samples alone fit exactly: {s:?}"
        );
        let plain_scores = score_with(&est, &truth, &movement, None, &model(0.0));
        let trimmed_scores = score_with(&est, &truth, &movement, None, &model(0.1));
        assert_eq!(trimmed_scores.scored, n);
        assert!(
            trimmed_scores.tilt_in99 > 0.9 && plain_scores.tilt_in99 < 0.1,
            "tilt inside 99%: trimmed {}, plain {}",
            trimmed_scores.tilt_in99,
            plain_scores.tilt_in99
        );
    }

    /// Honesty of a Gaussian error drawn from the covariance the estimate states: the tilt lies within
    /// the 99% ellipse 99% of the time and its median NEES is χ²₂'s 1.39; stating half the spread is
    /// caught (far fewer inside, median four times larger).
    #[test]
    fn honesty_of_a_consistent_and_an_overconfident_estimate() {
        use rand::SeedableRng;
        let mut rng = attitude_core::rng::Xoshiro256PlusPlus::seed_from_u64(7);
        let truth = Quaternion::from_euler_321(0.1, 0.4, -2.0);
        let sigma = 1.0 * DEG;
        let n = 40_000;
        let mut est = Vec::with_capacity(n);
        let mut half = Vec::with_capacity(n);
        for _ in 0..n {
            // A body-frame error with covariance σ² I (the truth's own tilt error is added by the
            // score, so the draw includes it on the horizontal axes).
            let mut d = attitude_core::sensors::gyro::normal3(&mut rng) * sigma;
            let extra = attitude_core::sensors::gyro::normal3(&mut rng) * TRUTH_TILT_SIGMA_RAD;
            let r = truth.attitude_matrix();
            // Only the horizontal part of the truth's error, in the body frame.
            let extra_ref = Vector3::new(extra[0], extra[1], 0.0);
            d += r * extra_ref;
            let q = Quaternion::from_rotation_vector(&d).compose(&truth);
            est.push(Some(Sample {
                q,
                p_att: Matrix3::identity() * sigma * sigma,
            }));
            half.push(Some(Sample {
                q,
                p_att: Matrix3::identity() * (0.5 * sigma).powi(2),
            }));
        }
        let t = vec![Some(truth); n];
        let mv = vec![true; n];
        let s = score(&est, &t, &mv);
        assert!((s.tilt_in99 - 0.99).abs() < 0.003, "{s:?}");
        assert!((s.tilt_nees_median - 1.386).abs() < 0.05, "{s:?}");
        assert!((s.heading_in99 - 0.99).abs() < 0.003, "{s:?}");
        let h = score(&half, &t, &mv);
        assert!(h.tilt_in99 < 0.85 && h.tilt_nees_median > 4.0, "{h:?}");
        assert!(h.heading_in99 < 0.85, "{h:?}");
    }

    /// The heading offset removed is the one the published σ make most likely: a first quarter 100°
    /// off that says σ 60° (a field not yet confirmed) hardly moves it, and the three confident
    /// quarters after it, 2° off with σ 2°, are inside; the same quarter claiming σ 2° moves it by
    /// a quarter of 98° and is caught (and so are the rest).
    #[test]
    fn the_heading_offset_is_weighted_by_the_published_variances() {
        let truth = Quaternion::from_euler_321(0.0, 0.2, -0.3);
        let run = |early_sigma_deg: f64| {
            let n = 400;
            let mut est = Vec::with_capacity(n);
            for k in 0..n {
                let (err, sigma) = if k < n / 4 {
                    (100.0 * DEG, early_sigma_deg * DEG)
                } else {
                    (2.0 * DEG, 2.0 * DEG)
                };
                // A rotation about the reference vertical (the heading), its σ about the body's
                // image of that vertical; tilt σ 1°.
                let q = truth.compose(&Quaternion::from_rotation_vector(&(Vector3::z() * err)));
                let up = q.attitude_matrix() * Vector3::z();
                let p = Matrix3::identity() * DEG * DEG + up * up.transpose() * sigma * sigma;
                est.push(Some(Sample { q, p_att: p }));
            }
            score(&est, &vec![Some(truth); n], &vec![true; n])
        };
        let honest = run(60.0);
        assert!(honest.heading_offset_deg.abs() < 3.0, "{honest:?}");
        assert!(
            honest.att_in99 > 0.99 && honest.heading_in99 > 0.99,
            "{honest:?}"
        );
        let confident = run(2.0);
        assert!(
            (confident.heading_offset_deg - 26.5).abs() < 0.5,
            "{confident:?}"
        );
        assert!(confident.att_in99 < 0.01, "{confident:?}");
    }
}
