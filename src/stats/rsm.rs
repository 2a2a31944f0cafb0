//! Quadratic response-surface analysis as Design-Expert prints it.
//!
//! The model is the full quadratic in k coded factors (x = (actual − centre)
//! / half-range, so the design's low and high levels are −1 and +1), with its
//! terms in Design-Expert order ([`quadratic_terms`]): intercept, A, B, …,
//! the two-factor interactions AB, AC, …, then A², B², …. It is fitted by
//! ordinary least squares ([`super::regression`]).
//!
//! The ANOVA table ([`Anova`]):
//! - Model: SS = SST − SSE (SST about the mean), df = p − 1, F = MS/MS_res.
//! - Each term: its partial (Type III) SS, the SSE of the model without that
//!   term minus the SSE of the full model; for a one-column term this is
//!   β²/(XᵀX)⁻¹_jj, which is how it is computed (no refit, no cancellation).
//!   df = 1, F = MS_term/MS_res on (1, n − p) df.
//! - Residual: SSE on n − p df.
//! - Lack of fit and pure error: runs whose coded rows are identical form
//!   replicate groups; pure error SS is the within-group SS, df = Σ(n_g − 1);
//!   lack of fit is the residual less pure error, F = MS_LoF/MS_PE. Both are
//!   `None` when no point is replicated; lack of fit alone is `None` when it
//!   has no df left (as many model terms as distinct points). Replicates that
//!   reuse one packing seed repeat the same simulation exactly, so their
//!   pure error is zero and F undefined (`None`): replicates must use
//!   distinct packing seeds.
//! - Cor Total: SST on n − 1 df.
//!
//! Fit statistics: R² = 1 − SSE/SST; adjusted R² = 1 − MS_res/(SST/(n − 1));
//! predicted R² = 1 − PRESS/SST with PRESS = Σ(e_i/(1 − h_ii))²; std. dev.
//! = √MS_res; C.V. % = 100 · std. dev./mean(y); adequate precision
//! = (max ŷ − min ŷ)/√(mean V(ŷ)) over the design points, with mean V(ŷ) =
//! p·s²/n (the leverages sum to p). Design-Expert calls a ratio above 4
//! adequate signal. They are NaN when y is constant (SST = 0).

use std::collections::BTreeMap;

use super::regression::ols_named;
use super::summary::{f_survival, t_quantile};
use super::{check_finite, StatsError};

/// One model term: a monomial in the coded factors.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Term {
    /// Design-Expert name: `Intercept`, `A`, `AB`, `A²`.
    pub name: String,
    /// The power of each factor in the monomial (all 0 for the intercept).
    pub powers: Vec<u8>,
}

impl Term {
    /// The monomial's value at a point, Π x_k^{powers_k}.
    pub fn value(&self, x: &[f64]) -> f64 {
        self.powers
            .iter()
            .zip(x)
            .map(|(&p, &v)| v.powi(i32::from(p)))
            .product()
    }
}

/// The full quadratic model's terms for factors named `names`, in
/// Design-Expert order: `Intercept`; the linear terms; the two-factor
/// interactions in lexicographic order of their factors (AB, AC, AD, BC, BD,
/// CD), named by juxtaposing the factor names; the squares, named with a `²`
/// suffix. k factors give 1 + 2k + k(k − 1)/2 terms.
pub fn quadratic_terms(names: &[String]) -> Vec<Term> {
    let k = names.len();
    let powers = |pairs: &[(usize, u8)]| {
        let mut p = vec![0u8; k];
        for &(i, e) in pairs {
            p[i] += e;
        }
        p
    };
    let mut terms = vec![Term {
        name: "Intercept".to_string(),
        powers: vec![0; k],
    }];
    for (i, n) in names.iter().enumerate() {
        terms.push(Term {
            name: n.clone(),
            powers: powers(&[(i, 1)]),
        });
    }
    for i in 0..k {
        for j in i + 1..k {
            terms.push(Term {
                name: format!("{}{}", names[i], names[j]),
                powers: powers(&[(i, 1), (j, 1)]),
            });
        }
    }
    for (i, n) in names.iter().enumerate() {
        terms.push(Term {
            name: format!("{n}²"),
            powers: powers(&[(i, 2)]),
        });
    }
    terms
}

/// One coefficient of the coded model, in units of y per coded unit.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Coefficient {
    /// The term's name.
    pub term: String,
    /// The estimate.
    pub estimate: f64,
    /// Its standard error.
    pub se: f64,
    /// t = estimate / se.
    pub t: f64,
    /// Two-sided p-value of t on the residual df.
    pub p: f64,
    /// Lower end of the 95 % confidence interval (estimate − t₀.₉₇₅ · se).
    pub ci95_low: f64,
    /// Upper end of the 95 % confidence interval.
    pub ci95_high: f64,
}

