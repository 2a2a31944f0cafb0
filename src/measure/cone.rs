//! The whole pile surface fitted as one cone: the angle of repose from every
//! surface particle at every azimuth, not from a few side silhouettes.
//!
//! A side view ([`super::pile`]) fits each flank through 5–7 silhouette
//! points of a small pile, so one rough spot moves a flank by degrees and one
//! run's eight flanks span 20° or more. Here the surface is the top of the
//! pile seen from above: the platform is cut into square columns
//! `cell_m` wide, and the highest particle top (centre height + radius) in
//! each column is one surface point at that particle's centre (x, y). The
//! points whose height above the base lies within `band` of the pile height
//! (he2019's 10 %–90 %) are fitted by least squares to a right circular cone
//! with a free axis,
//!
//! ```text
//! z = h − s · √((x − x₀)² + (y − y₀)²),
//! ```
//!
//! and the angle of repose is atan(s). The axis (x₀, y₀) is fitted because a
//! pile poured from a tilted outlet stands off the platform's centre; it
//! starts at the highest particle and the fit is the project's one
//! Levenberg–Marquardt loop ([`crate::stats::levenberg`], Marquardt damping)
//! on the four parameters (h, s, x₀, y₀).
//! Every surface point of the band weighs the same, so the outer rings,
//! which hold most of the surface, dominate as they do in a photograph of
//! the whole pile.

use nalgebra::{DMatrix, DVector};

use super::{check_positive, check_snapshot, mean_diameter, MeasureError};
use crate::dem::vec3::Vec3;
use crate::stats::levenberg::{minimise, Damping, LeastSquares, LmSettings, Stopping};

/// How to fit a pile's surface as a cone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeSpec {
    /// Height of the base the pile stands on, m; particles whose centre is
    /// below it are ignored.
    pub base_z_m: f64,
    /// Width of the square surface columns, m (about one particle diameter:
    /// the surface without holes).
    pub cell_m: f64,
    /// Fraction of the pile height between which surface points are fitted.
    pub band: (f64, f64),
    /// A pile lower than this many mean particle diameters is not measurable.
    pub min_height_diameters: f64,
}

impl ConeSpec {
    /// he2019's band (10 %–90 % of the height), at least 3 diameters high.
    pub fn new(base_z_m: f64, cell_m: f64) -> Self {
        Self {
            base_z_m,
            cell_m,
            band: (0.1, 0.9),
            min_height_diameters: 3.0,
        }
    }
}

/// Fewest surface points a cone fit accepts (four parameters and a
/// meaningful residual).
pub const MIN_CONE_POINTS: usize = 12;

/// A pile's angle of repose from its whole surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeAngle {
    /// atan(s), degrees.
    pub angle_deg: f64,
    /// Fitted axis (x₀, y₀), m.
    pub axis_xy_m: [f64; 2],
    /// Fitted apex height h above the base, m.
    pub apex_height_m: f64,
    /// Pile height: highest particle top above the base, m.
    pub height_m: f64,
    /// Surface points fitted.
    pub points: usize,
    /// Root mean square of the height residuals, m.
    pub rms_m: f64,
    /// R² of the fitted heights.
    pub r2: f64,
}

/// The pile's cone angle (see the module docs).
pub fn cone_angle(
    positions: &[Vec3],
    radii: &[f64],
    spec: &ConeSpec,
) -> Result<ConeAngle, MeasureError> {
    check_snapshot(positions, radii)?;
    check_positive("cell_m", spec.cell_m)?;
    check_positive("min_height_diameters", spec.min_height_diameters)?;
    let (b0, b1) = spec.band;
    if !((0.0..1.0).contains(&b0) && b0 < b1 && b1 <= 1.0) {
        return Err(MeasureError::BadParameter {
            name: "band",
            value: b1,
            allowed: "0 <= lower < upper <= 1",
        });
    }
    let on_base: Vec<(Vec3, f64)> = positions
        .iter()
        .zip(radii)
        .filter(|(p, _)| p.z >= spec.base_z_m)
        .map(|(p, &r)| (*p, r))
        .collect();
    if on_base.is_empty() {
        return Err(MeasureError::NoParticles { what: "the pile" });
    }
    let height_m = on_base
        .iter()
        .map(|(p, r)| p.z + r - spec.base_z_m)
        .fold(f64::NEG_INFINITY, f64::max);
    let radii_on_base: Vec<f64> = on_base.iter().map(|(_, r)| *r).collect();
    let min_m = spec.min_height_diameters * mean_diameter(&radii_on_base);
    if height_m < min_m {
        return Err(MeasureError::TooFlat { height_m, min_m });
    }
    let surface = column_tops(&on_base, spec.cell_m);
    let (lo, hi) = (spec.base_z_m + b0 * height_m, spec.base_z_m + b1 * height_m);
    let band: Vec<[f64; 3]> = surface
        .into_iter()
        .filter(|p| p[2] >= lo && p[2] <= hi)
        .map(|p| [p[0], p[1], p[2] - spec.base_z_m])
        .collect();
    if band.len() < MIN_CONE_POINTS {
        return Err(MeasureError::TooFewPoints {
            what: "the pile surface",
            found: band.len(),
            needed: MIN_CONE_POINTS,
        });
    }
    let apex = on_base
        .iter()
        .fold((f64::NEG_INFINITY, [0.0, 0.0]), |best, (p, r)| {
            if p.z + r > best.0 {
                (p.z + r, [p.x, p.y])
            } else {
                best
            }
        })
        .1;
    let fit = fit_cone(&band, apex)?;
    Ok(ConeAngle {
        angle_deg: fit.slope.atan().to_degrees(),
        axis_xy_m: fit.axis,
        apex_height_m: fit.apex_height,
        height_m,
        points: band.len(),
        rms_m: (fit.sse / band.len() as f64).sqrt(),
        r2: fit.r2,
    })
}

