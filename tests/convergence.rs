//! `repose convergence` on a tiny drum: the levels are ordinary cached
//! experiments (the base level is the base manifest), the stage's outputs
//! do not depend on the number of workers, a second call runs nothing, and
//! the analysis is the trend fit of the runs it read.

mod common;

use std::process::Command;

use repose::manifest::read_experiment;
use repose::stats::trend::weighted_line;
use repose::store::Store;
use repose::study::sweeps::convergence::plan::plan;
use repose::study::sweeps::convergence::{sweep, Analysis};

const MANIFEST: &str = "experiments/tradeoff/drum_tiny.json";

/// The CSV without the measured columns (CPU and wall seconds per run).
fn deterministic_columns(csv: &str) -> String {
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let drop: Vec<usize> = ["cpu_s_per_run", "wall_s_per_run"]
        .iter()
        .map(|c| header.iter().position(|h| h == c).unwrap())
        .collect();
    csv.lines()
        .map(|l| {
            l.split(',')
                .enumerate()
                .filter(|(i, _)| !drop.contains(i))
                .map(|(_, c)| c)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_tiny_drum_over_three_sizes() {
    let manifest = common::root().join(MANIFEST);
    let base = read_experiment(&manifest).unwrap();
    let plan = plan(&base, &[0.8, 1.0, 0.9], 2, None, Some(0.0001)).unwrap();
    let analysis = Analysis {
        responses: vec!["dynamic_angle_deg".into()],
        tolerance: Some(2.0),
    };
    let mut csvs = Vec::new();
    for jobs in [1, 2] {
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::open(tmp.path()).unwrap();
        let out = tmp.path().join("out");
        let done = sweep(
            &store,
            &base,
            &manifest,
            &plan,
            &analysis,
            &common::executor(jobs),
            &out,
        )
        .unwrap();
        let c = &done.convergence;
        // Coarsest first; the base level's first run is the base manifest.
        let factors: Vec<f64> = c.levels.iter().map(|l| l.factor).collect();
        assert_eq!(factors, [1.0, 0.9, 0.8]);
        assert_eq!(c.levels[0].ids[0], base.id());
        for level in &c.levels {
            assert_eq!(level.completed, 2, "{:?}", level.failure);
            // d/D is the drum's own figure: particle diameter / drum diameter.
            let x = level.x.unwrap();
            assert!((x - 2.0 * level.radius_m / 0.03).abs() < 1e-12, "{x}");
            assert!(level.cpu_s.iter().all(|s| *s > 0.0));
            assert!(level.planned_particle_steps.is_some() && level.particle_steps.is_some());
        }
        // Finer particles: more of them, more CPU.
        assert!(c.levels[2].particles > c.levels[0].particles);
        // The trend is the weighted line through the runs the table holds.
        let (mut x, mut y, mut w) = (vec![], vec![], vec![]);
        for level in &c.levels {
            let m = level.responses["dynamic_angle_deg"].unwrap();
            for v in &level.values["dynamic_angle_deg"] {
                x.push(level.x.unwrap());
                y.push(*v);
                w.push(1.0 / (m.std * m.std));
            }
        }
        let line = weighted_line(&x, &y, &w).unwrap();
        let trend = &c.trends[0];
        assert_eq!(trend.weighting, "inverse level variance");
        assert_eq!(trend.fit.as_ref().unwrap(), &line);
        let real_x = c.real_x.unwrap();
        assert!((real_x - 2.0 * 0.0001 / 0.03).abs() < 1e-12);
        let at = trend.at_real.unwrap();
        assert_eq!(at.mean, line.intercept + line.slope * real_x);
        // A second call finds every run in the store.
        let again = sweep(
            &store,
            &base,
            &manifest,
            &plan,
            &analysis,
            &common::executor(jobs),
            &out,
        )
        .unwrap();
        assert_eq!(again.convergence.levels[2].ids, c.levels[2].ids);
        for name in ["convergence.csv", "convergence.md", "convergence.svg"] {
            assert!(out.join(name).is_file(), "{name}");
            assert!(out.join(format!("{name}.lineage.json")).is_file(), "{name}");
        }
        let csv = std::fs::read_to_string(out.join("convergence.csv")).unwrap();
        csvs.push(deterministic_columns(&csv));
    }
    assert_eq!(csvs[0], csvs[1], "1 and 2 workers give the same table");
}

#[test]
fn cli_names_a_bad_rule_and_a_bad_size() {
    let run = |args: &[&str]| {
        let tmp = tempfile::tempdir().unwrap();
        Command::new(env!("CARGO_BIN_EXE_repose"))
            .current_dir(common::root())
            .arg("--store")
            .arg(tmp.path())
            .arg("convergence")
            .arg(MANIFEST)
            .args(args)
            .output()
            .unwrap()
    };
    let out = run(&["--rule", "bond"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--rule `bond`") && err.contains("constant_bond"),
        "{err}"
    );
    let out = run(&["--sizes", "1,0"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("size factor 0"), "{err}");
}
