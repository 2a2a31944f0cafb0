//! The skeleton every lab scene (funnel_pile, baffle_lift, drum, hopper,
//! static_pile) shares: the set-up from the experiment (contact physics, size
//! distribution, diameters, time step, the simulation's settings), the
//! opening of the run log, and the finish that closes the log and starts the
//! result with the measurements every lab scene reports under one spelling:
//!
//! - `particles`: particles the run put in (placed, charged, poured or
//!   generated), 1;
//! - `dt_s`: the time step, s;
//! - `steps`: steps simulated, 1;
//! - `end_time_s`: simulated time at the end of the run, s;
//! - `settled`: 1 when the scene's `settle` phase ended because the bed was
//!   at rest (the manifest's `at_rest` criterion), 0 when it ran its longest
//!   time.
//!
//! Why: each scene used to repeat these lines and spell the shared keys its
//! own way (`particles_inserted`, `end_s`, `settled_before_rotation` …), so a
//! reader of results needed to know which scene wrote them. The failures
//! they share are one [`LabError`]. Each scene keeps its geometry, protocol
//! and own measurements in its own file.

use std::path::Path;

pub use super::grains::Grains;
use super::physics::{self, STANDARD_GRAVITY_M_S2};
use super::protocol::Traces;
use super::SceneError;
use crate::dem::clump::template::ClumpShape;
use crate::dem::domain::DomainError;
use crate::dem::health::{HealthError, HealthLimits};
use crate::dem::simulation::{ContactSetup, SetupError, Simulation, SimulationSetup, World};
use crate::dem::timestep::TimeStepPlan;
use crate::dem::vec3::Vec3;
use crate::dem::walls::WallError;
use crate::log::{LogError, LogOptions, RunLog};
use crate::manifest::Experiment;
use crate::packing::distribution::SizeDistribution;
use crate::packing::PackingError;
use crate::store::RunResult;

/// What any lab scene's set-up or run can fail at besides its own protocol
/// and measurement: the variants the five lab scenes share, each message
/// starting with the scene's kind as written in manifests. Every lab scene's
/// error holds it as its `Lab` variant and converts from these sources with
/// [`lab_error_conversions`], so `?` works on them inside a scene.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// The particles could not be placed or inserted (an invalid size
    /// distribution, a region too small, an invalid factory setting).
    #[error("{scene} fill: {source}")]
    Packing {
        /// The scene kind.
        scene: &'static str,
        /// Why.
        source: PackingError,
    },
    /// The engine refused the set-up or an insertion.
    #[error("{scene}: {source}")]
    Setup {
        /// The scene kind.
        scene: &'static str,
        /// Why.
        source: SetupError,
    },
    /// The simulation became unhealthy (its message names the particle, step
    /// and cause).
    #[error(transparent)]
    Health(HealthError),
    /// A wall could not be built or moved.
    #[error("{scene} wall: {source}")]
    Wall {
        /// The scene kind.
        scene: &'static str,
        /// Why.
        source: WallError,
    },
    /// The simulation box could not be built.
    #[error("{scene} domain: {source}")]
    Domain {
        /// The scene kind.
        scene: &'static str,
        /// Why.
        source: DomainError,
    },
    /// The run log could not be written.
    #[error(transparent)]
    Log(LogError),
}

/// Implements `From` for a lab scene's error type (`$error`, which has a
/// `Lab(LabError)` variant) from each source of [`LabError`], naming the
/// scene `$scene` (its kind as written in manifests).
macro_rules! lab_error_conversions {
    ($error:ty, $scene:literal) => {
        impl From<$crate::packing::PackingError> for $error {
            fn from(source: $crate::packing::PackingError) -> Self {
                Self::Lab($crate::scenes::skeleton::LabError::Packing {
                    scene: $scene,
                    source,
                })
            }
        }
        impl From<$crate::dem::simulation::SetupError> for $error {
            fn from(source: $crate::dem::simulation::SetupError) -> Self {
                Self::Lab($crate::scenes::skeleton::LabError::Setup {
                    scene: $scene,
                    source,
                })
            }
        }
        impl From<$crate::dem::walls::WallError> for $error {
            fn from(source: $crate::dem::walls::WallError) -> Self {
                Self::Lab($crate::scenes::skeleton::LabError::Wall {
                    scene: $scene,
                    source,
                })
            }
        }
        impl From<$crate::dem::domain::DomainError> for $error {
            fn from(source: $crate::dem::domain::DomainError) -> Self {
                Self::Lab($crate::scenes::skeleton::LabError::Domain {
                    scene: $scene,
                    source,
                })
            }
        }
        impl From<$crate::dem::health::HealthError> for $error {
            fn from(e: $crate::dem::health::HealthError) -> Self {
                Self::Lab($crate::scenes::skeleton::LabError::Health(e))
            }
        }
        impl From<$crate::log::LogError> for $error {
            fn from(e: $crate::log::LogError) -> Self {
                Self::Lab($crate::scenes::skeleton::LabError::Log(e))
            }
        }
    };
}
pub(crate) use lab_error_conversions;

