//! Pile profile angle (he2019 §2.2, Fig. 4) and the height-over-diameter angle
//! (cai2024, GB/T 16913-2008).
//!
//! The pile is seen as in he2019's side image: every particle is projected on the
//! vertical plane through the pile axis that contains the viewing direction's normal
//! (the horizontal unit vector at `azimuth_rad` from +x). The silhouette is the
//! highest particle top per bin of the horizontal coordinate ([`super::profile`]); for
//! an axisymmetric cone the silhouette is its generator through the axis, so the
//! projection measures the cone angle while using every particle (a thin slab would
//! see only a few). Points left and right of the axis whose height above the base lies
//! between 10% and 90% of the pile height (he2019, after Alizadeh et al.) are fitted
//! by least squares; each flank's angle is atan(|slope|) and the repose angle is their
//! mean.
//!
//! A simulation can look from every side: [`side_views`] fits the profile in four
//! views 45° apart and averages the fitted flanks. A scene says how many views must
//! fit (`min_views`): a view can fail alone on a small rough pile (one flank with
//! fewer than three surface points) while the others still measure it.

use super::fit::LineFit;
use super::profile::{fit_flanks, top_per_bin};
use super::{check_finite, check_positive, check_snapshot, mean_diameter, MeasureError};
use crate::dem::vec3::Vec3;

/// How to look at a pile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PileSpec {
    /// Height of the base the pile stands on (platform or disk top), m. Particles
    /// whose centre is below it (fallen off the platform) are ignored.
    pub base_z_m: f64,
    /// Pile axis (x, y), m. `None`: the left/right split is the horizontal position
    /// of the highest surface point (the apex), which also handles asymmetric piles.
    pub axis_xy_m: Option<[f64; 2]>,
    /// Direction of the horizontal profile coordinate, radians from +x towards +y
    /// (0: the xz side view, looking along y).
    pub azimuth_rad: f64,
    /// Width of the surface bins, m; about one particle diameter resolves the
    /// surface without holes.
    pub bin_width_m: f64,
    /// Fraction of the pile height between which surface points are fitted
    /// (he2019: 0.1 to 0.9).
    pub band: (f64, f64),
    /// A pile lower than this many mean particle diameters is not measurable
    /// (a single layer or a flat bed has no flanks).
    pub min_height_diameters: f64,
}

impl PileSpec {
    /// he2019's settings: xz side view, 10%–90% band, axis from the apex, at least
    /// 3 diameters high.
    pub fn new(base_z_m: f64, bin_width_m: f64) -> Self {
        Self {
            base_z_m,
            axis_xy_m: None,
            azimuth_rad: 0.0,
            bin_width_m,
            band: (0.1, 0.9),
            min_height_diameters: 3.0,
        }
    }
}

/// A pile's repose angle from its profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PileAngle {
    /// Left flank angle, degrees.
    pub left_deg: f64,
    /// Right flank angle, degrees.
    pub right_deg: f64,
    /// Mean of left and right, degrees (he2019's angle of repose).
    pub mean_deg: f64,
    /// R² of the left fit.
    pub r2_left: f64,
    /// R² of the right fit.
    pub r2_right: f64,
    /// Surface points in the left fit.
    pub points_left: usize,
    /// Surface points in the right fit.
    pub points_right: usize,
    /// Pile height: highest particle top above the base, m.
    pub height_m: f64,
}

