//! The `drum` scene: a horizontal rotating cylinder (he2019 §3.6.2: ID 45 mm,
//! length 100 mm, 30 % fill, 60 rpm for 5 s then 2 s standing; cai2024:
//! 100 × 100 mm, 25 %, 50 rpm).
//!
//! Geometry: the drum axis is the y axis through the origin, gravity −z. The
//! full drum is a cylinder closed by two end caps (disks of the drum's wall
//! material) that turn with it or, with `end_walls: "fixed"`, stand still
//! while it turns (their wall velocity stays zero, so a grain sliding on a
//! cap feels a stationary wall); with `periodic_slice_m` only a slice of that
//! thickness is simulated, periodic along y, with no end caps (the cylinder
//! extends past the periodic box so its rims are never felt).
//!
//! Protocol: particles are placed without overlap (seeded by the packing seed)
//! in the square inscribed in the drum's cross-section, as many as fill
//! `fill_fraction` of the drum volume at a bulk solid fraction of
//! [`BULK_SOLID_FRACTION`]; they settle (`settle`, at most `settle_max_s`,
//! ending once the bed is at rest, [`SettleCriterion::at_rest`]); the drum turns at
//! `rpm` for `rotation_time_s` (`rotate`) and then stands for
//! `standing_time_s` (`stand`).
//!
//! Measurement ([`crate::measure::drum`]): the free-surface angle every
//! `sample_interval_s`; the dynamic angle is the mean (± standard deviation)
//! over the second half of the rotation (the first half is spin-up and is
//! not averaged); the static angle is measured at the end of standing. The
//! headline is the dynamic angle, else the static one. A surface that
//! cannot be fitted at the end leaves the static angle out with its reason
//! in `unmeasured` (`static_angle_deg`, and the headline's when there is no
//! dynamic angle either); the run keeps every other measurement.

use super::protocol::{run_phase, Phase, Progress, Sampler, SettleCriterion, Traces};
use super::resolution;
use super::skeleton::{finish, lab_error_conversions, open_log, Lab, LabError};
use super::SceneError;
use crate::dem::domain::Domain;
use crate::dem::health::{HealthError, HealthLimits};
use crate::dem::simulation::{Simulation, World};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{Motion, Wall};
use crate::log::RunLog;
use crate::manifest::scene::{DrumScene, EndWalls};
use crate::manifest::Experiment;
use crate::measure::drum::{drum_surface_angle, DrumSpec};
use crate::measure::series::mean_std;
use crate::packing::place::{place_lattice, place_random, FillTarget, PlacementSpec};
use crate::packing::region::Region;
use crate::packing::PackingError;
use crate::store::{RunResult, HEADLINE_KEY};
use std::f64::consts::PI;
use std::path::Path;

/// Solid fraction of the poured bed used to turn the bulk fill fraction into a
/// particle count (random loose packing of spheres, ≈ 0.60).
pub const BULK_SOLID_FRACTION: f64 = 0.6;
/// Lattice spacing factor used when random placement cannot reach the count.
const LATTICE_SPACING: f64 = 1.05;

/// Why a drum run failed beyond the engine's own errors.
#[derive(Debug, thiserror::Error)]
pub enum DrumError {
    /// What any lab scene can fail at ([`LabError`]).
    #[error(transparent)]
    Lab(LabError),
    /// No angle could be measured at the end of standing.
    #[error("drum: static angle: {0}")]
    Angle(#[from] crate::measure::MeasureError),
}

lab_error_conversions!(DrumError, "drum");

/// Samples traces, angles and log frames while the drum runs.
struct DrumSampler<'a> {
    traces: Traces,
    spec: DrumSpec,
    log: Option<&'a mut RunLog>,
    /// Dynamic-angle window (simulated time, s); set when rotation starts.
    dynamic_window: Option<(f64, f64)>,
    dynamic: Vec<f64>,
}

