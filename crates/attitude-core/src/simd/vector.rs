//! Eight `f64` lanes in three representations: [`F8`] (plain arrays: any target), [`Y8`] (two AVX2
//! registers) and [`Z8`] (one AVX-512 register). Kernels are generic over [`V8`]; each operation is
//! the same correctly rounded IEEE operation in every representation, so a kernel gives the same bits
//! in each (writing lanes as `[f64; 8]` loops and hoping for the auto-vectoriser gave code that mixed
//! widths and shuffled more than it computed).
//!
//! [`Y8`] and [`Z8`] are built only inside functions compiled with their instruction set and called
//! after detecting it (`simd::kernel!`): that is what makes their `unsafe` blocks sound.

use super::LANES;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Sub};

/// Lane conditions of a [`V8`].
pub trait Mask: Copy {
    fn and(self, o: Self) -> Self;
    fn any(self) -> bool;
    fn all(self) -> bool;
}

/// Eight `f64` lanes.
pub trait V8:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + AddAssign
    + MulAssign
{
    type M: Mask;
    fn splat(x: f64) -> Self;
    /// The first eight values of `s`.
    fn load(s: &[f64]) -> Self;
    fn from_array(a: [f64; LANES]) -> Self;
    fn to_array(self) -> [f64; LANES];
    fn lt(self, o: Self) -> Self::M;
    fn gt(self, o: Self) -> Self::M;
    /// `a` where `m`, else `b`.
    fn select(m: Self::M, a: Self, b: Self) -> Self;
    /// The lanes with these bits.
    fn from_bits(b: [u64; LANES]) -> Self;
    /// The lanes' bits XOR `b` (a sign flip with `1 << 63`).
    fn xor_bits(self, b: [u64; LANES]) -> Self;
    /// `(t[i][0], t[i][1])` for the lanes' indices `i`.
    fn lookup_pairs(t: &[[f64; 2]], i: &[usize; LANES]) -> (Self, Self);
    /// `2ⁿ` from `z = n + 1.5·2⁵²` (the bits of `n` in the low mantissa): `(bits(z) + 1023) << 52`.
    fn pow2_shifted(z: Self) -> Self;

    /// The lanes added in a fixed order.
    #[inline(always)]
    fn sum(self) -> f64 {
        let a = self.to_array();
        ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))
    }

    /// A scalar function lane by lane (the rare paths: libm, series fallbacks).
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self::from_array(self.to_array().map(f))
    }

    /// [`super::exp_neg`] on every lane, the same operations in the same order.
    #[inline(always)]
    fn exp_neg(self) -> Self {
        use super::exp_consts::*;
        let x = self;
        let z = x * LOG2E + SHIFT;
        let n = z - SHIFT;
        let r = (x - n * LN2_HI) - n * LN2_LO;
        let mut p = Self::splat(TAYLOR[0]);
        for c in &TAYLOR[1..] {
            p = p * r + *c;
        }
        let y = p * Self::pow2_shifted(z);
        Self::select(x.lt(Self::splat(CUT)), Self::splat(0.0), y)
    }
}

/// Eight lanes as a plain array: the portable representation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F8(pub [f64; LANES]);

impl Mask for [bool; LANES] {
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        std::array::from_fn(|l| self[l] & o[l])
    }
    #[inline(always)]
    fn any(self) -> bool {
        self.iter().any(|b| *b)
    }
    #[inline(always)]
    fn all(self) -> bool {
        self.iter().all(|b| *b)
    }
}

