//! The per-particle passes of the QPF as vectorised kernels (`crate::simd`): each works on one block
//! of at most [`BLOCK`] particles, eight at a time (particle `i` on lane `i mod 8`), and returns its
//! block's sums reduced in a fixed order; `par.rs` runs the blocks on one or more threads and adds
//! the block sums in block order, so the bits do not depend on the thread count or the instruction
//! set. Random draws: one key per pass from the filter's generator, the lanes of block `k` keyed
//! `(key, k)` (`rng::Lanes`).
//!
//! Steady state (no resampling) is four passes: [`propagate`], a log-likelihood ([`loglik_vectors`],
//! with [`loglik_heading`] or [`loglik_bias`]) with its live minimum and maximum, [`weigh`] (the
//! weight update fused with `Σw` and `Σ w q qᵀ` for the average) and [`moments`] (normalisation, the
//! local states, their mean and covariance and `Σw²`).

use crate::attitude::quaternion::{half_angle_terms, SERIES_ANGLE_RAD};
use crate::rng::{ziggurat, Lanes};
use crate::simd::{kernel, Mask, LANES, V8};
use rand_distr::Beta;

/// Particles per block: the unit of random streams, of threads and of partial sums.
pub(super) const BLOCK: usize = 1024;

/// Groups of eight particles per draw of normals in [`propagate`] and [`regularise`].
const GROUP: usize = 8;

/// `each8!(V, n, [ins], pad, [io], pad_io, |g, x, y| body)` runs `body` on every group `g` of eight
/// of the `n` particles: `x` the `ins` columns as `[V; _]` (past the end: `pad`), `y` the `io`
/// columns, written back for the particles that exist. Whole groups are loaded straight from the
/// columns; only a short last group is copied. (A macro, not a function taking a closure: a closure
/// would be compiled without the kernel's target features.)
macro_rules! each8 {
    ($v:ident, $n:expr, [$($in:expr),*], $pad:expr, [$($io:expr),*], $pad_io:expr,
     |$g:ident, $x:ident, $y:ident| $body:block) => {{
        const NI: usize = 0 $(+ { let _ = stringify!($in); 1 })*;
        const NO: usize = 0 $(+ { let _ = stringify!($io); 1 })*;
        let n: usize = $n;
        let ins: [&[f64]; NI] = [$(&$in[..n]),*];
        let mut io: [&mut [f64]; NO] = [$(&mut $io[..n]),*];
        let pad: [f64; NI] = $pad;
        let pad_io: [f64; NO] = $pad_io;
        let full = n - n % LANES;
        let mut i = 0;
        while i < full {
            let $g = i / LANES;
            // (Plain loops, no closures: a closure would lose the target features.)
            let mut $x = [$v::splat(0.0); NI];
            for (xk, col) in $x.iter_mut().zip(&ins) {
                *xk = $v::load(&col[i..]);
            }
            let mut y = [$v::splat(0.0); NO];
            for (yk, col) in y.iter_mut().zip(&io) {
                *yk = $v::load(&col[i..]);
            }
            {
                let $y = &mut y;
                $body
            }
            for (col, v) in io.iter_mut().zip(&y) {
                col[i..i + LANES].copy_from_slice(&v.to_array());
            }
            i += LANES;
        }
        if i < n {
            let m = n - i;
            let $g = i / LANES;
            let mut $x = [$v::splat(0.0); NI];
            for ((xk, col), p) in $x.iter_mut().zip(&ins).zip(pad) {
                let mut a = [p; LANES];
                a[..m].copy_from_slice(&col[i..n]);
                *xk = $v::from_array(a);
            }
            let mut y = [$v::splat(0.0); NO];
            for ((yk, col), p) in y.iter_mut().zip(&io).zip(pad_io) {
                let mut a = [p; LANES];
                a[..m].copy_from_slice(&col[i..n]);
                *yk = $v::from_array(a);
            }
            {
                let $y = &mut y;
                $body
            }
            for (col, v) in io.iter_mut().zip(&y) {
                col[i..n].copy_from_slice(&v.to_array()[..m]);
            }
        }
    }};
}

