//! The cai2024 smoke study end to end with real DEM runs
//! (experiments/cai2024-smoke/study.json): `repose rsm` runs the Box–Behnken
//! design (4 factors, 3 centre points, one packing seed per point) in the
//! static-pile and drum scenes, fits both responses, finds the joint
//! desirability optimum and verifies it and cai2024's own optimum (2 seeds
//! each); `repose screen` runs the one-factor tests. Once with one worker
//! and once with two: the stores must agree byte for byte, and the tables
//! must match the CSVs pinned in golden/cai2024_smoke/.
//!
//! `REPOSE_BLESS=1 cargo test --release --test cai2024_golden` rewrites the
//! pinned files (after the determinism check); review their diff in the
//! commit. About 3 minutes of CPU per store.

mod common;

use std::path::{Path, PathBuf};

use repose::commands::{rsm, screen};
use repose::exec::Executor;
use repose::scenes::plan::Limits;
use repose::study::plan::design_study::read_design_study;

const STUDY: &str = "experiments/cai2024-smoke/study.json";
const GOLDEN_DIR: &str = "golden/cai2024_smoke";

/// Relative tolerance of floating-point cells. On one platform the study is
/// bit-identical (seeded ChaCha streams, single-threaded deterministic runs,
/// and this test checks that one and two workers agree byte for byte), so
/// any difference is a change of behaviour; the band absorbs last-digit
/// differences of libm between platforms in the analysis. A DEM run
/// amplifies last-bit differences, so where libm differs re-bless and
/// review the diff.
const TOL: f64 = 1e-9;

/// Columns compared exactly: ids, seeds, indices, counts, term names,
/// statuses and verdicts.
const EXACT: [&str; 16] = [
    "verdict",
    "unresolved",
    "seeds_to_decide",
    "point",
    "replicate",
    "packing_seed",
    "static_id",
    "drum_id",
    "status",
    "source",
    "df",
    "rank",
    "response",
    "n",
    "factor",
    "significant",
];

fn study_dir(store: &Path) -> PathBuf {
    let path = common::root().join(STUDY);
    let study = read_design_study(&path).unwrap();
    store
        .join("studies")
        .join(format!("{}-{}", study.name, study.id().short(12)))
}

/// `repose rsm STUDY --jobs <jobs>` into `store`.
fn run_rsm(store: &Path, jobs: usize) {
    let mut out = Vec::new();
    rsm(
        store,
        &common::root().join(STUDY),
        &Executor::local(jobs, Limits::default()),
        false,
        &mut out,
    )
    .unwrap_or_else(|e| panic!("rsm failed: {e}\n{}", String::from_utf8_lossy(&out)));
    eprintln!("{}", String::from_utf8_lossy(&out));
}

#[test]
fn the_smoke_study_is_deterministic_and_matches_the_golden_tables() {
    let tmp = tempfile::tempdir().unwrap();
    let one = tmp.path().join("one-worker");
    let two = tmp.path().join("two-workers");
    run_rsm(&two, 2);
    run_rsm(&one, 1);
    // Every file of the two stores — study outputs, lineage, manifests, each
    // run's result.json and MCAP log — is byte-identical.
    common::assert_same_stores(&one, &two);

    let mut out = Vec::new();
    screen(
        &two,
        &common::root().join(STUDY),
        &Executor::local(2, Limits::default()),
        false,
        &mut out,
    )
    .unwrap_or_else(|e| panic!("screen failed: {e}"));
    let screen_md = String::from_utf8(out).unwrap();
    assert!(
        screen_md.contains("one-way ANOVA") || screen_md.contains("| F |"),
        "{screen_md}"
    );

    let dir = study_dir(&two);
    // Every output's lineage leads back to the study and the sealed runs, and
    // two re-runs reproduce their results byte for byte.
    let mut audit_out = Vec::new();
    repose::commands::audit(&two, &dir, 2, 1, &mut audit_out)
        .unwrap_or_else(|e| panic!("audit: {e}\n{}", String::from_utf8_lossy(&audit_out)));
    let tables = [
        ("responses.csv", dir.join("rsm/responses.csv")),
        (
            "anova_static.csv",
            dir.join("rsm/static_angle_deg/anova.csv"),
        ),
        (
            "anova_dynamic.csv",
            dir.join("rsm/dynamic_angle_deg/anova.csv"),
        ),
        ("optimum.csv", dir.join("rsm/optimum.csv")),
        ("verification.csv", dir.join("verify/verification.csv")),
        ("screen_levels.csv", dir.join("screen/levels.csv")),
    ];
    for svg in [
        "rsm/static_angle_deg/contour.svg",
        "rsm/dynamic_angle_deg/parity.svg",
        "screen/static_angle_deg.svg",
    ] {
        let text = std::fs::read_to_string(dir.join(svg)).unwrap();
        assert!(text.contains("<svg"), "{svg}");
    }
    // 27 design points × 1 replicate, both scenes measured everywhere.
    let responses = std::fs::read_to_string(&tables[0].1).unwrap();
    assert_eq!(responses.lines().count(), 1 + 27, "{responses}");
    if common::blessing() {
        let golden = common::root().join(GOLDEN_DIR);
        std::fs::create_dir_all(&golden).unwrap();
        for (name, path) in &tables {
            std::fs::copy(path, golden.join(name)).unwrap();
        }
    } else {
        for (name, path) in &tables {
            let now = std::fs::read_to_string(path).unwrap();
            common::compare_golden(GOLDEN_DIR, name, &now, &EXACT, TOL);
        }
    }
}
