//! The golden chain: `repose calibrate` on the smoke study
//! (experiments/calibrate-smoke/study.json) with real DEM runs — sample → batch
//! (12 drum runs) → train → search → verify (3 candidates × the 30 rpm
//! calibration drum and the 15 rpm verification drum) — in a temporary store,
//! once with one batch worker and once with two. Both stores must agree byte
//! for byte, and the stage tables must match the CSVs pinned in
//! golden/calibrate_smoke/: the design, the simulated-angle table (he2019's
//! Table A1 equivalent), the hidden-size sweep (Fig. 12), the clusters
//! (Table 2), the verification table (Table 3, with the one acceptance
//! rule's verdicts) and its per-seed runs.
//!
//! `REPOSE_BLESS=1 cargo test --release --test calibrate_golden` rewrites the
//! pinned files (after the determinism check); review their diff in the commit.
//! About 30 s of CPU per chain.

mod common;

use std::path::{Path, PathBuf};

use repose::commands::{calibrate, CalibrateFlags};
use repose::exec::Executor;
use repose::manifest::parse_study;
use repose::scenes::plan::Limits;
use repose::study::dir::Stage;
use repose::study::dir::StudyDir;

const STUDY: &str = "experiments/calibrate-smoke/study.json";
const GOLDEN_DIR: &str = "golden/calibrate_smoke";
/// Clusters verified, as `repose calibrate`'s default (`--candidates 3`).
const CANDIDATES: usize = 3;

/// Relative tolerance for floating-point cells (|pinned − now| ≤ TOL ·
/// max(|pinned|, 1)). On one platform the chain is bit-identical (every
/// random draw is a seeded ChaCha stream, each DEM run is single-threaded and
/// deterministic, and this test checks that one and two workers agree byte for
/// byte), so any difference is a change of behaviour. The band only absorbs
/// last-digit differences of `exp`/`powf` between math libraries in the
/// arithmetic stages. A DEM run amplifies any last-bit difference (granular
/// flow is chaotic), so on a platform whose libm differs the angles may move
/// beyond it: re-bless there and review the diff. Ids, indices, counts,
/// hidden sizes, groups and verdicts are compared exactly ([`EXACT`]).
const TOL: f64 = 1e-9;

/// The six pinned tables: file name in golden/ and path in the study directory.
fn tables(dir: &StudyDir) -> [(&'static str, PathBuf); 6] {
    [
        ("design.csv", dir.stage(Stage::Sample).join("design.csv")),
        ("angles.csv", dir.stage(Stage::Batch).join("angles.csv")),
        ("sweep.csv", dir.stage(Stage::Train).join("sweep.csv")),
        (
            "clusters.csv",
            dir.stage(Stage::Search).join("clusters.csv"),
        ),
        (
            "verification.csv",
            dir.stage(Stage::Verify).join("verification.csv"),
        ),
        ("runs.csv", dir.stage(Stage::Verify).join("runs.csv")),
    ]
}

/// Runs `repose calibrate STUDY --jobs <jobs>` into `store`; returns its study directory.
fn chain(store: &Path, jobs: usize) -> StudyDir {
    let path = common::root().join(STUDY);
    let mut out = Vec::new();
    calibrate(
        store,
        Some(&path),
        &Executor::local(jobs, Limits::default()),
        Some(CANDIDATES),
        CalibrateFlags::default(),
        &mut out,
    )
    .unwrap_or_else(|e| panic!("calibrate failed: {e}\n{}", String::from_utf8_lossy(&out)));
    eprintln!("{}", String::from_utf8_lossy(&out));
    let study = parse_study(&std::fs::read_to_string(&path).unwrap()).unwrap();
    StudyDir::new(store, &study, &path)
}

/// Columns compared exactly: ids, indices, counts, hidden sizes, cluster
/// groups and sizes, scene names, statuses and verdicts.
const EXACT: [&str; 18] = [
    "verdict",
    "unresolved",
    "seeds_to_decide",
    "seeds",
    "measured",
    "replicate",
    "packing_seed",
    "index",
    "experiment_id",
    "status",
    "hidden",
    "lm_epochs",
    "lm_stop",
    "kept",
    "group",
    "size",
    "scene",
    "failure",
];

#[test]
fn the_smoke_chain_is_deterministic_and_matches_the_golden_tables() {
    let tmp = tempfile::tempdir().unwrap();
    let one = tmp.path().join("one-worker");
    let two = tmp.path().join("two-workers");
    let dir = chain(&two, 2);
    chain(&one, 1);
    // Every file of the two stores — study outputs, lineage, manifests, each
    // run's result.json and MCAP log — is byte-identical.
    common::assert_same_stores(&one, &two);
    let bless = common::blessing();
    for (name, path) in tables(&dir) {
        let now = std::fs::read_to_string(&path).unwrap();
        if bless {
            let golden = common::root().join(GOLDEN_DIR);
            std::fs::create_dir_all(&golden).unwrap();
            std::fs::write(golden.join(name), &now).unwrap();
        } else {
            common::compare_golden(GOLDEN_DIR, name, &now, &EXACT, TOL);
        }
    }
}
