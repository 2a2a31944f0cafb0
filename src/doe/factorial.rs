//! Full factorial designs over explicit level lists: every combination of one
//! level per factor, in actual units, as yan2015's sliding friction
//! {0.05, 0.15, 0.25, 0.5} × rolling friction {0.05, 0.25, 0.45} × restitution
//! {0.05, 0.45, 0.85} (36 runs).
//!
//! Run order is the standard order: the first factor changes fastest, the last
//! slowest (run r takes level ⌊r / (n₀ n₁ ⋯ nᵢ₋₁)⌋ mod nᵢ of factor i, nⱼ the
//! number of levels of factor j), as pyDOE3's `fullfact`. Levels are used in
//! the order listed, not sorted.

use super::{check_levels, DesignError};

/// Every combination of one level from each of `levels` (one list per factor,
/// actual units), in standard order (first factor fastest):
/// Πᵢ `levels[i].len()` runs of `levels.len()` values.
///
/// Refused when there are no factors, a factor has no levels, or a factor's
/// levels are not finite or not distinct (a repeated level would repeat runs).
pub fn full_factorial(levels: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, DesignError> {
    if levels.is_empty() {
        return Err(DesignError::NoFactors);
    }
    for (factor, list) in levels.iter().enumerate() {
        if list.is_empty() {
            return Err(DesignError::EmptyLevels { factor });
        }
        check_levels(factor, list)?;
    }
    let runs: usize = levels.iter().map(Vec::len).product();
    let mut out = Vec::with_capacity(runs);
    for r in 0..runs {
        let mut stride = 1;
        let run = levels
            .iter()
            .map(|list| {
                let value = list[(r / stride) % list.len()];
                stride *= list.len();
                value
            })
            .collect();
        out.push(run);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yan2015() -> Vec<Vec<f64>> {
        vec![
            vec![0.05, 0.15, 0.25, 0.5],
            vec![0.05, 0.25, 0.45],
            vec![0.05, 0.45, 0.85],
        ]
    }

    #[test]
    fn yan2015_has_36_runs_in_standard_order() {
        let runs = full_factorial(&yan2015()).unwrap();
        assert_eq!(runs.len(), 36);
        assert_eq!(runs[0], vec![0.05, 0.05, 0.05]);
        assert_eq!(runs[1], vec![0.15, 0.05, 0.05]);
        assert_eq!(runs[3], vec![0.5, 0.05, 0.05]);
        assert_eq!(runs[4], vec![0.05, 0.25, 0.05]);
        assert_eq!(runs[11], vec![0.5, 0.45, 0.05]);
        assert_eq!(runs[12], vec![0.05, 0.05, 0.45]);
        assert_eq!(runs[35], vec![0.5, 0.45, 0.85]);
        // Every combination exactly once.
        let mut seen: Vec<Vec<u64>> = runs
            .iter()
            .map(|r| r.iter().map(|v| v.to_bits()).collect())
            .collect();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 36);
    }

    #[test]
    fn matches_pydoe3_fullfact_order() {
        // pyDOE3 1.6.2: fullfact([3, 2]).tolist() — level indices.
        let expected = [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]];
        let runs = full_factorial(&[vec![0.0, 1.0, 2.0], vec![0.0, 1.0]]).unwrap();
        let expected: Vec<Vec<f64>> = expected
            .iter()
            .map(|r| r.iter().map(|v| *v as f64).collect())
            .collect();
        assert_eq!(runs, expected);
    }

    #[test]
    fn levels_keep_their_listed_order_and_single_levels_are_fixed() {
        let runs = full_factorial(&[vec![3.0, 1.0], vec![7.0]]).unwrap();
        assert_eq!(runs, vec![vec![3.0, 7.0], vec![1.0, 7.0]]);
    }

    #[test]
    fn bad_level_lists_are_refused_naming_the_value() {
        assert_eq!(full_factorial(&[]).unwrap_err(), DesignError::NoFactors);
        let e = full_factorial(&[vec![1.0], vec![]]).unwrap_err();
        assert_eq!(e, DesignError::EmptyLevels { factor: 1 });
        assert!(e.to_string().contains("factor 1"), "{e}");
        let e = full_factorial(&[vec![1.0, f64::NAN]]).unwrap_err();
        assert!(e.to_string().contains("level 1 is NaN"), "{e}");
        assert!(e.to_string().contains("finite"), "{e}");
        let e = full_factorial(&[vec![0.05, 0.25, 0.05]]).unwrap_err();
        assert_eq!(
            e,
            DesignError::DuplicateLevel {
                factor: 0,
                value: 0.05,
                first: 0,
                second: 2
            }
        );
        assert!(e.to_string().contains("0.05 twice"), "{e}");
    }
}