impl Sampler for DrumSampler<'_> {
    type Error = SceneError;

    fn sample(&mut self, _phase: &'static str, sim: &mut Simulation) -> Result<(), SceneError> {
        let w = sim.world();
        let t = w.time_s;
        self.traces.push_engine_state(sim);
        if let Ok(a) = drum_surface_angle(&w.particles.position, &w.particles.radius, &self.spec) {
            self.traces.push("angle", "deg", t, a.angle_deg);
            if let Some((from, to)) = self.dynamic_window {
                if t >= from && t <= to {
                    self.dynamic.push(a.angle_deg);
                }
            }
            if let Some(log) = self.log.as_deref_mut() {
                log.angle(
                    t,
                    &crate::log::AngleSample {
                        left_deg: a.angle_deg,
                        right_deg: a.angle_deg,
                        mean_deg: a.angle_deg,
                        fit_r2: a.r2,
                    },
                )?;
            }
        }
        if let Some(log) = self.log.as_deref_mut() {
            log.record(sim)?;
        }
        Ok(())
    }
}

impl From<HealthError> for SceneError {
    fn from(e: HealthError) -> Self {
        SceneError::Drum(e.into())
    }
}

/// Runs a `drum` experiment (see the module docs); with `log`, writes its MCAP
/// log there.
pub fn run(
    exp: &Experiment,
    scene: &DrumScene,
    log: Option<&Path>,
) -> Result<RunResult, SceneError> {
    let lab = Lab::new(exp, &[scene.wall_material.as_str()], |e| {
        SceneError::Drum(e.into())
    })?;
    let d_mean = lab.d_mean_m;
    let r_drum = 0.5 * scene.inner_diameter_m;
    let length = scene.periodic_slice_m.unwrap_or(scene.length_m);

    let world = build_world(exp, scene, &lab).map_err(SceneError::Drum)?;
    let particle_count = world.grains();
    let mut sim = lab
        .simulation(world, HealthLimits::default())
        .map_err(|e| SceneError::Drum(e.into()))?;

    let speed_scale_m_s = r_drum * scene.rpm * 2.0 * PI / 60.0;
    let mut log_file = open_log(log, exp, speed_scale_m_s)?;
    let mut sampler = DrumSampler {
        traces: Traces::default(),
        spec: DrumSpec::new([0.0, 0.0], r_drum, d_mean),
        log: log_file.as_mut(),
        dynamic_window: None,
        dynamic: Vec::new(),
    };
    let mut progress = Progress::on_stderr();
    let mass = lab.mean_particle_mass_kg();
    let settle = Phase {
        name: "settle",
        max_duration_s: scene.settle_max_s,
        settle: Some(SettleCriterion::at_rest(&exp.at_rest, mass, d_mean)),
    };
    let dt = lab.plan.dt_s;
    let every = scene.sample_interval_s;
    let settled = run_phase(&mut sim, &settle, dt, every, &mut sampler, &mut progress)?;

    let start = sim.world().time_s;
    let end = start + scene.rotation_time_s;
    start_rotation(&mut sim, scene, start, end)?;
    sampler.dynamic_window = Some((start + 0.5 * scene.rotation_time_s, end));
    let rotate = Phase {
        name: "rotate",
        max_duration_s: scene.rotation_time_s,
        settle: None,
    };
    run_phase(&mut sim, &rotate, dt, every, &mut sampler, &mut progress)?;
    let stand = Phase {
        name: "stand",
        max_duration_s: scene.standing_time_s,
        settle: None,
    };
    run_phase(&mut sim, &stand, dt, every, &mut sampler, &mut progress)?;

    let w = sim.world();
    let last = drum_surface_angle(&w.particles.position, &w.particles.radius, &sampler.spec);
    let dynamic = mean_std(&sampler.dynamic).ok();
    let traces = std::mem::take(&mut sampler.traces);
    drop(sampler);

    let mut result = finish(
        exp,
        &sim,
        &lab.plan,
        traces,
        log_file,
        particle_count,
        settled.settled,
    )?;
    result.warnings.extend(lab.grains.warnings());
    let mut put = |k: &str, v: f64| {
        result.measurements.insert(k.to_string(), v);
    };
    put("simulated_length_m", length);
    put("rotation_start_s", start);
    if let Ok(last) = &last {
        put("static_angle_deg", last.angle_deg);
        put("static_angle_r2", last.r2);
        put("static_angle_points", last.points as f64);
    }
    if let Some(d) = dynamic {
        put("dynamic_angle_deg", d.mean);
        put("dynamic_angle_std_deg", d.std);
        put("dynamic_angle_samples", d.n as f64);
    }
    // One angle that cannot be measured never discards the other.
    result.headline_angle_deg = dynamic
        .map(|d| d.mean)
        .or(last.as_ref().ok().map(|l| l.angle_deg));
    resolution::at_least(
        &mut result,
        "drum_diameters",
        scene.inner_diameter_m / d_mean,
        resolution::ACROSS_MIN,
    );
    resolution::at_least(
        &mut result,
        "bed_depth_diameters",
        resolution::bed_depth_m(r_drum, scene.fill_fraction) / d_mean,
        resolution::BED_DEPTH_MIN,
    );
    let (lo, hi) = resolution::FROUDE_ROLLING;
    resolution::record(
        &mut result,
        "froude_number",
        resolution::froude_number(scene.rpm, r_drum),
        Some(lo),
        Some(hi),
    );
    if let Err(e) = last {
        let why = DrumError::from(e).to_string();
        result
            .unmeasured
            .insert("static_angle_deg".into(), why.clone());
        if result.headline_angle_deg.is_none() {
            result.unmeasured.insert(HEADLINE_KEY.into(), why);
        }
    }
    Ok(result)
}