/// What a lab scene sets up from its experiment before building its rig.
#[derive(Debug)]
pub struct Lab {
    /// Contact physics of the particles and the scene's wall materials (in
    /// the order the scene numbers its walls' materials).
    pub contact: ContactSetup,
    /// The simulated (possibly coarse-grained) size distribution.
    pub sizes: SizeDistribution,
    /// Smallest diameter that can be drawn, m.
    pub d_min_m: f64,
    /// Representative diameter (the mean of a list, d50 of a log-normal), m.
    pub d_mean_m: f64,
    /// The time step for particles no smaller than `d_min_m`.
    pub plan: TimeStepPlan,
    /// Particle density, kg/m³.
    pub density_kg_m3: f64,
    /// What the particles are and how they enter a world.
    pub grains: Grains,
}

impl Lab {
    /// The set-up of `exp` with the scene's `wall_materials` (names of the
    /// manifest's wall materials, material 0 first). A size distribution that
    /// cannot be sampled becomes the scene's own error through `packing` (its
    /// message names the scene); a time step that cannot be chosen is
    /// [`SceneError::TimeStep`].
    pub fn new(
        exp: &Experiment,
        wall_materials: &[&str],
        packing: impl FnOnce(PackingError) -> SceneError,
    ) -> Result<Self, SceneError> {
        let contact = physics::contact_setup(exp, wall_materials);
        let clump = physics::clump_shape(exp)?;
        let sizes = physics::size_distribution(exp);
        let (d_min_m, d_mean_m) = physics::diameter_bounds(&sizes).map_err(packing)?;
        // The smallest contact partner: the smallest member sphere (the
        // unit shape's members are per unit volume-equivalent radius).
        let smallest = clump.as_ref().map_or(1.0, ClumpShape::min_member_radius_m);
        let plan = physics::time_step(exp, &contact, 0.5 * d_min_m * smallest)?;
        Ok(Self {
            contact,
            sizes,
            d_min_m,
            d_mean_m,
            plan,
            density_kg_m3: exp.material.particle.density_kg_m3,
            grains: Grains::new(
                clump,
                exp.material.particle.density_kg_m3,
                exp.seeds.packing_seed,
            ),
        })
    }

    /// Mass of a sphere of the representative diameter, kg (the unit of the
    /// `at_rest` criterion, m g d).
    pub fn mean_particle_mass_kg(&self) -> f64 {
        self.density_kg_m3 * std::f64::consts::PI / 6.0 * self.d_mean_m.powi(3)
    }

    /// The simulation of `world` with every lab scene's settings: gravity
    /// 9.81 m/s² along −z, the planned time step, a Verlet skin of a tenth of
    /// the representative diameter, and the health limits `health`.
    pub fn simulation(&self, world: World, health: HealthLimits) -> Result<Simulation, SetupError> {
        let setup = SimulationSetup {
            contact: self.contact.clone(),
            density_kg_m3: self.density_kg_m3,
            gravity_m_s2: Some(Vec3::new(0.0, 0.0, -STANDARD_GRAVITY_M_S2)),
            dt_s: self.plan.dt_s,
            skin_m: 0.1 * self.d_mean_m,
            health,
        };
        Simulation::new(world, &setup)
    }
}

/// Opens the run's MCAP log at `path` (none without a path), particles
/// coloured red at `speed_scale_m_s` (m/s, the fastest the scene expects).
pub fn open_log(
    path: Option<&Path>,
    exp: &Experiment,
    speed_scale_m_s: f64,
) -> Result<Option<RunLog>, LogError> {
    path.map(|path| {
        RunLog::create(
            path,
            exp,
            LogOptions {
                speed_scale_m_s,
                ..LogOptions::default()
            },
        )
    })
    .transpose()
}

/// Ends a lab run: closes its MCAP log, if it has one (the file appears only
/// now, complete), and starts the result with the experiment, the kernel that
/// ran, the sampled traces, the warnings about the time step `plan` (contacts
/// faster than it resolves, see [`physics::time_step_warnings`]) and the
/// shared measurements (see the module docs) from `sim`'s final state,
/// `particles` and whether the `settle` phase `settled`. The scene then adds
/// its own measurements and its headline angle. A scene that finishes its log
/// itself, later (funnel_pile, after measuring the pile), passes `None`.
pub fn finish(
    exp: &Experiment,
    sim: &Simulation,
    plan: &TimeStepPlan,
    traces: Traces,
    log: Option<RunLog>,
    particles: usize,
    settled: bool,
) -> Result<RunResult, LogError> {
    if let Some(log) = log {
        log.finish()?;
    }
    let mut result = RunResult::new(exp, sim.kernel_name());
    result.traces = traces.into_map();
    result.warnings = physics::time_step_warnings(plan, sim.stats().max_approach_speed_m_s);
    let w = sim.world();
    for (key, value) in [
        ("particles", particles as f64),
        ("dt_s", plan.dt_s),
        ("steps", w.step as f64),
        ("end_time_s", w.time_s),
        ("settled", f64::from(u8::from(settled))),
    ] {
        result.measurements.insert(key.to_string(), value);
    }
    Ok(result)
}
