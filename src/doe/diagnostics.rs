//! Design diagnostics: how well a design fills its unit cube and whether its
//! columns are independent.
//!
//! - Centred L2 discrepancy, squared (Hickernell 1998, "A generalized
//!   discrepancy and quadrature error bound", Math. Comp. 67:299–322, the
//!   centred form): CD² = (13/12)^d − (2/n) Σᵢ Πₖ (1 + ½|xᵢₖ − ½| −
//!   ½|xᵢₖ − ½|²) + (1/n²) Σᵢ Σⱼ Πₖ (1 + ½|xᵢₖ − ½| + ½|xⱼₖ − ½| −
//!   ½|xᵢₖ − xⱼₖ|). This is the value `scipy.stats.qmc.discrepancy` returns (its default method
//!   `CD`). Smaller is more uniform.
//! - Smallest pairwise Euclidean distance (maximin criterion), in unit-cube
//!   coordinates. Larger is more space-filling.
//! - Largest absolute Pearson correlation and Spearman rank correlation
//!   (average ranks for ties) between two columns. A Latin hypercube's columns
//!   should be nearly uncorrelated; a rank correlation of ±1 means one column
//!   is a monotone function of another, so the design spans fewer dimensions
//!   than it has columns — it is degenerate (he2019's printed Table A1 is: all
//!   five columns follow one permutation).

use serde::{Deserialize, Serialize};

use super::lhs::distance;

/// Default |correlation| at or above which two columns are reported as
/// strongly correlated. Under independence a sample correlation has standard
/// deviation ≈ 1/√(n − 1) (0.09 for n = 120), so 0.5 is far beyond chance for
/// the design sizes of a calibration while tolerating small designs.
pub const STRONG_CORRELATION: f64 = 0.5;

/// |rank correlation| at or above which a design is called degenerate
/// (equal to 1 up to rounding).
pub const DEGENERATE_RANK_CORRELATION: f64 = 1.0 - 1e-12;

/// The correlation of two columns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnPair {
    /// First column.
    pub a: String,
    /// Second column.
    pub b: String,
    /// Correlation coefficient in [−1, 1].
    pub r: f64,
}

/// Diagnostics of one design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Diagnostics {
    /// Column names, in order.
    pub columns: Vec<String>,
    /// Number of points.
    pub points: usize,
    /// Squared centred L2 discrepancy (Hickernell 1998) in the unit cube.
    pub centred_l2_discrepancy_squared: f64,
    /// Smallest distance between two points in the unit cube.
    pub min_pairwise_distance: f64,
    /// Pearson correlation matrix (row-major, columns × columns); `null` where
    /// a column is constant.
    pub pearson: Vec<Vec<Option<f64>>>,
    /// Spearman rank correlation matrix, as `pearson`.
    pub spearman: Vec<Vec<Option<f64>>>,
    /// The pair with the largest |Pearson| correlation.
    pub max_abs_pearson: Option<ColumnPair>,
    /// The pair with the largest |Spearman| correlation.
    pub max_abs_spearman: Option<ColumnPair>,
    /// Threshold used for the warnings.
    pub strong_correlation: f64,
    /// True when two columns have rank correlation ±1.
    pub degenerate: bool,
    /// Human-readable warnings (empty for a healthy design).
    pub warnings: Vec<String>,
}

impl Diagnostics {
    /// The figures as `repose sample` prints them, one indented line each
    /// (the warnings are not included: they go to stderr).
    pub fn text(&self) -> String {
        let mut out = format!(
            "  points: {}  columns: {}\n  centred L2 discrepancy (squared, Hickernell 1998): \
             {:.6}\n  minimum pairwise distance (unit cube): {:.6}\n",
            self.points,
            self.columns.join(", "),
            self.centred_l2_discrepancy_squared,
            self.min_pairwise_distance
        );
        for (label, pair) in [
            ("Pearson", &self.max_abs_pearson),
            ("Spearman", &self.max_abs_spearman),
        ] {
            out.push_str(&match pair {
                Some(p) => format!(
                    "  max |{label}| correlation: {:.4} ({} vs {})\n",
                    p.r, p.a, p.b
                ),
                None => format!("  max |{label}| correlation: undefined\n"),
            });
        }
        out
    }
}

