//! What a run will cost, known before it starts: the plan of an experiment.
//!
//! [`plan`] is a pure function of an experiment. It first applies every field
//! rule of [`validate_experiment`], then the rules that need the scene's
//! geometry and the engine's physics together, which no single field can
//! check:
//!
//! - the time step the engine would choose ([`physics::time_step`]) must exist
//!   and be finite and > 0 (a Young's modulus or design impact speed of 1e308
//!   gives a step of 0 s);
//! - the scene must hold at least one particle (a fill fraction, powder mass or
//!   bed too small for one particle of the given size runs, then has nothing to
//!   measure);
//! - the largest simulated particle must fit the region it is placed in (the
//!   drum's fill square, the box, the hopper) and pass the opening it must
//!   flow through (funnel outlet, hopper orifice, static-pile outlet), and a
//!   periodic slice must be at least twice the engine's neighbour-search
//!   cutoff (2 r_max + JKR reach + skin), as [`crate::dem::domain`] demands;
//! - a lab scene's `sample_interval_s` must be at least the time step
//!   (samples and log frames are taken between steps; 1e-300 would otherwise
//!   write a frame at every step);
//! - the estimated particle count must be finite and at most
//!   [`ENGINE_MAX_PARTICLES`], the most the engine's 32-bit particle ids can
//!   address (a drum of diameter 1e308 would otherwise try to allocate an
//!   infinite placement).
//!
//! Each violation is a [`FieldError`] that names the manifest's own field
//! (`scene.periodic_slice_m = 0.009: must be >= ...`), so `repose validate`
//! reports them with the field rules and exits 2; nothing is simulated and
//! nothing is written to the store.
//!
//! # Estimates
//!
//! A valid experiment gets a [`RunPlan`]: particles, time step, simulated time,
//! steps, particle-steps, log frames and log bytes. They are upper estimates
//! where the protocol decides at run time (settling phases may end early; the
//! longest allowed time is counted). Particle counts use the scene's own
//! formula (the drum's and the static pile's are exact); fill-fraction and
//! mass targets are divided by the volume of the representative particle
//! (number-weighted mean diameter, d50 of a log-normal), which over-counts a
//! polydisperse powder a little. Log bytes use the measured worst sizes in
//! [`crate::log`]: [`SPHERE_BYTES`] per particle-frame up to
//! [`SPHERE_LIMIT`] particles, [`CLOUD_BYTES`] above it, plus
//! [`FRAME_OVERHEAD_BYTES`] per frame (walls, traces) and
//! [`LOG_FIXED_BYTES`].
//!
//! # Limits
//!
//! [`Limits`] caps particles, particle-steps and log bytes. `repose run`,
//! `batch`, `verify`, `calibrate` and `learning-curve` refuse, before anything
//! runs, an experiment whose estimate exceeds a limit, with the estimate and the
//! flag that raises it in the message (exit 2); a run already complete in
//! the store is served from the cache whatever the limits, and `repose plan`
//! reports an excess without failing. The defaults
//! ([`Limits::default`]) sit well above every committed profile (the largest,
//! the he2019 funnel at the paper profile, is about 6.3 × 10¹² particle-steps)
//! and well below what exhausts a workstation. The limits are command-line
//! flags, not manifest fields: a manifest field would be hashed into the
//! experiment id, so raising a limit would change the id and miss the cache of
//! an identical physical run; the limit is a property of the machine, not of
//! the experiment.

use std::f64::consts::PI;
use std::fmt;

use serde::Serialize;

use super::baffle::BAFFLE_CLEARANCE_DIAMETERS;
use super::funnel::geometry::FunnelGeometry;
use super::hopper::{DEFAULT_SAMPLE_INTERVAL_S as HOPPER_SAMPLE_S, DEFAULT_SETTLE_MAX_S};
use super::pair::PAIR_FRAMES;
use super::physics;
use super::static_pile::pour_duration_s;
use crate::dem::contact::normal_jkr::Jkr;
use crate::dem::contact::{NormalModel as _, PairCoefficients};
use crate::dem::simulation::NormalChoice;
use crate::log::writer::SPHERE_LIMIT;
use crate::manifest::scene::{
    BaffleLiftScene, DrumScene, FunnelPileScene, HopperScene, PairScene, Partner, StaticPileScene,
};
use crate::manifest::validate::number;
use crate::manifest::{
    validate_experiment, ContentId, Experiment, FieldError, Scene, SizeDistribution,
    ValidationErrors,
};

