//! yan2015 ortho-slice angles: the xz and yz slabs through the hopper axis each give
//! a left and a right angle, four per response; the response is their mean. The
//! same fit measures the upper angle α (the crater left in the hopper: the surface
//! descends towards the orifice) and the bottom angle θ (the heap on the plate: the
//! surface descends away from the axis); only the windows differ, and the caller
//! gives them.
//!
//! A slab holds the particles whose centre lies within half the thickness of the
//! plane through the axis and whose centre height is inside the z window (so the
//! heap on the plate and the material in the hopper above it are measured apart).
//! Its surface is the highest particle top per bin of the in-plane coordinate
//! ([`super::profile`]); the points with |h − axis| inside the radial window are
//! fitted left and right of the axis.

use super::fit::LineFit;
use super::profile::{fit_flanks, top_per_bin};
use super::{check_finite, check_positive, check_snapshot, check_window, MeasureError};
use crate::dem::vec3::Vec3;

/// Which vertical plane through the axis a slab follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlicePlane {
    /// The xz plane (y = axis y); profile coordinate x.
    Xz,
    /// The yz plane (x = axis x); profile coordinate y.
    Yz,
}

/// Where the slabs are and which part of their surface is fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlabSpec {
    /// Axis (x, y) the slabs pass through, m.
    pub axis_xy_m: [f64; 2],
    /// Slab thickness, m (a few particle diameters keeps the surface without holes).
    pub thickness_m: f64,
    /// Surface points are fitted where their horizontal distance from the axis is in
    /// this window, m (e.g. outside the orifice and off the wall for α; beyond the
    /// apex and short of the toe for θ).
    pub radial_window_m: (f64, f64),
    /// Only particles whose centre height is in this window, m.
    pub z_window_m: (f64, f64),
    /// Width of the surface bins, m (about one diameter).
    pub bin_width_m: f64,
}

/// Left and right fits of one slab's surface (left is towards −x or −y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlabAngles {
    /// Fit left of the axis.
    pub left: LineFit,
    /// Fit right of the axis.
    pub right: LineFit,
}

/// The four ortho-slice angles and their mean (yan2015: α = (α1+α2+α3+α4)/4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoAngles {
    /// The xz slab's fits.
    pub xz: SlabAngles,
    /// The yz slab's fits.
    pub yz: SlabAngles,
    /// The four angles, degrees: xz left, xz right, yz left, yz right.
    pub angles_deg: [f64; 4],
    /// Their mean, degrees.
    pub mean_deg: f64,
}

/// Fits one slab's surface left and right of the axis.
pub fn slab_angles(
    positions: &[Vec3],
    radii: &[f64],
    plane: SlicePlane,
    spec: &SlabSpec,
) -> Result<SlabAngles, MeasureError> {
    check_snapshot(positions, radii)?;
    check_finite("axis_xy_m", spec.axis_xy_m[0])?;
    check_finite("axis_xy_m", spec.axis_xy_m[1])?;
    check_positive("thickness_m", spec.thickness_m)?;
    check_positive("bin_width_m", spec.bin_width_m)?;
    check_window("radial_window_m", spec.radial_window_m)?;
    check_window("z_window_m", spec.z_window_m)?;
    let [cx, cy] = spec.axis_xy_m;
    let (zlo, zhi) = spec.z_window_m;
    let half = 0.5 * spec.thickness_m;
    let items: Vec<(f64, f64)> = positions
        .iter()
        .zip(radii)
        .filter(|(p, _)| p.z >= zlo && p.z <= zhi)
        .filter_map(|(p, &r)| {
            let (h, off) = match plane {
                SlicePlane::Xz => (p.x - cx, p.y - cy),
                SlicePlane::Yz => (p.y - cy, p.x - cx),
            };
            (off.abs() <= half).then_some((h, p.z + r))
        })
        .collect();
    if items.is_empty() {
        return Err(MeasureError::NoParticles { what: "the slab" });
    }
    let surface = top_per_bin(items, spec.bin_width_m);
    let (left, right) = fit_flanks(
        &surface,
        (f64::NEG_INFINITY, f64::INFINITY),
        spec.radial_window_m,
    )?;
    Ok(SlabAngles { left, right })
}