/// Computes the diagnostics of `points` (rows in `[0, 1]^d`, one column per
/// name), flagging correlations with |r| ≥ `strong_correlation`.
pub fn diagnose(columns: &[String], points: &[Vec<f64>], strong_correlation: f64) -> Diagnostics {
    let d = columns.len();
    let column = |k: usize| -> Vec<f64> { points.iter().map(|p| p[k]).collect() };
    let cols: Vec<Vec<f64>> = (0..d).map(column).collect();
    let ranked: Vec<Vec<f64>> = cols.iter().map(|c| ranks(c)).collect();
    let matrix = |data: &[Vec<f64>]| -> Vec<Vec<Option<f64>>> {
        (0..d)
            .map(|a| (0..d).map(|b| pearson(&data[a], &data[b])).collect())
            .collect()
    };
    let pearson_m = matrix(&cols);
    let spearman_m = matrix(&ranked);
    let max_abs_pearson = strongest(columns, &pearson_m);
    let max_abs_spearman = strongest(columns, &spearman_m);
    let mut warnings = Vec::new();
    for (k, c) in cols.iter().enumerate() {
        if pearson(c, c).is_none() && !c.is_empty() {
            warnings.push(format!("column `{}` is constant", columns[k]));
        }
    }
    let mut degenerate = false;
    for a in 0..d {
        for b in a + 1..d {
            let (p, s) = (pearson_m[a][b], spearman_m[a][b]);
            if s.is_some_and(|s| s.abs() >= DEGENERATE_RANK_CORRELATION) {
                degenerate = true;
            }
            let strong = |r: Option<f64>| r.is_some_and(|r| r.abs() >= strong_correlation);
            if strong(p) || strong(s) {
                warnings.push(format!(
                    "columns `{}` and `{}` are strongly correlated: Pearson {}, Spearman {} (|r| >= {strong_correlation})",
                    columns[a],
                    columns[b],
                    show(p),
                    show(s)
                ));
            }
        }
    }
    if degenerate {
        warnings.push(
            "degenerate design: some columns have rank correlation ±1 (one is a monotone \
             function of another), so the design spans fewer dimensions than it has columns"
                .to_string(),
        );
    }
    Diagnostics {
        columns: columns.to_vec(),
        points: points.len(),
        centred_l2_discrepancy_squared: centred_l2_discrepancy_squared(points),
        min_pairwise_distance: min_pairwise_distance(points),
        pearson: pearson_m,
        spearman: spearman_m,
        max_abs_pearson,
        max_abs_spearman,
        strong_correlation,
        degenerate,
        warnings,
    }
}

fn show(r: Option<f64>) -> String {
    r.map_or_else(|| "undefined".to_string(), |r| format!("{r:.4}"))
}

/// The off-diagonal entry of largest magnitude (first in row-major order on ties).
fn strongest(columns: &[String], m: &[Vec<Option<f64>>]) -> Option<ColumnPair> {
    let mut best: Option<ColumnPair> = None;
    for a in 0..m.len() {
        for b in a + 1..m.len() {
            if let Some(r) = m[a][b] {
                if best.as_ref().is_none_or(|p| r.abs() > p.r.abs()) {
                    best = Some(ColumnPair {
                        a: columns[a].clone(),
                        b: columns[b].clone(),
                        r,
                    });
                }
            }
        }
    }
    best
}

/// Squared centred L2 discrepancy of points in `[0, 1]^d` (Hickernell 1998;
/// formula in the module docs). 0 points give 0.
pub fn centred_l2_discrepancy_squared(points: &[Vec<f64>]) -> f64 {
    let n = points.len();
    if n == 0 {
        return 0.0;
    }
    let d = points[0].len() as i32;
    let n = n as f64;
    let single: f64 = points
        .iter()
        .map(|p| {
            p.iter()
                .map(|x| {
                    let c = (x - 0.5).abs();
                    1.0 + 0.5 * c - 0.5 * c * c
                })
                .product::<f64>()
        })
        .sum();
    let mut pairs = 0.0;
    for p in points {
        for q in points {
            pairs += p
                .iter()
                .zip(q)
                .map(|(x, y)| {
                    1.0 + 0.5 * (x - 0.5).abs() + 0.5 * (y - 0.5).abs() - 0.5 * (x - y).abs()
                })
                .product::<f64>();
        }
    }
    (13.0f64 / 12.0).powi(d) - 2.0 / n * single + pairs / (n * n)
}

/// Smallest Euclidean distance between two of the points (+∞ for fewer than two).
pub fn min_pairwise_distance(points: &[Vec<f64>]) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            best = best.min(distance(&points[i], &points[j]));
        }
    }
    best
}

/// Pearson correlation; `None` when either column is constant or empty.
pub fn pearson(a: &[f64], b: &[f64]) -> Option<f64> {
    let n = a.len() as f64;
    if a.is_empty() {
        return None;
    }
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    (saa > 0.0 && sbb > 0.0).then(|| (sab / (saa * sbb).sqrt()).clamp(-1.0, 1.0))
}

