//! The `baffle_lift` scene (he2019 §3.6.1): a 60 × 60 × 80 mm Plexiglas box
//! holds the powder; one side, the baffle, is lifted at 0.1 m/s, the powder runs
//! out through the opening, and the angle of the slope left inside the box is the
//! static angle of repose (he2019 measured 39.1°, simulated 37.2–40.1° with its
//! five candidate parameter sets, Table 3).
//!
//! # Geometry
//!
//! Gravity is −z. The box interior is x ∈ [0, L], y ∈ [−W/2, W/2], z ≥ 0
//! (`box_length_m` L along the flow, `box_width_m` W). Walls, in index order:
//! the baffle (x = L), the floor, the back wall (x = 0) and the two side walls
//! (y = ∓W/2) — thin rectangles of `box_material`, except the floor, a
//! rectangle of `floor_material` at z = 0 reaching `floor_overhang_m` past the
//! opening and past each side wall (and [`FLOOR_BEHIND_DIAMETERS`] mean
//! diameters behind the back wall, so no particle in the box feels its edge).
//! he2019 does not describe what the box stands on; the floor stands for the
//! bench. Its default reach, the box height H, holds the heap of powder that
//! runs out: a full box loses at most about half its bulk volume, 0.5 · L · W ·
//! H, and a half cone of radius ρ at 25° (a free-flowing powder) holds
//! (π/6) tan 25° · ρ³, which is that much for ρ ≈ 1.05 H — a cohesive powder's
//! steeper heap stays well inside. Powder that still runs off the edge falls,
//! and every sample removes the particles whose centre is off the floor's
//! extent or more than [`LEAVE_DEPTH_DIAMETERS`] below it
//! ([`Simulation::retain`]); the simulated domain is padded so that nothing
//! leaves it between two samples (see `domain_pad`). Removed powder is
//! counted, never lost from the books: placed = in box + outside on the floor
//! + removed.
//!
//! With `periodic_slice_m` only a slice of the box's width is simulated,
//! periodic along y, holding the same share of the powder: no side walls, and
//! the floor, back wall and baffle reach past the periodic box so their y
//! edges are never felt. The run-out heap is then a ridge instead of a fan, so
//! it props the slope's toe higher, and the side walls' friction (which the
//! side view sees: the measured silhouette is the highest top across the
//! width) is left out — a slice is for smoke runs, not for comparisons with
//! he2019.
//!
//! # Protocol
//!
//! 1. **place**: the mass `powder_mass_kg` (whole particles, at most one over) is
//!    placed without overlap by random sequential addition
//!    ([`crate::packing::place::place_random`], seeded by the packing seed) in a
//!    column over the box's footprint at the solid fraction
//!    [`FILL_SOLID_FRACTION`] (RSA saturates near 0.38; a dense regular lattice
//!    would crystallise a monodisperse bed, and its slope would follow crystal
//!    planes), made taller when big spheres near the walls cannot reach that
//!    fraction (see [`FILL_COLUMN_GROWTH`]); it is poured powder, and a cohesive
//!    one stays loose (quick.json's, at Bond number 1, settles to about 0.5 of
//!    the box up to its top). That column is taller than the settled bed, so the box walls and
//!    the baffle are built as tall as the column (above the settled bed they touch
//!    nothing); the settled bed itself must fit the box height, else the run stops
//!    with [`BaffleError::Overfull`].
//! 2. **settle**: the powder falls into the box and comes to rest (at most
//!    `settle_max_s`, ending at rest by [`SettleCriterion::at_rest`]).
//! 3. **lift**: the baffle translates upward at `lift_speed_m_s` until its lower
//!    edge is [`BAFFLE_CLEARANCE_DIAMETERS`] mean diameters above the bed's top
//!    (the highest particle top in the box when the lift starts), then stops.
//! 4. **rest**: the powder flows out and comes to rest (at most `settle_time_s`,
//!    ending earlier at rest by the same criterion).
//! 5. **measure**: [`crate::measure::baffle`] on the particles whose centre is in
//!    the box (x in [0, L]): the highest particle top per x bin one mean diameter
//!    wide, points between 10 % and 90 % of the slope height, one least-squares
//!    line. A slope lower than three diameters or with too few points is "not
//!    measurable" and the run fails with that error. A fit with R² below
//!    [`ANGLE_R2_FLOOR`] is reported with the flag `static_angle_low_r2` = 1.
//!
//! # Results
//!
//! `static_angle_deg` (the headline), `static_angle_r2`, `static_angle_points`,
//! `static_angle_low_r2`, `slope_height_m`; the books (`particles` placed,
//! `placed_mass_kg`, `in_box_*`, `outside_*`, `removed_*` as particle counts
//! and masses in kg, `discharged_mass_fraction`); the protocol
//! (`fill_column_height_m`, `bed_height_m`, `lift_start_s`, `lift_end_s`,
//! `settled` before the lift, `settled_after_lift`, `end_time_s`, `steps`,
//! `dt_s`; the shared keys are [`super::skeleton`]'s). Traces every `sample_interval_s`: the engine's (kinetic energy,
//! contacts, wall contacts, largest overlap), `angle` (whenever the slope is
//! measurable), `in_box_mass`, `removed_mass` and `baffle_lower_edge`. The
//! MCAP log holds a frame per sample, the angle samples and the discharged
//! particle count (outside the box or removed).
//!
//! # Cohesion and the rest criterion
//!
//! he2019's surface energies (3–8 J/m²) on spheres of its printed density
//! (60 kg/m³) are a granular Bond number (JKR pull-off 1.5 π Γ R* over the
//! weight) of 10³ at 2.5 mm and 10⁴ at 0.625 mm: such a bed is a solid block
//! that keeps its height when the baffle lifts, and its slope is not measurable
//! (tests/scene_baffle.rs shows it at Bond number 100): the run then has no
//! angle and records why in `unmeasured` (`static_angle_deg`), keeping its
//! counts. The example manifests
//! in `experiments/baffle_lift/` say what they use instead. Spheres with almost
//! no rolling resistance keep rolling slowly on the floor long after the slope
//! is still, so the rest phase often runs its full `settle_time_s`;
//! `settled_after_lift` says which.

