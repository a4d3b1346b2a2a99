//! Seeded randomness and stable hashes, each in one place:
//!
//! * [`derive_seed`] (SplitMix64): independent seeds from one seed and a stream index (a study's
//!   runs, the simulator's vehicles);
//! * [`fnv1a`] and [`splitmix64_mix`]: stable 64-bit hashes (a vehicle's filter seed and sample
//!   fingerprints, a fleet's rendezvous weights); the same on every machine and in every version;
//! * [`Xoshiro256PlusPlus`]: the generator of the particle filter and the simulator (Blackman & Vigna),
//!   bit for bit the one of the `rand_xoshiro` crate (pinned by a test against it), with its state
//!   readable and settable so that a checkpoint can save and restore it without serde in the core;
//! * fast standard-normal draws for the particle filter: the Ziggurat method (Marsaglia & Tsang 2000,
//!   in Doornik's 128-layer form) on one 64-bit draw per sample on the fast path (≈ 99% of draws): 53
//!   bits of uniform and the layer index from the low 7 bits. Seedable and deterministic through the
//!   RNG.

use rand::RngCore;
use std::sync::LazyLock;

/// The 64-bit FNV-1a offset basis: the hash of no bytes, where a hash starts.
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0100_0000_01b3;

/// 64-bit FNV-1a of `bytes`, continuing from `h` ([`FNV_OFFSET`] for a fresh hash; a previous result to
/// hash more bytes after it).
#[inline]
pub fn fnv1a(bytes: impl IntoIterator<Item = u8>, mut h: u64) -> u64 {
    for b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(FNV_PRIME);
    }
    h
}

/// SplitMix64's increment (2⁶⁴ / φ).
const GOLDEN_GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

/// SplitMix64's output function (Stafford's Mix13): a bijection of `u64` whose every input bit moves
/// about half the output bits.
#[inline]
pub fn splitmix64_mix(z: u64) -> u64 {
    let z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// SplitMix64: output number `stream + 1` of the generator seeded with `seed`, used as an independent
/// seed for stream `stream`.
pub fn derive_seed(seed: u64, stream: u64) -> u64 {
    splitmix64_mix(
        seed.wrapping_add(stream.wrapping_mul(GOLDEN_GAMMA))
            .wrapping_add(GOLDEN_GAMMA),
    )
}

/// Xoshiro256++ (Blackman & Vigna 2019): 256 bits of state, period 2²⁵⁶ − 1, the same output stream
/// as `rand_xoshiro::Xoshiro256PlusPlus` for the same seed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Xoshiro256PlusPlus {
    s: [u64; 4],
}

impl Xoshiro256PlusPlus {
    /// The generator in state `s` (as [`Xoshiro256PlusPlus::state`] returned it); `None` for the
    /// all-zero state, which the generator never leaves.
    pub fn from_state(s: [u64; 4]) -> Option<Self> {
        (s != [0; 4]).then_some(Xoshiro256PlusPlus { s })
    }

    /// The 256-bit state (what a checkpoint saves).
    pub fn state(&self) -> [u64; 4] {
        self.s
    }

    /// Advances the generator by 2¹²⁸ draws (independent sub-streams).
    pub fn jump(&mut self) {
        const JUMP: [u64; 4] = [
            0x180e_c6d3_3cfd_0aba,
            0xd5a6_1266_f0c9_392c,
            0xa958_2618_e03f_c9aa,
            0x39ab_dc45_29b1_661c,
        ];
        let mut acc = [0u64; 4];
        for word in JUMP {
            for bit in 0..64 {
                if word & (1u64 << bit) != 0 {
                    for (a, s) in acc.iter_mut().zip(self.s) {
                        *a ^= s;
                    }
                }
                self.next_u64();
            }
        }
        self.s = acc;
    }
}

impl rand::SeedableRng for Xoshiro256PlusPlus {
    type Seed = [u8; 32];

    fn from_seed(seed: [u8; 32]) -> Self {
        let mut s = [0u64; 4];
        for (i, w) in s.iter_mut().enumerate() {
            *w = u64::from_le_bytes(seed[8 * i..8 * i + 8].try_into().expect("8 bytes"));
        }
        Self::from_state(s).unwrap_or_else(|| Self::seed_from_u64(0))
    }

