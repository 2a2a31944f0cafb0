//! Lane-wise arithmetic: the same operation on several independent contacts
//! at once, in SIMD registers.
//!
//! The contact laws are written once, generic over a [`Real`] number type:
//! `f64` evaluates one contact (walls, and the tail of the pair list), and
//! [`F64x4`] four (the pair kernel). Every lane operation is the IEEE operation
//! the scalar code does, in the same order — sums and products are never
//! fused or reassociated, and [`Vec3L::dot`], [`Vec3L::cross`] and
//! [`Vec3L::norm_squared`] follow nalgebra's formulas — so a lane gives bit
//! for bit the result of evaluating its contact alone, whatever the lane count
//! or the SIMD width the build uses. Branches become selects: both sides are
//! computed and each lane keeps its own.

use crate::dem::vec3::Vec3;
use std::ops::{Add, Div, Mul, Neg, Sub};
use wide::{CmpEq, CmpGe, CmpGt, CmpLe};

/// Four f64 lanes (one AVX register, or two SSE2 registers).
pub type F64x4 = wide::f64x4;

/// The most lanes any [`Real`] has: the size of the fixed scratch arrays
/// that gather per-lane records (histories, particle records) for a batch.
pub const MAX_LANES: usize = 4;
const _: () = assert!(<F64x4 as Real>::LANES <= MAX_LANES);

/// A number type holding [`Real::LANES`] f64 lanes, with lane-wise IEEE
/// arithmetic and comparisons that are false for NaN (as `f64`'s are).
pub trait Real:
    Copy
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A flag per lane.
    type Mask: Copy;
    /// Number of lanes.
    const LANES: usize;
    /// `v` in every lane.
    fn splat(v: f64) -> Self;
    /// `f(l)` in lane `l`.
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    /// Lane `l`.
    fn lane(self, l: usize) -> f64;
    /// Square roots.
    fn sqrt(self) -> Self;
    /// Absolute values.
    fn abs(self) -> Self;
    /// `self > o` per lane.
    fn gt(self, o: Self) -> Self::Mask;
    /// `self >= o` per lane.
    fn ge(self, o: Self) -> Self::Mask;
    /// `self <= o` per lane.
    fn le(self, o: Self) -> Self::Mask;
    /// `self == o` per lane.
    fn eq(self, o: Self) -> Self::Mask;
    /// Per lane, `yes` where `m` is set and `no` elsewhere.
    fn select(m: Self::Mask, yes: Self, no: Self) -> Self;
    /// Lane-wise and.
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// Lane-wise not.
    fn not(a: Self::Mask) -> Self::Mask;
    /// Whether any lane is set.
    fn any(m: Self::Mask) -> bool;
    /// Lane `l` of a mask.
    fn flag(m: Self::Mask, l: usize) -> bool;
    /// A mask with `p(l)` in lane `l`.
    fn mask_from_fn(p: impl FnMut(usize) -> bool) -> Self::Mask;
}

impl Real for f64 {
    type Mask = bool;
    const LANES: usize = 1;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _: usize) -> f64 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: Self) -> bool {
        self >= o
    }
    #[inline(always)]
    fn le(self, o: Self) -> bool {
        self <= o
    }
    #[inline(always)]
    fn eq(self, o: Self) -> bool {
        self == o
    }
    #[inline(always)]
    fn select(m: bool, yes: Self, no: Self) -> Self {
        if m {
            yes
        } else {
            no
        }
    }
    #[inline(always)]
    fn and(a: bool, b: bool) -> bool {
        a && b
    }
    #[inline(always)]
    fn not(a: bool) -> bool {
        !a
    }
    #[inline(always)]
    fn any(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn flag(m: bool, _: usize) -> bool {
        m
    }
    #[inline(always)]
    fn mask_from_fn(mut p: impl FnMut(usize) -> bool) -> bool {
        p(0)
    }
}