use super::physics::STANDARD_GRAVITY_M_S2;
use super::protocol::{run_phase, Phase, Progress, Sampler, SettleCriterion, Traces};
use super::resolution;
use super::skeleton::{finish, lab_error_conversions, open_log, Lab, LabError};
use super::SceneError;
use crate::dem::domain::Domain;
use crate::dem::health::{HealthError, HealthLimits};
use crate::dem::particles::Particles;
use crate::dem::simulation::{Simulation, World};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{Motion, Wall};
use crate::log::{AngleSample, RunLog, Trace};
use crate::manifest::scene::BaffleLiftScene;
use crate::manifest::Experiment;
use crate::measure::baffle::{baffle_slope_angle, BaffleSpec, SlopeAngle};
use crate::measure::MeasureError;
use crate::packing::place::{place_random, FillTarget, PlacementSpec};
use crate::packing::region::Region;
use crate::packing::PackingError;
use crate::store::{RunResult, HEADLINE_KEY};
use std::path::Path;

/// Solid fraction of the placement column (random sequential addition
/// saturates near 0.38 for equal spheres and slows down well before).
pub const FILL_SOLID_FRACTION: f64 = 0.25;
/// Growth factor of the placement column when it cannot hold the powder.
pub const FILL_COLUMN_GROWTH: f64 = 1.1;
/// Placement attempts (each with a taller column) before the fill fails.
pub const FILL_COLUMN_TRIES: usize = 10;
/// The lifted baffle's lower edge ends this many mean diameters above the bed.
pub const BAFFLE_CLEARANCE_DIAMETERS: f64 = 2.0;
/// The floor reaches this many mean diameters behind the back wall.
pub const FLOOR_BEHIND_DIAMETERS: f64 = 2.0;
/// A particle whose centre is this many mean diameters below the floor has
/// fallen off it and is removed.
pub const LEAVE_DEPTH_DIAMETERS: f64 = 1.0;
/// A slope fit with R² below this is flagged (`static_angle_low_r2`): a straight
/// lattice slope fits with R² > 0.99 despite its one-diameter steps (see
/// `measure::baffle`'s tests); below 0.9 the surface is clumpy or curved (a
/// cohesive bed that broke off in blocks) and its angle depends on the band.
pub const ANGLE_R2_FLOOR: f64 = 0.9;