/// The pile angle from a snapshot (see the module docs).
pub fn pile_angle(
    positions: &[Vec3],
    radii: &[f64],
    spec: &PileSpec,
) -> Result<PileAngle, MeasureError> {
    check_snapshot(positions, radii)?;
    check_spec(spec)?;
    let (ux, uy) = (spec.azimuth_rad.cos(), spec.azimuth_rad.sin());
    let items: Vec<(f64, f64)> = positions
        .iter()
        .zip(radii)
        .filter(|(p, _)| p.z >= spec.base_z_m)
        .map(|(p, &r)| (p.x * ux + p.y * uy, p.z + r))
        .collect();
    let height_m = pile_height(&items, radii, spec.base_z_m, spec.min_height_diameters)?;
    let surface = top_per_bin(items, spec.bin_width_m);
    let split = match spec.axis_xy_m {
        Some([cx, cy]) => cx * ux + cy * uy,
        None => {
            surface
                .iter()
                .fold((f64::NEG_INFINITY, 0.0), |best, &(h, v)| {
                    if v > best.0 {
                        (v, h)
                    } else {
                        best
                    }
                })
                .1
        }
    };
    let centred: Vec<_> = surface.iter().map(|&(h, v)| (h - split, v)).collect();
    let band = (
        spec.base_z_m + spec.band.0 * height_m,
        spec.base_z_m + spec.band.1 * height_m,
    );
    let (left, right) = fit_flanks(&centred, band, (0.0, f64::INFINITY))?;
    Ok(from_fits(left, right, height_m))
}

/// Number of side views [`side_views`] looks from.
pub const VIEWS: usize = 4;

/// Azimuths of the side views, degrees from +x (the profile coordinate's
/// direction; 0 is the xz view, 90 the yz view): four views 45° apart. Each
/// view's silhouette is made of different boundary particles, so averaging
/// views lowers the scatter of one view.
pub const VIEW_AZIMUTHS_DEG: [u32; VIEWS] = [0, 45, 90, 135];

/// A pile seen from the sides of [`VIEW_AZIMUTHS_DEG`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SideViews {
    /// One profile fit per view, in the order of [`VIEW_AZIMUTHS_DEG`]; `None`
    /// for a view that could not be fitted (at most `VIEWS − min_views` of
    /// them, `min_views` as passed to [`side_views`]).
    pub views: [Option<PileAngle>; VIEWS],
}

impl SideViews {
    /// The fitted views.
    fn fitted(&self) -> impl Iterator<Item = &PileAngle> {
        self.views.iter().flatten()
    }

    /// Number of fitted views.
    pub fn fitted_views(&self) -> usize {
        self.fitted().count()
    }

    /// Mean over the fitted views of `value`.
    fn view_mean(&self, value: impl Fn(&PileAngle) -> f64) -> f64 {
        self.fitted().map(value).sum::<f64>() / self.fitted_views() as f64
    }

    /// Mean of every fitted flank angle, degrees: the angle of repose.
    pub fn mean_deg(&self) -> f64 {
        self.view_mean(|v| v.mean_deg)
    }

    /// Mean of the fitted left flanks, degrees.
    pub fn left_deg(&self) -> f64 {
        self.view_mean(|v| v.left_deg)
    }

    /// Mean of the fitted right flanks, degrees.
    pub fn right_deg(&self) -> f64 {
        self.view_mean(|v| v.right_deg)
    }

    /// Smallest R² of the fitted flanks.
    pub fn min_r2(&self) -> f64 {
        self.fitted()
            .flat_map(|v| [v.r2_left, v.r2_right])
            .fold(f64::INFINITY, f64::min)
    }
}

/// The pile's profile fitted in each view of [`VIEW_AZIMUTHS_DEG`] with the
/// settings of `base` (its `azimuth_rad` is replaced by each view's). A view
/// that cannot be fitted (a flank with too few surface points) is left out;
/// with fewer than `min_views` fitted views (1 to [`VIEWS`]) the pile is not
/// measurable and the first view's error is returned.
pub fn side_views(
    positions: &[Vec3],
    radii: &[f64],
    base: &PileSpec,
    min_views: usize,
) -> Result<SideViews, MeasureError> {
    if !(1..=VIEWS).contains(&min_views) {
        return Err(MeasureError::BadParameter {
            name: "min_views",
            value: min_views as f64,
            allowed: "1 to 4 side views",
        });
    }
    let fits = VIEW_AZIMUTHS_DEG.map(|az| {
        let spec = PileSpec {
            azimuth_rad: f64::from(az).to_radians(),
            ..*base
        };
        pile_angle(positions, radii, &spec)
    });
    if fits.iter().filter(|f| f.is_ok()).count() < min_views {
        let first_error = fits.into_iter().find_map(Result::err);
        return Err(first_error.expect("fewer than min_views >= 1 fits: some view failed"));
    }
    Ok(SideViews {
        views: fits.map(Result::ok),
    })
}

