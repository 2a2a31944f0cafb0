//! Level 3 of yan2015 (§2.2.3, §4.2.3): the norms (Eq. 17) and the
//! cross-correlation (Eq. 18) of the parameter sensitivity matrix of the
//! contact laws, a priori — no simulation is needed.
//!
//! For each parameter set (the study's base experiment, then every design
//! point) the particle–particle contact ([`super::parameters::pair_spec`]) is
//! evaluated at yan2015's 81 a-priori states
//! ([`crate::dem::contact::sensitivity::a_priori_states`]) for two model
//! responses, the force magnitude (the translational equation of motion, Eq.
//! 2) and the torque magnitude (the rotational one, Eq. 3). Row i of the
//! matrix of a response holds `P_k ∂f_i/∂P_k` for the four parameters e, μs,
//! μr and E (always all four, as the paper, whichever are the study's
//! factors), from the analytic derivatives of our own contact laws
//! ([`crate::dem::contact::sensitivity::sensitivity`]), so the analysis
//! cannot drift from what the engine simulates. Each column's norm is shown
//! with its share of the four norms (yan2015 Fig. 14's "normalised norms").
//! When the matrix is rank-deficient the cross-correlation is not defined:
//! the null vector then says which parameters are fully cross-correlated.

use serde::{Deserialize, Serialize};

use super::parameters::pair_spec;
use crate::dem::contact::sensitivity::{a_priori_states, sensitivity, PairSpec, Parameter};
use crate::report::markdown::MarkdownTable;
use crate::report::table::{Cell, CsvWriter};
use crate::stats::sensitivity::{cross_correlation, normalised, norms, CrossCorrelation};

/// The two model responses of the contact law.
pub const EQUATIONS: [Equation; 2] = [Equation::Force, Equation::Torque];

/// A model response of one contact: the translational or the rotational
/// equation of motion's contact term.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Equation {
    /// |F|, the magnitude of the contact force on a particle, N (yan2015
    /// Eq. 2, "equation of motion for mass").
    Force,
    /// |τ|, the magnitude of the contact torque on a particle, N·m (Eq. 3,
    /// "equation of motion for moment of inertia").
    Torque,
}

impl Equation {
    /// Its name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Equation::Force => "force",
            Equation::Torque => "torque",
        }
    }
}

/// The level-3 analysis of one parameter set and one equation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Norms {
    /// `base` or `point <i>` (the design point's index).
    pub set: String,
    /// The four parameter values e, μs, μr, E (Pa).
    pub parameters: [f64; 4],
    /// The equation.
    pub equation: Equation,
    /// Eq. 17 norm per parameter (the response's unit: N or N·m).
    pub norms: Vec<f64>,
    /// Each norm's share of their sum.
    pub shares: Vec<f64>,
    /// The parameters (indices into [`Parameter::ALL`]) the cross-correlation
    /// is over: those with a sensitivity (a parameter whose column is zero at
    /// every state, such as μr in the force, is left out: it has nothing to
    /// correlate).
    pub correlated: Vec<usize>,
    /// Eq. 18 over `correlated`.
    pub cross_correlation: CrossCorrelation,
}

/// What level 3 found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Level3 {
    /// States per matrix (81).
    pub states: usize,
    /// The nominal particle radius the states were built for, m.
    pub radius_m: f64,
    /// The base experiment's analyses (force, torque), then every design
    /// point's.
    pub sets: Vec<Norms>,
}

/// The scaled sensitivity matrix of `spec` for `equation`: one row per
/// state, `P_k ∂f/∂P_k` per parameter in [`Parameter::ALL`] order.
pub fn matrix(spec: &PairSpec, equation: Equation) -> Vec<Vec<f64>> {
    a_priori_states(2.0 * spec.radius_m)
        .iter()
        .map(|state| {
            let s = sensitivity(spec, state);
            let d = match equation {
                Equation::Force => s.d_force,
                Equation::Torque => s.d_torque,
            };
            Parameter::ALL
                .iter()
                .zip(d)
                .map(|(p, d)| spec.value(*p) * d)
                .collect()
        })
        .collect()
}

