//! Kernels compiled once per instruction set and chosen at run time, and the pieces they share.
//!
//! A kernel is written once, generic over [`V8`] (eight `f64` lanes): [`F8`] plain arrays, `Y8`
//! two AVX2 registers, `Z8` one AVX-512 register. The `kernel!` macro compiles the body for each,
//! inside a function with that instruction set enabled, and calls the one [`Isa::active`] names.
//! Every operation is a correctly rounded IEEE one (add, sub, mul, div, compare, select, bit
//! moves): no FMA anywhere (Rust never contracts `a * b + c`, and no fused intrinsic is used), no
//! approximate reciprocal, no libm in a vector, reductions in a fixed order. So every path gives the
//! same bits (tested per kernel); only the speed differs.

use std::sync::atomic::{AtomicU8, Ordering};

mod vector;

pub use vector::{Mask, F8, V8};
#[cfg(target_arch = "x86_64")]
pub(crate) use vector::{Y8, Z8};

/// Logical lanes of every kernel, whatever the instruction set: particle `i` is on lane `i mod 8`.
pub const LANES: usize = 8;

/// The instruction sets a kernel is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Isa {
    /// Whatever the target's baseline is (SSE2 on x86-64).
    Portable,
    /// AVX2 and FMA (x86-64-v3).
    Avx2,
    /// AVX-512 F, BW, DQ, VL (x86-64-v4).
    Avx512,
}

impl Isa {
    pub const ALL: [Isa; 3] = [Isa::Portable, Isa::Avx2, Isa::Avx512];

