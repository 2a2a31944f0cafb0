//! `repose verdict --table FILE.csv`: the acceptance rule
//! ([`crate::study::acceptance`]) on any table of replicates — lab data, another
//! code's runs, or a stage's own `runs.csv` — so a verdict printed by a study
//! can be recomputed from its replicates by the same rule.
//!
//! Rows are grouped by the `--group` columns (none: one group) in order of
//! first appearance. An empty cell in the value column is a missing
//! replicate (a run that could not measure the response), counted beside n;
//! any other cell that is not a finite number is an error naming its line,
//! column and value. The band is target × (1 ∓ tolerance), with the target
//! a finite non-zero number and the tolerance in (0, 1). A table without
//! rows, and a group whose mean or spread is not a finite number, are
//! refused rather than printed.

use std::collections::HashMap;
use std::path::Path;

use serde::Serialize;

use crate::report::markdown::MarkdownTable;
use crate::report::table::Table;
use crate::stats::equivalence::band;
use crate::study::acceptance::{judge, Judgement};
use crate::study::StudyError;

/// What to judge in a table.
#[derive(Debug, Clone)]
pub struct VerdictSpec {
    /// The column of replicate values.
    pub value: String,
    /// Columns whose values name a group (empty: the whole table is one).
    pub group: Vec<String>,
    /// The target, units of the values.
    pub target: f64,
    /// Accepted relative deviation, in (0, 1).
    pub tolerance: f64,
}

/// One group's verdict.
#[derive(Debug, Clone, Serialize)]
pub struct GroupVerdict {
    /// The group's values of the `--group` columns, in their order.
    pub group: Vec<String>,
    /// Rows with an empty value cell.
    pub missing: usize,
    /// The rule's judgement of the measured values.
    pub judgement: Judgement,
}

/// Every group's verdict.
#[derive(Debug, Clone, Serialize)]
pub struct TableVerdicts {
    /// The value column.
    pub value: String,
    /// The group columns.
    pub group_columns: Vec<String>,
    /// The target.
    pub target: f64,
    /// The tolerance.
    pub tolerance: f64,
    /// The band, target × (1 ∓ tolerance).
    pub band: (f64, f64),
    /// The rule in words.
    pub rule: String,
    /// One entry per group, in order of first appearance.
    pub groups: Vec<GroupVerdict>,
}

/// Judges the table at `path` (see the module docs).
pub fn judge_table(path: &Path, spec: &VerdictSpec) -> Result<TableVerdicts, StudyError> {
    if !(spec.target.is_finite() && spec.target != 0.0) {
        return Err(StudyError::Settings(format!(
            "--target = {:?}: must be a finite non-zero number",
            spec.target
        )));
    }
    if !(spec.tolerance > 0.0 && spec.tolerance < 1.0) {
        return Err(StudyError::Settings(format!(
            "--tolerance = {:?}: must lie in (0, 1) (a fraction of the target)",
            spec.tolerance
        )));
    }
    let table = Table::read(path)?;
    let values = table.optional_numbers(path, &spec.value)?;
    let keys = spec
        .group
        .iter()
        .map(|g| table.require(path, g))
        .collect::<Result<Vec<_>, _>>()?;
    if table.rows.is_empty() {
        return Err(StudyError::Settings(format!(
            "{}: the table has a header and no rows; there is nothing to judge",
            path.display()
        )));
    }
    let band = band(spec.target, spec.tolerance);
    // Groups in order of first appearance, found by a hash index (a linear
    // search made a million groups quadratic).
    let mut groups: Vec<(Vec<String>, Vec<f64>, usize)> = Vec::new();
    let mut index: HashMap<Vec<String>, usize> = HashMap::new();
    for (i, row) in table.rows.iter().enumerate() {
        let key: Vec<String> = keys.iter().map(|&k| row[k].clone()).collect();
        let k = *index.entry(key).or_insert_with_key(|key| {
            groups.push((key.clone(), Vec::new(), 0));
            groups.len() - 1
        });
        match values[i] {
            Some(v) => groups[k].1.push(v),
            None => groups[k].2 += 1,
        }
    }
    let groups: Vec<GroupVerdict> = groups
        .into_iter()
        .map(|(group, values, missing)| GroupVerdict {
            group,
            missing,
            judgement: judge(&values, band),
        })
        .collect();
    for g in &groups {
        let finite = g.judgement.tost.is_none_or(|t| {
            t.mean.is_finite() && t.sd.is_finite() && t.ci95_half_width.is_finite()
        });
        if !finite {
            return Err(StudyError::Settings(format!(
                "group [{}] of {}: its mean or standard deviation is not a finite number \
                 (values beyond the range of 64-bit floats); rescale the column",
                g.group.join(", "),
                path.display()
            )));
        }
    }
    Ok(TableVerdicts {
        value: spec.value.clone(),
        group_columns: spec.group.clone(),
        target: spec.target,
        tolerance: spec.tolerance,
        band,
        rule: crate::study::acceptance::RULE.to_string(),
        groups,
    })
}

/// The verdicts as a Markdown table, with the band and the rule above it.
pub fn markdown(v: &TableVerdicts) -> String {
    let mut header: Vec<&str> = v.group_columns.iter().map(String::as_str).collect();
    header.extend([
        "n (missing)",
        "mean",
        "sd",
        "95 % CI",
        "t lower (p)",
        "t upper (p)",
        "TOST p",
        "verdict",
        "seeds to decide",
    ]);
    let mut t = MarkdownTable::new(&header);
    for g in &v.groups {
        let j = &g.judgement;
        let mut row = g.group.clone();
        row.push(format!("{} ({})", j.n, g.missing));
        row.push(j.mean.map_or("—".into(), |m| number(m, 4)));
        match &j.tost {
            Some(t) => row.extend([
                number(t.sd, 4),
                format!(
                    "{} – {}",
                    number(t.mean - t.ci95_half_width, 4),
                    number(t.mean + t.ci95_half_width, 4)
                ),
                format!("{} ({})", number(t.t_lower, 3), p_text(t.p_lower)),
                format!("{} ({})", number(t.t_upper, 3), p_text(t.p_upper)),
                p_text(t.p),
            ]),
            None => row.extend(std::iter::repeat_n("—".to_string(), 5)),
        }
        row.push(j.verdict.to_string());
        row.push(j.seeds_to_decide.map_or("—".into(), |n| n.to_string()));
        t.row(&row);
    }
    format!(
        "`{}` against {} × (1 ∓ {}) = [{}, {}]: {}.\n\n{}",
        v.value,
        number(v.target, 4),
        v.tolerance,
        number(v.band.0, 4),
        number(v.band.1, 4),
        v.rule,
        t.render()
    )
}

/// A statistic to `decimals` places, in scientific notation past 10¹⁵ (not
/// 300 digits), and `—` for the 0/0 t of a mean exactly on a band edge with
/// no spread (its p is 1: nothing rejects).
fn number(v: f64, decimals: usize) -> String {
    if v.is_nan() {
        "—".to_string()
    } else if v.is_finite() && v.abs() >= 1e15 {
        format!("{v:.decimals$e}")
    } else {
        format!("{v:.decimals$}")
    }
}

/// A p-value to four decimals, or in scientific notation below 10⁻⁴.
fn p_text(p: f64) -> String {
    if p < 1e-4 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}
