//! `repose verdict --table`: the acceptance rule on a CSV table of
//! replicates, grouped, with missing replicates counted and bad input
//! refused (exit 2) naming the column and the value. The expected statistics
//! are statsmodels 0.15.0's:
//! `DescrStatsW(np.array(x)).ttost_mean(45.41, 50.19)` for each group's
//! values x (the same tables as `stats::equivalence`'s unit test).

mod common;

use serde_json::Value;

const TABLE: &str = "scene,seed,angle
funnel,1,47.1
drum,1,53.2
funnel,2,48.3
funnel,3,47.9
funnel,4,48.6
drum,2,54.1
funnel,5,47.5
funnel,6,48.0
funnel,7,48.8
funnel,8,47.7
drum,3,52.8
drum,4,53.9
drum,5,54.4
baffle,1,44.0
baffle,2,52.5
baffle,3,47.9
baffle,4,49.5
baffle,5,
";

fn verdict(dir: &std::path::Path, text: &str, extra: &[&str]) -> std::process::Output {
    let table = dir.join("replicates.csv");
    std::fs::write(&table, text).unwrap();
    let table = table.display().to_string();
    let mut args = vec!["verdict", "--table", &table];
    args.extend(extra);
    common::repose(dir, &args)
}

#[test]
fn groups_get_the_rules_verdicts() {
    let tmp = tempfile::tempdir().unwrap();
    let args = [
        "--value",
        "angle",
        "--group",
        "scene",
        "--target",
        "47.8",
        "--tolerance",
        "0.05",
        "--json",
    ];
    let out = verdict(tmp.path(), TABLE, &args);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let v: Value = serde_json::from_str(&common::stdout(&out)).unwrap();
    let groups = v["groups"].as_array().unwrap();
    // (group, n, missing, TOST p from statsmodels, verdict, seeds to decide)
    let expected = [
        ("funnel", 8, 0, 5.718976260823723e-06, "pass", None),
        ("drum", 5, 0, 0.9998526509670446, "fail", None),
        (
            "baffle",
            4,
            1,
            0.20206070049825653,
            "inconclusive",
            Some(14),
        ),
    ];
    assert_eq!(groups.len(), expected.len());
    for (g, (name, n, missing, p, word, decide)) in groups.iter().zip(expected) {
        assert_eq!(g["group"][0], name);
        assert_eq!(g["judgement"]["n"], n, "{name}");
        assert_eq!(g["missing"], missing, "{name}");
        let got = g["judgement"]["tost"]["p"].as_f64().unwrap();
        assert!((got - p).abs() <= 1e-6 * p, "{name}: {got} vs {p}");
        assert_eq!(g["judgement"]["verdict"], word, "{name}");
        assert_eq!(g["judgement"]["seeds_to_decide"].as_u64(), decide, "{name}");
    }
    // The text table carries the same verdicts.
    let text = verdict(tmp.path(), TABLE, &args[..8]);
    let text = common::stdout(&text);
    assert!(text.contains("| funnel | 8 (0) |"), "{text}");
    assert!(text.contains("| inconclusive | 14 |"), "{text}");
}

#[test]
fn bad_input_is_refused_naming_the_field() {
    let tmp = tempfile::tempdir().unwrap();
    let base = ["--target", "47.8", "--tolerance", "0.05"];
    let cases: [(&str, Vec<&str>, &str); 4] = [
        (TABLE, vec!["--value", "anglex"], "no column `anglex`"),
        (
            "scene,angle\nfunnel,47\nfunnel,abc\n",
            vec!["--value", "angle"],
            ":3: column `angle` = `abc`",
        ),
        (
            TABLE,
            vec!["--value", "angle", "--group", "lab"],
            "no column `lab`",
        ),
        (
            TABLE,
            vec!["--value", "angle", "--tolerance", "1.5"],
            "--tolerance = 1.5",
        ),
    ];
    for (table, extra, says) in cases {
        let mut args: Vec<&str> = base.to_vec();
        if extra.contains(&"--tolerance") {
            args.truncate(2);
        }
        args.extend(extra);
        let out = verdict(tmp.path(), table, &args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(
            common::stderr(&out).contains(says),
            "{}",
            common::stderr(&out)
        );
    }
}

/// Issue 54 item 4: values near 1e300 once overflowed the sum of squares
/// (sd null, "inconclusive"); the interval lies wholly outside the band.
/// Expected sd from Python's exact `statistics.stdev([1e300, 1.0000001e300,
/// 0.9999999e300])` = 9.99999999963232e+292.
#[test]
fn values_near_the_float_limit_get_a_finite_spread_and_a_fail() {
    let tmp = tempfile::tempdir().unwrap();
    let text = "x\n1e300\n1.0000001e300\n0.9999999e300\n";
    let out = verdict(
        tmp.path(),
        text,
        &[
            "--value",
            "x",
            "--target",
            "1",
            "--tolerance",
            "0.05",
            "--json",
        ],
    );
    assert!(out.status.success(), "{}", common::stderr(&out));
    let v: Value = serde_json::from_str(&common::stdout(&out)).unwrap();
    let j = &v["groups"][0]["judgement"];
    let sd = j["tost"]["sd"].as_f64().expect("a finite sd");
    assert!((sd / 9.99999999963232e292 - 1.0).abs() < 1e-12, "{sd}");
    assert_eq!(j["verdict"], "fail", "{j}");
}

#[test]
fn a_table_without_rows_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = verdict(
        tmp.path(),
        "x\n",
        &["--value", "x", "--target", "1", "--tolerance", "0.05"],
    );
    assert_eq!(out.status.code(), Some(2), "{}", common::stdout(&out));
    assert!(
        common::stderr(&out).contains("no rows"),
        "{}",
        common::stderr(&out)
    );
}

/// The printed table: no NaN for a mean exactly on a band edge with no
/// spread (its t is 0/0; p is 1), no 300-digit numbers for a huge target,
/// and a negative tolerance refused by the rule, not mistaken for a flag.
#[test]
fn the_printed_table_has_no_nan_no_300_digit_numbers_and_negative_flags_parse() {
    let tmp = tempfile::tempdir().unwrap();
    // band of 50 ± 10 % is [45, 55]; five values exactly on its lower edge.
    let edge = verdict(
        tmp.path(),
        "x\n45\n45\n45\n45\n45\n",
        &["--value", "x", "--target", "50", "--tolerance", "0.1"],
    );
    assert!(edge.status.success(), "{}", common::stderr(&edge));
    assert!(
        !common::stdout(&edge).contains("NaN"),
        "{}",
        common::stdout(&edge)
    );
    let huge = verdict(
        tmp.path(),
        "x\n1\n2\n3\n",
        &["--value", "x", "--target", "1e308", "--tolerance", "0.05"],
    );
    assert!(huge.status.success(), "{}", common::stderr(&huge));
    let longest = common::stdout(&huge)
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .map(str::len)
        .max()
        .unwrap();
    assert!(longest < 30, "{}", common::stdout(&huge));
    let negative = verdict(
        tmp.path(),
        "x\n1\n2\n3\n",
        &["--value", "x", "--target", "2", "--tolerance", "-0.05"],
    );
    assert_eq!(negative.status.code(), Some(2));
    assert!(
        common::stderr(&negative).contains("--tolerance = -0.05: must lie in (0, 1)"),
        "{}",
        common::stderr(&negative)
    );
}
