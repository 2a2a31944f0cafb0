//! yan2015's two repose angles from a snapshot, through
//! [`crate::measure::ortho`]: the upper angle α (the crater left in the
//! hopper) and the bottom angle θ (the heap on the plate), each the mean of
//! the four fits of the xz and yz slabs through the hopper axis.
//!
//! Windows (yan2015 does not state them; chosen here):
//! - both: slabs 3 mean diameters thick, surface bins one mean diameter wide
//!   (as the synthetic tests of `measure::ortho`);
//! - α: centres above the hopper bottom; surface points from a particle
//!   resting on the orifice's rim (centre at R_o + d/2) to one diameter
//!   short of the wall (R_h − d): the annulus is only 8.75 of yan2015's
//!   diameters wide, so nothing more is cut at the rim; the layer touching
//!   the wall is left out because wall friction can hold a column of
//!   particles there that is not part of the crater (seen with
//!   low-friction particles against the base-case wall);
//! - θ: centres between the plate and one diameter below the hopper; surface
//!   points between 20 % and 80 % of the heap's base radius R_b. R_b is
//!   estimated as R₉₇ / 0.9, R₉₇ being the radius that holds 97 % of the heap's
//!   particles: in a cone of uniform density the fraction beyond 0.9 R_b is
//!   1 − 3·0.9² + 2·0.9³ = 2.8 %. The band is the radial form of he2019's
//!   10–90 % of the height, narrowed because the falling stream rounds the
//!   apex and bouncing particles spread a foot. A heap whose top is less
//!   than [`MIN_HEAP_DIAMETERS`] mean diameters above the plate (a layer
//!   spread over the plate, not a heap) is not measurable.

use super::geometry::Geometry;
use crate::dem::vec3::Vec3;
use crate::measure::fit::LineFit;
use crate::measure::ortho::{ortho_slice_angles, OrthoAngles, SlabSpec};
use crate::measure::MeasureError;
use std::collections::BTreeMap;

/// A fit with R² below this is flagged in the result (not hidden, not
/// dropped): a surface that a straight line describes this poorly is rough
/// on the scale of the window, or not a slope at all.
pub const R2_FLOOR: f64 = 0.8;
/// Slab thickness in mean diameters.
const SLAB_DIAMETERS: f64 = 3.0;
/// Fraction of the heap's particles inside the radius used to estimate R_b.
const HEAP_QUANTILE: f64 = 0.97;
/// R₉₇ / R_b for a cone (see the module docs).
const QUANTILE_RADIUS_FRACTION: f64 = 0.9;
/// The θ fit band, fractions of R_b.
const HEAP_BAND: (f64, f64) = (0.2, 0.8);
/// A heap lower than this many mean diameters has no flanks to measure
/// (as [`crate::measure::pile::PileSpec::new`]'s default).
pub const MIN_HEAP_DIAMETERS: f64 = 3.0;

/// The slab spec for α.
pub fn upper_spec(g: &Geometry) -> SlabSpec {
    SlabSpec {
        axis_xy_m: [0.0, 0.0],
        thickness_m: SLAB_DIAMETERS * g.d_mean,
        radial_window_m: (
            g.orifice_radius + 0.5 * g.d_mean,
            g.hopper_radius - g.d_mean,
        ),
        z_window_m: (g.bottom_z, g.bottom_z + 2.0 * g.hopper_height),
        bin_width_m: g.d_mean,
    }
}

/// The z window of the heap: centres on or above the plate, below the hopper.
fn heap_z_window(g: &Geometry) -> (f64, f64) {
    (0.0, g.bottom_z - g.d_mean)
}

/// Estimated base radius of the heap on the plate, m (see the module docs);
/// an error when there is no heap, or one lower than [`MIN_HEAP_DIAMETERS`].
pub fn heap_base_radius(
    positions: &[Vec3],
    radii: &[f64],
    g: &Geometry,
) -> Result<f64, MeasureError> {
    let (lo, hi) = heap_z_window(g);
    let heap = || {
        positions
            .iter()
            .zip(radii)
            .filter(move |(p, _)| p.z >= lo && p.z <= hi)
    };
    let top = heap()
        .map(|(p, r)| p.z + r)
        .fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        return Err(MeasureError::NoParticles {
            what: "the heap on the plate",
        });
    }
    let min_m = MIN_HEAP_DIAMETERS * g.d_mean;
    if top < min_m {
        return Err(MeasureError::TooFlat {
            height_m: top,
            min_m,
        });
    }
    let mut rho: Vec<f64> = heap().map(|(p, _)| p.x.hypot(p.y)).collect();
    rho.sort_by(f64::total_cmp);
    let k = ((HEAP_QUANTILE * rho.len() as f64).ceil() as usize).clamp(1, rho.len());
    Ok(rho[k - 1] / QUANTILE_RADIUS_FRACTION)
}