#[inline(always)]
fn splat4<V: V8>(a: &[f64; 4]) -> [V; 4] {
    [
        V::splat(a[0]),
        V::splat(a[1]),
        V::splat(a[2]),
        V::splat(a[3]),
    ]
}

/// Each accumulator's lanes added in a fixed order.
#[inline(always)]
fn sums<V: V8, const K: usize>(acc: &[V; K]) -> [f64; K] {
    let mut out = [0.0; K];
    for k in 0..K {
        out[k] = acc[k].sum();
    }
    out
}

/// `p ⊗ q` on lanes (as `cloud::compose`).
#[inline(always)]
fn compose<V: V8>(p: [V; 4], q: [V; 4]) -> [V; 4] {
    let [px, py, pz, pw] = p;
    let [qx, qy, qz, qw] = q;
    [
        pw * qx + qw * px - (py * qz - pz * qy),
        pw * qy + qw * py - (pz * qx - px * qz),
        pw * qz + qw * pz - (px * qy - py * qx),
        pw * qw - (px * qx + py * qy + pz * qz),
    ]
}

/// The MRP of `q ⊗ fid⁻¹` on lanes, branch-free: `δp = d_v · k/(1 + k d₄)`, `k = sgn d₄` (the
/// shortest rotation).
#[inline(always)]
fn mrp<V: V8>(q: [V; 4], fid_inv: &[f64; 4]) -> [V; 3] {
    let d = compose(q, splat4(fid_inv));
    let k = V::select(d[3].lt(V::splat(0.0)), V::splat(-1.0), V::splat(1.0));
    let s = k / (k * d[3] + 1.0);
    [d[0] * s, d[1] * s, d[2] * s]
}

/// `MRP⁻¹(p) ⊗ fid` on lanes: `δq = [2p; 1 − ‖p‖²]/(1 + ‖p‖²)`, unit by construction.
#[inline(always)]
fn from_mrp<V: V8>(p: [V; 3], fid: &[f64; 4]) -> [V; 4] {
    let n2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    let f = V::splat(1.0) / (n2 + 1.0);
    compose(
        [
            p[0] * 2.0 * f,
            p[1] * 2.0 * f,
            p[2] * 2.0 * f,
            (V::splat(1.0) - n2) * f,
        ],
        splat4(fid),
    )
}

/// The gyro model's constants for one propagation (`Qpf::propagate`).
pub(super) struct Propagation {
    pub phi_b: f64,
    pub su: f64,
    pub sw: f64,
    pub omega: [f64; 3],
    pub dt: f64,
}

const CLOUD_PAD: [f64; 7] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];

