//! The `funnel_pile` scene: he2019's modified FBS-104 funnel flow meter
//! (§2.1, §2.3.2), the calibration test of the GA-BP study.
//!
//! # Geometry ([`geometry`])
//!
//! The platform is a disk of `platform_diameter_m` (he2019: 94 mm) whose top
//! face is z = 0. Above it hangs the funnel, a cone frustum on the same axis
//! from the outlet (`funnel_outlet_diameter_m`, its rim at `outlet_height_m`)
//! to the top rim (`funnel_top_diameter_m`, he2019: 120 mm,
//! `funnel_height_m` higher). he2019 says only that "the funnel outlet was
//! designed to have a small 7° angle of inclination to reduce the material
//! drop rate"; a sloped outlet that slows the drop is read here as a short
//! straight tube of the outlet's diameter hanging from the cone's rim with its
//! axis tilted `outlet_tilt_deg` from the vertical (towards +x): the stream
//! slides along the tube's lower side and leaves it off-axis. The tube is
//! `outlet_tube_length_m` long (paper silent; default one outlet diameter).
//! Its top rim is centred on the cone's lower rim, so the two meet except for
//! a sliver at most `outlet radius · sin(tilt)` wide (0.6 mm for a 10 mm
//! outlet at 7°). The pile can grow no higher than the tube's exit: the
//! outlet height must leave room for the angle sought (atan(exit height /
//! platform radius) bounds a pile covering the platform).
//!
//! The brush (he2019: "the material slides down along the funnel wall with the
//! brush at 60 rpm"; the standard funnel testers' stirrer) exists only when
//! `brush_rpm` is given: without it no brush wall is built at all. It is
//! `brush_blades` flat rectangles (default 2, evenly spaced) in meridian
//! planes, each with its outer long edge parallel to the cone wall at
//! `brush_gap_m` from it (default 1 mm, a stirrer's clearance), reaching
//! `brush_width_m` further inwards across the slope (default: far enough to
//! touch the axis at the outlet), from the top rim's height down into the
//! throat until the blade's inner lower corner is level with the outlet rim.
//! They turn about the funnel axis at `brush_rpm` during the discharge only.
//! Paper silent on all of it: blade count, gap, width and shape are choices.
//! The gap must exceed one particle diameter: a particle trapped between a
//! kinematic edge and the wall is crushed until the overlap check stops the
//! run (measured with a zero gap and 6 mm particles: 30 % overlap within
//! 0.07 s of brushing).
//!
//! # Protocol
//!
//! - `fill` (`fill_time_s`; he2019: fill rate 0.56 generated in 0.01 s): the
//!   charge — `fill_fraction` of the volume of the cone up to `fill_height_m`
//!   above the outlet (default the whole cone) — is laid out and released
//!   bottom-up one layer at a time ([`fill`]'s module docs).
//! - `stand` (`standing_time_s`, he2019: 3 s): the charge rests in the funnel,
//!   brush still. A cohesive powder arches over the outlet; a free-flowing one
//!   already runs out.
//! - `discharge` (the rest of `total_time_s`): the brush turns.
//! - `settle` (at most `settle_time_s`, he2019: the last 2 of 20 s): the brush
//!   stands; the phase ends early once the pile is at rest (mean kinetic energy
//!   per particle below the manifest's `at_rest` threshold, by default 1e-6
//!   m g d for 0.05 s, [`SettleCriterion::at_rest`]).
//!
//! Every `sample_interval_s` (default 0.02 s): particles whose centre has
//! sunk [`geometry::REMOVAL_DEPTH_DIAMETERS`] mean diameters below the
//! platform's face, or left the keep zone sideways, are removed
//! (`Simulation::retain`): they fell off the platform. The simulation box
//! must hold whatever the scene can throw, because leaving it stops the run
//! (the health check): it extends beyond that zone by what the fastest
//! particle travels in one interval, so a particle is removed before it can
//! leave the box, and above the funnel's rim by the height such a particle
//! thrown upwards climbs ([`geometry::FunnelGeometry::domain`]). The fastest
//! particle is bounded by free fall from the funnel top plus the brush tip
//! speed plus the speed of a particle squirting out of a contact squeezed to
//! the health check's overlap bound ([`geometry::spring_out_speed_m_s`]): the
//! kinematic brush wedges particles against those on the cone and throws them
//! out of the funnel faster than it moves. The box bounds positions only (the
//! neighbour grid covers the particles), so its size changes no trajectory.
//! Traces: kinetic energy, contacts, overlap, `discharged` (particles
//! whose centre is below the tube's lowest point), `removed` (cumulative) and
//! `angle` (the pile angle when measurable); the MCAP log gets a frame at each
//! sample.
//!
//! # Measurement ([`pile_angles`])
//!
//! he2019 §2.2: the pile's side silhouette, boundary points between 10 % and
//! 90 % of the pile height, least-squares lines left and right, their mean
//! ([`crate::measure::pile`], bins one mean diameter wide, the left/right
//! split at the apex so the off-axis stream of the tilted tube does not bias
//! it). The pile is every particle whose centre is on the platform
//! (0 ≤ z < the tube's lowest point, within the platform radius) moving
//! slower than [`PILE_SPEED_LIMIT_M_S`] (a particle still falling from the
//! funnel is not part of the silhouette). he2019 photographs one side; a
//! simulation can look from all of them, and a pile of a few hundred coarse
//! particles is rough, so the scene fits four side views 45° apart
//! ([`VIEW_AZIMUTHS_DEG`]), reports every flank's angle, R² and point count,
//! and gives the mean of the eight flanks as the angle of repose. A fit with
//! R² below [`R2_FLOOR`] is flagged (`angle_r2_below_floor` = 1), not
//! hidden. A view whose profile cannot be fitted (one flank with fewer than
//! three surface points, as when the tilted tube left the apex near the
//! platform's rim on that side) is left out, and the angle is the mean over
//! the flanks of the other views (`angle_views` says how many); a pile with
//! fewer than [`MIN_VIEWS`] fitted views, too low or too narrow, has no
//! side-view angle (and no headline): the run still succeeds with every other
//! measurement (the height angle, the cone, the counts) and records the
//! reason under `unmeasured` (`angle_deg`), as it does for a cone that cannot
//! be fitted (`angle_cone_deg`) or a platform without a pile
//! (`angle_2h_d_deg`). One fit that fails never discards the others.
//!
//! The same pile is also fitted as one cone over its whole surface
//! ([`crate::measure::cone`]: the top particle of every column one mean
//! diameter wide, 10 %–90 % of the height, a free axis): `angle_cone_deg`
//! with its point count, R², residual and the axis's distance from the
//! platform's centre. It uses every surface particle instead of the 5–7 of a
//! flank, so it scatters less between packings (measured in
//! `experiments/funnel_pile/README.md`); a study chooses it as its response
//! (`response` of a target scene). The headline stays he2019's side view.
//!
//! The height angle `angle_2h_d_deg` = atan(2H/D) takes H, the highest
//! particle top above the platform (`pile_height_m`), and D, the platform's
//! diameter, as the fixed-base method does (cai2024's GB/T 16913 pile,
//! [`super::static_pile`]). It assumes a cone whose base is the whole
//! platform, which the funnel's protocol gives: the pile grows until it sheds
//! over the rim (`removed` counts what fell). It reads one particle's height,
//! so it uses no flank fit at all, and scatters less between packings than
//! the side views (measured in `experiments/funnel_pile/README.md`); for a
//! rounded or lumpy top it reads steeper than the flanks.

