//! The `hopper` scene: yan2015's flat-bottomed cylindrical hopper discharging
//! onto a plate (D = 50 mm, H = 70 mm, central orifice 15 mm, 70 mm above
//! the plate; ~14 700 spheres R = 1 mm poured to a solid fraction of 56.7 %).
//!
//! Geometry (`geometry`): the plate's face is z = 0 and the hopper axis is
//! the z axis. Walls: the hopper's inner cylinder and its bottom (an annulus
//! around the orifice), both of `hopper_material`; the plate, a disk of
//! `plate_diameter_m` of `plate_material`; the lid, a disk one mean diameter
//! wider than the orifice, recessed half the smallest diameter below the
//! bottom (so no particle touches bottom and lid at once, and none fits in
//! the slot between them), of `hopper_material`.
//!
//! Protocol:
//! 1. `pour`: as many particles as fill `fill_height_m` of the hopper at
//!    `packing_fraction` are placed without overlap (random sequential
//!    addition seeded by the packing seed) in the hopper's inside, loosely, at
//!    [`PLACEMENT_FRACTION`] (random addition cannot reach a poured bed's
//!    density): the placement column is taller than the bed (2.3 times for
//!    yan2015's 56.7 %) and may stand above the rim. They fall and settle
//!    (`settle`, at most `settle_max_s`, ending once the bed is at rest by
//!    the experiment's `at_rest` criterion). With EPSD rolling resistance the
//!    criterion must be looser than the default 1e-6 of m g d: EPSD's
//!    rolling spring has no damping (yan2015 Eq. 8–10), so a settled bed
//!    keeps a floor of kinetic energy — measured 2.5e-6 m g d per particle
//!    (3 mm spheres, E = 20 MPa) and 1.1e-5 m g d (E = 2 MPa) — and a lower
//!    threshold is never met (the phase then runs to `settle_max_s`). The
//!    hopper profiles state `at_rest.kinetic_energy_fraction` = 1e-4 (a mean
//!    particle moving at √(2e-4 g d), 2.4 mm/s for d = 3 mm) and a 0.05 s
//!    hold. The solid fraction of the settled bed is measured
//!    (`settled_solid_fraction`, compare with `packing_fraction`).
//! 2. Opening: particles that ended up outside the hopper while pouring are
//!    removed and counted (`spilled_during_fill`; they would otherwise count
//!    as discharged). yan2015's lid "was quickly opened"; here it falls away:
//!    the lid translates straight down (`Motion::Translate`) at
//!    2 √(g h) (h: from the lid to below the plate), fast enough that no released
//!    particle can catch it, through the plate (walls do not interact) to one
//!    diameter below it, where it parks. A sliding lid would shear the bottom
//!    layer sideways; dropping it releases the bed as removing the wall would,
//!    with the wall list unchanged (the engine's wall indices stay valid).
//! 3. `discharge`: runs until no particle has left the hopper for
//!    `no_discharge_stop_s`, or for at most `max_time_s`. A particle has left
//!    once its centre is more than its radius below the orifice plane.
//!
//! Particles that fall off the plate (centre more than one mean diameter
//! below its face or beyond its rim) are removed with `Simulation::retain`
//! at every sample, so they never reach the edge of the simulation box and
//! trip the domain-exit health check; the box leaves room for the fastest
//! particle to travel for one sample interval. They stay counted as
//! discharged (`removed_off_plate`). Every sample satisfies
//! in_hopper + below_hopper + removed = particles (traces).
//!
//! Measurements (yan2015 §3.2; `angles` and [`crate::measure`]):
//! - upper angle α (the crater left in the hopper) and bottom angle θ (the
//!   heap on the plate), each the mean of the four fits of the xz and yz
//!   ortho-slices, each fit reported with its angle, R² and number of points,
//!   and the number of fits whose R² is below [`R2_FLOOR`]; the windows are
//!   documented in the `angles` submodule. θ is the headline angle.
//!   `upper_angle_measured` and `bottom_angle_measured` are 1 or 0: an
//!   angle the final snapshot cannot show (a heap lower than three diameters,
//!   spread over the plate by slippery or bouncy particles; a crater without
//!   enough surface points) is left out with the reason in the warnings, and
//!   the run keeps everything else it measured (the other angle, the flow).
//!   A design study then misses that response at that point, not the run.
//! - discharged particles against time (trace `discharged`, from the
//!   opening) and yan2015's flow rate FR(t) = discharged by t / t at
//!   t = 1, 2, 3, 4 s after the opening ([`FLOW_RATE_TIMES_S`]), reported only
//!   for the times inside the discharge (up to the last particle leaving,
//!   `discharge_duration_s`); `flow_rate_times_covered` says how many are.
//!   A later FR(t) would only be the final count over t.
//! - the steady rate over 10–50 % of the discharge duration
//!   (`flow_rate_steady_per_s`) beside Beverloo's prediction
//!   ([`beverloo_rate_per_s`]) for the measured bed density.
//! - the mean speed in yan2015's window 20–30 mm above the orifice plane
//!   (Fig. 6a) during the discharge; the window's radius is the orifice's
//!   (the paper does not give it; the orifice radius keeps the static zone at
//!   the hopper's corners out). Trace `window_speed`.
//! - traces every `sample_interval_s`: engine state, `in_hopper`,
//!   `below_hopper`, `removed`; during the discharge also `discharged`,
//!   `window_speed`, `upper_angle`, `bottom_angle` (when measurable). The
//!   MCAP log gets a particle frame every 0.05 s of simulated time,
//!   the discharged count and θ at every sample of the discharge.
//!
//! Material (yan2015 §3.1): Hertz–Mindlin with EPSD rolling resistance; its
//! base case E = 0.02 GPa, e = 0.45, μ_s = 0.25, μ_r = 0.25 (α 31.1°,
//! θ 28.9°). The paper's Table 1 is not in the text we have; the examples
//! choose density 2500 kg/m³ (glass: with ν = 0.25 the Rayleigh time of a
//! 1 mm sphere at E = 0.02 GPa is 60 µs, and 10 % of it is the paper's stated
//! step of ~5e-6 s), ν = 0.25, steel walls, and particle–wall parameters equal
//! to the base case's particle–particle ones ("the other material properties
//! for particles and walls were kept constant"). The plate's size is not
//! given either: the examples choose 200 mm, which holds the paper's heap
//! (~13 000 discharged spheres make a cone ~54 mm in radius at 29°) clear of
//! its rim. experiments/hopper/README.md lists the profiles and what each
//! reduction costs in fidelity.