impl V8 for F8 {
    type M = [bool; LANES];
    #[inline(always)]
    fn splat(x: f64) -> Self {
        F8([x; LANES])
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        F8(std::array::from_fn(|l| s[l]))
    }
    #[inline(always)]
    fn from_array(a: [f64; LANES]) -> Self {
        F8(a)
    }
    #[inline(always)]
    fn to_array(self) -> [f64; LANES] {
        self.0
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self::M {
        std::array::from_fn(|l| self.0[l] < o.0[l])
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::M {
        std::array::from_fn(|l| self.0[l] > o.0[l])
    }
    #[inline(always)]
    fn select(m: Self::M, a: Self, b: Self) -> Self {
        F8(std::array::from_fn(|l| if m[l] { a.0[l] } else { b.0[l] }))
    }
    #[inline(always)]
    fn from_bits(b: [u64; LANES]) -> Self {
        F8(b.map(f64::from_bits))
    }
    #[inline(always)]
    fn xor_bits(self, b: [u64; LANES]) -> Self {
        F8(std::array::from_fn(|l| {
            f64::from_bits(self.0[l].to_bits() ^ b[l])
        }))
    }
    #[inline(always)]
    fn lookup_pairs(t: &[[f64; 2]], i: &[usize; LANES]) -> (Self, Self) {
        (
            F8(std::array::from_fn(|l| t[i[l]][0])),
            F8(std::array::from_fn(|l| t[i[l]][1])),
        )
    }
    #[inline(always)]
    fn pow2_shifted(z: Self) -> Self {
        F8(z.0.map(|z| f64::from_bits(z.to_bits().wrapping_add(1023) << 52)))
    }
}

macro_rules! f8_ops {
    ($($tr:ident $f:ident $op:tt),*) => {$(
        impl $tr for F8 {
            type Output = F8;
            #[inline(always)]
            fn $f(self, o: F8) -> F8 {
                F8(std::array::from_fn(|l| self.0[l] $op o.0[l]))
            }
        }
        impl $tr<f64> for F8 {
            type Output = F8;
            #[inline(always)]
            fn $f(self, o: f64) -> F8 {
                F8(std::array::from_fn(|l| self.0[l] $op o))
            }
        }
    )*};
}
f8_ops!(Add add +, Sub sub -, Mul mul *, Div div /);

impl AddAssign for F8 {
    #[inline(always)]
    fn add_assign(&mut self, o: F8) {
        *self = *self + o;
    }
}

impl MulAssign for F8 {
    #[inline(always)]
    fn mul_assign(&mut self, o: F8) {
        *self = *self * o;
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    /// Two AVX2 registers.
    #[derive(Clone, Copy, Debug)]
    pub struct Y8(__m256d, __m256d);

    /// AVX2 lane conditions (all ones where true).
    #[derive(Clone, Copy, Debug)]
    pub struct Y8M(__m256d, __m256d);

    // SAFETY (every `unsafe` block of Y8): only called inside functions compiled with AVX2 and run
    // after detecting it (`simd::kernel!`); loads read eight values that `load` checked exist.
    impl Mask for Y8M {
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            unsafe { Y8M(_mm256_and_pd(self.0, o.0), _mm256_and_pd(self.1, o.1)) }
        }
        #[inline(always)]
        fn any(self) -> bool {
            unsafe { (_mm256_movemask_pd(self.0) | _mm256_movemask_pd(self.1)) != 0 }
        }
        #[inline(always)]
        fn all(self) -> bool {
            unsafe { (_mm256_movemask_pd(self.0) & _mm256_movemask_pd(self.1)) == 0xf }
        }
    }

    impl V8 for Y8 {
        type M = Y8M;
        #[inline(always)]
        fn splat(x: f64) -> Self {
            unsafe { Y8(_mm256_set1_pd(x), _mm256_set1_pd(x)) }
        }
        #[inline(always)]
        fn load(s: &[f64]) -> Self {
            let s = &s[..LANES];
            unsafe {
                Y8(
                    _mm256_loadu_pd(s.as_ptr()),
                    _mm256_loadu_pd(s[4..].as_ptr()),
                )
            }
        }
        #[inline(always)]
        fn from_array(a: [f64; LANES]) -> Self {
            Self::load(&a)
        }
        #[inline(always)]
        fn to_array(self) -> [f64; LANES] {
            let mut a = [0.0; LANES];
            unsafe {
                _mm256_storeu_pd(a.as_mut_ptr(), self.0);
                _mm256_storeu_pd(a[4..].as_mut_ptr(), self.1);
            }
            a
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Y8M {
            unsafe {
                Y8M(
                    _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, o.0),
                    _mm256_cmp_pd::<_CMP_LT_OQ>(self.1, o.1),
                )
            }
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Y8M {
            unsafe {
                Y8M(
                    _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0),
                    _mm256_cmp_pd::<_CMP_GT_OQ>(self.1, o.1),
                )
            }
        }
        #[inline(always)]
        fn select(m: Y8M, a: Self, b: Self) -> Self {
            unsafe {
                Y8(
                    _mm256_blendv_pd(b.0, a.0, m.0),
                    _mm256_blendv_pd(b.1, a.1, m.1),
                )
            }
        }
        #[inline(always)]
        fn from_bits(b: [u64; LANES]) -> Self {
            unsafe {
                let p = b.as_ptr() as *const __m256i;
                Y8(
                    _mm256_castsi256_pd(_mm256_loadu_si256(p)),
                    _mm256_castsi256_pd(_mm256_loadu_si256(p.add(1))),
                )
            }
        }
        #[inline(always)]
        fn xor_bits(self, b: [u64; LANES]) -> Self {
            let m = Self::from_bits(b);
            unsafe { Y8(_mm256_xor_pd(self.0, m.0), _mm256_xor_pd(self.1, m.1)) }
        }
        #[inline(always)]
        fn lookup_pairs(t: &[[f64; 2]], i: &[usize; LANES]) -> (Self, Self) {
            // Four 16-byte loads per half: [a0 b0 | a1 b1], [a2 b2 | a3 b3] → unpack, reorder.
            #[inline(always)]
            fn half(t: &[[f64; 2]], i: &[usize]) -> (__m256d, __m256d) {
                let p = [&t[i[0]], &t[i[1]], &t[i[2]], &t[i[3]]];
                unsafe {
                    let lo = _mm256_insertf128_pd::<1>(
                        _mm256_castpd128_pd256(_mm_loadu_pd(p[0].as_ptr())),
                        _mm_loadu_pd(p[1].as_ptr()),
                    );
                    let hi = _mm256_insertf128_pd::<1>(
                        _mm256_castpd128_pd256(_mm_loadu_pd(p[2].as_ptr())),
                        _mm_loadu_pd(p[3].as_ptr()),
                    );
                    // [a0 a2 | a1 a3] and [b0 b2 | b1 b3], then lanes 0 2 1 3.
                    let a = _mm256_unpacklo_pd(lo, hi);
                    let b = _mm256_unpackhi_pd(lo, hi);
                    (
                        _mm256_permute4x64_pd::<0b11_01_10_00>(a),
                        _mm256_permute4x64_pd::<0b11_01_10_00>(b),
                    )
                }
            }
            let (a0, b0) = half(t, &i[..4]);
            let (a1, b1) = half(t, &i[4..]);
            (Y8(a0, a1), Y8(b0, b1))
        }
        #[inline(always)]
        fn pow2_shifted(z: Self) -> Self {
            #[inline(always)]
            fn half(v: __m256d) -> __m256d {
                unsafe {
                    _mm256_castsi256_pd(_mm256_slli_epi64::<52>(_mm256_add_epi64(
                        _mm256_castpd_si256(v),
                        _mm256_set1_epi64x(1023),
                    )))
                }
            }
            Y8(half(z.0), half(z.1))
        }
    }

    macro_rules! y8_ops {
        ($($tr:ident $f:ident $intr:ident),*) => {$(
            impl $tr for Y8 {
                type Output = Y8;
                #[inline(always)]
                fn $f(self, o: Y8) -> Y8 {
                    unsafe { Y8($intr(self.0, o.0), $intr(self.1, o.1)) }
                }
            }
            impl $tr<f64> for Y8 {
                type Output = Y8;
                #[inline(always)]
                fn $f(self, o: f64) -> Y8 {
                    self.$f(Y8::splat(o))
                }
            }
        )*};
    }
    y8_ops!(Add add _mm256_add_pd, Sub sub _mm256_sub_pd, Mul mul _mm256_mul_pd, Div div _mm256_div_pd);

    impl AddAssign for Y8 {
        #[inline(always)]
        fn add_assign(&mut self, o: Y8) {
            *self = *self + o;
        }
    }

    impl MulAssign for Y8 {
        #[inline(always)]
        fn mul_assign(&mut self, o: Y8) {
            *self = *self * o;
        }
    }

    /// One AVX-512 register.
    #[derive(Clone, Copy, Debug)]
    pub struct Z8(__m512d);

    /// AVX-512 lane conditions: a mask register.
    #[derive(Clone, Copy, Debug)]
    pub struct Z8M(__mmask8);

    impl Mask for Z8M {
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            Z8M(self.0 & o.0)
        }
        #[inline(always)]
        fn any(self) -> bool {
            self.0 != 0
        }
        #[inline(always)]
        fn all(self) -> bool {
            self.0 == 0xff
        }
    }

    // SAFETY (every `unsafe` block of Z8): only called inside functions compiled with AVX-512 F/DQ/VL
    // and run after detecting them (`simd::kernel!`); loads read eight values that `load` checked.
    impl V8 for Z8 {
        type M = Z8M;
        #[inline(always)]
        fn splat(x: f64) -> Self {
            unsafe { Z8(_mm512_set1_pd(x)) }
        }
        #[inline(always)]
        fn load(s: &[f64]) -> Self {
            let s = &s[..LANES];
            unsafe { Z8(_mm512_loadu_pd(s.as_ptr())) }
        }
        #[inline(always)]
        fn from_array(a: [f64; LANES]) -> Self {
            Self::load(&a)
        }
        #[inline(always)]
        fn to_array(self) -> [f64; LANES] {
            let mut a = [0.0; LANES];
            unsafe { _mm512_storeu_pd(a.as_mut_ptr(), self.0) };
            a
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Z8M {
            unsafe { Z8M(_mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, o.0)) }
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Z8M {
            unsafe { Z8M(_mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, o.0)) }
        }
        #[inline(always)]
        fn select(m: Z8M, a: Self, b: Self) -> Self {
            unsafe { Z8(_mm512_mask_blend_pd(m.0, b.0, a.0)) }
        }
        #[inline(always)]
        fn from_bits(b: [u64; LANES]) -> Self {
            unsafe {
                Z8(_mm512_castsi512_pd(_mm512_loadu_si512(
                    b.as_ptr() as *const __m512i
                )))
            }
        }
        #[inline(always)]
        fn xor_bits(self, b: [u64; LANES]) -> Self {
            unsafe {
                let m = _mm512_loadu_si512(b.as_ptr() as *const __m512i);
                Z8(_mm512_castsi512_pd(_mm512_xor_si512(
                    _mm512_castpd_si512(self.0),
                    m,
                )))
            }
        }
        #[inline(always)]
        fn lookup_pairs(t: &[[f64; 2]], i: &[usize; LANES]) -> (Self, Self) {
            let p: [&[f64; 2]; LANES] = [
                &t[i[0]], &t[i[1]], &t[i[2]], &t[i[3]], &t[i[4]], &t[i[5]], &t[i[6]], &t[i[7]],
            ];
            #[inline(always)]
            fn quad(p: &[&[f64; 2]]) -> __m512d {
                unsafe {
                    let mut v = _mm512_castpd128_pd512(_mm_loadu_pd(p[0].as_ptr()));
                    v = _mm512_insertf64x2::<1>(v, _mm_loadu_pd(p[1].as_ptr()));
                    v = _mm512_insertf64x2::<2>(v, _mm_loadu_pd(p[2].as_ptr()));
                    _mm512_insertf64x2::<3>(v, _mm_loadu_pd(p[3].as_ptr()))
                }
            }
            unsafe {
                let (lo, hi) = (quad(&p[..4]), quad(&p[4..]));
                let even = _mm512_set_epi64(14, 12, 10, 8, 6, 4, 2, 0);
                let odd = _mm512_set_epi64(15, 13, 11, 9, 7, 5, 3, 1);
                (
                    Z8(_mm512_permutex2var_pd(lo, even, hi)),
                    Z8(_mm512_permutex2var_pd(lo, odd, hi)),
                )
            }
        }
        #[inline(always)]
        fn pow2_shifted(z: Self) -> Self {
            unsafe {
                Z8(_mm512_castsi512_pd(_mm512_slli_epi64::<52>(
                    _mm512_add_epi64(_mm512_castpd_si512(z.0), _mm512_set1_epi64(1023)),
                )))
            }
        }
    }

    macro_rules! z8_ops {
        ($($tr:ident $f:ident $intr:ident),*) => {$(
            impl $tr for Z8 {
                type Output = Z8;
                #[inline(always)]
                fn $f(self, o: Z8) -> Z8 {
                    unsafe { Z8($intr(self.0, o.0)) }
                }
            }
            impl $tr<f64> for Z8 {
                type Output = Z8;
                #[inline(always)]
                fn $f(self, o: f64) -> Z8 {
                    self.$f(Z8::splat(o))
                }
            }
        )*};
    }
    z8_ops!(Add add _mm512_add_pd, Sub sub _mm512_sub_pd, Mul mul _mm512_mul_pd, Div div _mm512_div_pd);

    impl AddAssign for Z8 {
        #[inline(always)]
        fn add_assign(&mut self, o: Z8) {
            *self = *self + o;
        }
    }

    impl MulAssign for Z8 {
        #[inline(always)]
        fn mul_assign(&mut self, o: Z8) {
            *self = *self * o;
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub use x86::{Y8, Z8};
