//! Small-sample summaries and exact distribution functions: the mean with its
//! Student-t 95 % confidence interval, the Welch interval of a difference of
//! means, t quantiles, and the p-values of t and F statistics.
//!
//! Quantiles and tail probabilities come from the regularised incomplete beta
//! function (`statrs`), so they hold for fractional degrees of freedom (the
//! Welch–Satterthwaite df) without interpolation in a table.

use statrs::distribution::{ContinuousCDF, StudentsT};
use statrs::function::beta::beta_reg;

/// The p-quantile of Student's t distribution with `df` degrees of freedom
/// (df > 0, fractional allowed): the t with P(T ≤ t) = p. NaN when `df` is
/// not positive or `p` lies outside [0, 1].
pub fn t_quantile(p: f64, df: f64) -> f64 {
    if !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    match StudentsT::new(0.0, 1.0, df) {
        Ok(t) => t.inverse_cdf(p),
        Err(_) => f64::NAN,
    }
}

/// Two-sided p-value of a t statistic with `df` degrees of freedom:
/// P(|T| ≥ |t|) = I_{df/(df+t²)}(df/2, 1/2). 0 for an infinite t; NaN when
/// `t` is NaN or `df` is not positive.
pub fn t_two_sided_p(t: f64, df: f64) -> f64 {
    if t.is_nan() || df.is_nan() || df <= 0.0 {
        return f64::NAN;
    }
    if t.is_infinite() {
        return 0.0;
    }
    beta_reg(0.5 * df, 0.5, df / (df + t * t))
}

/// Upper-tail probability P(F' ≥ f) of the F distribution with (`df1`,
/// `df2`) degrees of freedom: the p-value of an F statistic,
/// I_{df2/(df2+df1·f)}(df2/2, df1/2). 1 for f ≤ 0, 0 for an infinite f; NaN
/// when `f` is NaN or a df is not positive.
pub fn f_survival(f: f64, df1: f64, df2: f64) -> f64 {
    if f.is_nan() || df1.is_nan() || df2.is_nan() || df1 <= 0.0 || df2 <= 0.0 {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    if f.is_infinite() {
        return 0.0;
    }
    beta_reg(0.5 * df2, 0.5 * df1, df2 / (df2 + df1 * f))
}

/// Mean, sample standard deviation and the 95 % CI half-width of the mean,
/// in the units of the values summarised.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MeanCi {
    /// Sample mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1 denominator).
    pub std: f64,
    /// Number of values.
    pub n: usize,
    /// Half-width of the 95 % confidence interval of the mean,
    /// t₀.₉₇₅(n − 1) · std / √n.
    pub half_width: f64,
}

/// z of a two-sided 95 % normal interval (the 97.5 % normal quantile).
pub const Z95: f64 = 1.959_963_984_540_054;

/// Sample mean and standard deviation (n − 1 denominator) of n ≥ 2 values.
///
/// The plain two-pass sums are used whenever they are finite (so every
/// ordinary result keeps its bits); when finite values overflow them (a sum
/// above about 1.8e308, or squared deviations above it, i.e. deviations past
/// about 1.3e154), the mean is taken as Σ(v/n) and the deviations are scaled
/// by the largest before squaring, which cannot overflow.
pub fn mean_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mut mean = values.iter().sum::<f64>() / n;
    if !mean.is_finite() {
        mean = values.iter().map(|v| v / n).sum::<f64>();
    }
    let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    if sd.is_finite() || !mean.is_finite() {
        return (mean, sd);
    }
    let scale = values.iter().fold(0.0f64, |m, v| m.max((v - mean).abs()));
    let sum = values
        .iter()
        .map(|v| ((v - mean) / scale).powi(2))
        .sum::<f64>();
    (mean, scale * (sum / (n - 1.0)).sqrt())
}

/// [`MeanCi`] of `values`; `None` for fewer than two values (no spread, so no
/// interval).
pub fn mean_ci(values: &[f64]) -> Option<MeanCi> {
    let n = values.len();
    if n < 2 {
        return None;
    }
    let (mean, std) = mean_sd(values);
    Some(MeanCi {
        mean,
        std,
        n,
        half_width: t_quantile(0.975, (n - 1) as f64) * std / (n as f64).sqrt(),
    })
}

