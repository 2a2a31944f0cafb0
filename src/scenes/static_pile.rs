//! The `static_pile` scene: cai2024's fixed-base funnel test (GB/T 16913-2008,
//! "注入限定底面法"): powder poured through a funnel onto a disk until the pile
//! covers the disk and the excess runs off its rim; the static angle of repose
//! is tan(angle) = 2H/D.
//!
//! # Geometry
//!
//! The disk (diameter `disk_diameter_m`, cai2024: 80 mm) lies in z = 0, its
//! axis the z axis; the funnel is an open cone frustum on the same axis with
//! its outlet (`outlet_diameter_m`, cai2024: 5 mm) `outlet_height_m` above the
//! disk (cai2024: 80 mm), widening at the included angle `cone_angle_deg`
//! (cai2024: 60°) up to `funnel_top_diameter_m` (the paper is silent; the
//! examples choose 60 mm). The funnel has no spout and no lid. Gravity is
//! 9.81 m/s² along −z. Wall material 0 is `funnel_material`, 1 `disk_material`.
//!
//! # Insertion
//!
//! A [`RateFactory`] (seeded by the packing seed) creates
//! `insertion_rate_per_s` particles per second at rest inside the upper
//! [`INSERTION_DEPTH_FRACTION`] of the funnel (cai2024: "a particle factory at
//! the funnel top", 5000 /s), in windows of `insertion_interval_s`, until
//! `particle_count` particles fell due. Every new sphere lies in free space:
//! inside the funnel with a clearance of [`INSERTION_CLEARANCE_DIAMETERS`] d50
//! to its wall and not touching any particle, so insertion never creates an
//! overlap. A particle that finds no free place in [`INSERTION_ATTEMPTS`]
//! random tries (the funnel has backed up to its top) is retried in the next
//! windows, as an EDEM factory with a total number does, so the pour goes on
//! (into the settle phase if need be) at the rate the outlet lets through.
//! If the run ends first (a jammed outlet), `particles_not_generated` says how
//! many of `particle_count` never found room and `funnel_retained` how many
//! are stuck in the funnel.
//!
//! # Removal
//!
//! Particles that roll off the disk would fall out of the simulation box and
//! trip the health check that stops a run when a particle leaves the domain;
//! in the lab they fall into a tray and are no longer part of the pile. At
//! every insertion window the scene therefore removes ([`Simulation::retain`])
//! every particle whose centre is more than one largest diameter below the
//! disk, or which is below the outlet and more than two largest diameters
//! outside the disk's radius ([`Removal`]): neither can touch the disk or a
//! particle resting on it again. They are counted in `removed_off_disk`; a
//! pile that shed particles has reached the rim, which is what the fixed-base
//! method needs. The box extends past those limits by the farthest a particle
//! can travel in one window ([`Removal::travel_m`]), so no particle leaves it
//! between two checks.
//!
//! # Protocol
//!
//! The simulation starts empty (the engine then sizes the JKR contact reach
//! for a 1 m radius bound; that only widens the neighbour cutoff, by under
//! 1 % of d50 for the example manifests, and changes no force). `pour`: the
//! factory runs for ⌈particle_count / rate / window⌉ + 1 windows (enough for
//! the last particle to fall due); `settle`: at most `settle_time_s`, ending
//! earlier once the pile is at rest ([`SettleCriterion::at_rest`], shared with
//! the drum: the mean kinetic energy per particle below the manifest's
//! `at_rest` threshold, by default 1e-6 of m g d50 for 0.05 s, m the mass of a
//! d50 sphere). Pending particles keep being inserted
//! during `settle`, and while they fall the pile is not at rest. With CDT
//! rolling friction the resting pile keeps a small rotational chatter (the
//! known CDT artefact), so in practice the example runs use their whole
//! `settle_time_s`; `final_kinetic_energy_ratio` reports the mean kinetic
//! energy per particle over m g d50 at the end (1e-4 to 4e-4 for the examples:
//! creep of a few mm/s, the angles steady to a few tenths of a degree over
//! the last 0.1 s).
//!
//! # Measurement
//!
//! On the particles resting on the disk (centre above the disk and below the
//! outlet): the profile angle ([`crate::measure::pile`]: he2019's silhouette
//! with the 10–90 % height band, bins one d50 wide, about the funnel axis) in
//! the four side views of [`VIEW_AZIMUTHS_DEG`], each with its left and right
//! flank, R² and points (`profile_az000_*` is the xz view, `profile_az090_*`
//! the yz view); `profile_left_deg`, `profile_right_deg` are the means over
//! the views and `profile_angle_deg` the mean of all eight flanks. Every view
//! must fit (`min_views` = 4 in [`crate::measure::pile::side_views`]; the
//! funnel scene accepts 3): the disk pile is large and centred, and no run has
//! failed one view alone, so the profile stays the full four-view mean. A flank fit
//! with R² below [`R2_FLOOR`] sets `profile_r2_below_floor` to 1. A pile whose
//! flanks hold too few surface points for a fit (a small pile of coarse
//! particles, or a low mound) has no profile: `profile_measured` is 0 and the
//! `profile_*` keys are absent, while the height angle, the headline, is still
//! measured.
//!
//! The height angle `height_angle_deg` = atan(2H/D) uses H, the highest
//! particle top above the disk (`pile_height_m`), and the disk diameter D. It
//! assumes a perfect cone whose base is the whole disk, so it means something
//! only when the pile reaches the rim all round (`rim_coverage_fraction`: the
//! share of [`RIM_SECTORS`] equal sectors holding a particle centred within
//! one d50 of the rim) and sheds particles over it (`removed_off_disk` > 0).
//! Where the assumption fails is measured too: the pile does not end at height
//! 0 on the rim but on a step of `rim_height_m` (the median over the sectors
//! of the highest top within one d50 of the rim: the outermost particles and
//! the step cohesion lets them hold), which 2H/D reads as slope; H is one
//! particle's top, up to a d50 above or below where the flanks meet; and the
//! flanks are not straight (under the stream the top is rounded, the foot
//! steeper). `tests/scene_static_pile.rs` turns these into the margin within
//! which the two angles must agree. The headline angle is the height angle:
//! it is the paper's (and the standard's) measure, and on the smoke pile it
//! scatters 0.5° between packing seeds where the profile angle scatters 3°.
//! A pile lower than three d50 is not measurable: the run has no height
//! angle (and no headline) and records that reason with the particle counts
//! in `unmeasured` (`height_angle_deg`); its counts are still measured.
//!
//! # Results and traces
//!
//! Counts: `particles` (generated), `particles_not_generated`,
//! `funnel_retained`, `particles_on_disk`, `particles_below_disk` (falling off
//! the rim, removed at the next window) and `removed_off_disk` add up to
//! `particle_count`. Traces (every `sample_interval_s` and at the end):
//! kinetic energy, contacts, wall contacts, largest overlap ratio, particles
//! generated, pending insertion, removed, discharged from the funnel and
//! still in it, and the profile and height angles of the particles slower
//! than √(g d50) (the falling stream is not part of the pile) while they form
//! a measurable pile. The MCAP log holds a frame, the profile angle and the
//! discharged count at the same instants.