pub mod fill;
pub mod geometry;

use self::geometry::FunnelGeometry;
use super::protocol::{run_phase, Phase, Progress, Sampler, SettleCriterion, Traces};
use super::resolution;
use super::skeleton::{finish, lab_error_conversions, open_log, Lab, LabError};
use super::{physics, SceneError};
use crate::dem::health::HealthLimits;
use crate::dem::material::effective_youngs_modulus;
use crate::dem::particles::Particles;
use crate::dem::simulation::{ContactSetup, Simulation, World};
use crate::dem::vec3::Vec3;
use crate::log::{AngleSample, RunLog, Trace};
use crate::manifest::scene::FunnelPileScene;
use crate::manifest::Experiment;
use crate::measure::cone::{cone_angle, ConeAngle, ConeSpec};
pub use crate::measure::pile::VIEW_AZIMUTHS_DEG;
use crate::measure::pile::{side_views, PileSpec, SideViews};
use crate::measure::MeasureError;
use crate::store::{RunResult, HEADLINE_KEY};
use std::path::Path;

/// Particles faster than this (m/s) are not part of the pile's silhouette.
pub const PILE_SPEED_LIMIT_M_S: f64 = 0.05;
/// A flank fit with an R² below this is flagged in the result. For a straight
/// flank of height 0.8 H sampled in bins of one diameter d with a surface
/// roughness of about 0.3 d, R² ≈ 1 − 12 (0.3 d)² / (0.8 H)², above 0.95 for
/// H ≥ 8 d; below 0.9 the flank is not a line (clumps, a crater, a cliff).
pub const R2_FLOOR: f64 = 0.9;

