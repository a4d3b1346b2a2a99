//! Standard normal draws for the particle filter: the Ziggurat method (Marsaglia & Tsang 2000, with
//! Doornik's fixes) with 1024 layers, one 64-bit draw per sample: the layer from the low 10 bits, the
//! sign from bit 10, a 52-bit uniform from the top bits. 99.57% of draws end on the fast path (two
//! table lookups, a comparison and a product); the rest take the exact slow path (the tail beyond
//! `R`, or the wedge test). More layers than the usual 128 or 256 because a rejection costs the
//! vectorised path far more than a lookup (1.5% of draws with 256 layers cost a fifth of a
//! propagation); the tables (24 KB) stay in L1.
//!
//! [`Ziggurat::fill`] draws on eight generators side by side ([`Lanes`]): the fast path for all lanes
//! at once (vectorisable), and the rare rejections afterwards, in a fixed order, from a ninth scalar
//! generator of the same block. So what a lane draws does not depend on the vector width, and a
//! rejection costs no pass over the others.

use super::{derive_seed, Xoshiro256PlusPlus};
use crate::simd::{exp_neg, Mask, LANES, V8};
use rand::RngCore;
use std::sync::LazyLock;

const LAYERS: usize = 1024;
/// Start of the tail, and the area of each layer: `V = R f(R) + ∫_R^∞ f`, `R` such that the top
/// layer's area is `V` too (solved by bisection as in Marsaglia & Tsang 2000; the same solver gives
/// their 128- and 256-layer constants to 12 digits, and the top layer's area matches `V` to 4e-12).
const R: f64 = 4.038_849_846_109_505;
const V: f64 = 0.001_226_324_646_353_085_2;

struct Tables {
    /// Layer right edges `x[0..=LAYERS]` (`x[0] = V / f(R)`, `x[1] = R`, `x[LAYERS] = 0`).
    x: [f64; LAYERS + 1],
    /// `[x[i], x[i+1] / x[i]]` side by side (one 16-byte load per lane in [`Ziggurat::fill`]): the
    /// layer's width, and the uniform below which a draw is inside the layer's rectangle.
    edge: [[f64; 2]; LAYERS],
    /// `f(x[i]) / f(x[i+1])`, the wedge test's lower end relative to its upper one.
    wedge: [f64; LAYERS],
}

static TABLES: LazyLock<Tables> = LazyLock::new(|| {
    let mut x = [0.0; LAYERS + 1];
    let mut f = (-0.5 * R * R).exp();
    x[0] = V / f;
    x[1] = R;
    for i in 2..LAYERS {
        x[i] = (-2.0 * (V / x[i - 1] + f).ln()).sqrt();
        f = (-0.5 * x[i] * x[i]).exp();
    }
    x[LAYERS] = 0.0;
    let edge = std::array::from_fn(|i| [x[i], x[i + 1] / x[i]]);
    let wedge = std::array::from_fn(|i| exp_neg(-0.5 * (x[i] * x[i] - x[i + 1] * x[i + 1])));
    Tables { x, edge, wedge }
});

/// A uniform in [0, 1) from the top 53 bits.
#[inline(always)]
fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// The fast path of one 64-bit draw: `(value, accepted)`. `u ∈ [0, 1)` is exact from the top 52 bits
/// (as an `f64` in [1, 2) minus 1: no integer conversion, which AVX2 lacks for 64 bits).
#[inline(always)]
fn fast(t: &Tables, w: u64) -> (f64, bool) {
    let [x, ratio] = t.edge[(w & 0x3ff) as usize];
    let u = f64::from_bits(0x3ff0_0000_0000_0000 | (w >> 12)) - 1.0;
    let v = f64::from_bits((u * x).to_bits() | ((w >> 10) & 1) << 63);
    (v, u < ratio)
}

