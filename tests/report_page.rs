//! `repose report` on the cai2024 and yan2015 smoke studies (real DEM runs
//! in a temporary store, as tests/cai2024_golden.rs and
//! tests/yan2015_golden.rs run them; about 1–2 minutes each), then the page
//! itself:
//! - every CSV file of the stage directories is an HTML table and every SVG
//!   file an inline `<svg>` (counted against the files), the verification
//!   table gives a verdict table;
//! - no `src` or `href` leaves the page's files (no `http://`, `https://` or
//!   `//`), no script, no stylesheet link;
//! - headings start at one h1 and never skip a level, every table has a
//!   caption and `scope`d headers, every inline SVG `role="img"` and a
//!   `<title>`;
//! - every `run.mcap` link resolves from the page's directory to a file of
//!   the store (also with `--out` elsewhere, for yan2015).
//!
//! Then the page is opened in headless Chromium (Debian's `chromium`, which
//! `scripts/chromium.sh` installs when missing): no console error, the DOM
//! it parsed holds every table and figure, and a screenshot of the page is
//! kept as a test artifact in
//! `<target dir>/test-artifacts/report_page_<study>.png` (`<target dir>` is
//! `$CARGO_TARGET_DIR`, else `target/`). When Chromium cannot be installed
//! (not root, no apt-get, no network) the browser part is skipped and the
//! test says why on stderr; a failed install or a browser that fails is an
//! error.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

const CAI: &str = "experiments/cai2024-smoke/study.json";
const YAN: &str = "experiments/yan2015-smoke/study.json";

#[test]
fn the_cai2024_smoke_report_has_every_table_figure_and_verdict() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    for stage in ["rsm", "screen"] {
        let o = common::repose(&store, &["--quiet", stage, "--jobs", "2", CAI]);
        assert!(o.status.success(), "{stage}: {}", common::stderr(&o));
    }
    let page = report(&store, CAI, None);
    check_page(&page, &study_dir(&store, CAI), &store, "cai2024");
}

#[test]
fn the_yan2015_smoke_report_written_elsewhere_links_back_to_the_store() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let o = common::repose(&store, &["--quiet", "sensitivity", "--jobs", "2", YAN]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let out = tmp.path().join("pages").join("yan2015");
    let page = report(&store, YAN, Some(&out));
    assert_eq!(page, out.join("report.html"));
    check_page(&page, &study_dir(&store, YAN), &store, "yan2015");
}

#[test]
fn a_study_never_run_in_the_store_is_refused_with_exit_2() {
    let tmp = tempfile::tempdir().unwrap();
    let o = common::repose(tmp.path(), &["report", CAI]);
    assert_eq!(o.status.code(), Some(2), "{}", common::stderr(&o));
    let err = common::stderr(&o);
    assert!(
        err.contains("no study output in the store") && err.contains("cai2024-smoke-"),
        "{err}"
    );
}

/// `repose report STUDY [--out DIR]`; returns the path it printed.
fn report(store: &Path, study: &str, out: Option<&Path>) -> PathBuf {
    let mut args = vec!["report", study];
    let out_arg;
    if let Some(dir) = out {
        out_arg = dir.display().to_string();
        args.extend(["--out", &out_arg]);
    }
    let o = common::repose(store, &args);
    assert!(o.status.success(), "report: {}", common::stderr(&o));
    let page = PathBuf::from(common::stdout(&o).trim());
    assert!(page.is_file(), "{}", page.display());
    page
}

/// The study's directory in the store (the only one under `studies/` whose
/// name starts with the study's name).
fn study_dir(store: &Path, study: &str) -> PathBuf {
    let doc: serde_json::Value = serde_json::from_str(&common::text(study)).unwrap();
    let name = doc["name"].as_str().unwrap();
    let found: Vec<PathBuf> = std::fs::read_dir(store.join("studies"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with(&format!("{name}-"))
        })
        .collect();
    assert_eq!(found.len(), 1, "{found:?}");
    found[0].clone()
}

/// Files of the study's stage directories with extension `ext` (lineage
/// records and the Slurm ledger are not stage outputs, `study.json` and the
/// page not in a stage).
fn stage_files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    common::files_with_extension(dir, ext, "slurm")
        .into_iter()
        .filter(|p| p.parent() != Some(dir))
        .collect()
}