/// Why a funnel run failed beyond the engine's own errors.
#[derive(Debug, thiserror::Error)]
pub enum FunnelError {
    /// What any lab scene can fail at ([`LabError`]).
    #[error(transparent)]
    Lab(LabError),
    /// The charge region holds no particle.
    #[error("funnel_pile fill: the charge region (fill_height_m = {fill_height_m} m above the outlet, fill_fraction = {fill_fraction}) holds no particle")]
    EmptyCharge {
        /// Height of the charge, m.
        fill_height_m: f64,
        /// Requested solid fraction.
        fill_fraction: f64,
    },
    /// No angle could be measured at the end.
    #[error("funnel_pile: pile angle: {0}")]
    Angle(#[from] MeasureError),
}

lab_error_conversions!(FunnelError, "funnel_pile");

/// Fewest side views whose profile must fit for the pile to be measurable. A
/// single short flank in one view of a small, rough pile says little about the
/// pile; most views failing says it has no flanks to measure.
pub const MIN_VIEWS: usize = 3;

/// The pile: centres and radii of the particles on the platform moving slower
/// than [`PILE_SPEED_LIMIT_M_S`].
fn pile_particles(p: &Particles, geom: &FunnelGeometry) -> (Vec<Vec3>, Vec<f64>) {
    (0..p.len())
        .filter(|&i| {
            geom.on_platform(&p.position[i]) && p.velocity[i].norm() < PILE_SPEED_LIMIT_M_S
        })
        .map(|i| (p.position[i], p.radius[i]))
        .unzip()
}

/// Height of the pile's highest particle top above the platform, m (0 without
/// a pile); measured even when the angle is not.
pub fn pile_height_m(p: &Particles, geom: &FunnelGeometry) -> f64 {
    let (positions, radii) = pile_particles(p, geom);
    positions
        .iter()
        .zip(&radii)
        .map(|(x, r)| x.z + r)
        .fold(0.0, f64::max)
}

/// The height angle atan(2H/D) = atan(H/R) of a pile `height_m` high on a
/// platform of radius `platform_radius_m`, degrees (see the module docs).
pub fn height_angle_deg(height_m: f64, platform_radius_m: f64) -> f64 {
    (height_m / platform_radius_m).atan().to_degrees()
}

/// The pile's angles (see the module docs) in the particles' current state.
pub fn pile_angles(p: &Particles, geom: &FunnelGeometry) -> Result<SideViews, MeasureError> {
    let (positions, radii) = pile_particles(p, geom);
    side_views(
        &positions,
        &radii,
        &PileSpec::new(0.0, geom.d_mean_m),
        MIN_VIEWS,
    )
}

/// The pile's whole surface fitted as one cone (see the module docs).
pub fn pile_cone(p: &Particles, geom: &FunnelGeometry) -> Result<ConeAngle, MeasureError> {
    let (positions, radii) = pile_particles(p, geom);
    cone_angle(&positions, &radii, &ConeSpec::new(0.0, geom.d_mean_m))
}

/// Removes fallen particles and records traces, angles and log frames.
struct FunnelSampler<'a> {
    geom: &'a FunnelGeometry,
    traces: Traces,
    log: Option<&'a mut RunLog>,
    /// Particles inserted so far.
    charged: usize,
    /// Particles removed so far (fell off the platform).
    removed: usize,
}

