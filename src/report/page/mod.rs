//! The study report page (`repose report STUDY`): one self-contained static
//! HTML file per study.
//!
//! [`write_page`] reads a study's directory in the store (the files its stages
//! wrote, their lineage records and the runs those records name) and writes
//! `report.html`, atomically, into the study directory or a directory of the
//! caller's choice. The page holds, in this order:
//! - the study specification: the directory's `study.json`, pretty-printed;
//! - the verdicts: every `verification.csv` of the stages, one row per point
//!   and response with n, mean ± 95 % half-width, the interval itself, the
//!   target, the TOST p-value, the verdict, the seeds that would decide it
//!   and the resolution limits it is unresolved at;
//! - the resolution warnings: every distinct warning of the referenced runs'
//!   `result.json`, with how many runs carry it;
//! - one section per stage directory (name order; the executor's `slurm/`
//!   ledger is not a stage and is left out): every CSV file as an HTML table
//!   (first row the column headers, first column the row headers), every SVG
//!   plot inlined (not linked) with `role="img"` and a `<title>`, every
//!   Markdown and JSON output as preformatted text (Markdown open, JSON
//!   folded). Files of a sub-directory come under its heading;
//! - the provenance: each lineage record as `repose audit` reads it
//!   ([`crate::store::lineage::records_under`], same order) — output, stage,
//!   recorded sha256, whether the output still has those bytes, and every
//!   input with its id or path and sha256;
//! - the runs: every run the records name (by id, or by its `result.json`),
//!   its scene and state in the store, its roles, its warnings and a link to
//!   its `run.mcap`, relative from the page to the store, so the page and the
//!   store can move together.
//!
//! The page needs no server, network or scripts: CSS is inline, plots are
//! inline SVG, and no `src` or `href` points outside the store. Headings go
//! h1 → h2 → h3 without gaps; every table has a `<caption>` and `scope`d
//! headers. An SVG holding a script, a `foreignObject` or any `href` is not
//! inlined (the page says so instead).
//!
//! The page is rendered with askama: its template
//! (`templates/report.html`) is compiled into the binary and checked by the
//! compiler against the structs below (a misspelt field is a build error, not
//! a blank cell at run time), and askama escapes every interpolated value
//! for HTML by default, so text from the study files cannot inject markup.
//! Only the SVG plots are inserted unescaped (`|safe`), after the check
//! above. minijinja was the alternative; its templates are checked only when
//! rendered, which a page rendered from a test-free path would not catch.
//!
//! Like the rest of [`crate::report`] the page holds no time stamps: the same
//! study directory gives the same bytes.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};

use askama::Template;

use crate::manifest::ContentId;
use crate::store::lineage::{self, InputRef, Lineage};
use crate::store::{write_atomic, Depth, RunState, Store, StoreError, MCAP_FILE, TEMP_PREFIX};

/// The page's file name, in the study directory or the `--out` directory.
pub const PAGE_FILE: &str = "report.html";

/// The study document in a study directory.
const STUDY_FILE: &str = "study.json";

/// A sub-directory of a study directory that is not a stage: the Slurm
/// executor's ledger and scripts.
const NOT_A_STAGE: &str = "slurm";

/// Why the page could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PageError {
    /// The study has no directory (or no `study.json` in it) in the store.
    #[error(
        "{}: no study output in the store (no {STUDY_FILE}); run the study's stages \
         (e.g. `repose rsm`, `repose sensitivity`, `repose calibrate`) with the same --store first",
        .0.display()
    )]
    NoStudy(PathBuf),
    /// A file of the study directory could not be read or parsed.
    #[error("{}: {message}", path.display())]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The store failed (reading a directory, writing the page).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The template failed to render.
    #[error("rendering the report page: {0}")]
    Render(#[from] askama::Error),
}

impl PageError {
    /// True when the user's input is at fault (a study never run in this store).
    pub fn is_invalid_input(&self) -> bool {
        matches!(self, PageError::NoStudy(_))
    }
}

