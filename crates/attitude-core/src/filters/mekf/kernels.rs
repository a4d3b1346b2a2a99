//! The MEKF's arithmetic on fixed-size arrays, shaped like its matrices.
//!
//! * **Propagation.** `Φ = [[A, B], [0, I]]` (`A = Φ₁₁`, `B = Φ₁₂`), so `P₂₂` is unchanged by `Φ`,
//!   `P₁₂′ = A P₁₂ + B P₂₂ =: M` and `P₁₁′ = (A P₁₁ + B P₂₁) Aᵀ + M Bᵀ`: about 145 multiply-adds where
//!   two dense 6×6 products take 432. The coefficients of `Φ` come from a series at an IMU's rates.
//! * **Updates as scalar updates.** A vector observation `H = [[b×], 0]`, `R = σ² I`, is rank two: in
//!   the basis `e₁, e₂ ⊥ b̂, b̂` its rows are `(eₖ × b)ᵀ` and `0` (the component along `b̂` is noise
//!   alone and enters only the NIS), so its gain needs a 2×2 `L D Lᵀ`, no 3×3 solve. A tilt update
//!   projects that gain, `K ← Π K` with `Π = I − V`, `V = diag(v vᵀ, v vᵀ)`; a heading update is one row
//!   with its gain projected on `v`; a bias observation is three scalar rows. The covariance follows in
//!   Joseph form `(I − K H) P (I − K H)ᵀ + K R Kᵀ`, valid for any gain, evaluated on those one or two
//!   rows ([`joseph`]: ~130 multiply-adds for two rows where the dense products take ~1 000), never
//!   expanded into `P − k uᵀ − u kᵀ + s k kᵀ`, which is equal in exact arithmetic but loses a variance
//!   that an informative update removes to cancellation. No inverse, no Cholesky, no 6×6 product.
//!
//! Every kernel writes the upper triangle and mirrors it: the covariance stays exactly symmetric.

/// A symmetric 6×6 covariance of `[δα; δβ]` as plain rows (nalgebra's `Matrix6` storage is the same
/// array, by columns, which is the same matrix when it is symmetric).
pub type Cov = [[f64; 6]; 6];
pub type M3 = [[f64; 3]; 3];
pub type V3 = [f64; 3];

#[inline]
fn dot3(a: &V3, b: &[f64]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Copies the upper triangle to the lower one.
#[inline]
fn mirror(p: &mut Cov) {
    for i in 1..6 {
        for j in 0..i {
            p[i][j] = p[j][i];
        }
    }
}

/// `(c₁, c₂, c₃) = (sin θ/‖ω‖, (1 − cos θ)/‖ω‖², (θ − sin θ)/‖ω‖³)`, `θ = ‖ω‖ Δt`, from `‖ω‖²`. Below
/// θ = 0.1 rad (every sample of an IMU at 100 Hz or more turning slower than 10 rad/s) Taylor series to
/// θ⁸, whose first omitted terms are below 3e-18 relative: no trigonometric call and none of the
/// cancellation of `θ − sin θ`; above, one `sin_cos`.
#[inline]
pub fn phi_coefficients(w2: f64, dt: f64) -> (f64, f64, f64) {
    let t = w2 * dt * dt;
    if t < 0.01 {
        let c1 = dt
            * (1.0
                - t * (1.0 / 6.0)
                    * (1.0
                        - t * (1.0 / 20.0) * (1.0 - t * (1.0 / 42.0) * (1.0 - t * (1.0 / 72.0)))));
        let c2 = dt
            * dt
            * 0.5
            * (1.0
                - t * (1.0 / 12.0)
                    * (1.0
                        - t * (1.0 / 30.0) * (1.0 - t * (1.0 / 56.0) * (1.0 - t * (1.0 / 90.0)))));
        let c3 = dt
            * dt
            * dt
            * (1.0 / 6.0)
            * (1.0
                - t * (1.0 / 20.0)
                    * (1.0
                        - t * (1.0 / 42.0) * (1.0 - t * (1.0 / 72.0) * (1.0 - t * (1.0 / 110.0)))));
        (c1, c2, c3)
    } else {
        let w = w2.sqrt();
        let theta = w * dt;
        let (s, c) = theta.sin_cos();
        (s / w, (1.0 - c) / (w * w), (theta - s) / (w * w * w))
    }
}

/// The two non-trivial blocks of `Φ`: `A = Φ₁₁ = I − c₁[ω×] + c₂[ω×]²` and
/// `B = Φ₁₂ = c₂[ω×] − Δt I − c₃[ω×]²` (`Φ₂₁ = 0`, `Φ₂₂ = I`).
#[inline]
pub fn phi_blocks(w: &V3, dt: f64) -> (M3, M3) {
    let sq = [w[0] * w[0], w[1] * w[1], w[2] * w[2]];
    let (c1, c2, c3) = phi_coefficients(sq[0] + sq[1] + sq[2], dt);
    let wx = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
    // [ω×]² = ω ωᵀ − ‖ω‖² I, its diagonal summed from the other two squares (no cancellation).
    let wx2 = [
        [-(sq[1] + sq[2]), w[0] * w[1], w[0] * w[2]],
        [w[0] * w[1], -(sq[0] + sq[2]), w[1] * w[2]],
        [w[0] * w[2], w[1] * w[2], -(sq[0] + sq[1])],
    ];
    let mut a = [[0.0; 3]; 3];
    let mut b = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let one = if i == j { 1.0 } else { 0.0 };
            a[i][j] = one - wx[i][j] * c1 + wx2[i][j] * c2;
            b[i][j] = wx[i][j] * c2 - one * dt - wx2[i][j] * c3;
        }
    }
    (a, b)
}