use super::protocol::{
    mean_kinetic_energy_j, run_phase, Phase, Progress, Sampler, SettleCriterion, Traces,
    STANDARD_GRAVITY_M_S2,
};
use super::resolution;
use super::skeleton::{finish, lab_error_conversions, open_log, Grains, Lab, LabError};
use super::SceneError;
use crate::dem::domain::Domain;
use crate::dem::health::HealthLimits;
use crate::dem::simulation::{Simulation, World};
use crate::dem::timestep::TimeStepPlan;
use crate::dem::vec3::Vec3;
use crate::dem::walls::{Wall, WallError};
use crate::log::{AngleSample, RunLog, Trace};
use crate::manifest::scene::StaticPileScene;
use crate::manifest::Experiment;
use crate::measure::pile::{height_diameter_angle, side_views, HeightAngle, PileSpec, SideViews};
pub use crate::measure::pile::{VIEWS, VIEW_AZIMUTHS_DEG};
use crate::measure::MeasureError;
use crate::packing::factory::{RateFactory, RateFactorySpec};
use crate::packing::region::Region;
use crate::packing::PackingError;
use crate::store::{RunResult, HEADLINE_KEY};
use std::f64::consts::PI;
use std::path::Path;

/// Fraction of the funnel's height, from its top down, in which new particles
/// are placed (cai2024 only says "at the funnel top"; the upper half spreads a
/// window's particles over height so they arrive as a stream).
pub const INSERTION_DEPTH_FRACTION: f64 = 0.5;
/// Gap between a new particle and the funnel wall, in d50 (as the drum's fill).
pub const INSERTION_CLEARANCE_DIAMETERS: f64 = 0.05;
/// Random positions tried per new particle in one window; one that finds no
/// free place waits for the next window.
pub const INSERTION_ATTEMPTS: usize = 100;
/// A flank fit with a smaller R² is flagged (`profile_r2_below_floor`): below
/// it the surface is too lumpy for a line (synthetic rough cones give > 0.98).
pub const R2_FLOOR: f64 = 0.9;
/// Equal azimuthal sectors of the rim checked for pile coverage.
pub const RIM_SECTORS: usize = 16;
/// Factor on the free-fall speed from the top of the rig that bounds any
/// particle's speed when sizing the box ([`Removal::travel_m`]).
const SPEED_SAFETY: f64 = 2.0;
/// A pile lower than this many d50 is not measurable.
const MIN_HEIGHT_DIAMETERS: f64 = 3.0;