impl FunnelSampler<'_> {
    /// Particles that have left the funnel: inserted less those whose centre
    /// is still above the tube's lowest point.
    fn discharged(&self, w: &World) -> usize {
        let inside = w
            .grain_centres()
            .0
            .iter()
            .filter(|x| x.z >= self.geom.exit_z_m)
            .count();
        self.charged - inside
    }
}

impl Sampler for FunnelSampler<'_> {
    type Error = FunnelError;

    fn sample(&mut self, _phase: &'static str, sim: &mut Simulation) -> Result<(), FunnelError> {
        let geom = self.geom;
        self.removed += sim.retain(|p, i| geom.keeps(&p.position[i]))?;
        let t = sim.world().time_s;
        self.traces.push_engine_state(sim);
        let discharged = self.discharged(sim.world()) as f64;
        self.traces.push("discharged", "1", t, discharged);
        self.traces.push("removed", "1", t, self.removed as f64);
        let angles = pile_angles(&sim.world().particles, geom).ok();
        if let Some(a) = angles {
            self.traces.push("angle", "deg", t, a.mean_deg());
        }
        if let Some(log) = self.log.as_deref_mut() {
            log.record(sim)?;
            log.scalar(Trace::Discharged, t, discharged)?;
            if let Some(a) = angles {
                log.angle(
                    t,
                    &AngleSample {
                        left_deg: a.left_deg(),
                        right_deg: a.right_deg(),
                        mean_deg: a.mean_deg(),
                        fit_r2: a.min_r2(),
                    },
                )?;
            }
        }
        Ok(())
    }
}

/// A finished funnel simulation before its pile is measured.
#[derive(Debug)]
pub struct FunnelOutcome {
    /// The result so far: counts, times and traces, no angle yet.
    pub result: RunResult,
    /// The final state.
    pub world: World,
    /// The scene's geometry.
    pub geometry: FunnelGeometry,
}

/// Runs a `funnel_pile` experiment (see the module docs); with `log`, writes
/// its MCAP log there (only when the run succeeds).
pub fn run(
    exp: &Experiment,
    scene: &FunnelPileScene,
    log: Option<&Path>,
) -> Result<RunResult, SceneError> {
    let mut log_file = open_log(log, exp, speed_scale(exp, scene)?)?;
    let FunnelOutcome {
        mut result,
        world,
        geometry,
    } = simulate(exp, scene, log_file.as_mut())?;
    measure_pile(&mut result, &world.particles, &geometry);
    if let Some(log) = log_file {
        log.finish()?;
    }
    Ok(result)
}

/// The side views and the cone fit of the pile in `p`, into `result`. Each
/// fit stands alone: one that cannot measure the pile is recorded in
/// [`RunResult::unmeasured`] with its reason and never discards the others.
pub fn measure_pile(result: &mut RunResult, p: &Particles, geom: &FunnelGeometry) {
    match pile_angles(p, geom) {
        Ok(angles) => put_angles(result, &angles),
        Err(e) => {
            // The side views are the headline.
            let why = FunnelError::from(e);
            unmeasured(result, "angle_deg", &why);
            unmeasured(result, HEADLINE_KEY, &why);
        }
    }
    match pile_cone(p, geom) {
        Ok(cone) => put_cone(result, &cone),
        Err(e) => unmeasured(result, "angle_cone_deg", e),
    }
}

/// Records that measurement `key` could not be taken, and why.
fn unmeasured(result: &mut RunResult, key: &str, why: impl std::fmt::Display) {
    result.unmeasured.insert(key.to_string(), why.to_string());
}

/// The colour scale of the log: the speed bound of the geometry, m/s.
fn speed_scale(exp: &Experiment, scene: &FunnelPileScene) -> Result<f64, SceneError> {
    let (_, d_mean) =
        physics::diameter_bounds(&physics::size_distribution(exp)).map_err(FunnelError::from)?;
    Ok(FunnelGeometry::new(scene, d_mean).speed_bound_m_s)
}

