//! Principal component analysis of a data matrix (yan2015 Eq. 13–16).
//!
//! The n × m matrix X (one row per observation, one column per variable) is
//! auto-scaled column by column, z = (x − mean) / s with s the sample
//! standard deviation (n − 1 denominator), so every column of Z has zero mean
//! and unit variance and the units of the variables drop out (Eq. 13).
//! yan2015's Eq. 13 text says "variance" in the denominator, but scaling to
//! unit variance divides by the standard deviation, which is what is done
//! here; Q/(n − 1) is then the correlation matrix of X.
//!
//! The components are the eigenvectors of Q = ZᵀZ (Eq. 14), in descending
//! order of eigenvalue; each eigenvalue over their sum (which is m·(n − 1))
//! is the fraction of the total scaled variance that component explains
//! (Eq. 15–16). Eigenvectors are of unit length, and since their sign is
//! arbitrary it is fixed so that the entry of largest magnitude (the first
//! such on a tie) is positive, making the output deterministic.

use nalgebra::{DMatrix, SymmetricEigen};

use super::{check_finite, StatsError};

/// A principal component analysis of auto-scaled data.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Pca {
    /// Column (variable) names, in the order of the data columns.
    pub columns: Vec<String>,
    /// Column means, in the units of each column.
    pub means: Vec<f64>,
    /// Column sample standard deviations (n − 1 denominator), in the units of
    /// each column: the auto-scaling divisors.
    pub std_devs: Vec<f64>,
    /// Eigenvalues of Q = ZᵀZ, descending (dimensionless; rounding can leave
    /// a tiny negative value where the data are rank deficient).
    pub eigenvalues: Vec<f64>,
    /// Fraction of the total scaled variance explained by each component:
    /// eigenvalue / sum of eigenvalues.
    pub explained: Vec<f64>,
    /// `eigenvectors[k][c]`: loading of column c on component k (each
    /// component of unit length, its largest-magnitude loading positive).
    pub eigenvectors: Vec<Vec<f64>>,
}

