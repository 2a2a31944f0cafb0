//! Paired-sphere clumps in the lab scenes: every lab scene's smoke manifest
//! runs with `paired_spheres` (aspect ratio 1.3) and logs every member
//! sphere, and paired spheres stand steeper than spheres at the same contact
//! parameters, seed for seed. Up to the largest aspect ratio validation
//! allows (just below 2), clumps in the drum's dense layout start within
//! the engine's overlap bound: where some would not, they are moved to
//! places free of overlaps, and such runs start.
//!
//! Every smoke-clumps run gives the same result.json and run.mcap bytes on
//! one thread and on two (the rigid-body passes run on the engine's team).
//!
//! One test runs every long simulation: the one-thread runs two at a time,
//! each on one thread of its own, then the two-thread runs one at a time:
//! several engines sharing two cores with teams of threads each would spin
//! against each other (this file took 190 s of CI that way, against about
//! 70 s of work). The other tests run a few hundredths of a second each, on
//! one thread.

mod common;

use rayon::prelude::*;
use repose::dem::clump::template::ClumpTemplate;
use repose::dem::domain::Domain;
use repose::dem::health::HealthLimits;
use repose::dem::particles::ParticleInit;
use repose::dem::simulation::World;
use repose::dem::vec3::Vec3;
use repose::dem::walls::Wall;
use repose::log::inspect::inspect_file;
use repose::manifest::{parse_experiment, Experiment};
use repose::packing::distribution::SizeDistribution;
use repose::packing::place::{place_lattice, FillTarget, PlacementSpec};
use repose::packing::region::Region;
use repose::scenes::grains::{Grains, RELOCATION_REACH};
use repose::scenes::run_experiment;
use repose::store::RunResult;
use serde_json::json;

const SCENES: [(&str, &str); 5] = [
    ("funnel_pile", "angle_deg"),
    ("baffle_lift", "static_angle_deg"),
    ("drum", "dynamic_angle_deg"),
    ("static_pile", "profile_angle_deg"),
    ("hopper", "upper_angle_deg"),
];

/// Runs `exp` on one thread (with its log at `log`).
fn run_alone(exp: &Experiment, log: Option<&std::path::Path>) -> RunResult {
    run_on(1, exp, log)
}

/// Runs `exp` on `threads` threads (with its log at `log`).
fn run_on(threads: usize, exp: &Experiment, log: Option<&std::path::Path>) -> RunResult {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| run_experiment(exp, log))
        .unwrap_or_else(|e| panic!("{}: {e}", exp.scene.kind()))
}

/// The bytes of `r` as result.json and of the log at `log`.
fn result_and_log_bytes(r: &RunResult, log: &std::path::Path) -> (Vec<u8>, Vec<u8>) {
    (
        serde_json::to_vec_pretty(r).unwrap(),
        std::fs::read(log).unwrap(),
    )
}

fn smoke_clumps(scene: &str) -> Experiment {
    let text = common::text(&format!("experiments/{scene}/smoke-clumps.json"));
    parse_experiment(&text).unwrap()
}

/// Every lab scene's smoke-clumps run: it measures its headline angle and
/// its log holds particle frames.
fn check_smoke_run(scene: &str, headline: &str, r: &RunResult, log: &std::path::Path) {
    let angle = r.measurements[headline];
    assert!(
        angle.is_finite() && angle > 5.0 && angle < 80.0,
        "{scene}: {headline} = {angle}"
    );
    let frames = inspect_file(log)
        .unwrap()
        .channels
        .iter()
        .find(|c| c.topic == "/particles")
        .map_or(0, |c| c.messages);
    eprintln!(
        "{scene}: {} grains, kernel {}, {frames} frames, warnings {:?}",
        r.measurements["particles"], r.kernel, r.warnings
    );
    assert!(frames > 0, "{scene}: no particle frames in the log");
    assert!(r.measurements["particles"] > 20.0, "{scene}");
}