/// After a rejection of draw `w`: the tail (layer 0) or the wedge test, with further uniforms from
/// `rng`; `None` means draw again.
#[cold]
#[inline(never)]
fn slow_path<G: RngCore + ?Sized>(t: &Tables, rng: &mut G, w: u64) -> Option<f64> {
    let i = (w & 0x3ff) as usize;
    let negative = (w >> 10) & 1 == 1;
    let u = f64::from_bits(0x3ff0_0000_0000_0000 | (w >> 12)) - 1.0;
    let x = if i == 0 {
        tail(rng)
    } else {
        // f(x_{i+1}) + U (f(x_i) − f(x_{i+1})) < f(x), relative to f(x_{i+1}): both exponents ≤ 0.
        let (x, xn) = (u * t.x[i], t.x[i + 1]);
        let fx = exp_neg(-0.5 * (x * x - xn * xn));
        if !(1.0 + unit(rng.next_u64()) * (t.wedge[i] - 1.0) < fx) {
            return None;
        }
        x
    };
    Some(if negative { -x } else { x })
}

/// The tail beyond `R` (Marsaglia 1964), positive.
#[cold]
fn tail<G: RngCore + ?Sized>(rng: &mut G) -> f64 {
    loop {
        // 1 − unit() is in (0, 1]: the logarithm is finite.
        let x = (1.0 - unit(rng.next_u64())).ln() / R;
        let y = (1.0 - unit(rng.next_u64())).ln();
        if -2.0 * y >= x * x {
            return R - x;
        }
    }
}

/// The sampler: a handle on the tables, taken once outside a hot loop.
#[derive(Clone, Copy)]
pub struct Ziggurat(&'static Tables);

/// The shared sampler (the tables are built on first use).
pub fn ziggurat() -> Ziggurat {
    Ziggurat(&TABLES)
}

/// One standard normal draw (takes the tables on every call: use [`Ziggurat`] in loops).
#[inline]
pub fn standard_normal<G: RngCore + ?Sized>(rng: &mut G) -> f64 {
    ziggurat().sample(rng)
}

impl Ziggurat {
    /// One standard normal draw.
    #[inline(always)]
    pub fn sample<G: RngCore + ?Sized>(&self, rng: &mut G) -> f64 {
        loop {
            let w = rng.next_u64();
            let (v, ok) = fast(self.0, w);
            if ok {
                return v;
            }
            if let Some(x) = slow_path(self.0, rng, w) {
                return x;
            }
        }
    }

    /// Fills `out` with standard normals: `out[k][l]` from lane `l`'s `k`-th draw (its fast path),
    /// or, where that was rejected, from the block's fix-up generator, rejections taken in the order
    /// `(k, l)`. `words` is scratch of `out`'s length (the draws, kept for the fix-up); at most 128
    /// rows.
    #[inline(always)]
    pub fn fill<W: V8>(
        &self,
        lanes: &mut Lanes,
        out: &mut [[f64; LANES]],
        words: &mut [[u64; LANES]],
    ) {
        assert!(
            out.len() <= 128 && words.len() == out.len(),
            "at most 128 rows"
        );
        let t = self.0;
        let mut s = lanes.s;
        let mut rows = [0u64; 2];
        for (k, (row, kept)) in out.iter_mut().zip(words.iter_mut()).enumerate() {
            let w = step(&mut s);
            let (mut idx, mut unit, mut sign) = ([0usize; LANES], [0u64; LANES], [0u64; LANES]);
            for l in 0..LANES {
                idx[l] = (w[l] & 0x3ff) as usize;
                unit[l] = 0x3ff0_0000_0000_0000 | (w[l] >> 12);
                sign[l] = ((w[l] >> 10) & 1) << 63;
            }
            // As `fast`, on lanes; the lookups as one 16-byte load per lane (cheaper than gathers).
            let u = W::from_bits(unit) - 1.0;
            let (x, ratio) = W::lookup_pairs(&t.edge, &idx);
            *row = (u * x).xor_bits(sign).to_array();
            let any = !u.lt(ratio).all();
            *kept = w;
            // Which rows need the fix-up, without a branch per row.
            rows[(k / 64) % 2] |= (any as u64) << (k % 64);
        }
        lanes.s = s;
        if rows != [0, 0] {
            self.fix_up(&mut lanes.fix, out, words, rows);
        }
    }

    #[cold]
    #[inline(never)]
    fn fix_up(
        &self,
        fix: &mut Xoshiro256PlusPlus,
        out: &mut [[f64; LANES]],
        words: &[[u64; LANES]],
        rows: [u64; 2],
    ) {
        debug_assert!(out.len() <= 128);
        for (half, mut m) in rows.into_iter().enumerate() {
            while m != 0 {
                let k = 64 * half + m.trailing_zeros() as usize;
                m &= m - 1;
                for l in 0..LANES {
                    if !fast(self.0, words[k][l]).1 {
                        out[k][l] = match slow_path(self.0, fix, words[k][l]) {
                            Some(x) => x,
                            None => self.sample(fix),
                        };
                    }
                }
            }
        }
    }
}

crate::simd::kernel! {
    /// Standard normals into `out` (rows of eight lanes) from the lanes of stream `stream` of `key`, as
    /// the particle filter draws them ([`Ziggurat::fill`], 48 rows at a time): for benchmarks and
    /// tests of the instruction sets.
    pub fn fill_normals<V>(key: u64, stream: u64, out: &mut [[f64; LANES]]) {
        let z = ziggurat();
        let mut lanes = Lanes::keyed(key, stream);
        let mut words = [[0u64; LANES]; 48];
        for rows in out.chunks_mut(48) {
            let n = rows.len();
            z.fill::<V>(&mut lanes, rows, &mut words[..n]);
        }
    }
}

/// Eight Xoshiro256++ generators side by side (structure of arrays) and the fix-up generator of
/// their block, for kernels that draw for eight particles at once: lane `l` is an ordinary
/// [`Xoshiro256PlusPlus`] ([`Lanes::lane`]), so what a vectorised kernel draws on it is what the
/// scalar generator gives, whatever the vector width.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Lanes {
    s: [[u64; LANES]; 4],
    fix: Xoshiro256PlusPlus,
}