impl Real for F64x4 {
    /// All bits set in a lane that is true.
    type Mask = F64x4;
    const LANES: usize = 4;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        F64x4::splat(v)
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self {
        F64x4::new(std::array::from_fn(f))
    }
    #[inline(always)]
    fn lane(self, l: usize) -> f64 {
        self.as_array_ref()[l]
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F64x4::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F64x4::abs(self)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self {
        self.cmp_gt(o)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self {
        self.cmp_ge(o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self {
        self.cmp_le(o)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Self {
        self.cmp_eq(o)
    }
    #[inline(always)]
    fn select(m: Self, yes: Self, no: Self) -> Self {
        m.blend(yes, no)
    }
    #[inline(always)]
    fn and(a: Self, b: Self) -> Self {
        a & b
    }
    #[inline(always)]
    fn not(a: Self) -> Self {
        !a
    }
    #[inline(always)]
    fn any(m: Self) -> bool {
        F64x4::any(m)
    }
    #[inline(always)]
    fn flag(m: Self, l: usize) -> bool {
        m.move_mask() & (1 << l) != 0
    }
    #[inline(always)]
    fn mask_from_fn(mut p: impl FnMut(usize) -> bool) -> Self {
        let all = f64::from_bits(u64::MAX);
        F64x4::new(std::array::from_fn(|l| if p(l) { all } else { 0.0 }))
    }
}

/// Whether this processor runs AVX-512 (F, VL, DQ, BW and CD: x86-64-v4).
///
/// The pair kernel then runs a copy of itself compiled for it
/// (`simulation::pair_kernel`): the same four-lane AVX arithmetic, but with
/// 32 vector registers instead of 16, so its live state (about 20 vectors of
/// four contacts) no longer spills to the stack. The copy performs the same
/// IEEE operations in the same order, so results are bit-identical either way.
pub fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512vl")
            && std::is_x86_feature_detected!("avx512dq")
            && std::is_x86_feature_detected!("avx512bw")
            && std::is_x86_feature_detected!("avx512cd")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The instruction set the pair kernel runs on here, for reports: AVX-512
/// when [`has_avx512`], else the one this build was compiled for.
pub fn pair_kernel_isa() -> &'static str {
    if has_avx512() {
        "avx512"
    } else if cfg!(target_feature = "avx2") {
        "avx2"
    } else {
        "baseline"
    }
}

/// 3-vectors stored component by component, one per lane (m, m/s, N, ... as
/// the variable using it says).
#[derive(Clone, Copy, Debug)]
pub struct Vec3L<T: Real> {
    /// x components.
    pub x: T,
    /// y components.
    pub y: T,
    /// z components.
    pub z: T,
}

impl<T: Real> Vec3L<T> {
    /// The zero vector in every lane.
    #[inline(always)]
    pub fn zeros() -> Self {
        Self::splat(Vec3::zeros())
    }

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        Self {
            x: T::splat(v.x),
            y: T::splat(v.y),
            z: T::splat(v.z),
        }
    }

    /// Gathers one vector per lane.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> Vec3) -> Self {
        let v: [Vec3; MAX_LANES] =
            std::array::from_fn(|l| if l < T::LANES { f(l) } else { Vec3::zeros() });
        Self {
            x: T::from_fn(|l| v[l].x),
            y: T::from_fn(|l| v[l].y),
            z: T::from_fn(|l| v[l].z),
        }
    }

    /// Lane `l` as a vector.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Vec3 {
        Vec3::new(self.x.lane(l), self.y.lane(l), self.z.lane(l))
    }

    /// Each lane's vector times that lane's scalar (`v * s`).
    #[inline(always)]
    pub fn scale(&self, s: T) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    /// Dot products `(ax bx + ay by) + az bz`, nalgebra's order.
    #[inline(always)]
    pub fn dot(&self, o: &Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Squared lengths, as nalgebra's `norm_squared` (`0 + dot(v, v)`, which
    /// equals `dot(v, v)` bit for bit).
    #[inline(always)]
    pub fn norm_squared(&self) -> T {
        self.dot(self)
    }

    /// Lengths, `√norm_squared`.
    #[inline(always)]
    pub fn norm(&self) -> T {
        self.norm_squared().sqrt()
    }

    /// Cross products `self × o`, nalgebra's formula.
    #[inline(always)]
    pub fn cross(&self, o: &Self) -> Self {
        Self {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }

    /// Per lane, `self` where `m` is set and `other` elsewhere.
    #[inline(always)]
    pub fn select(&self, m: T::Mask, other: &Self) -> Self {
        Self {
            x: T::select(m, self.x, other.x),
            y: T::select(m, self.y, other.y),
            z: T::select(m, self.z, other.z),
        }
    }
}

impl<T: Real> Add for Vec3L<T> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl<T: Real> Sub for Vec3L<T> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

impl<T: Real> Neg for Vec3L<T> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vectors with awkward magnitudes, so any reordering of a sum would show.
    fn samples() -> [Vec3; 4] {
        [
            Vec3::new(1e-3, -2.7e-7, 3.3),
            Vec3::new(-0.1, 0.7, 1e16),
            Vec3::new(1.0 / 3.0, 2.0 / 7.0, -5.0 / 11.0),
            Vec3::new(0.0, -0.0, 1e-300),
        ]
    }

    #[test]
    fn four_lanes_match_nalgebra_bit_for_bit() {
        let a = samples();
        let mut b = samples();
        b.rotate_left(1);
        let la = Vec3L::<F64x4>::from_fn(|l| a[l]);
        let lb = Vec3L::<F64x4>::from_fn(|l| b[l]);
        let s = F64x4::new([0.5, -3.0, 1e-9, 7.0]);
        for l in 0..4 {
            assert_eq!(la.dot(&lb).lane(l).to_bits(), a[l].dot(&b[l]).to_bits());
            assert_eq!(
                la.norm_squared().lane(l).to_bits(),
                a[l].norm_squared().to_bits()
            );
            assert_eq!(la.norm().lane(l).to_bits(), a[l].norm().to_bits());
            assert_eq!(la.cross(&lb).lane(l), a[l].cross(&b[l]));
            assert_eq!((la + lb).lane(l), a[l] + b[l]);
            assert_eq!((la - lb).lane(l), a[l] - b[l]);
            assert_eq!((-la).lane(l), -a[l]);
            assert_eq!(la.scale(s).lane(l), a[l] * s.lane(l));
            assert_eq!(
                (s / s.sqrt()).lane(l).to_bits(),
                (s.lane(l) / s.lane(l).sqrt()).to_bits()
            );
        }
    }

    #[test]
    fn masks_behave_like_f64_comparisons_including_nan() {
        let x = F64x4::new([1.0, f64::NAN, 0.0, -2.0]);
        let zero = F64x4::splat(0.0);
        for l in 0..4 {
            let v = x.lane(l);
            assert_eq!(F64x4::flag(x.gt(zero), l), v > 0.0);
            assert_eq!(F64x4::flag(x.le(zero), l), v <= 0.0);
            assert_eq!(F64x4::flag(x.ge(zero), l), v >= 0.0);
            assert_eq!(F64x4::flag(x.eq(zero), l), v == 0.0);
            assert_eq!(
                F64x4::flag(F64x4::not(x.le(zero)), l),
                v > 0.0 || v.is_nan()
            );
        }
        let m = F64x4::mask_from_fn(|l| l % 2 == 0);
        let picked = F64x4::select(m, x, zero);
        assert_eq!(picked.lane(0), 1.0);
        assert_eq!(picked.lane(1), 0.0);
        assert!(F64x4::flag(F64x4::and(m, x.gt(zero)), 0));
        assert!(!F64x4::flag(F64x4::and(m, x.gt(zero)), 2));
    }
}