/// The drum of `scene_drum`'s friction test (30 mm slice of 1 mm grains, no
/// rolling friction), as spheres or paired spheres of aspect 1.3.
fn drum(paired: bool, seed: u64) -> Experiment {
    let shape = if paired {
        r#", "shape": { "kind": "paired_spheres", "aspect_ratio": 1.3 }"#
    } else {
        ""
    };
    let text = format!(
        r#"{{
  "schema_version": 1, "physics_version": 1, "profile": "smoke",
  "scene": {{ "kind": "drum", "inner_diameter_m": 0.03, "length_m": 0.1, "fill_fraction": 0.3,
             "rpm": 30, "rotation_time_s": 1.0, "standing_time_s": 0.2, "wall_material": "steel",
             "periodic_slice_m": 0.006, "settle_max_s": 0.3, "sample_interval_s": 0.02 }},
  "material": {{ "particle": {{ "density_kg_m3": 2500, "youngs_modulus_pa": 5e6, "poisson_ratio": 0.3,
                              "size": {{ "kind": "monodisperse", "radius_m": 0.001 }}{shape} }},
                 "walls": {{ "steel": {{ "youngs_modulus_pa": 2e11, "poisson_ratio": 0.3, "density_kg_m3": 7850 }} }} }},
  "contact": {{ "model": {{ "normal": "hertz", "rolling": "cdt" }},
               "particle_particle": {{ "restitution": 0.5, "static_friction": 0.5, "rolling_friction": 0.0, "surface_energy_j_m2": 0 }},
               "particle_wall": {{ "steel": {{ "restitution": 0.5, "static_friction": 0.8, "rolling_friction": 0.1, "surface_energy_j_m2": 0 }} }} }},
  "seeds": {{ "design_seed": 0, "sample_index": 0, "packing_seed": {seed} }},
  "time_step": {{ "rayleigh_fraction": 0.2, "design_impact_speed_m_s": 0.3 }}
}}"#
    );
    parse_experiment(&text).unwrap()
}