/// The analyses of one parameter set.
fn analyse(set: &str, spec: &PairSpec) -> Vec<Norms> {
    EQUATIONS
        .iter()
        .map(|&equation| {
            let s = matrix(spec, equation);
            let n = norms(&s);
            let correlated: Vec<usize> = (0..n.len()).filter(|&k| n[k] > 0.0).collect();
            let kept: Vec<Vec<f64>> = s
                .iter()
                .map(|row| correlated.iter().map(|&k| row[k]).collect())
                .collect();
            Norms {
                set: set.to_string(),
                parameters: Parameter::ALL.map(|p| spec.value(p)),
                equation,
                shares: normalised(&n),
                norms: n,
                cross_correlation: cross_correlation(&kept),
                correlated,
            }
        })
        .collect()
}

/// Level 3 for the base experiment and each design point (`points`: the
/// experiments of the design points, one per point, in design order).
pub fn level3(
    base: &crate::manifest::Experiment,
    points: &[crate::manifest::Experiment],
) -> Result<Level3, String> {
    let base_spec = pair_spec(base)?;
    let mut sets = analyse("base", &base_spec);
    for (i, e) in points.iter().enumerate() {
        sets.extend(analyse(&format!("point {i}"), &pair_spec(e)?));
    }
    Ok(Level3 {
        states: a_priori_states(2.0 * base_spec.radius_m).len(),
        radius_m: base_spec.radius_m,
        sets,
    })
}

/// `norms.csv`: one row per set and equation.
pub fn norms_csv(l: &Level3) -> String {
    let mut header = vec!["set".to_string(), "equation".into()];
    header.extend(Parameter::ALL.iter().map(|p| format!("value_{}", p.name())));
    header.extend(Parameter::ALL.iter().map(|p| format!("norm_{}", p.name())));
    header.extend(Parameter::ALL.iter().map(|p| format!("share_{}", p.name())));
    let mut csv = CsvWriter::new(&header);
    for s in &l.sets {
        let mut cells = vec![
            Cell::Text(s.set.clone()),
            Cell::Text(s.equation.name().into()),
        ];
        cells.extend(s.parameters.iter().map(|v| Cell::Number(*v)));
        cells.extend(s.norms.iter().map(|v| Cell::Number(*v)));
        cells.extend(s.shares.iter().map(|v| Cell::Number(*v)));
        csv.row(&cells);
    }
    csv.finish()
}

/// `cross_correlation.csv`: per set and equation, one row per correlated
/// parameter with its CC against each parameter (empty for a parameter
/// without sensitivity), or (rank-deficient) one row `null_vector` with the
/// null vector's components and the rank.
pub fn cross_correlation_csv(l: &Level3) -> String {
    let mut header = vec![
        "set".to_string(),
        "equation".into(),
        "row".into(),
        "rank".into(),
    ];
    header.extend(Parameter::ALL.iter().map(|p| p.name().to_string()));
    let mut csv = CsvWriter::new(&header);
    for s in &l.sets {
        let lead = |row: String, rank: usize| {
            vec![
                Cell::Text(s.set.clone()),
                Cell::Text(s.equation.name().into()),
                Cell::Text(row),
                Cell::Integer(rank as u64),
            ]
        };
        let spread = |values: &[f64]| {
            let mut cells = vec![Cell::Empty; Parameter::ALL.len()];
            for (&k, v) in s.correlated.iter().zip(values) {
                cells[k] = Cell::Number(*v);
            }
            cells
        };
        match &s.cross_correlation {
            CrossCorrelation::Full(cc) => {
                for (&k, row) in s.correlated.iter().zip(cc) {
                    let mut cells = lead(Parameter::ALL[k].name().into(), s.correlated.len());
                    cells.extend(spread(row));
                    csv.row(&cells);
                }
            }
            CrossCorrelation::Singular { rank, null_vector } => {
                let mut cells = lead("null_vector".into(), *rank);
                cells.extend(spread(null_vector));
                csv.row(&cells);
            }
        }
    }
    csv.finish()
}

/// The ranking of the parameters by share, largest first, as `μs > μr > …`.
pub fn ranking(shares: &[f64]) -> String {
    let mut order: Vec<usize> = (0..shares.len()).collect();
    order.sort_by(|a, b| shares[*b].total_cmp(&shares[*a]));
    order
        .iter()
        .map(|&k| Parameter::ALL[k].symbol())
        .collect::<Vec<_>>()
        .join(" > ")
}

