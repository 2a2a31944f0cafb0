//! The `drum` scene: a horizontal rotating cylinder (he2019 §3.6.2: ID 45 mm,
//! length 100 mm, 30 % fill, 60 rpm for 5 s then 2 s standing; cai2024:
//! 100 × 100 mm, 25 %, 50 rpm).
//!
//! Geometry: the drum axis is the y axis through the origin, gravity −z. The
//! full drum is a cylinder with two rotating end caps; with
//! `periodic_slice_m` only a slice of that thickness is simulated, periodic
//! along y, with no end caps (the cylinder extends past the periodic box so
//! its rims are never felt).
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
use crate::manifest::scene::DrumScene;
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
    let spin = Motion::Rotate {
        axis_point: Vec3::zeros(),
        axis_dir: Vec3::y(),
        rpm: scene.rpm,
        start_s: start,
        end_s: end,
    };
    for k in 0..sim.world().walls.len() {
        sim.set_wall_motion(k, spin)
            .map_err(|e| SceneError::Drum(e.into()))?;
    }
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

/// Walls, domain and the placed particles.
/// The drum, its domain and its bed.
fn build_world(exp: &Experiment, scene: &DrumScene, lab: &Lab) -> Result<World, DrumError> {
    let (sizes, d_mean) = (&lab.sizes, lab.d_mean_m);
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