#[test]
fn lab_scenes_run_with_paired_spheres_alike_on_two_threads_and_paired_spheres_stand_steeper() {
    let tmp = tempfile::tempdir().unwrap();
    // The five smoke runs and the four drum runs, two at a time.
    enum Job {
        Smoke(&'static str, &'static str),
        Drum(bool, u64),
    }
    enum Done {
        /// A smoke run: its scene, result.json and run.mcap bytes.
        Smoke(&'static str, Vec<u8>, Vec<u8>),
        /// A drum run: paired, seed, dynamic angle.
        Drum(bool, u64, f64),
    }
    let mut jobs: Vec<Job> = SCENES.iter().map(|&(s, h)| Job::Smoke(s, h)).collect();
    jobs.extend([(false, 1), (false, 2), (true, 1), (true, 2)].map(|(p, s)| Job::Drum(p, s)));
    let done: Vec<Done> = jobs
        .par_iter()
        .map(|job| match *job {
            Job::Smoke(scene, headline) => {
                let log = tmp.path().join(format!("{scene}.mcap"));
                let r = run_alone(&smoke_clumps(scene), Some(&log));
                check_smoke_run(scene, headline, &r, &log);
                let (result, log) = result_and_log_bytes(&r, &log);
                Done::Smoke(scene, result, log)
            }
            Job::Drum(paired, seed) => {
                let r = run_alone(&drum(paired, seed), None);
                assert_eq!(r.measurements["particles"], 182.0, "same grain count");
                Done::Drum(paired, seed, r.measurements["dynamic_angle_deg"])
            }
        })
        .collect();
    // The smoke runs again on two threads, one at a time: the same bytes.
    for d in &done {
        let Done::Smoke(scene, result_1, log_1) = d else {
            continue;
        };
        let log = tmp.path().join(format!("{scene}-2.mcap"));
        let r = run_on(2, &smoke_clumps(scene), Some(&log));
        let (result_2, log_2) = result_and_log_bytes(&r, &log);
        assert!(
            *result_1 == result_2,
            "{scene}: result.json differs between 1 and 2 threads"
        );
        assert!(
            *log_1 == log_2,
            "{scene}: run.mcap differs between 1 and 2 threads"
        );
    }
    let drums: Vec<(bool, u64, f64)> = done
        .iter()
        .filter_map(|d| match *d {
            Done::Drum(paired, seed, angle) => Some((paired, seed, angle)),
            Done::Smoke(..) => None,
        })
        .collect();
    // Shape interlocking holds a slope that rolling spheres cannot (no
    // rolling friction here): measured 2026-11-27 at seeds 1 and 2, dynamic
    // angle 26.1° and 28.0° for spheres, 39.1° and 37.4° for paired spheres.
    eprintln!("{drums:?}");
    let steepest_sphere = drums
        .iter()
        .filter(|r| !r.0)
        .map(|r| r.2)
        .fold(f64::MIN, f64::max);
    let flattest_pair = drums
        .iter()
        .filter(|r| r.0)
        .map(|r| r.2)
        .fold(f64::MAX, f64::min);
    assert!(
        flattest_pair > steepest_sphere + 5.0,
        "paired spheres {flattest_pair:.1}° vs spheres {steepest_sphere:.1}°"
    );
}

/// Aspect ratios of paired spheres from near a sphere to the largest below 2
/// (validation allows (1, 2)).
const ASPECT_RATIOS: [f64; 8] = [1.01, 1.1, 1.3, 1.5, 1.7, 1.9, 1.99, 1.999999];

/// The layout of experiments/drum/smoke-clumps.json as the drum scene builds
/// it: 182 spheres of radius 1.5 mm on the jittered face-centred lattice
/// (spacing 1.05 diameters) in the square inscribed in the 45 mm drum's
/// cross-section, a 9 mm slice periodic along the axis (y) — random addition
/// cannot reach the count there — inside the drum's cylinder and domain.
fn drum_smoke_layout() -> (Vec<ParticleInit>, Vec<Wall>, Domain) {
    let (r_drum, d, slice) = (0.0225, 0.003, 0.009);
    let (half, margin) = (0.5 * slice, 4.0 * d);
    let wall = Wall::cylinder(
        Vec3::new(0.0, -half - 2.0 * margin, 0.0),
        Vec3::y(),
        r_drum,
        slice + 4.0 * margin,
        0,
    )
    .unwrap();
    let extent = r_drum + margin;
    let domain = Domain::new(
        Vec3::new(-extent, -half, -extent),
        Vec3::new(extent, half, extent),
        [false, true, false],
    )
    .unwrap();
    let side = r_drum / 2f64.sqrt();
    let spec = PlacementSpec {
        region: Region::Box {
            min_m: Vec3::new(-side, -half, -side),
            max_m: Vec3::new(side, half, side),
        },
        sizes: SizeDistribution::Mono { diameter_m: d },
        target: FillTarget::Count(182),
        seed: 0,
        clearance_m: 0.05 * d,
        velocity_m_s: Vec3::zeros(),
    };
    let placed = place_lattice(&spec, 1.05).unwrap().particles;
    (placed, vec![wall], domain)
}

/// The deepest overlap between members of different clumps (periodic
/// images included) or a member and a wall in `world`, relative to the
/// smaller radius (0 when nothing touches).
fn deepest_overlap(world: &World, walls: &[Wall], domain: &Domain) -> f64 {
    let p = &world.particles;
    let bodies = world.bodies.as_ref().unwrap();
    let mut deepest: f64 = 0.0;
    for i in 0..p.len() {
        for wall in walls {
            if let Some(c) = wall.contact_at(0.0, p.position[i], p.radius[i], 0.0) {
                deepest = deepest.max(c.overlap_m / p.radius[i]);
            }
        }
        let body = bodies.body_of_member(p.id[i]);
        for j in i + 1..p.len() {
            if bodies.body_of_member(p.id[j]) == body {
                continue;
            }
            let gap =
                domain.min_image(p.position[j] - p.position[i]).norm() - p.radius[i] - p.radius[j];
            deepest = deepest.max(-gap / p.radius[i].min(p.radius[j]));
        }
    }
    deepest
}

#[test]
fn paired_spheres_start_within_the_overlap_bound_up_to_the_largest_aspect_ratio() {
    let (placed, walls, domain) = drum_smoke_layout();
    let bound = HealthLimits::default().max_overlap_ratio;
    let mut moved_at = Vec::new();
    for aspect in ASPECT_RATIOS {
        let shape = ClumpTemplate::paired_spheres(aspect).unwrap().shape(1.0);
        let grains = Grains::new(Some(shape), 60.0, 0);
        let world = grains.world(&placed, walls.clone(), domain).unwrap();
        let warnings = grains.warnings();
        let bodies = world.bodies.as_ref().unwrap();
        assert_eq!(bodies.len(), placed.len(), "aspect {aspect}");
        // Each clump stays near the sphere it replaces.
        for (sphere, centre) in placed.iter().zip(&bodies.position) {
            let moved = (centre - sphere.position).norm() / sphere.radius_m;
            assert!(
                moved <= RELOCATION_REACH,
                "aspect {aspect}: moved {moved} radii"
            );
        }
        let deepest = deepest_overlap(&world, &walls, &domain);
        assert!(deepest <= bound, "aspect {aspect}: overlap {deepest:.3}");
        if warnings.iter().any(|w| w.contains("were moved")) {
            // A moved layout is free of overlaps.
            assert!(deepest <= 0.0, "aspect {aspect}: overlap {deepest:.3}");
            assert_eq!(warnings.len(), 1, "aspect {aspect}: {warnings:?}");
            assert!(!warnings[0].contains("no free place"), "{warnings:?}");
            moved_at.push(aspect);
        }
        if aspect == 1.3 {
            // A layout that could start is left as it was placed before
            // misfits were moved (the committed 1.3 results depend on it).
            assert_eq!(
                warnings,
                [
                    "particle shape: 12 clumps found no orientation free of overlaps in 400 \
                  tries and started overlapping a neighbour or wall by up to 0.082 of a \
                  member radius (a layout too dense for the shape)"
                ]
            );
        }
    }
    // Measured 2026-11-28: moved at 1.9, 1.99 and 1.999999 (up to 1.7 the
    // deepest misfit stays within the bound).
    eprintln!("moved at aspect ratios {moved_at:?}");
    assert!(
        moved_at.contains(&1.999999) && !moved_at.contains(&1.3),
        "moved at {moved_at:?}"
    );
}

/// `scene`'s smoke-clumps manifest with paired spheres of aspect ratio
/// 1.999999, its scene fields `cut` replaced (a run of a few hundredths of
/// a second).
fn near_aspect_two(scene: &str, cut: serde_json::Value) -> Experiment {
    let mut v: serde_json::Value = serde_json::from_str(&common::text(&format!(
        "experiments/{scene}/smoke-clumps.json"
    )))
    .unwrap();
    v["material"]["particle"]["shape"]["aspect_ratio"] = json!(1.999999);
    for (key, value) in cut.as_object().unwrap() {
        v["scene"][key] = value.clone();
    }
    parse_experiment(&v.to_string()).unwrap()
}

#[test]
fn drum_and_hopper_of_paired_spheres_near_aspect_two_start_with_their_misfits_moved() {
    let runs = [
        near_aspect_two(
            "drum",
            json!({ "settle_max_s": 0.02, "rotation_time_s": 0.02, "standing_time_s": 0.02,
                    "sample_interval_s": 0.01 }),
        ),
        near_aspect_two(
            "hopper",
            json!({ "settle_max_s": 0.02, "max_time_s": 0.05, "no_discharge_stop_s": 0.02,
                    "sample_interval_s": 0.01 }),
        ),
    ];
    for exp in &runs {
        let r = run_alone(exp, None);
        let scene = exp.scene.kind();
        assert!(r.measurements["steps"] > 0.0, "{scene}");
        let shape: Vec<_> = r
            .warnings
            .iter()
            .filter(|w| w.starts_with("particle shape"))
            .collect();
        assert!(
            shape.len() == 1
                && shape[0].contains("were moved")
                && !shape[0].contains("no free place"),
            "{scene}: {shape:?}"
        );
    }
}