mod angles;
mod geometry;
mod sampler;

pub use angles::R2_FLOOR;

use self::geometry::{Geometry, LID_WALL};
use self::sampler::DischargeSampler;
use super::physics::STANDARD_GRAVITY_M_S2 as G_M_S2;
use super::protocol::{run_phase, Phase, Progress, SettleCriterion};
use super::resolution;
use super::skeleton::{finish, lab_error_conversions, open_log, Lab, LabError};
use super::SceneError;
use crate::dem::health::HealthLimits;
use crate::dem::simulation::World;
use crate::dem::vec3::Vec3;
use crate::manifest::scene::HopperScene;
use crate::manifest::Experiment;
use crate::measure::flow::{flow_rates, interval_rate, DischargeSample};
use crate::measure::series::mean_std;
use crate::measure::MeasureError;
use crate::packing::distribution::SizeDistribution;
use crate::packing::place::{place_random, FillTarget, Placement, PlacementSpec};
use crate::packing::PackingError;
use crate::store::{RunResult, Trace, HEADLINE_KEY};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

/// Solid fraction at which the pour is placed (random sequential addition
/// saturates near 0.38, and slows sharply before; the wall exclusion makes
/// the effective fraction ~10 % higher than this nominal one).
pub const PLACEMENT_FRACTION: f64 = 0.25;
/// Default longest settling time of the poured bed, s.
pub const DEFAULT_SETTLE_MAX_S: f64 = 1.0;
/// Default sample interval, s.
pub const DEFAULT_SAMPLE_INTERVAL_S: f64 = 0.01;
/// yan2015's flow-rate times after the opening, s.
pub const FLOW_RATE_TIMES_S: [f64; 4] = [1.0, 2.0, 3.0, 4.0];
/// Part of the discharge (fractions of its duration) over which the steady
/// rate is taken: after the start transient, before the flow from the sides
/// slows it (yan2015 Fig. 4: constant rate for the first ~60 %).
pub const STEADY_WINDOW: (f64, f64) = (0.1, 0.5);
/// Beverloo's discharge coefficient C (Beverloo, Leniger & van de Velde 1961,
/// Chem. Eng. Sci. 15:260; Nedderman's review gives 0.55–0.65, 0.58 typical).
pub const BEVERLOO_C: f64 = 0.58;
/// Beverloo's empty-annulus coefficient k (same sources: 1.3–2.9, 1.5 for
/// spheres).
pub const BEVERLOO_K: f64 = 1.5;