/// Most particles a run can have: the engine numbers particles with `u32` ids.
pub const ENGINE_MAX_PARTICLES: f64 = u32::MAX as f64;
/// Log bytes per particle and frame while particles are drawn as spheres (the
/// measured worst case after compression, 20 000 scattered particles; see
/// [`crate::log`]).
pub const SPHERE_BYTES: f64 = 62.0;
/// Log bytes per particle and frame in a point cloud (above [`SPHERE_LIMIT`]
/// particles): a point's 20 raw bytes, compression not counted.
pub const CLOUD_BYTES: f64 = 20.0;
/// Log bytes per frame besides the particles (wall poses, four trace messages),
/// an allowance.
pub const FRAME_OVERHEAD_BYTES: f64 = 1024.0;
/// Log bytes of every run whatever its length (schemas, descriptors, manifest
/// metadata and attachment, summary).
pub const LOG_FIXED_BYTES: f64 = 64.0 * 1024.0;
/// Neighbour-search skin of the lab scenes, as a fraction of the representative
/// diameter (each scene's `SimulationSetup::skin_m`).
const SKIN_DIAMETERS: f64 = 0.1;
/// Gap the lab scenes keep between a placed sphere and its region's faces, as a
/// fraction of the representative diameter (each scene's `clearance_m`).
const CLEARANCE_DIAMETERS: f64 = 0.05;

/// The estimated cost of one run (see the module docs). Counts are `f64` so that
/// an absurd estimate is reported, not overflowed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RunPlan {
    /// The scene kind (`drum`, `pair`, ...).
    pub scene: &'static str,
    /// Estimated number of simulated spheres (the most at any time; with
    /// clumps, their member spheres).
    pub particles: f64,
    /// The time step the engine will use, s.
    pub dt_s: f64,
    /// Longest simulated time (every phase at its maximum), s.
    pub simulated_time_s: f64,
    /// Steps: simulated time / time step.
    pub steps: f64,
    /// Particles × steps: the work, proportional to CPU time.
    pub particle_steps: f64,
    /// Frames written to the run log.
    pub frames: f64,
    /// Estimated size of the run log, bytes.
    pub log_bytes: f64,
}

/// Resource limits a run must stay within (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Limits {
    /// Most particles.
    pub max_particles: u64,
    /// Most particle-steps.
    pub max_particle_steps: u64,
    /// Largest run log, bytes.
    pub max_log_bytes: u64,
}

impl Limits {
    /// Default of [`Limits::max_particles`]: 2 × 10⁶, nine times the largest
    /// committed profile (funnel_pile paper, 2.1 × 10⁵ estimated).
    pub const DEFAULT_MAX_PARTICLES: u64 = 2_000_000;
    /// Default of [`Limits::max_particle_steps`]: 10¹⁴, 16 times the largest
    /// committed profile (funnel_pile paper, 6.3 × 10¹², about 25 CPU-days
    /// measured), so about a CPU-year.
    pub const DEFAULT_MAX_PARTICLE_STEPS: u64 = 100_000_000_000_000;
    /// Default of [`Limits::max_log_bytes`]: 10 GB, ten times the largest
    /// committed profile's estimate (hopper paper, 1.0 × 10⁹).
    pub const DEFAULT_MAX_LOG_BYTES: u64 = 10_000_000_000;
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_particles: Self::DEFAULT_MAX_PARTICLES,
            max_particle_steps: Self::DEFAULT_MAX_PARTICLE_STEPS,
            max_log_bytes: Self::DEFAULT_MAX_LOG_BYTES,
        }
    }
}

/// One estimate above its limit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Excess {
    /// What is estimated (`particles`, `particle_steps`, `log_bytes`).
    pub quantity: &'static str,
    /// The estimate.
    pub estimate: f64,
    /// The limit it exceeds.
    pub limit: u64,
    /// The command-line flag that raises the limit.
    pub flag: &'static str,
}

/// A run refused because its estimates exceed the limits (never empty).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", describe_excess(.0))]
pub struct OverLimit(pub Vec<Excess>);