/// Every check of the module docs on the page of the study in `dir`.
fn check_page(page: &Path, dir: &Path, store: &Path, name: &str) {
    let html = std::fs::read_to_string(page).unwrap();
    let csvs = stage_files(dir, "csv");
    let svgs = stage_files(dir, "svg");
    assert!(!csvs.is_empty() && !svgs.is_empty(), "{csvs:?} {svgs:?}");
    assert_eq!(
        html.matches("<table class=\"stage-table\"").count(),
        csvs.len(),
        "one table per CSV file: {csvs:?}"
    );
    for csv in &csvs {
        let caption = csv.strip_prefix(dir).unwrap().display().to_string();
        assert!(
            html.contains(&format!("<caption>{caption}</caption>")),
            "{caption}"
        );
    }
    assert_eq!(html.matches("<svg").count(), svgs.len(), "{svgs:?}");
    assert_eq!(html.matches("role=\"img\"").count(), svgs.len());
    assert_eq!(html.matches("<title id=\"fig-").count(), svgs.len());
    assert!(
        html.contains("<table class=\"verdicts\"") && html.contains("Verdicts of "),
        "no verdict table"
    );
    assert!(html.contains("<h2 id=\"provenance-h\">Provenance</h2>"));
    assert!(html.contains("<h2 id=\"warnings-h\">Resolution warnings</h2>"));

    // Tables: a caption each, every header cell scoped.
    let tables = html.matches("<table").count();
    assert_eq!(html.matches("<caption>").count(), tables);
    assert_eq!(
        html.matches("<th ").count(),
        html.matches("<th scope=\"").count()
    );
    assert!(!html.contains("<th>"));

    // Headings: one h1 first, then never deeper than one level below the last.
    let levels = heading_levels(&html);
    assert_eq!(levels.first(), Some(&1), "{levels:?}");
    assert_eq!(levels.iter().filter(|&&l| l == 1).count(), 1);
    for pair in levels.windows(2) {
        assert!(pair[1] <= pair[0] + 1, "heading skips a level: {levels:?}");
    }

    // No external references, no scripts.
    assert!(!html.contains("<script"), "a script");
    assert!(!html.contains("<link"), "a linked resource");
    let links = attribute_values(&html, &["href", "src"]);
    assert!(!links.is_empty());
    let page_dir = page.parent().unwrap();
    let mut logs = 0;
    for link in &links {
        assert!(
            !link.starts_with("http://")
                && !link.starts_with("https://")
                && !link.starts_with("//"),
            "external reference {link}"
        );
        assert!(!link.contains(':'), "a link with a scheme: {link}");
        if link.ends_with("run.mcap") {
            let target = page_dir.join(link).canonicalize().unwrap();
            assert!(target.starts_with(store.canonicalize().unwrap()), "{link}");
            logs += 1;
        }
    }
    assert!(logs > 0, "no run.mcap link");

    browser_checks(page, name, tables, svgs.len());
}

/// The level of every heading, in document order.
fn heading_levels(html: &str) -> Vec<u32> {
    html.match_indices("<h")
        .filter_map(|(i, _)| {
            let b = html.as_bytes();
            let level = (b[i + 2] as char).to_digit(10)?;
            (matches!(b[i + 3], b' ' | b'>')).then_some(level)
        })
        .collect()
}

/// The values of every attribute named one of `names` (double-quoted).
fn attribute_values(html: &str, names: &[&str]) -> Vec<String> {
    let mut values = Vec::new();
    for name in names {
        let pattern = format!(" {name}=\"");
        for (i, _) in html.match_indices(&pattern) {
            let rest = &html[i + pattern.len()..];
            values.push(rest[..rest.find('"').unwrap()].to_string());
        }
    }
    values
}

/// Where test artifacts go: `<target dir>/test-artifacts/`.
fn artifacts_dir() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| common::root().join("target"));
    let dir = target.join("test-artifacts");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Opens the page in headless Chromium: the DOM it parsed holds `tables`
/// tables and `figures` SVGs, the console is free of errors, and a
/// screenshot is kept (see the module docs). Skipped, saying why, when
/// Chromium cannot be installed.
fn browser_checks(page: &Path, name: &str, tables: usize, figures: usize) {
    let setup = Command::new(common::root().join("scripts/chromium.sh"))
        .output()
        .expect("run scripts/chromium.sh");
    let setup_err = common::stderr(&setup);
    match setup.status.code() {
        Some(0) => {}
        Some(3) => {
            eprintln!(
                "SKIPPED the headless Chromium part of the {name} report check: \
                 Chromium cannot be installed here:\n{setup_err}"
            );
            return;
        }
        _ => panic!(
            "scripts/chromium.sh failed ({}):\n{setup_err}",
            setup.status
        ),
    }
    let chromium = common::stdout(&setup)
        .trim()
        .lines()
        .last()
        .unwrap()
        .to_string();
    let url = format!("file://{}", page.canonicalize().unwrap().display());
    let screenshot = artifacts_dir().join(format!("report_page_{name}.png"));
    let _ = std::fs::remove_file(&screenshot);
    let run = |extra: &[String]| {
        let o = Command::new(&chromium)
            .args([
                "--headless",
                "--disable-gpu",
                "--no-sandbox",
                "--enable-logging=stderr",
                "--v=0",
                "--window-size=1280,2400",
            ])
            .args(extra)
            .arg(&url)
            .output()
            .expect("chromium runs");
        let err = common::stderr(&o);
        assert!(o.status.success(), "chromium failed ({}):\n{err}", o.status);
        for line in err.lines() {
            assert!(
                !line.contains("Uncaught") && !line.contains("ERROR:CONSOLE"),
                "console error: {line}"
            );
            assert!(!line.contains(":CONSOLE("), "console message: {line}");
        }
        o
    };
    let dom = common::stdout(&run(&["--dump-dom".to_string()]));
    assert_eq!(dom.matches("<table").count(), tables, "tables in the DOM");
    assert_eq!(dom.matches("<svg").count(), figures, "figures in the DOM");
    run(&[format!("--screenshot={}", screenshot.display())]);
    let size = std::fs::metadata(&screenshot).map(|m| m.len()).unwrap_or(0);
    assert!(size > 0, "no screenshot at {}", screenshot.display());
    eprintln!("screenshot of the {name} report: {}", screenshot.display());
}