/// Why a static-pile run failed beyond the engine's time-step refusal.
#[derive(Debug, thiserror::Error)]
pub enum StaticPileError {
    /// What any lab scene can fail at ([`LabError`]).
    #[error(transparent)]
    Lab(LabError),
}

lab_error_conversions!(StaticPileError, "static_pile");

/// The rig's dimensions, m: disk top at z = 0, funnel and disk on the z axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Disk radius, m.
    pub disk_radius_m: f64,
    /// Height of the funnel outlet above the disk, m.
    pub outlet_z_m: f64,
    /// Outlet radius, m.
    pub outlet_radius_m: f64,
    /// Height of the funnel top above the disk, m.
    pub top_z_m: f64,
    /// Funnel top radius, m.
    pub top_radius_m: f64,
}

impl Geometry {
    /// The rig of a scene: the funnel's height follows from its radii and the
    /// cone angle, (top − outlet radius) / tan(cone angle / 2).
    pub fn new(scene: &StaticPileScene) -> Self {
        let half_angle = (0.5 * scene.cone_angle_deg).to_radians();
        let outlet_radius_m = 0.5 * scene.outlet_diameter_m;
        let top_radius_m = 0.5 * scene.funnel_top_diameter_m;
        Self {
            disk_radius_m: 0.5 * scene.disk_diameter_m,
            outlet_z_m: scene.outlet_height_m,
            outlet_radius_m,
            top_z_m: scene.outlet_height_m + (top_radius_m - outlet_radius_m) / half_angle.tan(),
            top_radius_m,
        }
    }

    /// Funnel (material 0) and disk (material 1).
    pub fn walls(&self) -> Result<Vec<Wall>, WallError> {
        Ok(vec![
            Wall::cone_frustum(
                Vec3::new(0.0, 0.0, self.outlet_z_m),
                Vec3::z(),
                self.outlet_radius_m,
                self.top_radius_m,
                self.top_z_m - self.outlet_z_m,
                0,
            )?,
            Wall::disk(Vec3::zeros(), Vec3::z(), self.disk_radius_m, 1)?,
        ])
    }

    /// The funnel's inside over its upper [`INSERTION_DEPTH_FRACTION`].
    pub fn insertion_region(&self) -> Region {
        let f = INSERTION_DEPTH_FRACTION;
        Region::Frustum {
            axis_xy_m: [0.0, 0.0],
            z_bottom_m: self.top_z_m - f * (self.top_z_m - self.outlet_z_m),
            radius_bottom_m: self.top_radius_m - f * (self.top_radius_m - self.outlet_radius_m),
            z_top_m: self.top_z_m,
            radius_top_m: self.top_radius_m,
        }
    }
}

