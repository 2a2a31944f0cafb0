//! Small-sample statistics for the tradeoff table: Student-t confidence
//! intervals of a mean and of a difference of means (Welch), and the Pareto
//! front of (error, cost).

/// Two-sided 95 % Student-t quantile t₀.₉₇₅ for `df` degrees of freedom
/// (df ≥ 1). Values for df ≤ 30 from the standard table (e.g. NIST/SEMATECH
/// e-Handbook §1.3.6.7.2); above, the Cornish–Fisher expansion
/// z + (z³ + z)/(4 df) + (5z⁵ + 16z³ + 3z)/(96 df²), within 1e-3 there.
pub fn t_975(df: f64) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    if df < 1.0 {
        return f64::INFINITY;
    }
    if df <= 30.0 {
        // Welch df is fractional: interpolate between table entries.
        let lo = df.floor() as usize;
        let frac = df - lo as f64;
        let a = TABLE[lo - 1];
        let b = TABLE[lo.min(29)];
        return a + frac * (b - a);
    }
    let z: f64 = 1.959_963_985;
    z + (z.powi(3) + z) / (4.0 * df)
        + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * df * df)
}

/// Mean, sample standard deviation and the 95 % CI half-width of the mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeanCi {
    /// Sample mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1).
    pub std: f64,
    /// Number of values.
    pub n: usize,
    /// Half-width of the 95 % confidence interval of the mean.
    pub half_width: f64,
}

/// [`MeanCi`] of `values`; `None` for fewer than two values.
pub fn mean_ci(values: &[f64]) -> Option<MeanCi> {
    let n = values.len();
    if n < 2 {
        return None;
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let std = var.sqrt();
    Some(MeanCi {
        mean,
        std,
        n,
        half_width: t_975((n - 1) as f64) * std / (n as f64).sqrt(),
    })
}

/// Difference `a − b` of two means with its Welch 95 % CI half-width.
pub fn difference_ci(a: &MeanCi, b: &MeanCi) -> (f64, f64) {
    let va = a.std * a.std / a.n as f64;
    let vb = b.std * b.std / b.n as f64;
    let se2 = va + vb;
    let diff = a.mean - b.mean;
    if se2 == 0.0 {
        return (diff, 0.0);
    }
    let df = se2 * se2
        / (va * va / (a.n - 1) as f64 + vb * vb / (b.n - 1) as f64).max(f64::MIN_POSITIVE);
    (diff, t_975(df) * se2.sqrt())
}

/// Indices of the Pareto-optimal points minimising both coordinates: no other
/// point is at least as good in both and better in one. Sorted by cost.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&i, &j| {
        points[i]
            .1
            .total_cmp(&points[j].1)
            .then(points[i].0.total_cmp(&points[j].0))
    });
    let mut front = Vec::new();
    let mut best_error = f64::INFINITY;
    for i in order {
        if points[i].0 < best_error {
            best_error = points[i].0;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles_match_the_table_and_the_normal_limit() {
        assert_eq!(t_975(1.0), 12.706);
        assert_eq!(t_975(2.0), 4.303);
        assert!((t_975(2.5) - 0.5 * (4.303 + 3.182)).abs() < 1e-12);
        // NIST table: df 40 → 2.021, df 100 → 1.984.
        assert!((t_975(40.0) - 2.021).abs() < 1e-3);
        assert!((t_975(100.0) - 1.984).abs() < 1e-3);
    }

    #[test]
    fn ci_of_three_values() {
        // 1, 2, 3: mean 2, s = 1, half-width 4.303 / √3.
        let c = mean_ci(&[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(c.mean, 2.0);
        assert!((c.std - 1.0).abs() < 1e-15);
        assert!((c.half_width - 4.303 / 3f64.sqrt()).abs() < 1e-12);
        assert!(mean_ci(&[1.0]).is_none());
    }

    #[test]
    fn welch_equal_variances_reduces_to_pooled_df() {
        // Equal n and s: Welch df = 2(n − 1) = 4 for n = 3.
        let a = mean_ci(&[1.0, 2.0, 3.0]).unwrap();
        let b = mean_ci(&[2.0, 3.0, 4.0]).unwrap();
        let (d, h) = difference_ci(&a, &b);
        assert_eq!(d, -1.0);
        assert!((h - 2.776 * (2.0f64 / 3.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn pareto_front_drops_dominated_points() {
        // (error, cost): b is dominated by a (worse error, more cost).
        let pts = [(1.0, 10.0), (2.0, 20.0), (0.5, 30.0), (3.0, 1.0)];
        assert_eq!(pareto_front(&pts), vec![3, 0, 2]);
    }
}