/// One Xoshiro256++ step on every lane (vectorisable).
#[inline(always)]
fn step(s: &mut [[u64; LANES]; 4]) -> [u64; LANES] {
    let [s0, s1, s2, s3] = s;
    let mut out = [0u64; LANES];
    for l in 0..LANES {
        out[l] = s0[l]
            .wrapping_add(s3[l])
            .rotate_left(23)
            .wrapping_add(s0[l]);
        let t = s1[l] << 17;
        s2[l] ^= s0[l];
        s3[l] ^= s1[l];
        s1[l] ^= s2[l];
        s0[l] ^= s3[l];
        s2[l] ^= t;
        s3[l] = s3[l].rotate_left(45);
    }
    out
}

impl Lanes {
    /// Stream `stream` of a pass keyed `key`: generator `g` (lanes 0–7, then the fix-up generator
    /// 8) is the one seeded (as [`rand::SeedableRng::seed_from_u64`]) with
    /// [`derive_seed`]`(key, 9·stream + g)`. A pass takes one key from its filter's generator and one
    /// stream per block of particles, so no lane state is kept between passes (a checkpoint holds the
    /// filter's generator only) and a block draws the same numbers whichever thread runs it.
    pub fn keyed(key: u64, stream: u64) -> Lanes {
        let seeded = |g: u64| {
            <Xoshiro256PlusPlus as rand::SeedableRng>::seed_from_u64(derive_seed(
                key,
                stream.wrapping_mul(LANES as u64 + 1).wrapping_add(g),
            ))
        };
        let mut s = [[0u64; LANES]; 4];
        for l in 0..LANES {
            for (k, w) in seeded(l as u64).s.iter().enumerate() {
                s[k][l] = *w;
            }
        }
        Lanes {
            s,
            fix: seeded(LANES as u64),
        }
    }

    /// The next output of every lane.
    #[inline(always)]
    pub fn next(&mut self) -> [u64; LANES] {
        step(&mut self.s)
    }

    /// Lane `l` as a scalar generator.
    pub fn lane(&self, l: usize) -> Xoshiro256PlusPlus {
        Xoshiro256PlusPlus {
            s: [self.s[0][l], self.s[1][l], self.s[2][l], self.s[3][l]],
        }
    }

    pub fn set_lane(&mut self, l: usize, g: &Xoshiro256PlusPlus) {
        for k in 0..4 {
            self.s[k][l] = g.s[k];
        }
    }

    /// The fix-up generator.
    pub fn fix_up(&mut self) -> &mut Xoshiro256PlusPlus {
        &mut self.fix
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn moments_and_tails_of_a_million_draws() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(42);
        let draws: Vec<f64> = (0..1_000_000).map(|_| standard_normal(&mut rng)).collect();
        check_standard_normal(&draws);
    }