/// One line of an ANOVA table; SS and MS in squared units of y.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AnovaRow {
    /// `Model`, a term name, `Residual`, `Lack of Fit`, `Pure Error` or
    /// `Cor Total`.
    pub source: String,
    /// Sum of squares.
    pub ss: f64,
    /// Degrees of freedom.
    pub df: usize,
    /// Mean square SS/df.
    pub ms: f64,
    /// F statistic, for the rows that are tested (`None` also when the
    /// denominator mean square is zero: the ratio is undefined).
    pub f: Option<f64>,
    /// Its p-value (upper tail of F).
    pub p: Option<f64>,
}

impl AnovaRow {
    fn new(source: &str, ss: f64, df: usize, test: Option<(f64, usize)>) -> Self {
        let ms = ss / df as f64;
        let f = test
            .map(|(ms_den, _)| ms / ms_den)
            .filter(|f| f.is_finite());
        let p = f
            .zip(test)
            .map(|(f, (_, df_den))| f_survival(f, df as f64, df_den as f64));
        AnovaRow {
            source: source.to_string(),
            ss,
            df,
            ms,
            f,
            p,
        }
    }
}

/// The ANOVA of a response-surface fit (see the module docs for each row).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Anova {
    /// The model as a whole against the mean.
    pub model: AnovaRow,
    /// One row per non-intercept term, partial (Type III) SS.
    pub terms: Vec<AnovaRow>,
    /// The residual.
    pub residual: AnovaRow,
    /// Lack of fit (residual less pure error), when testable.
    pub lack_of_fit: Option<AnovaRow>,
    /// Pure error between replicates, when any point is replicated.
    pub pure_error: Option<AnovaRow>,
    /// The corrected total.
    pub total: AnovaRow,
}

/// A fitted quadratic response surface (coded units throughout).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RsmFit {
    /// The model's terms in Design-Expert order.
    pub terms: Vec<Term>,
    /// One coefficient per term, coded units.
    pub coefficients: Vec<Coefficient>,
    /// The ANOVA table.
    pub anova: Anova,
    /// R² = 1 − SSE/SST.
    pub r2: f64,
    /// Adjusted R² = 1 − MS_res/(SST/(n − 1)).
    pub adj_r2: f64,
    /// Predicted R² = 1 − PRESS/SST.
    pub pred_r2: f64,
    /// PRESS = Σ(e_i/(1 − h_ii))², the sum of squared leave-one-out
    /// prediction errors.
    pub press: f64,
    /// Std. dev. √MS_res, units of y.
    pub std_dev: f64,
    /// Mean of y.
    pub mean: f64,
    /// Coefficient of variation 100 · std_dev / mean, %.
    pub cv_percent: f64,
    /// Adequate precision (max ŷ − min ŷ)/√(p·s²/n), a signal-to-noise ratio.
    pub adequate_precision: f64,
    /// Fitted values, one per run.
    pub fitted: Vec<f64>,
    /// Residuals y − ŷ, one per run.
    pub residuals: Vec<f64>,
    /// Leverages h_ii, one per run.
    pub leverage: Vec<f64>,
}