/// Why a baffle-lift run failed beyond the engine's own errors.
#[derive(Debug, thiserror::Error)]
pub enum BaffleError {
    /// What any lab scene can fail at ([`LabError`]).
    #[error(transparent)]
    Lab(LabError),
    /// The settled powder stands higher than the box.
    #[error(
        "baffle_lift: the settled powder stands {bed_height_m:.4} m high, above box_height_m = \
         {box_height_m} m; use a smaller powder_mass_kg"
    )]
    Overfull {
        /// Top of the settled bed, m.
        bed_height_m: f64,
        /// The box height, m.
        box_height_m: f64,
    },
    /// No slope angle could be measured at the end.
    #[error("baffle_lift: static angle {0}")]
    Angle(#[from] MeasureError),
}

lab_error_conversions!(BaffleError, "baffle_lift");

/// The box, the floor and what counts as where.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BoxGeometry {
    /// Box length (x), m.
    length_m: f64,
    /// Simulated width (y): the box width, or the periodic slice, m.
    width_m: f64,
    /// Whether y is periodic (a slice: no side walls).
    periodic: bool,
    /// Top of the placement column, m.
    column_m: f64,
    /// Height of the built walls (box height, or the taller fill column), m.
    wall_height_m: f64,
    /// Floor extent in x, m.
    floor_x_m: (f64, f64),
    /// Floor half-width in y, m.
    floor_half_y_m: f64,
    /// Centres this far below the floor have left it, m.
    leave_depth_m: f64,
}

/// Index of the baffle in the world's walls.
const BAFFLE_WALL: usize = 0;

impl BoxGeometry {
    /// Whether a particle centre is inside the box.
    fn in_box(&self, p: &Vec3) -> bool {
        (0.0..=self.length_m).contains(&p.x)
            && (self.periodic || p.y.abs() <= 0.5 * self.width_m)
            && p.z >= 0.0
    }

    /// Whether a particle centre is still over (or on) the floor.
    fn on_floor(&self, p: &Vec3) -> bool {
        (self.floor_x_m.0..=self.floor_x_m.1).contains(&p.x)
            && (self.periodic || p.y.abs() <= self.floor_half_y_m)
            && p.z >= -self.leave_depth_m
    }

    /// Walls in index order: the baffle (material 0), the floor (material 1),
    /// the back wall and, unless periodic, the side walls at y = ∓W/2
    /// (material 0). In a periodic slice the walls reach past the periodic box
    /// so their y edges are never felt.
    fn walls(&self) -> Result<Vec<Wall>, BaffleError> {
        let (l, h) = (self.length_m, self.wall_height_m);
        let hw = 0.5 * self.width_m;
        // Half-extent across y of the back wall and the baffle.
        let across = if self.periodic {
            self.floor_half_y_m
        } else {
            hw
        };
        let (x0, x1) = self.floor_x_m;
        let end_wall = |x: f64, normal: Vec3| {
            Wall::rectangle(
                Vec3::new(x, 0.0, 0.5 * h),
                normal,
                Vec3::y(),
                across,
                0.5 * h,
                0,
            )
        };
        let mut walls = vec![
            end_wall(l, -Vec3::x())?,
            Wall::rectangle(
                Vec3::new(0.5 * (x0 + x1), 0.0, 0.0),
                Vec3::z(),
                Vec3::x(),
                0.5 * (x1 - x0),
                self.floor_half_y_m,
                1,
            )?,
            end_wall(0.0, Vec3::x())?,
        ];
        if !self.periodic {
            for side in [-1.0, 1.0] {
                walls.push(Wall::rectangle(
                    Vec3::new(0.5 * l, side * hw, 0.5 * h),
                    Vec3::y() * -side,
                    Vec3::x(),
                    0.5 * l,
                    0.5 * h,
                    0,
                )?);
            }
        }
        Ok(walls)
    }
}

/// How far the domain reaches past the floor (sideways and below) and above the
/// walls, m: twice the distance a particle covers in one sampling interval at
/// the manifest's design impact speed plus free fall, plus two diameters — so a
/// particle that leaves the floor is removed at the next sample, before it can
/// leave the domain and stop the run.
fn domain_pad(design_speed_m_s: f64, sample_interval_s: f64, d_mean_m: f64) -> f64 {
    let dt = sample_interval_s;
    2.0 * (design_speed_m_s * dt + 0.5 * STANDARD_GRAVITY_M_S2 * dt * dt) + 2.0 * d_mean_m
}