kernel! {
    /// One block of the exact discrete gyro model: `βᵢ' = φ βᵢ + σ_u N`,
    /// `θᵢ = (ω̃ − ½(βᵢ + βᵢ') − σ_w N) Δt`, `qᵢ ← δq(θᵢ) ⊗ qᵢ`. Each group of 64 particles draws 24
    /// rows of normals and takes them twice, the second time negated (antithetic pairs): particle
    /// `8g + l` of the group takes lane `l` of rows `6g..6g + 6` (`N_u`, `N_v` of x, then y, then z),
    /// particle `8g + l + 32` the same rows negated. Each particle still follows the model; a pair's
    /// noise cancels in the cloud's mean (to first order), and half the normals are drawn.
    pub(super) fn propagate<V>(
        key: u64,
        block: u64,
        p: &Propagation,
        qx: &mut [f64],
        qy: &mut [f64],
        qz: &mut [f64],
        qw: &mut [f64],
        bx: &mut [f64],
        by: &mut [f64],
        bz: &mut [f64],
    ) {
        let z = ziggurat();
        let mut lanes = Lanes::keyed(key, block);
        let mut normals = [[0.0; LANES]; 6 * GROUP];
        let mut words = [[0u64; LANES]; 3 * GROUP];
        let limit = V::splat(SERIES_ANGLE_RAD * SERIES_ANGLE_RAD);
        let n = qx.len();
        let mut start = 0;
        while start < n {
            let end = (start + GROUP * LANES).min(n);
            let (drawn, mirrored) = normals.split_at_mut(3 * GROUP);
            z.fill::<V>(&mut lanes, drawn, &mut words);
            for (m, d) in mirrored.iter_mut().zip(drawn.iter()) {
                *m = d.map(|x| -x);
            }
            let (gx, gy, gz, gw) = (&mut qx[start..], &mut qy[start..], &mut qz[start..], &mut qw[start..]);
            let (hx, hy, hz) = (&mut bx[start..], &mut by[start..], &mut bz[start..]);
            each8!(V, end - start, [], [], [gx, gy, gz, gw, hx, hy, hz], CLOUD_PAD, |g, _x, c| {
                let eps = &normals[6 * g..6 * g + 6];
                let mut th = [V::splat(0.0); 3];
                for k in 0..3 {
                    let b0 = c[4 + k];
                    let b1 = b0 * p.phi_b + V::load(&eps[2 * k]) * p.su;
                    th[k] = (V::splat(p.omega[k]) - (b0 + b1) * 0.5 - V::load(&eps[2 * k + 1]) * p.sw)
                        * p.dt;
                    c[4 + k] = b1;
                }
                let t2 = th[0] * th[0] + th[1] * th[1] + th[2] * th[2];
                // The series of `half_angle_terms`, written on lanes.
                let h2 = t2 * 0.25;
                let one = V::splat(1.0);
                let mut sf = (one
                    - h2 * (1.0 / 6.0) * (one - h2 * (1.0 / 20.0) * (one - h2 * (1.0 / 42.0))))
                    * 0.5;
                let mut cf = one
                    - h2 * 0.5
                        * (one - h2 * (1.0 / 12.0) * (one - h2 * (1.0 / 30.0) * (one - h2 * (1.0 / 56.0))));
                if !t2.lt(limit).all() {
                    // A long or fast step: the trigonometric branch where it applies (rare).
                    sf = t2.map(|t| half_angle_terms(t).0);
                    cf = t2.map(|t| half_angle_terms(t).1);
                }
                let q = compose([th[0] * sf, th[1] * sf, th[2] * sf, cf], [c[0], c[1], c[2], c[3]]);
                c[..4].copy_from_slice(&q);
            });
            start = end;
        }
    }
}

/// The log-likelihood of all full-direction (and tilt) observations as one quadratic form in the
/// fiducial's chart: `log L(q) = c + eᵀ(2g + K′e)`, `e = sgn(q·q̄) q − q̄`, `K′ = K − (q̄ᵀKq̄) I`,
/// `g = K′q̄` (docs/algorithms.md §3).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Chart {
    pub qbar: [f64; 4],
    pub g2: [f64; 4],
    /// `K′` row by row, upper triangle: 00 01 02 03 11 12 13 22 23 33.
    pub k: [f64; 10],
    pub c: f64,
}

/// `[lo, hi]`: the smallest and largest log-likelihood of the live particles (`w > 0`).
pub(super) type Spread = [f64; 2];

/// Per-lane running `[lo, hi]`.
struct Lanes2<V>([V; 2]);

impl<V: V8> Lanes2<V> {
    #[inline(always)]
    fn new() -> Self {
        Lanes2([V::splat(f64::INFINITY), V::splat(f64::NEG_INFINITY)])
    }

    #[inline(always)]
    fn add(&mut self, ll: V, w: V) {
        // Compare-and-select (not f64::min): the same choice on every path, NaN never chosen.
        let live = w.gt(V::splat(0.0));
        let [lo, hi] = &mut self.0;
        *lo = V::select(live.and(ll.lt(*lo)), ll, *lo);
        *hi = V::select(live.and(ll.gt(*hi)), ll, *hi);
    }