/// The particle sizes a run draws from, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diameters {
    /// Smallest diameter that can be drawn (sets the time step), m.
    pub min_m: f64,
    /// Representative diameter (d50 of a log-normal, the mean of a list), m.
    pub median_m: f64,
    /// Largest diameter that can be drawn, m.
    pub max_m: f64,
}

/// Which particles have left the rig for good (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Removal {
    /// Centres below this height are gone, m (one largest diameter below the disk).
    pub floor_z_m: f64,
    /// Below the outlet, centres farther than this from the axis are gone, m.
    pub max_radius_m: f64,
    /// Height of the funnel outlet, m.
    pub outlet_z_m: f64,
}

impl Removal {
    /// The removal limits of a rig whose largest particle is `d_max_m` across.
    pub fn new(geometry: &Geometry, d_max_m: f64) -> Self {
        Self {
            floor_z_m: -d_max_m,
            max_radius_m: geometry.disk_radius_m + 2.0 * d_max_m,
            outlet_z_m: geometry.outlet_z_m,
        }
    }

    /// True for a particle centred at `p` that is still part of the rig.
    pub fn keeps(&self, p: &Vec3) -> bool {
        p.z >= self.floor_z_m && (p.z >= self.outlet_z_m || p.x.hypot(p.y) <= self.max_radius_m)
    }

    /// The farthest a particle can move between two removal checks `window_s`
    /// apart, m: free fall from the funnel top to the removal floor gives the
    /// speed scale, times a safety factor of 2 (collisions can pass momentum
    /// on), plus the fall within the window.
    pub fn travel_m(&self, geometry: &Geometry, window_s: f64) -> f64 {
        let g = STANDARD_GRAVITY_M_S2;
        let v_max = SPEED_SAFETY * (2.0 * g * (geometry.top_z_m - self.floor_z_m)).sqrt();
        v_max * window_s + 0.5 * g * window_s * window_s
    }
}

/// The rate factory of a run: `particle_count` particles in total, a
/// shortfall retried in the following windows.
#[derive(Clone, Debug)]
pub struct Feeder {
    factory: RateFactory,
    budget: u64,
    due: u64,
    generated: u64,
    /// What the inserted spheres become (spheres or clumps), and how their
    /// placement went.
    pub grains: Grains,
}

impl Feeder {
    /// The scene's factory (see the module docs), starting at t = 0.
    pub fn new(
        exp: &Experiment,
        scene: &StaticPileScene,
        geometry: &Geometry,
        lab: &Lab,
    ) -> Result<Self, PackingError> {
        let d50_m = lab.d_mean_m;
        let spec = RateFactorySpec {
            region: geometry.insertion_region(),
            sizes: lab.sizes.clone(),
            rate_per_s: scene.insertion_rate_per_s,
            velocity_m_s: Vec3::zeros(),
            seed: exp.seeds.packing_seed,
            clearance_m: INSERTION_CLEARANCE_DIAMETERS * d50_m,
            attempts_per_particle: INSERTION_ATTEMPTS,
        };
        Ok(Self {
            factory: RateFactory::new(spec, 0.0)?,
            budget: scene.particle_count,
            due: 0,
            generated: 0,
            grains: lab.grains.clone(),
        })
    }

    /// Inserts the particles due up to the simulation's current time and those
    /// still pending from earlier windows (never more than the budget in
    /// total); returns their ids (body ids when the particles are clumps).
    pub fn feed(&mut self, sim: &mut Simulation) -> Result<Vec<u32>, StaticPileError> {
        if self.generated == self.budget {
            return Ok(Vec::new());
        }
        let carried = self.pending();
        let w = sim.world();
        let ins = self
            .factory
            .insert(w.time_s, &w.particles.position, &w.particles.radius)?;
        let fresh = ins.requested as u64 - carried;
        self.due = (self.due + fresh).min(self.budget);
        let mut new = ins.particles;
        new.truncate((self.due - self.generated) as usize);
        self.generated += new.len() as u64;
        self.factory.carry_over(self.pending() as usize);
        Ok(self.grains.insert(sim, &new)?)
    }

    /// Particles inserted so far.
    pub fn generated(&self) -> u64 {
        self.generated
    }

