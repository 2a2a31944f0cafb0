//! Do k groups share one variance? Bartlett's test of homogeneity of
//! variances, as `scipy.stats.bartlett` computes it.
//!
//! With nᵢ observations and sample variance sᵢ² (divisor nᵢ − 1) in group i,
//! N = Σ nᵢ and the pooled variance S_p² = Σ(nᵢ − 1)sᵢ² / (N − k),
//!
//! T = [(N − k) ln S_p² − Σ(nᵢ − 1) ln sᵢ²] / C,
//! C = 1 + (Σ 1/(nᵢ − 1) − 1/(N − k)) / (3(k − 1)),
//!
//! and under equal variances (and normal data) T is approximately χ² with
//! k − 1 degrees of freedom; the p-value is its upper tail (the regularised
//! upper incomplete gamma function of `statrs`, not a table).
//!
//! # Why Bartlett and not Levene / Brown–Forsythe
//!
//! The groups this serves are the points of a replicated design: typically
//! two packing seeds per point, one point (the noise floor's centre) with
//! eight. Bartlett's test uses each group's variance directly, so a group of
//! two still contributes its one degree of freedom, and the correction C
//! keeps the χ² approximation usable for such small groups. Levene's test
//! with the median as centre (Brown–Forsythe) is an ANOVA of the absolute
//! deviations |y − median|: in a group of two both deviations equal
//! |y₁ − y₂|/2, so such a group has no within-group spread at all and the
//! test's denominator comes from the few larger groups alone — on a design
//! of two-seed points and one eight-seed centre it measures the centre's
//! spread against the others' means, not the variances' homogeneity. Its
//! robustness to heavy tails does not help with groups of two.
//!
//! Bartlett's price is its sensitivity to non-normality (heavy tails inflate
//! its false rejections). Simulated with groups of one degree of freedom
//! (12 groups of 2 and one of 8, normal data; 20 000 draws of
//! `scipy.stats.bartlett`), it rejects 2.9 % of homogeneous tables at
//! α = 0.05, so it errs on the side of keeping the pooled variance; one
//! group with 5 times the others' standard deviation is found in 31 % of
//! tables (a single 1-df variance says little).
//!
//! A group whose values are all equal (sᵢ² = 0) while others vary makes
//! ln sᵢ² = −∞: T = ∞ and p = 0, as scipy returns (with a warning). When
//! every group is constant there is no variance to compare and the test is
//! refused.

use statrs::function::gamma::gamma_ur;

use super::{check_finite, StatsError};

/// Bartlett's test of k groups' variances.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Bartlett {
    /// T, corrected by C (dimensionless); infinite when a group's values are
    /// all equal and another's are not.
    pub statistic: f64,
    /// Degrees of freedom of the χ² reference, k − 1.
    pub df: usize,
    /// P(χ²(k − 1) ≥ T): the p-value (0 when T is infinite).
    pub p: f64,
    /// Pooled variance S_p² = Σ(nᵢ − 1)sᵢ² / (N − k), in squared units of the
    /// data.
    pub pooled_variance: f64,
    /// Its degrees of freedom, N − k.
    pub pooled_df: usize,
}