/// Every layout of `foxglove/` (one per scene kind) is valid JSON, and every
/// topic it names is a channel of that scene's log: each scene's smoke
/// manifest (pair: experiments/validation/pair_hertz_rigid_wall.json) is
/// run once with a log, in parallel. `/particles/cloud` is the one topic a
/// smoke log lacks: runs above 20 000 particles write it instead of
/// `/particles` (src/log/schema.rs), so the layouts show either.
#[test]
fn every_foxglove_layout_names_only_topics_of_its_scenes_logs() {
    let scenes = [
        ("funnel_pile", "experiments/funnel_pile/smoke.json"),
        ("baffle_lift", "experiments/baffle_lift/smoke.json"),
        ("drum", "experiments/drum/smoke.json"),
        ("hopper", "experiments/hopper/smoke.json"),
        ("static_pile", "experiments/static_pile/smoke.json"),
        ("pair", "experiments/validation/pair_hertz_rigid_wall.json"),
    ];
    let mut files: Vec<String> = std::fs::read_dir(common::root().join("foxglove"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let mut expected: Vec<String> = scenes.iter().map(|(s, _)| format!("{s}.json")).collect();
    expected.sort();
    assert_eq!(files, expected, "one layout per scene kind");
    let tmp = tempfile::tempdir().unwrap();
    std::thread::scope(|s| {
        for (scene, manifest) in scenes {
            let dir = tmp.path().to_path_buf();
            s.spawn(move || check_layout(scene, manifest, &dir));
        }
    });
}

/// The topics of `foxglove/<scene>.json` against the channels of a logged
/// run of `manifest`.
fn check_layout(scene: &str, manifest: &str, tmp: &Path) {
    let layout: serde_json::Value =
        serde_json::from_str(&common::text(&format!("foxglove/{scene}.json")))
            .unwrap_or_else(|e| panic!("foxglove/{scene}.json: {e}"));
    let mut topics = Vec::new();
    let panels = layout["configById"].as_object().unwrap();
    for (id, panel) in panels {
        if id.starts_with("3D!") {
            topics.extend(panel["topics"].as_object().unwrap().keys().cloned());
            let camera = &panel["cameraState"];
            assert!(camera["distance"].as_f64().unwrap() > 0.0, "{scene}");
            assert!(camera["near"].as_f64().unwrap() < camera["distance"].as_f64().unwrap());
        }
        for path in panel["paths"].as_array().into_iter().flatten() {
            let value = path["value"].as_str().unwrap();
            topics.push(value.split_once('.').map_or(value, |(t, _)| t).to_string());
        }
    }
    assert!(
        panels.keys().any(|k| k.starts_with("3D!")),
        "{scene}: no 3D panel"
    );
    if scene != "pair" {
        assert!(
            topics.iter().any(|t| t == "/trace/angle"),
            "{scene}: no angle plot"
        );
    }
    let exp = repose::manifest::read_experiment(&common::root().join(manifest)).unwrap();
    let log = tmp.join(format!("{scene}.mcap"));
    repose::scenes::run_experiment(&exp, Some(&log)).unwrap_or_else(|e| panic!("{scene}: {e}"));
    let channels: Vec<String> = repose::log::inspect_file(&log)
        .unwrap()
        .channels
        .into_iter()
        .map(|c| c.topic)
        .collect();
    for topic in &topics {
        let present = channels.contains(topic)
            || (topic == "/particles/cloud" && channels.iter().any(|c| c == "/particles"));
        assert!(
            present,
            "{scene}: layout topic {topic} not in the log {channels:?}"
        );
    }
}