/// The highest particle top per square column of the plane: (x, y) of the
/// particle's centre and its top height. Sorted by column, so the result does
/// not depend on the particles' order except for exact ties (first wins).
fn column_tops(particles: &[(Vec3, f64)], cell_m: f64) -> Vec<[f64; 3]> {
    let mut tops: std::collections::BTreeMap<(i64, i64), [f64; 3]> =
        std::collections::BTreeMap::new();
    for (p, r) in particles {
        let key = ((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64);
        let top = p.z + r;
        let entry = tops.entry(key).or_insert([p.x, p.y, f64::NEG_INFINITY]);
        if top > entry[2] {
            *entry = [p.x, p.y, top];
        }
    }
    tops.into_values().collect()
}

struct ConeFit {
    apex_height: f64,
    slope: f64,
    axis: [f64; 2],
    sse: f64,
    r2: f64,
}

/// The cone z = h − s ρ as a least-squares problem in θ = (h, s, x₀, y₀)
/// for the one Levenberg–Marquardt loop ([`crate::stats::levenberg`]).
struct ConeProblem<'a> {
    points: &'a [[f64; 3]],
}

impl ConeProblem<'_> {
    /// The model height at `q` and its horizontal distance ρ from the axis.
    fn model(q: &[f64; 3], p: &[f64]) -> (f64, f64, f64, f64) {
        let (dx, dy) = (q[0] - p[2], q[1] - p[3]);
        let rho = dx.hypot(dy);
        (p[0] - p[1] * rho, rho, dx, dy)
    }
}

impl LeastSquares for ConeProblem<'_> {
    fn objective(&self, p: &[f64]) -> f64 {
        self.points
            .iter()
            .map(|q| {
                let r = Self::model(q, p).0 - q[2];
                r * r
            })
            .sum()
    }

    fn linearise(&self, p: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let n = self.points.len();
        let mut e = DVector::zeros(n);
        let mut jacobian = DMatrix::zeros(n, 4);
        for (i, q) in self.points.iter().enumerate() {
            let (model, rho, dx, dy) = Self::model(q, p);
            let (ux, uy) = if rho > 0.0 {
                (dx / rho, dy / rho)
            } else {
                (0.0, 0.0)
            };
            e[i] = model - q[2];
            jacobian[(i, 0)] = 1.0;
            jacobian[(i, 1)] = -rho;
            jacobian[(i, 2)] = p[1] * ux;
            jacobian[(i, 3)] = p[1] * uy;
        }
        (e, jacobian)
    }
}

/// The loop's settings: Marquardt damping from 10⁻³, at most 200 trials,
/// stopping on a relative gain or a relative step below 10⁻¹².
fn cone_lm() -> LmSettings {
    LmSettings {
        damping: Damping::Marquardt { initial: 1e-3 },
        stopping: Stopping {
            max_trials: Some(200),
            objective_gain: Some(1e-12),
            step: Some(1e-12),
            ..Stopping::default()
        },
    }
}