fn from_fits(left: LineFit, right: LineFit, height_m: f64) -> PileAngle {
    let (left_deg, right_deg) = (left.angle_deg(), right.angle_deg());
    PileAngle {
        left_deg,
        right_deg,
        mean_deg: 0.5 * (left_deg + right_deg),
        r2_left: left.r2,
        r2_right: right.r2,
        points_left: left.points,
        points_right: right.points,
        height_m,
    }
}

fn check_spec(spec: &PileSpec) -> Result<(), MeasureError> {
    check_finite("base_z_m", spec.base_z_m)?;
    check_finite("azimuth_rad", spec.azimuth_rad)?;
    check_positive("bin_width_m", spec.bin_width_m)?;
    check_positive("min_height_diameters", spec.min_height_diameters)?;
    if let Some([cx, cy]) = spec.axis_xy_m {
        check_finite("axis_xy_m", cx)?;
        check_finite("axis_xy_m", cy)?;
    }
    let (lo, hi) = spec.band;
    if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi && hi <= 1.0) {
        return Err(MeasureError::BadParameter {
            name: "band",
            value: hi,
            allowed: "fractions 0 <= lo < hi <= 1",
        });
    }
    Ok(())
}

/// Highest top above the base among `items` (h, top); an error when the pile is
/// lower than `min_height_diameters` mean diameters or empty.
fn pile_height(
    items: &[(f64, f64)],
    radii: &[f64],
    base_z_m: f64,
    min_height_diameters: f64,
) -> Result<f64, MeasureError> {
    if items.is_empty() {
        return Err(MeasureError::NoParticles {
            what: "the region above the base",
        });
    }
    let top = items.iter().map(|i| i.1).fold(f64::NEG_INFINITY, f64::max);
    let height_m = top - base_z_m;
    let min_m = min_height_diameters * mean_diameter(radii);
    if height_m < min_m {
        return Err(MeasureError::TooFlat { height_m, min_m });
    }
    Ok(height_m)
}

/// cai2024's static angle (GB/T 16913-2008): tan(angle) = 2H/D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeightAngle {
    /// atan(2H/D), degrees.
    pub angle_deg: f64,
    /// H: highest particle top above the base, m.
    pub height_m: f64,
    /// D: the base disk diameter used, m.
    pub base_diameter_m: f64,
}

/// The angle from the pile height over the base disk diameter (the pile is assumed
/// to cover the disk, as the fixed-base method requires). Particles whose centre is
/// below `base_z_m` (fallen off the disk) are ignored; a pile lower than
/// `min_height_diameters` mean diameters is not measurable.
pub fn height_diameter_angle(
    positions: &[Vec3],
    radii: &[f64],
    base_z_m: f64,
    base_diameter_m: f64,
    min_height_diameters: f64,
) -> Result<HeightAngle, MeasureError> {
    check_snapshot(positions, radii)?;
    check_finite("base_z_m", base_z_m)?;
    check_positive("base_diameter_m", base_diameter_m)?;
    check_positive("min_height_diameters", min_height_diameters)?;
    let items: Vec<(f64, f64)> = positions
        .iter()
        .zip(radii)
        .filter(|(p, _)| p.z >= base_z_m)
        .map(|(p, &r)| (0.0, p.z + r))
        .collect();
    let height_m = pile_height(&items, radii, base_z_m, min_height_diameters)?;
    Ok(HeightAngle {
        angle_deg: (2.0 * height_m / base_diameter_m).atan().to_degrees(),
        height_m,
        base_diameter_m,
    })
}

#[cfg(test)]
mod tests {
    use super::super::synthetic::{cone, jitter, ridge};
    use super::*;

    const D: f64 = 1e-3;

    fn spec() -> PileSpec {
        PileSpec::new(0.0, D)
    }

