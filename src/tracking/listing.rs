//! `repose runs list` with a query: every run of the store, filtered, grouped
//! over packing seeds, sorted, with the columns asked for.
//!
//! The steps, in order: each run's fields ([`super::fields`]); every field
//! the options name is checked against the fields the store's runs have (an
//! unknown one is refused with the closest known names before anything is
//! printed); the `--where` filters keep the runs that pass them all (on the
//! runs, before grouping: a filter on a response keeps the replicates that
//! have such a value); `--group-seeds` folds replicates ([`super::group`]);
//! `--sort` orders the rows (a group by its shared values and its responses'
//! means); the columns are `--columns` or [`DEFAULT_COLUMNS`] (grouped: with
//! every response of the listed runs), with `id` first (and `n` beside it,
//! grouped); `--only-changed` keeps of those (or, without `--columns`, of
//! every field of the listed runs) the ones whose shown value is not the
//! same on every row.
//!
//! Without any of `--columns`, `--only-changed` and `--group-seeds`, text
//! output is the classic table of [`RunSummary::row`], byte for byte what
//! `repose runs list` printed before queries existed (filters and sorts only
//! choose and order its rows).
//!
//! [`RunSummary::row`]: crate::store::RunSummary::row

use std::collections::BTreeSet;
use std::path::PathBuf;

use super::fields::{closest, is_catalogue_response, known_fields, Record, Value, BUILTINS};
use super::group::{group_by_seed, Estimate, Group};
use super::query::{order_by, Filter, SortKey};
use super::TrackingError;
use crate::manifest::ContentId;
use crate::store::{Store, HEADLINE_KEY};

/// The columns of a listing when none are asked for: those of the classic
/// table (id, scene, profile, particle–particle restitution, friction and
/// surface energy in J/m², status, headline angle in degrees).
pub const DEFAULT_COLUMNS: [&str; 8] = [
    "id",
    "scene",
    "profile",
    "contact.particle_particle.restitution",
    "contact.particle_particle.static_friction",
    "contact.particle_particle.surface_energy_j_m2",
    "status",
    HEADLINE_KEY,
];

/// What `repose runs list` was asked (module docs); the default lists every
/// run in the classic table.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ListOptions {
    /// `--where` expressions, all of which must hold.
    pub filters: Vec<String>,
    /// `--sort` arguments (`FIELD[:desc]`, comma lists allowed).
    pub sort: Vec<String>,
    /// `--columns`, in order.
    pub columns: Option<Vec<String>>,
    /// `--only-changed`.
    pub only_changed: bool,
    /// `--group-seeds`.
    pub group_seeds: bool,
}

/// One row of a listing: a run, or a group of replicates.
#[derive(Debug, Clone)]
pub enum Row {
    /// One run (boxed: a record holds its manifest and result).
    Run(Box<Record>),
    /// Replicates folded together.
    Group(Group),
}

impl Row {
    /// The runs of the row, in store order.
    pub fn records(&self) -> &[Record] {
        match self {
            Row::Run(r) => std::slice::from_ref(r),
            Row::Group(g) => &g.members,
        }
    }

    /// The id of the row's first run.
    pub fn id(&self) -> &ContentId {
        &self.records()[0].summary.id
    }

    /// The row's value of `field`: the run's, or the value the group's runs
    /// share, or the mean of a group's response; `n` is the number of runs.
    pub fn get(&self, field: &str) -> Option<Value> {
        if field == "n" {
            return Some(Value::Number(self.records().len() as f64));
        }
        match self {
            Row::Run(r) => r.get(field),
            Row::Group(g) => g
                .common
                .get(field)
                .cloned()
                .or_else(|| g.estimates.get(field).map(|e| Value::Number(e.mean))),
        }
    }

    /// A group's estimate of response `field`.
    pub fn estimate(&self, field: &str) -> Option<&Estimate> {
        match self {
            Row::Run(_) => None,
            Row::Group(g) => g.estimates.get(field),
        }
    }
}

/// A listing ready to print ([`super::render`]).
#[derive(Debug, Clone)]
pub struct Listing {
    /// The store's root (for "no runs in …").
    pub root: PathBuf,
    /// Runs in the store before filtering.
    pub total: usize,
    /// Text output is the classic table (module docs).
    pub classic: bool,
    /// Rows are groups of replicates.
    pub grouped: bool,
    /// The columns, `id` first (and `n` second, grouped).
    pub columns: Vec<String>,
    /// The rows, in order.
    pub rows: Vec<Row>,
}

impl Listing {
    /// `id12: problem` for every damaged run listed.
    pub fn damaged(&self) -> Vec<String> {
        self.rows
            .iter()
            .flat_map(Row::records)
            .filter_map(|r| {
                r.summary
                    .problem
                    .as_ref()
                    .map(|p| format!("{}: {p}", r.summary.id.short(12)))
            })
            .collect()
    }
}