    /// Particles that fell due but have found no free place yet (the funnel
    /// has backed up into the insertion region); they are retried.
    pub fn pending(&self) -> u64 {
        self.due - self.generated
    }
}

/// A static-pile run ready to start: the simulation (walls, box, no particles
/// yet), its factory and the numbers the protocol needs.
#[derive(Debug)]
pub struct Rig {
    /// The simulation, at t = 0 and empty.
    pub sim: Simulation,
    /// The factory that fills it.
    pub feeder: Feeder,
    /// The rig's dimensions.
    pub geometry: Geometry,
    /// Which particles leave the rig.
    pub removal: Removal,
    /// Particle sizes.
    pub diameters: Diameters,
    /// The time step and the numbers behind it.
    pub plan: TimeStepPlan,
}

/// Builds the rig of a `static_pile` experiment (see the module docs).
pub fn rig(exp: &Experiment, scene: &StaticPileScene) -> Result<Rig, SceneError> {
    let fail = |e: StaticPileError| SceneError::StaticPile(e);
    let walls = [scene.funnel_material.as_str(), scene.disk_material.as_str()];
    let lab = Lab::new(exp, &walls, |e| fail(e.into()))?;
    let max_m = lab
        .sizes
        .sampler()
        .map_err(|e| fail(e.into()))?
        .max_diameter();
    let diameters = Diameters {
        min_m: lab.d_min_m,
        median_m: lab.d_mean_m,
        max_m,
    };
    let geometry = Geometry::new(scene);
    let removal = Removal::new(&geometry, max_m);
    let world =
        empty_world(&lab, &geometry, &removal, max_m, scene.insertion_interval_s).map_err(fail)?;
    let sim = lab
        .simulation(world, HealthLimits::default())
        .map_err(|e| fail(e.into()))?;
    let feeder = Feeder::new(exp, scene, &geometry, &lab).map_err(|e| fail(e.into()))?;
    Ok(Rig {
        sim,
        feeder,
        geometry,
        removal,
        diameters,
        plan: lab.plan,
    })
}

/// Walls and a box that no kept particle can leave within one window.
fn empty_world(
    lab: &Lab,
    geometry: &Geometry,
    removal: &Removal,
    d_max_m: f64,
    window_s: f64,
) -> Result<World, StaticPileError> {
    let travel = removal.travel_m(geometry, window_s);
    let reach = removal.max_radius_m.max(geometry.top_radius_m) + d_max_m + travel;
    let domain = Domain::new(
        Vec3::new(-reach, -reach, removal.floor_z_m - d_max_m - travel),
        Vec3::new(reach, reach, geometry.top_z_m + d_max_m + travel),
        [false; 3],
    )?;
    Ok(lab.grains.world(&[], geometry.walls()?, domain)?)
}

/// The pile's measurements (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PileMeasurement {
    /// Profile angle in each view of [`VIEW_AZIMUTHS_DEG`]; all four are fitted,
    /// or `None` when a view cannot be (too few surface points on a flank).
    pub profile: Option<SideViews>,
    /// cai2024's atan(2H/D).
    pub height: HeightAngle,
    /// Share of the rim's sectors reached by the pile, in [0, 1].
    pub rim_coverage_fraction: f64,
    /// Median height of the pile's top at the rim, m: 2H/D reads this step
    /// as part of the cone (see the module docs).
    pub rim_height_m: f64,
}

/// Measures the pile formed by the particles (`positions`, `radii`, m) on the
/// disk of `geometry`, with surface bins `bin_width_m` wide (one d50).
pub fn measure_pile(
    geometry: &Geometry,
    positions: &[Vec3],
    radii: &[f64],
    bin_width_m: f64,
) -> Result<PileMeasurement, MeasureError> {
    let (pos, rad): (Vec<Vec3>, Vec<f64>) = positions
        .iter()
        .zip(radii)
        .filter(|(p, _)| p.z >= 0.0 && p.z < geometry.outlet_z_m)
        .map(|(p, r)| (*p, *r))
        .unzip();
    let base = PileSpec {
        axis_xy_m: Some([0.0, 0.0]),
        min_height_diameters: MIN_HEIGHT_DIAMETERS,
        ..PileSpec::new(0.0, bin_width_m)
    };
    let profile = side_views(&pos, &rad, &base, VIEWS).ok();
    let height = height_diameter_angle(
        &pos,
        &rad,
        0.0,
        2.0 * geometry.disk_radius_m,
        MIN_HEIGHT_DIAMETERS,
    )?;
    let (rim_coverage_fraction, rim_height_m) = rim(geometry, &pos, &rad, bin_width_m);
    Ok(PileMeasurement {
        profile,
        height,
        rim_coverage_fraction,
        rim_height_m,
    })
}

