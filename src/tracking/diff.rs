//! `repose diff A B`: what differs between two runs (or, through
//! [`super::study_diff`], two studies).
//!
//! An argument names a study when it is a study directory, else a run when
//! it is a prefix of a run id, else a study whose directory name or id
//! starts with it ([`super::study_files::resolve_study`]); both must name the
//! same kind.
//!
//! Two runs are compared on: status; physics version; every manifest field
//! (dotted paths, [`super::fields`]) whose values differ, with both values;
//! every response either has, with the difference B − A; the warnings only
//! one of them has; and the size and sha256 of each sealed file
//! ([`crate::store::seal`]; manifest.json always differs, as it is the id).
//!
//! Seed noise: when each run has replicates in the store (runs whose
//! manifests differ only in the packing seed, [`super::group`]) with at
//! least two values of a response per side, the difference of the
//! replicates' means is given with the half-width of its Welch 95 %
//! confidence interval ([`crate::stats::summary::difference_ci`]: unequal
//! variances, Welch–Satterthwaite degrees of freedom), and the difference
//! is *inside the seed noise* when that interval contains 0. The Welch
//! interval and not a pooled t-test: replicates of two parameter sets need
//! not share a spread (a cohesive pile scatters more).

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::fields::{Record, Value};
use super::group::seed_key;
use super::render::short_number;
use super::study_diff::{diff_studies, StudyDiff};
use super::study_files::{resolve_study, STUDY_FILE};
use super::TrackingError;
use crate::manifest::ContentId;
use crate::stats::summary::{difference_ci, mean_ci};
use crate::store::seal::{FileDigest, Seal};
use crate::store::{Depth, RunSummary, Store};

/// The answer of `repose diff`.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Diff {
    /// Two runs.
    Runs(RunDiff),
    /// Two studies.
    Studies(StudyDiff),
}

impl Diff {
    /// The diff as text for people.
    pub fn text(&self) -> String {
        match self {
            Diff::Runs(d) => d.text(),
            Diff::Studies(d) => d.text(),
        }
    }
}

/// A field whose values differ (`None`: the side has no such field).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldChange {
    /// Dotted path.
    pub field: String,
    /// A's value.
    pub a: Option<Value>,
    /// B's value.
    pub b: Option<Value>,
}

/// One response of two runs, in its unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResponseChange {
    /// The response's key.
    pub response: String,
    /// A's value.
    pub a: Option<f64>,
    /// B's value.
    pub b: Option<f64>,
    /// B − A, when both have it.
    pub difference: Option<f64>,
    /// The same over the replicates, when both have two or more.
    pub seed_noise: Option<SeedNoise>,
}

/// A response's difference over the two runs' replicates (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SeedNoise {
    /// Replicates of A with the response.
    pub n_a: usize,
    /// Replicates of B with the response.
    pub n_b: usize,
    /// Mean of B's replicates − mean of A's.
    pub difference: f64,
    /// Half-width of the Welch 95 % interval of that difference.
    pub ci95_half_width: f64,
    /// The interval contains 0.
    pub inside_noise: bool,
}

/// A sealed file of two runs (`None`: not sealed on that side).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FileChange {
    /// File name (manifest.json, result.json, run.mcap).
    pub file: String,
    /// A's size and hash.
    pub a: Option<FileDigest>,
    /// B's size and hash.
    pub b: Option<FileDigest>,
}

/// What differs between two runs (module docs).
#[derive(Debug, Clone, Serialize)]
pub struct RunDiff {
    /// A's id.
    pub a: ContentId,
    /// B's id.
    pub b: ContentId,
    /// Statuses of A and B.
    pub status: [String; 2],
    /// Physics versions of A and B (from their manifests).
    pub physics_version: [Option<u32>; 2],
    /// Manifest fields that differ.
    pub manifest: Vec<FieldChange>,
    /// Every response either has.
    pub responses: Vec<ResponseChange>,
    /// Warnings of A that B lacks.
    pub warnings_only_a: Vec<String>,
    /// Warnings of B that A lacks.
    pub warnings_only_b: Vec<String>,
    /// Every sealed file of either.
    pub files: Vec<FileChange>,
}

/// The fields of `a` and `b` (dotted paths) whose values differ, by path.
pub fn changed_fields(
    a: &BTreeMap<String, Value>,
    b: &BTreeMap<String, Value>,
) -> Vec<FieldChange> {
    let fields: BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    fields
        .into_iter()
        .filter(|f| a.get(*f) != b.get(*f))
        .map(|f| FieldChange {
            field: f.clone(),
            a: a.get(f).cloned(),
            b: b.get(f).cloned(),
        })
        .collect()
}

