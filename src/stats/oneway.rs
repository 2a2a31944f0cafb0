//! One-way analysis of variance: do k groups share one mean?
//!
//! SS_between = Σ n_g (ȳ_g − ȳ)², SS_within = Σ Σ (y − ȳ_g)², with k − 1 and
//! N − k degrees of freedom; F = MS_between / MS_within and its p-value is the
//! upper tail of F(k − 1, N − k).

use super::summary::f_survival;
use super::{check_finite, StatsError};

/// The one-way ANOVA table (sums of squares in squared units of the data).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OneWay {
    /// Sum of squares between groups, Σ n_g (ȳ_g − ȳ)².
    pub ss_between: f64,
    /// Sum of squares within groups, Σ Σ (y − ȳ_g)².
    pub ss_within: f64,
    /// Degrees of freedom between groups, k − 1.
    pub df_between: usize,
    /// Degrees of freedom within groups, N − k.
    pub df_within: usize,
    /// Mean square between groups, SS_between / (k − 1).
    pub ms_between: f64,
    /// Mean square within groups, SS_within / (N − k).
    pub ms_within: f64,
    /// F = MS_between / MS_within (infinite when every group is constant but
    /// the means differ).
    pub f: f64,
    /// P(F(k − 1, N − k) ≥ F).
    pub p: f64,
}

/// One-way ANOVA of `groups` (each a slice of observations).
///
/// Errors: fewer than two groups, an empty group, a non-finite value, or no
/// more observations than groups (no within-group degree of freedom).
pub fn one_way_anova(groups: &[Vec<f64>]) -> Result<OneWay, StatsError> {
    let k = groups.len();
    if k < 2 {
        return Err(StatsError::TooFewGroups { got: k, needed: 2 });
    }
    for (g, values) in groups.iter().enumerate() {
        if values.is_empty() {
            return Err(StatsError::EmptyGroup { index: g });
        }
        check_finite(&format!("group {g}"), values)?;
    }
    let total: usize = groups.iter().map(Vec::len).sum();
    if total <= k {
        return Err(StatsError::TooFewObservations {
            observations: total,
            parameters: k,
        });
    }
    let grand = groups.iter().flatten().sum::<f64>() / total as f64;
    let mut ss_between = 0.0;
    let mut ss_within = 0.0;
    for values in groups {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        ss_between += values.len() as f64 * (mean - grand).powi(2);
        ss_within += values.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    }
    let (df_between, df_within) = (k - 1, total - k);
    let ms_between = ss_between / df_between as f64;
    let ms_within = ss_within / df_within as f64;
    let f = ms_between / ms_within;
    Ok(OneWay {
        ss_between,
        ss_within,
        df_between,
        df_within,
        ms_between,
        ms_within,
        f,
        p: f_survival(f, df_between as f64, df_within as f64),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::assert_rel;

    #[test]
    fn one_way_anova_matches_scipy() {
        // g = [[29.1, 30.4, 31.0, 28.7], [32.2, 33.0, 31.8], [30.5, 29.9, 30.8, 31.5, 30.1]]
        // r = scipy.stats.f_oneway(*g)        -> 8.717915049097977, 0.007838320339105224
        // gm = np.concatenate(g).mean()
        // sum(len(a) * (np.mean(a) - gm)**2 for a in g)          -> 11.311333333333344
        // sum(np.sum((np.array(a) - np.mean(a))**2) for a in g)  -> 5.838666666666663
        let groups = vec![
            vec![29.1, 30.4, 31.0, 28.7],
            vec![32.2, 33.0, 31.8],
            vec![30.5, 29.9, 30.8, 31.5, 30.1],
        ];
        let a = one_way_anova(&groups).unwrap();
        assert_eq!((a.df_between, a.df_within), (2, 9));
        assert_rel(
            "SS between, SS within, F, p",
            &[a.ss_between, a.ss_within, a.f, a.p],
            &[
                11.311333333333344,
                5.838666666666663,
                8.717915049097977,
                0.007838320339105224,
            ],
        );
        assert_rel(
            "MS",
            &[a.ms_between, a.ms_within],
            &[11.311333333333344 / 2.0, 5.838666666666663 / 9.0],
        );
    }

    #[test]
    fn one_way_anova_refuses_degenerate_groups() {
        assert_eq!(
            one_way_anova(&[vec![1.0, 2.0]]),
            Err(StatsError::TooFewGroups { got: 1, needed: 2 })
        );
        assert_eq!(
            one_way_anova(&[vec![1.0, 2.0], vec![]]),
            Err(StatsError::EmptyGroup { index: 1 })
        );
        assert_eq!(
            one_way_anova(&[vec![1.0], vec![2.0]]),
            Err(StatsError::TooFewObservations {
                observations: 2,
                parameters: 2
            })
        );
        let err = one_way_anova(&[vec![1.0, f64::NAN], vec![2.0]]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "non-finite value NaN in group 0 at index 1"
        );
    }
}