/// The pile at the disk's rim: the share of [`RIM_SECTORS`] sectors holding a
/// particle centred within `width_m` of the rim, and the median over those
/// sectors of the highest particle top there, m (0 when none is reached).
fn rim(geometry: &Geometry, positions: &[Vec3], radii: &[f64], width_m: f64) -> (f64, f64) {
    let mut top = [f64::NEG_INFINITY; RIM_SECTORS];
    for (p, r) in positions.iter().zip(radii) {
        if p.x.hypot(p.y) >= geometry.disk_radius_m - width_m {
            let turn = p.y.atan2(p.x).rem_euclid(2.0 * PI) / (2.0 * PI);
            let k = ((turn * RIM_SECTORS as f64) as usize).min(RIM_SECTORS - 1);
            top[k] = top[k].max(p.z + r);
        }
    }
    let mut reached: Vec<f64> = top.into_iter().filter(|t| t.is_finite()).collect();
    if reached.is_empty() {
        return (0.0, 0.0);
    }
    reached.sort_by(f64::total_cmp);
    let m = reached.len();
    let median = if m % 2 == 1 {
        reached[m / 2]
    } else {
        0.5 * (reached[m / 2 - 1] + reached[m / 2])
    };
    (m as f64 / RIM_SECTORS as f64, median)
}

/// Where the particles are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Census {
    /// Centre at or above the outlet: still in the funnel.
    pub in_funnel: usize,
    /// Centre above the disk and below the outlet: on the disk (or falling).
    pub on_disk: usize,
    /// Centre below the disk: falling off it, removed at the next window.
    pub below_disk: usize,
}

impl Census {
    /// Counts the particles centred at `positions` (m) in the rig `geometry`.
    pub fn of(geometry: &Geometry, positions: &[Vec3]) -> Self {
        let in_funnel = positions
            .iter()
            .filter(|p| p.z >= geometry.outlet_z_m)
            .count();
        let on_disk = positions
            .iter()
            .filter(|p| p.z >= 0.0 && p.z < geometry.outlet_z_m)
            .count();
        let below_disk = positions.len() - in_funnel - on_disk;
        Self {
            in_funnel,
            on_disk,
            below_disk,
        }
    }
}

/// Feeds, removes, and samples traces and log frames during the run.
struct PileSampler<'a> {
    feeder: Feeder,
    removal: Removal,
    removed: u64,
    geometry: Geometry,
    /// d50, m: the surface bin width and the speed scale √(g d50).
    d50_m: f64,
    traces: Traces,
    log: Option<&'a mut RunLog>,
    window_s: f64,
    sample_interval_s: f64,
    next_sample_s: f64,
    last_recorded_s: Option<f64>,
}

impl Sampler for PileSampler<'_> {
    type Error = StaticPileError;

    fn sample(&mut self, _phase: &'static str, sim: &mut Simulation) -> Result<(), Self::Error> {
        let removal = self.removal;
        self.removed += sim.retain(|p, i| removal.keeps(&p.position[i]))? as u64;
        self.feeder.feed(sim)?;
        // Calls come every window (a whole number of steps, so within a step
        // of the nominal window): sample at the call nearest each due time.
        let t = sim.world().time_s;
        if t + 0.5 * self.window_s >= self.next_sample_s {
            self.next_sample_s += self.sample_interval_s;
            self.record(sim)?;
        }
        Ok(())
    }
}

