//! The engine throughput benchmark (`repose bench`): builds the dense-bed test
//! bed of `../shared/bench` (the LIGGGHTS and LAMMPS decks) and times it.
//!
//! # The bed
//!
//! Spheres R = 1 mm, ρ = 2500 kg/m³, E = 5 MPa, ν = 0.3, e = 0.5, μ = 0.5, CDT
//! rolling friction 0.1, gravity 9.81 m/s², dt = 2.4477e-5 s (0.2 × the Rayleigh
//! time), skin 0.2 mm, periodic in x and y (period n × 2.4 mm) on a flat wall at
//! z = 0 of the particles' own material. N = n·n·20 spheres start on a
//! simple-cubic lattice of spacing 2.4 mm (the deck's `lattice sc 0.0024 origin
//! 0.5 0.5 0.5`, layers 2 to 21) jittered by up to ±0.2 mm per axis (seeded
//! ChaCha8), and settle under gravity for as many steps as the deck (20,000;
//! 16,000 for n ≥ 50) with the deck's physics (Hertz + CDT). The settled bed is
//! kept in memory; every requested variant (normal model × rolling model ×
//! thread count) starts a fresh simulation from it (contact history starts
//! empty, as after a LIGGGHTS restart) and runs a warm-up (500 steps). Then
//! the timed segments (6,000 / 2,000 / 1,000 steps for n = 16 / 32 / 50, the
//! deck's `nb`) run in rounds: round k runs segment k of every variant, one
//! after the other, so that a change in the machine's speed (other tenants
//! of a shared host) hits every variant alike instead of whichever ran
//! last. Throughput is N × steps / wall seconds of a segment; a variant's
//! speedup is the median over the rounds of its throughput over that of the
//! same kernel on the fewest threads in the same round.
//!
//! Measurements, and what was tried and not kept, are in `docs/performance.md`.

use std::io::Write;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::{ThreadPool, ThreadPoolBuilder};
use serde::Serialize;

use crate::dem::contact::PairParameters;
use crate::dem::domain::Domain;
use crate::dem::health::{HealthError, HealthLimits};
use crate::dem::material::ElasticMaterial;
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::simulation::{
    ContactSetup, NormalChoice, RollingChoice, SetupError, Simulation, SimulationSetup, World,
};
use crate::dem::vec3::Vec3;
use crate::dem::walls::Wall;

/// Sphere radius, m.
const RADIUS_M: f64 = 1e-3;
/// Lattice spacing, m.
const SPACING_M: f64 = 2.4e-3;
/// Largest jitter per axis, m.
const JITTER_M: f64 = 2e-4;
/// Layers of the lattice.
const LAYERS: usize = 20;
/// Time step, s (the decks' `timestep`).
pub const DT_S: f64 = 2.4477e-5;
/// Verlet skin, m (the decks' `neighbor 0.0002 bin`).
const SKIN_M: f64 = 2e-4;

/// What to benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Lattice side: N = n·n·20 spheres (16, 32, 50 give 5,120, 20,480, 50,000).
    pub n: usize,
    /// Thread counts to time, each in its own rayon pool.
    pub threads: Vec<usize>,
    /// Steps per timed segment; `None`: the deck's (6,000 / 2,000 / 1,000).
    pub steps: Option<u64>,
    /// Timed segments per variant.
    pub segments: usize,
    /// Warm-up steps before the timed segments.
    pub warmup: u64,
    /// Settling steps; `None`: the deck's (20,000; 16,000 for n ≥ 50).
    pub settle: Option<u64>,
    /// Normal models to time (JKR runs with [`JKR_SURFACE_ENERGY_J_M2`]).
    pub normals: Vec<NormalChoice>,
    /// Rolling models to time.
    pub rollings: Vec<RollingChoice>,
    /// Seed of the lattice jitter.
    pub seed: u64,
}

impl BenchOptions {
    /// The deck's settings for lattice side `n`: Hertz + CDT on one thread.
    pub fn deck(n: usize) -> Self {
        Self {
            n,
            threads: vec![1],
            steps: None,
            segments: 3,
            warmup: 500,
            settle: None,
            normals: vec![NormalChoice::Hertz],
            rollings: vec![RollingChoice::Cdt],
            seed: 15_485_863,
        }
    }