/// Index of the cylinder among the drum's walls; the end caps of a full drum
/// follow it.
const CYLINDER: usize = 0;

/// Sets the drum turning at `rpm` about its axis from `start_s` to `end_s`
/// (simulated time, s): the cylinder always, the end caps only when they
/// turn with it (`end_walls: "rotating"`); fixed caps keep their static
/// motion, so their wall velocity stays zero.
fn start_rotation(
    sim: &mut Simulation,
    scene: &DrumScene,
    start_s: f64,
    end_s: f64,
) -> Result<(), SceneError> {
    let spin = Motion::Rotate {
        axis_point: Vec3::zeros(),
        axis_dir: Vec3::y(),
        rpm: scene.rpm,
        start_s,
        end_s,
    };
    let caps_turn = scene.end_walls == EndWalls::Rotating;
    for k in 0..sim.world().walls.len() {
        if k == CYLINDER || caps_turn {
            sim.set_wall_motion(k, spin)
                .map_err(|e| SceneError::Drum(e.into()))?;
        }
    }
    Ok(())
}

/// The drum, its domain and its bed.
fn build_world(exp: &Experiment, scene: &DrumScene, lab: &Lab) -> Result<World, DrumError> {
    let (sizes, d_mean) = (&lab.sizes, lab.d_mean_m);
    let r_drum = 0.5 * scene.inner_diameter_m;
    let length = scene.periodic_slice_m.unwrap_or(scene.length_m);
    let half = 0.5 * length;
    let (walls, domain) = rig(scene, d_mean)?;
    // The square inscribed in the cross-section; the clearance keeps spheres
    // off the walls and off the periodic faces (no overlaps across them).
    let side = r_drum / 2f64.sqrt();
    let region = Region::Box {
        min_m: Vec3::new(-side, -half, -side),
        max_m: Vec3::new(side, half, side),
    };
    let drum_volume = PI * r_drum * r_drum * length;
    let particle_volume = PI / 6.0 * d_mean.powi(3);
    let count = (scene.fill_fraction * drum_volume * BULK_SOLID_FRACTION / particle_volume).round()
        as usize;
    let spec = PlacementSpec {
        region,
        sizes: sizes.clone(),
        target: FillTarget::Count(count),
        seed: exp.seeds.packing_seed,
        clearance_m: 0.05 * d_mean,
        velocity_m_s: Vec3::zeros(),
    };
    let placed = match place_random(&spec) {
        Ok(p) => p,
        Err(PackingError::RegionFull { .. }) => place_lattice(&spec, LATTICE_SPACING)?,
        Err(e) => return Err(e.into()),
    };
    Ok(lab.grains.world(&placed.particles, walls, domain)?)
}

