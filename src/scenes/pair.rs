//! The `pair` scene: two particles, or a particle and a flat wall, colliding
//! at a given normal and tangential speed and spin, or an adhered pair pulled
//! apart quasi-statically. Users check their contact parameters with it; the
//! physics tests validate the engine with it against Hertz, restitution,
//! Chung & Ooi (2011) oblique impacts and JKR pull-off.
//!
//! Geometry: the partner (a particle at the origin, or the plane z = 0 with
//! normal +z) sits below; the moving particle starts a hair (1 % of its
//! radius) above contact and moves along −z with `normal_velocity_m_s` and
//! along +x with `tangential_velocity_m_s`. Gravity (−z, 9.81 m/s²) only if
//! asked. Contact start and end are found by linear interpolation of the
//! overlap between steps, so the duration is resolved below one step.
//!
//! Separation: the moving particle starts pressed in by 0.1 % of its radius
//! and then moves at exactly the pull speed along +z, the partner particle
//! stays at rest: both have prescribed kinematics
//! ([`Simulation::prescribe`]: never kicked, so the damping sees the
//! prescribed velocities, yet they drift and receive the contact force). The
//! force is therefore evaluated at the prescribed separation whatever the
//! step. (Resetting position and velocity before each step instead let the
//! step's own half kick and drift move the particles under the adhesive
//! force, and the engine's damping saw a held particle moving: the measured
//! pull-off fell with the step, to 0.95 × 3πΓR* at 0.2 T_R against
//! 0.99 × at 0.05 T_R for R 0.5 mm, Γ 0.2 J/m², E 50 MPa, e 0.5.) The
//! pull-off is the largest tensile normal force on the moving particle
//! read after each step.
//!
//! The step comes from the manifest's `time_step` settings, not from the
//! impact speed: an impact faster than the design speed is simulated with
//! the step it gets. If that step carries the sphere past its partner the
//! engine stops the run as tunnelling; if it resolves the contact with too
//! few steps, result.json carries the warning (see
//! [`crate::dem::timestep`]). The engine's measured approach speed is
//! [`PairMeasurements::max_approach_speed_m_s`].

use super::physics::STANDARD_GRAVITY_M_S2;
use super::{physics, SceneError};
use crate::dem::contact::normal_jkr::{pull_off_force_n, separation_overlap_m};
use crate::dem::contact::{PairCoefficients, ParameterError};
use crate::dem::domain::{Domain, DomainError};
use crate::dem::health::{HealthError, HealthLimits};
use crate::dem::material::{harmonic, hertz_contact_time_s, hertz_max_overlap_m};
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::simulation::{ContactSetup, SetupError, Simulation, SimulationSetup, World};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{Wall, WallError};
use crate::log::{FrameSchedule, LogError, LogOptions, Recorder, RunLog};
use crate::manifest::scene::{PairMode as ManifestPairMode, PairScene, Partner as ManifestPartner};
use crate::manifest::Experiment;
use crate::store::RunResult;
use std::path::Path;

/// Frames a pair run logs over its expected duration (approach plus elastic
/// Hertz contact time, or the pull-off travel): every k-th step with
/// k = expected steps / this (at least 1). Longer runs (captured particles)
/// thin out by [`FrameSchedule`]'s doubling.
pub const PAIR_FRAMES: u64 = 200;

/// What the moving particle meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Partner {
    /// A free particle of this radius (m), initially at rest.
    Particle {
        /// Partner radius, m.
        radius_m: f64,
    },
    /// The flat wall z = 0 made of wall material 0 of the contact setup.
    Wall,
}

/// What the test does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairMode {
    /// A free collision.
    Impact,
    /// The particle is pressed into contact, then pulled straight off at
    /// `pull_speed_m_s` (prescribed kinematics); the partner particle is held
    /// (see the module docs).
    Separation {
        /// Pull speed, m/s.
        pull_speed_m_s: f64,
    },
}