/// Why a hopper run failed.
#[derive(Debug, thiserror::Error)]
pub enum HopperError {
    /// What any lab scene can fail at ([`LabError`]).
    #[error(transparent)]
    Lab(LabError),
    /// The discharge trace could not be evaluated.
    #[error("hopper discharge: {0}")]
    Discharge(MeasureError),
}

lab_error_conversions!(HopperError, "hopper");

/// Beverloo's discharge rate of a flat-bottomed orifice, particles per
/// second: W = C ρ_b √g (D_o − k d)^{5/2} (kg/s) over the particle mass
/// ρ π d³/6, ρ_b = `solid_fraction` · ρ (so ρ cancels). 0 when D_o ≤ k d.
pub fn beverloo_rate_per_s(solid_fraction: f64, orifice_m: f64, diameter_m: f64) -> f64 {
    let free = (orifice_m - BEVERLOO_K * diameter_m).max(0.0);
    BEVERLOO_C * solid_fraction * G_M_S2.sqrt() * free.powf(2.5) / (PI / 6.0 * diameter_m.powi(3))
}

/// Runs a `hopper` experiment (see the module docs); with `log`, writes its
/// MCAP log there.
pub fn run(
    exp: &Experiment,
    scene: &HopperScene,
    log: Option<&Path>,
) -> Result<RunResult, SceneError> {
    let walls = [
        scene.hopper_material.as_str(),
        scene.plate_material.as_str(),
    ];
    let lab = Lab::new(exp, &walls, |e| SceneError::Hopper(e.into()))?;
    run_hopper(exp, scene, &lab, log).map_err(SceneError::Hopper)
}

