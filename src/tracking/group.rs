//! Replicates: runs whose manifests differ only in their packing seed, folded
//! into one group with the mean and 95 % confidence interval of each response.
//!
//! Two runs are replicates when every manifest field but [`PACKING_SEED`] is
//! equal (the design seed and sample index included: they are what a study
//! varies between points). A run whose manifest cannot be read is a group of
//! its own. Groups keep the order of their first run.
//!
//! A group's field is shown when all its runs agree on it (the status too;
//! otherwise the distinct statuses joined by `+`, e.g. `complete+failed`).
//! Each response becomes an [`Estimate`] over the runs that have it: n, the
//! mean and the half-width of its Student-t 95 % interval,
//! t₀.₉₇₅(n − 1)·s/√n ([`crate::stats::summary::mean_ci`]); with one value
//! there is no interval.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use super::fields::{Record, Value, BUILTINS};
use crate::stats::summary::{mean_ci, MeanCi};

/// The manifest field replicates differ in.
pub const PACKING_SEED: &str = "seeds.packing_seed";

/// A response over the replicates of one group, in the response's unit.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// Runs that have the response.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// Half-width of the 95 % interval of the mean; `None` for one value.
    pub ci95_half_width: Option<f64>,
}

impl Estimate {
    /// The estimate of `values` (at least one).
    pub fn of(values: &[f64]) -> Estimate {
        match mean_ci(values) {
            Some(MeanCi {
                mean,
                n,
                half_width,
                ..
            }) => Estimate {
                n,
                mean,
                ci95_half_width: Some(half_width),
            },
            None => Estimate {
                n: values.len(),
                mean: values.iter().sum::<f64>() / values.len().max(1) as f64,
                ci95_half_width: None,
            },
        }
    }
}

/// Replicate runs folded into one row (module docs).
#[derive(Debug, Clone)]
pub struct Group {
    /// The runs, in store order.
    pub members: Vec<Record>,
    /// The fields every run agrees on (and the joined statuses).
    pub common: BTreeMap<String, Value>,
    /// Each response over the runs that have it.
    pub estimates: BTreeMap<String, Estimate>,
}

impl Group {
    fn of(members: Vec<Record>) -> Group {
        let mut names: BTreeSet<&str> = BUILTINS.into_iter().collect();
        let mut responses: BTreeSet<&str> = BTreeSet::new();
        for m in &members {
            names.extend(m.manifest.keys().map(String::as_str));
            responses.extend(m.responses.keys().map(String::as_str));
        }
        let mut common = BTreeMap::new();
        for name in names {
            if let Some(first) = members[0].get(name) {
                if members[1..]
                    .iter()
                    .all(|m| m.get(name).as_ref() == Some(&first))
                {
                    common.insert(name.to_string(), first);
                }
            }
        }
        if !common.contains_key("status") {
            let statuses: BTreeSet<String> = members
                .iter()
                .map(|m| m.summary.status.to_string())
                .collect();
            let joined = statuses.into_iter().collect::<Vec<_>>().join("+");
            common.insert("status".to_string(), Value::Text(joined));
        }
        let estimates = responses
            .into_iter()
            .filter(|r| !common.contains_key(*r))
            .map(|r| {
                let values: Vec<f64> = members
                    .iter()
                    .filter_map(|m| m.responses.get(r).copied())
                    .collect();
                (r.to_string(), Estimate::of(&values))
            })
            .collect();
        Group {
            members,
            common,
            estimates,
        }
    }
}

/// What replicates share: the manifest without its packing seed, as text;
/// `None` for a run without a readable manifest.
pub fn seed_key(record: &Record) -> Option<String> {
    if record.manifest.is_empty() {
        return None;
    }
    let mut key = String::new();
    for (k, v) in record.manifest.iter().filter(|(k, _)| *k != PACKING_SEED) {
        key.push_str(k);
        key.push('=');
        key.push_str(&v.to_string());
        key.push('\n');
    }
    Some(key)
}

/// `records` folded into groups of replicates (module docs).
pub fn group_by_seed(records: Vec<Record>) -> Vec<Group> {
    let mut order: Vec<Vec<Record>> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for record in records {
        match seed_key(&record) {
            Some(key) => {
                let next = order.len();
                let at = *index.entry(key).or_insert(next);
                if at == next {
                    order.push(Vec::new());
                }
                order[at].push(record);
            }
            None => order.push(vec![record]),
        }
    }
    order.into_iter().map(Group::of).collect()
}