/// Fits the cone from the axis `start` (see the module docs).
fn fit_cone(points: &[[f64; 3]], start: [f64; 2]) -> Result<ConeFit, MeasureError> {
    // Linear least squares for (h, s) about the starting axis.
    let rho: Vec<f64> = points
        .iter()
        .map(|q| (q[0] - start[0]).hypot(q[1] - start[1]))
        .collect();
    let n = points.len() as f64;
    let (mr, mz) = (
        rho.iter().sum::<f64>() / n,
        points.iter().map(|q| q[2]).sum::<f64>() / n,
    );
    let sxx: f64 = rho.iter().map(|r| (r - mr) * (r - mr)).sum();
    let sxz: f64 = rho
        .iter()
        .zip(points)
        .map(|(r, q)| (r - mr) * (q[2] - mz))
        .sum();
    if sxx <= 0.0 {
        return Err(MeasureError::VerticalLine {
            what: "pile surface",
        });
    }
    let s0 = -sxz / sxx;
    let problem = ConeProblem { points };
    let fit = minimise(
        &problem,
        &[mz + s0 * mr, s0, start[0], start[1]],
        &cone_lm(),
    );
    let (p, sse) = (fit.theta, fit.objective);
    let (xmin, xmax, ymin, ymax) = points.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |b, q| (b.0.min(q[0]), b.1.max(q[0]), b.2.min(q[1]), b.3.max(q[1])),
    );
    let inside = p[2] >= xmin && p[2] <= xmax && p[3] >= ymin && p[3] <= ymax;
    if p[1].is_nan() || p[1] <= 0.0 || !inside {
        return Err(MeasureError::Series(format!(
            "the pile surface is not a cone (fitted slope {:.3}, axis ({:.4}, {:.4}) m)",
            p[1], p[2], p[3]
        )));
    }
    let sst: f64 = points.iter().map(|q| (q[2] - mz) * (q[2] - mz)).sum();
    Ok(ConeFit {
        apex_height: p[0],
        slope: p[1],
        axis: [p[2], p[3]],
        sse,
        r2: if sst > 0.0 { 1.0 - sse / sst } else { 0.0 },
    })
}

#[cfg(test)]
mod tests {
    use super::super::synthetic::{cone, jitter};
    use super::*;

    fn snapshot_cone(angle: f64, shift: [f64; 2]) -> (Vec<Vec3>, Vec<f64>) {
        let s = cone(0.002, 0.04, angle, 0.0);
        let pos =
            s.0.iter()
                .map(|p| Vec3::new(p.x + shift[0], p.y + shift[1], p.z))
                .collect();
        (pos, s.1)
    }

    #[test]
    fn a_lattice_cone_gives_its_angle_and_axis() {
        for angle in [25.0, 35.0, 48.0] {
            let (pos, radii) = snapshot_cone(angle, [0.004, -0.003]);
            let a = cone_angle(&pos, &radii, &ConeSpec::new(0.0, 0.002)).unwrap();
            assert!(
                (a.angle_deg - angle).abs() < 1.5,
                "{angle}: {}",
                a.angle_deg
            );
            assert!((a.axis_xy_m[0] - 0.004).abs() < 0.002, "{:?}", a.axis_xy_m);
            assert!((a.axis_xy_m[1] + 0.003).abs() < 0.002, "{:?}", a.axis_xy_m);
            assert!(a.points > 100 && a.r2 > 0.95, "{a:?}");
        }
    }

    #[test]
    fn the_cone_angle_scatters_less_than_one_side_view_between_jitters() {
        // The same lattice pile, jittered by 0.4 d with 8 seeds: the spread
        // of the cone angle over the seeds against that of one side view's
        // flank (the precision the cone is for; both share the lattice's
        // own bias).
        let (pos, radii) = snapshot_cone(40.0, [0.0, 0.0]);
        let (mut cone, mut flank) = (Vec::new(), Vec::new());
        for seed in 0..8 {
            let s = jitter((pos.clone(), radii.clone()), 0.0008, 0.0, seed);
            let c = cone_angle(&s.0, &s.1, &ConeSpec::new(0.0, 0.002)).unwrap();
            let v = super::super::pile::pile_angle(
                &s.0,
                &s.1,
                &super::super::pile::PileSpec::new(0.0, 0.002),
            )
            .unwrap();
            cone.push(c.angle_deg);
            flank.push(v.left_deg);
        }
        let sd = |x: &[f64]| {
            let m = x.iter().sum::<f64>() / x.len() as f64;
            (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
        };
        assert!(
            sd(&cone) < 0.5 * sd(&flank),
            "cone sd {} vs flank sd {}",
            sd(&cone),
            sd(&flank)
        );
    }

    #[test]
    fn flat_beds_and_bad_settings_are_not_measurable() {
        let (pos, radii) = snapshot_cone(35.0, [0.0, 0.0]);
        let flat: Vec<Vec3> = pos.iter().map(|p| Vec3::new(p.x, p.y, 0.001)).collect();
        assert!(matches!(
            cone_angle(&flat, &radii, &ConeSpec::new(0.0, 0.002)),
            Err(MeasureError::TooFlat { .. })
        ));
        let mut spec = ConeSpec::new(0.0, 0.002);
        spec.band = (0.5, 0.4);
        assert!(cone_angle(&pos, &radii, &spec).is_err());
        spec = ConeSpec::new(0.0, 0.0);
        assert!(cone_angle(&pos, &radii, &spec).is_err());
    }
}
