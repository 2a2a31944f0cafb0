//! Box–Behnken designs (Box & Behnken 1960, "Some new three level designs for
//! the study of quantitative variables", Technometrics 2:455–475): three levels
//! per factor, coded −1/0/+1, fitting a full quadratic response surface without
//! the corners of the cube (no run sets every factor to an extreme).
//!
//! Run order (pyDOE3 1.6.2's `bbdesign`, row for row): for every pair of
//! factors (i, j), i < j, in lexicographic order, the four runs
//! (−1, −1), (−1, +1), (+1, −1), (+1, +1) as (factor i, factor j) with every
//! other factor at 0; then the centre points. The original pyDOE 0.3.8 ordered
//! each pair's four runs (−,−), (+,−), (−,+), (+,+) instead; the set of runs is
//! the same.

use super::DesignError;

/// The four corners of one pair's square, as (factor i, factor j).
const PAIR_CORNERS: [(f64, f64); 4] = [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)];

/// The Box–Behnken design of `factors` factors (k ≥ 3) followed by
/// `centre_points` centre runs, in coded units (−1, 0, +1), one row per run in
/// the order of the module docs: 2k(k − 1) + `centre_points` rows of k values
/// (4 factors with 5 centre points: 29 runs).
///
/// Refused for k < 3: with two factors the design would be a 2² factorial
/// without axial runs, unable to fit curvature.
pub fn box_behnken(factors: usize, centre_points: usize) -> Result<Vec<Vec<f64>>, DesignError> {
    if factors < 3 {
        return Err(DesignError::TooFewFactors { factors });
    }
    let edges = 2 * factors * (factors - 1);
    let mut runs = Vec::with_capacity(edges + centre_points);
    for i in 0..factors {
        for j in i + 1..factors {
            for (a, b) in PAIR_CORNERS {
                let mut run = vec![0.0; factors];
                run[i] = a;
                run[j] = b;
                runs.push(run);
            }
        }
    }
    runs.extend((0..centre_points).map(|_| vec![0.0; factors]));
    Ok(runs)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factors a run sets away from the centre.
    fn nonzero(run: &[f64]) -> Vec<usize> {
        (0..run.len()).filter(|&f| run[f] != 0.0).collect()
    }

    /// Run count, the shape of every edge run, each pair 4 times, centres last.
    fn check_structure(k: usize, centres: usize) {
        let runs = box_behnken(k, centres).unwrap();
        let edges = 2 * k * (k - 1);
        assert_eq!(runs.len(), edges + centres, "k = {k}");
        let mut pairs = std::collections::BTreeMap::new();
        for run in &runs[..edges] {
            assert_eq!(run.len(), k);
            let on = nonzero(run);
            assert_eq!(on.len(), 2, "{run:?}");
            assert!(
                on.iter().all(|&f| run[f] == 1.0 || run[f] == -1.0),
                "{run:?}"
            );
            *pairs.entry((on[0], on[1])).or_insert(0) += 1;
        }
        assert_eq!(pairs.len(), k * (k - 1) / 2);
        assert!(pairs.values().all(|&n| n == 4), "{pairs:?}");
        // Pairs in lexicographic order, each a block of four.
        let order: Vec<(usize, usize)> = runs[..edges]
            .chunks(4)
            .map(|block| {
                let on = nonzero(&block[0]);
                assert!(block.iter().all(|r| nonzero(r) == on));
                (on[0], on[1])
            })
            .collect();
        let mut sorted = order.clone();
        sorted.sort();
        assert_eq!(order, sorted);
        assert!(runs[edges..].iter().all(|r| r.iter().all(|v| *v == 0.0)));
        // Every level of every factor is used, in a balanced way: each factor
        // is at −1 and +1 equally often.
        for f in 0..k {
            let low = runs.iter().filter(|r| r[f] == -1.0).count();
            let high = runs.iter().filter(|r| r[f] == 1.0).count();
            assert_eq!(low, high);
            assert_eq!(low, 2 * (k - 1));
        }
    }

    #[test]
    fn three_factors() {
        check_structure(3, 3);
        // pyDOE3 1.6.2 (python3 -m venv /tmp/venv-doe &&
        // /tmp/venv-doe/bin/pip install pyDOE3):
        //   from pyDOE3 import bbdesign; bbdesign(3, center=3).tolist()
        let expected = [
            [-1, -1, 0],
            [-1, 1, 0],
            [1, -1, 0],
            [1, 1, 0],
            [-1, 0, -1],
            [-1, 0, 1],
            [1, 0, -1],
            [1, 0, 1],
            [0, -1, -1],
            [0, -1, 1],
            [0, 1, -1],
            [0, 1, 1],
            [0, 0, 0],
            [0, 0, 0],
            [0, 0, 0],
        ];
        let expected: Vec<Vec<f64>> = expected
            .iter()
            .map(|r| r.iter().map(|v| *v as f64).collect())
            .collect();
        assert_eq!(box_behnken(3, 3).unwrap(), expected);
    }

    #[test]
    fn four_factors_with_five_centres_is_29_runs() {
        check_structure(4, 5);
        let runs = box_behnken(4, 5).unwrap();
        assert_eq!(runs.len(), 29);
        // pyDOE3 1.6.2: bbdesign(4, center=5)[4:12].tolist() — pairs (A,C), (A,D).
        assert_eq!(runs[4], vec![-1.0, 0.0, -1.0, 0.0]);
        assert_eq!(runs[5], vec![-1.0, 0.0, 1.0, 0.0]);
        assert_eq!(runs[6], vec![1.0, 0.0, -1.0, 0.0]);
        assert_eq!(runs[7], vec![1.0, 0.0, 1.0, 0.0]);
        assert_eq!(runs[8], vec![-1.0, 0.0, 0.0, -1.0]);
        assert_eq!(runs[11], vec![1.0, 0.0, 0.0, 1.0]);
        // ... and the last edge block, (C,D).
        assert_eq!(runs[20], vec![0.0, 0.0, -1.0, -1.0]);
        assert_eq!(runs[23], vec![0.0, 0.0, 1.0, 1.0]);
    }

    #[test]
    fn five_factors() {
        check_structure(5, 2);
        check_structure(5, 0);
        assert_eq!(box_behnken(5, 2).unwrap().len(), 42);
    }

    #[test]
    fn fewer_than_three_factors_is_refused_naming_k() {
        for k in 0..3 {
            let e = box_behnken(k, 1).unwrap_err();
            assert_eq!(e, DesignError::TooFewFactors { factors: k });
            assert!(e.to_string().contains(&format!("k = {k}")), "{e}");
            assert!(e.to_string().contains("at least 3"), "{e}");
        }
    }
}