    /// Number of spheres, n·n·20.
    pub fn particles(&self) -> usize {
        self.n * self.n * LAYERS
    }

    /// Steps per timed segment (given or the deck's).
    pub fn segment_steps(&self) -> u64 {
        self.steps.unwrap_or(match self.n {
            0..=31 => 6000,
            32..=49 => 2000,
            _ => 1000,
        })
    }

    /// Settling steps (given or the deck's).
    pub fn settle_steps(&self) -> u64 {
        self.settle
            .unwrap_or(if self.n >= 50 { 16_000 } else { 20_000 })
    }
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// An option is out of range.
    #[error("invalid option {name}: {message}")]
    Option {
        /// The option.
        name: &'static str,
        /// What is allowed.
        message: &'static str,
    },
    /// The rayon pool could not be built.
    #[error("thread pool: {0}")]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
    /// The simulation rejected the bed.
    #[error("setup: {0}")]
    Setup(#[from] SetupError),
    /// The bed became unhealthy.
    #[error(transparent)]
    Health(#[from] HealthError),
    /// Writing progress failed.
    #[error("cannot write progress: {0}")]
    Progress(#[from] std::io::Error),
}

impl BenchError {
    /// True when the user's options are at fault.
    pub fn is_invalid_input(&self) -> bool {
        matches!(self, BenchError::Option { .. })
    }
}

/// The settling phase.
#[derive(Clone, Debug, Serialize)]
pub struct SettleReport {
    /// Steps run.
    pub steps: u64,
    /// Threads used.
    pub threads: usize,
    /// Wall time, s.
    pub wall_s: f64,
    /// Highest sphere centre at the end, m.
    pub top_z_m: f64,
    /// Kinetic energy at the end, J.
    pub kinetic_energy_j: f64,
}

/// One timed variant.
#[derive(Clone, Debug, Serialize)]
pub struct VariantReport {
    /// The kernel's name (its effects).
    pub kernel: String,
    /// Threads of the pool.
    pub threads: usize,
    /// Steps per timed segment.
    pub segment_steps: u64,
    /// Throughput of each segment, million particle-steps per second.
    pub segment_mps: Vec<f64>,
    /// Median of `segment_mps`.
    pub median_mps: f64,
    /// Throughput of each segment per CPU second of the process (all its
    /// threads), million particle-steps per CPU second; empty where the CPU
    /// clock (`/proc/self/stat`) is unavailable. On a shared machine this is
    /// less sensitive than wall time to other processes' load.
    pub segment_cpu_mps: Vec<f64>,
    /// Median of `segment_cpu_mps` (0 when empty).
    pub median_cpu_mps: f64,
    /// Median over the rounds of this variant's throughput over that of the
    /// same kernel on the fewest threads timed, in the same round (1 for
    /// that variant itself): the speedup from the extra threads, measured
    /// segment by segment so that the machine's changing speed cancels.
    pub speedup: f64,
    /// Force-carrying particle pairs per particle at the end.
    pub pairs_per_particle: f64,
    /// Particle contacts per particle (2 × pairs per particle).
    pub contacts_per_particle: f64,
    /// Wall contacts per particle at the end.
    pub wall_contacts_per_particle: f64,
    /// Neighbour-list rebuilds during the timed segments.
    pub rebuilds: u64,
    /// Setup (first neighbour build and forces) wall time, s.
    pub setup_s: f64,
    /// Warm-up wall time, s.
    pub warmup_s: f64,
    /// Wall time of all timed segments, s.
    pub timed_s: f64,
}

/// Everything one `repose bench` measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Lattice side n.
    pub n: usize,
    /// Spheres, n·n·20.
    pub particles: usize,
    /// Time step, s.
    pub dt_s: f64,
    /// The instruction set the pair kernel ran on
    /// ([`pair_kernel_isa`](crate::dem::lanes::pair_kernel_isa)).
    pub pair_kernel_isa: &'static str,
    /// The settling phase.
    pub settle: SettleReport,
    /// Timed variants, in the order run.
    pub variants: Vec<VariantReport>,
}

/// The jittered lattice, the periodic box and the floor.
pub fn bed_world(n: usize, seed: u64) -> World {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut particles = Particles::default();
    let density = bed_setup(NormalChoice::Hertz, RollingChoice::Cdt).density_kg_m3;
    let mut jitter = || JITTER_M * (2.0 * rng.random::<f64>() - 1.0);
    for k in 0..LAYERS {
        for j in 0..n {
            for i in 0..n {
                let lattice = Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 1.5) * SPACING_M;
                let offset = Vec3::new(jitter(), jitter(), jitter());
                particles.push(
                    &ParticleInit {
                        position: lattice + offset,
                        velocity: Vec3::zeros(),
                        angular_velocity: Vec3::zeros(),
                        radius_m: RADIUS_M,
                    },
                    density,
                );
            }
        }
    }
    let side = n as f64 * SPACING_M;
    let top = (LAYERS + 2) as f64 * SPACING_M;
    World::new(
        particles,
        vec![Wall::plane(Vec3::zeros(), Vec3::z(), 0).expect("the floor is a valid plane")],
        Domain::new(
            Vec3::zeros(),
            Vec3::new(side, side, top),
            [true, true, false],
        )
        .expect("the bed's box is valid"),
    )
}

/// Surface energy the JKR variant uses, J/m²: physically negligible (the
/// pull-off force of a 1 mm pair is 5e-12 N against a 1e-4 N weight), but not
/// zero, because with Γ = 0 everywhere the engine runs the Hertz kernel.
pub const JKR_SURFACE_ENERGY_J_M2: f64 = 1e-9;

/// The deck's physics with the given normal and rolling models (JKR with
/// [`JKR_SURFACE_ENERGY_J_M2`]).
pub fn bed_setup(normal: NormalChoice, rolling: RollingChoice) -> SimulationSetup {
    let material = ElasticMaterial {
        youngs_modulus_pa: 5e6,
        poisson_ratio: 0.3,
    };
    let pair = PairParameters {
        restitution: 0.5,
        static_friction: 0.5,
        rolling_friction: 0.1,
        surface_energy_j_m2: match normal {
            NormalChoice::Hertz => 0.0,
            NormalChoice::Jkr => JKR_SURFACE_ENERGY_J_M2,
        },
    };
    SimulationSetup {
        contact: ContactSetup {
            normal,
            rolling,
            clip_tensile: false,
            particle_material: material,
            particle_particle: pair,
            wall_materials: vec![(material, pair)],
        },
        density_kg_m3: 2500.0,
        gravity_m_s2: Some(Vec3::new(0.0, 0.0, -9.81)),
        dt_s: DT_S,
        skin_m: SKIN_M,
        health: HealthLimits::default(),
    }
}

/// Settles the bed (progress to `progress`), then times every variant.
pub fn run(
    options: &BenchOptions,
    progress: &mut (dyn Write + Send),
) -> Result<BenchReport, BenchError> {
    check(options)?;
    let n_part = options.particles();
    let settle_threads = options.threads.iter().copied().max().unwrap_or(1);
    let settle_steps = options.settle_steps();
    writeln!(
        progress,
        "settling N = {n_part} for {settle_steps} steps on {settle_threads} thread(s)"
    )?;
    let pool = ThreadPoolBuilder::new()
        .num_threads(settle_threads)
        .build()?;
    let start = Instant::now();
    let settled = pool.install(|| -> Result<World, BenchError> {
        let world = bed_world(options.n, options.seed);
        let mut sim = Simulation::new(world, &bed_setup(NormalChoice::Hertz, RollingChoice::Cdt))?;
        let chunk = settle_steps.div_ceil(10).max(1);
        let mut done = 0;
        while done < settle_steps {
            let k = chunk.min(settle_steps - done);
            sim.advance(k)?;
            done += k;
            let s = sim.stats();
            writeln!(
                progress,
                "  step {done}: {:.2} contacts/particle, KE {:.3e} J, {:.1} s",
                2.0 * s.contacts as f64 / n_part as f64,
                sim.world().particles.kinetic_energy_j(),
                start.elapsed().as_secs_f64()
            )?;
        }
        Ok(sim.world().clone())
    })?;
    let p = &settled.particles;
    let settle = SettleReport {
        steps: settle_steps,
        threads: settle_threads,
        wall_s: start.elapsed().as_secs_f64(),
        top_z_m: p.position.iter().map(|x| x.z).fold(f64::MIN, f64::max),
        kinetic_energy_j: p.kinetic_energy_j(),
    };
    let mut timings = Vec::new();
    for &normal in &options.normals {
        for &rolling in &options.rollings {
            for &threads in &options.threads {
                timings.push(VariantTiming::start(
                    options, &settled, normal, rolling, threads,
                )?);
            }
        }
    }
    for round in 0..options.segments {
        for timing in &mut timings {
            timing.segment(options, round, progress)?;
        }
    }
    let mut variants: Vec<VariantReport> = timings.into_iter().map(|t| t.finish(options)).collect();
    set_speedups(&mut variants);
    Ok(BenchReport {
        n: options.n,
        particles: n_part,
        dt_s: DT_S,
        pair_kernel_isa: crate::dem::lanes::pair_kernel_isa(),
        settle,
        variants,
    })
}

fn check(options: &BenchOptions) -> Result<(), BenchError> {
    let fail = |name, message| Err(BenchError::Option { name, message });
    if !(2..=400).contains(&options.n) {
        return fail("--n", "the lattice side must be in 2..=400");
    }
    if options.threads.is_empty() || options.threads.contains(&0) {
        return fail("--threads", "thread counts must be >= 1");
    }
    if options.segments == 0 || options.segment_steps() == 0 {
        return fail("--segments/--steps", "at least one segment of >= 1 step");
    }
    if options.normals.is_empty() || options.rollings.is_empty() {
        return fail("--normal/--rolling", "at least one model each");
    }
    Ok(())
}

/// One variant being timed: its pool, its simulation and what its segments
/// measured so far.
struct VariantTiming {
    pool: ThreadPool,
    sim: Simulation,
    threads: usize,
    /// Neighbour rebuilds before the first timed segment.
    rebuilds_before: u64,
    /// Set-up and warm-up wall times, s.
    setup_s: f64,
    warmup_s: f64,
    /// Per segment: M particle-steps per wall second and per CPU second.
    segment_mps: Vec<f64>,
    segment_cpu_mps: Vec<f64>,
    /// Wall time of the timed segments so far, s.
    timed_s: f64,
}

impl VariantTiming {
    /// A fresh simulation of the settled bed with the variant's laws in a
    /// pool of `threads` threads, set up and warmed up (both timed).
    fn start(
        options: &BenchOptions,
        settled: &World,
        normal: NormalChoice,
        rolling: RollingChoice,
        threads: usize,
    ) -> Result<Self, BenchError> {
        let pool = ThreadPoolBuilder::new().num_threads(threads).build()?;
        let (sim, setup_s, warmup_s) = pool.install(|| -> Result<_, BenchError> {
            let t0 = Instant::now();
            let mut sim = Simulation::new(settled.clone(), &bed_setup(normal, rolling))?;
            let setup_s = t0.elapsed().as_secs_f64();
            let t1 = Instant::now();
            sim.advance(options.warmup)?;
            Ok((sim, setup_s, t1.elapsed().as_secs_f64()))
        })?;
        Ok(Self {
            pool,
            threads,
            rebuilds_before: sim.stats().rebuilds,
            sim,
            setup_s,
            warmup_s,
            segment_mps: Vec::with_capacity(options.segments),
            segment_cpu_mps: Vec::with_capacity(options.segments),
            timed_s: 0.0,
        })
    }

