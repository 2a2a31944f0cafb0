//! The simulation domain: an axis-aligned box with optionally periodic axes.
//!
//! Lengths are metres. On a periodic axis the box length `L = hi − lo` is the
//! period: positions are equivalent modulo `L`, and displacements between
//! particles are taken in the minimum-image convention. On a non-periodic axis
//! the box only bounds where particles may be (see [`Domain::contains`], used by
//! the health check); walls, not the domain, keep particles in.

use crate::dem::lanes::{Real, Vec3L};
use crate::dem::vec3::Vec3;
use std::fmt;

/// Why a [`Domain`] could not be built, or why it cannot host a neighbour search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DomainError {
    /// A bound is NaN or infinite. `field` is `"lo"` or `"hi"`, `axis` is 0 (x), 1 (y)
    /// or 2 (z); `value` in metres.
    NonFinite {
        /// `"lo"` or `"hi"`.
        field: &'static str,
        /// 0 = x, 1 = y, 2 = z.
        axis: usize,
        /// The offending value (m).
        value: f64,
    },
    /// `lo[axis] >= hi[axis]`: the box is empty or inverted on that axis (m).
    EmptyExtent {
        /// 0 = x, 1 = y, 2 = z.
        axis: usize,
        /// `lo[axis]` (m).
        lo: f64,
        /// `hi[axis]` (m).
        hi: f64,
    },
    /// A periodic axis is shorter than twice the neighbour-search cutoff, so a pair
    /// could see two images of each other (minimum image no longer unique).
    PeriodicTooSmall {
        /// 0 = x, 1 = y, 2 = z.
        axis: usize,
        /// Box length on that axis (m).
        length: f64,
        /// Smallest allowed length, 2 × cutoff (m).
        required: f64,
    },
}

const AXIS: [&str; 3] = ["x", "y", "z"];

impl fmt::Display for DomainError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DomainError::NonFinite { field, axis, value } => write!(
                f,
                "domain.{field}[{axis}] ({}) = {value} m: must be finite",
                AXIS[axis]
            ),
            DomainError::EmptyExtent { axis, lo, hi } => write!(
                f,
                "domain.lo[{axis}] = {lo} m must be < domain.hi[{axis}] = {hi} m ({} axis)",
                AXIS[axis]
            ),
            DomainError::PeriodicTooSmall {
                axis,
                length,
                required,
            } => write!(
                f,
                "domain: periodic {} axis has length {length} m but needs at least \
                 {required} m (2 x the neighbour-search cutoff: 2 r_max + extra range + skin)",
                AXIS[axis]
            ),
        }
    }
}

impl std::error::Error for DomainError {}

/// Axis-aligned simulation box `[lo, hi]` (m) with per-axis periodicity.
///
/// Cheap to copy; the neighbour list keeps a copy of the domain it was built in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    lo: Vec3,
    hi: Vec3,
    len: Vec3,
    inv_len: Vec3,
    periodic: [bool; 3],
}

impl Domain {
    /// Builds a box from its lower and upper corners (m) and which axes are periodic.
    ///
    /// Errors: any bound non-finite ([`DomainError::NonFinite`]) or `lo >= hi` on an
    /// axis ([`DomainError::EmptyExtent`]), checked x, y, z in order, `lo` before `hi`.
    pub fn new(lo: Vec3, hi: Vec3, periodic: [bool; 3]) -> Result<Self, DomainError> {
        for axis in 0..3 {
            for (field, v) in [("lo", lo[axis]), ("hi", hi[axis])] {
                if !v.is_finite() {
                    return Err(DomainError::NonFinite {
                        field,
                        axis,
                        value: v,
                    });
                }
            }
            if lo[axis] >= hi[axis] || !(hi[axis] - lo[axis]).is_finite() {
                return Err(DomainError::EmptyExtent {
                    axis,
                    lo: lo[axis],
                    hi: hi[axis],
                });
            }
        }
        let len = hi - lo;
        Ok(Domain {
            lo,
            hi,
            len,
            inv_len: len.map(|l| 1.0 / l),
            periodic,
        })
    }