fn describe_excess(excess: &[Excess]) -> String {
    excess
        .iter()
        .map(|e| {
            format!(
                "estimated {} {} exceed the limit {} (raise it with {} N if you mean it)",
                sci(e.estimate),
                e.quantity.replace('_', "-"),
                e.limit,
                e.flag
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// A count in a short form: integers up to 10⁶ in full, larger values as `2.3e9`.
pub fn sci(v: f64) -> String {
    if v.is_finite() && v.abs() < 1e6 && v == v.round() {
        format!("{v}")
    } else {
        format!("{v:.3e}")
    }
}

/// A derived quantity to four significant digits, trailing zeros dropped
/// (`0.02201`, `0.003`, `1.431e-5`).
fn approx(v: f64) -> String {
    let trim = |t: String| {
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            t
        }
    };
    if v != 0.0 && v.is_finite() && (v.abs() >= 1e5 || v.abs() < 1e-3) {
        let t = format!("{v:.3e}");
        let (mantissa, exponent) = t.split_once('e').unwrap_or((&t, "0"));
        format!("{}e{exponent}", trim(mantissa.to_string()))
    } else {
        let digits = if v == 0.0 || !v.is_finite() {
            0
        } else {
            (3 - v.abs().log10().floor() as i32).max(0) as usize
        };
        trim(format!("{v:.digits$}"))
    }
}

impl RunPlan {
    /// The estimates above `limits`; `Ok` when all are within.
    pub fn check(&self, limits: &Limits) -> Result<(), OverLimit> {
        let excess: Vec<Excess> = [
            (
                "particles",
                self.particles,
                limits.max_particles,
                "--max-particles",
            ),
            (
                "particle_steps",
                self.particle_steps,
                limits.max_particle_steps,
                "--max-particle-steps",
            ),
            (
                "log_bytes",
                self.log_bytes,
                limits.max_log_bytes,
                "--max-log-bytes",
            ),
        ]
        .into_iter()
        // NaN never passes.
        .filter(|&(_, estimate, limit, _)| estimate.is_nan() || estimate > limit as f64)
        .map(|(quantity, estimate, limit, flag)| Excess {
            quantity,
            estimate,
            limit,
            flag,
        })
        .collect();
        if excess.is_empty() {
            Ok(())
        } else {
            Err(OverLimit(excess))
        }
    }
}

impl RunPlan {
    /// The plan of experiment `id` (from `manifest`) against `limits` as
    /// `repose plan` prints it: a header line, the estimates, the limits and
    /// whether the estimates are within them (above a limit is a finding
    /// here, not an error).
    pub fn text(&self, id: &ContentId, manifest: &str, limits: &Limits) -> String {
        let mut out = format!("plan {id} ({manifest})\n");
        for line in self.to_string().lines() {
            out.push_str(&format!("  {line}\n"));
        }
        out.push_str(&format!(
            "  limits: particles {}, particle_steps {}, log_bytes {}\n",
            limits.max_particles, limits.max_particle_steps, limits.max_log_bytes
        ));
        match self.check(limits) {
            Ok(()) => out.push_str("  within limits: yes\n"),
            Err(e) => out.push_str(&format!("  within limits: no: {e}\n")),
        }
        out
    }

    /// [`RunPlan::text`] as one JSON object: `manifest`, `id`, `plan`,
    /// `limits`, `within_limits` and the `excess` estimates.
    pub fn json(&self, id: &ContentId, manifest: &str, limits: &Limits) -> serde_json::Value {
        let verdict = self.check(limits);
        let excess = verdict.as_ref().err().map_or(&[][..], |e| &e.0[..]);
        serde_json::json!({
            "manifest": manifest,
            "id": id.to_string(),
            "plan": self,
            "limits": limits,
            "within_limits": verdict.is_ok(),
            "excess": excess,
        })
    }
}

impl fmt::Display for RunPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "scene: {}", self.scene)?;
        writeln!(f, "particles: {}", sci(self.particles.round()))?;
        writeln!(f, "dt_s: {:.4e}", self.dt_s)?;
        writeln!(f, "simulated_time_s: {}", approx(self.simulated_time_s))?;
        writeln!(f, "steps: {}", sci(self.steps.ceil()))?;
        writeln!(f, "particle_steps: {}", sci(self.particle_steps.ceil()))?;
        writeln!(f, "frames: {}", sci(self.frames.ceil()))?;
        write!(f, "log_bytes: {}", sci(self.log_bytes.ceil()))
    }
}