    #[inline(always)]
    fn finish(&self) -> Spread {
        let (lo, hi) = (self.0[0].to_array(), self.0[1].to_array());
        let mut s = [f64::INFINITY, f64::NEG_INFINITY];
        for l in 0..LANES {
            if lo[l] < s[0] {
                s[0] = lo[l];
            }
            if hi[l] > s[1] {
                s[1] = hi[l];
            }
        }
        s
    }
}

kernel! {
    /// `ll ← log L` of the full-direction observations (in `chart`), and the live spread.
    pub(super) fn loglik_vectors<V>(
        chart: &Chart,
        qx: &[f64],
        qy: &[f64],
        qz: &[f64],
        qw: &[f64],
        w: &[f64],
        ll: &mut [f64],
    ) -> Spread {
        let mut spread = Lanes2::<V>::new();
        let [k00, k01, k02, k03, k11, k12, k13, k22, k23, k33] = chart.k;
        let (qb, g) = (chart.qbar, chart.g2);
        each8!(V, ll.len(), [qx, qy, qz, qw, w], [0.0, 0.0, 0.0, 1.0, 0.0], [ll], [0.0], |_g, x, out| {
            let d = x[0] * qb[0] + x[1] * qb[1] + x[2] * qb[2] + x[3] * qb[3];
            let s = V::select(d.lt(V::splat(0.0)), V::splat(-1.0), V::splat(1.0));
            let e = [s * x[0] - qb[0], s * x[1] - qb[1], s * x[2] - qb[2], s * x[3] - qb[3]];
            let t0 = (e[0] * k00 + e[1] * k01 + e[2] * k02 + e[3] * k03) + g[0];
            let t1 = (e[0] * k01 + e[1] * k11 + e[2] * k12 + e[3] * k13) + g[1];
            let t2 = (e[0] * k02 + e[1] * k12 + e[2] * k22 + e[3] * k23) + g[2];
            let t3 = (e[0] * k03 + e[1] * k13 + e[2] * k23 + e[3] * k33) + g[3];
            out[0] = (e[0] * t0 + e[1] * t1 + e[2] * t2 + e[3] * t3) + chart.c;
            spread.add(out[0], x[4]);
        });
        spread.finish()
    }
}

/// A heading-only observation: `b·(A e₁) = qᵀK₁q`, `b·(A e₂) = qᵀK₂q` as the ten coefficients of the
/// products `xx yy zz ww xy xz xw yz yw zw`, and `−½σ_ψ⁻²`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Heading {
    pub k1: [f64; 10],
    pub k2: [f64; 10],
    pub half_inv_var: f64,
}

kernel! {
    /// `ll ← ll + Σ −½ψ²/σ_ψ²` over the heading-only observations, `ψ = atan2(qᵀK₂q, qᵀK₁q)`, and the
    /// live spread of the result. The quadratic forms are vectorised; `atan2` is libm's, lane by lane.
    pub(super) fn loglik_heading<V>(
        terms: &[Heading],
        qx: &[f64],
        qy: &[f64],
        qz: &[f64],
        qw: &[f64],
        w: &[f64],
        ll: &mut [f64],
    ) -> Spread {
        let mut spread = Lanes2::<V>::new();
        each8!(V, ll.len(), [qx, qy, qz, qw, w], [0.0, 0.0, 0.0, 1.0, 0.0], [ll], [0.0], |_g, x, out| {
            let [a, b, c, d] = [x[0], x[1], x[2], x[3]];
            let pp = [a * a, b * b, c * c, d * d, a * b, a * c, a * d, b * c, b * d, c * d];
            for t in terms {
                let (mut c, mut sn) = (V::splat(0.0), V::splat(0.0));
                for k in 0..10 {
                    c += pp[k] * t.k1[k];
                    sn += pp[k] * t.k2[k];
                }
                let (sa, ca) = (sn.to_array(), c.to_array());
                let mut psi = [0.0; LANES];
                for l in 0..LANES {
                    psi[l] = sa[l].atan2(ca[l]);
                }
                let psi = V::from_array(psi);
                out[0] += psi * psi * t.half_inv_var;
            }
            spread.add(out[0], x[4]);
        });
        spread.finish()
    }
}