/// The listing of `store` that `options` ask for (module docs).
pub fn list_runs(store: &Store, options: &ListOptions) -> Result<Listing, TrackingError> {
    let mut records: Vec<Record> = store.list()?.into_iter().map(Record::new).collect();
    let total = records.len();
    let known = known_fields(&records);
    let filters = options
        .filters
        .iter()
        .map(|f| Filter::parse(f))
        .collect::<Result<Vec<_>, _>>()?;
    let keys = SortKey::parse_all(&options.sort)?;
    // `n` (runs per row) is a column and a sort key, not a run's field.
    let shown = keys.iter().map(|k| &k.field);
    let shown = shown.chain(options.columns.iter().flatten());
    let unknown = filters
        .iter()
        .map(|f| &f.field)
        .find(|f| !known.contains(*f))
        .or_else(|| shown.into_iter().find(|f| *f != "n" && !known.contains(*f)));
    if let Some(field) = unknown {
        return Err(TrackingError::UnknownField {
            field: field.clone(),
            closest: closest(field, &known),
        });
    }
    for f in &filters {
        let values = records.iter().filter_map(|r| r.get(&f.field));
        f.check_kind(values, is_catalogue_response(&f.field))?;
    }
    records.retain(|r| filters.iter().all(|f| f.accepts(r.get(&f.field).as_ref())));
    let rows: Vec<Row> = if options.group_seeds {
        group_by_seed(records).into_iter().map(Row::Group).collect()
    } else {
        records.into_iter().map(|r| Row::Run(Box::new(r))).collect()
    };
    let rows = sorted(rows, &keys);
    let columns = columns(&rows, options);
    Ok(Listing {
        root: store.root().to_path_buf(),
        total,
        classic: options.columns.is_none() && !options.only_changed && !options.group_seeds,
        grouped: options.group_seeds,
        columns,
        rows,
    })
}

/// `rows` stably sorted by `keys`.
fn sorted(rows: Vec<Row>, keys: &[SortKey]) -> Vec<Row> {
    if keys.is_empty() {
        return rows;
    }
    let mut keyed: Vec<(Vec<Option<Value>>, Row)> = rows
        .into_iter()
        .map(|r| (keys.iter().map(|k| r.get(&k.field)).collect(), r))
        .collect();
    keyed.sort_by(|(a, _), (b, _)| {
        keys.iter()
            .zip(a.iter().zip(b))
            .map(|(k, (a, b))| order_by(k, a.as_ref(), b.as_ref()))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    keyed.into_iter().map(|(_, r)| r).collect()
}

/// The columns of the listing (module docs).
fn columns(rows: &[Row], options: &ListOptions) -> Vec<String> {
    let mut wanted: Vec<String> = match (&options.columns, options.only_changed) {
        (Some(c), _) => c.clone(),
        (None, true) => every_field(rows),
        (None, false) => {
            let mut c: Vec<String> = DEFAULT_COLUMNS.iter().map(|s| s.to_string()).collect();
            if options.group_seeds {
                let responses = rows.iter().flat_map(Row::records);
                let responses: BTreeSet<&String> =
                    responses.flat_map(|r| r.responses.keys()).collect();
                c.extend(
                    responses
                        .into_iter()
                        .filter(|r| **r != HEADLINE_KEY)
                        .cloned(),
                );
            }
            c
        }
    };
    wanted.retain(|c| c != "id" && c != "n");
    if options.only_changed {
        wanted.retain(|c| changes(rows, c));
    }
    let mut columns = vec!["id".to_string()];
    if options.group_seeds {
        columns.push("n".to_string());
    }
    columns.extend(wanted);
    columns
}

/// Every field of the listed runs: the built-ins, the manifest paths, then
/// the responses.
fn every_field(rows: &[Row]) -> Vec<String> {
    let records = || rows.iter().flat_map(Row::records);
    let manifest: BTreeSet<&String> = records().flat_map(|r| r.manifest.keys()).collect();
    let responses: BTreeSet<&String> = records().flat_map(|r| r.responses.keys()).collect();
    let mut fields: Vec<String> = BUILTINS.iter().map(|s| s.to_string()).collect();
    fields.extend(manifest.into_iter().cloned());
    fields.extend(responses.into_iter().cloned());
    fields
}

/// Whether `field` is not the same on every row (a missing value counts as
/// one value; a group's response by its estimate).
fn changes(rows: &[Row], field: &str) -> bool {
    let shown = |r: &Row| (r.get(field), r.estimate(field).copied());
    let first = rows.first().map(shown);
    rows.iter().skip(1).any(|r| Some(shown(r)) != first)
}
