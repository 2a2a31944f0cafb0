//! Resolution figures: whether a scene's particles are fine enough for the
//! test it models. A calibration can only be as good as the scene that
//! measures it: a drum two grains deep, or a box ten grains across, gives an
//! angle that says more about the particle size than about the parameters.
//! Each lab scene records its figures in result.json (`resolution`: each
//! figure's value and limits, [`ResolutionFigure`]); a figure outside its
//! limits adds a warning that names the figure, its value and the limit, and
//! verification reports the scene as "unresolved at this particle size"
//! beside its numbers.
//!
//! # Figures and limits
//!
//! | figure | scenes | limit | source |
//! |---|---|---|---|
//! | `platform_diameters`, `disk_diameters`, `box_length_diameters`, `drum_diameters` | funnel, static pile, baffle, drum | ≥ [`ACROSS_MIN`] | repose's limit (below) |
//! | `bed_depth_diameters` | drum | ≥ [`BED_DEPTH_MIN`] | repose's limit (below) |
//! | `froude_number` Ω²R/g | drum | [`FROUDE_ROLLING`] | the rolling regime, Mellmann (2001) |
//! | `orifice_diameters`, `beverloo_orifice_diameters` | hopper | ≥ [`ORIFICE_MIN`], none | Beverloo et al. (1961) |
//! | `slope_height_diameters` | baffle | ≥ [`SLOPE_HEIGHT_MIN`] | repose's limit (below) |
//!
//! - **Across a device, ≥ 20 diameters.** An angle is fitted to the surface
//!   particles between 10 % and 90 % of a slope's height; a cone filling a
//!   platform D across puts about 0.4 D/d of them on each flank, so 20
//!   diameters give about 8 points per fit (the fits refuse fewer than 3), and
//!   leave most of the width clear of the few layers that order against a
//!   wall. This is repose's limit, chosen for the fit, not a literature value.
//! - **Drum bed depth, ≥ 10 diameters.** The dynamic angle is that of a thin
//!   flowing layer over a bed in solid-body rotation; a bed only a few grains
//!   deep has no such layer beneath its surface. repose's limit.
//! - **Drum Froude number, 10⁻⁴ – 10⁻².** Mellmann (2001, Powder Technol.
//!   118, 251–270) classifies the transverse motion by Fr = Ω²R/g: rolling
//!   (a flat surface at the dynamic angle) for 10⁻⁴ < Fr < 10⁻², cascading
//!   (a curved, kidney-shaped surface) up to 10⁻¹, then cataracting. A
//!   dynamic angle of repose is the rolling regime's.
//! - **Hopper orifice, ≥ 6 diameters.** Beverloo et al. (1961, Chem. Eng. Sci.
//!   15, 260–269) found the discharge rate to go as (D₀ − k d)^{5/2} with
//!   k ≈ 1.5 for orifices of a few diameters and more; near 5 diameters and
//!   below, arches block the flow intermittently. The effective orifice
//!   (D₀ − k d)/d, k = [`crate::scenes::hopper::BEVERLOO_K`], is reported
//!   beside it.
//! - **Baffle slope height, ≥ 5 diameters.** The slope left by the lifted
//!   baffle is fitted between 10 % and 90 % of its height; fewer than 5
//!   grains of height leave 2–3 surface points per column of the fit.
//!   repose's limit.

use crate::store::{ResolutionFigure, RunResult};

/// Fewest particle diameters across a device (platform, disk, box, drum).
pub const ACROSS_MIN: f64 = 20.0;
/// Fewest particle diameters of drum bed depth.
pub const BED_DEPTH_MIN: f64 = 10.0;
/// The drum's rolling regime, Froude number Ω²R/g (Mellmann 2001).
pub const FROUDE_ROLLING: (f64, f64) = (1e-4, 1e-2);
/// Fewest particle diameters across a hopper orifice (Beverloo et al. 1961).
pub const ORIFICE_MIN: f64 = 6.0;
/// Fewest particle diameters of baffle slope height.
pub const SLOPE_HEIGHT_MIN: f64 = 5.0;

/// Records figure `name` = `value` with limits `min`/`max` into `result`,
/// with a warning naming the figure and the limit when it is outside them.
pub fn record(result: &mut RunResult, name: &str, value: f64, min: Option<f64>, max: Option<f64>) {
    let figure = ResolutionFigure { value, min, max };
    if let Some(why) = figure.violation() {
        result.warnings.push(format!(
            "unresolved at this particle size: {name} = {value:.4} {why} (see \
             src/scenes/resolution.rs)"
        ));
    }
    result.resolution.insert(name.to_string(), figure);
}