impl PileSampler<'_> {
    /// Traces and a log frame at the current time.
    fn record(&mut self, sim: &Simulation) -> Result<(), StaticPileError> {
        let w = sim.world();
        let t = w.time_s;
        self.last_recorded_s = Some(t);
        self.traces.push_engine_state(sim);
        let in_funnel = Census::of(&self.geometry, &w.grain_centres().0).in_funnel as u64;
        let discharged = w.grains() as u64 - in_funnel + self.removed;
        self.traces
            .push("generated", "1", t, self.feeder.generated() as f64);
        self.traces
            .push("insertion_pending", "1", t, self.feeder.pending() as f64);
        self.traces
            .push("removed_off_disk", "1", t, self.removed as f64);
        self.traces.push("discharged", "1", t, discharged as f64);
        self.traces.push("in_funnel", "1", t, in_funnel as f64);
        // The falling stream is not part of the pile: only particles slower
        // than a fall through half a d50, √(g d50), count here.
        let p = &w.particles;
        let calm_sq = STANDARD_GRAVITY_M_S2 * self.d50_m;
        let (pos, rad): (Vec<Vec3>, Vec<f64>) = (0..p.len())
            .filter(|&i| p.velocity[i].norm_squared() <= calm_sq)
            .map(|i| (p.position[i], p.radius[i]))
            .unzip();
        let pile = measure_pile(&self.geometry, &pos, &rad, self.d50_m).ok();
        if let Some(profile) = pile.and_then(|m| m.profile) {
            self.traces
                .push("profile_angle", "deg", t, profile.mean_deg());
        }
        if let Some(m) = pile {
            self.traces
                .push("height_angle", "deg", t, m.height.angle_deg);
        }
        if let Some(log) = self.log.as_deref_mut() {
            log.record(sim)?;
            log.scalar(Trace::Discharged, t, discharged as f64)?;
            if let Some(profile) = pile.and_then(|m| m.profile) {
                log.angle(
                    t,
                    &AngleSample {
                        left_deg: profile.left_deg(),
                        right_deg: profile.right_deg(),
                        mean_deg: profile.mean_deg(),
                        fit_r2: profile.min_r2(),
                    },
                )?;
            }
        }
        Ok(())
    }
}

/// Duration of the pour, s: whole windows until the last particle falls due,
/// plus one so that it does whatever the clock's rounding.
pub fn pour_duration_s(scene: &StaticPileScene) -> f64 {
    let window = scene.insertion_interval_s;
    let windows = (scene.particle_count as f64 / scene.insertion_rate_per_s / window).ceil() + 1.0;
    windows * window
}