    /// Spheres in the bed, as a float for throughputs.
    fn particles(&self) -> f64 {
        self.sim.world().particles.len() as f64
    }

    /// Times segment `round` (0-based) in the variant's pool.
    fn segment(
        &mut self,
        options: &BenchOptions,
        round: usize,
        progress: &mut (dyn Write + Send),
    ) -> Result<(), BenchError> {
        let steps = options.segment_steps();
        let work = self.particles() * steps as f64 / 1e6;
        let sim = &mut self.sim;
        let (t, cpu) = (Instant::now(), process_cpu_s());
        self.pool.install(|| sim.advance(steps))?;
        let wall_s = t.elapsed().as_secs_f64();
        let mps = work / wall_s;
        let cpu_mps = cpu
            .zip(process_cpu_s())
            .map(|(a, b)| work / (b - a).max(1e-2));
        writeln!(
            progress,
            "  {}, {} thread(s), segment {} of {}: {mps:.2} M particle-steps/s, {:.2} per CPU s",
            self.sim.kernel_name(),
            self.threads,
            round + 1,
            options.segments,
            cpu_mps.unwrap_or(0.0)
        )?;
        self.segment_mps.push(mps);
        self.segment_cpu_mps.extend(cpu_mps);
        self.timed_s += wall_s;
        Ok(())
    }