/// The figures outside their limits in `results` (the runs of one scene),
/// each once by name in name order, as `name = value below/above limit`.
pub fn unresolved_figures<'a>(results: impl IntoIterator<Item = &'a RunResult>) -> Vec<String> {
    let mut found = std::collections::BTreeMap::new();
    for result in results {
        for (name, figure) in &result.resolution {
            if let Some(why) = figure.violation() {
                found
                    .entry(name.clone())
                    .or_insert_with(|| format!("{name} = {:.4} {why}", figure.value));
            }
        }
    }
    found.into_values().collect()
}

/// Records a figure that must be at least `min`.
pub fn at_least(result: &mut RunResult, name: &str, value: f64, min: f64) {
    record(result, name, value, Some(min), None);
}

/// The drum's Froude number Ω²R/g at `rpm` for inner radius `radius_m`.
pub fn froude_number(rpm: f64, radius_m: f64) -> f64 {
    let omega = rpm * 2.0 * std::f64::consts::PI / 60.0;
    omega * omega * radius_m / crate::scenes::physics::STANDARD_GRAVITY_M_S2
}

/// Depth of a bed at rest filling `fill_fraction` of a circle of radius
/// `radius_m` (a circular segment), m: the segment of central angle θ has
/// area R²(θ − sin θ)/2 and depth R(1 − cos(θ/2)); θ by bisection.
pub fn bed_depth_m(radius_m: f64, fill_fraction: f64) -> f64 {
    let target = fill_fraction.clamp(0.0, 1.0) * 2.0 * std::f64::consts::PI;
    let (mut lo, mut hi) = (0.0, 2.0 * std::f64::consts::PI);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if mid - mid.sin() < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let theta = 0.5 * (lo + hi);
    radius_m * (1.0 - (0.5 * theta).cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand computations: a half-full circle is one radius deep; at 60 rpm
    /// (Ω = 2π s⁻¹) a 22.5 mm radius gives Fr = 4π² · 0.0225 / 9.81 =
    /// 0.0905 (he2019-quick's drum, cascading; g is the scenes' 9.81 m/s²).
    #[test]
    fn figures_by_hand() {
        assert!((bed_depth_m(1.0, 0.5) - 1.0).abs() < 1e-12);
        assert!(bed_depth_m(1.0, 0.0).abs() < 1e-12);
        // Full: the bisection meets θ − sin θ = 2π where its slope vanishes,
        // so θ (and the depth) is good to ~1e-11 only.
        assert!((bed_depth_m(1.0, 1.0) - 2.0).abs() < 1e-9);
        // A quarter fill: θ − sin θ = π/2 at θ = 2.3099 rad, depth
        // 1 − cos(1.15495) = 0.5960.
        assert!((bed_depth_m(1.0, 0.25) - 0.5960).abs() < 1e-4);
        let fr = froude_number(60.0, 0.0225);
        assert!((fr - 0.09054682936779226).abs() < 1e-15);
    }

    #[test]
    fn a_figure_outside_its_limit_warns_naming_it() {
        let exp = crate::manifest::parse_experiment(include_str!(
            "../../experiments/funnel_pile/smoke.json"
        ))
        .unwrap();
        let mut r = RunResult::new(&exp, "test");
        at_least(&mut r, "platform_diameters", 25.0, ACROSS_MIN);
        assert!(r.warnings.is_empty());
        record(&mut r, "froude_number", 0.09, Some(1e-4), Some(1e-2));
        assert_eq!(r.warnings.len(), 1);
        assert!(
            r.warnings[0].contains("froude_number = 0.0900 above 0.01"),
            "{}",
            r.warnings[0]
        );
        at_least(&mut r, "bed_depth_diameters", 2.6, BED_DEPTH_MIN);
        assert!(
            r.warnings[1].contains("bed_depth_diameters = 2.6000 below 10"),
            "{}",
            r.warnings[1]
        );
        assert_eq!(r.unresolved(), ["bed_depth_diameters", "froude_number"]);
        assert_eq!(
            unresolved_figures([&r, &r]),
            [
                "bed_depth_diameters = 2.6000 below 10",
                "froude_number = 0.0900 above 0.01"
            ]
        );
    }
}
