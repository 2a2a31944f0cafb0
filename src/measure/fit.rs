//! Least-squares straight lines through surface points.

use super::MeasureError;

/// Fewest points a line fit accepts: two points always fit exactly (R² = 1 says
/// nothing), so three is the least that carries a quality measure.
pub const MIN_FIT_POINTS: usize = 3;

/// A least-squares line `v = intercept + slope · h` through surface points
/// (h horizontal, v vertical, both in m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFit {
    /// dv/dh, dimensionless (a rise over a run).
    pub slope: f64,
    /// v at h = 0, m.
    pub intercept: f64,
    /// Coefficient of determination, 1 − SS_res/SS_tot; 1 for points exactly on a
    /// horizontal line (SS_tot = 0, SS_res = 0).
    pub r2: f64,
    /// Number of points in the fit.
    pub points: usize,
}

impl LineFit {
    /// Inclination of the line, degrees in [0, 90): atan(|slope|).
    pub fn angle_deg(&self) -> f64 {
        self.slope.abs().atan().to_degrees()
    }
}

/// Fits `v = a + b h` by ordinary least squares (residuals in v). `what` names the
/// profile in errors. Needs [`MIN_FIT_POINTS`] points with at least two distinct h.
pub fn fit_line(points: &[(f64, f64)], what: &'static str) -> Result<LineFit, MeasureError> {
    let n = points.len();
    if n < MIN_FIT_POINTS {
        return Err(MeasureError::TooFewPoints {
            what,
            found: n,
            needed: MIN_FIT_POINTS,
        });
    }
    let nf = n as f64;
    let mean_h = points.iter().map(|p| p.0).sum::<f64>() / nf;
    let mean_v = points.iter().map(|p| p.1).sum::<f64>() / nf;
    let (mut shh, mut shv, mut svv) = (0.0, 0.0, 0.0);
    for &(h, v) in points {
        let (dh, dv) = (h - mean_h, v - mean_v);
        shh += dh * dh;
        shv += dh * dv;
        svv += dv * dv;
    }
    // Relative test: a spread far below rounding of the coordinates is no spread.
    let scale = points
        .iter()
        .map(|p| p.0.abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    if shh <= (scale * 1e-12).powi(2) * nf {
        return Err(MeasureError::VerticalLine { what });
    }
    let slope = shv / shh;
    let intercept = mean_v - slope * mean_h;
    let ss_res = (svv - slope * shv).max(0.0);
    let r2 = if svv > 0.0 { 1.0 - ss_res / svv } else { 1.0 };
    Ok(LineFit {
        slope,
        intercept,
        r2,
        points: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_line_has_r2_one() {
        let pts: Vec<_> = (0..5).map(|i| (i as f64, 2.0 + 0.5 * i as f64)).collect();
        let f = fit_line(&pts, "test").unwrap();
        assert!((f.slope - 0.5).abs() < 1e-12);
        assert!((f.intercept - 2.0).abs() < 1e-12);
        assert!((f.r2 - 1.0).abs() < 1e-12);
        assert!((f.angle_deg() - 0.5f64.atan().to_degrees()).abs() < 1e-12);
    }

    #[test]
    fn horizontal_line_is_fine_and_vertical_is_an_error() {
        let flat: Vec<_> = (0..4).map(|i| (i as f64, 1.0)).collect();
        let f = fit_line(&flat, "flat").unwrap();
        assert_eq!((f.slope, f.r2), (0.0, 1.0));
        let vertical: Vec<_> = (0..4).map(|i| (1.0, i as f64)).collect();
        assert_eq!(
            fit_line(&vertical, "v"),
            Err(MeasureError::VerticalLine { what: "v" })
        );
        assert!(matches!(
            fit_line(&flat[..2], "two"),
            Err(MeasureError::TooFewPoints { found: 2, .. })
        ));
    }

    #[test]
    fn noisy_line_r2_below_one() {
        let pts: Vec<_> = (0..20)
            .map(|i| (i as f64, i as f64 + if i % 2 == 0 { 0.3 } else { -0.3 }))
            .collect();
        let f = fit_line(&pts, "noisy").unwrap();
        assert!(f.r2 > 0.9 && f.r2 < 1.0);
        assert!((f.slope - 1.0).abs() < 0.05);
    }
}