/// Runs a `static_pile` experiment (see the module docs); with `log`, writes
/// its MCAP log there.
pub fn run(
    exp: &Experiment,
    scene: &StaticPileScene,
    log: Option<&Path>,
) -> Result<RunResult, SceneError> {
    let Rig {
        mut sim,
        feeder,
        geometry,
        removal,
        diameters,
        plan,
    } = rig(exp, scene)?;
    let dt_s = plan.dt_s;
    let speed_scale_m_s = (2.0 * STANDARD_GRAVITY_M_S2 * geometry.top_z_m).sqrt();
    let mut log_file = open_log(log, exp, speed_scale_m_s)?;
    let d50 = diameters.median_m;
    let mut sampler = PileSampler {
        feeder,
        removal,
        removed: 0,
        geometry,
        d50_m: d50,
        traces: Traces::default(),
        log: log_file.as_mut(),
        window_s: scene.insertion_interval_s,
        sample_interval_s: scene.sample_interval_s,
        next_sample_s: 0.0,
        last_recorded_s: None,
    };
    let mut progress = Progress::on_stderr();
    let window = scene.insertion_interval_s;
    let pour = Phase {
        name: "pour",
        max_duration_s: pour_duration_s(scene),
        settle: None,
    };
    let fail = |e: StaticPileError| SceneError::StaticPile(e);
    run_phase(&mut sim, &pour, dt_s, window, &mut sampler, &mut progress).map_err(fail)?;
    let pour_end_s = sim.world().time_s;
    let mass = exp.material.particle.density_kg_m3 * PI / 6.0 * d50.powi(3);
    let settle = Phase {
        name: "settle",
        max_duration_s: scene.settle_time_s,
        settle: Some(SettleCriterion::at_rest(&exp.at_rest, mass, d50)),
    };
    let settled =
        run_phase(&mut sim, &settle, dt_s, window, &mut sampler, &mut progress).map_err(fail)?;

    // The final state is always in the traces and the log.
    if sampler.last_recorded_s != Some(sim.world().time_s) {
        sampler.record(&sim).map_err(fail)?;
    }
    let w = sim.world();
    let generated = sampler.feeder.generated();
    let census = Census::of(&geometry, &w.grain_centres().0);
    // No pile is a measurement the run could not take, with the counts
    // that say why; the run keeps every other measurement.
    let pile = measure_pile(&geometry, &w.particles.position, &w.particles.radius, d50).map_err(
        |source| {
            format!(
                "static pile: angle not measurable: {source}; {generated} of {} particles \
                 were generated, {} rest on the disk and {} are still in the funnel",
                scene.particle_count, census.on_disk, census.in_funnel
            )
        },
    );
    let rest_ratio = mean_kinetic_energy_j(&sim) / (mass * STANDARD_GRAVITY_M_S2 * d50);
    let traces = std::mem::take(&mut sampler.traces);
    let removed = sampler.removed;
    let grains = sampler.feeder.grains.clone();
    drop(sampler);

    let mut result = finish(
        exp,
        &sim,
        &plan,
        traces,
        log_file,
        generated as usize,
        settled.settled,
    )?;
    result.warnings.extend(grains.warnings());
    let mut put = |k: &str, v: f64| {
        result.measurements.insert(k.to_string(), v);
    };
    put(
        "particles_not_generated",
        (scene.particle_count - generated) as f64,
    );
    put("removed_off_disk", removed as f64);
    put("funnel_retained", census.in_funnel as f64);
    put("particles_on_disk", census.on_disk as f64);
    put("particles_below_disk", census.below_disk as f64);
    put("pour_end_s", pour_end_s);
    put("final_kinetic_energy_ratio", rest_ratio);
    put_pile(&mut result, pile);
    resolution::at_least(
        &mut result,
        "disk_diameters",
        2.0 * geometry.disk_radius_m / d50,
        resolution::ACROSS_MIN,
    );
    Ok(result)
}

/// The pile's measurements, or why there are none (see the module docs).
fn put_pile(result: &mut RunResult, pile: Result<PileMeasurement, String>) {
    let pile = match pile {
        Ok(pile) => pile,
        Err(why) => {
            result.measurements.insert("profile_measured".into(), 0.0);
            for key in ["height_angle_deg", HEADLINE_KEY] {
                result.unmeasured.insert(key.to_string(), why.clone());
            }
            return;
        }
    };
    let mut put = |k: &str, v: f64| {
        result.measurements.insert(k.to_string(), v);
    };
    put(
        "profile_measured",
        f64::from(u8::from(pile.profile.is_some())),
    );
    if let Some(profile) = &pile.profile {
        put("profile_angle_deg", profile.mean_deg());
        put("profile_left_deg", profile.left_deg());
        put("profile_right_deg", profile.right_deg());
        for (az, a) in VIEW_AZIMUTHS_DEG.iter().zip(&profile.views) {
            let Some(a) = a else { continue };
            let view = format!("az{az:03}");
            put(&format!("profile_{view}_left_deg"), a.left_deg);
            put(&format!("profile_{view}_right_deg"), a.right_deg);
            put(&format!("profile_{view}_mean_deg"), a.mean_deg);
            put(&format!("profile_{view}_r2_left"), a.r2_left);
            put(&format!("profile_{view}_r2_right"), a.r2_right);
            put(&format!("profile_{view}_points_left"), a.points_left as f64);
            put(
                &format!("profile_{view}_points_right"),
                a.points_right as f64,
            );
        }
        put("profile_r2_min", profile.min_r2());
        put(
            "profile_r2_below_floor",
            f64::from(u8::from(profile.min_r2() < R2_FLOOR)),
        );
    }
    put("height_angle_deg", pile.height.angle_deg);
    put("pile_height_m", pile.height.height_m);
    put("rim_coverage_fraction", pile.rim_coverage_fraction);
    put("rim_height_m", pile.rim_height_m);
    result.headline_angle_deg = Some(pile.height.angle_deg);
}