/// The level-3 section of the report.
pub fn markdown(l: &Level3) -> String {
    let symbols: Vec<&str> = Parameter::ALL.iter().map(|p| p.symbol()).collect();
    let mut md = format!(
        "## Level 3: norms of the contact-law sensitivity matrix (a priori)\n\n\
         {} states (vn, vt ∈ {{1e-4, 1e-2, 1}} m/s, ω ∈ {{0.01, 1, 100}} rad/s, δn = δt ∈ \
         {{0.1, 1, 10}} % of the {:.3} mm diameter) × {}, scaled by the parameter (Eq. 17); \
         shares of the four norms. yan2015 Fig. 14: μs dominates the force, μr the torque \
         with μs second; Table 6: e and E fully cross-correlated.\n\n",
        l.states,
        2e3 * l.radius_m,
        symbols.join(", ")
    );
    for eq in EQUATIONS {
        let sets: Vec<&Norms> = l.sets.iter().filter(|s| s.equation == eq).collect();
        let mut header = vec!["Set".to_string(), "e, μs, μr, E".into()];
        header.extend(symbols.iter().map(|s| format!("share {s}")));
        header.push("ranking".into());
        let mut t = MarkdownTable::new(&header);
        for s in sets.iter().take(1) {
            t.row(&share_row(s));
        }
        let mut means = vec![0.0; 4];
        let (mut lo, mut hi) = (vec![f64::INFINITY; 4], vec![f64::NEG_INFINITY; 4]);
        let design: Vec<&&Norms> = sets.iter().skip(1).collect();
        for s in &design {
            for k in 0..4 {
                means[k] += s.shares[k] / design.len() as f64;
                lo[k] = lo[k].min(s.shares[k]);
                hi[k] = hi[k].max(s.shares[k]);
            }
        }
        if !design.is_empty() {
            let mut row = vec![
                format!("{} design points", design.len()),
                "mean (min–max)".into(),
            ];
            row.extend((0..4).map(|k| format!("{:.3} ({:.3}–{:.3})", means[k], lo[k], hi[k])));
            row.push(ranking(&means));
            t.row(&row);
        }
        md.push_str(&format!("### {} equation\n\n{}\n", eq.name(), t.render()));
        if let Some(base) = sets.first() {
            md.push_str(&format!(
                "Cross-correlation at the base set ({}):\n\n{}\n",
                parameter_text(&base.parameters),
                cc_markdown(&base.correlated, &base.cross_correlation)
            ));
        }
    }
    md
}

fn parameter_text(p: &[f64; 4]) -> String {
    format!("e {}, μs {}, μr {}, E {:.3e} Pa", p[0], p[1], p[2], p[3])
}

fn share_row(s: &Norms) -> Vec<String> {
    let mut row = vec![s.set.clone(), parameter_text(&s.parameters)];
    row.extend(s.shares.iter().map(|v| format!("{v:.3}")));
    row.push(ranking(&s.shares));
    row
}

/// Eq. 18 over the `correlated` parameters as a Markdown table, or the
/// null vector when it is not defined.
pub fn cc_markdown(correlated: &[usize], cc: &CrossCorrelation) -> String {
    let symbols: Vec<&str> = correlated
        .iter()
        .map(|&k| Parameter::ALL[k].symbol())
        .collect();
    let left_out: Vec<&str> = (0..Parameter::ALL.len())
        .filter(|k| !correlated.contains(k))
        .map(|k| Parameter::ALL[k].symbol())
        .collect();
    let mut md = match cc {
        CrossCorrelation::Full(m) => {
            let mut header = vec![String::new()];
            header.extend(symbols.iter().map(|s| s.to_string()));
            let mut t = MarkdownTable::new(&header);
            for (s, row) in symbols.iter().zip(m) {
                let mut cells = vec![s.to_string()];
                cells.extend(row.iter().map(|v| format!("{v:+.4}")));
                t.row(&cells);
            }
            t.render()
        }
        CrossCorrelation::Singular { rank, null_vector } => {
            let terms: Vec<String> = symbols
                .iter()
                .zip(null_vector)
                .filter(|(_, v)| v.abs() > 1e-6)
                .map(|(s, v)| format!("{v:+.4}·{s}"))
                .collect();
            format!(
                "not defined: the scaled columns of {} have rank {rank}; they satisfy \
                 {} = 0, so these parameters are fully cross-correlated (|CC| = 1).\n",
                symbols.join(", "),
                terms.join(" ")
            )
        }
    };
    if !left_out.is_empty() {
        md.push_str(&format!(
            "\n{} left out: no sensitivity at any state (zero column).\n",
            left_out.join(", ")
        ));
    }
    md
}
