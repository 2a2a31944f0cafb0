//! Scene protocols: a run is a sequence of phases (fill, settle, action,
//! settle, measure), each ending when its stop criterion is met — the mean
//! kinetic energy per particle held below a threshold for a time, or a maximum
//! time. While a phase runs, a sampler is called at a fixed simulated-time
//! interval (traces, log frames) and progress is reported unless quiet.
//!
//! Everything that reaches results depends on simulated time only; wall-clock
//! time is used for the progress line and nothing else.

use crate::dem::health::HealthError;
use crate::dem::simulation::Simulation;
use crate::manifest::AtRest;
use crate::store::Trace;
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// When a phase may end early: the mean kinetic energy per particle (J) stays
/// below `mean_kinetic_energy_j` for `hold_s` seconds of simulated time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SettleCriterion {
    /// Threshold on the mean kinetic energy per particle, J.
    pub mean_kinetic_energy_j: f64,
    /// How long the energy must stay below the threshold, s.
    pub hold_s: f64,
}

impl SettleCriterion {
    /// The lab scenes' 'bed at rest' as the manifest's `at_rest` block states
    /// it: the mean kinetic energy per particle below
    /// `rest.kinetic_energy_fraction` · m g d for `rest.hold_s`, with m (kg) and
    /// d (m) the mass and diameter of a representative particle.
    pub fn at_rest(rest: &AtRest, mass_kg: f64, diameter_m: f64) -> Self {
        Self {
            mean_kinetic_energy_j: rest.kinetic_energy_fraction
                * mass_kg
                * STANDARD_GRAVITY_M_S2
                * diameter_m,
            hold_s: rest.hold_s,
        }
    }
}

pub use super::physics::STANDARD_GRAVITY_M_S2;

/// One phase of a protocol.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phase {
    /// Name for progress lines and results (`fill`, `settle`, `rotate`, ...).
    pub name: &'static str,
    /// The phase ends at the latest after this much simulated time, s.
    pub max_duration_s: f64,
    /// Optional early end once the bed is at rest.
    pub settle: Option<SettleCriterion>,
}

/// How a phase ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseOutcome {
    /// The phase's name.
    pub name: &'static str,
    /// Simulated time at its start, s.
    pub start_s: f64,
    /// Simulated time at its end, s.
    pub end_s: f64,
    /// True if it ended early (its settle criterion was met, or the sampler
    /// asked to stop), false if the maximum time ended it.
    pub settled: bool,
}

/// Receives the simulation at every sampling instant.
pub trait Sampler {
    /// Error type of the sampler (e.g. writing a log).
    type Error: From<HealthError>;
    /// Called at t = phase start and then every sampling interval.
    fn sample(&mut self, phase: &'static str, sim: &mut Simulation) -> Result<(), Self::Error>;

    /// Asked after every sample but the first: true ends the phase there, like a
    /// met settle criterion (e.g. no particle has left a hopper for a while).
    /// By default a phase runs to its own criterion or maximum time.
    fn stop_early(&self) -> bool {
        false
    }
}

/// Mean kinetic energy per particle, J (0 for an empty world).
pub fn mean_kinetic_energy_j(sim: &Simulation) -> f64 {
    let p = &sim.world().particles;
    if p.is_empty() {
        0.0
    } else {
        p.kinetic_energy_j() / p.len() as f64
    }
}

/// Runs one phase in steps of `dt_s`, sampling every `sample_interval_s`
/// (rounded to whole steps, at least one).
pub fn run_phase<S: Sampler>(
    sim: &mut Simulation,
    phase: &Phase,
    dt_s: f64,
    sample_interval_s: f64,
    sampler: &mut S,
    progress: &mut Progress,
) -> Result<PhaseOutcome, S::Error> {
    let start = sim.world().time_s;
    let total_steps = (phase.max_duration_s / dt_s).round().max(0.0) as u64;
    let chunk = ((sample_interval_s / dt_s).round() as u64).max(1);
    let mut done = 0;
    let mut calm_since: Option<f64> = None;
    sampler.sample(phase.name, sim)?;
    while done < total_steps {
        let n = chunk.min(total_steps - done);
        sim.advance(n)?;
        done += n;
        sampler.sample(phase.name, sim)?;
        progress.report(phase, sim, done, total_steps);
        if sampler.stop_early() {
            return Ok(outcome(phase, start, sim, true));
        }
        if let Some(c) = phase.settle {
            let t = sim.world().time_s;
            if mean_kinetic_energy_j(sim) < c.mean_kinetic_energy_j {
                let since = *calm_since.get_or_insert(t);
                if t - since >= c.hold_s {
                    return Ok(outcome(phase, start, sim, true));
                }
            } else {
                calm_since = None;
            }
        }
    }
    Ok(outcome(phase, start, sim, false))
}

fn outcome(phase: &Phase, start: f64, sim: &Simulation, settled: bool) -> PhaseOutcome {
    PhaseOutcome {
        name: phase.name,
        start_s: start,
        end_s: sim.world().time_s,
        settled,
    }
}

/// Named time series collected during a run (stored in result.json).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Traces {
    series: BTreeMap<String, Trace>,
}