/// Fits the full quadratic model to `y` at the coded points `coded` (one row
/// per run, one column per factor named in `names`) and analyses it.
///
/// Errors: a row whose length differs from `names`, rows other than
/// `y.len()`, a non-finite value, no more runs than model terms, or an
/// aliased term (named; e.g. a factor held at one level, or two factors
/// varied together).
pub fn fit_quadratic(
    coded: &[Vec<f64>],
    y: &[f64],
    names: &[String],
) -> Result<RsmFit, StatsError> {
    let k = names.len();
    if let Some((i, row)) = coded.iter().enumerate().find(|(_, r)| r.len() != k) {
        return Err(StatsError::LengthMismatch {
            what: format!("coded run {i}"),
            expected: k,
            got: row.len(),
        });
    }
    for (i, row) in coded.iter().enumerate() {
        check_finite(&format!("coded run {i}"), row)?;
    }
    let terms = quadratic_terms(names);
    let term_names: Vec<String> = terms.iter().map(|t| t.name.clone()).collect();
    let x: Vec<Vec<f64>> = coded
        .iter()
        .map(|row| terms.iter().map(|t| t.value(row)).collect())
        .collect();
    let fit = ols_named(&x, y, &term_names)?;

    let n = y.len();
    let p = terms.len();
    let df_res = fit.df_residual;
    let ms_res = fit.s2;
    let mean = y.iter().sum::<f64>() / n as f64;
    let sst: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let t_crit = t_quantile(0.975, df_res as f64);

    let coefficients = (0..p)
        .map(|j| {
            let (b, se) = (fit.coefficients[j], fit.std_errors[j]);
            Coefficient {
                term: terms[j].name.clone(),
                estimate: b,
                se,
                t: fit.t[j],
                p: fit.p[j],
                ci95_low: b - t_crit * se,
                ci95_high: b + t_crit * se,
            }
        })
        .collect();

    let against_residual = Some((ms_res, df_res));
    let term_rows = (1..p)
        .map(|j| {
            let ss = fit.coefficients[j].powi(2) / fit.unscaled_variances[j];
            AnovaRow::new(&terms[j].name, ss, 1, against_residual)
        })
        .collect();
    let (pure_error, lack_of_fit) = replication(coded, y, fit.sse, df_res);
    let anova = Anova {
        model: AnovaRow::new("Model", sst - fit.sse, p - 1, against_residual),
        terms: term_rows,
        residual: AnovaRow::new("Residual", fit.sse, df_res, None),
        lack_of_fit,
        pure_error,
        total: AnovaRow::new("Cor Total", sst, n - 1, None),
    };

    let press: f64 = fit
        .residuals
        .iter()
        .zip(&fit.leverage)
        .map(|(e, h)| (e / (1.0 - h)).powi(2))
        .sum();
    let std_dev = ms_res.sqrt();
    let (lo, hi) = fit
        .fitted
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    Ok(RsmFit {
        terms,
        coefficients,
        anova,
        r2: 1.0 - fit.sse / sst,
        adj_r2: 1.0 - ms_res / (sst / (n - 1) as f64),
        pred_r2: 1.0 - press / sst,
        press,
        std_dev,
        mean,
        cv_percent: 100.0 * std_dev / mean,
        adequate_precision: (hi - lo) / (p as f64 * ms_res / n as f64).sqrt(),
        fitted: fit.fitted,
        residuals: fit.residuals,
        leverage: fit.leverage,
    })
}

/// The indices of `rows` grouped by identical rows (equal coordinate by
/// coordinate, 0.0 and −0.0 alike), groups in the order of their first
/// member and members in row order: the replicate groups of pure error. An
/// ordered map of the rows' bit patterns finds each row's group in
/// O(log groups), so a table of 10⁶ distinct rows groups in about a second
/// where a linear search over the groups took hours.
fn identical_rows(rows: &[Vec<f64>]) -> Vec<Vec<usize>> {
    let key = |row: &[f64]| -> Vec<u64> {
        row.iter()
            .map(|&v| if v == 0.0 { 0 } else { v.to_bits() })
            .collect()
    };
    let mut index: BTreeMap<Vec<u64>, usize> = BTreeMap::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let next = groups.len();
        let g = *index.entry(key(row)).or_insert(next);
        if g == next {
            groups.push(Vec::new());
        }
        groups[g].push(i);
    }
    groups
}

/// Pure error and lack of fit rows from the groups of identical coded runs.
fn replication(
    coded: &[Vec<f64>],
    y: &[f64],
    sse: f64,
    df_res: usize,
) -> (Option<AnovaRow>, Option<AnovaRow>) {
    let groups: Vec<(&[f64], Vec<f64>)> = identical_rows(coded)
        .into_iter()
        .map(|members| {
            let ys = members.iter().map(|&i| y[i]).collect();
            (coded[members[0]].as_slice(), ys)
        })
        .collect();
    let df_pe: usize = groups.iter().map(|(_, ys)| ys.len() - 1).sum();
    if df_pe == 0 {
        return (None, None);
    }
    let ss_pe: f64 = groups
        .iter()
        .map(|(_, ys)| {
            let m = ys.iter().sum::<f64>() / ys.len() as f64;
            ys.iter().map(|v| (v - m).powi(2)).sum::<f64>()
        })
        .sum();
    let pure_error = AnovaRow::new("Pure Error", ss_pe, df_pe, None);
    let df_lof = df_res - df_pe;
    let lack_of_fit = (df_lof > 0).then(|| {
        AnovaRow::new(
            "Lack of Fit",
            sse - ss_pe,
            df_lof,
            Some((pure_error.ms, df_pe)),
        )
    });
    (Some(pure_error), lack_of_fit)
}