/// Ranks 1..n, ties given their average rank.
pub fn ranks(values: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&i, &j| values[i].total_cmp(&values[j]));
    let mut out = vec![0.0; values.len()];
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && values[order[end]] == values[order[start]] {
            end += 1;
        }
        let average = (start + end + 1) as f64 / 2.0; // mean of ranks start+1..=end
        for &i in &order[start..end] {
            out[i] = average;
        }
        start = end;
    }
    out
}

/// Columns mapped onto [0, 1] by their own min–max (for a table whose ranges
/// are unknown); a constant column maps to ½.
pub fn unit_scaled(columns: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = columns.first().map_or(0, Vec::len);
    let scaled: Vec<Vec<f64>> = columns
        .iter()
        .map(|c| {
            let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            c.iter()
                .map(|v| if hi > lo { (v - lo) / (hi - lo) } else { 0.5 })
                .collect()
        })
        .collect();
    (0..n)
        .map(|i| scaled.iter().map(|c| c[i]).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// scipy's documented example: the 6-point design [[1,3],[2,6],[3,2],
    /// [4,5],[5,1],[6,4]] scaled from [0.5, 6.5]² to the unit square.
    fn scipy_example() -> Vec<Vec<f64>> {
        [[1, 3], [2, 6], [3, 2], [4, 5], [5, 1], [6, 4]]
            .iter()
            .map(|p| p.iter().map(|v| (*v as f64 - 0.5) / 6.0).collect())
            .collect()
    }

    #[test]
    fn cd2_of_the_centre_point_by_hand() {
        // n = 1, d = 1, x = ½: 13/12 − 2·1 + 1 = 1/12.
        let cd = centred_l2_discrepancy_squared(&[vec![0.5]]);
        assert!((cd - 1.0 / 12.0).abs() < 1e-15, "{cd}");
        // n = 2, d = 1, x = ¼, ¾: each single term 1 + 1/8 − 1/32 = 35/32, so
        // the middle term is −(2/2)·2·35/32 = −35/16; pair terms: (i = j)
        // 1 + 1/8 + 1/8 = 5/4 twice, (i ≠ j) 5/4 − 1/4 = 1 twice, sum 9/2, /n² =
        // 9/8; CD² = 13/12 − 35/16 + 9/8 = 1/48.
        let cd = centred_l2_discrepancy_squared(&[vec![0.25], vec![0.75]]);
        assert!((cd - 1.0 / 48.0).abs() < 1e-15, "{cd}");
    }

    #[test]
    fn cd2_matches_scipys_documented_value() {
        // scipy.stats.qmc.update_discrepancy docs: 0.008142039609053513 for
        // the six points (its five-point "iterative" value 0.0477 is normalised
        // by n + 1 for a later update, so it is not the plain CD² of five points).
        let six = centred_l2_discrepancy_squared(&scipy_example());
        assert!((six - 0.008142039609053513).abs() < 1e-14, "{six}");
    }

    #[test]
    fn ranks_average_ties() {
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
    }

    #[test]
    fn a_monotone_but_nonlinear_pair_is_degenerate() {
        // b = a³: Pearson < 1 but Spearman exactly 1.
        let a: Vec<f64> = (0..10).map(|i| i as f64 / 9.0).collect();
        let pts: Vec<Vec<f64>> = a.iter().map(|x| vec![*x, x.powi(3)]).collect();
        let d = diagnose(&["a".into(), "b".into()], &pts, STRONG_CORRELATION);
        assert!(d.degenerate);
        assert_eq!(d.max_abs_spearman.as_ref().unwrap().r, 1.0);
        assert!(d.max_abs_pearson.as_ref().unwrap().r < 1.0);
        assert_eq!(d.warnings.len(), 2, "{:?}", d.warnings);
    }

    #[test]
    fn the_scipy_example_is_healthy() {
        let pts = scipy_example();
        let d = diagnose(&["x".into(), "y".into()], &pts, STRONG_CORRELATION);
        assert!(!d.degenerate && d.warnings.is_empty(), "{:?}", d.warnings);
        // By hand over the 15 pairs (in strata): the closest are (1,3)–(3,2),
        // (2,6)–(4,5), (3,2)–(5,1) and (4,5)–(6,4), each √(2² + 1²) = √5 apart,
        // i.e. √5/6 in the unit square.
        assert!((d.min_pairwise_distance - 5f64.sqrt() / 6.0).abs() < 1e-15);
    }
}