impl Traces {
    /// Appends `value` (in `unit`) at simulated time `time_s` to series `name`.
    pub fn push(&mut self, name: &str, unit: &str, time_s: f64, value: f64) {
        let t = self
            .series
            .entry(name.to_string())
            .or_insert_with(|| Trace {
                time_s: Vec::new(),
                values: Vec::new(),
                unit: unit.to_string(),
            });
        t.time_s.push(time_s);
        t.values.push(value);
    }

    /// Records the engine's standard traces: kinetic energy (J), contacts,
    /// wall contacts and the largest overlap ratio.
    pub fn push_engine_state(&mut self, sim: &Simulation) {
        let t = sim.world().time_s;
        let s = sim.stats();
        self.push(
            "kinetic_energy",
            "J",
            t,
            sim.world().particles.kinetic_energy_j(),
        );
        self.push("contacts", "1", t, s.contacts as f64);
        self.push("wall_contacts", "1", t, s.wall_contacts as f64);
        self.push("max_overlap_ratio", "1", t, s.max_overlap_ratio);
    }

    /// The collected series, by name.
    pub fn into_map(self) -> BTreeMap<String, Trace> {
        self.series
    }
}

/// Progress on stderr for long runs: phase, simulated time, wall time,
/// particle-steps per second and an ETA for the phase, at most once a second.
#[derive(Debug)]
pub struct Progress {
    quiet: bool,
    started: Instant,
    last: Option<Instant>,
}

/// Set once by the command line (`--quiet`): silences every [`Progress::on_stderr`].
static QUIET: AtomicBool = AtomicBool::new(false);

/// Silences (or re-enables) progress reports of every scene in this process;
/// `repose --quiet` calls it before running anything.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// True when progress may be shown on stderr: not `--quiet`, and stderr is a
/// terminal (batch logs and CI stay clean). [`Progress::on_stderr`] and the
/// calibration batch's progress bar both decide by it.
pub fn progress_enabled() -> bool {
    !QUIET.load(Ordering::Relaxed) && std::io::stderr().is_terminal()
}

impl Progress {
    /// The reporter scenes use: silent unless [`progress_enabled`].
    pub fn on_stderr() -> Self {
        Self::new(!progress_enabled())
    }

    /// A progress reporter; `quiet` silences it.
    pub fn new(quiet: bool) -> Self {
        Self {
            quiet,
            started: Instant::now(),
            last: None,
        }
    }