fn run_hopper(
    exp: &Experiment,
    scene: &HopperScene,
    lab: &Lab,
    log: Option<&Path>,
) -> Result<RunResult, HopperError> {
    let (d_min, d_mean) = (lab.d_min_m, lab.d_mean_m);
    let geo = Geometry::new(scene, d_mean, d_min);
    let every = scene.sample_interval_s.unwrap_or(DEFAULT_SAMPLE_INTERVAL_S);
    let fill_height = scene.fill_height_m.unwrap_or(scene.height_m);

    let (placed, top_z) = pour(exp, scene, &geo, &lab.sizes, fill_height)?;
    let inserted = placed.particles.len();
    let world = lab
        .grains
        .world(&placed.particles, geo.walls()?, geo.domain(top_z, every)?)?;
    let mut sim = lab.simulation(world, HealthLimits::default())?;

    let speed_scale_m_s = (2.0 * G_M_S2 * scene.drop_height_m).sqrt();
    let mut log_file = open_log(log, exp, speed_scale_m_s)?;
    let mut sampler = DischargeSampler::new(geo, scene.no_discharge_stop_s, log_file.as_mut());
    let mut progress = Progress::on_stderr();
    let mass = lab.mean_particle_mass_kg();
    let dt = lab.plan.dt_s;
    let settle = Phase {
        name: "settle",
        max_duration_s: scene.settle_max_s.unwrap_or(DEFAULT_SETTLE_MAX_S),
        settle: Some(SettleCriterion::at_rest(&exp.at_rest, mass, d_mean)),
    };
    let settled = run_phase(&mut sim, &settle, dt, every, &mut sampler, &mut progress)?;
    let solid_fraction = bed_solid_fraction(sim.world(), &geo, fill_height);

    let spilled = sampler.open(&mut sim)?;
    let t_open = sim.world().time_s;
    sim.set_wall_motion(LID_WALL, geo.lid_opening(t_open))?;
    let discharge = Phase {
        name: "discharge",
        max_duration_s: scene.max_time_s,
        settle: None,
    };
    let ended = run_phase(&mut sim, &discharge, dt, every, &mut sampler, &mut progress)?;

    let w = sim.world();
    let p = &w.particles;
    let alpha = angles::upper_angle(&p.position, &p.radius, &geo);
    let theta = angles::bottom_angle(&p.position, &p.radius, &geo);
    let census = sampler.census(&sim);
    let removed = sampler.removed();
    let last_discharge = sampler.last_discharge_s();
    let samples = sampler.discharge().to_vec();
    let traces = sampler.into_traces();

    let mut result = finish(
        exp,
        &sim,
        &lab.plan,
        traces,
        log_file,
        inserted,
        settled.settled,
    )?;
    result.warnings.extend(lab.grains.warnings());
    let mut put = |k: &str, v: f64| {
        result.measurements.insert(k.to_string(), v);
    };
    put("spilled_during_fill", spilled as f64);
    put("lid_open_s", t_open);
    if let Some(phi) = solid_fraction {
        put("settled_solid_fraction", phi);
    }
    put(
        "stopped_without_discharge",
        f64::from(u8::from(ended.settled)),
    );
    put("remaining_in_hopper", census.hopper as f64);
    put("on_plate", census.below as f64);
    put("removed_off_plate", (removed - spilled) as f64);
    put("discharged", (census.below + removed - spilled) as f64);
    for (k, v) in flow_measurements(&samples, &result.traces, t_open, last_discharge)
        .map_err(HopperError::Discharge)?
    {
        put(&k, v);
    }
    put(
        "beverloo_flow_rate_per_s",
        beverloo_rate_per_s(
            solid_fraction.unwrap_or(scene.packing_fraction),
            scene.orifice_diameter_m,
            d_mean,
        ),
    );
    put("angle_fit_r2_floor", R2_FLOOR);
    for (name, which, angle) in [
        (
            "upper_angle",
            "upper angle α (the crater in the hopper)",
            &alpha,
        ),
        (
            "bottom_angle",
            "bottom angle θ (the heap on the plate)",
            &theta,
        ),
    ] {
        result.measurements.insert(
            format!("{name}_measured"),
            f64::from(u8::from(angle.is_ok())),
        );
        match angle {
            Ok(a) => angles::record(&mut result.measurements, name, a),
            Err(e) => {
                let why = format!("{which} {e}");
                if name == "bottom_angle" {
                    result.unmeasured.insert(HEADLINE_KEY.into(), why.clone());
                }
                result.unmeasured.insert(format!("{name}_deg"), why);
            }
        }
    }
    result.headline_angle_deg = theta.as_ref().ok().map(|t| t.mean_deg);
    let orifice = scene.orifice_diameter_m / d_mean;
    resolution::at_least(
        &mut result,
        "orifice_diameters",
        orifice,
        resolution::ORIFICE_MIN,
    );
    resolution::record(
        &mut result,
        "beverloo_orifice_diameters",
        orifice - BEVERLOO_K,
        None,
        None,
    );
    Ok(result)
}