kernel! {
    /// `ll ← −½ ‖z − βᵢ‖²/σ²` (`k = −½σ⁻²`), a direct observation of the bias, and the live spread.
    pub(super) fn loglik_bias<V>(
        z: [f64; 3],
        k: f64,
        bx: &[f64],
        by: &[f64],
        bz: &[f64],
        w: &[f64],
        ll: &mut [f64],
    ) -> Spread {
        let mut spread = Lanes2::<V>::new();
        each8!(V, ll.len(), [bx, by, bz, w], [0.0; 4], [ll], [0.0], |_g, x, out| {
            let d = [V::splat(z[0]) - x[0], V::splat(z[1]) - x[1], V::splat(z[2]) - x[2]];
            out[0] = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * k;
            spread.add(out[0], x[3]);
        });
        spread.finish()
    }
}

/// `[Σw, Σ w q qᵀ]`, the matrix as `xx xy xz xw yy yz yw zz zw ww`.
pub(super) type Average = [f64; 11];

#[inline(always)]
fn average_add<V: V8>(acc: &mut [V; 11], q: &[V], w: V) {
    let (x, y, z, s) = (q[0], q[1], q[2], q[3]);
    let (a, b, c, d) = (x * w, y * w, z * w, s * w);
    acc[0] += w;
    acc[1] += a * x;
    acc[2] += a * y;
    acc[3] += a * z;
    acc[4] += a * s;
    acc[5] += b * y;
    acc[6] += b * z;
    acc[7] += b * s;
    acc[8] += c * z;
    acc[9] += c * s;
    acc[10] += d * s;
}

kernel! {
    /// The weight update of one progressive-correction stage, `wᵢ ← wᵢ exp(min(0, λ(log Lᵢ − max)))`
    /// (not normalised: [`moments`] does it), and the sums the average needs.
    pub(super) fn weigh<V>(
        lambda: f64,
        max: f64,
        qx: &[f64],
        qy: &[f64],
        qz: &[f64],
        qw: &[f64],
        ll: &[f64],
        w: &mut [f64],
    ) -> Average {
        let mut acc = [V::splat(0.0); 11];
        each8!(V, w.len(), [qx, qy, qz, qw, ll], [0.0, 0.0, 0.0, 1.0, 0.0], [w], [0.0], |_g, x, wn| {
            let a = (x[4] - max) * lambda;
            // A dead particle may lie above the live maximum: its factor is capped at 1.
            let a = V::select(a.gt(V::splat(0.0)), V::splat(0.0), a);
            wn[0] *= a.exp_neg();
            average_add(&mut acc, &x[..4], wn[0]);
        });
        sums(&acc)
    }
}

kernel! {
    /// The sums of [`weigh`] without changing the weights (the average between updates).
    pub(super) fn average_sums<V>(qx: &[f64], qy: &[f64], qz: &[f64], qw: &[f64], w: &[f64]) -> Average {
        let mut acc = [V::splat(0.0); 11];
        each8!(V, w.len(), [qx, qy, qz, qw, w], [0.0, 0.0, 0.0, 1.0, 0.0], [], [], |_g, x, _y| {
            average_add(&mut acc, &x[..4], x[4]);
        });
        sums(&acc)
    }
}

/// `[Σ w x (6), Σ w x xᵀ (21, upper triangle row by row), Σw, Σw²]` of the local states
/// `x = [MRP(q ⊗ fid⁻¹); β − β_ref]`.
pub(super) type Moments = [f64; 29];