/// The slab spec for θ, from the heap in the snapshot.
pub fn bottom_spec(
    positions: &[Vec3],
    radii: &[f64],
    g: &Geometry,
) -> Result<SlabSpec, MeasureError> {
    let r_b = heap_base_radius(positions, radii, g)?;
    Ok(SlabSpec {
        axis_xy_m: [0.0, 0.0],
        thickness_m: SLAB_DIAMETERS * g.d_mean,
        radial_window_m: (HEAP_BAND.0 * r_b, HEAP_BAND.1 * r_b),
        z_window_m: heap_z_window(g),
        bin_width_m: g.d_mean,
    })
}

/// The upper angle α of a snapshot.
pub fn upper_angle(
    positions: &[Vec3],
    radii: &[f64],
    g: &Geometry,
) -> Result<OrthoAngles, MeasureError> {
    ortho_slice_angles(positions, radii, &upper_spec(g))
}

/// The bottom angle θ of a snapshot.
pub fn bottom_angle(
    positions: &[Vec3],
    radii: &[f64],
    g: &Geometry,
) -> Result<OrthoAngles, MeasureError> {
    ortho_slice_angles(positions, radii, &bottom_spec(positions, radii, g)?)
}

/// Writes an angle into `out` as `<name>_deg` (the mean of four), and per fit
/// `<name>_<slab>_<side>_{deg,r2,points}`, plus `<name>_fits_below_r2_floor`
/// (how many of the four fits have R² < [`R2_FLOOR`]).
pub fn record(out: &mut BTreeMap<String, f64>, name: &str, a: &OrthoAngles) {
    let fits: [(&str, &LineFit); 4] = [
        ("xz_left", &a.xz.left),
        ("xz_right", &a.xz.right),
        ("yz_left", &a.yz.left),
        ("yz_right", &a.yz.right),
    ];
    out.insert(format!("{name}_deg"), a.mean_deg);
    let mut low = 0;
    for (label, fit) in fits {
        out.insert(format!("{name}_{label}_deg"), fit.angle_deg());
        out.insert(format!("{name}_{label}_r2"), fit.r2);
        out.insert(format!("{name}_{label}_points"), fit.points as f64);
        low += usize::from(fit.r2 < R2_FLOOR);
    }
    out.insert(format!("{name}_fits_below_r2_floor"), low as f64);
}

#[cfg(test)]
mod tests {
    use super::super::geometry::yan2015_geometry;
    use super::*;

    /// Particles spread uniformly over a cone of base radius 50 mm: R₉₇/0.9
    /// is the base radius to within the quantile's sampling error.
    #[test]
    fn heap_radius_of_a_uniform_cone() {
        let g = yan2015_geometry();
        let (rb, h) = (0.05, 0.03);
        let mut p = Vec::new();
        let step = 0.001;
        let n = (rb / step) as i32;
        for i in -n..=n {
            for j in -n..=n {
                let (x, y) = (f64::from(i) * step, f64::from(j) * step);
                let top = h * (1.0 - x.hypot(y) / rb);
                let mut z = 0.0005;
                while z < top {
                    p.push(Vec3::new(x, y, z));
                    z += step;
                }
            }
        }
        let radii = vec![0.0005; p.len()];
        let est = heap_base_radius(&p, &radii, &g).unwrap();
        assert!((est - rb).abs() < 0.02 * rb, "{est}");
        assert!(matches!(
            heap_base_radius(&[], &[], &g),
            Err(MeasureError::NoParticles { .. })
        ));
        // Two layers of 2 mm spheres are a spread layer, not a heap.
        let layer: Vec<Vec3> = p.iter().filter(|q| q.z < 0.003).copied().collect();
        assert!(matches!(
            heap_base_radius(&layer, &vec![0.001; layer.len()], &g),
            Err(MeasureError::TooFlat { .. })
        ));
    }
}