    pub fn name(self) -> &'static str {
        match self {
            Isa::Portable => "portable",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// Whether this machine runs it.
    pub fn supported(self) -> bool {
        match self {
            Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                Isa::Avx2.supported()
                    && std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512bw")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && std::arch::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The widest supported.
    pub fn detected() -> Isa {
        [Isa::Avx512, Isa::Avx2]
            .into_iter()
            .find(|i| i.supported())
            .unwrap_or(Isa::Portable)
    }

    /// What the kernels use: [`Isa::detected`] unless [`Isa::force`] chose another.
    #[inline]
    pub fn active() -> Isa {
        match ACTIVE.load(Ordering::Relaxed) {
            1 => Isa::Portable,
            2 => Isa::Avx2,
            3 => Isa::Avx512,
            _ => {
                let d = Isa::detected();
                ACTIVE.store(d.code(), Ordering::Relaxed);
                d
            }
        }
    }

    /// Makes every kernel of this process use `isa` (benchmarks and tests; the results are the same
    /// bits whatever it is). `None` goes back to the detected one; an unsupported one is refused.
    pub fn force(isa: Option<Isa>) -> Result<(), Isa> {
        let isa = isa.unwrap_or_else(Isa::detected);
        if !isa.supported() {
            return Err(isa);
        }
        ACTIVE.store(isa.code(), Ordering::Relaxed);
        Ok(())
    }

    fn code(self) -> u8 {
        match self {
            Isa::Portable => 1,
            Isa::Avx2 => 2,
            Isa::Avx512 => 3,
        }
    }
}

impl std::str::FromStr for Isa {
    type Err = String;
    fn from_str(s: &str) -> Result<Isa, String> {
        Isa::ALL
            .into_iter()
            .find(|i| i.name() == s)
            .ok_or_else(|| format!("unknown instruction set {s:?} (portable, avx2, avx512)"))
    }
}

static ACTIVE: AtomicU8 = AtomicU8::new(0);

/// `fn name(isa: Isa, args…) -> R { body }`: the body compiled for each instruction set, the one
/// `isa` names called (an unsupported `isa` falls back to the portable build).
macro_rules! kernel {
    ($(#[$m:meta])* $vis:vis fn $name:ident<$v:ident>($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$m])*
        #[allow(clippy::too_many_arguments)]
        $vis fn $name(isa: $crate::simd::Isa, $($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            #[allow(clippy::too_many_arguments)]
            fn body<$v: $crate::simd::V8>($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn avx512($($arg: $ty),*) $(-> $ret)? { body::<$crate::simd::Z8>($($arg),*) }
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn avx2($($arg: $ty),*) $(-> $ret)? { body::<$crate::simd::Y8>($($arg),*) }
            match isa {
                // SAFETY: the instruction set is supported (checked here, cached by std).
                #[cfg(target_arch = "x86_64")]
                $crate::simd::Isa::Avx512 if isa.supported() => unsafe { avx512($($arg),*) },
                // SAFETY: as above.
                #[cfg(target_arch = "x86_64")]
                $crate::simd::Isa::Avx2 if isa.supported() => unsafe { avx2($($arg),*) },
                _ => body::<$crate::simd::F8>($($arg),*),
            }
        }
    };
}
pub(crate) use kernel;

/// The constants of [`exp_neg`] (shared with [`V8::exp_neg`]).
pub(crate) mod exp_consts {
    pub const LOG2E: f64 = std::f64::consts::LOG2_E;
    /// ln 2 split so that `n · LN2_HI` is exact for `|n| < 2²⁰` (Cody & Waite; fdlibm's values).
    pub const LN2_HI: f64 = 6.931_471_803_691_238_2e-1;
    pub const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    /// 1.5·2⁵²: adding it rounds to an integer held in the low mantissa bits.
    pub const SHIFT: f64 = 6_755_399_441_055_744.0;
    /// `1/k!` for `k = 10, 9, …, 0`: Horner's order.
    pub const TAYLOR: [f64; 11] = [
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ];
    /// Below this `e^x` leaves the normal range: 0.
    pub const CUT: f64 = -708.0;
}

/// `e^x` for `x ≤ 0`, vectorisable and the same bits on every machine (no libm): Cody–Waite
/// reduction `x = n ln2 + r`, `|r| ≤ ln2/2`, and the degree-10 Taylor polynomial of `e^r`, whose
/// truncation error is below `0.3466¹¹/11! · e^0.3466 ≈ 3.1e-13`; with rounding the relative error is
/// below `1e-12` (tested against libm). Below `−708` (where `e^x` leaves the normal range) it returns
/// 0; small positive `x` work too, large ones are not its domain (callers clamp to 0); NaN gives NaN.
#[inline(always)]
pub fn exp_neg(x: f64) -> f64 {
    use exp_consts::*;
    let z = x * LOG2E + SHIFT;
    let n = z - SHIFT;
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let mut p = TAYLOR[0];
    for c in &TAYLOR[1..] {
        p = p * r + *c;
    }
    // 2ⁿ from n in the low bits of z: (n + 1023) << 52 (the bits of SHIFT shift out).
    let y = p * f64::from_bits(z.to_bits().wrapping_add(1023) << 52);
    if x < CUT {
        0.0
    } else {
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_is_within_its_bound_of_libm() {
        let mut worst: f64 = 0.0;
        let mut x = 0.0;
        // Dense near 0 (the weights that matter), then every scale down to the cut-off.
        while x > -708.0 {
            let (a, b) = (exp_neg(x), x.exp());
            worst = worst.max(((a - b) / b).abs());
            x -= if x > -20.0 { 1.37e-4 } else { 0.0137 };
        }
        assert!(worst < 1e-12, "relative error {worst:e}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(-0.0), 1.0);
        assert_eq!(exp_neg(-708.5), 0.0);
        assert_eq!(exp_neg(f64::NEG_INFINITY), 0.0);
        assert!(exp_neg(f64::NAN).is_nan());
        // Monotone across the reduction boundaries, where a careless reduction jumps.
        let mut prev = 1.0;
        for k in 1..200_000 {
            let v = exp_neg(-(k as f64) * 3.4657e-4);
            assert!(v <= prev, "not monotone at {k}");
            prev = v;
        }
    }

    #[test]
    fn isa_names_and_support() {
        assert!(Isa::Portable.supported());
        for isa in Isa::ALL {
            assert_eq!(isa.name().parse::<Isa>(), Ok(isa));
        }
        assert!(Isa::detected().supported());
    }

    kernel! {
        fn exp_lanes<V>(x: &[f64], out: &mut [f64]) {
            for (c, o) in x.chunks_exact(LANES).zip(out.chunks_exact_mut(LANES)) {
                o.copy_from_slice(&V::load(c).exp_neg().to_array());
            }
        }
    }

    #[test]
    fn vector_exp_is_the_scalar_one_on_every_path() {
        let x: Vec<f64> = (0..4096)
            .map(|i| -(i as f64) * 0.19 + 0.001 * (i % 7) as f64)
            .collect();
        for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
            let mut out = vec![0.0; x.len()];
            exp_lanes(isa, &x, &mut out);
            for (a, b) in x.iter().zip(&out) {
                assert_eq!(exp_neg(*a).to_bits(), b.to_bits(), "{isa:?} at {a}");
            }
        }
    }

    kernel! {
        fn sum_of_squares<V>(v: &[f64]) -> f64 {
            let mut acc = V::splat(0.0);
            for c in v.chunks_exact(LANES) {
                let x = V::load(c);
                acc = acc + x * x;
            }
            acc.sum()
        }
    }

    #[test]
    fn every_path_of_a_kernel_gives_the_same_bits() {
        let v: Vec<f64> = (0..1024).map(|i| (i as f64 * 0.37).sin()).collect();
        let base = sum_of_squares(Isa::Portable, &v);
        for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
            assert_eq!(sum_of_squares(isa, &v).to_bits(), base.to_bits(), "{isa:?}");
        }
    }
}