/// The chart of the local states: `fid⁻¹` and the bias reference.
#[derive(Clone, Copy, Debug)]
pub(super) struct Local {
    pub fid_inv: [f64; 4],
    pub b_ref: [f64; 3],
}

#[inline(always)]
fn locals<V: V8>(q: [V; 4], b: [V; 3], c: &Local) -> [V; 6] {
    let p = mrp(q, &c.fid_inv);
    [
        p[0],
        p[1],
        p[2],
        b[0] - c.b_ref[0],
        b[1] - c.b_ref[1],
        b[2] - c.b_ref[2],
    ]
}

#[inline(always)]
fn moments_add<V: V8>(acc: &mut [V; 29], x: &[V; 6], w: V) {
    let wx = [w * x[0], w * x[1], w * x[2], w * x[3], w * x[4], w * x[5]];
    let mut k = 6;
    for r in 0..6 {
        acc[r] += wx[r];
        for col in r..6 {
            acc[k] += wx[r] * x[col];
            k += 1;
        }
    }
    acc[27] += w;
    acc[28] += w * w;
}

kernel! {
    /// The weighted moments of the local states about a chart, normalising the weights on the way
    /// (`wᵢ ← scale · wᵢ`; `scale = 1/Σw` after a weight update, else 1).
    pub(super) fn moments<V>(
        c: &Local,
        scale: f64,
        q: [&[f64]; 4],
        b: [&[f64]; 3],
        w: &mut [f64],
    ) -> Moments {
        let mut acc = [V::splat(0.0); 29];
        let [qx, qy, qz, qw] = q;
        let [bx, by, bz] = b;
        each8!(V, w.len(), [qx, qy, qz, qw, bx, by, bz], CLOUD_PAD, [w], [0.0], |_g, v, wn| {
            wn[0] = wn[0] * scale;
            let x = locals([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6]], c);
            moments_add(&mut acc, &x, wn[0]);
        });
        sums(&acc)
    }
}

kernel! {
    /// [`moments`] without writing the weights (an estimate between updates).
    pub(super) fn moments_of<V>(c: &Local, q: [&[f64]; 4], b: [&[f64]; 3], w: &[f64]) -> Moments {
        let mut acc = [V::splat(0.0); 29];
        let [qx, qy, qz, qw] = q;
        let [bx, by, bz] = b;
        let pad = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        each8!(V, w.len(), [qx, qy, qz, qw, bx, by, bz, w], pad, [], [], |_g, v, _y| {
            let x = locals([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6]], c);
            moments_add(&mut acc, &x, v[7]);
        });
        sums(&acc)
    }
}

/// The regularisation of one resampling (`update.rs`): `xᵢ ← m + s (a (x_src(i) − m) + h D εᵢ)`.
pub(super) struct Regularisation<'a> {
    pub local: Local,
    pub m: [f64; 6],
    /// `D` (lower triangle, row by row: 21).
    pub d: [f64; 21],
    pub a: f64,
    pub s: f64,
    pub h: f64,
    /// `Some` for the Epanechnikov kernel (`r² ~ Beta(3, 2)`), drawn lane by lane.
    pub beta: Option<&'a Beta<f64>>,
    pub src: [&'a [f64]; 7],
}