/// A fully specified pair test.
#[derive(Clone, Debug)]
pub struct PairTest {
    /// Contact physics (wall material 0 is the wall partner's).
    pub contact: ContactSetup,
    /// Particle density, kg/m³.
    pub density_kg_m3: f64,
    /// Radius of the moving particle, m.
    pub radius_m: f64,
    /// The partner.
    pub partner: Partner,
    /// Approach speed along the normal, m/s (≥ 0).
    pub normal_velocity_m_s: f64,
    /// Tangential speed along +x, m/s.
    pub tangential_velocity_m_s: f64,
    /// Initial angular velocity of the moving particle, rad/s.
    pub angular_velocity_rad_s: Vec3,
    /// Gravity along −z.
    pub gravity: bool,
    /// Impact or separation.
    pub mode: PairMode,
    /// Time step, s.
    pub dt_s: f64,
    /// Give up after this much simulated time, s.
    pub max_time_s: f64,
    /// Verlet skin, m (the manifest runner uses 5 % of the radius; tests use
    /// a tiny skin to force a neighbour rebuild nearly every step).
    pub skin_m: f64,
}

/// What a pair test measured (the `measurements` of result.json).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairMeasurements {
    /// Duration of the (first) contact, s (interpolated).
    pub contact_duration_s: f64,
    /// Largest overlap, m.
    pub max_overlap_m: f64,
    /// Largest repulsive normal contact force, N.
    pub max_normal_force_n: f64,
    /// Normal restitution: −(relative normal velocity after)/(before).
    pub restitution: f64,
    /// Relative normal velocity after contact (positive = separating), m/s.
    pub rebound_normal_velocity_m_s: f64,
    /// Relative tangential velocity of the centres after contact along +x, m/s.
    pub rebound_tangential_velocity_m_s: f64,
    /// Moving particle's spin after contact about n × x̂ (= +y), rad/s; positive
    /// is the sense friction drives in a +x impact.
    pub rebound_angular_velocity_rad_s: f64,
    /// Largest tensile contact force during separation, N (separation mode).
    pub pull_off_force_n: Option<f64>,
    /// Overlap at the end of the run, m: the resting overlap of a captured
    /// (e.g. adhered) pair.
    pub final_overlap_m: f64,
    /// The contact had not ended by `max_time_s` (the particle was captured,
    /// e.g. e → 0 or adhesion): duration and rebound are those at that time.
    pub captured: bool,
    /// Steps simulated.
    pub steps: u64,
    /// Neighbour-list rebuilds during the run.
    pub rebuilds: u64,
    /// Largest relative normal approach speed of a contact that the engine
    /// measured ([`StepStats::max_approach_speed_m_s`](crate::dem::simulation::StepStats::max_approach_speed_m_s)), m/s.
    pub max_approach_speed_m_s: f64,
}

