//! The parameter sensitivity matrix analysis of yan2015 §2.2.3 ("Level 3"):
//! column norms (Eq. 17), their normalised shares (Fig. 14) and the
//! cross-correlation of parameters (Eq. 18).
//!
//! The input is a parameter-scaled sensitivity matrix S with one row per
//! observation (model response at one state) and one column per parameter,
//! `S_ik = P_k ∂f_i/∂P_k`, so every column is in the units of the response
//! and columns of different parameters compare directly.
//!
//! The cross-correlation needs (SᵀS)⁻¹, which does not exist when a column is
//! zero or a linear combination of the others; the singular value
//! decomposition S = UΣVᵀ gives both the inverse, (SᵀS)⁻¹ = VΣ⁻²Vᵀ, without
//! forming SᵀS (which would square the condition number), and, when S is
//! rank deficient, the combination of columns that vanishes.

use nalgebra::DMatrix;

/// Singular values below this fraction of the largest count as zero.
const RANK_TOLERANCE: f64 = 1e-10;

/// Eq. 17: `norm_k = √(Σ_i S_ik²)`, the Euclidean norm of each column of an
/// already parameter-scaled matrix (rows i, columns k:
/// `S_ik = P_k ∂f_i/∂P_k`), in the units of the response. The smallest norm
/// marks the least influential parameter. Rows must have equal lengths
/// (panics otherwise); no rows gives no columns.
pub fn norms(s: &[Vec<f64>]) -> Vec<f64> {
    let k = columns(s);
    (0..k)
        .map(|j| s.iter().map(|row| row[j] * row[j]).sum::<f64>().sqrt())
        .collect()
}

/// Norms as fractions of their sum (yan2015 Fig. 14 "normalised norms"),
/// dimensionless, summing to one; all zeros when every norm is zero.
pub fn normalised(norms: &[f64]) -> Vec<f64> {
    let total: f64 = norms.iter().sum();
    if total > 0.0 {
        norms.iter().map(|n| n / total).collect()
    } else {
        vec![0.0; norms.len()]
    }
}

/// Eq. 18 cross-correlation of the parameters (columns) of a scaled
/// sensitivity matrix, or why it does not exist.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum CrossCorrelation {
    /// `CC_kl = (SᵀS)⁻¹_kl / √((SᵀS)⁻¹_kk (SᵀS)⁻¹_ll)`, k × k, symmetric, with
    /// unit diagonal and entries in [−1, 1]; near ±1 means the two
    /// parameters can hardly be told apart from these responses.
    Full(Vec<Vec<f64>>),
    /// SᵀS is singular: the smallest singular value of S is below 1e-10 of
    /// the largest (or S is zero, or has fewer rows than columns).
    Singular {
        /// Number of singular values of S at or above the threshold.
        rank: usize,
        /// Unit vector c with S c ≈ 0 (the right singular vector of the
        /// smallest singular value), its largest-magnitude entry positive:
        /// the parameters with nonzero entries are fully cross-correlated
        /// (a zero column gives that column's unit vector). When the rank is
        /// below k − 1 the null space has more dimensions and this is one
        /// vector of it.
        null_vector: Vec<f64>,
    },
}

/// Eq. 18 cross-correlation of the columns of the scaled sensitivity matrix
/// `s` (rows: observations, columns: parameters), computed through the
/// singular value decomposition of S (see the module docs).
///
/// A matrix without columns gives an empty `Full`. Panics if the rows have
/// different lengths or a value is not finite.
pub fn cross_correlation(s: &[Vec<f64>]) -> CrossCorrelation {
    let k = columns(s);
    assert!(
        s.iter().flatten().all(|v| v.is_finite()),
        "cross_correlation: a sensitivity is not finite"
    );
    if k == 0 {
        return CrossCorrelation::Full(Vec::new());
    }
    // Pad with zero rows to at least k: SᵀS is unchanged and the SVD then
    // returns all k right singular vectors, null directions included.
    let n = s.len().max(k);
    let m = DMatrix::from_fn(n, k, |i, j| s.get(i).map_or(0.0, |row| row[j]));
    let svd = m.svd(false, true);
    let v_t = svd.v_t.expect("V was requested");
    let sigma = svd.singular_values;
    let max = sigma.max();
    let (min_at, min) = sigma.argmin();
    let rank = sigma
        .iter()
        .filter(|&&x| max > 0.0 && x >= RANK_TOLERANCE * max)
        .count();
    if rank < k || min < RANK_TOLERANCE * max {
        let mut v: Vec<f64> = v_t.row(min_at).iter().copied().collect();
        let largest = v
            .iter()
            .copied()
            .fold(0.0, |a: f64, x| if x.abs() > a.abs() { x } else { a });
        if largest < 0.0 {
            v.iter_mut().for_each(|x| *x = -*x);
        }
        return CrossCorrelation::Singular {
            rank,
            null_vector: v,
        };
    }
    // (SᵀS)⁻¹ = V Σ⁻² Vᵀ; rows of Vᵀ are the right singular vectors.
    let inverse = DMatrix::from_fn(k, k, |a, b| {
        (0..k)
            .map(|r| v_t[(r, a)] * v_t[(r, b)] / (sigma[r] * sigma[r]))
            .sum::<f64>()
    });
    CrossCorrelation::Full(
        (0..k)
            .map(|a| {
                (0..k)
                    .map(|b| inverse[(a, b)] / (inverse[(a, a)] * inverse[(b, b)]).sqrt())
                    .collect()
            })
            .collect(),
    )
}