impl RsmFit {
    /// The predicted response at a point in coded units (one value per
    /// factor).
    pub fn predict(&self, coded: &[f64]) -> f64 {
        assert_eq!(
            coded.len(),
            self.terms[0].powers.len(),
            "one coded value per factor"
        );
        self.terms
            .iter()
            .zip(&self.coefficients)
            .map(|(t, c)| c.estimate * t.value(coded))
            .sum()
    }

    /// The same polynomial expanded in actual units: substituting
    /// x_coded = (x − centre)/half_range with centre = (low + high)/2 and
    /// half_range = (high − low)/2 for each factor's `(low, high)` in
    /// `ranges` (the actual values coded −1 and +1; low ≠ high). One (term
    /// name, coefficient) per term, in term order; a coefficient is in units
    /// of y per product of its factors' units.
    pub fn actual_coefficients(&self, ranges: &[(f64, f64)]) -> Vec<(String, f64)> {
        let k = self.terms[0].powers.len();
        assert_eq!(ranges.len(), k, "one (low, high) per factor");
        assert!(
            ranges.iter().all(|(low, high)| low != high),
            "a factor's low and high levels differ"
        );
        // x_coded = a·x + b per factor.
        let affine: Vec<(f64, f64)> = ranges
            .iter()
            .map(|&(low, high)| {
                let half = 0.5 * (high - low);
                (1.0 / half, -0.5 * (high + low) / half)
            })
            .collect();
        let mut actual = vec![0.0; self.terms.len()];
        for (term, c) in self.terms.iter().zip(&self.coefficients) {
            // Π_k (a_k x_k + b_k)^{p_k} = Σ over q ≤ p of Π_k C(p_k, q_k) a_k^q_k b_k^(p_k − q_k) x_k^q_k.
            let mut q = vec![0u8; k];
            loop {
                let weight: f64 = (0..k)
                    .map(|i| {
                        let (a, b) = affine[i];
                        let (p, qi) = (i32::from(term.powers[i]), i32::from(q[i]));
                        binomial(p, qi) * a.powi(qi) * b.powi(p - qi)
                    })
                    .product();
                let target = self
                    .terms
                    .iter()
                    .position(|t| t.powers == q)
                    .expect("the quadratic model holds every monomial of its terms");
                actual[target] += c.estimate * weight;
                // Next q in the box 0 ≤ q ≤ powers (odometer order).
                match (0..k).find(|&i| q[i] < term.powers[i]) {
                    Some(i) => {
                        q[i] += 1;
                        q[..i].fill(0);
                    }
                    None => break,
                }
            }
        }
        self.terms
            .iter()
            .map(|t| t.name.clone())
            .zip(actual)
            .collect()
    }
}

