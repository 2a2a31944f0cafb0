//! One-factor-at-a-time (OFAT) designs: sensitivity sweeps around a base
//! point, varying a single factor per run with every other factor at its base
//! value (actual units).
//!
//! Run order: factor by factor (0, 1, …), and within a factor its levels in
//! the order listed. The base point itself is not a run unless it is listed as
//! a level. A factor with an empty level list is not varied.

use super::{check_levels, DesignError};

/// One run of a one-factor-at-a-time design.
#[derive(Debug, Clone, PartialEq)]
pub struct OfatRun {
    /// The factor this run varies (index into the base point).
    pub factor: usize,
    /// The level's position in that factor's list.
    pub level: usize,
    /// The full point: the base with `factor` set to the level (actual units).
    pub point: Vec<f64>,
}

/// The runs that vary each factor of `base` through its `levels` list in turn,
/// holding the others at `base` (actual units), in the order of the module
/// docs: Σᵢ `levels[i].len()` runs.
///
/// Refused when `base` and `levels` differ in length, a base coordinate is not
/// finite, or a factor's levels are not finite or not distinct.
pub fn one_factor_at_a_time(
    base: &[f64],
    levels: &[Vec<f64>],
) -> Result<Vec<OfatRun>, DesignError> {
    if base.len() != levels.len() {
        return Err(DesignError::BaseLength {
            base: base.len(),
            factors: levels.len(),
        });
    }
    if base.is_empty() {
        return Err(DesignError::NoFactors);
    }
    if let Some((factor, &value)) = base.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(DesignError::NonFiniteBase { factor, value });
    }
    for (factor, list) in levels.iter().enumerate() {
        check_levels(factor, list)?;
    }
    let mut runs = Vec::with_capacity(levels.iter().map(Vec::len).sum());
    for (factor, list) in levels.iter().enumerate() {
        for (level, &value) in list.iter().enumerate() {
            let mut point = base.to_vec();
            point[factor] = value;
            runs.push(OfatRun {
                factor,
                level,
                point,
            });
        }
    }
    Ok(runs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factor_by_factor_level_by_level_others_at_the_base() {
        let base = [0.25, 0.25, 0.45];
        let levels = vec![vec![0.05, 0.5], vec![], vec![0.05, 0.45, 0.85]];
        let runs = one_factor_at_a_time(&base, &levels).unwrap();
        let summary: Vec<(usize, usize, Vec<f64>)> = runs
            .into_iter()
            .map(|r| (r.factor, r.level, r.point))
            .collect();
        assert_eq!(
            summary,
            vec![
                (0, 0, vec![0.05, 0.25, 0.45]),
                (0, 1, vec![0.5, 0.25, 0.45]),
                (2, 0, vec![0.25, 0.25, 0.05]),
                (2, 1, vec![0.25, 0.25, 0.45]),
                (2, 2, vec![0.25, 0.25, 0.85]),
            ]
        );
    }

    #[test]
    fn every_run_differs_from_the_base_in_at_most_its_own_factor() {
        let base = [1.0, 2.0, 3.0, 4.0];
        let levels: Vec<Vec<f64>> = (0..4).map(|f| vec![f as f64 * 10.0, 0.5]).collect();
        let runs = one_factor_at_a_time(&base, &levels).unwrap();
        assert_eq!(runs.len(), 8);
        for r in &runs {
            for (f, (v, b)) in r.point.iter().zip(&base).enumerate() {
                if f == r.factor {
                    assert_eq!(*v, levels[f][r.level]);
                } else {
                    assert_eq!(v, b);
                }
            }
        }
    }

    #[test]
    fn bad_settings_are_refused_naming_the_value() {
        let e = one_factor_at_a_time(&[1.0, 2.0], &[vec![1.0]]).unwrap_err();
        assert_eq!(
            e,
            DesignError::BaseLength {
                base: 2,
                factors: 1
            }
        );
        assert!(e.to_string().contains("2 coordinates but 1 factors"), "{e}");
        assert_eq!(
            one_factor_at_a_time(&[], &[]).unwrap_err(),
            DesignError::NoFactors
        );
        let e = one_factor_at_a_time(&[1.0, f64::INFINITY], &[vec![], vec![]]).unwrap_err();
        assert!(e.to_string().contains("coordinate 1 is inf"), "{e}");
        let e = one_factor_at_a_time(&[1.0], &[vec![2.0, 2.0]]).unwrap_err();
        assert!(matches!(e, DesignError::DuplicateLevel { factor: 0, .. }));
    }
}