/// Why a pair test failed.
#[derive(Debug, thiserror::Error)]
pub enum PairError {
    /// The scene geometry is invalid.
    #[error("pair scene: {0}")]
    Domain(#[from] DomainError),
    /// The wall could not be built.
    #[error("pair scene wall: {0}")]
    Wall(#[from] WallError),
    /// The engine refused the setup.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The simulation became unhealthy.
    #[error(transparent)]
    Health(#[from] HealthError),
    /// The contact did not end within `max_time_s`.
    #[error("pair scene: the contact did not end within max_time_s = {0} s")]
    Timeout(f64),
    /// The run log could not be written.
    #[error(transparent)]
    Log(#[from] LogError),
}

/// Stable ids of the moving particle and the partner particle (indices change
/// when the engine re-sorts particles by cell).
const MOVING_ID: u32 = 0;
const PARTNER_ID: u32 = 1;

/// Current index of the particle with stable id `id`.
fn index_of(p: &Particles, id: u32) -> usize {
    p.id.iter()
        .position(|&i| i == id)
        .expect("pair scene particles are never removed")
}

/// Runs the test and measures it. Returns the measurements and the kernel name.
pub fn run_pair(test: &PairTest) -> Result<(PairMeasurements, String), PairError> {
    run_pair_logged(test, None)
}

/// [`run_pair`], logging [`PAIR_FRAMES`] frames (particles, wall, engine
/// traces) over the expected duration into `log` when given; the initial and
/// final states are always frames.
pub fn run_pair_logged(
    test: &PairTest,
    log: Option<&mut RunLog>,
) -> Result<(PairMeasurements, String), PairError> {
    let r = test.radius_m;
    let (partner_r, walls) = match test.partner {
        Partner::Particle { radius_m } => (radius_m, vec![]),
        Partner::Wall => (0.0, vec![Wall::plane(Vec3::zeros(), Vec3::z(), 0)?]),
    };
    let reach = jkr_reach(test);
    let start_gap = 0.01 * r;
    let z0 = match test.partner {
        Partner::Particle { .. } => r + partner_r + start_gap,
        Partner::Wall => r + start_gap,
    };
    let separating = matches!(test.mode, PairMode::Separation { .. });
    let travel = test.max_time_s * (test.normal_velocity_m_s + test.tangential_velocity_m_s + 1.0);
    let span = 4.0 * (r + partner_r) + travel + 2.0 * reach;
    let domain = Domain::new(
        Vec3::new(-span, -span, -span),
        Vec3::new(span, span, span),
        [false; 3],
    )?;
    let mut particles = Particles::default();
    let approach = if separating {
        0.0
    } else {
        test.normal_velocity_m_s
    };
    particles.push(
        &ParticleInit {
            position: Vec3::new(
                0.0,
                0.0,
                if separating {
                    z0 - start_gap - 1e-3 * r
                } else {
                    z0
                },
            ),
            velocity: Vec3::new(test.tangential_velocity_m_s, 0.0, -approach),
            angular_velocity: test.angular_velocity_rad_s,
            radius_m: r,
        },
        test.density_kg_m3,
    );
    if let Partner::Particle { radius_m } = test.partner {
        particles.push(
            &ParticleInit {
                position: Vec3::zeros(),
                velocity: Vec3::zeros(),
                angular_velocity: Vec3::zeros(),
                radius_m,
            },
            test.density_kg_m3,
        );
    }
    let world = World::new(particles, walls, domain);
    let setup = SimulationSetup {
        contact: test.contact.clone(),
        density_kg_m3: test.density_kg_m3,
        gravity_m_s2: test
            .gravity
            .then(|| Vec3::new(0.0, 0.0, -STANDARD_GRAVITY_M_S2)),
        dt_s: test.dt_s,
        skin_m: test.skin_m,
        health: HealthLimits::default(),
    };
    let mut sim = Simulation::new(world, &setup)?;
    let kernel = sim.kernel_name();
    let expected_steps = (expected_duration_s(test, reach) / test.dt_s).ceil() as u64;
    let mut rec =
        log.map(|log| Recorder::new(log, FrameSchedule::new(expected_steps, PAIR_FRAMES)));
    if let Some(r) = rec.as_mut() {
        r.step(&sim)?;
    }
    let m = match test.mode {
        PairMode::Impact => measure_impact(&mut sim, test, partner_r, &mut rec)?,
        PairMode::Separation { pull_speed_m_s } => {
            measure_separation(&mut sim, test, pull_speed_m_s, &mut rec)?
        }
    };
    if let Some(r) = rec {
        r.finish(&sim)?;
    }
    Ok((m, kernel))
}

/// How long the test should take (s): the approach over the start gap plus the
/// elastic Hertz contact time for an impact; the pull-off travel (pre-load plus
/// JKR reach) for a separation; `max_time_s` if that is not finite and positive.
fn expected_duration_s(test: &PairTest, reach: f64) -> f64 {
    let r = test.radius_m;
    let t = match test.mode {
        PairMode::Impact => {
            let v = test.normal_velocity_m_s;
            effective_pair(test).map_or(f64::NAN, |(m_star, r_star, coef)| {
                0.01 * r / v + hertz_contact_time_s(m_star, r_star, coef.e_star, v)
            })
        }
        PairMode::Separation { pull_speed_m_s } => (1e-3 * r + reach) / pull_speed_m_s,
    };
    if t.is_finite() && t > 0.0 {
        t.min(test.max_time_s)
    } else {
        test.max_time_s
    }
}

/// Records after a step when a recorder is given.
fn record(rec: &mut Option<Recorder<'_>>, sim: &Simulation) -> Result<(), LogError> {
    match rec {
        Some(r) => r.step(sim),
        None => Ok(()),
    }
}

/// Extra separation (m) over which a JKR contact of this test stays alive
/// (0 when the parameters are invalid: the engine then reports them).
fn jkr_reach(test: &PairTest) -> f64 {
    effective_pair(test)
        .map(|(_, r_star, coef)| -separation_overlap_m(&coef, r_star))
        .unwrap_or(0.0)
}

/// Overlap (m), unit normal (partner → moving particle) and the relative velocity.
fn contact_state(p: &Particles, partner_r: f64, wall: bool) -> (f64, Vec3, Vec3) {
    let i = index_of(p, MOVING_ID);
    if wall {
        let x = p.position[i];
        (p.radius[i] - x.z, Vec3::z(), p.velocity[i])
    } else {
        let j = index_of(p, PARTNER_ID);
        let d = p.position[i] - p.position[j];
        let dist = d.norm();
        (
            p.radius[i] + partner_r - dist,
            d / dist,
            p.velocity[i] - p.velocity[j],
        )
    }
}

fn in_contact(sim: &Simulation) -> bool {
    let s = sim.stats();
    s.contacts + s.wall_contacts > 0
}

fn measure_impact(
    sim: &mut Simulation,
    test: &PairTest,
    partner_r: f64,
    rec: &mut Option<Recorder<'_>>,
) -> Result<PairMeasurements, PairError> {
    let wall = test.partner == Partner::Wall;
    let dt = test.dt_s;
    let max_steps = (test.max_time_s / dt).ceil() as u64;
    let gravity_force = if test.gravity {
        let p = &sim.world().particles;
        p.mass[index_of(p, MOVING_ID)] * STANDARD_GRAVITY_M_S2
    } else {
        0.0
    };
    let (mut prev_overlap, _, _) = contact_state(&sim.world().particles, partner_r, wall);
    let mut m = PairMeasurements::default();
    let (mut start, mut end) = (None, None);
    let mut touched = false;
    let mut approach_n = 0.0;
    while m.steps < max_steps {
        let (_, n_before, v_before) = contact_state(&sim.world().particles, partner_r, wall);
        sim.advance(1)?;
        m.steps += 1;
        record(rec, sim)?;
        let p = &sim.world().particles;
        let (overlap, n, _) = contact_state(p, partner_r, wall);
        let t = sim.world().time_s;
        if start.is_none() && overlap > 0.0 {
            approach_n = v_before.dot(&n_before);
            start = Some(t - dt * overlap / (overlap - prev_overlap));
        }
        if start.is_some() && end.is_none() && overlap <= 0.0 && prev_overlap > 0.0 {
            end = Some(t - dt * overlap / (overlap - prev_overlap));
        }
        if start.is_some() {
            m.max_overlap_m = m.max_overlap_m.max(overlap);
            let normal_force = p.force[index_of(p, MOVING_ID)].dot(&n) + gravity_force * n.z;
            m.max_normal_force_n = m.max_normal_force_n.max(normal_force);
        }
        prev_overlap = overlap;
        touched |= in_contact(sim);
        if touched && !in_contact(sim) && end.is_some() {
            break;
        }
    }
    let Some(start) = start else {
        return Err(PairError::Timeout(test.max_time_s));
    };
    // A contact still closed at max_time_s captured the particle (e → 0):
    // its duration is the time observed and its rebound the current motion.
    m.captured = in_contact(sim) || end.is_none();
    let end = end.filter(|_| !m.captured).unwrap_or(sim.world().time_s);
    let p = &sim.world().particles;
    m.rebuilds = sim.stats().rebuilds;
    m.max_approach_speed_m_s = sim.stats().max_approach_speed_m_s;
    let (final_overlap, n, v) = contact_state(p, partner_r, wall);
    m.final_overlap_m = final_overlap;
    m.contact_duration_s = end - start;
    m.rebound_normal_velocity_m_s = v.dot(&n);
    m.restitution = -m.rebound_normal_velocity_m_s / approach_n;
    m.rebound_tangential_velocity_m_s = v.x;
    m.rebound_angular_velocity_rad_s =
        p.angular_velocity[index_of(p, MOVING_ID)].dot(&n.cross(&Vec3::x()));
    Ok(m)
}

/// Pulls the pre-loaded pair apart with prescribed kinematics (see the
/// module docs) and returns the largest tensile normal force on the moving
/// particle, read after each step, once the contact has broken.
fn measure_separation(
    sim: &mut Simulation,
    test: &PairTest,
    pull_speed: f64,
    rec: &mut Option<Recorder<'_>>,
) -> Result<PairMeasurements, PairError> {
    let max_steps = (test.max_time_s / test.dt_s).ceil() as u64;
    // Set once: the moving particle at the pull velocity, the partner
    // particle at rest (Simulation::new's force evaluation kicked both), and
    // the engine never kicks them again (a wall partner has no particle: its
    // id is then ignored).
    let p = sim.particles_mut();
    for i in 0..p.len() {
        let speed = if p.id[i] == MOVING_ID {
            pull_speed
        } else {
            0.0
        };
        p.velocity[i] = Vec3::new(0.0, 0.0, speed);
        p.angular_velocity[i] = Vec3::zeros();
    }
    sim.prescribe(&[MOVING_ID, PARTNER_ID]);
    let mut m = PairMeasurements::default();
    let mut tension: f64 = 0.0;
    while m.steps < max_steps {
        sim.advance(1)?;
        m.steps += 1;
        record(rec, sim)?;
        let p = &sim.world().particles;
        let f = p.force[index_of(p, MOVING_ID)].z;
        tension = tension.max(-f);
        if m.steps > 1 && !in_contact(sim) {
            m.rebuilds = sim.stats().rebuilds;
            m.max_approach_speed_m_s = sim.stats().max_approach_speed_m_s;
            m.pull_off_force_n = Some(tension);
            m.contact_duration_s = sim.world().time_s;
            return Ok(m);
        }
    }
    Err(PairError::Timeout(test.max_time_s))
}

/// Runs a `pair` experiment: the manifest's materials and contact model, the
/// automatic time step from its `time_step` settings, and the measurements
/// named as in result.json, with the closed-form references beside them
/// (`theory_*`: elastic Hertz duration and maximum overlap at the approach
/// speed; JKR pull-off 3πΓR*). With `log`, the run's MCAP log is written
/// there (see [`run_pair_logged`]), particles coloured red at the largest
/// initial speed.
pub fn run(
    exp: &Experiment,
    scene: &PairScene,
    log: Option<&Path>,
) -> Result<RunResult, SceneError> {
    let (partner, walls): (Partner, Vec<&str>) = match &scene.partner {
        ManifestPartner::Particle { radius_m } => (
            Partner::Particle {
                radius_m: *radius_m,
            },
            vec![],
        ),
        ManifestPartner::Wall { material } => (Partner::Wall, vec![material.as_str()]),
    };
    let contact = physics::contact_setup(exp, &walls);
    let min_radius = match partner {
        Partner::Particle { radius_m } => radius_m.min(scene.radius_m),
        Partner::Wall => scene.radius_m,
    };
    let plan = physics::time_step(exp, &contact, min_radius)?;
    let test = PairTest {
        contact,
        density_kg_m3: exp.material.particle.density_kg_m3,
        radius_m: scene.radius_m,
        partner,
        normal_velocity_m_s: scene.normal_velocity_m_s,
        tangential_velocity_m_s: scene.tangential_velocity_m_s,
        angular_velocity_rad_s: Vec3::from(scene.angular_velocity_rad_s),
        gravity: scene.gravity,
        mode: match scene.mode {
            ManifestPairMode::Impact => PairMode::Impact,
            ManifestPairMode::Separation => PairMode::Separation {
                pull_speed_m_s: scene.pull_speed_m_s.unwrap_or(1e-4),
            },
        },
        dt_s: plan.dt_s,
        max_time_s: scene.max_time_s,
        skin_m: 0.05 * scene.radius_m,
    };
    let (m, kernel) = match log {
        Some(path) => {
            let speed = [
                test.normal_velocity_m_s,
                test.tangential_velocity_m_s.abs(),
                scene.pull_speed_m_s.unwrap_or(0.0),
            ]
            .into_iter()
            .fold(0.0, f64::max);
            let options = LogOptions {
                speed_scale_m_s: if speed > 0.0 { speed } else { 1.0 },
                ..LogOptions::default()
            };
            let mut log = RunLog::create(path, exp, options)?;
            let done = run_pair_logged(&test, Some(&mut log))?;
            log.finish()?;
            done
        }
        None => run_pair(&test)?,
    };
    let mut result = RunResult::new(exp, kernel);
    result.warnings = physics::time_step_warnings(&plan, m.max_approach_speed_m_s);
    let mut put = |k: &str, v: f64| {
        result.measurements.insert(k.to_string(), v);
    };
    put("dt_s", plan.dt_s);
    put("steps", m.steps as f64);
    put("contact_duration_s", m.contact_duration_s);
    put("max_overlap_m", m.max_overlap_m);
    put("max_normal_force_n", m.max_normal_force_n);
    // run_pair has just simulated with these very parameters, so they mix.
    let (m_star, r_star, coef) = effective_pair(&test).expect("parameters the engine accepted");
    if let Some(f) = m.pull_off_force_n {
        put("pull_off_force_n", f);
        put("theory_pull_off_force_n", pull_off_force_n(&coef, r_star));
    } else {
        put("captured", f64::from(u8::from(m.captured)));
        put("final_overlap_m", m.final_overlap_m);
        put("restitution", m.restitution);
        put("rebound_normal_velocity_m_s", m.rebound_normal_velocity_m_s);
        put(
            "rebound_tangential_velocity_m_s",
            m.rebound_tangential_velocity_m_s,
        );
        put(
            "rebound_angular_velocity_rad_s",
            m.rebound_angular_velocity_rad_s,
        );
        let v = scene.normal_velocity_m_s;
        put(
            "theory_hertz_contact_duration_s",
            hertz_contact_time_s(m_star, r_star, coef.e_star, v),
        );
        put(
            "theory_hertz_max_overlap_m",
            hertz_max_overlap_m(m_star, r_star, coef.e_star, v),
        );
    }
    Ok(result)
}

/// m*, R* and the mixed coefficients of the test's contact.
fn effective_pair(test: &PairTest) -> Result<(f64, f64, PairCoefficients), ParameterError> {
    let c = &test.contact;
    let mass = |r: f64| test.density_kg_m3 * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let (partner_material, params, m_star, r_star) = match test.partner {
        Partner::Particle { radius_m } => (
            c.particle_material,
            c.particle_particle,
            harmonic(mass(test.radius_m), mass(radius_m)),
            harmonic(test.radius_m, radius_m),
        ),
        Partner::Wall => {
            let Some(&(material, params)) = c.wall_materials.first() else {
                return Err(ParameterError {
                    name: "wall_materials",
                    value: 0.0,
                    allowed: "a wall partner needs wall material 0",
                });
            };
            (material, params, mass(test.radius_m), test.radius_m)
        }
    };
    let coef = PairCoefficients::new(
        &c.particle_material,
        &partner_material,
        &params,
        c.clip_tensile,
    )?;
    Ok((m_star, r_star, coef))
}
