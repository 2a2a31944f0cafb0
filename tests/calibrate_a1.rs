//! he2019's printed Table A1 (experiments/he2019-table-a1/): the GA-BP sweep
//! reaches the paper's R² ≥ 0.9 on rows 81–120, the sweep is pinned in golden/,
//! the paper's own printed predictions score 0.896 by Eq. 7, and the design
//! diagnostics flag the table as degenerate.

mod common;

use std::path::{Path, PathBuf};

use repose::report::table::Table;
use repose::stats::metrics::r_squared;
use repose::study::stages::design::diagnose_table;
use repose::study::stages::fit_network::{train_table, TableSpec, TrainOptions, TrainOutcome};
use repose::surrogate::ga_bp::{TrainSettings, DEFAULT_TRAIN_FRACTION};

const TABLE: &str = "experiments/he2019-table-a1/table_a1.csv";
const GOLDEN: &str = "golden/he2019_table_a1_sweep.csv";
/// R² tolerance against the golden sweep. On one platform the sweep is
/// bit-identical (each hidden size is a pure function of its seed); the band
/// only absorbs last-digit differences of `exp` between math libraries. A
/// change of the optimisation path moves R² by far more and must be reviewed
/// and re-blessed.
const R2_TOLERANCE: f64 = 1e-6;

/// The four independent inputs: the printed gamma column repeats mu_pw.
fn inputs() -> Vec<String> {
    ["e_pp", "mu_pp", "e_pw", "mu_pw"]
        .map(String::from)
        .to_vec()
}

fn table() -> PathBuf {
    common::root().join(TABLE)
}

fn options() -> TrainOptions {
    TrainOptions {
        settings: TrainSettings::with_seed(0),
        train_fraction: DEFAULT_TRAIN_FRACTION,
    }
}

fn train(out: &Path) -> TrainOutcome {
    let inputs = inputs();
    let path = table();
    let spec = TableSpec {
        path: &path,
        inputs: &inputs,
        target: "aor",
        reference: Some("pred_aor"),
    };
    train_table(&spec, out, &options()).unwrap()
}

#[test]
fn the_sweep_reaches_r2_0_9_and_matches_the_golden_file() {
    let tmp = tempfile::tempdir().unwrap();
    let outcome = train(tmp.path());
    // he2019 §3.4: 80 training and 40 validation rows, R² ≥ 0.9 required.
    assert_eq!((outcome.train_rows, outcome.validation_rows), (80, 40));
    let sizes: Vec<usize> = outcome.sweep.rows.iter().map(|r| r.hidden).collect();
    assert_eq!(sizes, (3..=12).collect::<Vec<_>>(), "Eq. 6's sweep 3..12");
    let best = &outcome.sweep.rows[outcome.sweep.best];
    for r in &outcome.sweep.rows {
        eprintln!(
            "h = {:>2}: train R² {:.4}, validation R² {:.4}",
            r.hidden, r.train_r2, r.validation_r2
        );
        assert!(r.validation_r2 <= best.validation_r2);
    }
    assert!(
        best.validation_r2 >= 0.90,
        "best validation R² {} (h = {})",
        best.validation_r2,
        best.hidden
    );

    let current = std::fs::read_to_string(tmp.path().join("sweep.csv")).unwrap();
    let golden_path = common::root().join(GOLDEN);
    if std::env::var_os("REPOSE_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&golden_path, &current).unwrap();
        return;
    }
    let pinned = Table::parse(&std::fs::read_to_string(&golden_path).unwrap()).unwrap();
    let now = Table::parse(&current).unwrap();
    assert_eq!(pinned.header, now.header);
    assert_eq!(pinned.rows.len(), now.rows.len());
    let col = |t: &Table, name: &str| t.index(name).unwrap();
    for (p, c) in pinned.rows.iter().zip(&now.rows) {
        assert_eq!(p[col(&pinned, "hidden")], c[col(&now, "hidden")]);
        assert_eq!(
            p[col(&pinned, "kept")],
            c[col(&now, "kept")],
            "kept size moved"
        );
        for name in ["train_r2", "validation_r2"] {
            let a: f64 = p[col(&pinned, name)].parse().unwrap();
            let b: f64 = c[col(&now, name)].parse().unwrap();
            assert!(
                (a - b).abs() <= R2_TOLERANCE,
                "h = {}: {name} {b} vs pinned {a} in {GOLDEN}; if intended, rerun with REPOSE_BLESS=1 and review the diff",
                p[0]
            );
        }
    }
}

#[test]
fn the_papers_printed_predictions_score_0_896_by_eq_7() {
    // he2019 §3.4 states R² = 0.93 (and 0.924 in Fig. 13a) for its validation
    // predictions; Eq. 7 applied to the printed pred_aor column of rows 81–120
    // gives 0.8962 (computed independently with a few lines of Python while
    // writing this test).
    let path = table();
    let t = Table::read(&path).unwrap();
    let aor = t.numbers(&path, "aor").unwrap();
    let set = t.index("set").unwrap();
    let pred = t.index("pred_aor").unwrap();
    let (mut y, mut p) = (Vec::new(), Vec::new());
    for (i, row) in t.rows.iter().enumerate() {
        if row[set] == "valid" {
            assert!(i >= 80, "validation rows are 81–120");
            y.push(aor[i]);
            p.push(row[pred].parse::<f64>().unwrap());
        }
    }
    assert_eq!(y.len(), 40);
    let r2 = r_squared(&y, &p).unwrap();
    assert!((r2 - 0.8962).abs() < 5e-5, "{r2}");
    // The train stage reports the same number beside its own sweep.
    let tmp = tempfile::tempdir().unwrap();
    assert_eq!(train(tmp.path()).reference_r2, Some(r2));
}

#[test]
fn the_printed_gamma_column_repeats_mu_pw() {
    let path = table();
    let t = Table::read(&path).unwrap();
    assert_eq!(
        t.numbers(&path, "gamma").unwrap(),
        t.numbers(&path, "mu_pw").unwrap()
    );
}

#[test]
fn the_diagnostics_flag_table_a1_as_degenerate() {
    // Every printed column follows one permutation: rank correlation 1.0
    // between every pair of the five inputs.
    let columns = ["e_pp", "mu_pp", "e_pw", "mu_pw", "gamma"].map(String::from);
    let d = diagnose_table(&table(), Some(&columns), 0.5).unwrap();
    assert!(d.degenerate);
    assert_eq!(d.max_abs_spearman.as_ref().unwrap().r, 1.0);
    for a in 0..5 {
        for b in 0..5 {
            assert_eq!(
                d.spearman[a][b],
                Some(1.0),
                "{} vs {}",
                columns[a],
                columns[b]
            );
        }
    }
    // 10 pairs strongly correlated, plus the degeneracy warning.
    assert_eq!(d.warnings.len(), 11, "{:#?}", d.warnings);
    assert!(d.warnings.last().unwrap().starts_with("degenerate design"));
}

#[test]
fn training_is_bit_identical_on_any_thread_count_and_on_rerun() {
    let run = |threads: usize| {
        let tmp = tempfile::tempdir().unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| train(tmp.path()));
        [
            "sweep.csv",
            "model.json",
            "parity.svg",
            "summary.json",
            "sweep.csv.lineage.json",
        ]
        .map(|f| std::fs::read(tmp.path().join(f)).unwrap())
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert_eq!(one, run(1));
}
