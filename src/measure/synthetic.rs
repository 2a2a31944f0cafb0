//! Synthetic packings with a known surface, for the measurement tests.

use crate::dem::vec3::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A snapshot: positions and radii.
pub type Snapshot = (Vec<Vec3>, Vec<f64>);

/// Simple cubic lattice of spheres (diameter `d`, spacing `d`) resting on
/// `base_z`, offset from the origin by a fraction of a spacing so that no column
/// sits on a bin edge, keeping the sites whose top lies below `surface(x, y)`
/// (absolute height) and whose centre satisfies `inside(x, y)`.
pub fn lattice_under(
    d: f64,
    half_extent: f64,
    base_z: f64,
    surface: impl Fn(f64, f64) -> f64,
    inside: impl Fn(f64, f64) -> bool,
) -> Snapshot {
    let r = 0.5 * d;
    let n = (half_extent / d).ceil() as i64 + 1;
    let (mut pos, mut rad) = (Vec::new(), Vec::new());
    for i in -n..=n {
        for j in -n..=n {
            let (x, y) = ((i as f64 + 0.37) * d, (j as f64 + 0.21) * d);
            if !inside(x, y) {
                continue;
            }
            let top = surface(x, y);
            let mut z = base_z + r;
            while z + r <= top {
                pos.push(Vec3::new(x, y, z));
                rad.push(r);
                z += d;
            }
        }
    }
    (pos, rad)
}

/// A cone of slope `angle_deg` and base radius `base_radius` on `base_z`, axis
/// through the origin.
pub fn cone(d: f64, base_radius: f64, angle_deg: f64, base_z: f64) -> Snapshot {
    let t = angle_deg.to_radians().tan();
    let h = base_radius * t;
    lattice_under(
        d,
        base_radius,
        base_z,
        |x, y| base_z + h - x.hypot(y) * t,
        |x, y| x.hypot(y) <= base_radius,
    )
}

/// An asymmetric ridge along y (|y| ≤ `half_length`): apex at x = 0, height `h`,
/// left flank (x < 0) at `left_deg`, right flank at `right_deg`.
pub fn ridge(d: f64, h: f64, left_deg: f64, right_deg: f64, half_length: f64) -> Snapshot {
    let (tl, tr) = (left_deg.to_radians().tan(), right_deg.to_radians().tan());
    let extent = (h / tl).max(h / tr).max(half_length);
    lattice_under(
        d,
        extent,
        0.0,
        |x, _| h - if x < 0.0 { -x * tl } else { x * tr },
        |_, y| y.abs() <= half_length,
    )
}

/// Adds uniform noise of ±`amp` to every coordinate and scales every radius by a
/// factor in [1 − `rad_amp`, 1 + `rad_amp`] (seeded).
pub fn jitter(snap: Snapshot, amp: f64, rad_amp: f64, seed: u64) -> Snapshot {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut pos, mut rad) = snap;
    for (p, r) in pos.iter_mut().zip(rad.iter_mut()) {
        for c in p.iter_mut() {
            *c += rng.random_range(-amp..=amp);
        }
        *r *= 1.0 + rng.random_range(-rad_amp..=rad_amp);
    }
    (pos, rad)
}
