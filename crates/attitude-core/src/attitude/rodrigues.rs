//! Generalized Rodrigues parameters (GRP) of an error quaternion (docs/algorithms.md §1).
//!
//! `δp = f δϱ / (a + δq4)`, with inverse
//! `δq4 = (−a‖δp‖² + f √(f² + (1 − a²)‖δp‖²)) / (f² + ‖δp‖²)`, `δϱ = (a + δq4) δp / f`.
//! `a = 1, f = 1` are the modified Rodrigues parameters (MRP); `a = 1, f = 4` the USQUE choice (then
//! `‖δp‖ ≈` rotation angle in rad for small errors); `a = 0, f = 1` the Gibbs vector.

use super::quaternion::Quaternion;
use nalgebra::Vector3;

/// The parameters `(a, f)` of a generalized Rodrigues representation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grp {
    pub a: f64,
    pub f: f64,
}

impl Grp {
    /// Modified Rodrigues parameters (`a = 1, f = 1`): the local chart of the particle filter.
    pub const MRP: Grp = Grp { a: 1.0, f: 1.0 };
    /// The USQUE choice `a = 1, f = 2(a + 1) = 4`.
    pub const USQUE: Grp = Grp { a: 1.0, f: 4.0 };
    /// The Gibbs vector (`a = 0, f = 1`), singular at 180°.
    pub const GIBBS: Grp = Grp { a: 0.0, f: 1.0 };

    pub fn new(a: f64, f: f64) -> Self {
        Grp { a, f }
    }

    /// The GRP of an error quaternion. Flips `δq → −δq` first when `δq4 < 0` (shortest rotation), which
    /// for the MRP selects the parameter set of norm ≤ 1 rather than its shadow set.
    pub fn from_quaternion(&self, dq: &Quaternion) -> Vector3<f64> {
        let dq = dq.canonical();
        dq.vector() * (self.f / (self.a + dq.w))
    }

    /// The error quaternion of a GRP vector (unit norm by construction; never renormalised).
    pub fn to_quaternion(&self, dp: &Vector3<f64>) -> Quaternion {
        let (a, f) = (self.a, self.f);
        let n2 = dp.norm_squared();
        let w = (-a * n2 + f * (f * f + (1.0 - a * a) * n2).sqrt()) / (f * f + n2);
        let v = dp * ((a + w) / f);
        Quaternion::new(v[0], v[1], v[2], w)
    }

    /// The factor `k = 2(a + 1)/f` with `δα ≈ k δp` for small errors (`δq4 ≈ 1`, `δϱ ≈ δα/2`): 4 for
    /// the MRP, 1 for the USQUE choice.
    pub fn small_angle_factor(&self) -> f64 {
        2.0 * (self.a + 1.0) / self.f
    }
}

/// The MRP shadow set `−p/‖p‖²`: the other MRP vector of the same attitude.
pub fn mrp_shadow(p: &Vector3<f64>) -> Vector3<f64> {
    let n2 = p.norm_squared();
    if n2 == 0.0 {
        return *p;
    }
    -p / n2
}
