//! `repose rsm --table`: the response-surface analysis of any CSV table, as
//! a user with data from another code or the lab runs it. The statistics
//! themselves are checked against statsmodels in `src/stats/rsm.rs`; these
//! tests check the command around them: coded and actual-unit tables give
//! the same fit, `--json` carries the whole analysis at full precision,
//! empty responses are skipped and counted, and bad options name what is
//! wrong.

mod common;

use serde_json::Value;

use repose::doe::box_behnken::box_behnken;

/// A 4-factor Box–Behnken with 5 centre points, twice (two "seeds"), and a
/// response y = 40 + 3A − 2B + AB + 1.5C² + a fixed ±0.3 pattern; written
/// coded and in actual units (A in 0.2..0.6, B 0.1..0.5, C 0.3..0.7, D
/// 0.05..0.4). One row has an empty response.
fn tables(dir: &std::path::Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let ranges = [(0.2, 0.6), (0.1, 0.5), (0.3, 0.7), (0.05, 0.4)];
    let mut coded = String::from("A,B,C,D,y\n");
    let mut actual = String::from("A,B,C,D,y\n");
    let design = box_behnken(4, 5).unwrap();
    for copy in 0..2 {
        for (i, x) in design.iter().enumerate() {
            let noise = if (i + copy) % 3 == 0 { 0.3 } else { -0.15 };
            let y = 40.0 + 3.0 * x[0] - 2.0 * x[1] + x[0] * x[1] + 1.5 * x[2] * x[2] + noise;
            let y = if copy == 1 && i == 7 {
                String::new()
            } else {
                format!("{y}")
            };
            let c: Vec<String> = x.iter().map(|v| format!("{v}")).collect();
            let a: Vec<String> = x
                .iter()
                .zip(ranges)
                .map(|(v, (lo, hi))| format!("{}", lo + (v + 1.0) * 0.5 * (hi - lo)))
                .collect();
            coded.push_str(&format!("{},{y}\n", c.join(",")));
            actual.push_str(&format!("{},{y}\n", a.join(",")));
        }
    }
    let (pc, pa) = (dir.join("coded.csv"), dir.join("actual.csv"));
    std::fs::write(&pc, coded).unwrap();
    std::fs::write(&pa, actual).unwrap();
    (pc, pa)
}

fn json_fit(store: &std::path::Path, args: &[&str]) -> Value {
    let o = common::repose(store, args);
    assert!(o.status.success(), "{}", common::stderr(&o));
    serde_json::from_str(&common::stdout(&o)).expect("one JSON document")
}

#[test]
fn coded_and_actual_tables_give_the_same_fit_and_json_carries_all_of_it() {
    let tmp = tempfile::tempdir().unwrap();
    let (coded, actual) = tables(tmp.path());
    let base = ["rsm", "--factors", "A,B,C,D", "--response", "y", "--json"];
    let mut a = base.to_vec();
    a.extend(["--table", coded.to_str().unwrap()]);
    let from_coded = json_fit(tmp.path(), &a);
    let mut b = base.to_vec();
    b.extend([
        "--table",
        actual.to_str().unwrap(),
        "--ranges",
        "A=0.2:0.6,B=0.1:0.5,C=0.3:0.7,D=0.05:0.4",
    ]);
    let from_actual = json_fit(tmp.path(), &b);
    assert_eq!(from_coded["observations"], 57);
    assert_eq!(from_coded["missing"], 1);
    let coefficients = |v: &Value| -> Vec<f64> {
        v["fit"]["coefficients"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["estimate"].as_f64().unwrap())
            .collect()
    };
    let (c1, c2) = (coefficients(&from_coded), coefficients(&from_actual));
    assert_eq!(c1.len(), 15);
    for (x, y) in c1.iter().zip(&c2) {
        assert!((x - y).abs() < 1e-9, "{c1:?} vs {c2:?}");
    }
    // The model recovers the planted terms (intercept ≈ 40 + mean noise).
    let term = |name: &str| {
        let list = from_coded["fit"]["coefficients"].as_array().unwrap();
        list.iter()
            .find(|c| c["term"] == name)
            .unwrap_or_else(|| panic!("no term {name}"))["estimate"]
            .as_f64()
            .unwrap()
    };
    assert!((term("A") - 3.0).abs() < 0.2 && (term("B") + 2.0).abs() < 0.2);
    assert!((term("AB") - 1.0).abs() < 0.3 && (term("C²") - 1.5).abs() < 0.3);
    // Every ANOVA row, the R² family, PRESS, C.V., adequate precision, lack
    // of fit and pure error are in the JSON.
    let fit = &from_coded["fit"];
    for key in [
        "r2",
        "adj_r2",
        "pred_r2",
        "press",
        "cv_percent",
        "adequate_precision",
    ] {
        assert!(fit[key].is_f64(), "{key}");
    }
    assert_eq!(fit["anova"]["terms"].as_array().unwrap().len(), 14);
    assert!(fit["anova"]["lack_of_fit"]["p"].is_f64());
    assert_eq!(fit["anova"]["pure_error"]["df"], 57 - 25);
    // The actual-unit model: y = Σ b_term × term(actual values).
    assert_eq!(
        from_actual["actual_coefficients"].as_array().unwrap().len(),
        15
    );
}