/// The discharge's measurements from the discharge trace (opening at
/// `t_open_s`, last particle out at `last_s`) and the `window_speed` trace:
/// its duration, yan2015's FR(t) at the covered [`FLOW_RATE_TIMES_S`], the
/// steady rate over [`STEADY_WINDOW`] and the mean window speed.
fn flow_measurements(
    samples: &[DischargeSample],
    traces: &BTreeMap<String, Trace>,
    t_open_s: f64,
    last_s: f64,
) -> Result<Vec<(String, f64)>, MeasureError> {
    let duration = last_s - t_open_s;
    let mut out = vec![("discharge_duration_s".to_string(), duration)];
    let covered: Vec<f64> = FLOW_RATE_TIMES_S
        .into_iter()
        .filter(|&t| t <= duration)
        .collect();
    out.push(("flow_rate_times_covered".into(), covered.len() as f64));
    for r in flow_rates(samples, t_open_s, &covered)? {
        out.push((format!("flow_rate_{}s_per_s", r.t_s), r.rate_per_s));
    }
    if duration > 0.0 {
        let window = (
            t_open_s + STEADY_WINDOW.0 * duration,
            t_open_s + STEADY_WINDOW.1 * duration,
        );
        out.push((
            "flow_rate_steady_per_s".into(),
            interval_rate(samples, window)?,
        ));
    }
    if let Some(s) = window_speed(traces, t_open_s, last_s) {
        out.push(("window_speed_mean_m_s".into(), s.mean));
        out.push(("window_speed_std_m_s".into(), s.std));
        out.push(("window_speed_samples".into(), s.n as f64));
    }
    Ok(out)
}

/// Places the pour: `packing_fraction` of a `fill_height`-tall bed's volume,
/// spread at [`PLACEMENT_FRACTION`] over a taller column of the hopper's
/// inside. Returns the placement and the highest possible centre, m.
fn pour(
    exp: &Experiment,
    scene: &HopperScene,
    geo: &Geometry,
    sizes: &SizeDistribution,
    fill_height: f64,
) -> Result<(Placement, f64), PackingError> {
    let column = fill_height * (scene.packing_fraction / PLACEMENT_FRACTION).max(1.0);
    let spec = PlacementSpec {
        region: geo.fill_region(column),
        sizes: sizes.clone(),
        target: FillTarget::FillFraction(scene.packing_fraction * fill_height / column),
        seed: exp.seeds.packing_seed,
        clearance_m: 0.05 * geo.d_mean,
        velocity_m_s: Vec3::zeros(),
    };
    Ok((place_random(&spec)?, geo.bottom_z + column))
}

/// Solid fraction of the settled bed: the volume of the spheres whose centres
/// lie between two diameters above the bottom and 70 % of the nominal fill
/// height, inside the hopper, over that slice's volume (sphere parts that
/// cross the slice's faces even out on average). None for a bed too shallow
/// to have such a slice.
fn bed_solid_fraction(w: &World, g: &Geometry, fill_height: f64) -> Option<f64> {
    let (lo, hi) = (g.bottom_z + 2.0 * g.d_mean, g.bottom_z + 0.7 * fill_height);
    if hi <= lo {
        return None;
    }
    let p = &w.particles;
    let solid: f64 = p
        .position
        .iter()
        .zip(&p.radius)
        .filter(|(x, _)| x.z >= lo && x.z < hi && x.x.hypot(x.y) < g.hopper_radius)
        .map(|(_, r)| 4.0 / 3.0 * PI * r.powi(3))
        .sum();
    Some(solid / (PI * g.hopper_radius.powi(2) * (hi - lo)))
}

/// Mean and standard deviation of the `window_speed` trace between the
/// opening and the last discharge (None when the window never held a
/// particle then, e.g. a bed lower than the window).
fn window_speed(
    traces: &BTreeMap<String, Trace>,
    from_s: f64,
    to_s: f64,
) -> Option<crate::measure::series::MeanStd> {
    let t = traces.get("window_speed")?;
    let inside: Vec<f64> = t
        .time_s
        .iter()
        .zip(&t.values)
        .filter(|(&ts, _)| ts >= from_s && ts <= to_s)
        .map(|(_, &v)| v)
        .collect();
    mean_std(&inside).ok()
}