/// Bartlett's test that `groups` (each a slice of observations) share one
/// variance (see the module docs).
///
/// Errors: fewer than two groups, a group with fewer than two values, a
/// non-finite value, or every group constant (no variance to compare).
pub fn bartlett(groups: &[Vec<f64>]) -> Result<Bartlett, StatsError> {
    let k = groups.len();
    if k < 2 {
        return Err(StatsError::TooFewGroups { got: k, needed: 2 });
    }
    for (g, values) in groups.iter().enumerate() {
        if values.len() < 2 {
            return Err(StatsError::GroupTooSmall {
                index: g,
                got: values.len(),
                needed: 2,
            });
        }
        check_finite(&format!("group {g}"), values)?;
    }
    let variances: Vec<(f64, f64)> = groups
        .iter()
        .map(|v| {
            let n = v.len() as f64;
            let mean = v.iter().sum::<f64>() / n;
            let ss = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
            (n - 1.0, ss / (n - 1.0))
        })
        .collect();
    let pooled_df: usize = groups.iter().map(|v| v.len() - 1).sum();
    let nk = pooled_df as f64;
    let pooled_variance = variances.iter().map(|(df, s2)| df * s2).sum::<f64>() / nk;
    if pooled_variance == 0.0 {
        return Err(StatsError::NoVariance);
    }
    let c = 1.0
        + (variances.iter().map(|(df, _)| 1.0 / df).sum::<f64>() - 1.0 / nk)
            / (3.0 * (k - 1) as f64);
    let (statistic, p) = if variances.iter().any(|(_, s2)| *s2 == 0.0) {
        (f64::INFINITY, 0.0)
    } else {
        let t = (nk * pooled_variance.ln()
            - variances.iter().map(|(df, s2)| df * s2.ln()).sum::<f64>())
            / c;
        // Rounding can leave T a hair below 0 for equal variances.
        let t = t.max(0.0);
        (t, gamma_ur(0.5 * (k - 1) as f64, 0.5 * t))
    };
    Ok(Bartlett {
        statistic,
        df: k - 1,
        p,
        pooled_variance,
        pooled_df,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::assert_rel_within;

    /// Twelve two-seed points of a design and an eight-seed centre, with the
    /// fifth point's seeds far apart.
    fn design_groups(fifth: [f64; 2]) -> Vec<Vec<f64>> {
        vec![
            vec![33.1, 33.9],
            vec![35.2, 34.6],
            vec![31.0, 31.4],
            vec![36.8, 35.9],
            fifth.to_vec(),
            vec![32.5, 32.2],
            vec![39.3, 39.0, 40.1, 39.6, 38.8, 39.9, 39.2, 40.4],
        ]
    }

    #[test]
    fn bartlett_matches_scipy() {
        // scipy 1.17.1:
        // scipy.stats.bartlett([29.1, 30.4, 31.0, 28.7], [32.2, 33.0, 31.8],
        //                      [30.5, 29.9, 30.8, 31.5, 30.1])
        //   -> statistic 1.1177175658328375, pvalue 0.5718613094969246
        let b = bartlett(&[
            vec![29.1, 30.4, 31.0, 28.7],
            vec![32.2, 33.0, 31.8],
            vec![30.5, 29.9, 30.8, 31.5, 30.1],
        ])
        .unwrap();
        assert_eq!((b.df, b.pooled_df), (2, 9));
        assert_rel_within(
            "T, p",
            &[b.statistic, b.p],
            &[1.1177175658328375, 0.5718613094969246],
            1e-9,
        );
        // The pooled variance is one-way ANOVA's within mean square,
        // 5.838666666666663 / 9 (see oneway.rs).
        assert_rel_within(
            "pooled variance",
            &[b.pooled_variance],
            &[5.838666666666663 / 9.0],
            1e-12,
        );
    }

    #[test]
    fn bartlett_matches_scipy_on_two_seed_points() {
        // g = [[33.1,33.9],[35.2,34.6],[31.0,31.4],[36.8,35.9],[30.2,34.9],
        //      [32.5,32.2],[39.3,39.0,40.1,39.6,38.8,39.9,39.2,40.4]]
        // scipy.stats.bartlett(*g) -> 12.194677549955578, 0.057764063169709355
        let noisy = bartlett(&design_groups([30.2, 34.9])).unwrap();
        assert_eq!((noisy.df, noisy.pooled_df), (6, 13));
        assert_rel_within(
            "noisy fifth point",
            &[noisy.statistic, noisy.p],
            &[12.194677549955578, 0.057764063169709355],
            1e-9,
        );
        // The same with the fifth point [32.6, 33.3]:
        // scipy.stats.bartlett(*g) -> 1.3023796556500624, 0.9715263230844103
        let quiet = bartlett(&design_groups([32.6, 33.3])).unwrap();
        assert_rel_within(
            "quiet fifth point",
            &[quiet.statistic, quiet.p],
            &[1.3023796556500624, 0.9715263230844103],
            1e-9,
        );
    }

    #[test]
    fn a_constant_group_among_varying_ones_is_infinitely_significant() {
        // scipy.stats.bartlett([1., 2.], [3., 3.], [4., 6.])
        //   -> statistic inf, pvalue 0.0 (RuntimeWarning: divide by zero in log)
        let b = bartlett(&[vec![1.0, 2.0], vec![3.0, 3.0], vec![4.0, 6.0]]).unwrap();
        assert_eq!((b.statistic, b.p, b.df), (f64::INFINITY, 0.0, 2));
        assert_rel_within("pooled", &[b.pooled_variance], &[2.5 / 3.0], 1e-12);
    }

    #[test]
    fn bartlett_refuses_what_it_cannot_test() {
        assert_eq!(
            bartlett(&[vec![1.0, 2.0]]),
            Err(StatsError::TooFewGroups { got: 1, needed: 2 })
        );
        let err = bartlett(&[vec![1.0, 2.0], vec![3.0]]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "group 1 has 1 values; at least 2 are needed"
        );
        assert_eq!(
            bartlett(&[vec![1.0, 1.0], vec![3.0, 3.0]]),
            Err(StatsError::NoVariance)
        );
        let err = bartlett(&[vec![1.0, 2.0], vec![3.0, f64::INFINITY]]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "non-finite value inf in group 1 at index 1"
        );
    }
}
