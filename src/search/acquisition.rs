//! Acquisition: how likely, or how much better, a surrogate's prediction
//! N(mean, sd²) makes a point — the probability that the response lies in
//! the target band (the noise-aware search keeps points by it and the
//! adaptive stage picks its candidates by it), and the expected improvement
//! of the distance to a target.

use statrs::function::erf::erfc;

/// Standard normal CDF Φ(z).
fn normal_cdf(z: f64) -> f64 {
    0.5 * erfc(-z / std::f64::consts::SQRT_2)
}

/// Standard normal density φ(z).
fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// P(lo ≤ Y ≤ hi) for Y ~ N(mean, sd²) (all in the same unit, e.g. deg);
/// sd = 0 gives 1 when lo ≤ mean ≤ hi and 0 otherwise; hi < lo gives 0.
/// Bands above the mean are computed from the upper tail, so far-tail bands
/// keep their precision.
pub fn probability_in_band(mean: f64, sd: f64, lo: f64, hi: f64) -> f64 {
    if hi < lo {
        return 0.0;
    }
    if sd <= 0.0 {
        return if (lo..=hi).contains(&mean) { 1.0 } else { 0.0 };
    }
    let (a, b) = ((lo - mean) / sd, (hi - mean) / sd);
    if a > 0.0 {
        // Upper tail: Φ(−a) − Φ(−b).
        normal_cdf(-a) - normal_cdf(-b)
    } else {
        normal_cdf(b) - normal_cdf(a)
    }
}

/// Expected improvement for minimising |Y − target|: E[max(0, best − |Y −
/// target|)] for Y ~ N(mean, sd²), `best` = smallest |y − target| seen so far
/// (all in deg). Closed form: with Z = Y − target ~ N(μ, s²), μ = mean −
/// target, and zₜ = (t − μ)/s,
/// E = b(Φ(z_b) − Φ(z₋b)) − μ(Φ(z_b) − 2Φ(z₀) + Φ(z₋b)) − s(2φ(z₀) − φ(z_b)
/// − φ(z₋b)) (the integral of the triangle b − |z| on [−b, b] against the
/// density of Z). sd = 0 gives max(0, best − |mean − target|); best ≤ 0
/// gives 0.
pub fn expected_improvement_on_distance(mean: f64, sd: f64, target: f64, best: f64) -> f64 {
    let mu = mean - target;
    if best <= 0.0 {
        return 0.0;
    }
    if sd <= 0.0 {
        return (best - mu.abs()).max(0.0);
    }
    let z = |t: f64| (t - mu) / sd;
    let (zp, z0, zm) = (z(best), z(0.0), z(-best));
    let (cp, c0, cm) = (normal_cdf(zp), normal_cdf(z0), normal_cdf(zm));
    let ei = best * (cp - cm)
        - mu * (cp - 2.0 * c0 + cm)
        - sd * (2.0 * normal_pdf(z0) - normal_pdf(zp) - normal_pdf(zm));
    ei.max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Asserts |actual − expected| ≤ tol · |expected| for each pair.
    fn assert_close(what: &str, actual: &[f64], expected: &[f64], tol: f64) {
        for (a, e) in actual.iter().zip(expected) {
            assert!((a - e).abs() <= tol * e.abs(), "{what}: {a} against {e}");
        }
    }

    #[test]
    fn band_probability_and_expected_improvement_match_scipy() {
        // scipy.stats.norm.cdf(hi, mu, s) - norm.cdf(lo, mu, s)
        let bands = [
            ((30.0, 2.0, 28.0, 33.0), 0.7745375447996848),
            ((35.0, 1.5, 30.0, 34.0), 0.2520634772137261),
            ((0.0, 1.0, -0.5, 0.25), 0.2901687869569368),
            // far tail, where cdf differences cancel: norm.sf(8) - norm.sf(9)
            ((0.0, 1.0, 8.0, 9.0), 6.219831985865787e-16),
        ];
        for ((mu, s, lo, hi), p_ref) in bands {
            let p = probability_in_band(mu, s, lo, hi);
            assert_close("band", &[p], &[p_ref], 1e-9);
        }
        assert_eq!(probability_in_band(30.0, 0.0, 29.0, 31.0), 1.0);
        assert_eq!(probability_in_band(32.0, 0.0, 29.0, 31.0), 0.0);
        // scipy.integrate.quad(lambda y: max(0, b - abs(y - t)) * norm.pdf(y, mu, s),
        //     t - b, t + b, points=[t], epsabs=1e-14, epsrel=1e-12)[0]
        let cases = [
            ((31.0, 1.0, 32.0, 1.5), 0.5331697534050615),
            ((35.0, 2.0, 32.0, 0.5), 0.016294150190150365),
            ((32.2, 0.3, 32.0, 0.4), 0.1572113166377256),
        ];
        for ((mu, s, t, b), ei_ref) in cases {
            let ei = expected_improvement_on_distance(mu, s, t, b);
            assert_close("ei", &[ei], &[ei_ref], 1e-9);
        }
        assert_eq!(expected_improvement_on_distance(32.5, 0.0, 32.0, 1.5), 1.0);
        assert_eq!(expected_improvement_on_distance(32.5, 1.0, 32.0, 0.0), 0.0);
    }
}