/// Difference `a − b` of two means with the half-width of its Welch 95 %
/// confidence interval: t₀.₉₇₅(ν) · √(s²ₐ/nₐ + s²_b/n_b) with the
/// Welch–Satterthwaite ν (fractional). The half-width is 0 when both samples
/// have zero spread.
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
    (diff, t_quantile(0.975, df) * se2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::{assert_rel, assert_rel_within};

    /// Python's exact `statistics.stdev` (fractions): 9.99999999963232e+292
    /// for the first set, and `statistics.stdev([1.5, 2.5, 4.0])` =
    /// 1.2583057392117916 for the ordinary one.
    #[test]
    fn mean_sd_survives_values_whose_squares_overflow() {
        let (mean, sd) = mean_sd(&[1e300, 1.0000001e300, 0.9999999e300]);
        assert_rel_within("huge", &[mean, sd], &[1e300, 9.99999999963232e292], 1e-12);
        // statistics.stdev([1.5e308, 1.7e308, 1.6e308]) = 9.999999999999996e+306
        let (mean, sd) = mean_sd(&[1.5e308, 1.7e308, 1.6e308]);
        assert_rel_within("max", &[mean, sd], &[1.6e308, 9.999999999999996e306], 1e-12);
        let (mean, sd) = mean_sd(&[1.5, 2.5, 4.0]);
        assert_eq!(mean, 8.0 / 3.0);
        assert_rel_within("ordinary", &[sd], &[1.2583057392117916], 1e-15);
    }

    #[test]
    fn t_quantiles_match_scipy() {
        // scipy.stats.t.ppf(0.975, 1), t.ppf(0.975, 4), t.ppf(0.975, 7.3),
        // t.ppf(0.05, 12), t.ppf(0.995, 200)
        let got = [
            t_quantile(0.975, 1.0),
            t_quantile(0.975, 4.0),
            t_quantile(0.975, 7.3),
            t_quantile(0.05, 12.0),
            t_quantile(0.995, 200.0),
        ];
        let scipy = [
            12.706204736174694,
            2.7764451051977934,
            2.345066736547703,
            -1.7822875556493194,
            2.600634436191558,
        ];
        assert_rel("t quantile", &got, &scipy);
        assert!(t_quantile(0.975, 0.0).is_nan() && t_quantile(1.5, 3.0).is_nan());
    }

    #[test]
    fn f_and_t_p_values_match_scipy() {
        // scipy.stats.f.sf(3.2, 4, 12), f.sf(0.5, 2, 30), f.sf(250.0, 1, 14)
        let got = [
            f_survival(3.2, 4.0, 12.0),
            f_survival(0.5, 2.0, 30.0),
            f_survival(250.0, 1.0, 14.0),
        ];
        let scipy = [
            0.052579859157099174,
            0.6114957082084547,
            2.529993494148865e-10,
        ];
        assert_rel("F survival", &got, &scipy);
        // 2 * scipy.stats.t.sf(2.1, 9), 2 * t.sf(0.3, 3.5), 2 * t.sf(12.0, 20)
        let got = [
            t_two_sided_p(2.1, 9.0),
            t_two_sided_p(-0.3, 3.5),
            t_two_sided_p(12.0, 20.0),
        ];
        let scipy = [
            0.06511828241215196,
            0.7811334098398895,
            1.359555702588066e-10,
        ];
        assert_rel("t two-sided p", &got, &scipy);
        assert_eq!(f_survival(0.0, 2.0, 3.0), 1.0);
        assert_eq!(t_two_sided_p(f64::INFINITY, 3.0), 0.0);
    }

    #[test]
    fn mean_ci_matches_scipy() {
        // v = [30.2, 31.5, 29.8, 30.9, 31.1]; s = np.std(v, ddof=1)
        // np.mean(v), s, scipy.stats.t.ppf(0.975, 4) * s / np.sqrt(5)
        let c = mean_ci(&[30.2, 31.5, 29.8, 30.9, 31.1]).unwrap();
        assert_eq!(c.n, 5);
        assert_rel(
            "mean, std, half-width",
            &[c.mean, c.std, c.half_width],
            &[30.7, 0.689202437604511, 0.8557578542477975],
        );
        assert!(mean_ci(&[1.0]).is_none());
    }

    #[test]
    fn welch_interval_matches_scipy() {
        // a = [30.2, 31.5, 29.8, 30.9, 31.1]; b = [28.0, 33.1, 29.5]
        // va = np.var(a, ddof=1)/5; vb = np.var(b, ddof=1)/3
        // df = (va+vb)**2 / (va**2/4 + vb**2/2)            -> 2.16751570057801
        // scipy.stats.t.ppf(0.975, df) * np.sqrt(va + vb)  -> 6.176125189186646
        let a = mean_ci(&[30.2, 31.5, 29.8, 30.9, 31.1]).unwrap();
        let b = mean_ci(&[28.0, 33.1, 29.5]).unwrap();
        let (d, h) = difference_ci(&a, &b);
        assert_rel("difference, half-width", &[d, h], &[0.5, 6.176125189186646]);
        let flat = mean_ci(&[2.0, 2.0]).unwrap();
        assert_eq!(difference_ci(&flat, &flat), (0.0, 0.0));
    }
}