    /// The variant's report (speedup 1 until [`set_speedups`]), with the
    /// bed's contacts at the end.
    fn finish(self, options: &BenchOptions) -> VariantReport {
        let n = self.particles();
        let s = self.sim.stats();
        VariantReport {
            kernel: self.sim.kernel_name(),
            threads: self.threads,
            segment_steps: options.segment_steps(),
            median_mps: median(&self.segment_mps),
            segment_mps: self.segment_mps,
            median_cpu_mps: if self.segment_cpu_mps.is_empty() {
                0.0
            } else {
                median(&self.segment_cpu_mps)
            },
            segment_cpu_mps: self.segment_cpu_mps,
            speedup: 1.0,
            pairs_per_particle: s.contacts as f64 / n,
            contacts_per_particle: 2.0 * s.contacts as f64 / n,
            wall_contacts_per_particle: s.wall_contacts as f64 / n,
            rebuilds: s.rebuilds - self.rebuilds_before,
            setup_s: self.setup_s,
            warmup_s: self.warmup_s,
            timed_s: self.timed_s,
        }
    }
}

/// Sets each variant's [`speedup`](VariantReport::speedup): the median over
/// the rounds of its throughput over that of the same kernel on the fewest
/// threads in the same round.
fn set_speedups(variants: &mut [VariantReport]) {
    let speedups: Vec<f64> = variants
        .iter()
        .map(|v| {
            let base = variants
                .iter()
                .filter(|b| b.kernel == v.kernel)
                .min_by_key(|b| b.threads)
                .unwrap_or(v);
            let ratios: Vec<f64> = v
                .segment_mps
                .iter()
                .zip(&base.segment_mps)
                .map(|(m, b)| m / b)
                .collect();
            median(&ratios)
        })
        .collect();
    for (v, s) in variants.iter_mut().zip(speedups) {
        v.speedup = s;
    }
}

/// User + system CPU time of this process (all threads), s, from
/// `/proc/self/stat` (clock ticks of 1/100 s); `None` where unavailable.
fn process_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let mut fields = rest.split_whitespace().skip(11);
    let utime: f64 = fields.next()?.parse().ok()?;
    let stime: f64 = fields.next()?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// Median of a non-empty list (mean of the middle two for even lengths).
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let m = s.len() / 2;
    if s.len() % 2 == 1 {
        s[m]
    } else {
        0.5 * (s[m - 1] + s[m])
    }
}