    /// A lattice cone 50 diameters in base radius: every surface point lies below
    /// the true surface by a staircase step in [0, d), which shifts the fitted line
    /// but barely tilts it. The flank spans 0.8 H over ~40 bins, so a d-sized
    /// quantisation tilts it by at most about d / (40 d) rad / sqrt(40) ≈ 0.2°;
    /// ±0.5° (the tolerance) covers it.
    #[test]
    fn cones_of_known_angle() {
        for angle in [25.0, 30.0, 35.0, 40.0, 45.0, 47.8] {
            let (p, r) = cone(D, 50.0 * D, angle, 0.0);
            let a = pile_angle(&p, &r, &spec()).unwrap();
            assert!((a.mean_deg - angle).abs() < 0.5, "{angle}: {a:?}");
            assert!((a.left_deg - angle).abs() < 0.75, "{angle}: {a:?}");
            assert!((a.right_deg - angle).abs() < 0.75, "{angle}: {a:?}");
            assert!(a.r2_left > 0.99 && a.r2_right > 0.99, "{a:?}");
            assert!(a.points_left >= 20 && a.points_right >= 20, "{a:?}");
            // The apex column is 0.43 d off the axis and its top up to one step
            // below the surface: H is short by at most d (1 + 0.43 tan θ) < 1.5 d.
            let h = 50.0 * D * angle.to_radians().tan();
            assert!(
                a.height_m <= h && a.height_m > h - 1.5 * D,
                "{angle}: {a:?}"
            );
            // The given axis and the apex estimate agree on a symmetric cone.
            let with_axis = PileSpec {
                axis_xy_m: Some([0.0, 0.0]),
                ..spec()
            };
            let b = pile_angle(&p, &r, &with_axis).unwrap();
            assert!((b.mean_deg - angle).abs() < 0.5, "{angle}: {b:?}");
        }
    }

    #[test]
    fn a_cone_is_fitted_in_every_side_view() {
        let (p, r) = cone(D, 50.0 * D, 35.0, 0.0);
        let v = side_views(&p, &r, &spec(), VIEWS).unwrap();
        assert_eq!(v.fitted_views(), VIEWS);
        // Each view sees the cone's generator (tolerance as in
        // `cones_of_known_angle`).
        for a in v.views.iter().flatten() {
            assert!((a.mean_deg - 35.0).abs() < 0.5, "{a:?}");
        }
        assert!((v.mean_deg() - 35.0).abs() < 0.5, "{v:?}");
    }

    #[test]
    fn an_unfittable_view_is_left_out_down_to_min_views() {
        // A ridge 80 diameters long along y: seen along x (the yz view,
        // azimuth 90°) it is a flat-topped block with vertical ends and no
        // flank points, while the other three views see sloped flanks.
        let (p, r) = ridge(D, 20.0 * D, 35.0, 35.0, 40.0 * D);
        let v = side_views(&p, &r, &spec(), 3).unwrap();
        assert_eq!(v.fitted_views(), 3, "{v:?}");
        assert!(v.views[2].is_none(), "{v:?}");
        let alone: Vec<f64> = [0, 1, 3]
            .map(|k| {
                let one = PileSpec {
                    azimuth_rad: f64::from(VIEW_AZIMUTHS_DEG[k]).to_radians(),
                    ..spec()
                };
                pile_angle(&p, &r, &one).unwrap().mean_deg
            })
            .to_vec();
        assert_eq!(v.mean_deg(), alone.iter().sum::<f64>() / 3.0);
        // Asking for all four views makes the same ridge not measurable.
        assert!(side_views(&p, &r, &spec(), VIEWS).is_err());
        for bad in [0, VIEWS + 1] {
            let err = side_views(&p, &r, &spec(), bad).unwrap_err();
            assert!(err.to_string().contains("min_views"), "{err}");
        }
    }

    #[test]
    fn side_view_along_x_sees_the_same_cone() {
        let (p, r) = cone(D, 50.0 * D, 40.0, 0.0);
        let yz = PileSpec {
            azimuth_rad: std::f64::consts::FRAC_PI_2,
            ..spec()
        };
        let a = pile_angle(&p, &r, &yz).unwrap();
        assert!((a.mean_deg - 40.0).abs() < 0.5, "{a:?}");
    }

