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
//! a finite non-zero number and the tolerance in (0, 1).

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
            "--target = {}: must be a finite non-zero number",
            spec.target
        )));
    }
    if !(spec.tolerance > 0.0 && spec.tolerance < 1.0) {
        return Err(StudyError::Settings(format!(
            "--tolerance = {}: must lie in (0, 1) (a fraction of the target)",
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
    let band = band(spec.target, spec.tolerance);
    let mut groups: Vec<(Vec<String>, Vec<f64>, usize)> = Vec::new();
    for (i, row) in table.rows.iter().enumerate() {
        let key: Vec<String> = keys.iter().map(|&k| row[k].clone()).collect();
        let parsed = values[i];
        let entry = match groups.iter().position(|g| g.0 == key) {
            Some(k) => &mut groups[k],
            None => {
                groups.push((key, Vec::new(), 0));
                groups.last_mut().expect("just pushed")
            }
        };
        match parsed {
            Some(v) => entry.1.push(v),
            None => entry.2 += 1,
        }
    }
    Ok(TableVerdicts {
        value: spec.value.clone(),
        group_columns: spec.group.clone(),
        target: spec.target,
        tolerance: spec.tolerance,
        band,
        rule: crate::study::acceptance::RULE.to_string(),
        groups: groups
            .into_iter()
            .map(|(group, values, missing)| GroupVerdict {
                group,
                missing,
                judgement: judge(&values, band),
            })
            .collect(),
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
        row.push(j.mean.map_or("—".into(), |m| format!("{m:.4}")));
        match &j.tost {
            Some(t) => row.extend([
                format!("{:.4}", t.sd),
                format!(
                    "{:.4} – {:.4}",
                    t.mean - t.ci95_half_width,
                    t.mean + t.ci95_half_width
                ),
                format!("{:.3} ({})", t.t_lower, p_text(t.p_lower)),
                format!("{:.3} ({})", t.t_upper, p_text(t.p_upper)),
                p_text(t.p),
            ]),
            None => row.extend(std::iter::repeat_n("—".to_string(), 5)),
        }
        row.push(j.verdict.to_string());
        row.push(j.seeds_to_decide.map_or("—".into(), |n| n.to_string()));
        t.row(&row);
    }
    format!(
        "`{}` against {} × (1 ∓ {}) = [{:.4}, {:.4}]: {}.\n\n{}",
        v.value,
        v.target,
        v.tolerance,
        v.band.0,
        v.band.1,
        v.rule,
        t.render()
    )
}

/// A p-value to four decimals, or in scientific notation below 10⁻⁴.
fn p_text(p: f64) -> String {
    if p < 1e-4 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}