/// The per-axis entries of the Farrenkopf process noise over `Δt` (see [`super::process_noise`]):
/// `Q₁₁ = q11 I`, `Q₁₂ = Q₂₁ = q12 I`, `Q₂₂ = q22 I`.
#[derive(Clone, Copy, Debug)]
pub struct Noise {
    pub q11: f64,
    pub q12: f64,
    pub q22: f64,
}

/// `D (Φ P Φᵀ + Q + e I_α) D` with `D = diag(I, φ_b I)` (`e` the rate-proportional attitude
/// variance, `φ_b` the Gauss–Markov bias reversion, 1 for none), on the blocks (module documentation).
pub fn propagate(p: &Cov, a: &M3, b: &M3, q: &Noise, extra: f64, phi_b: f64) -> Cov {
    // M = A P₁₂ + B P₂₂ and N = A P₁₁ + B P₂₁, row by row: each row a sum of rows of P, in lanes of
    // four (the fourth is padding) so that the compiler packs them.
    let row = |r: usize, c: usize| [p[r][c], p[r][c + 1], p[r][c + 2], 0.0];
    let (p11, p12, p21, p22): ([[f64; 4]; 3], [[f64; 4]; 3], [[f64; 4]; 3], [[f64; 4]; 3]) = (
        std::array::from_fn(|k| row(k, 0)),
        std::array::from_fn(|k| row(k, 3)),
        std::array::from_fn(|k| row(k + 3, 0)),
        std::array::from_fn(|k| row(k + 3, 3)),
    );
    let mut m = [[0.0; 4]; 3];
    let mut n = [[0.0; 4]; 3];
    for i in 0..3 {
        for k in 0..3 {
            let (aik, bik) = (a[i][k], b[i][k]);
            for j in 0..4 {
                m[i][j] += aik * p12[k][j] + bik * p22[k][j];
                n[i][j] += aik * p11[k][j] + bik * p21[k][j];
            }
        }
    }
    let mut out = [[0.0; 6]; 6];
    for i in 0..3 {
        // P₁₁′ = N Aᵀ + M Bᵀ (upper triangle), P₁₂′ = M, P₂₂′ = P₂₂, plus Q and the reversion.
        for j in i..3 {
            let mut v = 0.0;
            for k in 0..3 {
                v += n[i][k] * a[j][k] + m[i][k] * b[j][k];
            }
            let (v, b22) = if i == j {
                (v + q.q11 + extra, p[i + 3][j + 3] + q.q22)
            } else {
                (v, p[i + 3][j + 3])
            };
            out[i][j] = v;
            out[i + 3][j + 3] = b22 * phi_b * phi_b;
        }
        for j in 0..3 {
            let b12 = if i == j { m[i][j] + q.q12 } else { m[i][j] };
            out[i][j + 3] = b12 * phi_b;
        }
    }
    mirror(&mut out);
    out
}

