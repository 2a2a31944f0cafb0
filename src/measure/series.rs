//! Statistics of a measurement trace (e.g. the drum angle sampled during steady
//! rotation): the caller picks the samples, this averages them.

use super::MeasureError;

/// Mean and spread of a series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeanStd {
    /// Arithmetic mean, in the series' unit.
    pub mean: f64,
    /// Sample standard deviation (n − 1 in the denominator; 0 for one sample), in
    /// the series' unit.
    pub std: f64,
    /// Number of samples.
    pub n: usize,
}

/// Mean and sample standard deviation of `values`; an error for an empty series or
/// a non-finite value.
pub fn mean_std(values: &[f64]) -> Result<MeanStd, MeasureError> {
    if values.is_empty() {
        return Err(MeasureError::Series("the series is empty".into()));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(MeasureError::Series(format!("sample {i} is not finite")));
    }
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    let std = if n > 1 {
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    Ok(MeanStd { mean, std, n })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_std() {
        let m = mean_std(&[46.0, 47.0, 48.0]).unwrap();
        assert_eq!((m.mean, m.std, m.n), (47.0, 1.0, 3));
        assert_eq!(mean_std(&[5.0]).unwrap().std, 0.0);
        assert!(mean_std(&[]).is_err());
        assert!(mean_std(&[1.0, f64::NAN]).is_err());
    }
}