/// Principal component analysis of `rows` (one row per observation, one value
/// per entry of `columns`), as in the module docs.
///
/// Errors: fewer than two rows ([`StatsError::TooFewObservations`]: a
/// standard deviation needs two); a row without one value per column
/// ([`StatsError::LengthMismatch`]); a non-finite value
/// ([`StatsError::NonFinite`], naming the row); a column with zero variance
/// ([`StatsError::ConstantColumn`], which cannot be scaled).
pub fn pca(rows: &[Vec<f64>], columns: &[String]) -> Result<Pca, StatsError> {
    let n = rows.len();
    let m = columns.len();
    if n < 2 {
        return Err(StatsError::TooFewObservations {
            observations: n,
            parameters: 1,
        });
    }
    for (i, row) in rows.iter().enumerate() {
        if row.len() != m {
            return Err(StatsError::LengthMismatch {
                what: format!("row {i} (one value per column)"),
                expected: m,
                got: row.len(),
            });
        }
        check_finite(&format!("row {i}"), row)?;
    }
    let mut means = Vec::with_capacity(m);
    let mut std_devs = Vec::with_capacity(m);
    for (c, name) in columns.iter().enumerate() {
        let mean = rows.iter().map(|r| r[c]).sum::<f64>() / n as f64;
        let var = rows.iter().map(|r| (r[c] - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        if var <= 0.0 {
            return Err(StatsError::ConstantColumn {
                column: name.clone(),
            });
        }
        means.push(mean);
        std_devs.push(var.sqrt());
    }
    let z = DMatrix::from_fn(n, m, |i, c| (rows[i][c] - means[c]) / std_devs[c]);
    let q = z.transpose() * &z;
    let eigen = SymmetricEigen::new(q);
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
    let eigenvalues: Vec<f64> = order.iter().map(|&k| eigen.eigenvalues[k]).collect();
    let total: f64 = eigenvalues.iter().sum();
    let eigenvectors = order
        .iter()
        .map(|&k| {
            let mut v: Vec<f64> = eigen.eigenvectors.column(k).iter().copied().collect();
            let largest =
                v.iter().enumerate().fold(
                    0,
                    |best, (c, x)| if x.abs() > v[best].abs() { c } else { best },
                );
            if v[largest] < 0.0 {
                v.iter_mut().for_each(|x| *x = -*x);
            }
            v
        })
        .collect();
    Ok(Pca {
        columns: columns.to_vec(),
        means,
        std_devs,
        explained: eigenvalues.iter().map(|e| e / total).collect(),
        eigenvalues,
        eigenvectors,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::assert_rel;

    fn names() -> Vec<String> {
        ["a", "b", "c", "d"].map(String::from).to_vec()
    }

    #[test]
    fn pca_matches_numpy_eigh() {
        // M as below; Z=(M-M.mean(0))/M.std(0,ddof=1)
        // w,V=np.linalg.eigh(Z.T@Z); o=np.argsort(w)[::-1]; w=w[o]; V=V[:,o]
        // each column V[:,k] negated when its largest-|.| entry is negative;
        // explained = w/w.sum()
        let m = vec![
            vec![0.3, 12.0, 1.1, 5.0],
            vec![0.5, 15.0, 0.9, 4.2],
            vec![0.2, 9.0, 1.4, 6.1],
            vec![0.7, 20.0, 0.8, 3.9],
            vec![0.4, 11.0, 1.2, 5.5],
            vec![0.6, 18.0, 1.0, 4.0],
            vec![0.1, 7.0, 1.5, 6.8],
            vec![0.8, 21.0, 0.7, 3.1],
        ];
        let p = pca(&m, &names()).unwrap();
        assert_eq!(p.columns, names());
        assert_rel(
            "means",
            &p.means,
            &[0.45000000000000007, 14.125, 1.075, 4.825],
        );
        assert_rel(
            "std devs",
            &p.std_devs,
            &[
                0.24494897427831783,
                5.19443383412888,
                0.28157719063467174,
                1.2487136238088035,
            ],
        );
        assert_rel(
            "eigenvalues",
            &p.eigenvalues,
            &[
                27.31791861724353,
                0.443045084460183,
                0.15185214496149999,
                0.08718415333478786,
            ],
        );
        assert_rel(
            "explained",
            &p.explained,
            &[
                0.9756399506158403,
                0.015823038730720818,
                0.0054232908914821415,
                0.003113719761956709,
            ],
        );
        let vectors = [
            [
                -0.4993274855845688,
                -0.5008318816351564,
                0.49821383754302223,
                0.5016198366873421,
            ],
            [
                0.5389082667469874,
                0.43791857895332453,
                0.6297066041663278,
                0.34824530278033916,
            ],
            [
                0.5572763134047802,
                -0.4688647507732652,
                -0.44095606717944,
                0.5245633449050194,
            ],
            [
                -0.3869018644172276,
                0.580999647183726,
                -0.4010116102653486,
                0.5932419790568195,
            ],
        ];
        for (k, v) in vectors.iter().enumerate() {
            assert_rel(&format!("eigenvector {k}"), &p.eigenvectors[k], v);
        }
    }

    #[test]
    fn pca_refuses_bad_input() {
        let rows = vec![
            vec![1.0, 2.0, 3.0, 4.0],
            vec![2.0, 2.0, 1.0, 5.0],
            vec![3.0, 2.0, 2.0, 7.0],
        ];
        assert_eq!(
            pca(&rows, &names()),
            Err(StatsError::ConstantColumn {
                column: "b".to_string()
            })
        );
        assert_eq!(
            pca(&rows[..1], &names()),
            Err(StatsError::TooFewObservations {
                observations: 1,
                parameters: 1
            })
        );
        let mut bad = rows.clone();
        bad[2][3] = f64::NAN;
        assert_eq!(
            pca(&bad, &names()).unwrap_err().to_string(),
            "non-finite value NaN in row 2 at index 3"
        );
        assert!(matches!(
            pca(&rows, &names()[..3]),
            Err(StatsError::LengthMismatch { .. })
        ));
    }
}