/// Checks the experiment (field rules, then the scene-and-physics rules of the
/// module docs) and estimates its cost.
pub fn plan(exp: &Experiment) -> Result<RunPlan, ValidationErrors> {
    validate_experiment(exp)?;
    let mut errors = Vec::new();
    let plan = estimate(exp, &mut errors);
    match plan {
        Some(p) if errors.is_empty() => Ok(p),
        _ => Err(ValidationErrors(errors)),
    }
}

/// Records a field error.
fn fail(errors: &mut Vec<FieldError>, path: &str, value: String, rule: String) {
    errors.push(FieldError {
        path: path.to_string(),
        value,
        rule,
    });
}

/// The path and value of the field that sets the largest particle.
fn largest_size_field(exp: &Experiment) -> (&'static str, String) {
    match &exp.material.particle.size {
        SizeDistribution::Monodisperse { radius_m } => {
            ("material.particle.size.radius_m", number(*radius_m))
        }
        SizeDistribution::List { radii_m, .. } => (
            "material.particle.size.radii_m",
            serde_json::to_string(radii_m).unwrap_or_default(),
        ),
        SizeDistribution::D10D50D90 { d90_m, .. } => {
            ("material.particle.size.d90_m", number(*d90_m))
        }
    }
}

/// Simulated diameters of a lab scene's particles, m.
#[derive(Clone, Copy)]
struct Diameters {
    min: f64,
    mean: f64,
    max: f64,
}

impl Diameters {
    /// Volume of the representative particle, m³.
    fn mean_volume(&self) -> f64 {
        PI / 6.0 * self.mean.powi(3)
    }
}

fn diameters(exp: &Experiment, errors: &mut Vec<FieldError>) -> Option<Diameters> {
    let sizes = physics::size_distribution(exp);
    let bounds = physics::diameter_bounds(&sizes)
        .and_then(|(min, mean)| Ok((min, mean, sizes.sampler()?.max_diameter())));
    let (path, value) = largest_size_field(exp);
    match bounds {
        Ok((min, mean, max)) if [min, mean, max].iter().all(|d| d.is_finite() && *d > 0.0) => {
            Some(Diameters { min, mean, max })
        }
        Ok((min, _, max)) => {
            fail(
                errors,
                path,
                value,
                format!(
                    "gives simulated diameters from {} to {} m; they must be finite and > 0",
                    number(min),
                    number(max)
                ),
            );
            None
        }
        Err(_) => {
            fail(
                errors,
                path,
                value,
                "gives simulated diameters (2 x radius x coarse_graining.size_factor) that are not finite numbers > 0".to_string(),
            );
            None
        }
    }
}

/// The engine's time step for particles of diameter `d_min`, or the error
/// naming the field that makes it impossible: the design impact speed when a
/// speed of 1 m/s would give a step, else the particle's Young's modulus.
fn time_step(exp: &Experiment, d_min: f64, errors: &mut Vec<FieldError>) -> Option<f64> {
    let walls: Vec<&str> = exp
        .scene
        .wall_materials()
        .into_iter()
        .map(|(_, w)| w)
        .collect();
    let contact = physics::contact_setup(exp, &walls);
    let dt_of = |e: &Experiment| {
        physics::time_step(e, &contact, 0.5 * d_min)
            .ok()
            .map(|p| p.dt_s)
            .filter(|dt| dt.is_finite() && *dt > 0.0)
    };
    if let Some(dt) = dt_of(exp) {
        return Some(dt);
    }
    let mut slower = exp.clone();
    slower.time_step.design_impact_speed_m_s = 1.0;
    let speed = exp.time_step.design_impact_speed_m_s;
    let (path, value) = if dt_of(&slower).is_some() {
        ("time_step.design_impact_speed_m_s", number(speed))
    } else {
        (
            "material.particle.youngs_modulus_pa",
            number(exp.material.particle.youngs_modulus_pa),
        )
    };
    fail(
        errors,
        path,
        value,
        format!(
            "leaves no time step: the step for the smallest particle (diameter {} m, density {} kg/m3, simulated Young's modulus {} Pa, design impact speed {} m/s) is 0 s or not finite; use physical values",
            approx(d_min),
            number(exp.material.particle.density_kg_m3),
            approx(contact.particle_material.youngs_modulus_pa),
            number(speed)
        ),
    );
    None
}

