//! Rotating-drum free-surface angle.
//!
//! The drum axis is along y. Particles inside the axial window are projected on the
//! xz plane; the free surface is the highest particle top per bin along the surface
//! direction, fitted by one least-squares line. The surface direction is found in
//! two passes: a first fit with bins along x gives the inclination φ, then the
//! particles are rotated by φ and binned along the surface (top = the farthest
//! particle along the surface normal), which keeps a steep surface (cai2024's 60°)
//! as well sampled as a shallow one. Those points, back in the lab frame, are fitted
//! by an ordinary z-on-x least-squares line, whose slope gives the angle and whose
//! R² is reported.
//!
//! Wall window: only surface points closer to the drum axis than
//! `window_fraction` · R (default 0.7) are fitted. The free surface of a partly filled
//! drum is a chord at distance R cos(β/2) from the axis, where the bed's central
//! angle β solves β − sin β = 2π f: 0.32 R for he2019's 30% fill and 0.40 R for
//! cai2024's 25%. A circle of 0.7 R then keeps the middle 62% (30% fill) to 57%
//! (25%) of the chord and drops both ends, where particles climb the rising wall
//! and the toe curls against the falling wall (the S-shape of a cascading bed). At
//! fills above about 45% the chord leaves too little inside 0.7 R; the error then
//! says how many points were found.
//!
//! Time averaging over the steady rotation is the caller's job
//! ([`super::series::mean_std`]).

use super::fit::fit_line;
use super::profile::top_per_bin;
use super::{check_finite, check_positive, check_snapshot, check_window, MeasureError};
use crate::dem::vec3::Vec3;

/// The drum and the measuring window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrumSpec {
    /// Drum axis position in the xz plane, m (the axis is parallel to y).
    pub centre_xz_m: [f64; 2],
    /// Inner radius, m.
    pub radius_m: f64,
    /// Surface points are fitted only closer than this fraction of the radius to the
    /// axis (see the module docs; 0.7 by default).
    pub window_fraction: f64,
    /// Only particles with y in this window, m; `None` takes all. Keep a few
    /// diameters away from end walls, whose friction raises the surface there.
    pub y_window_m: Option<(f64, f64)>,
    /// Width of the surface bins, m (about one diameter).
    pub bin_width_m: f64,
}

impl DrumSpec {
    /// A drum at `centre_xz_m` of radius `radius_m` with the 0.7 R window and every
    /// particle along y.
    pub fn new(centre_xz_m: [f64; 2], radius_m: f64, bin_width_m: f64) -> Self {
        Self {
            centre_xz_m,
            radius_m,
            window_fraction: 0.7,
            y_window_m: None,
            bin_width_m,
        }
    }
}

/// A drum's free-surface angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrumAngle {
    /// Inclination of the free surface, degrees in [0, 90].
    pub angle_deg: f64,
    /// Signed inclination, degrees: positive when the surface rises towards +x
    /// (tells the rotation sense).
    pub signed_deg: f64,
    /// R² of the final lab-frame fit.
    pub r2: f64,
    /// Surface points in the fit.
    pub points: usize,
}

/// The free-surface angle of a drum snapshot (see the module docs).
pub fn drum_surface_angle(
    positions: &[Vec3],
    radii: &[f64],
    spec: &DrumSpec,
) -> Result<DrumAngle, MeasureError> {
    check_snapshot(positions, radii)?;
    check_finite("centre_xz_m", spec.centre_xz_m[0])?;
    check_finite("centre_xz_m", spec.centre_xz_m[1])?;
    check_positive("radius_m", spec.radius_m)?;
    check_positive("bin_width_m", spec.bin_width_m)?;
    if !(spec.window_fraction > 0.0 && spec.window_fraction <= 1.0) {
        return Err(MeasureError::BadParameter {
            name: "window_fraction",
            value: spec.window_fraction,
            allowed: "a fraction in (0, 1]",
        });
    }
    if let Some(w) = spec.y_window_m {
        check_window("y_window_m", w)?;
    }
    let [cx, cz] = spec.centre_xz_m;
    let rel: Vec<(f64, f64, f64)> = positions
        .iter()
        .zip(radii)
        .filter(|(p, _)| {
            spec.y_window_m
                .is_none_or(|(lo, hi)| p.y >= lo && p.y <= hi)
        })
        .map(|(p, &r)| (p.x - cx, p.z - cz, r))
        .collect();
    if rel.is_empty() {
        return Err(MeasureError::NoParticles {
            what: "the drum's axial window",
        });
    }
    let first = fit_line(&surface_points(&rel, 0.0, spec), "drum free surface")?;
    let phi = first.slope.atan();
    let (c, sn) = (phi.cos(), phi.sin());
    // Points selected along the surface, rotated back to the lab frame and fitted
    // there: the slope and R² are those of an ordinary z-on-x fit.
    let lab: Vec<_> = surface_points(&rel, phi, spec)
        .into_iter()
        .map(|(h, v)| (h * c - v * sn, h * sn + v * c))
        .collect();
    let fit = fit_line(&lab, "drum free surface")?;
    let signed = fit.slope.atan();
    Ok(DrumAngle {
        angle_deg: signed.abs().to_degrees(),
        signed_deg: signed.to_degrees(),
        r2: fit.r2,
        points: fit.points,
    })
}