/// The drum's walls (the cylinder first, then in a full drum its two end caps
/// at y = ∓length/2, all of wall material 0 and static until the rotation
/// starts) and its domain: periodic along the axis for a slice, else open
/// with a margin of four diameters `d_mean` (m) beyond the caps.
fn rig(scene: &DrumScene, d_mean: f64) -> Result<(Vec<Wall>, Domain), DrumError> {
    let r_drum = 0.5 * scene.inner_diameter_m;
    let margin = 4.0 * d_mean;
    let (length, periodic) = match scene.periodic_slice_m {
        Some(slice) => (slice, true),
        None => (scene.length_m, false),
    };
    let half = 0.5 * length;
    let mut walls = Vec::new();
    if periodic {
        // Longer than the periodic box so the rims never touch a particle.
        let extra = 2.0 * margin;
        walls.push(Wall::cylinder(
            Vec3::new(0.0, -half - extra, 0.0),
            Vec3::y(),
            r_drum,
            length + 2.0 * extra,
            0,
        )?);
    } else {
        walls.push(Wall::cylinder(
            Vec3::new(0.0, -half, 0.0),
            Vec3::y(),
            r_drum,
            length,
            0,
        )?);
        walls.push(Wall::disk(
            Vec3::new(0.0, -half, 0.0),
            Vec3::y(),
            r_drum,
            0,
        )?);
        walls.push(Wall::disk(Vec3::new(0.0, half, 0.0), Vec3::y(), r_drum, 0)?);
    }
    let (y_lo, y_hi) = if periodic {
        (-half, half)
    } else {
        (-half - margin, half + margin)
    };
    let extent = r_drum + margin;
    let domain = Domain::new(
        Vec3::new(-extent, y_lo, -extent),
        Vec3::new(extent, y_hi, extent),
        [false, periodic, false],
    )?;
    Ok((walls, domain))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::particles::ParticleInit;
    use crate::manifest::{parse_experiment, Scene};

    /// A full 30 mm drum, 10 mm long, of soft 1 mm spheres with
    /// particle–wall friction 0.8, turning at 60 rpm, with the given
    /// `end_walls` (`None`: the field left out).
    fn full_drum(end_walls: Option<&str>) -> (Experiment, DrumScene) {
        let field = end_walls.map_or(String::new(), |v| format!(r#", "end_walls": "{v}""#));
        let text = format!(
            r#"{{
  "schema_version": 1, "physics_version": 1, "profile": "smoke",
  "scene": {{ "kind": "drum", "inner_diameter_m": 0.03, "length_m": 0.01, "fill_fraction": 0.3,
             "rpm": 60, "rotation_time_s": 1.0, "standing_time_s": 0.2, "wall_material": "steel"{field} }},
  "material": {{ "particle": {{ "density_kg_m3": 2500, "youngs_modulus_pa": 5e6, "poisson_ratio": 0.3,
                              "size": {{ "kind": "monodisperse", "radius_m": 0.001 }} }},
                 "walls": {{ "steel": {{ "youngs_modulus_pa": 2e11, "poisson_ratio": 0.3, "density_kg_m3": 7850 }} }} }},
  "contact": {{ "model": {{ "normal": "hertz", "rolling": "cdt" }},
               "particle_particle": {{ "restitution": 0.5, "static_friction": 0.5, "rolling_friction": 0.1, "surface_energy_j_m2": 0 }},
               "particle_wall": {{ "steel": {{ "restitution": 0.5, "static_friction": 0.8, "rolling_friction": 0.1, "surface_energy_j_m2": 0 }} }} }},
  "seeds": {{ "design_seed": 0, "sample_index": 0, "packing_seed": 7 }},
  "time_step": {{ "rayleigh_fraction": 0.2, "design_impact_speed_m_s": 0.3 }}
}}"#
        );
        let exp = parse_experiment(&text).unwrap();
        let Scene::Drum(scene) = exp.scene.clone() else {
            unreachable!()
        };
        (exp, scene)
    }

    fn lab(exp: &Experiment, scene: &DrumScene) -> Lab {
        Lab::new(exp, &[scene.wall_material.as_str()], |e| {
            SceneError::Drum(e.into())
        })
        .unwrap()
    }

    #[test]
    fn fixed_end_caps_stand_still_while_the_cylinder_turns() {
        for (end_walls, caps_turn) in [
            (None, true),
            (Some("rotating"), true),
            (Some("fixed"), false),
        ] {
            let (exp, scene) = full_drum(end_walls);
            let lab = lab(&exp, &scene);
            let world = build_world(&exp, &scene, &lab).unwrap();
            let mut sim = lab.simulation(world, HealthLimits::default()).unwrap();
            start_rotation(&mut sim, &scene, 0.0, 1.0).unwrap();
            let walls = &sim.world().walls;
            assert_eq!(walls.len(), 3, "a cylinder and two end caps");
            // 60 rpm: ω = 2π rad/s; at 10 mm from the axis the material of a
            // turning wall moves at 2π · 0.01 m/s, perpendicular to the radius.
            let speed = 2.0 * PI * 0.01;
            let cylinder = walls[CYLINDER].placed_at(0.5);
            let v = cylinder.velocity_at(Vec3::new(0.01, 0.0, 0.0));
            assert!((v.norm() - speed).abs() < 1e-12, "cylinder {v:?}");
            for (k, y) in [(1, -0.005), (2, 0.005)] {
                let v = walls[k]
                    .placed_at(0.5)
                    .velocity_at(Vec3::new(0.0, y, -0.01));
                let want = if caps_turn { speed } else { 0.0 };
                assert!(
                    (v.norm() - want).abs() < 1e-12,
                    "end_walls {end_walls:?}: cap {k} moves at {v:?}"
                );
                assert_eq!(walls[k].motion().is_static(), !caps_turn);
            }
        }
    }

    #[test]
    fn a_grain_bouncing_off_a_fixed_cap_is_not_dragged_round() {
        // One sphere 7.5 mm below the axis (clear of the cylinder) moves
        // along the axis into the y = −5 mm cap. A cap turning at 60 rpm
        // slides past it at 2π · 0.0075 = 47 mm/s along −x there, and its
        // friction (0.8) drags the sphere along −x (it leaves at more than a
        // fifth of the cap's speed); a fixed cap has no velocity along x, so
        // the sphere leaves it with none.
        let vx_after = |end_walls: &str| {
            let (exp, scene) = full_drum(Some(end_walls));
            let lab = lab(&exp, &scene);
            let (walls, domain) = rig(&scene, lab.d_mean_m).unwrap();
            let grain = ParticleInit {
                position: Vec3::new(0.0, -0.005 + 0.0012, -0.0075),
                velocity: Vec3::new(0.0, -0.05, 0.0),
                angular_velocity: Vec3::zeros(),
                radius_m: 0.001,
            };
            let world = lab.grains.world(&[grain], walls, domain).unwrap();
            let mut sim = lab.simulation(world, HealthLimits::default()).unwrap();
            start_rotation(&mut sim, &scene, 0.0, 1.0).unwrap();
            // 8 ms: the 0.2 mm gap closes in 4 ms, the Hertz contact lasts
            // under 1 ms.
            let steps = (0.008 / lab.plan.dt_s).ceil() as u64;
            sim.advance(steps).unwrap();
            let w = sim.world();
            assert!(
                w.particles.velocity[0].y > 0.0,
                "the sphere has not bounced off the cap"
            );
            w.particles.velocity[0].x
        };
        let rotating = vx_after("rotating");
        let fixed = vx_after("fixed");
        assert!(rotating < -0.01, "rotating cap: v_x = {rotating} m/s");
        assert!(fixed.abs() < 1e-9, "fixed cap: v_x = {fixed} m/s");
    }
}