/// The fastest a particle can squirt out of its stiffest contact (the
/// particles' own or a wall material's) at the overlap bound of `health`, m/s
/// ([`geometry::spring_out_speed_m_s`]).
fn spring_out_speed(contact: &ContactSetup, rho: f64, health: &HealthLimits) -> f64 {
    let particle = &contact.particle_material;
    let pair = (effective_youngs_modulus(particle, particle), 0.5);
    let walls = contact
        .wall_materials
        .iter()
        .map(|(wall, _)| (effective_youngs_modulus(particle, wall), 1.0));
    std::iter::once(pair)
        .chain(walls)
        .map(|(e_star, c)| geometry::spring_out_speed_m_s(e_star, c, health.max_overlap_ratio, rho))
        .fold(0.0, f64::max)
}

/// Every angle with its fit diagnostics; the headline is the mean over all
/// flanks.
fn put_angles(result: &mut RunResult, a: &SideViews) {
    let mut put = |k: String, v: f64| {
        result.measurements.insert(k, v);
    };
    for (az, p) in VIEW_AZIMUTHS_DEG.iter().zip(&a.views) {
        let Some(p) = p else { continue };
        let view = format!("angle_az{az:03}");
        put(format!("{view}_left_deg"), p.left_deg);
        put(format!("{view}_right_deg"), p.right_deg);
        put(format!("{view}_deg"), p.mean_deg);
        put(format!("{view}_r2_left"), p.r2_left);
        put(format!("{view}_r2_right"), p.r2_right);
        put(format!("{view}_points_left"), p.points_left as f64);
        put(format!("{view}_points_right"), p.points_right as f64);
    }
    put("angle_deg".into(), a.mean_deg());
    put("angle_views".into(), a.fitted_views() as f64);
    put("angle_min_r2".into(), a.min_r2());
    put("angle_r2_floor".into(), R2_FLOOR);
    put(
        "angle_r2_below_floor".into(),
        f64::from(u8::from(a.min_r2() < R2_FLOOR)),
    );
    result.headline_angle_deg = Some(a.mean_deg());
}

/// The cone fit's angle and diagnostics (absent when the surface could not
/// be fitted).
fn put_cone(result: &mut RunResult, c: &ConeAngle) {
    let m = &mut result.measurements;
    m.insert("angle_cone_deg".into(), c.angle_deg);
    m.insert("angle_cone_points".into(), c.points as f64);
    m.insert("angle_cone_r2".into(), c.r2);
    m.insert("angle_cone_rms_m".into(), c.rms_m);
    m.insert(
        "angle_cone_axis_offset_m".into(),
        c.axis_xy_m[0].hypot(c.axis_xy_m[1]),
    );
}