/// Rotates the (x, z, r) triples by −φ (so a surface inclined at φ is horizontal),
/// takes the top per bin along the rotated x and keeps the points inside the
/// window circle; the points are in the rotated frame.
fn surface_points(rel: &[(f64, f64, f64)], phi: f64, spec: &DrumSpec) -> Vec<(f64, f64)> {
    let (c, s) = (phi.cos(), phi.sin());
    let items = rel
        .iter()
        .map(|&(x, z, r)| (x * c + z * s, -x * s + z * c + r));
    let limit = spec.window_fraction * spec.radius_m;
    top_per_bin(items, spec.bin_width_m)
        .into_iter()
        .filter(|&(h, v)| h.hypot(v) < limit)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 0.0225;
    const D: f64 = R / 40.0;

    /// A bed in a drum of radius R (axis y, centre at the origin): lattice of
    /// spacing d in a frame rotated by `lattice_deg`, keeping the sites inside the
    /// drum whose top lies below the plane through (0, −depth) inclined at
    /// `surface_deg`, for 5 rows along y.
    fn bed(surface_deg: f64, lattice_deg: f64, depth: f64) -> (Vec<Vec3>, Vec<f64>) {
        let (t, (ls, lc)) = (
            surface_deg.to_radians().tan(),
            lattice_deg.to_radians().sin_cos(),
        );
        let (mut p, mut r) = (Vec::new(), Vec::new());
        let n = 45;
        for i in -n..=n {
            for k in -n..=n {
                let (a, b) = ((i as f64 + 0.37) * D, (k as f64 + 0.21) * D);
                let (x, z) = (a * lc - b * ls, a * ls + b * lc);
                let below = z + 0.5 * D <= x * t - depth / surface_deg.to_radians().cos();
                if x.hypot(z) + 0.5 * D <= R && below {
                    for j in 0..5 {
                        p.push(Vec3::new(x, j as f64 * D, z));
                        r.push(0.5 * D);
                    }
                }
            }
        }
        (p, r)
    }

    /// ~50 surface points along a 0.62 R half-chord each side, 40 bins per radius:
    /// the staircase (axis-aligned lattice) or the exact flat surface (lattice
    /// aligned with it) gives the angle within 0.5°.
    #[test]
    fn inclined_beds() {
        let spec = DrumSpec::new([0.0, 0.0], R, D);
        for (angle, lattice) in [
            (40.0, 0.0),
            (40.0, 40.0),
            (47.1, 0.0),
            (60.5, 60.5),
            (-40.0, 0.0),
        ] {
            let (p, r) = bed(angle, lattice, 0.32 * R);
            let a = drum_surface_angle(&p, &r, &spec).unwrap();
            assert!(
                (a.signed_deg - angle).abs() < 0.5,
                "{angle} {lattice}: {a:?}"
            );
            assert!((a.angle_deg - f64::abs(angle)).abs() < 0.5, "{a:?}");
            assert!(a.r2 > 0.99, "{a:?}");
            assert!(a.points > 30, "{a:?}");
        }
    }

    /// Particles carried up the rising wall above the surface (further than 0.9 R
    /// from the axis) are outside the window and do not change the angle.
    #[test]
    fn wall_climbers_are_excluded() {
        let spec = DrumSpec::new([0.0, 0.0], R, D);
        let (mut p, mut r) = bed(40.0, 40.0, 0.32 * R);
        let clean = drum_surface_angle(&p, &r, &spec).unwrap();
        for k in 0..20 {
            let a = -0.3 + 0.05 * k as f64;
            p.push(Vec3::new(0.95 * R * a.cos(), 0.0, 0.95 * R * a.sin()));
            r.push(0.5 * D);
        }
        let dirty = drum_surface_angle(&p, &r, &spec).unwrap();
        assert!((dirty.angle_deg - clean.angle_deg).abs() < 1e-9);
    }

    #[test]
    fn degenerate_drums() {
        let spec = DrumSpec::new([0.0, 0.0], R, D);
        assert!(drum_surface_angle(&[], &[], &spec).is_err());
        // One layer lying on the wall: every surface point is outside 0.7 R.
        let (p, r): (Vec<_>, Vec<_>) = (0..30)
            .map(|k| {
                let a = -2.0 + 0.04 * k as f64;
                (
                    Vec3::new((R - D) * a.cos(), 0.0, (R - D) * a.sin()),
                    0.5 * D,
                )
            })
            .unzip();
        assert!(matches!(
            drum_surface_angle(&p, &r, &spec),
            Err(MeasureError::TooFewPoints { found: 0, .. })
        ));
        let outside = DrumSpec {
            y_window_m: Some((1.0, 2.0)),
            ..spec
        };
        assert!(matches!(
            drum_surface_angle(&p, &r, &outside),
            Err(MeasureError::NoParticles { .. })
        ));
    }
}