    /// Mean, variance, skewness, kurtosis and tail frequencies of `draws` (≈ 10⁶) against N(0, 1).
    fn check_standard_normal(draws: &[f64]) {
        let (mut s1, mut s2, mut s3, mut s4) = (0.0, 0.0, 0.0, 0.0);
        let (mut beyond2, mut beyond3, mut beyond_r) = (0usize, 0usize, 0usize);
        for &x in draws {
            s1 += x;
            s2 += x * x;
            s3 += x * x * x;
            s4 += x * x * x * x;
            beyond2 += (x.abs() > 2.0) as usize;
            beyond3 += (x.abs() > 3.0) as usize;
            beyond_r += (x.abs() > R) as usize;
        }
        let nf = draws.len() as f64;
        // Standard errors at 10⁶: mean 1e-3, variance 1.4e-3, skewness 2.4e-3, kurtosis 4.9e-3 (×5 here).
        assert!((s1 / nf).abs() < 5e-3, "mean {}", s1 / nf);
        assert!((s2 / nf - 1.0).abs() < 7e-3, "variance {}", s2 / nf);
        assert!((s3 / nf).abs() < 1.2e-2, "third moment {}", s3 / nf);
        assert!((s4 / nf - 3.0).abs() < 5e-2, "fourth moment {}", s4 / nf);
        // P(|x| > 2) = 0.0455, P(|x| > 3) = 0.0027, P(|x| > R) = 5.37e-5.
        assert!((beyond2 as f64 / nf - 0.0455).abs() < 1.2e-3);
        assert!((beyond3 as f64 / nf - 0.0027).abs() < 2.6e-4);
        assert!(
            (beyond_r as f64 / nf - 5.37e-5).abs() < 3.5e-5,
            "tail {}",
            beyond_r as f64 / nf
        );
    }

    /// The lanes of [`Ziggurat::fill`] are independent streams of N(0, 1), and each lane's draws are
    /// its scalar generator's fast paths, with the rejections from the fix-up generator in order.
    #[test]
    fn filled_lanes_are_the_scalar_streams() {
        let z = ziggurat();
        let mut lanes = Lanes::keyed(7, 3);
        let mut scalar: Vec<Xoshiro256PlusPlus> = (0..LANES).map(|l| lanes.lane(l)).collect();
        let mut fix = lanes.fix.clone();
        let mut all = Vec::new();
        let (mut out, mut rej) = (vec![[0.0; LANES]; 48], vec![[0u64; LANES]; 48]);
        let mut cross = 0.0;
        for _ in 0..2700 {
            z.fill::<crate::simd::F8>(&mut lanes, &mut out, &mut rej);
            for row in &out {
                for (l, v) in row.iter().enumerate() {
                    let w = scalar[l].next_u64();
                    let (fv, ok) = fast(z.0, w);
                    let expected = if ok {
                        fv
                    } else {
                        slow_path(z.0, &mut fix, w).unwrap_or_else(|| z.sample(&mut fix))
                    };
                    assert_eq!(v.to_bits(), expected.to_bits());
                    all.push(*v);
                }
                cross += row[0] * row[1];
            }
        }
        check_standard_normal(&all);
        let rows = (2700 * 48) as f64;
        assert!((cross / rows).abs() < 1.5e-2, "lanes 0 and 1 correlate");
        assert_eq!(lanes.lane(5), scalar[5]);
        assert_eq!(lanes.fix, fix);
    }

    #[test]
    fn every_instruction_set_draws_the_same_normals() {
        use crate::simd::Isa;
        let mut base = vec![[0.0; LANES]; 1000];
        fill_normals(Isa::Portable, 11, 2, &mut base);
        for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
            let mut rows = vec![[0.0; LANES]; 1000];
            fill_normals(isa, 11, 2, &mut rows);
            let same = rows
                .iter()
                .flatten()
                .zip(base.iter().flatten())
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{isa:?}");
        }
    }

    #[test]
    fn keyed_streams_differ_and_repeat() {
        assert_eq!(Lanes::keyed(1, 0), Lanes::keyed(1, 0));
        assert_ne!(Lanes::keyed(1, 0), Lanes::keyed(1, 1));
        assert_ne!(Lanes::keyed(1, 0), Lanes::keyed(2, 0));
        let l = Lanes::keyed(1, 0);
        assert_ne!(l.lane(0), l.lane(1));
    }
}