    /// The state is four successive outputs of SplitMix64 seeded with `seed` (as `rand_xoshiro` does).
    fn seed_from_u64(seed: u64) -> Self {
        let mut x = seed;
        let s = std::array::from_fn(|_| {
            x = x.wrapping_add(GOLDEN_GAMMA);
            splitmix64_mix(x)
        });
        Xoshiro256PlusPlus { s }
    }
}

impl RngCore for Xoshiro256PlusPlus {
    #[inline]
    fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    #[inline]
    fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let out = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        out
    }

    fn fill_bytes(&mut self, dest: &mut [u8]) {
        for chunk in dest.chunks_mut(8) {
            let b = self.next_u64().to_le_bytes();
            chunk.copy_from_slice(&b[..chunk.len()]);
        }
    }
}

const LAYERS: usize = 128;
/// Start of the tail, and the area of each layer (Doornik 2005, "An improved ziggurat method").
const R: f64 = 3.442_619_855_899;
const V: f64 = 9.912_563_035_262_17e-3;

struct Tables {
    /// Layer right edges `x[0..=LAYERS]` (`x[0] = V / f(R)`, `x[1] = R`, `x[LAYERS] = 0`).
    x: [f64; LAYERS + 1],
    /// `x[i+1] / x[i]`: below it a draw is inside the layer's rectangle.
    ratio: [f64; LAYERS],
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
    let mut ratio = [0.0; LAYERS];
    for i in 0..LAYERS {
        ratio[i] = x[i + 1] / x[i];
    }
    Tables { x, ratio }
});