impl FieldChange {
    /// `  field: A → B` and a line break (`(absent)` for a missing side).
    pub fn line(&self) -> String {
        let show = |v: &Option<Value>| v.as_ref().map_or("(absent)".to_string(), Value::to_string);
        format!("  {}: {} → {}\n", self.field, show(&self.a), show(&self.b))
    }
}

/// What `a` and `b` name, compared (module docs).
pub fn diff(store: &Store, a: &str, b: &str) -> Result<Diff, TrackingError> {
    match (target(store, a)?, target(store, b)?) {
        (Target::Run(x), Target::Run(y)) => Ok(Diff::Runs(diff_runs(store, &x, &y)?)),
        (Target::Study(x), Target::Study(y)) => Ok(Diff::Studies(diff_studies(&x, &y)?)),
        (x, y) => Err(TrackingError::MixedDiff {
            a: a.to_string(),
            a_kind: x.kind(),
            b: b.to_string(),
            b_kind: y.kind(),
        }),
    }
}

enum Target {
    Run(ContentId),
    Study(std::path::PathBuf),
}

impl Target {
    fn kind(&self) -> &'static str {
        match self {
            Target::Run(_) => "run",
            Target::Study(_) => "study",
        }
    }
}

/// What one argument names (module docs); when it names nothing, the run
/// store's error for a hex argument and the study lookup's otherwise.
fn target(store: &Store, given: &str) -> Result<Target, TrackingError> {
    if std::path::Path::new(given).join(STUDY_FILE).is_file() {
        return Ok(Target::Study(given.into()));
    }
    let run_error = match store.resolve_prefix(given) {
        Ok(id) => {
            // A prefix of a run id and of a study's names neither alone.
            return match resolve_study(store.root(), given) {
                Ok(dir) => Err(TrackingError::AmbiguousStudy {
                    given: given.to_string(),
                    candidates: vec![
                        format!("run {id}"),
                        format!(
                            "study {}",
                            dir.file_name().map_or(dir.display().to_string(), |n| n
                                .to_string_lossy()
                                .into_owned())
                        ),
                    ],
                }),
                Err(_) => Ok(Target::Run(id)),
            };
        }
        Err(e @ crate::store::StoreError::Ambiguous { .. }) => return Err(e.into()),
        Err(e) => e,
    };
    match resolve_study(store.root(), given) {
        Ok(dir) => Ok(Target::Study(dir)),
        Err(_) if given.bytes().all(|b| b.is_ascii_hexdigit()) => Err(run_error.into()),
        Err(e) => Err(e),
    }
}

/// The diff of runs `a` and `b` (module docs).
pub fn diff_runs(store: &Store, a: &ContentId, b: &ContentId) -> Result<RunDiff, TrackingError> {
    let records: Vec<Record> = store.list()?.into_iter().map(Record::new).collect();
    // The listing checked sizes only; the diff reports hashes, so check fully.
    let full = |id: &ContentId| {
        let state = store.check(id, Depth::Full);
        Record::new(RunSummary::new(
            id.clone(),
            state,
            store.load_manifest(id).ok(),
        ))
    };
    let (ra, rb) = (full(a), full(b));
    let manifest = changed_fields(&ra.manifest, &rb.manifest);
    let warnings = |r: &Record| -> BTreeSet<String> {
        r.summary
            .result
            .iter()
            .flat_map(|x| x.warnings.iter().cloned())
            .collect()
    };
    let (wa, wb) = (warnings(&ra), warnings(&rb));
    Ok(RunDiff {
        a: a.clone(),
        b: b.clone(),
        status: [ra.summary.status.to_string(), rb.summary.status.to_string()],
        physics_version: [&ra, &rb]
            .map(|r| r.summary.experiment.as_ref().map(|e| e.physics_version)),
        manifest,
        responses: responses(&ra, &rb, &records),
        warnings_only_a: wa.difference(&wb).cloned().collect(),
        warnings_only_b: wb.difference(&wa).cloned().collect(),
        files: files(store, a, b),
    })
}