/// C(n, k) for the small powers of a polynomial term.
fn binomial(n: i32, k: i32) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * f64::from(n - i) / f64::from(i + 1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::assert_rel;

    // The references come from this Python (statsmodels 0.15.0, scipy 1.17.1):
    //
    //   import numpy as np, pandas as pd, scipy.stats as st
    //   import statsmodels.api as sm, statsmodels.formula.api as smf
    //   X = box_behnken_4()        # the 29 runs of `box_behnken_4` below
    //   df = pd.DataFrame(X, columns=list("ABCD")); df["y"] = y
    //   FORM = ("y ~ A + B + C + D + A:B + A:C + A:D + B:C + B:D + C:D"
    //           " + I(A**2) + I(B**2) + I(C**2) + I(D**2)")
    //   fit = smf.ols(FORM, df).fit()
    //   fit.params, fit.bse, fit.tvalues, fit.pvalues, fit.conf_int(0.05)
    //   a = sm.stats.anova_lm(fit, typ=3); a.sum_sq, a.F, a["PR(>F)"]
    //   fit.fvalue, fit.f_pvalue, fit.ess, fit.ssr, fit.rsquared, fit.rsquared_adj
    //   h = fit.get_influence().hat_matrix_diag
    //   press = np.sum((fit.resid / (1 - h))**2); pred_r2 = 1 - press / sst
    //   s = np.sqrt(fit.mse_resid); cv = 100 * s / y.mean()
    //   yh = fit.fittedvalues.values
    //   adeq = (yh.max() - yh.min()) / np.sqrt(15 * fit.mse_resid / len(y))
    //   # pure error: groups of identical rows of X
    //   sspe = sum(np.sum((v - v.mean())**2) for v in groups); dfpe = sum(len(v) - 1 ...)
    //   sslof = fit.ssr - sspe; dflof = fit.df_resid - dfpe
    //   Flof = (sslof / dflof) / (sspe / dfpe); st.f.sf(Flof, dflof, dfpe)

    /// 4-factor Box–Behnken: 24 edge runs, pairs (A,B), (A,C), (A,D), (B,C),
    /// (B,D), (C,D), each at (−,−), (+,−), (−,+), (+,+); then 5 centre runs.
    fn box_behnken_4() -> Vec<Vec<f64>> {
        let pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
        let mut runs = Vec::new();
        for (i, j) in pairs {
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                let mut r = vec![0.0; 4];
                r[i] = a;
                r[j] = b;
                runs.push(r);
            }
        }
        runs.extend(std::iter::repeat_n(vec![0.0; 4], 5));
        runs
    }

    fn names() -> Vec<String> {
        ["A", "B", "C", "D"].map(String::from).to_vec()
    }

    /// 30 + 2A − 1.5B + 0.8C + 0.3D + 0.6AB − 0.4AC + 0.2BD + 1.1A² − 0.7C²
    /// + 0.5D² plus N(0, 0.6²) noise (numpy default_rng(7)), rounded to 0.01.
    const Y1: [f64; 29] = [
        31.2, 34.18, 26.84, 31.67, 26.93, 31.41, 29.64, 33.6, 29.0, 32.93, 30.19, 34.11, 30.06,
        26.44, 31.58, 29.02, 31.09, 28.23, 30.96, 28.73, 27.59, 30.16, 28.54, 31.06, 30.09, 29.89,
        28.49, 29.68, 29.97,
    ];
    /// The same surface with fresh noise (the next 29 draws).
    const Y2: [f64; 29] = [
        31.27, 33.08, 26.71, 31.61, 26.71, 32.64, 29.12, 32.78, 29.83, 32.95, 29.83, 33.97, 30.04,
        26.26, 31.65, 29.42, 30.97, 29.02, 32.17, 29.12, 29.9, 30.76, 28.58, 30.94, 30.35, 29.89,
        30.41, 29.96, 30.4,
    ];

    fn estimates(fit: &RsmFit) -> Vec<f64> {
        fit.coefficients.iter().map(|c| c.estimate).collect()
    }

    #[test]
    fn quadratic_terms_are_in_design_expert_order() {
        let labels: Vec<String> = quadratic_terms(&names())
            .into_iter()
            .map(|t| t.name)
            .collect();
        assert_eq!(
            labels,
            [
                "Intercept",
                "A",
                "B",
                "C",
                "D",
                "AB",
                "AC",
                "AD",
                "BC",
                "BD",
                "CD",
                "A²",
                "B²",
                "C²",
                "D²"
            ]
        );
        let t = &quadratic_terms(&names())[6];
        assert_eq!(t.powers, [1, 0, 1, 0]);
        assert_eq!(t.value(&[2.0, 5.0, -3.0, 7.0]), -6.0);
    }

    #[test]
    fn box_behnken_matches_statsmodels() {
        let fit = fit_quadratic(&box_behnken_4(), &Y1, &names()).unwrap();
        assert_rel(
            "coefficients",
            &estimates(&fit),
            &[
                29.623999999999988,
                2.008333333333335,
                -1.511666666666662,
                1.1741666666666641,
                0.3824999999999994,
                0.462499999999997,
                -0.13000000000000364,
                -0.0024999999999991496,
                0.26500000000000473,
                0.15749999999999814,
                -0.012499999999997596,
                1.4354999999999958,
                -0.027000000000007324,
                -0.5232500000000024,
                0.29674999999999513,
            ],
        );
        let c = &fit.coefficients;
        assert_rel(
            "standard errors",
            &c.iter().map(|c| c.se).collect::<Vec<_>>(),
            &[
                0.21877891645612085,
                0.14122118332264333,
                0.14122118332264336,
                0.14122118332264338,
                0.14122118332264336,
                0.24460226461981677,
                0.24460226461981693,
                0.24460226461981696,
                0.24460226461981693,
                0.24460226461981704,
                0.24460226461981688,
                0.19208157601716547,
                0.19208157601716547,
                0.19208157601716552,
                0.19208157601716547,
            ],
        );
        assert_rel(
            "t",
            &c.iter().map(|c| c.t).collect::<Vec<_>>(),
            &[
                135.4061007333926,
                14.221190377260633,
                -10.704248690601943,
                8.314380598157744,
                2.708517171436769,
                1.8908246852041901,
                -0.5314750466520065,
                -0.010220673974073283,
                1.0833914412521561,
                0.6439024603668281,
                -0.05110336987037399,
                7.473387243926568,
                -0.1405652773152718,
                -2.72410301315542,
                1.5449165201220336,
            ],
        );
        assert_rel(
            "p",
            &c.iter().map(|c| c.p).collect::<Vec<_>>(),
            &[
                3.154372186779907e-23,
                1.0282822363682746e-09,
                3.9953639310575055e-08,
                8.718693278802535e-07,
                0.01697114471884504,
                0.07952486545206464,
                0.6034208114288913,
                0.9919894415882131,
                0.29694119392013707,
                0.5300467466622655,
                0.9599651308448234,
                2.9976249357870078e-06,
                0.8902157882342129,
                0.016460531597037396,
                0.14466626471369534,
            ],
        );
        assert_rel(
            "95 % CI low",
            &c.iter().map(|c| c.ci95_low).collect::<Vec<_>>(),
            &[
                29.154765892387818,
                1.70544401929093,
                -1.8145559807090672,
                0.8712773526242588,
                0.07961068595759413,
                -0.06211968099113396,
                -0.6546196809911351,
                -0.5271196809911306,
                -0.2596196809911267,
                -0.3671196809911335,
                -0.537119680991129,
                1.0235259927641076,
                -0.4389740072358955,
                -0.9352240072358908,
                -0.11522400723589304,
            ],
        );
        assert_rel(
            "95 % CI high",
            &c.iter().map(|c| c.ci95_high).collect::<Vec<_>>(),
            &[
                30.093234107612158,
                2.3112226473757405,
                -1.208777352624257,
                1.4770559807090695,
                0.6853893140424047,
                0.987119680991128,
                0.39461968099112776,
                0.5221196809911323,
                0.7896196809911362,
                0.6821196809911299,
                0.5121196809911337,
                1.847474007235884,
                0.3849740072358808,
                -0.1112759927641141,
                0.7087240072358834,
            ],
        );

        // anova_lm(typ=3) rows A … I(D ** 2) (its Intercept row is not a
        // Design-Expert row).
        let a = &fit.anova;
        let sources: Vec<&str> = a.terms.iter().map(|r| r.source.as_str()).collect();
        assert_eq!(sources[0], "A");
        assert_eq!(sources[13], "D²");
        assert!(a.terms.iter().all(|r| r.df == 1));
        assert_rel(
            "Type III SS",
            &a.terms.iter().map(|r| r.ss).collect::<Vec<_>>(),
            &[
                48.400833333333416,
                27.42163333333315,
                16.544008333333245,
                1.755674999999994,
                0.8556249999999895,
                0.06760000000000373,
                2.4999999999982962e-05,
                0.28090000000000975,
                0.09922499999999748,
                0.0006249999999997594,
                13.366444864864787,
                0.004728648648651214,
                1.7759387837837994,
                0.5712036486486302,
            ],
        );
        assert_rel(
            "Type III F",
            &a.terms.iter().map(|r| r.f.unwrap()).collect::<Vec<_>>(),
            &[
                202.24225574629043,
                114.5809400302534,
                69.12892473102191,
                7.336065267967838,
                3.5752179901775247,
                0.28246572521375246,
                0.00010446217648429895,
                1.1737370149784239,
                0.41461037846645465,
                0.0026115544121082484,
                55.85151689768434,
                0.01975859718671926,
                7.420737226282438,
                2.3867670541459742,
            ],
        );
        assert_rel(
            "Type III p",
            &a.terms.iter().map(|r| r.p.unwrap()).collect::<Vec<_>>(),
            &[
                1.0282822363682746e-09,
                3.9953639310575055e-08,
                8.718693278802546e-07,
                0.01697114471884504,
                0.07952486545206464,
                0.6034208114288913,
                0.9919894415882131,
                0.2969411939201373,
                0.5300467466622655,
                0.9599651308448234,
                2.9976249357870078e-06,
                0.8902157882342129,
                0.016460531597037396,
                0.1446662647136954,
            ],
        );
        assert_eq!((a.model.df, a.residual.df, a.total.df), (14, 14, 28));
        assert_rel(
            "model SS, F, p; residual SS; total SS",
            &[
                a.model.ss,
                a.model.f.unwrap(),
                a.model.p.unwrap(),
                a.residual.ss,
                a.total.ss,
            ],
            &[
                113.46312568965519,
                33.86458588646009,
                2.3532214973671497e-08,
                3.350495000000002,
                113.46312568965519 + 3.350495000000002,
            ],
        );
        assert_rel(
            "R², adj R², pred R², PRESS",
            &[fit.r2, fit.adj_r2, fit.pred_r2, fit.press],
            &[
                0.9713175999492265,
                0.942635199898453,
                0.8957581408049071,
                12.176869000000021,
            ],
        );
        assert_rel(
            "std dev, mean, CV %, adequate precision",
            &[
                fit.std_dev,
                fit.mean,
                fit.cv_percent,
                fit.adequate_precision,
            ],
            &[
                0.48920452923963365,
                30.11310344827586,
                1.6245569975207697,
                22.64447519327899,
            ],
        );
        let pe = a.pure_error.as_ref().unwrap();
        let lof = a.lack_of_fit.as_ref().unwrap();
        assert_eq!((pe.df, lof.df), (4, 10));
        assert_eq!((pe.f, pe.p), (None, None));
        assert_rel(
            "pure error SS, lack of fit SS, F, p",
            &[pe.ss, lof.ss, lof.f.unwrap(), lof.p.unwrap()],
            &[
                1.6967200000000027,
                1.6537749999999996,
                0.389875760290442,
                0.89651835627289,
            ],
        );
        // h[[0, 24, 28]], fittedvalues[0], resid[0]
        assert_rel(
            "leverage, fitted, residual",
            &[
                fit.leverage[0],
                fit.leverage[24],
                fit.leverage[28],
                fit.fitted[0],
                fit.residuals[0],
            ],
            &[
                0.5833333333333343,
                0.19999999999999998,
                0.19999999999999998,
                30.9983333333333,
                0.20166666666669997,
            ],
        );
        // fit.predict(pd.DataFrame([[0.5, -0.25, 0.75, -1.0]], columns=list("ABCD")))
        assert_rel(
            "prediction",
            &[fit.predict(&[0.5, -0.25, 0.75, -1.0])],
            &[31.757567708333305],
        );
    }

    #[test]
    fn replicated_box_behnken_has_pure_error_from_every_point() {
        // The 29 runs twice: X2 = np.vstack([X, X]), y = np.concatenate([Y1, Y2]).
        let mut coded = box_behnken_4();
        coded.extend(box_behnken_4());
        let y: Vec<f64> = Y1.iter().chain(&Y2).copied().collect();
        let fit = fit_quadratic(&coded, &y, &names()).unwrap();
        assert_rel(
            "coefficients",
            &estimates(&fit),
            &[
                29.912999999999997,
                1.9858333333333342,
                -1.4658333333333307,
                1.0262500000000012,
                0.2404166666666646,
                0.6174999999999996,
                -0.3487500000000021,
                0.12624999999999914,
                0.32624999999999993,
                -0.05874999999999733,
                0.1812499999999949,
                1.1291250000000006,
                -0.17587500000000134,
                -0.581499999999997,
                0.4059999999999975,
            ],
        );
        assert_rel(
            "standard errors",
            &fit.coefficients.iter().map(|c| c.se).collect::<Vec<_>>(),
            &[
                0.16538396128755278,
                0.10675488796608401,
                0.10675488796608404,
                0.10675488796608405,
                0.10675488796608401,
                0.18490488991358084,
                0.18490488991358087,
                0.1849048899135808,
                0.1849048899135808,
                0.18490488991358084,
                0.18490488991358084,
                0.14520234603340482,
                0.1452023460334049,
                0.14520234603340484,
                0.14520234603340482,
            ],
        );
        let a = &fit.anova;
        assert_rel(
            "Type III SS",
            &a.terms.iter().map(|r| r.ss).collect::<Vec<_>>(),
            &[
                94.64481666666678,
                51.56801666666648,
                25.276537500000053,
                1.3872041666666433,
                3.050449999999997,
                0.9730125000000117,
                0.12751249999999834,
                0.8515125,
                0.0276124999999975,
                0.2628124999999852,
                16.53954506756759,
                0.40128020270270837,
                4.386710270270224,
                2.138412972972947,
            ],
        );
        assert_rel(
            "Type III p",
            &a.terms.iter().map(|r| r.p.unwrap()).collect::<Vec<_>>(),
            &[
                3.482815272585292e-22,
                2.5433299714561478e-17,
                2.819467668169958e-12,
                0.02948070341243562,
                0.0017416476144115156,
                0.06604664176599871,
                0.49840591852013416,
                0.08476401038849798,
                0.7522269173437334,
                0.33245394880677714,
                9.858208654821533e-10,
                0.2324179949281757,
                0.00024152301051621946,
                0.007702216736733595,
            ],
        );
        assert_eq!(a.residual.df, 43);
        assert_rel(
            "model F, p",
            &[a.model.f.unwrap(), a.model.p.unwrap()],
            &[53.781349278136766, 1.3702015415248857e-22],
        );
        assert_rel(
            "R², adj R², pred R², CV %, adequate precision",
            &[
                fit.r2,
                fit.adj_r2,
                fit.pred_r2,
                fit.cv_percent,
                fit.adequate_precision,
            ],
            &[
                0.9459757519754673,
                0.9283864619209683,
                0.9020538285866052,
                1.7297601735568287,
                28.0613018971516,
            ],
        );
        let pe = a.pure_error.as_ref().unwrap();
        let lof = a.lack_of_fit.as_ref().unwrap();
        assert_eq!((pe.df, lof.df), (33, 10));
        assert_rel(
            "pure error SS, lack of fit SS, F, p",
            &[pe.ss, lof.ss, lof.f.unwrap(), lof.p.unwrap()],
            &[
                9.163460000000006,
                2.5978374999999847,
                0.9355487719704069,
                0.5144515554264147,
            ],
        );
    }

    #[test]
    fn identical_replicates_give_zero_pure_error_and_no_lack_of_fit_test() {
        // The 24 edge runs and one centre run, each twice with the same
        // response, as replicates sharing one packing seed give.
        let once = &box_behnken_4()[..25];
        let coded: Vec<Vec<f64>> = once.iter().chain(once).cloned().collect();
        let y: Vec<f64> = Y1[..25].iter().chain(&Y1[..25]).copied().collect();
        let fit = fit_quadratic(&coded, &y, &names()).unwrap();
        let pe = fit.anova.pure_error.unwrap();
        let lof = fit.anova.lack_of_fit.unwrap();
        assert_eq!((pe.ss, pe.df, lof.df), (0.0, 25, 10));
        assert_eq!((lof.f, lof.p), (None, None));
        // Without any replication there is neither row.
        let fit = fit_quadratic(once, &Y1[..25], &names()).unwrap();
        assert_eq!((fit.anova.pure_error, fit.anova.lack_of_fit), (None, None));
    }

    #[test]
    fn actual_coefficients_match_a_fit_in_actual_units() {
        // ranges = [(0.2, 0.6), (0.1, 0.5), (10.0, 50.0), (1.0, 3.0)]
        // act = centre + half_range * X per column; the same FORM fitted to
        // (act, Y1): smf.ols(FORM, dfa).fit().params
        let ranges = [(0.2, 0.6), (0.1, 0.5), (10.0, 50.0), (1.0, 3.0)];
        let fit = fit_quadratic(&box_behnken_4(), &Y1, &names()).unwrap();
        let actual = fit.actual_coefficients(&ranges);
        let labels: Vec<&str> = actual.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(labels[..3], ["Intercept", "A", "B"]);
        assert_rel(
            "actual coefficients",
            &actual.iter().map(|(_, c)| *c).collect::<Vec<_>>(),
            &[
                33.058270833327256,
                -21.13708333333178,
                -15.340833333329348,
                0.1315708333336778,
                -1.0169999999999633,
                11.562499999999611,
                -0.032499999999997135,
                -0.012500000000045046,
                0.06624999999999642,
                0.7874999999999766,
                -0.0006250000000058843,
                35.887499999998425,
                -0.6750000000062719,
                -0.001308125000005352,
                0.29674999999998664,
            ],
        );
    }

    #[test]
    fn identical_rows_group_in_order_of_first_appearance() {
        let rows = vec![
            vec![1.0, 0.0],
            vec![-1.0, 0.5],
            vec![1.0, -0.0],
            vec![-1.0, 0.5],
            vec![0.0, 0.0],
        ];
        assert_eq!(identical_rows(&rows), vec![vec![0, 2], vec![1, 3], vec![4]]);
    }

    #[test]
    fn an_aliased_term_is_named() {
        // D always equals C: the D column repeats the C column.
        let coded: Vec<Vec<f64>> = box_behnken_4()
            .into_iter()
            .map(|r| vec![r[0], r[1], r[2], r[2]])
            .collect();
        let err = fit_quadratic(&coded, &Y1, &names()).unwrap_err();
        assert_eq!(
            err,
            StatsError::Aliased {
                term: "D".to_string()
            }
        );
        assert!(err.to_string().contains("term `D` is aliased"), "{err}");
        let err = fit_quadratic(&box_behnken_4()[..10], &Y1[..10], &names()).unwrap_err();
        assert_eq!(
            err,
            StatsError::TooFewObservations {
                observations: 10,
                parameters: 15
            }
        );
    }
}
