//! he2019 §3.6.1 baffle lift: the static angle of the slope left in the box after
//! the baffle is lifted and the powder has run out.
//!
//! The box's length runs along x. Every particle in the x window (the box interior;
//! powder that ran out past the baffle is left out by the caller's window) is
//! projected on the xz plane; the highest particle top per x bin is the slope's
//! profile; points between 10% and 90% of the slope height (highest top above the
//! box floor), as for the he2019 pile, are fitted by one least-squares line.

use super::fit::fit_line;
use super::profile::top_per_bin;
use super::{
    check_finite, check_positive, check_snapshot, check_window, mean_diameter, MeasureError,
};
use crate::dem::vec3::Vec3;

/// The box and the fit band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaffleSpec {
    /// Box floor height, m.
    pub base_z_m: f64,
    /// Only particles with x in this window, m (the box interior).
    pub x_window_m: (f64, f64),
    /// Width of the surface bins, m (about one diameter).
    pub bin_width_m: f64,
    /// Fractions of the slope height between which points are fitted (0.1, 0.9).
    pub band: (f64, f64),
    /// A slope lower than this many mean diameters is not measurable.
    pub min_height_diameters: f64,
}

impl BaffleSpec {
    /// he2019's band (10%–90%), at least 3 diameters high.
    pub fn new(base_z_m: f64, x_window_m: (f64, f64), bin_width_m: f64) -> Self {
        Self {
            base_z_m,
            x_window_m,
            bin_width_m,
            band: (0.1, 0.9),
            min_height_diameters: 3.0,
        }
    }
}

/// The remaining slope's angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeAngle {
    /// atan(|slope|), degrees.
    pub angle_deg: f64,
    /// R² of the fit.
    pub r2: f64,
    /// Surface points in the fit.
    pub points: usize,
    /// Slope height: highest particle top above the floor, m.
    pub height_m: f64,
}

/// The baffle-lift slope angle of a snapshot (see the module docs).
pub fn baffle_slope_angle(
    positions: &[Vec3],
    radii: &[f64],
    spec: &BaffleSpec,
) -> Result<SlopeAngle, MeasureError> {
    check_snapshot(positions, radii)?;
    check_finite("base_z_m", spec.base_z_m)?;
    check_window("x_window_m", spec.x_window_m)?;
    check_positive("bin_width_m", spec.bin_width_m)?;
    check_positive("min_height_diameters", spec.min_height_diameters)?;
    let (lo, hi) = spec.band;
    if !(0.0 <= lo && lo < hi && hi <= 1.0) {
        return Err(MeasureError::BadParameter {
            name: "band",
            value: hi,
            allowed: "fractions 0 <= lo < hi <= 1",
        });
    }
    let (xlo, xhi) = spec.x_window_m;
    let items: Vec<(f64, f64)> = positions
        .iter()
        .zip(radii)
        .filter(|(p, _)| p.x >= xlo && p.x <= xhi && p.z >= spec.base_z_m)
        .map(|(p, &r)| (p.x, p.z + r))
        .collect();
    if items.is_empty() {
        return Err(MeasureError::NoParticles { what: "the box" });
    }
    let height_m = items.iter().map(|i| i.1).fold(f64::NEG_INFINITY, f64::max) - spec.base_z_m;
    let min_m = spec.min_height_diameters * mean_diameter(radii);
    if height_m < min_m {
        return Err(MeasureError::TooFlat { height_m, min_m });
    }
    let (vlo, vhi) = (spec.base_z_m + lo * height_m, spec.base_z_m + hi * height_m);
    let points: Vec<_> = top_per_bin(items, spec.bin_width_m)
        .into_iter()
        .filter(|&(_, v)| v >= vlo && v <= vhi)
        .collect();
    let fit = fit_line(&points, "baffle slope")?;
    Ok(SlopeAngle {
        angle_deg: fit.angle_deg(),
        r2: fit.r2,
        points: fit.points,
        height_m,
    })
}

#[cfg(test)]
mod tests {
    use super::super::synthetic::lattice_under;
    use super::*;

    const D: f64 = 1e-3;

    /// A 60 mm box (x in [0, 60] mm) whose powder stands full height (50 mm) at the
    /// back wall (x = 0) and slopes down at 39.1° (he2019's measured angle) to the
    /// floor; ~48 points over a 0.8·50 mm band. The lattice staircase tilts the fit
    /// by well under 0.5°.
    #[test]
    fn slope_of_known_angle() {
        let t = 39.1f64.to_radians().tan();
        let (p, r) = lattice_under(
            D,
            60.0 * D,
            0.0,
            |x, _| (50.0 * D).min(60.0 * D - x * t),
            |x, y| (0.0..=60.0 * D).contains(&x) && y.abs() < 3.0 * D,
        );
        let spec = BaffleSpec::new(0.0, (0.0, 0.06), D);
        let a = baffle_slope_angle(&p, &r, &spec).unwrap();
        assert!((a.angle_deg - 39.1).abs() < 0.5, "{a:?}");
        assert!(a.r2 > 0.99 && a.points > 30, "{a:?}");
    }

    #[test]
    fn flat_bed_and_empty_box_are_not_measurable() {
        let (p, r) = lattice_under(D, 60.0 * D, 0.0, |_, _| 2.0 * D, |x, _| x >= 0.0);
        let spec = BaffleSpec::new(0.0, (0.0, 0.06), D);
        assert!(matches!(
            baffle_slope_angle(&p, &r, &spec),
            Err(MeasureError::TooFlat { .. })
        ));
        let elsewhere = BaffleSpec::new(0.0, (1.0, 2.0), D);
        assert!(matches!(
            baffle_slope_angle(&p, &r, &elsewhere),
            Err(MeasureError::NoParticles { .. })
        ));
    }
}
