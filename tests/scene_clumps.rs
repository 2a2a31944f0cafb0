//! Paired-sphere clumps in the lab scenes: every lab scene's smoke manifest
//! runs with `paired_spheres` (aspect ratio 1.3) and logs every member
//! sphere, and paired spheres stand steeper than spheres at the same contact
//! parameters, seed for seed.
//!
//! One test runs every simulation, two at a time, each on one thread of its
//! own: several engines sharing two cores with teams of threads each would
//! spin against each other (this file took 190 s of CI that way, against
//! about 70 s of work).

mod common;

use rayon::prelude::*;
use repose::log::inspect::inspect_file;
use repose::manifest::{parse_experiment, Experiment};
use repose::scenes::run_experiment;
use repose::store::RunResult;

const SCENES: [(&str, &str); 5] = [
    ("funnel_pile", "angle_deg"),
    ("baffle_lift", "static_angle_deg"),
    ("drum", "dynamic_angle_deg"),
    ("static_pile", "profile_angle_deg"),
    ("hopper", "upper_angle_deg"),
];

/// Runs `exp` on one thread (with its log at `log`).
fn run_alone(exp: &Experiment, log: Option<&std::path::Path>) -> RunResult {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| run_experiment(exp, log))
        .unwrap_or_else(|e| panic!("{}: {e}", exp.scene.kind()))
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
fn lab_scenes_run_with_paired_spheres_and_paired_spheres_stand_steeper() {
    let tmp = tempfile::tempdir().unwrap();
    // The five smoke runs and the four drum runs, two at a time.
    enum Job {
        Smoke(&'static str, &'static str),
        Drum(bool, u64),
    }
    let mut jobs: Vec<Job> = SCENES.iter().map(|&(s, h)| Job::Smoke(s, h)).collect();
    jobs.extend([(false, 1), (false, 2), (true, 1), (true, 2)].map(|(p, s)| Job::Drum(p, s)));
    let drums: Vec<(bool, u64, f64)> = jobs
        .par_iter()
        .filter_map(|job| match *job {
            Job::Smoke(scene, headline) => {
                let log = tmp.path().join(format!("{scene}.mcap"));
                let r = run_alone(&smoke_clumps(scene), Some(&log));
                check_smoke_run(scene, headline, &r, &log);
                None
            }
            Job::Drum(paired, seed) => {
                let r = run_alone(&drum(paired, seed), None);
                assert_eq!(r.measurements["particles"], 182.0, "same grain count");
                Some((paired, seed, r.measurements["dynamic_angle_deg"]))
            }
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