/// `P h` for an observation of the attitude alone (`h = [h_α; 0]`).
#[inline]
fn p_att(p: &Cov, h: &V3) -> [f64; 6] {
    std::array::from_fn(|i| p[i][0] * h[0] + p[i][1] * h[1] + p[i][2] * h[2])
}

/// `[v (v·x_α); v (v·x_β)]`: the vertical part of each half.
#[inline]
fn vertical_part(v: &V3, x: &[f64; 6]) -> [f64; 6] {
    let (ca, cb) = (dot3(v, &x[..3]), dot3(v, &x[3..]));
    [
        v[0] * ca,
        v[1] * ca,
        v[2] * ca,
        v[0] * cb,
        v[1] * cb,
        v[2] * cb,
    ]
}

/// What an update changes besides the covariance: the error-state correction and `νᵀ S⁻¹ ν`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correction {
    pub dx: [f64; 6],
    pub nis: f64,
}

/// Two unit vectors that complete the unit `n` to a right-handed orthonormal basis, branch-free
/// (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017).
#[inline]
fn basis(n: &V3) -> (V3, V3) {
    let s = 1f64.copysign(n[2]);
    let a = -1.0 / (s + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + s * n[0] * n[0] * a, s * b, -s * n[0]],
        [b, s + n[1] * n[1] * a, -n[1]],
    )
}

/// The Joseph form `(I − K H) P (I − K H)ᵀ + r K Kᵀ` of `N` scalar rows `hₙ` (uncorrelated, each of
/// variance `r`) with any gains `kₙ` (the columns of `K`), given `uₙ = P hₙ`: `Y = P − Σ kₙ uₙᵀ`, then
/// `P⁺ = Y − Σ (Y hₙ) kₙᵀ + r Σ kₙ kₙᵀ`. Taking `Y hₙ` from the computed `Y` keeps what makes the Joseph
/// form robust: the rounding of `Y` along an observed direction is multiplied by the small `I − K H`
/// there, so a variance that the update removes almost entirely stays positive (the expanded
/// `P − k uᵀ − u kᵀ + s k kᵀ` loses it to cancellation when `s ≫ r`). `y_h(Y, n)` is `Y hₙ`.
fn joseph<const N: usize>(
    p: &mut Cov,
    k: &[[f64; 6]; N],
    u: &[[f64; 6]; N],
    r: f64,
    y_h: impl Fn(&Cov, usize) -> [f64; 6],
) {
    let mut y = *p;
    for (i, row) in y.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            for n in 0..N {
                *v -= k[n][i] * u[n][j];
            }
        }
    }
    let g: [[f64; 6]; N] = std::array::from_fn(|n| y_h(&y, n));
    for i in 0..6 {
        for j in i..6 {
            let mut v = y[i][j];
            for n in 0..N {
                v += (r * k[n][i] - g[n][i]) * k[n][j];
            }
            p[i][j] = v;
        }
    }
    mirror(p);
}

/// `Y h` for an attitude row `h = [h_α; 0]`.
#[inline]
fn y_att(y: &Cov, h: &V3) -> [f64; 6] {
    std::array::from_fn(|i| y[i][0] * h[0] + y[i][1] * h[1] + y[i][2] * h[2])
}