/// The common row length of `s` (0 for no rows); panics on ragged rows.
fn columns(s: &[Vec<f64>]) -> usize {
    let k = s.first().map_or(0, Vec::len);
    assert!(
        s.iter().all(|row| row.len() == k),
        "sensitivity matrix rows have different lengths"
    );
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norms_and_normalised_by_hand() {
        let s = vec![vec![3.0, 0.0, 1.0], vec![4.0, 0.0, -1.0]];
        // √(9 + 16) = 5, 0, √2.
        let n = norms(&s);
        assert_eq!(n, vec![5.0, 0.0, 2f64.sqrt()]);
        let f = normalised(&n);
        let total = 5.0 + 2f64.sqrt();
        assert_eq!(f, vec![5.0 / total, 0.0, 2f64.sqrt() / total]);
        assert_eq!(normalised(&[0.0, 0.0]), vec![0.0, 0.0]);
        assert!(norms(&[]).is_empty());
    }

    #[test]
    fn cross_correlation_matches_numpy() {
        let s = vec![
            vec![1.0, 2.0, 0.5],
            vec![0.3, -1.0, 2.0],
            vec![2.0, 0.1, 1.0],
            vec![-0.7, 1.5, 0.2],
            vec![0.4, 0.4, -1.2],
        ];
        // import numpy as np
        // S = np.array([[1,2,.5],[.3,-1,2],[2,.1,1],[-.7,1.5,.2],[.4,.4,-1.2]])
        // A = np.linalg.inv(S.T @ S); d = np.sqrt(np.diag(A))
        // print(repr(A / np.outer(d, d)))
        // → [[ 1.0,                 -0.23808243797259313, -0.43290677024186847],
        //    [-0.23808243797259313, 1.0,                  0.23687462534572198],
        //    [-0.4329067702418684,  0.23687462534572193,  1.0]]
        // (numpy prints the diagonal as 0.9999999999999999 / 0.9999999999999998)
        let expected = [
            [1.0, -0.238_082_437_972_593_13, -0.432_906_770_241_868_47],
            [-0.238_082_437_972_593_13, 1.0, 0.236_874_625_345_721_98],
            [-0.432_906_770_241_868_47, 0.236_874_625_345_721_98, 1.0],
        ];
        let CrossCorrelation::Full(cc) = cross_correlation(&s) else {
            panic!("full rank expected");
        };
        for a in 0..3 {
            for b in 0..3 {
                assert!(
                    (cc[a][b] - expected[a][b]).abs() < 1e-12,
                    "{a},{b}: {} vs {}",
                    cc[a][b],
                    expected[a][b]
                );
            }
        }
    }

    #[test]
    fn singular_matrix_names_the_collinear_columns() {
        // Third column = first + 2 × second: S (1, 2, −1)ᵀ = 0.
        let s: Vec<Vec<f64>> = [[1.0, 0.5], [0.2, -1.0], [3.0, 0.7], [-0.4, 0.9]]
            .iter()
            .map(|&[x, y]| vec![x, y, x + 2.0 * y])
            .collect();
        let CrossCorrelation::Singular { rank, null_vector } = cross_correlation(&s) else {
            panic!("singular expected");
        };
        assert_eq!(rank, 2);
        let norm = 6f64.sqrt();
        let expected = [1.0 / norm, 2.0 / norm, -1.0 / norm];
        for (v, e) in null_vector.iter().zip(expected) {
            assert!((v - e).abs() < 1e-12, "{null_vector:?}");
        }
        // A zero column is rank deficient too, and is its own null vector.
        let z = vec![vec![1.0, 0.0], vec![2.0, 0.0], vec![0.5, 0.0]];
        let CrossCorrelation::Singular { rank, null_vector } = cross_correlation(&z) else {
            panic!("singular expected");
        };
        assert_eq!(rank, 1);
        assert!((null_vector[0]).abs() < 1e-15 && (null_vector[1] - 1.0).abs() < 1e-15);
        // Fewer rows than columns.
        assert!(matches!(
            cross_correlation(&[vec![1.0, 2.0]]),
            CrossCorrelation::Singular { rank: 1, .. }
        ));
    }
}