/// Mass and count of a set of particles.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Tally {
    count: usize,
    mass_kg: f64,
}

impl Tally {
    fn add(&mut self, mass_kg: f64) {
        self.count += 1;
        self.mass_kg += mass_kg;
    }
}

/// Where the powder is: (in the box, outside it on the floor).
fn census(p: &Particles, geo: &BoxGeometry) -> (Tally, Tally) {
    let (mut inside, mut outside) = (Tally::default(), Tally::default());
    for (x, m) in p.position.iter().zip(&p.mass) {
        if geo.in_box(x) {
            inside.add(*m);
        } else {
            outside.add(*m);
        }
    }
    (inside, outside)
}

/// Samples traces, angles and log frames, and removes powder that left the floor.
struct BaffleSampler<'a> {
    traces: Traces,
    geo: BoxGeometry,
    spec: BaffleSpec,
    log: Option<&'a mut RunLog>,
    removed: Tally,
}

impl BaffleSampler<'_> {
    /// The slope of the particles in the box now.
    fn slope(&self, p: &Particles) -> Result<SlopeAngle, MeasureError> {
        baffle_slope_angle(&p.position, &p.radius, &self.spec)
    }

    /// Removes (and counts) the particles that left the floor.
    fn remove_fallen(&mut self, sim: &mut Simulation) -> Result<(), HealthError> {
        let geo = self.geo;
        let p = &sim.world().particles;
        for (x, m) in p.position.iter().zip(&p.mass) {
            if !geo.on_floor(x) {
                self.removed.add(*m);
            }
        }
        sim.retain(|p, i| geo.on_floor(&p.position[i]))?;
        Ok(())
    }
}

impl Sampler for BaffleSampler<'_> {
    type Error = BaffleError;

    fn sample(&mut self, _phase: &'static str, sim: &mut Simulation) -> Result<(), BaffleError> {
        self.remove_fallen(sim)?;
        let w = sim.world();
        let t = w.time_s;
        self.traces.push_engine_state(sim);
        let (inside, outside) = census(&w.particles, &self.geo);
        self.traces.push("in_box_mass", "kg", t, inside.mass_kg);
        self.traces
            .push("removed_mass", "kg", t, self.removed.mass_kg);
        let baffle = w.walls[BAFFLE_WALL].pose_at(t).to_world(Vec3::zeros()).z;
        self.traces.push("baffle_lower_edge", "m", t, baffle);
        let slope = self.slope(&w.particles).ok();
        if let Some(a) = slope {
            self.traces.push("angle", "deg", t, a.angle_deg);
        }
        if let Some(log) = self.log.as_deref_mut() {
            if let Some(a) = slope {
                log.angle(
                    t,
                    &AngleSample {
                        left_deg: a.angle_deg,
                        right_deg: a.angle_deg,
                        mean_deg: a.angle_deg,
                        fit_r2: a.r2,
                    },
                )?;
            }
            let discharged = (outside.count + self.removed.count) as f64;
            log.scalar(Trace::Discharged, t, discharged)?;
            log.record(sim)?;
        }
        Ok(())
    }
}