    fn report(&mut self, phase: &Phase, sim: &Simulation, done: u64, total: u64) {
        if self.quiet {
            return;
        }
        let now = Instant::now();
        if self
            .last
            .is_some_and(|l| now.duration_since(l).as_secs_f64() < 1.0)
            && done < total
        {
            return;
        }
        self.last = Some(now);
        let wall = now.duration_since(self.started).as_secs_f64();
        let w = sim.world();
        let rate = w.step as f64 * w.particles.len() as f64 / wall.max(1e-9);
        let eta = wall / w.step.max(1) as f64 * (total - done) as f64;
        eprintln!(
            "{:>8}  t = {:.3} s  step {}/{}  wall {:.0} s  {:.2e} particle-steps/s  phase ETA {:.0} s",
            phase.name, w.time_s, done, total, wall, rate, eta
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::PairParameters;
    use crate::dem::domain::Domain;
    use crate::dem::health::HealthLimits;
    use crate::dem::material::ElasticMaterial;
    use crate::dem::particles::{ParticleInit, Particles};
    use crate::dem::simulation::{
        ContactSetup, NormalChoice, RollingChoice, SimulationSetup, World,
    };
    use crate::dem::vec3::Vec3;
    use crate::dem::walls::Wall;

    struct Count(usize);
    impl Sampler for Count {
        type Error = HealthError;
        fn sample(&mut self, _: &'static str, _: &mut Simulation) -> Result<(), HealthError> {
            self.0 += 1;
            Ok(())
        }
    }

    fn dropped_sphere() -> Simulation {
        let p = PairParameters {
            restitution: 0.3,
            static_friction: 0.5,
            rolling_friction: 0.0,
            surface_energy_j_m2: 0.0,
        };
        let m = ElasticMaterial {
            youngs_modulus_pa: 1e7,
            poisson_ratio: 0.3,
        };
        let mut particles = Particles::default();
        particles.push(
            &ParticleInit {
                position: Vec3::new(0.0, 0.0, 3e-3),
                velocity: Vec3::zeros(),
                angular_velocity: Vec3::zeros(),
                radius_m: 1e-3,
            },
            2500.0,
        );
        let world = World::new(
            particles,
            vec![Wall::plane(Vec3::zeros(), Vec3::z(), 0).unwrap()],
            Domain::new(
                Vec3::new(-0.1, -0.1, -0.01),
                Vec3::new(0.1, 0.1, 0.1),
                [false; 3],
            )
            .unwrap(),
        );
        let setup = SimulationSetup {
            contact: ContactSetup {
                normal: NormalChoice::Hertz,
                rolling: RollingChoice::None,
                clip_tensile: false,
                particle_material: m,
                particle_particle: p,
                wall_materials: vec![(ElasticMaterial::RIGID, p)],
            },
            density_kg_m3: 2500.0,
            gravity_m_s2: Some(Vec3::new(0.0, 0.0, -9.81)),
            dt_s: 1e-5,
            skin_m: 1e-4,
            health: HealthLimits::default(),
        };
        Simulation::new(world, &setup).unwrap()
    }

    #[test]
    fn a_dropped_sphere_settles_before_the_maximum_time() {
        let mut sim = dropped_sphere();
        let phase = Phase {
            name: "settle",
            max_duration_s: 1.0,
            settle: Some(SettleCriterion {
                mean_kinetic_energy_j: 1e-12,
                hold_s: 0.01,
            }),
        };
        let mut count = Count(0);
        let out = run_phase(
            &mut sim,
            &phase,
            1e-5,
            1e-3,
            &mut count,
            &mut Progress::new(true),
        )
        .unwrap();
        assert!(out.settled, "{out:?}");
        // A 2 mm drop with e = 0.3 is at rest within ~0.1 s.
        assert!(out.end_s > 0.02 && out.end_s < 0.3, "{out:?}");
        assert_eq!(count.0 as f64, (out.end_s / 1e-3).round() + 1.0);
    }

    #[test]
    fn without_a_criterion_the_phase_runs_its_maximum_time() {
        let mut sim = dropped_sphere();
        let phase = Phase {
            name: "rotate",
            max_duration_s: 0.05,
            settle: None,
        };
        let out = run_phase(
            &mut sim,
            &phase,
            1e-5,
            1e-2,
            &mut Count(0),
            &mut Progress::new(true),
        )
        .unwrap();
        assert!(!out.settled && (out.end_s - 0.05).abs() < 1e-9, "{out:?}");
    }
}