/// The xz and yz slabs' four angles and their mean.
pub fn ortho_slice_angles(
    positions: &[Vec3],
    radii: &[f64],
    spec: &SlabSpec,
) -> Result<OrthoAngles, MeasureError> {
    let xz = slab_angles(positions, radii, SlicePlane::Xz, spec)?;
    let yz = slab_angles(positions, radii, SlicePlane::Yz, spec)?;
    let angles_deg = [
        xz.left.angle_deg(),
        xz.right.angle_deg(),
        yz.left.angle_deg(),
        yz.right.angle_deg(),
    ];
    Ok(OrthoAngles {
        xz,
        yz,
        angles_deg,
        mean_deg: angles_deg.iter().sum::<f64>() / 4.0,
    })
}

#[cfg(test)]
mod tests {
    use super::super::synthetic::{cone, lattice_under};
    use super::*;

    const D: f64 = 2e-3;

    /// A heap of 28.9° on the plate (yan2015's example θ) and a crater of 31.1° in a
    /// hopper 70 mm above it (yan2015's α), both in one snapshot. The hopper holds
    /// half-size particles so that its 25 mm radius spans 25 of them (yan2015's
    /// 1 mm radius gives only 12 bins per flank, too few for a sub-degree test).
    fn hopper_and_heap() -> (Vec<Vec3>, Vec<f64>) {
        let (mut p, mut r) = cone(D, 40.0 * D, 28.9, 0.0);
        let t = 31.1f64.to_radians().tan();
        let (hp, hr) = lattice_under(
            0.5 * D,
            25.0 * D,
            0.07,
            |x, y| 0.07 + 3.0 * D + x.hypot(y).min(12.5 * D) * t,
            |x, y| x.hypot(y) <= 12.5 * D,
        );
        p.extend(hp);
        r.extend(hr);
        (p, r)
    }

    /// Slab thickness 3 d, windows away from the apex/orifice and the toe/wall;
    /// ~32 (heap) and ~18 (crater, half-size particles) points per flank. The
    /// lattice staircase tilts a fit by about d / run / sqrt(n) rad: well under 0.5°
    /// for the heap and under 1° for the shorter crater flanks.
    #[test]
    fn heap_and_crater_angles() {
        let (p, r) = hopper_and_heap();
        let heap = SlabSpec {
            axis_xy_m: [0.0, 0.0],
            thickness_m: 3.0 * D,
            radial_window_m: (4.0 * D, 36.0 * D),
            z_window_m: (0.0, 0.06),
            bin_width_m: D,
        };
        let theta = ortho_slice_angles(&p, &r, &heap).unwrap();
        assert!((theta.mean_deg - 28.9).abs() < 0.5, "{theta:?}");
        for a in theta.angles_deg {
            assert!((a - 28.9).abs() < 0.75, "{theta:?}");
        }
        let crater = SlabSpec {
            radial_window_m: (2.0 * D, 11.0 * D),
            z_window_m: (0.07, 0.2),
            ..heap
        };
        let alpha = ortho_slice_angles(&p, &r, &crater).unwrap();
        assert!((alpha.mean_deg - 31.1).abs() < 0.5, "{alpha:?}");
        for a in alpha.angles_deg {
            assert!((a - 31.1).abs() < 1.0, "{alpha:?}");
        }
        // The crater descends towards the axis: the left flank falls to the right.
        assert!(alpha.xz.left.slope < 0.0 && alpha.xz.right.slope > 0.0);
        assert!(theta.xz.left.slope > 0.0 && theta.xz.right.slope < 0.0);
    }

    #[test]
    fn empty_slab_and_bad_windows_are_errors() {
        let (p, r) = hopper_and_heap();
        let spec = SlabSpec {
            axis_xy_m: [1.0, 1.0],
            thickness_m: 3.0 * D,
            radial_window_m: (0.0, 1.0),
            z_window_m: (0.0, 1.0),
            bin_width_m: D,
        };
        assert!(matches!(
            ortho_slice_angles(&p, &r, &spec),
            Err(MeasureError::NoParticles { .. })
        ));
        let reversed = SlabSpec {
            radial_window_m: (1.0, 0.0),
            ..spec
        };
        assert!(matches!(
            ortho_slice_angles(&p, &r, &reversed),
            Err(MeasureError::BadParameter { .. })
        ));
    }
}
