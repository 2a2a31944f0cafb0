//! Level 2 of yan2015 (§2.2.2, §4.2.2): principal component analysis of the
//! auto-scaled sensitivity matrix with a bulk response as its last column
//! (Eq. 13–16, 25–26), one matrix for the force and one for the torque.
//!
//! One row per design point: for each factor that is a contact parameter
//! ([`super::parameters::parameter_of`]) its scaled sensitivity
//! `P ∂f/∂P` of the contact law at that point, then the point's bulk
//! response (the mean over its replicates). yan2015 uses "generalised"
//! derivatives (its Table 4: μs and μr linear, e through ψ(e)); we evaluate
//! the derivatives of our own contact law at one reference contact state,
//! the middle of level 3's a-priori grid ([`reference_state`]). Scaling by
//! the parameter is what makes the columns vary over the design (a linear
//! law's derivative is a constant, which auto-scaling cannot take); after
//! auto-scaling, a term proportional to ψ(e), μs or μr keeps no trace of the
//! state. A column that does not vary (a parameter the equation does not
//! contain: μr in the force, e in a sliding contact's torque) has no
//! sensitivity there and is left out, named in the report.

use serde::{Deserialize, Serialize};

use super::level3::{Equation, EQUATIONS};
use super::parameters::parameter_of;
use crate::dem::contact::sensitivity::{sensitivity, ContactState, PairSpec, Parameter};
use crate::report::markdown::MarkdownTable;
use crate::report::table::{Cell, CsvWriter};
use crate::stats::pca::{pca, Pca};

/// The reference contact state of level 2 for particles of `diameter_m`:
/// δn = δt = 1 % of the diameter, vn = vt = 0.01 m/s, ω = 1 rad/s (the
/// middle of level 3's grid).
pub fn reference_state(diameter_m: f64) -> ContactState {
    ContactState {
        normal_overlap_m: 0.01 * diameter_m,
        tangential_overlap_m: 0.01 * diameter_m,
        normal_speed_m_s: 1e-2,
        tangential_speed_m_s: 1e-2,
        angular_speed_rad_s: 1.0,
    }
}

/// One PCA: a bulk response against one equation's sensitivities.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Analysis {
    /// The bulk response.
    pub response: String,
    /// The equation.
    pub equation: Equation,
    /// Design points with a value of the response.
    pub points: usize,
    /// Factors left out, with why.
    pub dropped: Vec<(String, String)>,
    /// The PCA (columns: the kept factors, then the response), or None.
    pub pca: Option<Pca>,
    /// Why there is no PCA.
    pub problem: Option<String>,
}

/// What level 2 found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Level2 {
    /// The reference state.
    pub state: ContactState,
    /// One analysis per response and equation.
    pub analyses: Vec<Analysis>,
    /// Why there is no analysis at all (e.g. a JKR study).
    pub problem: Option<String>,
}

/// The inputs of level 2: the design's contact-parameter factors and, per
/// point, the pair at that point and the mean of each response.
pub struct Inputs {
    /// Factor names and addresses, study order.
    pub factors: Vec<(String, String)>,
    /// The particle–particle pair of each design point.
    pub pairs: Vec<PairSpec>,
    /// (response, per-point mean or None).
    pub responses: Vec<(String, Vec<Option<f64>>)>,
    /// The nominal particle diameter, m.
    pub diameter_m: f64,
}

/// Runs level 2 (see the module docs).
pub fn level2(inputs: &Inputs) -> Level2 {
    let state = reference_state(inputs.diameter_m);
    let params: Vec<(String, Option<_>)> = inputs
        .factors
        .iter()
        .map(|(name, address)| (name.clone(), parameter_of(address)))
        .collect();
    let mut analyses = Vec::new();
    for (response, means) in &inputs.responses {
        for equation in EQUATIONS {
            analyses.push(analyse(
                response,
                means,
                equation,
                &params,
                &inputs.pairs,
                &state,
            ));
        }
    }
    Level2 {
        state,
        analyses,
        problem: None,
    }
}