    /// Lower corner (m).
    #[inline]
    pub fn lo(&self) -> Vec3 {
        self.lo
    }

    /// Upper corner (m).
    #[inline]
    pub fn hi(&self) -> Vec3 {
        self.hi
    }

    /// Box lengths `hi − lo` per axis (m); the period on periodic axes.
    #[inline]
    pub fn lengths(&self) -> Vec3 {
        self.len
    }

    /// Which axes are periodic (x, y, z).
    #[inline]
    pub fn periodic(&self) -> [bool; 3] {
        self.periodic
    }

    /// True when at least one axis is periodic.
    #[inline]
    pub fn any_periodic(&self) -> bool {
        self.periodic.iter().any(|&p| p)
    }

    /// Minimum-image displacement (m): on each periodic axis, `d` shifted by a whole
    /// number of periods into `[−L/2, L/2]`; unchanged on other axes.
    ///
    /// `d` is typically `x_j − x_i`. Exactly half a period is left as is (both images
    /// are equally near). The common case (already within half a period) costs one
    /// comparison per periodic axis; any `d` is handled, however many periods away.
    #[inline]
    pub fn min_image(&self, d: Vec3) -> Vec3 {
        let mut d = d;
        for a in 0..3 {
            if self.periodic[a] {
                let s = d[a] * self.inv_len[a];
                if s.abs() > 0.5 {
                    d[a] -= self.len[a] * s.round();
                    // `round` can leave |d| a rounding error above L/2; fold once more.
                    if d[a] > 0.5 * self.len[a] {
                        d[a] -= self.len[a];
                    } else if d[a] < -0.5 * self.len[a] {
                        d[a] += self.len[a];
                    }
                }
            }
        }
        d
    }

    /// [`min_image`](Self::min_image) of several separations at once (one per
    /// lane), bit for bit. Separations of wrapped positions are under one
    /// period, where the rounding `min_image` does is ±1 and needs no rounding
    /// instruction; should some lane be farther off, every lane takes the
    /// scalar route.
    #[inline(always)]
    pub fn min_image_lanes<T: Real>(&self, d: Vec3L<T>) -> Vec3L<T> {
        let mut axes = [d.x, d.y, d.z];
        for (a, da) in axes.iter_mut().enumerate() {
            if !self.periodic[a] {
                continue;
            }
            let s = *da * T::splat(self.inv_len[a]);
            if T::any(s.abs().ge(T::splat(1.5))) {
                return Vec3L::from_fn(|l| self.min_image(d.lane(l)));
            }
            let (len, half) = (T::splat(self.len[a]), T::splat(0.5 * self.len[a]));
            // round(s) for 0.5 < |s| < 1.5.
            let round = T::select(s.gt(T::splat(0.0)), T::splat(1.0), T::splat(-1.0));
            let shifted = *da - len * round;
            let folded = T::select(
                shifted.gt(half),
                shifted - len,
                T::select((-half).gt(shifted), shifted + len, shifted),
            );
            *da = T::select(s.abs().gt(T::splat(0.5)), folded, *da);
        }
        let [x, y, z] = axes;
        Vec3L { x, y, z }
    }

    /// Position `p` (m) put back into the box on periodic axes: the result lies in
    /// `[lo, hi)` there; other axes are unchanged.
    ///
    /// A point a rounding error below `lo` maps to `lo`, never to `hi`.
    #[inline]
    pub fn wrap(&self, p: Vec3) -> Vec3 {
        let mut p = p;
        for a in 0..3 {
            if self.periodic[a] && !(p[a] >= self.lo[a] && p[a] < self.hi[a]) {
                let r = (p[a] - self.lo[a]).rem_euclid(self.len[a]);
                let w = self.lo[a] + r;
                p[a] = if w >= self.hi[a] { self.lo[a] } else { w };
            }
        }
        p
    }

