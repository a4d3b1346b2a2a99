//! The attitude quaternion and its kinematics.

use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};

/// Below this angle (rad) a rotation's half-angle terms come from their Taylor series: exact to
/// rounding (the first omitted terms are below 1e-17) and no trigonometric calls in the particle
/// filter's per-particle propagation, where every step's rotation is tiny.
pub(crate) const SERIES_ANGLE_RAD: f64 = 0.05;

/// `(sin(θ/2)/θ, cos(θ/2))` from `θ²`; safe at zero.
#[inline]
pub fn half_angle_terms(theta_sq: f64) -> (f64, f64) {
    if theta_sq < SERIES_ANGLE_RAD * SERIES_ANGLE_RAD {
        half_angle_series(theta_sq)
    } else {
        let angle = theta_sq.sqrt();
        let half = 0.5 * angle;
        (half.sin() / angle, half.cos())
    }
}

/// The series branch of [`half_angle_terms`] (valid below `SERIES_ANGLE_RAD`): Horner forms of
/// `sin(h)/(2h)` and `cos(h)`, `h = θ/2`, with reciprocals (no divisions). Shared with the particle
/// filter's vectorised propagation, which must give the same bits.
#[inline(always)]
pub(crate) fn half_angle_series(theta_sq: f64) -> (f64, f64) {
    let h2 = 0.25 * theta_sq;
    let s = 0.5 * (1.0 - h2 * (1.0 / 6.0) * (1.0 - h2 * (1.0 / 20.0) * (1.0 - h2 * (1.0 / 42.0))));
    let c = 1.0
        - h2 * 0.5
            * (1.0 - h2 * (1.0 / 12.0) * (1.0 - h2 * (1.0 / 30.0) * (1.0 - h2 * (1.0 / 56.0))));
    (s, c)
}