/// Runs a `baffle_lift` experiment (see the module docs); with `log`, writes
/// its MCAP log there.
pub fn run(
    exp: &Experiment,
    scene: &BaffleLiftScene,
    log: Option<&Path>,
) -> Result<RunResult, SceneError> {
    let walls = [scene.box_material.as_str(), scene.floor_material.as_str()];
    let lab = Lab::new(exp, &walls, |e| BaffleError::from(e).into())?;
    let d_mean = lab.d_mean_m;
    let every = scene.sample_interval();

    let (world, geo, placed) = build_world(exp, scene, &lab)?;
    let mut sim = lab
        .simulation(world, HealthLimits::default())
        .map_err(BaffleError::from)?;

    // Free-fall speed over the box height: the fastest outflow.
    let speed_scale_m_s = (2.0 * STANDARD_GRAVITY_M_S2 * scene.box_height_m).sqrt();
    let mut log_file = open_log(log, exp, speed_scale_m_s)?;
    let mut sampler = BaffleSampler {
        traces: Traces::default(),
        geo,
        spec: BaffleSpec::new(0.0, (0.0, scene.box_length_m), d_mean),
        log: log_file.as_mut(),
        removed: Tally::default(),
    };
    let mut progress = Progress::on_stderr();
    let at_rest = SettleCriterion::at_rest(&exp.at_rest, lab.mean_particle_mass_kg(), d_mean);
    let dt = lab.plan.dt_s;

    let settle = Phase {
        name: "settle",
        max_duration_s: scene.settle_max(),
        settle: Some(at_rest),
    };
    let settled = run_phase(&mut sim, &settle, dt, every, &mut sampler, &mut progress)?;

    let bed_height = bed_top(&sim.world().particles, &geo);
    if bed_height > scene.box_height_m {
        return Err(BaffleError::Overfull {
            bed_height_m: bed_height,
            box_height_m: scene.box_height_m,
        }
        .into());
    }
    let lift_start = sim.world().time_s;
    let lift_time = (bed_height + BAFFLE_CLEARANCE_DIAMETERS * d_mean) / scene.lift_speed_m_s;
    sim.set_wall_motion(
        BAFFLE_WALL,
        Motion::Translate {
            velocity_m_s: Vec3::new(0.0, 0.0, scene.lift_speed_m_s),
            start_s: lift_start,
            end_s: lift_start + lift_time,
        },
    )
    .map_err(BaffleError::from)?;
    let lift = Phase {
        name: "lift",
        max_duration_s: lift_time,
        settle: None,
    };
    let lifted = run_phase(&mut sim, &lift, dt, every, &mut sampler, &mut progress)?;
    let rest = Phase {
        name: "rest",
        max_duration_s: scene.settle_time_s,
        settle: Some(at_rest),
    };
    let rested = run_phase(&mut sim, &rest, dt, every, &mut sampler, &mut progress)?;

    let w = sim.world();
    let slope = sampler.slope(&w.particles);
    let (inside, outside) = census(&w.particles, &geo);
    let removed = sampler.removed;
    let traces = std::mem::take(&mut sampler.traces);
    drop(sampler);

    let mut result = finish(
        exp,
        &sim,
        &lab.plan,
        traces,
        log_file,
        placed.count,
        settled.settled,
    )
    .map_err(BaffleError::from)?;
    result.warnings.extend(lab.grains.warnings());
    let mut put = |k: &str, v: f64| {
        result.measurements.insert(k.to_string(), v);
    };
    let flag = |b: bool| f64::from(u8::from(b));
    put("placed_mass_kg", placed.mass_kg);
    put("fill_column_height_m", geo.column_m);
    put("bed_height_m", bed_height);
    put("lift_start_s", lift_start);
    put("lift_end_s", lifted.end_s);
    put("settled_after_lift", flag(rested.settled));
    put("in_box_particles", inside.count as f64);
    put("in_box_mass_kg", inside.mass_kg);
    put("outside_particles", outside.count as f64);
    put("outside_mass_kg", outside.mass_kg);
    put("removed_particles", removed.count as f64);
    put("removed_mass_kg", removed.mass_kg);
    put(
        "discharged_mass_fraction",
        (outside.mass_kg + removed.mass_kg) / placed.mass_kg,
    );
    let slope_height_m = slope.as_ref().ok().map(|s| s.height_m);
    match slope {
        Ok(slope) => {
            put("static_angle_deg", slope.angle_deg);
            put("static_angle_r2", slope.r2);
            put("static_angle_points", slope.points as f64);
            put("static_angle_low_r2", flag(slope.r2 < ANGLE_R2_FLOOR));
            put("slope_height_m", slope.height_m);
            result.headline_angle_deg = Some(slope.angle_deg);
        }
        // The run keeps its counts; the slope's reason is recorded.
        Err(e) => {
            let why = BaffleError::from(e).to_string();
            for key in ["static_angle_deg", HEADLINE_KEY] {
                result.unmeasured.insert(key.to_string(), why.clone());
            }
        }
    }
    resolution::at_least(
        &mut result,
        "box_length_diameters",
        scene.box_length_m / d_mean,
        resolution::ACROSS_MIN,
    );
    if let Some(height) = slope_height_m {
        resolution::at_least(
            &mut result,
            "slope_height_diameters",
            height / d_mean,
            resolution::SLOPE_HEIGHT_MIN,
        );
    }
    Ok(result)
}