impl BenchReport {
    /// Writes the report as a text table.
    pub fn write_table(&self, out: &mut dyn Write) -> std::io::Result<()> {
        writeln!(
            out,
            "bed: N = {} ({} x {} x {LAYERS}), dt = {:e} s, pair kernel on {}; settled in {} steps, {:.1} s on {} thread(s), top z = {:.2} mm",
            self.particles,
            self.n,
            self.n,
            self.dt_s,
            self.pair_kernel_isa,
            self.settle.steps,
            self.settle.wall_s,
            self.settle.threads,
            self.settle.top_z_m * 1e3
        )?;
        writeln!(
            out,
            "{:<34} {:>3} {:>6}  {:<23} {:>7} {:>7} {:>7} {:>7} {:>7} {:>6} {:>5} {:>8} {:>8}",
            "kernel",
            "thr",
            "steps",
            "segments Mps/s",
            "median",
            "speedup",
            "cpu Mps",
            "pairs/p",
            "cont/p",
            "wall/p",
            "rebld",
            "warmup s",
            "timed s"
        )?;
        for v in &self.variants {
            let segs: Vec<String> = v.segment_mps.iter().map(|m| format!("{m:.2}")).collect();
            writeln!(
                out,
                "{:<34} {:>3} {:>6}  {:<23} {:>7.2} {:>7.2} {:>7.2} {:>7.3} {:>7.3} {:>6.3} {:>5} {:>8.2} {:>8.2}",
                v.kernel,
                v.threads,
                v.segment_steps,
                segs.join(" "),
                v.median_mps,
                v.speedup,
                v.median_cpu_mps,
                v.pairs_per_particle,
                v.contacts_per_particle,
                v.wall_contacts_per_particle,
                v.rebuilds,
                v.warmup_s,
                v.timed_s
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_matches_the_deck() {
        let w = bed_world(4, 1);
        assert_eq!(w.particles.len(), 4 * 4 * 20);
        let z: Vec<f64> = w.particles.position.iter().map(|p| p.z).collect();
        let (lo, hi) = z
            .iter()
            .fold((f64::MAX, f64::MIN), |a, &z| (a.0.min(z), a.1.max(z)));
        // Layers k = 1..=20 of `lattice sc 0.0024 origin 0.5 0.5 0.5`, ±0.2 mm.
        assert!(lo >= 1.5 * SPACING_M - JITTER_M && hi <= 20.5 * SPACING_M + JITTER_M);
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    }

    /// A report of `kernel` on `threads` threads with these segments.
    fn timed(kernel: &str, threads: usize, segment_mps: Vec<f64>) -> VariantReport {
        VariantReport {
            kernel: kernel.into(),
            threads,
            segment_steps: 1,
            median_mps: median(&segment_mps),
            segment_mps,
            segment_cpu_mps: Vec::new(),
            median_cpu_mps: 0.0,
            speedup: 0.0,
            pairs_per_particle: 0.0,
            contacts_per_particle: 0.0,
            wall_contacts_per_particle: 0.0,
            rebuilds: 0,
            setup_s: 0.0,
            warmup_s: 0.0,
            timed_s: 0.0,
        }
    }

    #[test]
    fn speedups_pair_the_segments_of_one_round() {
        // Round 2 ran while the machine was slow: per round the 2-thread
        // variant did 1.8, 2.0 and 1.7 times the 1-thread one, median 1.8;
        // the ratio of the medians would be 17 / 10 = 1.7.
        let mut v = vec![
            timed("a", 1, vec![10.0, 5.0, 10.0]),
            timed("b", 1, vec![4.0, 4.0, 4.0]),
            timed("a", 2, vec![18.0, 10.0, 17.0]),
        ];
        set_speedups(&mut v);
        let speedups: Vec<f64> = v.iter().map(|v| v.speedup).collect();
        assert_eq!(speedups, vec![1.0, 1.0, 18.0 / 10.0]);
    }

    #[test]
    fn a_tiny_bed_settles_and_times() {
        let mut o = BenchOptions::deck(3);
        o.settle = Some(50);
        o.steps = Some(20);
        o.warmup = 10;
        o.segments = 2;
        o.threads = vec![1, 2];
        o.rollings = vec![RollingChoice::None, RollingChoice::Epsd];
        o.normals = vec![NormalChoice::Jkr];
        let r = run(&o, &mut std::io::sink()).unwrap();
        assert_eq!(r.variants.len(), 4);
        assert!(r.variants.iter().all(|v| v.median_mps > 0.0));
        assert!(r.variants.iter().all(|v| v.segment_mps.len() == 2));
        let one_thread: Vec<f64> = r
            .variants
            .iter()
            .filter(|v| v.threads == 1)
            .map(|v| v.speedup)
            .collect();
        assert_eq!(one_thread, vec![1.0, 1.0]);
        assert!(r.variants[0]
            .kernel
            .starts_with("jkr+mindlin+none+gravity+periodic"));
        let mut bad = o.clone();
        bad.threads = vec![0];
        assert!(run(&bad, &mut std::io::sink())
            .unwrap_err()
            .is_invalid_input());
    }
}