/// Twice the engine's pair-search cutoff for these particles: the shortest
/// periodic length it accepts, m.
fn periodic_minimum(exp: &Experiment, d: &Diameters) -> f64 {
    let r_max = 0.5 * d.max;
    let contact = physics::contact_setup(exp, &[]);
    // The engine bounds the reach with twice the largest radius (R* = r_max).
    let reach = match contact.normal {
        NormalChoice::Jkr => PairCoefficients::new(
            &contact.particle_material,
            &contact.particle_material,
            &contact.particle_particle,
            contact.clip_tensile,
        )
        .map_or(0.0, |c| Jkr::reach_m(&c, r_max)),
        NormalChoice::Hertz => 0.0,
    };
    2.0 * (2.0 * r_max + reach.max(0.0) + SKIN_DIAMETERS * d.mean)
}

fn check_periodic(
    exp: &Experiment,
    d: &Diameters,
    path: &str,
    slice: Option<f64>,
    errors: &mut Vec<FieldError>,
) {
    let Some(slice) = slice else { return };
    let need = periodic_minimum(exp, d);
    if need.is_nan() || slice < need {
        fail(
            errors,
            path,
            number(slice),
            format!(
                "must be >= {} m, twice the neighbour-search cutoff for particles of simulated diameter up to {} m (2 r_max + cohesion reach + skin); use a thicker slice or smaller particles",
                approx(need),
                approx(d.max)
            ),
        );
    }
}

/// Requires the largest particle (with the scene's clearance on both sides) to
/// fit `room` (m), an extent of the region it is placed in or an opening.
fn check_fits(
    exp: &Experiment,
    d: &Diameters,
    room: f64,
    what: &str,
    errors: &mut Vec<FieldError>,
) {
    let need = d.max + 2.0 * CLEARANCE_DIAMETERS * d.mean;
    if room.is_finite() && (need.is_nan() || need >= room) {
        let (path, value) = largest_size_field(exp);
        fail(
            errors,
            path,
            value,
            format!(
                "the largest simulated particle (diameter {} m) must be smaller than {what} ({} m)",
                approx(d.max),
                approx(room)
            ),
        );
    }
}

/// A manifest field and its value as the error shows it.
type Named<'a> = (&'a str, String);

/// Requires a count of at least one particle and at most the engine's limit.
/// Too few names `amount` (the field that sets how much is filled); too many
/// names `size` when given (the geometry that holds them: a drum of diameter
/// 1e308 is wrong, not its fill fraction), else `amount`.
fn check_count(
    count: f64,
    amount: Named<'_>,
    size: Option<Named<'_>>,
    how: &str,
    errors: &mut Vec<FieldError>,
) {
    if count.is_nan() || count < 0.5 {
        let (path, value) = amount;
        fail(
            errors,
            path,
            value,
            format!(
                "gives {} particles ({how}); the scene needs at least one: raise it or use smaller particles",
                sci(count.round())
            ),
        );
    } else if count > ENGINE_MAX_PARTICLES {
        let (path, value) = size.unwrap_or(amount);
        fail(
            errors,
            path,
            value,
            format!(
                "gives an estimated {} particles ({how}); the engine holds at most {} (32-bit particle ids)",
                sci(count),
                sci(ENGINE_MAX_PARTICLES)
            ),
        );
    }
}

/// What the protocol of a scene amounts to.
struct Shape {
    particles: f64,
    d_min: f64,
    simulated_time_s: f64,
    /// Interval between log frames, s (None: a fixed number of frames).
    sample_interval_s: Option<f64>,
}