    /// Left 35°, right 45°: the apex split separates the flanks.
    #[test]
    fn asymmetric_pile() {
        let (p, r) = ridge(D, 40.0 * D, 35.0, 45.0, 3.0 * D);
        let a = pile_angle(&p, &r, &spec()).unwrap();
        assert!((a.left_deg - 35.0).abs() < 0.75, "{a:?}");
        assert!((a.right_deg - 45.0).abs() < 0.75, "{a:?}");
        assert!((a.mean_deg - 40.0).abs() < 0.5, "{a:?}");
    }

    /// Positions jittered by ±0.2 d and radii by ±20%: the surface is rough on the
    /// particle scale; the fit over ~40 points per flank still lands within 1°.
    #[test]
    fn noisy_cone() {
        let snap = jitter(cone(D, 50.0 * D, 40.0, 0.0), 0.2 * D, 0.2, 7);
        let a = pile_angle(&snap.0, &snap.1, &spec()).unwrap();
        assert!((a.mean_deg - 40.0).abs() < 1.0, "{a:?}");
        assert!(a.r2_left > 0.98 && a.r2_right > 0.98, "{a:?}");
    }

    #[test]
    fn particles_below_the_base_are_ignored() {
        let (mut p, mut r) = cone(D, 30.0 * D, 40.0, 0.0);
        for i in 0..50 {
            p.push(Vec3::new(0.1 + i as f64 * D, 0.0, -0.05));
            r.push(0.5 * D);
        }
        let a = pile_angle(&p, &r, &spec()).unwrap();
        assert!((a.mean_deg - 40.0).abs() < 0.75, "{a:?}");
    }

    #[test]
    fn degenerate_inputs_are_not_measurable() {
        let s = spec();
        assert!(matches!(
            pile_angle(&[], &[], &s),
            Err(MeasureError::NoParticles { .. })
        ));
        let one = [Vec3::new(0.0, 0.0, 0.5 * D)];
        assert!(matches!(
            pile_angle(&one, &[0.5 * D], &s),
            Err(MeasureError::TooFlat { .. })
        ));
        // A flat bed two layers deep.
        let (p, r) =
            super::super::synthetic::lattice_under(D, 20.0 * D, 0.0, |_, _| 2.0 * D, |_, _| true);
        assert!(!p.is_empty());
        assert!(matches!(
            pile_angle(&p, &r, &s),
            Err(MeasureError::TooFlat { .. })
        ));
        // A single column: one bin, no flanks.
        let col: Vec<_> = (0..10)
            .map(|k| Vec3::new(0.0, 0.0, (k as f64 + 0.5) * D))
            .collect();
        assert!(matches!(
            pile_angle(&col, &[0.5 * D; 10], &s),
            Err(MeasureError::TooFewPoints { .. })
        ));
        assert!(matches!(
            pile_angle(&one, &[], &s),
            Err(MeasureError::LengthMismatch { .. })
        ));
        let nan = [Vec3::new(f64::NAN, 0.0, 0.0)];
        assert_eq!(
            pile_angle(&nan, &[D], &s),
            Err(MeasureError::BadParticle { index: 0 })
        );
        let bad = PileSpec {
            bin_width_m: 0.0,
            ..s
        };
        assert!(matches!(
            pile_angle(&col, &[0.5 * D; 10], &bad),
            Err(MeasureError::BadParameter {
                name: "bin_width_m",
                ..
            })
        ));
        assert!(height_diameter_angle(&one, &[0.5 * D], 0.0, 0.08, 3.0).is_err());
    }

    /// On a cone covering the disk, 2H/D = H/R_base = tan(angle). H is the lattice
    /// apex top, short of the true apex by less than 1.5 d (see above), so the angle
    /// is low by less than cos²θ · 1.5 d / R rad = 0.95° for θ = 41.8°, R = 50 d.
    #[test]
    fn height_over_diameter() {
        let (p, r) = cone(D, 50.0 * D, 41.8, 0.0);
        let a = height_diameter_angle(&p, &r, 0.0, 100.0 * D, 3.0).unwrap();
        assert!(a.angle_deg <= 41.8 && a.angle_deg > 41.8 - 0.95, "{a:?}");
        assert_eq!(a.base_diameter_m, 100.0 * D);
    }
}