/// Writes the report page of the study whose outputs are in `study_dir`
/// (a directory of the store at `store_root`) to `out_dir/report.html`, or
/// `study_dir/report.html` without `out_dir`; returns the path written.
pub fn write_page(
    store_root: &Path,
    study_dir: &Path,
    out_dir: Option<&Path>,
) -> Result<PathBuf, PageError> {
    let study_file = study_dir.join(STUDY_FILE);
    if !study_file.is_file() {
        return Err(PageError::NoStudy(study_dir.to_path_buf()));
    }
    let out_dir = out_dir.unwrap_or(study_dir);
    std::fs::create_dir_all(out_dir).map_err(StoreError::io(out_dir))?;
    let store = Store::open(store_root)?;
    let page = Page::collect(&store, study_dir, out_dir)?;
    let html = page.render()?;
    let path = out_dir.join(PAGE_FILE);
    write_atomic(&path, html.as_bytes()).map_err(StoreError::io(&path))?;
    Ok(path)
}

/// Everything the template shows (see the module docs for the order).
#[derive(Template)]
#[template(path = "report.html")]
struct Page {
    title: String,
    study_id: String,
    study_dir: String,
    version: &'static str,
    spec: String,
    verdicts: Vec<VerdictTable>,
    warnings: Vec<Warning>,
    stages: Vec<Stage>,
    lineage: Vec<Record>,
    runs: Vec<Run>,
}

/// One `verification.csv`.
struct VerdictTable {
    /// The file, relative to the study directory (as its lineage record's
    /// output is shown).
    source: String,
    caption: String,
    rows: Vec<Verdict>,
}

/// One row of a verification table, formatted.
struct Verdict {
    point: String,
    response: String,
    n: String,
    mean: String,
    interval: String,
    target: String,
    tost_p: String,
    verdict: String,
    seeds_to_decide: String,
    unresolved: String,
}

/// A distinct run warning and how many runs carry it.
struct Warning {
    text: String,
    runs: usize,
}

/// A stage directory.
struct Stage {
    name: String,
    anchor: String,
    groups: Vec<Group>,
}

/// The files of one directory of a stage (heading empty for the stage's own).
struct Group {
    heading: String,
    items: Vec<Item>,
}

/// One output file as the page shows it.
enum Item {
    Table(Table),
    Figure(Figure),
    Text(Text),
}