fn estimate(exp: &Experiment, errors: &mut Vec<FieldError>) -> Option<RunPlan> {
    let shape = match &exp.scene {
        Scene::Pair(s) => Some(pair(s)),
        lab => {
            let d = diameters(exp, errors)?;
            match lab {
                Scene::Drum(s) => drum(exp, s, &d, errors),
                Scene::FunnelPile(s) => funnel(exp, s, &d, errors),
                Scene::BaffleLift(s) => baffle(exp, s, &d, errors),
                Scene::Hopper(s) => hopper(exp, s, &d, errors),
                Scene::StaticPile(s) => static_pile(exp, s, &d, errors),
                Scene::Pair(_) => None,
            }
        }
    };
    // Clumps: each grain is its member spheres, the smallest of which sets
    // the step (as in the lab set-up).
    let (members, smallest) = match physics::clump_shape(exp) {
        Ok(None) => (1.0, 1.0),
        Ok(Some(c)) => (c.members.len() as f64, c.min_member_radius_m()),
        Err(e) => {
            fail(
                errors,
                "material.particle.shape",
                String::from("the clump given"),
                e.to_string(),
            );
            return None;
        }
    };
    let dt = time_step(exp, shape.as_ref()?.d_min * smallest, errors)?;
    let mut shape = shape?;
    shape.particles *= members;
    if let Some(every) = shape.sample_interval_s {
        if every < dt {
            fail(
                errors,
                "scene.sample_interval_s",
                number(every),
                format!(
                    "must be >= the time step {dt:.4e} s (samples and log frames are taken between steps)"
                ),
            );
        }
    }
    let steps = (shape.simulated_time_s / dt).ceil();
    let frames = match shape.sample_interval_s {
        Some(every) => (steps / (every / dt).round().max(1.0)).ceil() + 4.0,
        None => (PAIR_FRAMES + 2) as f64,
    };
    let per_particle = if shape.particles > SPHERE_LIMIT as f64 {
        CLOUD_BYTES
    } else {
        SPHERE_BYTES
    };
    Some(RunPlan {
        scene: exp.scene.kind(),
        particles: shape.particles,
        dt_s: dt,
        simulated_time_s: shape.simulated_time_s,
        steps,
        particle_steps: shape.particles * steps,
        frames,
        log_bytes: LOG_FIXED_BYTES
            + frames * (FRAME_OVERHEAD_BYTES + shape.particles * per_particle),
    })
}

fn pair(s: &PairScene) -> Shape {
    let (particles, d_min) = match s.partner {
        Partner::Particle { radius_m } => (2.0, 2.0 * radius_m.min(s.radius_m)),
        Partner::Wall { .. } => (1.0, 2.0 * s.radius_m),
    };
    Shape {
        particles,
        d_min,
        simulated_time_s: s.max_time_s,
        sample_interval_s: None,
    }
}

fn drum(
    exp: &Experiment,
    s: &DrumScene,
    d: &Diameters,
    errors: &mut Vec<FieldError>,
) -> Option<Shape> {
    let r = 0.5 * s.inner_diameter_m;
    let length = s.periodic_slice_m.unwrap_or(s.length_m);
    // The scene's own count (scenes::drum::build_world).
    let volume = PI * r * r * length;
    let count =
        (s.fill_fraction * volume * super::drum::BULK_SOLID_FRACTION / d.mean_volume()).round();
    let how = format!(
        "scene.fill_fraction of the simulated drum volume {} m3 at bulk solid fraction {}, particles of simulated diameter {} m",
        approx(volume),
        super::drum::BULK_SOLID_FRACTION,
        approx(d.mean)
    );
    check_count(
        count,
        ("scene.fill_fraction", number(s.fill_fraction)),
        Some(("scene.inner_diameter_m", number(s.inner_diameter_m))),
        &how,
        errors,
    );
    // Particles are placed in the square inscribed in the cross-section.
    check_fits(
        exp,
        d,
        2.0 * r / 2f64.sqrt(),
        "the side of the square inscribed in scene.inner_diameter_m, where the drum is filled",
        errors,
    );
    match s.periodic_slice_m {
        Some(_) => check_periodic(exp, d, "scene.periodic_slice_m", s.periodic_slice_m, errors),
        None => check_fits(exp, d, s.length_m, "scene.length_m", errors),
    }
    Some(Shape {
        particles: count,
        d_min: d.min,
        simulated_time_s: s.settle_max_s + s.rotation_time_s + s.standing_time_s,
        sample_interval_s: Some(s.sample_interval_s),
    })
}