/// Every response of either run, with the seed noise when both have
/// replicates among `records`.
fn responses(a: &Record, b: &Record, records: &[Record]) -> Vec<ResponseChange> {
    let replicates = |r: &Record| -> Vec<&Record> {
        let key = seed_key(r);
        records
            .iter()
            .filter(|x| key.is_some() && seed_key(x) == key)
            .collect()
    };
    let (reps_a, reps_b) = (replicates(a), replicates(b));
    let names: BTreeSet<&String> = a.responses.keys().chain(b.responses.keys()).collect();
    names
        .into_iter()
        .map(|name| {
            let values = |reps: &[&Record]| -> Vec<f64> {
                reps.iter()
                    .filter_map(|r| r.responses.get(name).copied())
                    .collect()
            };
            let seed_noise = match (mean_ci(&values(&reps_a)), mean_ci(&values(&reps_b))) {
                (Some(ma), Some(mb)) => {
                    let (difference, hw) = difference_ci(&mb, &ma);
                    Some(SeedNoise {
                        n_a: ma.n,
                        n_b: mb.n,
                        difference,
                        ci95_half_width: hw,
                        inside_noise: difference.abs() <= hw,
                    })
                }
                _ => None,
            };
            let (va, vb) = (
                a.responses.get(name).copied(),
                b.responses.get(name).copied(),
            );
            ResponseChange {
                response: name.clone(),
                a: va,
                b: vb,
                difference: va.zip(vb).map(|(x, y)| y - x),
                seed_noise,
            }
        })
        .collect()
}

/// The sealed files of both runs (a run without a seal has none), each as it
/// is on disk now (size and hash of the file, not the seal's record of it:
/// a damaged run shows what it holds; a sealed file now missing has none).
fn files(store: &Store, a: &ContentId, b: &ContentId) -> Vec<FileChange> {
    let seal = |id: &ContentId| -> BTreeMap<String, FileDigest> {
        let dir = store.run_dir(id);
        Store::read_json::<Seal>(&dir.seal_path())
            .map(|s| s.files)
            .unwrap_or_default()
            .into_keys()
            .filter_map(|name| {
                let digest = FileDigest::of_file(&dir.path().join(&name)).ok()?;
                Some((name, digest))
            })
            .collect()
    };
    let (sa, sb): (BTreeMap<_, _>, BTreeMap<_, _>) = (seal(a), seal(b));
    let names: BTreeSet<&String> = sa.keys().chain(sb.keys()).collect();
    names
        .into_iter()
        .map(|name| FileChange {
            file: name.clone(),
            a: sa.get(name).cloned(),
            b: sb.get(name).cloned(),
        })
        .collect()
}

impl RunDiff {
    /// The diff as text: one section per part, `A → B` for each change.
    pub fn text(&self) -> String {
        let num = |v: Option<f64>| v.map_or("-".to_string(), short_number);
        let mut out = format!("runs {} → {}\n", self.a.short(12), self.b.short(12));
        out.push_str(&format!(
            "status: {} → {}\n",
            self.status[0], self.status[1]
        ));
        let pv = self
            .physics_version
            .map(|v| v.map_or("?".into(), |v| v.to_string()));
        out.push_str(&format!("physics_version: {} → {}\n", pv[0], pv[1]));
        out.push_str(&format!(
            "manifest fields that differ ({}):\n",
            self.manifest.len()
        ));
        for c in &self.manifest {
            out.push_str(&c.line());
        }
        out.push_str(&format!("responses ({}), B − A:\n", self.responses.len()));
        for r in &self.responses {
            out.push_str(&format!(
                "  {}: {} → {} (Δ {})",
                r.response,
                num(r.a),
                num(r.b),
                num(r.difference)
            ));
            if let Some(s) = &r.seed_noise {
                out.push_str(&format!(
                    "; over replicates ({} vs {}) Δ {} ± {} (Welch 95 %): {}",
                    s.n_a,
                    s.n_b,
                    short_number(s.difference),
                    short_number(s.ci95_half_width),
                    if s.inside_noise {
                        "inside the seed noise"
                    } else {
                        "beyond the seed noise"
                    }
                ));
            }
            out.push('\n');
        }
        for (label, list) in [
            ("only A", &self.warnings_only_a),
            ("only B", &self.warnings_only_b),
        ] {
            for w in list {
                out.push_str(&format!("warning ({label}): {w}\n"));
            }
        }
        out.push_str("sealed files (sha256, bytes):\n");
        for f in &self.files {
            let d = |d: &Option<FileDigest>| {
                d.as_ref().map_or("(none)".into(), |d| {
                    format!("{} {}", &d.sha256[..12], d.bytes)
                })
            };
            let same = if f.a == f.b { "same" } else { "differs" };
            out.push_str(&format!(
                "  {}: {} → {} ({same})\n",
                f.file,
                d(&f.a),
                d(&f.b)
            ));
        }
        out
    }
}