/// Runs the protocol (fill, stand, discharge, settle) and returns the final
/// state with the counts and traces; the pile is not measured here, so a run
/// whose powder never reaches the platform still reports how much left the
/// funnel.
pub fn simulate(
    exp: &Experiment,
    scene: &FunnelPileScene,
    log: Option<&mut RunLog>,
) -> Result<FunnelOutcome, SceneError> {
    let walls = [
        scene.funnel_material.as_str(),
        scene.platform_material.as_str(),
        scene
            .brush_material
            .as_deref()
            .unwrap_or(&scene.funnel_material),
    ];
    let lab = Lab::new(exp, &walls, |e| FunnelError::from(e).into())?;
    let (rho, d_mean, sizes) = (lab.density_kg_m3, lab.d_mean_m, &lab.sizes);
    let dt = lab.plan.dt_s;
    let geom = FunnelGeometry::new(scene, d_mean);
    let brush_start = scene.fill_time_s + scene.standing_time_s;
    let brush_end = scene.total_time_s - scene.settle_time_s;
    let walls = geometry::walls(scene, &geom, brush_start, brush_end).map_err(FunnelError::from)?;
    let charge = fill::lay_out(
        |h| geom.charge_region(h),
        scene.fill_height(),
        scene.funnel_height_m,
        sizes,
        scene.fill_fraction,
        exp.seeds.packing_seed,
        d_mean,
        &walls,
    )
    .map_err(FunnelError::from)?;
    let mut layers = charge.layers.iter();
    let Some(first) = layers.next() else {
        return Err(FunnelError::EmptyCharge {
            fill_height_m: scene.fill_height(),
            fill_fraction: scene.fill_fraction,
        }
        .into());
    };
    let health = HealthLimits::default();
    let domain = geom
        .domain(spring_out_speed(&lab.contact, rho, &health))
        .map_err(FunnelError::from)?;
    let world = lab
        .grains
        .world(first, walls, domain)
        .map_err(FunnelError::from)?;
    let mut sim = lab.simulation(world, health).map_err(FunnelError::from)?;

    // Fill: layer k is released at k / n of the generation time.
    let n = charge.layers.len();
    let step_at = |k: usize| (scene.fill_time_s * k as f64 / n as f64 / dt).round() as u64;
    let mut charged = first.len();
    let mut skipped = 0;
    for (k, layer) in layers.enumerate() {
        sim.advance(step_at(k + 1) - step_at(k))
            .map_err(FunnelError::from)?;
        let w = sim.world();
        let free = fill::free_sites(layer, &w.particles.position, &w.particles.radius);
        skipped += layer.len() - free.len();
        charged += free.len();
        lab.grains
            .insert(&mut sim, &free)
            .map_err(FunnelError::from)?;
    }
    sim.advance(step_at(n) - step_at(n - 1))
        .map_err(FunnelError::from)?;

    let mut sampler = FunnelSampler {
        geom: &geom,
        traces: Traces::default(),
        log,
        charged,
        removed: 0,
    };
    let mut progress = Progress::on_stderr();
    let every = geom.sample_interval_s;
    let now = |sim: &Simulation| sim.world().time_s;
    let stand = Phase {
        name: "stand",
        max_duration_s: brush_start - now(&sim),
        settle: None,
    };
    run_phase(&mut sim, &stand, dt, every, &mut sampler, &mut progress)?;
    let discharge = Phase {
        name: "discharge",
        max_duration_s: brush_end - now(&sim),
        settle: None,
    };
    run_phase(&mut sim, &discharge, dt, every, &mut sampler, &mut progress)?;
    let settle = Phase {
        name: "settle",
        max_duration_s: scene.settle_time_s,
        settle: Some(SettleCriterion::at_rest(
            &exp.at_rest,
            lab.mean_particle_mass_kg(),
            d_mean,
        )),
    };
    let settled = run_phase(&mut sim, &settle, dt, every, &mut sampler, &mut progress)?;

    let w = sim.world();
    let discharged = sampler.discharged(w);
    let removed = sampler.removed;
    let on_platform = w
        .grain_centres()
        .0
        .iter()
        .filter(|x| geom.on_platform(x))
        .count();
    let traces = std::mem::take(&mut sampler.traces);
    // `run` finishes the log, after measuring the pile.
    let mut result = finish(exp, &sim, &lab.plan, traces, None, charged, settled.settled)?;
    result.warnings.extend(lab.grains.warnings());
    let mut put = |k: &str, v: f64| {
        result.measurements.insert(k.to_string(), v);
    };
    put("brush_blades", f64::from(scene.brush_blade_count()));
    put("brush_start_s", brush_start);
    put("brush_end_s", brush_end);
    put("charge_height_m", charge.height_m);
    put("charge_lattice_spacing", charge.spacing);
    put("charge_sites_at_brush", charge.dropped_at_walls as f64);
    put("charge_sites_occupied", skipped as f64);
    put("discharged", discharged as f64);
    put("discharged_fraction", discharged as f64 / charged as f64);
    put("left_in_funnel", (charged - discharged) as f64);
    put("removed", removed as f64);
    put("on_platform", on_platform as f64);
    let height = pile_height_m(&w.particles, &geom);
    put("pile_height_m", height);
    if height > 0.0 {
        put(
            "angle_2h_d_deg",
            height_angle_deg(height, geom.platform_radius_m),
        );
    } else {
        unmeasured(
            &mut result,
            "angle_2h_d_deg",
            "funnel_pile: height angle: not measurable: no particle at rest on the platform",
        );
    }
    resolution::at_least(
        &mut result,
        "platform_diameters",
        2.0 * geom.platform_radius_m / d_mean,
        resolution::ACROSS_MIN,
    );
    Ok(FunnelOutcome {
        result,
        world: w.clone(),
        geometry: geom,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::particles::ParticleInit;
    use crate::manifest::parse_experiment;
    use crate::manifest::scene::Scene;

    /// Sphere radius of the smoke manifest, m.
    const R: f64 = 0.003;

    /// The smoke manifest's geometry (platform radius 47 mm).
    fn geometry() -> FunnelGeometry {
        let text = include_str!("../../experiments/funnel_pile/smoke.json");
        let exp = parse_experiment(text).unwrap();
        let Scene::FunnelPile(scene) = &exp.scene else {
            unreachable!()
        };
        FunnelGeometry::new(scene, 2.0 * R)
    }

    /// Columns of resting spheres on a square grid of one diameter over the
    /// platform, each as high as `height(x, y)` (m) allows.
    fn pile(geom: &FunnelGeometry, height: impl Fn(f64, f64) -> f64) -> Particles {
        let mut p = Particles::default();
        let n = (geom.platform_radius_m / (2.0 * R)) as i32;
        for i in -n..=n {
            for j in -n..=n {
                let (x, y) = (f64::from(i) * 2.0 * R, f64::from(j) * 2.0 * R);
                let mut z = R;
                while x.hypot(y) <= geom.platform_radius_m && z + R <= height(x, y) {
                    let position = Vec3::new(x, y, z);
                    p.push(
                        &ParticleInit {
                            position,
                            velocity: Vec3::zeros(),
                            angular_velocity: Vec3::zeros(),
                            radius_m: R,
                        },
                        60.0,
                    );
                    z += 2.0 * R;
                }
            }
        }
        p
    }

    #[test]
    fn a_centred_cone_is_measured_in_every_view() {
        // A 35° cone 36 mm high: each view's silhouette is its generator.
        let geom = geometry();
        let slope = 35f64.to_radians().tan();
        let p = pile(&geom, |x, y| 0.036 - slope * x.hypot(y));
        let a = pile_angles(&p, &geom).unwrap();
        assert_eq!(a.fitted_views(), 4);
        // Columns of whole spheres make a staircase; its fitted slope stays
        // within a few degrees of the cone's.
        assert!((a.mean_deg() - 35.0).abs() < 5.0, "{}", a.mean_deg());
    }

    #[test]
    fn a_flat_layer_is_not_measurable() {
        // Two layers: lower than the 3 diameters a pile needs, in every view.
        let geom = geometry();
        let p = pile(&geom, |_, _| 4.0 * R);
        assert!(pile_angles(&p, &geom).is_err());
    }

    /// A pile the side views cannot fit still reports every other
    /// measurement; the missing one carries its reason, which a study reads
    /// as the reason for a missing replicate.
    #[test]
    fn an_unmeasurable_view_discards_nothing_else() {
        let geom = geometry();
        let exp =
            parse_experiment(include_str!("../../experiments/funnel_pile/smoke.json")).unwrap();
        let mut result = RunResult::new(&exp, "test");
        result.measurements.insert("pile_height_m".into(), 4.0 * R);
        measure_pile(&mut result, &pile(&geom, |_, _| 4.0 * R), &geom);
        assert_eq!(result.headline_angle_deg, None);
        assert!(!result.measurements.contains_key("angle_deg"));
        assert_eq!(result.measurements["pile_height_m"], 4.0 * R);
        let why = result.unmeasured["angle_deg"].clone();
        assert!(why.contains("not measurable"), "{why}");
        assert_eq!(result.headline_reason(), Some(why.as_str()));
        let err = crate::scenes::responses::response(&result, "funnel_pile", "angle_deg")
            .unwrap_err()
            .to_string();
        assert!(err.ends_with(&why), "{err}");
        // A tall cone on the same platform is measured by both fits.
        let mut tall = RunResult::new(&exp, "test");
        let top = 12.0 * R;
        measure_pile(&mut tall, &pile(&geom, |x, y| top - x.hypot(y)), &geom);
        assert!(tall.unmeasured.is_empty(), "{:?}", tall.unmeasured);
        assert!(tall.headline_angle_deg.is_some());
    }
}
