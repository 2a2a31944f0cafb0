//! `repose tradeoff` on a tiny drum: the plan, the bookkeeping, the sanity
//! properties the issue names, and the pinned table.

mod common;

use std::process::Command;

use repose::manifest::read_experiment;
use repose::store::Store;
use repose::study::sweeps::tradeoff::plan::{plan, Knob, PlanError};
use repose::study::sweeps::tradeoff::{report, run, summarise};

const GOLDEN: &str = "golden/tradeoff_drum_tiny.csv";

fn base() -> repose::manifest::Experiment {
    read_experiment(&common::root().join("experiments/tradeoff/drum_tiny.json")).unwrap()
}

fn step_knob() -> Knob {
    Knob::preset("rayleigh_fraction")
        .unwrap()
        .with_values(vec![0.05, 0.1, 0.2])
}

#[test]
fn a_step_fraction_beyond_the_stable_limit_is_refused_before_running() {
    // The engine's rule (dem::timestep): fractions above 0.5 of the Rayleigh
    // time are unstable; validation refuses them, so the plan fails up front.
    let knob = step_knob().with_values(vec![0.2, 0.6]);
    match plan(&base(), &[knob], 2) {
        Err(PlanError::Invalid {
            knob,
            value,
            errors,
        }) => {
            assert_eq!((knob, value), ("rayleigh_fraction", 0.6));
            assert!(
                errors.to_string().contains("time_step.rayleigh_fraction"),
                "{errors}"
            );
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert!(matches!(
        plan(&base(), &[step_knob()], 1),
        Err(PlanError::Replicates(1))
    ));
}

#[test]
fn the_stop_knobs_edit_only_the_at_rest_block() {
    let base = base();
    let knobs = [
        Knob::preset("stop_threshold").unwrap(),
        Knob::preset("stop_hold").unwrap(),
    ];
    let points = plan(&base, &knobs, 2).unwrap();
    let labels: Vec<String> = points.iter().map(|p| p.label()).collect();
    assert_eq!(
        labels,
        [
            "reference",
            "stop_threshold=1",
            "stop_threshold=10",
            "stop_hold=1",
            "stop_hold=0.5"
        ]
    );
    // drum_tiny omits `at_rest`, so its criterion is the default (1e-6 m g d
    // for 0.05 s); the reference takes both finest presets (0.1x, 2x).
    let (f0, h0) = (1e-6, 0.05);
    let expected = [
        (f0 * 0.1, h0 * 2.0),
        (f0, h0 * 2.0),
        (f0 * 10.0, h0 * 2.0),
        (f0 * 0.1, h0),
        (f0 * 0.1, h0 * 0.5),
    ];
    for (p, (fraction, hold)) in points.iter().zip(expected) {
        for (r, e) in p.replicates.iter().enumerate() {
            let rest = e.at_rest;
            assert!(
                (rest.kinetic_energy_fraction / fraction - 1.0).abs() < 1e-12
                    && (rest.hold_s / hold - 1.0).abs() < 1e-12,
                "{}: {rest:?}",
                p.label()
            );
            // Nothing but the criterion and the packing seed moved.
            let mut back = e.clone();
            back.at_rest = base.at_rest;
            back.seeds.packing_seed -= r as u64;
            assert_eq!(back, base, "{}", p.label());
        }
    }
    // Every point is a distinct experiment.
    let mut ids: Vec<_> = points.iter().map(|p| p.replicates[0].id()).collect();
    ids.sort();
    ids.dedup();
    assert_eq!(ids.len(), points.len());
}

#[test]
fn a_stop_knob_on_a_scene_that_never_settles_is_refused() {
    let pair =
        read_experiment(&common::root().join("experiments/validation/pair_hertz_rigid_wall.json"))
            .unwrap();
    match plan(&pair, &[Knob::preset("stop_hold").unwrap()], 2) {
        Err(PlanError::Invalid { knob, errors, .. }) => {
            assert_eq!(knob, "stop_hold");
            assert!(errors.to_string().contains("at_rest"), "{errors}");
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn sweep_of_the_step_fraction_on_a_tiny_drum() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let points = plan(&base(), &[step_knob()], 2).unwrap();
    let labels: Vec<String> = points.iter().map(|p| p.label()).collect();
    assert_eq!(
        labels,
        [
            "reference",
            "rayleigh_fraction=0.1",
            "rayleigh_fraction=0.2"
        ]
    );
    let outcomes = run(&store, &points, &common::executor(2)).unwrap();
    let rows = summarise(&points, &outcomes);
    for r in &rows {
        assert_eq!((r.replicates, r.healthy), (2, 2), "{r:?}");
        let a = r.angle.unwrap();
        assert!(a.mean > 5.0 && a.mean < 60.0, "implausible angle {a:?}");
    }
    // The reference's error against itself is exactly zero.
    assert_eq!(rows[0].error_deg.unwrap().0, 0.0);
    // Cost grows as the step fraction shrinks: the step is min(f · T_R, t_c/20)
    // (dem::timestep), so it never shrinks with f, and wherever it is smaller
    // the same simulated time takes more steps. Here f = 0.05 and 0.1 are
    // bound by T_R (the step halves), so that cost at least nearly doubles.
    let dt: Vec<f64> = rows.iter().map(|r| r.dt_s.unwrap()).collect();
    let cost: Vec<f64> = rows.iter().map(|r| r.particle_steps.unwrap()).collect();
    assert!(dt[0] <= dt[1] && dt[1] <= dt[2], "{dt:?}");
    assert!((dt[1] / dt[0] - 2.0).abs() < 1e-9, "{dt:?}");
    assert!(cost[0] > 1.8 * cost[1], "{cost:?}");
    assert!(cost[1] >= cost[2], "{cost:?}");
    assert!(dt[2] == dt[1] || cost[1] > cost[2], "{dt:?} {cost:?}");
    // At least the cheapest point is on the front (nothing is cheaper).
    assert!(rows.iter().any(|r| r.pareto));

    // Re-running the sweep computes nothing new (cached by id).
    let again = summarise(
        &points,
        &run(&store, &points, &common::executor(1)).unwrap(),
    );
    for (a, b) in rows.iter().zip(&again) {
        assert_eq!(a.ids, b.ids);
        assert_eq!(a.wall_time_s, b.wall_time_s, "a cached run kept its timing");
    }

    // Pinned: ids, counts and angles (deterministic; 1e-6° allows only libm
    // differences between platforms). Wall time columns are not compared.
    let deterministic = |csv: &str| -> Vec<Vec<String>> {
        csv.lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                [0, 3, 4, 5, 6, 7, 9, 14]
                    .iter()
                    .map(|&i| f[i].to_string())
                    .collect()
            })
            .collect()
    };
    let now = report::csv(&rows);
    let golden = common::root().join(GOLDEN);
    if std::env::var_os("REPOSE_BLESS").is_some() {
        let pinned: String = deterministic(&now)
            .iter()
            .map(|r| r.join(",") + "\n")
            .collect();
        std::fs::write(&golden, pinned).unwrap();
    }
    let pinned = std::fs::read_to_string(&golden).expect("golden file (REPOSE_BLESS=1 writes it)");
    let pinned: Vec<Vec<String>> = pinned
        .lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    let now = deterministic(&now);
    assert_eq!(pinned.len(), now.len());
    for (p, n) in pinned.iter().zip(&now) {
        for (col, (a, b)) in p.iter().zip(n).enumerate() {
            match (a.parse::<f64>(), b.parse::<f64>()) {
                (Ok(x), Ok(y)) if col >= 3 => assert!((x - y).abs() < 1e-6, "{p:?} vs {n:?}"),
                _ => assert_eq!(a, b, "{p:?} vs {n:?}"),
            }
        }
    }
    let svg = report::svg(&rows, "t");
    assert!(svg.starts_with("<svg") && svg.contains("rayleigh_fraction=0.2"));
}

#[test]
fn cli_rejects_an_unknown_knob_naming_it() {
    let out = Command::new(env!("CARGO_BIN_EXE_repose"))
        .args([
            "tradeoff",
            "experiments/tradeoff/drum_tiny.json",
            "--knobs",
            "colour",
        ])
        .current_dir(common::root())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("`colour` is not a knob"), "{err}");
}