/// A unit attitude quaternion `q = [ϱ; q4]` (vector part `(x, y, z)`, scalar `w`).
///
/// # Conventions
///
/// * Shuster / Crassidis / Markley convention (docs/algorithms.md §1): the attitude matrix maps
///   reference-frame (inertial) coordinates to body coordinates, `b = A(q) r`, with
///   `A(q) = (q4² − ϱᵀϱ) I + 2 ϱϱᵀ − 2 q4 [ϱ×]`.
/// * Composition [`Quaternion::compose`] (`p ⊗ q`) satisfies `A(p ⊗ q) = A(p) A(q)`: the rotation on
///   the right is applied first.
/// * The error quaternion is `δq = q ⊗ q̂⁻¹` (error on the left, in the body frame); its small-angle
///   error vector is `δα ≈ 2 δϱ` rad ([`Quaternion::small_angle_error`]).
/// * The same four numbers are the Hamilton quaternion of the rotation body → reference (the
///   orientation of the body in the reference frame), as used by ROS, nalgebra and scipy:
///   `A(q) = R_hamilton(q)ᵀ`, and the Shuster product `p ⊗ q` equals the Hamilton product `q · p`.
/// * `q` and `−q` are the same attitude. Wire formats write `{"w", "x", "y", "z"}` and normalise
///   `w ≥ 0`; this type is never serialised directly.
///
/// These statements are pinned by tests with known numbers (`tests/it/conventions.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    pub const IDENTITY: Quaternion = Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };

    /// Builds a quaternion from its components without normalising (callers that need a unit
    /// quaternion from arbitrary numbers use [`Quaternion::normalized`]).
    pub const fn new(x: f64, y: f64, z: f64, w: f64) -> Self {
        Quaternion { x, y, z, w }
    }

    /// From a scalar-last 4-vector `[x, y, z, w]`.
    pub fn from_vector4(v: &Vector4<f64>) -> Self {
        Quaternion::new(v[0], v[1], v[2], v[3])
    }

    /// As a scalar-last 4-vector `[x, y, z, w]`.
    pub fn to_vector4(&self) -> Vector4<f64> {
        Vector4::new(self.x, self.y, self.z, self.w)
    }

    /// The vector part `ϱ`.
    pub fn vector(&self) -> Vector3<f64> {
        Vector3::new(self.x, self.y, self.z)
    }

    pub fn norm(&self) -> f64 {
        (self.x * self.x + self.y * self.y + self.z * self.z + self.w * self.w).sqrt()
    }

    /// The same direction with unit norm; `None` when the norm is zero or not finite.
    pub fn normalized(&self) -> Option<Self> {
        let n = self.norm();
        if !n.is_finite() || n < f64::MIN_POSITIVE.sqrt() {
            return None;
        }
        Some(Quaternion::new(
            self.x / n,
            self.y / n,
            self.z / n,
            self.w / n,
        ))
    }

    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite() && self.w.is_finite()
    }

    /// `−q`: the same attitude.
    pub fn negated(&self) -> Self {
        Quaternion::new(-self.x, -self.y, -self.z, -self.w)
    }

    /// The representative with `w ≥ 0` (the shortest rotation).
    pub fn canonical(&self) -> Self {
        if self.w < 0.0 {
            self.negated()
        } else {
            *self
        }
    }

    /// The inverse of a unit quaternion (its conjugate).
    pub fn inverse(&self) -> Self {
        Quaternion::new(-self.x, -self.y, -self.z, self.w)
    }

    pub fn dot(&self, other: &Quaternion) -> f64 {
        self.x * other.x + self.y * other.y + self.z * other.z + self.w * other.w
    }

    /// The Shuster product `self ⊗ q`, with `A(p ⊗ q) = A(p) A(q)`:
    /// `p ⊗ q = [p4 ϱ_q + q4 ϱ_p − ϱ_p × ϱ_q ; p4 q4 − ϱ_p · ϱ_q]`.
    pub fn compose(&self, q: &Quaternion) -> Quaternion {
        let (p, pw) = (self.vector(), self.w);
        let (r, qw) = (q.vector(), q.w);
        let v = r * pw + p * qw - p.cross(&r);
        Quaternion::new(v[0], v[1], v[2], pw * qw - p.dot(&r))
    }

    /// The attitude matrix `A(q)`: reference-frame coordinates → body coordinates.
    pub fn attitude_matrix(&self) -> Matrix3<f64> {
        let v = self.vector();
        let w = self.w;
        Matrix3::identity() * (w * w - v.dot(&v)) + v * v.transpose() * 2.0 - skew(&v) * (2.0 * w)
    }

    /// The unit quaternion of a rotation vector `θ` (rad) in this convention: `[sin(θ/2) θ̂; cos(θ/2)]`.
    /// Exact for any angle and safe at zero. `δq(δα) ⊗ q̂` applies a body-frame error `δα` to `q̂`.
    pub fn from_rotation_vector(theta: &Vector3<f64>) -> Quaternion {
        let (s, c) = half_angle_terms(theta.norm_squared());
        Quaternion::new(theta[0] * s, theta[1] * s, theta[2] * s, c)
    }

    /// The rotation vector (rad, angle in `[0, π]`) of this unit quaternion; the inverse of
    /// [`Quaternion::from_rotation_vector`] up to the sign of `q`.
    pub fn to_rotation_vector(&self) -> Vector3<f64> {
        let q = self.canonical();
        let v = q.vector();
        let s = v.norm();
        // angle = 2 atan2(‖ϱ‖, q4) is accurate at both ends; angle/‖ϱ‖ → 2 as ‖ϱ‖ → 0.
        let angle = 2.0 * s.atan2(q.w);
        if s < 1e-300 {
            return v * 2.0;
        }
        v * (angle / s)
    }

    /// The rotation angle of this quaternion, rad in `[0, π]`.
    pub fn angle(&self) -> f64 {
        2.0 * self.vector().norm().atan2(self.w.abs())
    }

    /// The small-angle error vector `δα = 2 δϱ` of `δq = self ⊗ estimate⁻¹` (rad, body frame), taken on
    /// the shortest rotation (`δq4 ≥ 0`). This is the error metric of the Monte-Carlo studies.
    pub fn small_angle_error(&self, estimate: &Quaternion) -> Vector3<f64> {
        let dq = self.compose(&estimate.inverse()).canonical();
        dq.vector() * 2.0
    }

    /// `Ω(ω) q`: kinematic propagation over `dt_s` with a constant body rate `omega_rad_s`
    /// (docs/algorithms.md §1, kinematics). Equal to `δq(ω Δt) ⊗ q`; safe at zero rate.
    pub fn propagate(&self, omega_rad_s: &Vector3<f64>, dt_s: f64) -> Quaternion {
        Quaternion::from_rotation_vector(&(omega_rad_s * dt_s)).compose(self)
    }

    /// The matrix `Ω(ω)` of docs/algorithms.md §1 (scalar-last 4×4) so that `q⁺ = Ω q⁻`.
    pub fn omega_matrix(omega_rad_s: &Vector3<f64>, dt_s: f64) -> Matrix4<f64> {
        let dq = Quaternion::from_rotation_vector(&(omega_rad_s * dt_s));
        let psi = dq.vector();
        let c = dq.w;
        let mut m = Matrix4::zeros();
        let top = Matrix3::identity() * c - skew(&psi);
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&top);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&psi);
        m.fixed_view_mut::<1, 3>(3, 0)
            .copy_from(&(-psi.transpose()));
        m[(3, 3)] = c;
        m
    }

    /// The quaternion of a proper orthogonal attitude matrix (Shepperd's method, numerically safe for
    /// every rotation). The result has `w ≥ 0`.
    pub fn from_attitude_matrix(a: &Matrix3<f64>) -> Quaternion {
        // Build from the transpose (the Hamilton rotation matrix) with the standard algorithm, since
        // these components are the Hamilton quaternion of body → reference.
        let r = a.transpose();
        let tr = r.trace();
        let (x, y, z, w);
        if tr > r[(0, 0)] && tr > r[(1, 1)] && tr > r[(2, 2)] {
            let s = (1.0 + tr).sqrt() * 2.0;
            w = 0.25 * s;
            x = (r[(2, 1)] - r[(1, 2)]) / s;
            y = (r[(0, 2)] - r[(2, 0)]) / s;
            z = (r[(1, 0)] - r[(0, 1)]) / s;
        } else if r[(0, 0)] > r[(1, 1)] && r[(0, 0)] > r[(2, 2)] {
            let s = (1.0 + r[(0, 0)] - r[(1, 1)] - r[(2, 2)]).sqrt() * 2.0;
            w = (r[(2, 1)] - r[(1, 2)]) / s;
            x = 0.25 * s;
            y = (r[(0, 1)] + r[(1, 0)]) / s;
            z = (r[(0, 2)] + r[(2, 0)]) / s;
        } else if r[(1, 1)] > r[(2, 2)] {
            let s = (1.0 + r[(1, 1)] - r[(0, 0)] - r[(2, 2)]).sqrt() * 2.0;
            w = (r[(0, 2)] - r[(2, 0)]) / s;
            x = (r[(0, 1)] + r[(1, 0)]) / s;
            y = 0.25 * s;
            z = (r[(1, 2)] + r[(2, 1)]) / s;
        } else {
            let s = (1.0 + r[(2, 2)] - r[(0, 0)] - r[(1, 1)]).sqrt() * 2.0;
            w = (r[(1, 0)] - r[(0, 1)]) / s;
            x = (r[(0, 2)] + r[(2, 0)]) / s;
            y = (r[(1, 2)] + r[(2, 1)]) / s;
            z = 0.25 * s;
        }
        let q = Quaternion::new(x, y, z, w);
        q.normalized().unwrap_or(Quaternion::IDENTITY).canonical()
    }

    /// The attitude of a 3-2-1 (yaw ψ about z, then pitch θ about the new y, then roll φ about the
    /// new x) Euler sequence, angles in rad, as used for initial-error specifications.
    pub fn from_euler_321(roll: f64, pitch: f64, yaw: f64) -> Quaternion {
        // A = R1(φ) R2(θ) R3(ψ); the elementary quaternion of a frame rotation by angle a about axis e
        // in this convention is [sin(a/2) e; cos(a/2)].
        let qx = Quaternion::from_rotation_vector(&Vector3::new(roll, 0.0, 0.0));
        let qy = Quaternion::from_rotation_vector(&Vector3::new(0.0, pitch, 0.0));
        let qz = Quaternion::from_rotation_vector(&Vector3::new(0.0, 0.0, yaw));
        qx.compose(&qy).compose(&qz)
    }
}

/// The cross-product matrix `[v×]`, so that `[v×] u = v × u`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v[2], v[1], v[2], 0.0, -v[0], -v[1], v[0], 0.0)
}
