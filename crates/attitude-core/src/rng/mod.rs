//! Seeded randomness and stable hashes, each in one place:
//!
//! * [`derive_seed`] (SplitMix64): independent seeds from one seed and a stream index (a study's
//!   runs, the simulator's vehicles);
//! * [`fnv1a`] and [`splitmix64_mix`]: stable 64-bit hashes (a vehicle's filter seed and sample
//!   fingerprints, a fleet's rendezvous weights); the same on every machine and in every version;
//! * [`Xoshiro256PlusPlus`]: the generator of the particle filter and the simulator (Blackman & Vigna),
//!   bit for bit the one of the `rand_xoshiro` crate (pinned by a test against it), with its state
//!   readable and settable so that a checkpoint can save and restore it without serde in the core;
//! * `normal`: fast standard-normal draws for the particle filter (a Ziggurat), one generator at a
//!   time or eight side by side ([`Lanes`]) for vectorised kernels.

mod normal;

pub use normal::{fill_normals, standard_normal, ziggurat, Lanes, Ziggurat};
use rand::RngCore;

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

/// [`fnv1a`] of the eight little-endian bytes of `x`, continuing from `h`: the same value, without an
/// iterator per byte (a vector set's fingerprint hashes 21 numbers per estimate).
#[inline]
pub fn fnv1a_u64(x: u64, mut h: u64) -> u64 {
    for i in 0..8 {
        h ^= (x >> (8 * i)) & 0xff;
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// FNV-1a's published 64-bit vectors ("" and "a", "foobar"), and the word form equal to the bytes'.
    #[test]
    fn fnv1a_is_the_published_hash_and_the_word_form_the_same() {
        assert_eq!(fnv1a(*b"", FNV_OFFSET), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(*b"a", FNV_OFFSET), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(*b"foobar", FNV_OFFSET), 0x8594_4171_f739_67e8);
        for (i, x) in [
            0u64,
            1,
            0x80,
            u64::MAX,
            0x0123_4567_89ab_cdef,
            1.5f64.to_bits(),
        ]
        .into_iter()
        .enumerate()
        {
            let h = FNV_OFFSET ^ i as u64;
            assert_eq!(fnv1a_u64(x, h), fnv1a(x.to_le_bytes(), h), "{x:#x}");
        }
    }

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
}