    /// True when `p` (m) lies inside the box, bounds included, on every non-periodic
    /// axis (periodic axes are not checked). NaN components give `false`.
    ///
    /// Used by the health check to detect particles leaving the domain.
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        (0..3).all(|a| self.periodic[a] || (p[a] >= self.lo[a] && p[a] <= self.hi[a]))
    }

    /// Checks that every periodic axis is at least `2 × cutoff` long (m), so that a
    /// pair closer than `cutoff` has exactly one image within it.
    pub fn check_cutoff(&self, cutoff: f64) -> Result<(), DomainError> {
        for a in 0..3 {
            let required = 2.0 * cutoff;
            // NaN cutoff fails too.
            if self.periodic[a] && (self.len[a] < required || required.is_nan()) {
                return Err(DomainError::PeriodicTooSmall {
                    axis: a,
                    length: self.len[a],
                    required,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn construction_errors_name_the_field() {
        let e = Domain::new(v(0.0, f64::NAN, 0.0), v(1.0, 1.0, 1.0), [false; 3]).unwrap_err();
        assert!(matches!(
            e,
            DomainError::NonFinite {
                field: "lo",
                axis: 1,
                value
            } if value.is_nan()
        ));
        assert!(e.to_string().contains("domain.lo[1]"));
        let e = Domain::new(v(0.0, 0.0, 0.0), v(1.0, 1.0, f64::INFINITY), [false; 3]).unwrap_err();
        assert!(matches!(
            e,
            DomainError::NonFinite {
                field: "hi",
                axis: 2,
                ..
            }
        ));
        assert!(e.to_string().contains("domain.hi[2]"));
        let e = Domain::new(v(0.0, 0.0, 0.0), v(1.0, 0.0, 1.0), [false; 3]).unwrap_err();
        assert_eq!(
            e,
            DomainError::EmptyExtent {
                axis: 1,
                lo: 0.0,
                hi: 0.0
            }
        );
        assert!(e.to_string().contains("domain.lo[1]"));
        let e = Domain::new(v(2.0, 0.0, 0.0), v(1.0, 1.0, 1.0), [true; 3]).unwrap_err();
        assert!(matches!(e, DomainError::EmptyExtent { axis: 0, .. }));
        // Finite bounds whose difference overflows.
        let e = Domain::new(v(-f64::MAX, 0.0, 0.0), v(f64::MAX, 1.0, 1.0), [false; 3]).unwrap_err();
        assert!(matches!(e, DomainError::EmptyExtent { axis: 0, .. }));
    }

    #[test]
    fn min_image_lanes_equal_min_image_bit_for_bit() {
        use crate::dem::lanes::{F64x4, Real, Vec3L};
        let d = Domain::new(v(-1.0, 0.0, 0.0), v(1.3, 3.0, 1.0), [true, true, false]).unwrap();
        let bits = |u: Vec3| [u.x.to_bits(), u.y.to_bits(), u.z.to_bits()];
        // Steps through every regime: inside half a period, near ±L/2 and ±1.5 L
        // (rounding ties), beyond (the scalar route), and a NaN.
        let mut values: Vec<f64> = (-700..700).map(|k| k as f64 * 0.00731).collect();
        values.extend([1.15, -1.15, 3.45, -3.45, 1.5, -4.5, f64::NAN, 0.0, -0.0]);
        for w in values.windows(4) {
            let lanes = Vec3L::<F64x4>::from_fn(|l| v(w[l], w[3 - l] * 0.5, w[l]));
            let got = d.min_image_lanes(lanes);
            for l in 0..F64x4::LANES {
                assert_eq!(
                    bits(got.lane(l)),
                    bits(d.min_image(lanes.lane(l))),
                    "{w:?} lane {l}"
                );
            }
        }
    }

    #[test]
    fn min_image_edge_cases() {
        let d = Domain::new(v(-1.0, 0.0, 0.0), v(1.0, 3.0, 1.0), [true, true, false]).unwrap();
        // Within half a period: unchanged.
        assert_eq!(d.min_image(v(0.9, -1.4, 5.0)), v(0.9, -1.4, 5.0));
        // Exactly half a period: unchanged (both images equally near).
        assert_eq!(d.min_image(v(1.0, -1.5, 0.0)), v(1.0, -1.5, 0.0));
        // Just beyond half a period: folded.
        let m = d.min_image(v(1.25, 1.75, 0.0));
        assert!((m.x - (-0.75)).abs() < 1e-15 && (m.y - (-1.25)).abs() < 1e-15);
        // Several periods away, both signs.
        let m = d.min_image(v(-7.25, 9.5, -40.0));
        assert!((m.x - 0.75).abs() < 1e-12, "{m:?}");
        assert!((m.y - 0.5).abs() < 1e-12, "{m:?}");
        assert_eq!(m.z, -40.0, "non-periodic axis untouched");
        // Result always within [-L/2, L/2].
        for k in -2000..2000 {
            let x = k as f64 * 0.0137;
            let m = d.min_image(v(x, x, x));
            assert!(m.x.abs() <= 1.0 && m.y.abs() <= 1.5, "{x} -> {m:?}");
            assert_eq!(m.z, x);
        }
        // Non-periodic domain: identity.
        let d = Domain::new(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), [false; 3]).unwrap();
        assert_eq!(d.min_image(v(3.0, -3.0, 0.7)), v(3.0, -3.0, 0.7));
    }

    #[test]
    fn wrap_edge_cases() {
        let d = Domain::new(v(-1.0, 0.0, 0.0), v(1.0, 3.0, 1.0), [true, true, false]).unwrap();
        // Inside: unchanged.
        assert_eq!(d.wrap(v(0.3, 2.9, 7.0)), v(0.3, 2.9, 7.0));
        // lo stays, hi maps to lo.
        assert_eq!(d.wrap(v(-1.0, 0.0, 0.0)), v(-1.0, 0.0, 0.0));
        assert_eq!(d.wrap(v(1.0, 3.0, 1.0)), v(-1.0, 0.0, 1.0));
        // A hair below lo maps into [lo, hi), never to hi.
        let w = d.wrap(v(-1.0 - 1e-300, -1e-300, -5.0));
        assert!(w.x >= -1.0 && w.x < 1.0, "{w:?}");
        assert!(w.y >= 0.0 && w.y < 3.0, "{w:?}");
        assert_eq!(w.z, -5.0);
        let w = d.wrap(v(-1.0 - 1e-17, -1e-17, 0.0));
        assert!(w.x >= -1.0 && w.x < 1.0 && w.y >= 0.0 && w.y < 3.0, "{w:?}");
        // Far outside, several periods.
        let w = d.wrap(v(10.5, -7.5, 0.0));
        assert!(
            (w.x - 0.5).abs() < 1e-12 && (w.y - 1.5).abs() < 1e-12,
            "{w:?}"
        );
        // Wrapping never changes the minimum-image distance to another point.
        let a = v(0.95, 2.95, 0.2);
        let b = v(1.05, 3.05, 0.2);
        let m1 = d.min_image(b - a);
        let m2 = d.min_image(d.wrap(b) - d.wrap(a));
        assert!((m1 - m2).norm() < 1e-12);
        for k in -500..500 {
            let x = k as f64 * 0.0371;
            let w = d.wrap(v(x, x, x));
            assert!(
                w.x >= -1.0 && w.x < 1.0 && w.y >= 0.0 && w.y < 3.0,
                "{x} {w:?}"
            );
        }
    }

    #[test]
    fn contains_checks_only_non_periodic_axes() {
        let d = Domain::new(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), [true, false, false]).unwrap();
        assert!(d.contains(v(5.0, 0.5, 0.5)));
        assert!(d.contains(v(0.5, 0.0, 1.0)), "bounds are inside");
        assert!(!d.contains(v(0.5, -1e-12, 0.5)));
        assert!(!d.contains(v(0.5, 0.5, 1.0 + 1e-12)));
        assert!(!d.contains(v(0.5, f64::NAN, 0.5)));
    }

    #[test]
    fn periodic_cutoff_check() {
        let d = Domain::new(v(0.0, 0.0, 0.0), v(1.0, 0.5, 0.1), [true, true, false]).unwrap();
        assert!(d.check_cutoff(0.25).is_ok());
        let e = d.check_cutoff(0.2500001).unwrap_err();
        assert!(matches!(e, DomainError::PeriodicTooSmall { axis: 1, .. }));
        assert!(e.to_string().contains("periodic y axis"));
        assert!(d.check_cutoff(f64::NAN).is_err());
    }
}