/// A uniform in [0, 1) from 53 bits.
#[inline(always)]
fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// The sampler: a handle on the tables, taken once outside a hot loop.
#[derive(Clone, Copy)]
pub struct Ziggurat(&'static Tables);

/// The shared sampler (the tables are built on first use).
pub fn ziggurat() -> Ziggurat {
    Ziggurat(&TABLES)
}

impl Ziggurat {
    /// One standard normal draw.
    #[inline(always)]
    pub fn sample<G: RngCore + ?Sized>(&self, rng: &mut G) -> f64 {
        let t = self.0;
        loop {
            let bits = rng.next_u64();
            let i = (bits & 0x7f) as usize;
            // u in (−1, 1) from the top 53 bits.
            let u = 2.0 * unit(bits) - 1.0;
            if u.abs() < t.ratio[i] {
                return u * t.x[i];
            }
            if let Some(x) = slow_path(t, rng, i, u) {
                return x;
            }
        }
    }
}

impl Ziggurat {
    /// Two standard normal draws from one 64-bit draw on the fast path: each 32-bit half gives the
    /// layer (7 bits) and a 25-bit signed uniform (Marsaglia & Tsang's original 32-bit form). The
    /// 2⁻²⁴ resolution is far below anything a filter's process noise can resolve.
    #[inline(always)]
    pub fn sample_pair<G: RngCore + ?Sized>(&self, rng: &mut G) -> (f64, f64) {
        let bits = rng.next_u64();
        let a = self.from_u32(bits as u32, rng);
        let b = self.from_u32((bits >> 32) as u32, rng);
        (a, b)
    }

    #[inline(always)]
    fn from_u32<G: RngCore + ?Sized>(&self, word: u32, rng: &mut G) -> f64 {
        let t = self.0;
        let i = (word & 0x7f) as usize;
        // The top 25 bits as a signed integer: u in [−1, 1).
        let u = ((word as i32) >> 7) as f64 * (1.0 / (1u32 << 24) as f64);
        if u.abs() < t.ratio[i] {
            return u * t.x[i];
        }
        match slow_path(t, rng, i, u) {
            Some(x) => x,
            None => self.sample(rng),
        }
    }
}

/// One standard normal draw (takes the tables on every call: use [`Ziggurat`] in loops).
#[inline]
pub fn standard_normal<G: RngCore + ?Sized>(rng: &mut G) -> f64 {
    ziggurat().sample(rng)
}

/// Outside a layer's rectangle: the tail (layer 0) or the wedge test; `None` means draw again.
#[cold]
#[inline(never)]
fn slow_path<G: RngCore + ?Sized>(t: &Tables, rng: &mut G, i: usize, u: f64) -> Option<f64> {
    if i == 0 {
        return Some(tail(rng, u < 0.0));
    }
    let x = u * t.x[i];
    let f0 = (-0.5 * (t.x[i] * t.x[i] - x * x)).exp();
    let f1 = (-0.5 * (t.x[i + 1] * t.x[i + 1] - x * x)).exp();
    (f1 + unit(rng.next_u64()) * (f0 - f1) < 1.0).then_some(x)
}

/// The tail beyond `R` (Marsaglia 1964).
#[cold]
fn tail<G: RngCore + ?Sized>(rng: &mut G, negative: bool) -> f64 {
    loop {
        // 1 − unit() is in (0, 1]: the logarithm is finite.
        let x = (1.0 - unit(rng.next_u64())).ln() / R;
        let y = (1.0 - unit(rng.next_u64())).ln();
        if -2.0 * y >= x * x {
            return if negative { x - R } else { R - x };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Our generator against the `rand_xoshiro` crate's, over seeds, `u64`/`u32` draws, byte fills
    /// and a state round trip.
    #[test]
    fn xoshiro_is_rand_xoshiros_stream() {
        for seed in [0u64, 1, 7, 42, 0xdead_beef, u64::MAX] {
            let mut ours = Xoshiro256PlusPlus::seed_from_u64(seed);
            let mut theirs = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
            for _ in 0..1000 {
                assert_eq!(ours.next_u64(), theirs.next_u64());
            }
            assert_eq!(ours.next_u32(), theirs.next_u32());
            let (mut a, mut b) = ([0u8; 29], [0u8; 29]);
            ours.fill_bytes(&mut a);
            theirs.fill_bytes(&mut b);
            assert_eq!(a, b);
            let mut copy = Xoshiro256PlusPlus::from_state(ours.state()).unwrap();
            let next = theirs.next_u64();
            assert_eq!(copy.next_u64(), next);
            assert_eq!(ours.next_u64(), next);
        }
        let seed: [u8; 32] = std::array::from_fn(|i| i as u8 * 7 + 1);
        let mut ours = Xoshiro256PlusPlus::from_seed(seed);
        let mut theirs = rand_xoshiro::Xoshiro256PlusPlus::from_seed(seed);
        assert_eq!(ours.next_u64(), theirs.next_u64());
        assert!(Xoshiro256PlusPlus::from_state([0; 4]).is_none());
        ours.jump();
        theirs.jump();
        assert_eq!(ours.next_u64(), theirs.next_u64());
    }

    #[test]
    fn moments_and_tails_of_a_million_draws() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(42);
        let n = 1_000_000;
        let (mut s1, mut s2, mut s3, mut s4) = (0.0, 0.0, 0.0, 0.0);
        let (mut beyond2, mut beyond3, mut beyond4) = (0usize, 0usize, 0usize);
        for _ in 0..n {
            let x = standard_normal(&mut rng);
            s1 += x;
            s2 += x * x;
            s3 += x * x * x;
            s4 += x * x * x * x;
            beyond2 += (x.abs() > 2.0) as usize;
            beyond3 += (x.abs() > 3.0) as usize;
            beyond4 += (x.abs() > R) as usize;
        }
        let nf = n as f64;
        // Standard errors: mean 1e-3, variance 1.4e-3, skewness 2.4e-3, kurtosis 4.9e-3 (×5 here).
        assert!((s1 / nf).abs() < 5e-3, "mean {}", s1 / nf);
        assert!((s2 / nf - 1.0).abs() < 7e-3, "variance {}", s2 / nf);
        assert!((s3 / nf).abs() < 1.2e-2, "third moment {}", s3 / nf);
        assert!((s4 / nf - 3.0).abs() < 5e-2, "fourth moment {}", s4 / nf);
        // P(|x| > 2) = 0.0455, P(|x| > 3) = 0.0027, P(|x| > R) = 5.76e-4.
        assert!((beyond2 as f64 / nf - 0.0455).abs() < 1.2e-3);
        assert!((beyond3 as f64 / nf - 0.0027).abs() < 2.6e-4);
        assert!(
            (beyond4 as f64 / nf - 5.76e-4).abs() < 1.2e-4,
            "tail {}",
            beyond4 as f64 / nf
        );
    }

    #[test]
    fn pairs_have_the_same_distribution() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let z = ziggurat();
        let n = 500_000;
        let (mut s1, mut s2, mut s4, mut cross, mut beyond3) = (0.0, 0.0, 0.0, 0.0, 0usize);
        for _ in 0..n {
            let (a, b) = z.sample_pair(&mut rng);
            for x in [a, b] {
                s1 += x;
                s2 += x * x;
                s4 += x * x * x * x;
                beyond3 += (x.abs() > 3.0) as usize;
            }
            cross += a * b;
        }
        let m = 2.0 * n as f64;
        assert!((s1 / m).abs() < 5e-3);
        assert!((s2 / m - 1.0).abs() < 7e-3, "variance {}", s2 / m);
        assert!((s4 / m - 3.0).abs() < 5e-2, "fourth moment {}", s4 / m);
        assert!(
            (cross / n as f64).abs() < 7e-3,
            "the two halves are independent"
        );
        assert!((beyond3 as f64 / m - 0.0027).abs() < 3e-4);
    }

    /// Published FNV-1a and SplitMix64 values, and the seeds and hashes this project has always
    /// derived (a vehicle's filter seed, a fleet weight, a study's run seed): pinned, since checkpoints,
    /// determinism tests and mixed-version fleets depend on them.
    #[test]
    fn hashes_and_seeds_are_pinned() {
        // FNV-1a test vectors (Fowler, Noll, Vo).
        assert_eq!(fnv1a(*b"", FNV_OFFSET), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(*b"a", FNV_OFFSET), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(*b"foobar", FNV_OFFSET), 0x8594_4171_f739_67e8);
        assert_eq!(
            fnv1a(*b"bar", fnv1a(*b"foo", FNV_OFFSET)),
            fnv1a(*b"foobar", FNV_OFFSET)
        );
        // SplitMix64 seeded with 0: its first output (Vigna's reference implementation).
        assert_eq!(derive_seed(0, 0), 0xe220_a839_7b1d_cdaf);
        // This project's values: the particle-filter seed of vehicle `sc1` (generations 0 and 1),
        // a study's run seeds, and a fleet's rendezvous weight.
        let vehicle_seed = |id: &str, generation: u64| {
            fnv1a(id.bytes().chain(generation.to_le_bytes()), FNV_OFFSET)
        };
        assert_eq!(vehicle_seed("sc1", 0), 0xe0a6_35dd_d1ba_bde6);
        assert_eq!(vehicle_seed("sc1", 1), 0xffa0_fce6_dcaa_0807);
        assert_eq!(derive_seed(1, 0), 0x910a_2dec_8902_5cc1);
        assert_eq!(derive_seed(42, 1000), 0x5566_dbe8_93f1_b4ae);
        assert_eq!(
            splitmix64_mix(fnv1a(b"i1\xffsc1".iter().copied(), FNV_OFFSET)),
            0x76c0_7c5e_3764_3fa5
        );
    }

    #[test]
    fn derived_seeds_differ() {
        let a: Vec<u64> = (0..100).map(|r| derive_seed(1, r)).collect();
        let mut b = a.clone();
        b.sort();
        b.dedup();
        assert_eq!(a.len(), b.len());
        assert_ne!(derive_seed(1, 0), derive_seed(2, 0));
    }

    #[test]
    fn deterministic_for_a_seed() {
        let draw = |seed| {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
            (0..10)
                .map(|_| standard_normal(&mut rng))
                .collect::<Vec<_>>()
        };
        assert_eq!(draw(1), draw(1));
        assert_ne!(draw(1), draw(2));
    }
}