/// A CSV file.
struct Table {
    caption: String,
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

/// An SVG file, split where the page adds its accessibility attributes:
/// `open_tag` is `<svg …` without its `>`, `body` everything after it.
struct Figure {
    caption: String,
    id: String,
    title: String,
    open_tag: String,
    body: String,
}

/// A Markdown or JSON file (or an SVG that could not be inlined), shown as
/// preformatted text.
struct Text {
    caption: String,
    text: String,
    open: bool,
}

/// A lineage record.
struct Record {
    output: String,
    stage: String,
    output_sha256: String,
    intact: bool,
    state: String,
    inputs: Vec<InputRef>,
}

/// A run named by the lineage records.
struct Run {
    id: String,
    scene: String,
    state: String,
    roles: String,
    warnings: String,
    log_href: Option<String>,
}

impl Page {
    /// Reads the study directory; run log links are relative to `out_dir`.
    fn collect(store: &Store, study_dir: &Path, out_dir: &Path) -> Result<Page, PageError> {
        let study_file = study_dir.join(STUDY_FILE);
        let bytes = std::fs::read(&study_file).map_err(StoreError::io(&study_file))?;
        let spec: serde_json::Value =
            serde_json::from_slice(&bytes).map_err(|e| PageError::Unreadable {
                path: study_file.clone(),
                message: e.to_string(),
            })?;
        let title = spec
            .get("name")
            .and_then(|n| n.as_str())
            .map(str::to_string)
            .unwrap_or_else(|| display_name(study_dir));
        let stages = stage_dirs(study_dir)?
            .iter()
            .map(|dir| stage(dir))
            .collect::<Result<Vec<_>, _>>()?;
        let mut verdicts: Vec<VerdictTable> = stages
            .iter()
            .flat_map(|s| s.groups.iter().flat_map(|g| &g.items))
            .filter_map(|item| match item {
                Item::Table(t) if t.caption.ends_with("verification.csv") => Some(verdict_table(t)),
                _ => None,
            })
            .collect();
        let records = lineage::records_under(study_dir)?;
        let lineage = records
            .iter()
            .map(|r| record(study_dir, r))
            .collect::<Result<Vec<_>, _>>()?;
        for v in &mut verdicts {
            // Verdicts are shown as the stage's only when its lineage
            // record still describes the file.
            match lineage.iter().find(|r| r.output == v.source) {
                Some(r) if r.intact => {}
                Some(r) => v.caption.push_str(&format!(
                    " — EDITED: {} (these are not the stage's verdicts)",
                    r.state
                )),
                None => v
                    .caption
                    .push_str(" — no lineage record: not shown to be the stage's verdicts"),
            }
        }
        let (runs, warnings) = runs(store, &lineage, out_dir)?;
        Ok(Page {
            title,
            study_id: ContentId::of_bytes(&bytes).to_string(),
            study_dir: study_dir.display().to_string(),
            version: env!("CARGO_PKG_VERSION"),
            spec: serde_json::to_string_pretty(&spec).unwrap_or_default(),
            verdicts,
            warnings,
            stages,
            lineage,
            runs,
        })
    }
}

/// The last component of `path`, for display.
fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// The stage directories of a study directory, in name order.
fn stage_dirs(study_dir: &Path) -> Result<Vec<PathBuf>, PageError> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(study_dir)
        .map_err(StoreError::io(study_dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .filter(|p| {
            let name = display_name(p);
            !name.starts_with('.') && name != NOT_A_STAGE
        })
        .collect();
    dirs.sort();
    Ok(dirs)
}

/// One stage's section: its output files grouped by directory.
fn stage(dir: &Path) -> Result<Stage, PageError> {
    let name = display_name(dir);
    let mut groups: Vec<Group> = Vec::new();
    for file in lineage::files_under(dir)? {
        let file_name = display_name(&file);
        if lineage::is_record(&file) || file_name.starts_with(TEMP_PREFIX) {
            continue;
        }
        let relative = file.strip_prefix(dir).unwrap_or(&file);
        let caption = format!("{name}/{}", relative.display());
        let heading = relative
            .parent()
            .map(|p| p.display().to_string())
            .unwrap_or_default();
        let figure_id = format!("fig-{}", anchor(&caption));
        let Some(item) = item(&file, caption, figure_id)? else {
            continue;
        };
        match groups.last_mut() {
            Some(g) if g.heading == heading => g.items.push(item),
            _ => groups.push(Group {
                heading,
                items: vec![item],
            }),
        }
    }
    Ok(Stage {
        anchor: format!("stage-{}", anchor(&name)),
        name,
        groups,
    })
}

/// `text` as an HTML id: ASCII letters and digits kept, everything else `-`.
fn anchor(text: &str) -> String {
    text.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

/// How the page shows `file`: CSV as a table, SVG inline, Markdown and JSON
/// as text; any other file is left out.
fn item(file: &Path, caption: String, figure_id: String) -> Result<Option<Item>, PageError> {
    match shown(file, caption.clone(), figure_id) {
        // A file the page cannot read as its kind (not UTF-8, a broken
        // CSV) is marked and shown as far as it goes, never the end of the
        // page.
        Err(PageError::Unreadable { message, .. }) => Ok(Some(Item::Text(Text {
            caption: format!("{caption} — UNREADABLE: {message}"),
            text: std::fs::read(file)
                .map(|b| String::from_utf8_lossy(&b).into_owned())
                .unwrap_or_default(),
            open: false,
        }))),
        other => other,
    }
}

/// [`item`] of a readable file.
fn shown(file: &Path, caption: String, figure_id: String) -> Result<Option<Item>, PageError> {
    let extension = file
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let unreadable = |message: String| PageError::Unreadable {
        path: file.to_path_buf(),
        message,
    };
    let read = || std::fs::read_to_string(file).map_err(|e| unreadable(e.to_string()));
    Ok(Some(match extension.as_str() {
        "csv" => Item::Table(csv_table(file, caption)?),
        "svg" => {
            let svg = read()?;
            match split_svg(&svg) {
                Some((open_tag, body)) => Item::Figure(Figure {
                    title: svg_title(body).unwrap_or_else(|| caption.clone()),
                    caption,
                    id: figure_id,
                    open_tag: open_tag.to_string(),
                    body: body.to_string(),
                }),
                None => Item::Text(Text {
                    caption: format!(
                        "{caption} (not inlined: it holds a script, a foreignObject or a link)"
                    ),
                    text: svg,
                    open: false,
                }),
            }
        }
        "md" => Item::Text(Text {
            caption,
            text: read()?,
            open: true,
        }),
        "json" => Item::Text(Text {
            caption,
            text: read()?,
            open: false,
        }),
        _ => return Ok(None),
    }))
}

/// A CSV file as a table: its first record is the header.
fn csv_table(file: &Path, caption: String) -> Result<Table, PageError> {
    let unreadable = |e: csv::Error| PageError::Unreadable {
        path: file.to_path_buf(),
        message: e.to_string(),
    };
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(file)
        .map_err(unreadable)?;
    let header = reader
        .headers()
        .map_err(unreadable)?
        .iter()
        .map(str::to_string)
        .collect();
    let rows = reader
        .records()
        .map(|r| r.map(|r| r.iter().map(str::to_string).collect()))
        .collect::<Result<_, _>>()
        .map_err(unreadable)?;
    Ok(Table {
        caption,
        header,
        rows,
    })
}

/// An SVG document split after its opening tag's attributes (see
/// [`Figure`]), without the XML prolog; `None` when it holds a script, a
/// `foreignObject`, an `href` (it could reach outside the page) or an event
/// handler attribute (`onload=` and the like, which run script).
fn split_svg(svg: &str) -> Option<(&str, &str)> {
    let lower = svg.to_ascii_lowercase();
    if ["<script", "<foreignobject", "href"]
        .iter()
        .any(|bad| lower.contains(bad))
        || has_event_attribute(&lower)
    {
        return None;
    }
    let start = svg.find("<svg")?;
    let end = start + svg[start..].find('>')?;
    let open_tag = svg[start..end].trim_end_matches('/');
    if open_tag.len() != end - start {
        return None; // an empty `<svg/>`: nothing to show
    }
    Some((open_tag, &svg[end + 1..]))
}

/// Whether `lower` (lower-cased markup) holds an attribute `on<letters>=`
/// after white space, the form of every event handler.
fn has_event_attribute(lower: &str) -> bool {
    let bytes = lower.as_bytes();
    lower.match_indices("on").any(|(i, _)| {
        let after_space = i > 0 && bytes[i - 1].is_ascii_whitespace();
        let rest = &lower[i + 2..];
        let name = rest.bytes().take_while(u8::is_ascii_lowercase).count();
        after_space && name > 0 && rest[name..].trim_start().starts_with('=')
    })
}

/// The text of the first `<text>` element of an SVG body, unescaped: the
/// plots' titles come first.
fn svg_title(body: &str) -> Option<String> {
    let start = body.find("<text")?;
    let open_end = start + body[start..].find('>')? + 1;
    let len = body[open_end..].find('<')?;
    let text = body[open_end..open_end + len].trim();
    (!text.is_empty()).then(|| {
        text.replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&apos;", "'")
            .replace("&amp;", "&")
    })
}

/// The verdicts of a verification table (columns by name; a missing column
/// shows empty). The design studies' tables (`verify/verification.csv` of
/// rsm and sensitivity) and he2019's (`verify/verification.csv` of the
/// candidates: `group`, `scene`, `measured`, `mean_deg`, … in degrees) name
/// the same quantities differently; each cell takes the first of its names
/// the table has.
fn verdict_table(table: &Table) -> VerdictTable {
    let column = |names: &[&str]| {
        names
            .iter()
            .find_map(|name| table.header.iter().position(|h| h == name))
    };
    let cols: BTreeMap<&str, Option<usize>> = [
        ("point", &["point", "group"][..]),
        ("response", &["response", "scene"]),
        ("n", &["n", "measured"]),
        ("mean", &["mean", "mean_deg"]),
        (
            "ci95_half_width",
            &["ci95_half_width", "ci95_half_width_deg"],
        ),
        ("target", &["target", "target_deg"]),
        ("tost_p", &["tost_p"]),
        ("verdict", &["verdict"]),
        ("seeds_to_decide", &["seeds_to_decide"]),
        ("unresolved", &["unresolved"]),
    ]
    .into_iter()
    .map(|(c, names)| (c, column(names)))
    .collect();
    let rows = table
        .rows
        .iter()
        .map(|row| {
            let cell = |name: &str| {
                cols[name]
                    .and_then(|i| row.get(i))
                    .cloned()
                    .unwrap_or_default()
            };
            let number = |name: &str| cell(name).parse::<f64>().ok();
            let (mean, interval) = match (number("mean"), number("ci95_half_width")) {
                (Some(m), Some(h)) => (
                    format!("{m:.3} ± {h:.3}"),
                    format!("[{:.3}, {:.3}]", m - h, m + h),
                ),
                (Some(m), None) => (format!("{m:.3}"), String::new()),
                _ => (cell("mean"), String::new()),
            };
            Verdict {
                point: cell("point"),
                response: cell("response"),
                n: cell("n"),
                mean,
                interval,
                target: cell("target"),
                tost_p: number("tost_p")
                    .map(|p| format!("{p:.3}"))
                    .unwrap_or_else(|| cell("tost_p")),
                verdict: cell("verdict"),
                seeds_to_decide: cell("seeds_to_decide"),
                unresolved: cell("unresolved"),
            }
        })
        .collect();
    VerdictTable {
        source: table.caption.clone(),
        caption: format!("Verdicts of {}", table.caption),
        rows,
    }
}

/// A lineage record for the page: its output relative to the study
/// directory and whether the output still has the bytes the stage wrote.
fn record(study_dir: &Path, path: &Path) -> Result<Record, PageError> {
    let lineage: Lineage = Store::read_json(path)?;
    let output = lineage::output_of(path);
    let (intact, state) = match std::fs::read(&output) {
        Ok(bytes) if lineage.describes(&bytes) => (true, String::new()),
        Ok(_) => (false, "changed since the stage wrote it".to_string()),
        Err(_) => (false, "missing".to_string()),
    };
    Ok(Record {
        output: output
            .strip_prefix(study_dir)
            .unwrap_or(&output)
            .display()
            .to_string(),
        stage: lineage.stage,
        output_sha256: lineage.output_sha256.unwrap_or_default(),
        intact,
        state,
        inputs: lineage.inputs,
    })
}

/// The runs the records name, in id order, and the distinct warnings of
/// those runs (text order) with how many runs carry each.
fn runs(
    store: &Store,
    records: &[Record],
    out_dir: &Path,
) -> Result<(Vec<Run>, Vec<Warning>), PageError> {
    let mut roles: BTreeMap<ContentId, BTreeSet<&str>> = BTreeMap::new();
    for input in records.iter().flat_map(|r| &r.inputs) {
        if let Some(id) = input.run() {
            if store.run_dir(&id).path().is_dir() {
                roles.entry(id).or_default().insert(&input.role);
            }
        }
    }
    let page_dir = canonical(out_dir)?;
    let root = canonical(store.root())?;
    let mut warnings: BTreeMap<String, usize> = BTreeMap::new();
    let mut runs = Vec::new();
    for (id, used_as) in roles {
        let (scene, state, run_warnings) = match store.check(&id, Depth::Sizes) {
            RunState::Complete(result) => (result.scene, "complete".to_string(), result.warnings),
            RunState::Damaged(problem) => (String::new(), format!("damaged: {problem}"), vec![]),
            RunState::Failed => (String::new(), "failed".to_string(), vec![]),
            RunState::Incomplete => (String::new(), "incomplete".to_string(), vec![]),
            RunState::Missing => (String::new(), "missing".to_string(), vec![]),
        };
        for w in &run_warnings {
            *warnings.entry(w.clone()).or_default() += 1;
        }
        let log = root.join(id.as_str()).join(MCAP_FILE);
        runs.push(Run {
            id: id.to_string(),
            scene,
            state,
            roles: used_as.into_iter().collect::<Vec<_>>().join(", "),
            warnings: run_warnings.join("; "),
            log_href: log
                .is_file()
                .then(|| relative(&page_dir, &log).display().to_string()),
        });
    }
    let warnings = warnings
        .into_iter()
        .map(|(text, runs)| Warning { text, runs })
        .collect();
    Ok((runs, warnings))
}

/// `path` made absolute with every link resolved.
fn canonical(path: &Path) -> Result<PathBuf, PageError> {
    Ok(std::fs::canonicalize(path).map_err(StoreError::io(path))?)
}

/// The path of `to` relative to the directory `from` (both canonical).
fn relative(from: &Path, to: &Path) -> PathBuf {
    let from: Vec<Component> = from.components().collect();
    let to: Vec<Component> = to.components().collect();
    let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
    let mut path: PathBuf = from[common..].iter().map(|_| "..").collect();
    path.extend(to[common..].iter());
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 54 item 7: a he2019 study's verification table (the candidates
    /// stage's header, as `verify_candidates` writes it) left every cell but
    /// the verdict empty.
    #[test]
    fn a_he2019_verification_table_fills_every_verdict_cell() {
        let table = Table {
            caption: "verify/verification.csv".into(),
            header: [
                "group",
                "scene",
                "seeds",
                "measured",
                "mean_deg",
                "sd_deg",
                "ci95_half_width_deg",
                "target_deg",
                "relative_error",
                "tost_p",
                "verdict",
                "seeds_to_decide",
                "unresolved",
            ]
            .map(String::from)
            .to_vec(),
            rows: vec![[
                "0", "funnel", "7", "7", "48.3", "1.6", "1.47", "47.8", "0.01", "0.0104", "pass",
                "", "",
            ]
            .map(String::from)
            .to_vec()],
        };
        let v = &verdict_table(&table).rows[0];
        assert_eq!(
            (&v.point[..], &v.response[..], &v.n[..], &v.target[..]),
            ("0", "funnel", "7", "47.8")
        );
        assert_eq!(v.mean, "48.300 ± 1.470");
        assert_eq!(v.interval, "[46.830, 49.770]");
        assert_eq!(v.tost_p, "0.010");
        assert_eq!(v.verdict, "pass");
    }

    #[test]
    fn relative_paths_climb_to_the_common_prefix() {
        let page = Path::new("/s/studies/x-1");
        let log = Path::new("/s/ab12/run.mcap");
        assert_eq!(relative(page, log), Path::new("../../ab12/run.mcap"));
        assert_eq!(relative(Path::new("/s"), log), Path::new("ab12/run.mcap"));
        assert_eq!(
            relative(Path::new("/elsewhere/out"), log),
            Path::new("../../s/ab12/run.mcap")
        );
    }

    #[test]
    fn svgs_are_split_after_the_opening_tag_and_refused_with_links_or_scripts() {
        let svg =
            "<?xml version=\"1.0\"?>\n<svg width=\"10\" xmlns=\"http://www.w3.org/2000/svg\">\
                   <text x=\"1\">a &lt; b</text></svg>";
        let (open, body) = split_svg(svg).unwrap();
        assert_eq!(
            open,
            "<svg width=\"10\" xmlns=\"http://www.w3.org/2000/svg\""
        );
        assert!(body.starts_with("<text"));
        assert_eq!(svg_title(body).as_deref(), Some("a < b"));
        for bad in [
            "<svg><script>alert(1)</script></svg>",
            "<svg><a href=\"https://x\">x</a></svg>",
            "<svg><foreignObject/></svg>",
            "<svg onload=\"alert(1)\"><rect/></svg>",
            "<svg><rect\n  onclick = \"x()\"/></svg>",
            "<svg/>",
        ] {
            assert!(split_svg(bad).is_none(), "{bad}");
        }
    }

    #[test]
    fn text_from_the_study_is_escaped() {
        let page = Page {
            title: "<b>&".to_string(),
            study_id: String::new(),
            study_dir: String::new(),
            version: "0",
            spec: "{\"x\": \"</pre><script>\"}".to_string(),
            verdicts: Vec::new(),
            warnings: Vec::new(),
            stages: vec![Stage {
                name: "s".to_string(),
                anchor: "stage-s".to_string(),
                groups: vec![Group {
                    heading: String::new(),
                    items: vec![Item::Table(Table {
                        caption: "t.csv".to_string(),
                        header: vec!["<th>".to_string()],
                        rows: vec![vec!["a<b".to_string()]],
                    })],
                }],
            }],
            lineage: Vec::new(),
            runs: Vec::new(),
        };
        let html = page.render().unwrap();
        assert!(html.contains("&#60;b&#62;&#38;"));
        assert!(!html.contains("<script"));
        assert!(html.contains("a&#60;b"));
    }
}