fn analyse(
    response: &str,
    means: &[Option<f64>],
    equation: Equation,
    params: &[(String, Option<Parameter>)],
    pairs: &[PairSpec],
    state: &ContactState,
) -> Analysis {
    let rows_at: Vec<usize> = (0..means.len()).filter(|&i| means[i].is_some()).collect();
    let mut dropped = Vec::new();
    let mut columns = Vec::new();
    let mut data: Vec<Vec<f64>> = vec![Vec::new(); rows_at.len()];
    for (name, p) in params {
        let Some(p) = p else {
            dropped.push((
                name.clone(),
                "not a particle–particle contact parameter".into(),
            ));
            continue;
        };
        let column: Vec<f64> = rows_at
            .iter()
            .map(|&i| {
                let s = sensitivity(&pairs[i], state);
                let d = match equation {
                    Equation::Force => s.d_force,
                    Equation::Torque => s.d_torque,
                }[Parameter::ALL
                    .iter()
                    .position(|q| q == p)
                    .expect("one of ALL")];
                pairs[i].value(*p) * d
            })
            .collect();
        let first = column.first().copied().unwrap_or(0.0);
        if column.iter().all(|v| *v == first) {
            dropped.push((
                name.clone(),
                format!(
                    "∂|{}|/∂{} does not vary over the design (no sensitivity)",
                    equation_symbol(equation),
                    p.symbol()
                ),
            ));
            continue;
        }
        columns.push(name.clone());
        for (row, v) in data.iter_mut().zip(column) {
            row.push(v);
        }
    }
    columns.push(response.to_string());
    for (row, &i) in data.iter_mut().zip(&rows_at) {
        row.push(means[i].expect("kept rows have a value"));
    }
    let (pca, problem) = if columns.len() < 2 {
        (None, Some("no contact-parameter column varies".to_string()))
    } else {
        match pca(&data, &columns) {
            Ok(p) => (Some(p), None),
            Err(e) => (None, Some(e.to_string())),
        }
    };
    Analysis {
        response: response.to_string(),
        equation,
        points: rows_at.len(),
        dropped,
        pca,
        problem,
    }
}

fn equation_symbol(e: Equation) -> &'static str {
    match e {
        Equation::Force => "F",
        Equation::Torque => "τ",
    }
}

/// `pca.csv`: per response, equation and component, its eigenvalue, the
/// explained fraction and the loadings (one column per matrix column, named
/// `loading_<column>`; a column not in that analysis is empty).
pub fn csv(l: &Level2, factor_names: &[String]) -> String {
    let mut header = vec![
        "response".to_string(),
        "equation".into(),
        "component".into(),
        "eigenvalue".into(),
        "explained".into(),
    ];
    header.extend(factor_names.iter().map(|f| format!("loading_{f}")));
    header.push("loading_response".into());
    let mut csv = CsvWriter::new(&header);
    for a in &l.analyses {
        let Some(p) = &a.pca else { continue };
        for (k, vector) in p.eigenvectors.iter().enumerate() {
            let mut cells = vec![
                Cell::Text(a.response.clone()),
                Cell::Text(a.equation.name().into()),
                Cell::Integer(k as u64 + 1),
                Cell::Number(p.eigenvalues[k]),
                Cell::Number(p.explained[k]),
            ];
            for f in factor_names {
                cells.push(
                    p.columns
                        .iter()
                        .position(|c| c == f)
                        .map_or(Cell::Empty, |c| Cell::Number(vector[c])),
                );
            }
            cells.push(Cell::Number(*vector.last().expect("the response column")));
            csv.row(&cells);
        }
    }
    csv.finish()
}

/// The level-2 section of the report: the first two components of each
/// analysis (yan2015 Table 5 shows two).
pub fn markdown(l: &Level2, labels: &[(String, String)]) -> String {
    let mut md = format!(
        "## Level 2: PCA of the auto-scaled sensitivity matrices\n\n\
         Rows: design points; columns: P·∂f/∂P of the contact law at δn = δt = {:.3} µm, \
         vn = vt = {} m/s, ω = {} rad/s, then the bulk response (Eq. 25–26). yan2015 \
         Table 5 (θ): the force's first component is dominated by μs; the torque's first \
         two are comparable, the first led by μr, the second by μs; e plays a very minor \
         role.\n\n",
        1e6 * l.state.normal_overlap_m,
        l.state.normal_speed_m_s,
        l.state.angular_speed_rad_s
    );
    if let Some(why) = &l.problem {
        md.push_str(&format!("Not computed: {why}\n"));
    }
    let label = |c: &str| {
        labels
            .iter()
            .find(|(n, _)| n == c)
            .map_or(c.to_string(), |(_, l)| l.clone())
    };
    for a in &l.analyses {
        md.push_str(&format!(
            "### {} — {} equation ({} points)\n\n",
            a.response,
            a.equation.name(),
            a.points
        ));
        for (f, why) in &a.dropped {
            md.push_str(&format!("- {} left out: {why}\n", label(f)));
        }
        match (&a.pca, &a.problem) {
            (Some(p), _) => {
                let mut header = vec![
                    "Component".to_string(),
                    "eigenvalue".into(),
                    "explained".into(),
                ];
                header.extend(p.columns.iter().map(|c| label(c)));
                let mut t = MarkdownTable::new(&header);
                for k in 0..p.eigenvalues.len().min(2) {
                    let mut row = vec![
                        format!("PC{}", k + 1),
                        format!("{:.3}", p.eigenvalues[k]),
                        format!("{:.1} %", 100.0 * p.explained[k]),
                    ];
                    row.extend(p.eigenvectors[k].iter().map(|v| format!("{v:+.3}")));
                    t.row(&row);
                }
                md.push('\n');
                md.push_str(&t.render());
                md.push('\n');
            }
            (None, Some(why)) => md.push_str(&format!("\nNo PCA: {why}\n\n")),
            (None, None) => {}
        }
    }
    md
}