kernel! {
    /// One block of the regulariser: the new particles' local states into `x` (six columns), from
    /// the resampled sources `idx`; returns their sums (for the mean-preserving shift). Normals laid out
    /// as in [`propagate`], but all 48 rows drawn: particle `8g + l` of a group of 64 takes lane `l` of
    /// rows `6g..6g + 6`.
    pub(super) fn regularise<V>(
        key: u64,
        block: u64,
        r: &Regularisation<'_>,
        idx: &[u32],
        x0: &mut [f64],
        x1: &mut [f64],
        x2: &mut [f64],
        x3: &mut [f64],
        x4: &mut [f64],
        x5: &mut [f64],
    ) -> [f64; 6] {
        let z = ziggurat();
        let mut lanes = Lanes::keyed(key, block);
        let mut normals = [[0.0; LANES]; 6 * GROUP];
        let mut words = [[0u64; LANES]; 6 * GROUP];
        let mut acc = [V::splat(0.0); 6];
        let n = idx.len();
        let mut start = 0;
        while start < n {
            let end = (start + GROUP * LANES).min(n);
            match r.beta {
                None => z.fill::<V>(&mut lanes, &mut normals, &mut words),
                Some(beta) => {
                    for g in 0..GROUP {
                        for l in 0..LANES {
                            let mut gen = lanes.lane(l);
                            let e = super::options::epanechnikov_draw(&mut gen, beta);
                            lanes.set_lane(l, &gen);
                            for k in 0..6 {
                                normals[6 * g + k][l] = e[k];
                            }
                        }
                    }
                }
            }
            let m = end - start;
            let (y0, y1, y2) = (&mut x0[start..], &mut x1[start..], &mut x2[start..]);
            let (y3, y4, y5) = (&mut x3[start..], &mut x4[start..], &mut x5[start..]);
            each8!(V, m, [], [], [y0, y1, y2, y3, y4, y5], [0.0; 6], |g, _x, out| {
                let mut q = [[0.0; LANES], [0.0; LANES], [0.0; LANES], [1.0; LANES]];
                let mut b = [[0.0; LANES]; 3];
                let here = LANES.min(m - LANES * g);
                for l in 0..here {
                    let j = idx[start + LANES * g + l] as usize;
                    for k in 0..4 {
                        q[k][l] = r.src[k][j];
                    }
                    for k in 0..3 {
                        b[k][l] = r.src[4 + k][j];
                    }
                }
                let q = [
                    V::from_array(q[0]),
                    V::from_array(q[1]),
                    V::from_array(q[2]),
                    V::from_array(q[3]),
                ];
                let b = [V::from_array(b[0]), V::from_array(b[1]), V::from_array(b[2])];
                let x = locals(q, b, &r.local);
                let eps = &normals[6 * g..6 * g + 6];
                let mut k = 0;
                for row in 0..6 {
                    let mut de = V::splat(0.0);
                    for e in eps.iter().take(row + 1) {
                        de += V::load(e) * r.d[k];
                        k += 1;
                    }
                    out[row] = ((x[row] - r.m[row]) * r.a + de * r.h) * r.s + r.m[row];
                }
                let lane = V::from_array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
                let live = V::splat(here as f64).gt(lane);
                for row in 0..6 {
                    // (Lanes past the end add exactly 0.)
                    acc[row] += V::select(live, out[row], V::splat(0.0));
                }
            });
            start = end;
        }
        sums(&acc)
    }
}

kernel! {
    /// The regularised local states (in `qx qy qz bx by bz`), shifted by `shift`, back to particles:
    /// `q = MRP⁻¹(δp) ⊗ fid`, `β = x + β_ref`.
    pub(super) fn rebuild<V>(
        fid: [f64; 4],
        shift: [f64; 6],
        b_ref: [f64; 3],
        qx: &mut [f64],
        qy: &mut [f64],
        qz: &mut [f64],
        qw: &mut [f64],
        bx: &mut [f64],
        by: &mut [f64],
        bz: &mut [f64],
    ) {
        each8!(V, qx.len(), [], [], [qx, qy, qz, qw, bx, by, bz], CLOUD_PAD, |_g, _x, c| {
            let p = [c[0] + shift[0], c[1] + shift[1], c[2] + shift[2]];
            let q = from_mrp(p, &fid);
            c[..4].copy_from_slice(&q);
            for k in 0..3 {
                c[4 + k] += V::splat(shift[3 + k] + b_ref[k]);
            }
        });
    }
}