#[test]
fn the_markdown_report_has_the_design_expert_rows() {
    let tmp = tempfile::tempdir().unwrap();
    let (coded, _) = tables(tmp.path());
    let o = common::repose(
        tmp.path(),
        &[
            "rsm",
            "--table",
            coded.to_str().unwrap(),
            "--factors",
            "A,B,C,D",
            "--response",
            "y",
        ],
    );
    let text = common::stdout(&o);
    assert!(o.status.success(), "{}", common::stderr(&o));
    for row in [
        "| Model |",
        "| Residual |",
        "| Lack of Fit |",
        "| Pure Error |",
        "| Cor Total |",
        "Adeq. precision",
    ] {
        assert!(text.contains(row), "{row}: {text}");
    }
}

#[test]
fn bad_table_options_name_what_is_wrong() {
    let tmp = tempfile::tempdir().unwrap();
    let (coded, _) = tables(tmp.path());
    let table = coded.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["rsm", "--table", table, "--response", "y"];
        args.extend(extra);
        let o = common::repose(tmp.path(), &args);
        assert_eq!(o.status.code(), Some(2), "{}", common::stderr(&o));
        common::stderr(&o)
    };
    let e = run(&["--factors", "A,B,C,E"]);
    assert!(e.contains("E"), "{e}");
    let e = run(&["--factors", "A,B,C,D", "--ranges", "A=0.6:0.2"]);
    assert!(e.contains("--ranges `A=0.6:0.2`"), "{e}");
    let e = run(&["--factors", "A,B,C,D", "--ranges", "A=0.2:0.6,Z=0:1"]);
    assert!(e.contains("no range for factor `B`"), "{e}");
    // Issue 54 (low): a factor listed twice was called "aliased"; the
    // response among the factors was accepted.
    let e = run(&["--factors", "A,A,B,C"]);
    assert!(e.contains("`A` is listed twice"), "{e}");
    let e = run(&["--factors", "A,B,C,y"]);
    assert!(e.contains("--response `y` is also among --factors"), "{e}");
    // Issue 40 (low): a response cell that is not a number is an error
    // naming its line, column and value, not a silently missing value; a
    // repeated header is refused.
    let text = std::fs::read_to_string(&coded).unwrap();
    for bad in ["NaN", "abc", "1e999", "inf"] {
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let last = lines[3].rfind(',').unwrap();
        lines[3] = format!("{},{bad}", &lines[3][..last]);
        std::fs::write(&coded, lines.join("\n")).unwrap();
        let e = run(&["--factors", "A,B,C,D"]);
        assert!(e.contains(&format!(":4: column `y` = `{bad}`")), "{e}");
    }
    std::fs::write(&coded, text.replacen("A,B,C,D,y", "A,B,C,D,A", 1)).unwrap();
    let e = run(&["--factors", "A,B,C,D"]);
    assert!(e.contains(":1: column 5 repeats the header `A`"), "{e}");

    // Issue 40 (low): ranges must be finite; a header-only, one-row or
    // constant table is the input's fault (exit 2, naming the file or
    // column), as `sensitivity --table` says; so is a missing file or a
    // directory (they were exit 1).
    std::fs::write(&coded, &text).unwrap();
    let e = run(&["--factors", "A,B,C,D", "--ranges", "A=-inf:inf"]);
    assert!(e.contains("--ranges `A=-inf:inf`"), "{e}");
    let header = text.lines().next().unwrap().to_string();
    std::fs::write(&coded, format!("{header}\n")).unwrap();
    let e = run(&["--factors", "A,B,C,D"]);
    assert!(e.contains("no data rows"), "{e}");
    let first_row = text.lines().nth(1).unwrap();
    std::fs::write(&coded, format!("{header}\n{first_row}\n")).unwrap();
    let e = run(&["--factors", "A,B,C,D"]);
    assert!(e.contains("1 observations are too few"), "{e}");
    let constant: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| match i {
            0 => l.to_string(),
            _ => format!("{},7.5", &l[..l.rfind(',').unwrap()]),
        })
        .collect();
    std::fs::write(&coded, constant.join("\n")).unwrap();
    let e = run(&["--factors", "A,B,C,D"]);
    assert!(e.contains("column `y` is 7.5 in every one of its"), "{e}");
    for missing in [tmp.path().join("nope.csv"), tmp.path().to_path_buf()] {
        let o = common::repose(
            tmp.path(),
            &[
                "rsm",
                "--table",
                missing.to_str().unwrap(),
                "--response",
                "y",
                "--factors",
                "A",
            ],
        );
        assert_eq!(o.status.code(), Some(2), "{}", common::stderr(&o));
        assert!(
            common::stderr(&o).contains("cannot read"),
            "{}",
            common::stderr(&o)
        );
    }
}

#[test]
fn a_study_without_factors_is_refused_with_what_the_stage_needs() {
    let tmp = tempfile::tempdir().unwrap();
    for command in ["rsm", "screen"] {
        let o = common::repose(tmp.path(), &[command, "experiments/he2019/study.json"]);
        assert_eq!(o.status.code(), Some(2));
        let e = common::stderr(&o);
        assert!(
            e.contains("not a design study") && e.contains("repose calibrate"),
            "{e}"
        );
    }
}