/// Highest particle top (centre height + radius) in the box, m.
fn bed_top(p: &Particles, geo: &BoxGeometry) -> f64 {
    p.position
        .iter()
        .zip(&p.radius)
        .filter(|(x, _)| geo.in_box(x))
        .map(|(x, r)| x.z + r)
        .fold(0.0, f64::max)
}

/// Places `mass_kg` by random sequential addition in a column over the box's
/// footprint (`l` × `w`, m) at [`FILL_SOLID_FRACTION`]; if the column cannot
/// hold it (near walls and periodic faces big spheres lose room), the column
/// is made [`FILL_COLUMN_GROWTH`] times taller, up to [`FILL_COLUMN_TRIES`]
/// times. Returns the placement and the column height, m.
fn place_column(
    exp: &Experiment,
    sizes: &crate::packing::distribution::SizeDistribution,
    mass_kg: f64,
    l: f64,
    w: f64,
    d_mean: f64,
    d_max: f64,
) -> Result<(crate::packing::place::Placement, f64), BaffleError> {
    let rho = exp.material.particle.density_kg_m3;
    // At least two of the largest diameters high.
    let mut column = (mass_kg / rho / (FILL_SOLID_FRACTION * l * w)).max(2.0 * d_max);
    let mut tries = 1;
    loop {
        let spec = PlacementSpec {
            region: Region::Box {
                min_m: Vec3::new(0.0, -0.5 * w, 0.0),
                max_m: Vec3::new(l, 0.5 * w, column),
            },
            sizes: sizes.clone(),
            target: FillTarget::Mass {
                mass_kg,
                density_kg_m3: rho,
            },
            seed: exp.seeds.packing_seed,
            // Off the walls, and off the periodic faces (no overlaps across them).
            clearance_m: 0.05 * d_mean,
            velocity_m_s: Vec3::zeros(),
        };
        match place_random(&spec) {
            Ok(placed) => return Ok((placed, column)),
            Err(PackingError::RegionFull { .. }) if tries < FILL_COLUMN_TRIES => {
                column *= FILL_COLUMN_GROWTH;
                tries += 1;
            }
            Err(e) => return Err(e.into()),
        }
    }
}

/// Walls, domain and the placed powder (with its tally).
fn build_world(
    exp: &Experiment,
    scene: &BaffleLiftScene,
    lab: &Lab,
) -> Result<(World, BoxGeometry, Tally), BaffleError> {
    let (sizes, d_mean) = (&lab.sizes, lab.d_mean_m);
    let l = scene.box_length_m;
    let (w, periodic) = match scene.periodic_slice_m {
        Some(slice) => (slice, true),
        None => (scene.box_width_m, false),
    };
    let mass = scene.powder_mass_kg * w / scene.box_width_m;
    let d_max = sizes.sampler()?.max_diameter();
    let (placed, column) = place_column(exp, sizes, mass, l, w, d_mean, d_max)?;
    let overhang = scene.floor_overhang();
    let pad = domain_pad(
        exp.time_step.design_impact_speed_m_s,
        scene.sample_interval(),
        d_mean,
    );
    let geo = BoxGeometry {
        length_m: l,
        width_m: w,
        periodic,
        column_m: column,
        wall_height_m: scene.box_height_m.max(column + d_max),
        floor_x_m: (-FLOOR_BEHIND_DIAMETERS * d_mean, l + overhang),
        // A slice's floor reaches past the periodic box, so its edges are never felt.
        floor_half_y_m: 0.5 * w + if periodic { pad } else { overhang },
        leave_depth_m: LEAVE_DEPTH_DIAMETERS * d_mean,
    };
    let (y_lo, y_hi) = if periodic {
        (-0.5 * w, 0.5 * w)
    } else {
        (-geo.floor_half_y_m - pad, geo.floor_half_y_m + pad)
    };
    let domain = Domain::new(
        Vec3::new(geo.floor_x_m.0 - pad, y_lo, -pad),
        Vec3::new(geo.floor_x_m.1 + pad, y_hi, geo.wall_height_m + pad),
        [false, periodic, false],
    )?;
    let world = lab.grains.world(&placed.particles, geo.walls()?, domain)?;
    let mut tally = Tally::default();
    for m in &world.particles.mass {
        tally.add(*m);
    }
    Ok((world, geo, tally))
}