/// One vector observation `b̃ = A(q) r + v`, `R = σ² I`, about the predicted `b = Â r` with the
/// innovation `nu`: the optimal update, or with `vertical` (the body-frame vertical, unit) the tilt
/// update whose gain is projected perpendicular to it (module documentation). Updates `p`; `None` (and
/// `p` unchanged) when the innovation covariance is not positive definite.
pub fn vector(
    p: &mut Cov,
    b: &V3,
    sigma: f64,
    nu: &V3,
    vertical: Option<&V3>,
) -> Option<Correction> {
    let r = sigma * sigma;
    let bn = dot3(b, b).sqrt();
    // S = diag(S₂, r) in the basis (e₁, e₂, b̂): singular without noise.
    if !(r > 0.0 && r.is_finite() && bn.is_finite()) {
        return None;
    }
    if bn == 0.0 {
        // H = 0: nothing is observed, the innovation is all noise.
        return Some(Correction {
            dx: [0.0; 6],
            nis: dot3(nu, nu) / r,
        });
    }
    let bh = [b[0] / bn, b[1] / bn, b[2] / bn];
    let (e1, e2) = basis(&bh);
    let h = [cross(&e1, b), cross(&e2, b)];
    let (z1, z2, z3) = (dot3(&e1, nu), dot3(&e2, nu), dot3(&bh, nu));
    let u = [p_att(p, &h[0]), p_att(p, &h[1])];
    // S₂ = H̃ P H̃ᵀ + r I = L D Lᵀ: the second row on what the first left.
    let s1 = dot3(&h[0], &u[0]) + r;
    if !(s1 > 0.0 && s1.is_finite()) {
        return None;
    }
    let l = dot3(&h[1], &u[0]) / s1;
    let u2: [f64; 6] = std::array::from_fn(|i| u[1][i] - l * u[0][i]);
    let s2 = dot3(&h[1], &u2) + r;
    if !(s2 > 0.0 && s2.is_finite()) {
        return None;
    }
    let z2 = z2 - l * z1;
    // The optimal gain U S₂⁻¹ = [u₁/s₁ − l u₂′/s₂, u₂′/s₂].
    let k2: [f64; 6] = std::array::from_fn(|i| u2[i] / s2);
    let k1: [f64; 6] = std::array::from_fn(|i| u[0][i] / s1 - l * k2[i]);
    let mut k = [k1, k2];
    let mut dx: [f64; 6] = std::array::from_fn(|i| u[0][i] * (z1 / s1) + u2[i] * (z2 / s2));
    let nis = z1 * z1 / s1 + z2 * z2 / s2 + z3 * z3 / r;
    if let Some(v) = vertical {
        // Tilt only: K ← (I − V) K, and so the correction.
        for x in k.iter_mut().chain([&mut dx]) {
            let vx = vertical_part(v, x);
            for i in 0..6 {
                x[i] -= vx[i];
            }
        }
    }
    joseph(p, &k, &u, r, |y, n| y_att(y, &h[n]));
    Some(Correction { dx, nis })
}

/// One heading-only observation `y = hᵀ δα + n`, `n ~ N(0, σ_ψ²)`, innovation `nu`, with the gain
/// projected on the body-frame vertical `v` (`k = V u/s`), in Joseph form. `None` (and `p`
/// unchanged) when `s ≤ 0`.
pub fn heading(p: &mut Cov, h: &V3, v: &V3, sigma_psi: f64, nu: f64) -> Option<Correction> {
    let r = sigma_psi * sigma_psi;
    let u = p_att(p, h);
    let s = dot3(h, &u) + r;
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let y = vertical_part(v, &u);
    let k: [f64; 6] = std::array::from_fn(|i| y[i] / s);
    joseph(p, &[k], &[u], r, |y, _| y_att(y, h));
    Some(Correction {
        dx: std::array::from_fn(|i| k[i] * nu),
        nis: nu * nu / s,
    })
}

/// A direct observation of the gyro bias, `z = β + n`, `n ~ N(0, σ² I₃)`, innovation `nu`: three
/// scalar updates, one per axis (`R` is diagonal, so they are the 3-D update exactly), each in Joseph
/// form. `None` (and `p` unchanged) when an innovation variance is not positive.
pub fn bias(p: &mut Cov, sigma: f64, nu: &V3) -> Option<Correction> {
    let r = sigma * sigma;
    let mut q = *p;
    let mut dx = [0.0; 6];
    let mut nis = 0.0;
    for axis in 0..3 {
        let c = axis + 3;
        let u: [f64; 6] = std::array::from_fn(|i| q[i][c]);
        let s = u[c] + r;
        if !(s > 0.0 && s.is_finite()) {
            return None;
        }
        let z = nu[axis] - dx[c];
        let k: [f64; 6] = std::array::from_fn(|i| u[i] / s);
        for i in 0..6 {
            dx[i] += k[i] * z;
        }
        nis += z * z / s;
        joseph(&mut q, &[k], &[u], r, |y, _| {
            std::array::from_fn(|i| y[i][c])
        });
    }
    *p = q;
    Some(Correction { dx, nis })
}