fn funnel(
    exp: &Experiment,
    s: &FunnelPileScene,
    d: &Diameters,
    errors: &mut Vec<FieldError>,
) -> Option<Shape> {
    let geom = FunnelGeometry::new(s, d.mean);
    let volume = geom.charge_region(s.fill_height()).volume();
    let count = (s.fill_fraction * volume / d.mean_volume()).round();
    let how = format!(
        "scene.fill_fraction of the charge volume {} m3 up to the fill height, particles of simulated diameter {} m",
        approx(volume),
        approx(d.mean)
    );
    check_count(
        count,
        ("scene.fill_fraction", number(s.fill_fraction)),
        Some((
            "scene.funnel_top_diameter_m",
            number(s.funnel_top_diameter_m),
        )),
        &how,
        errors,
    );
    check_fits(
        exp,
        d,
        s.funnel_outlet_diameter_m,
        "scene.funnel_outlet_diameter_m, the opening the powder must flow through",
        errors,
    );
    Some(Shape {
        particles: count,
        d_min: d.min,
        simulated_time_s: s.total_time_s,
        sample_interval_s: Some(s.sample_interval()),
    })
}

fn baffle(
    exp: &Experiment,
    s: &BaffleLiftScene,
    d: &Diameters,
    errors: &mut Vec<FieldError>,
) -> Option<Shape> {
    let width = s.periodic_slice_m.unwrap_or(s.box_width_m);
    let mass = s.powder_mass_kg * width / s.box_width_m;
    let count = (mass / (exp.material.particle.density_kg_m3 * d.mean_volume())).round();
    let how = format!(
        "{} kg placed in the simulated width, particles of simulated diameter {} m",
        approx(mass),
        approx(d.mean)
    );
    check_count(
        count,
        ("scene.powder_mass_kg", number(s.powder_mass_kg)),
        None,
        &how,
        errors,
    );
    check_fits(exp, d, s.box_length_m, "scene.box_length_m", errors);
    check_fits(exp, d, s.box_height_m, "scene.box_height_m", errors);
    match s.periodic_slice_m {
        Some(_) => check_periodic(exp, d, "scene.periodic_slice_m", s.periodic_slice_m, errors),
        None => check_fits(exp, d, s.box_width_m, "scene.box_width_m", errors),
    }
    let lift = (s.box_height_m + BAFFLE_CLEARANCE_DIAMETERS * d.mean) / s.lift_speed_m_s;
    Some(Shape {
        particles: count,
        d_min: d.min,
        simulated_time_s: s.settle_max() + lift + s.settle_time_s,
        sample_interval_s: Some(s.sample_interval()),
    })
}

fn hopper(
    exp: &Experiment,
    s: &HopperScene,
    d: &Diameters,
    errors: &mut Vec<FieldError>,
) -> Option<Shape> {
    let bed = s.fill_height_m.unwrap_or(s.height_m);
    let volume = PI / 4.0 * s.diameter_m * s.diameter_m * bed;
    let count = (s.packing_fraction * volume / d.mean_volume()).round();
    let how = format!(
        "scene.packing_fraction of the bed volume {} m3, particles of simulated diameter {} m",
        approx(volume),
        approx(d.mean)
    );
    check_count(
        count,
        ("scene.packing_fraction", number(s.packing_fraction)),
        Some(("scene.diameter_m", number(s.diameter_m))),
        &how,
        errors,
    );
    check_fits(
        exp,
        d,
        s.orifice_diameter_m,
        "scene.orifice_diameter_m, the opening the powder must flow through",
        errors,
    );
    Some(Shape {
        particles: count,
        d_min: d.min,
        simulated_time_s: s.settle_max_s.unwrap_or(DEFAULT_SETTLE_MAX_S) + s.max_time_s,
        sample_interval_s: Some(s.sample_interval_s.unwrap_or(HOPPER_SAMPLE_S)),
    })
}

fn static_pile(
    exp: &Experiment,
    s: &StaticPileScene,
    d: &Diameters,
    errors: &mut Vec<FieldError>,
) -> Option<Shape> {
    let count = s.particle_count as f64;
    check_count(
        count,
        ("scene.particle_count", s.particle_count.to_string()),
        None,
        "as stated",
        errors,
    );
    check_fits(
        exp,
        d,
        s.outlet_diameter_m,
        "scene.outlet_diameter_m, the opening the powder must flow through",
        errors,
    );
    Some(Shape {
        particles: count,
        d_min: d.min,
        simulated_time_s: pour_duration_s(s) + s.settle_time_s,
        sample_interval_s: Some(s.sample_interval_s),
    })
}
