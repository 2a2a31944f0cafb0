//! Equivalence of a mean to a band: the two one-sided t-tests (TOST), the
//! power of TOST for a planned number of replicates, and the number of
//! replicates that would decide an undecided comparison.
//!
//! # TOST
//!
//! For n ≥ 2 values with mean x̄, sample sd s, se = s/√n and df = n − 1,
//! against a band [lo, hi]:
//! - lower test H₀: μ ≤ lo, t₁ = (x̄ − lo)/se, p₁ = P(T_df ≥ t₁);
//! - upper test H₀: μ ≥ hi, t₂ = (x̄ − hi)/se, p₂ = P(T_df ≤ t₂);
//! - the TOST p-value is max(p₁, p₂) (as statsmodels'
//!   `DescrStatsW(x).ttost_mean(lo, hi)` returns it). Both tests reject at
//!   level α exactly when the (1 − 2α) interval of the mean lies inside the
//!   band.
//!
//! With zero spread a t statistic is ±∞ (p 0 or 1); a mean on a band edge
//! with zero spread gives p = 1 (nothing rejects).
//!
//! # Power
//!
//! [`tost_power`] is the exact probability that both tests reject when the
//! values are normal with mean μ and sd σ: given the sample sd S, the
//! means that reject form the interval lo + c·S/√n < x̄ < hi − c·S/√n
//! (c = t_{1−α}(n − 1)), so the power is the expectation over S of
//! Φ((hi − c·S/√n − μ)/(σ/√n)) − Φ((lo + c·S/√n − μ)/(σ/√n)), clipped at 0,
//! with S = σ·W/√(n − 1) and W chi-distributed with n − 1 df. The
//! integral is taken by composite Simpson's rule over W (the integrand is
//! smooth up to the point where the interval closes, which is the upper
//! limit). The usual noncentral-t approximation (the sum of the two
//! one-sided powers minus one) is a lower bound of it that agrees where the
//! chance of an empty rejection interval is negligible.

use statrs::distribution::{ContinuousCDF, Normal};
use statrs::function::gamma::ln_gamma;

use super::summary::{mean_sd, t_quantile, t_two_sided_p};

/// The two one-sided t-tests of a mean against a band, with the intervals a
/// report prints beside them. Units are those of the values.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Tost {
    /// Number of values.
    pub n: usize,
    /// Sample mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1 denominator).
    pub sd: f64,
    /// Degrees of freedom, n − 1.
    pub df: f64,
    /// t statistic of the lower test, (mean − lo)/se.
    pub t_lower: f64,
    /// p-value of the lower test, P(T ≥ t_lower).
    pub p_lower: f64,
    /// t statistic of the upper test, (mean − hi)/se.
    pub t_upper: f64,
    /// p-value of the upper test, P(T ≤ t_upper).
    pub p_upper: f64,
    /// The TOST p-value, max(p_lower, p_upper).
    pub p: f64,
    /// Half-width of the 90 % interval of the mean, t₀.₉₅(df)·se.
    pub ci90_half_width: f64,
    /// Half-width of the 95 % interval of the mean, t₀.₉₇₅(df)·se.
    pub ci95_half_width: f64,
}

/// P(T ≥ t) for Student's t with `df` degrees of freedom (1 for a NaN t,
/// which arises only as 0/0: a mean on the bound with no spread).
fn upper_tail(t: f64, df: f64) -> f64 {
    if t.is_nan() {
        return 1.0;
    }
    let two = t_two_sided_p(t, df);
    if t > 0.0 {
        0.5 * two
    } else {
        1.0 - 0.5 * two
    }
}

/// The equivalence band of a target: target × (1 ∓ tolerance) as
/// (lo, hi), lo ≤ hi for a target of either sign. The one band formula:
/// he2019's targets (Eq. 8–10), the design studies' and `repose verdict`.
pub fn band(target: f64, tolerance: f64) -> (f64, f64) {
    let (a, b) = (target * (1.0 - tolerance), target * (1.0 + tolerance));
    (a.min(b), a.max(b))
}

/// TOST of `values` against the band `band` = (lo, hi) (see the module
/// docs); `None` for fewer than two values (no spread, so no test).
pub fn tost(values: &[f64], band: (f64, f64)) -> Option<Tost> {
    let n = values.len();
    if n < 2 {
        return None;
    }
    let (mean, sd) = mean_sd(values);
    let df = (n - 1) as f64;
    let test = tost_estimate(mean, sd / (n as f64).sqrt(), df, band);
    Some(Tost {
        n,
        mean,
        sd,
        df,
        t_lower: test.t_lower,
        p_lower: test.p_lower,
        t_upper: test.t_upper,
        p_upper: test.p_upper,
        p: test.p,
        ci90_half_width: test.ci90_half_width,
        ci95_half_width: test.ci95_half_width,
    })
}

/// TOST of any estimate with a t-distributed error, against a band: the
/// core of [`tost`] (whose estimate is a mean), also used for a fitted
/// quantity such as a trend's change over a range (statsmodels has no
/// one-call form for it; the test gives the scipy calls).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EstimateTost {
    /// The estimate.
    pub estimate: f64,
    /// Its standard error.
    pub std_error: f64,
    /// Degrees of freedom of the t distribution.
    pub df: f64,
    /// (estimate − lo)/se.
    pub t_lower: f64,
    /// P(T ≥ t_lower).
    pub p_lower: f64,
    /// (estimate − hi)/se.
    pub t_upper: f64,
    /// P(T ≤ t_upper).
    pub p_upper: f64,
    /// The TOST p-value, max(p_lower, p_upper).
    pub p: f64,
    /// Half-width of the 90 % interval, t₀.₉₅(df)·se.
    pub ci90_half_width: f64,
    /// Half-width of the 95 % interval, t₀.₉₇₅(df)·se.
    pub ci95_half_width: f64,
}

/// [`EstimateTost`] of `estimate` with standard error `std_error` on `df`
/// degrees of freedom against `band` = (lo, hi).
pub fn tost_estimate(estimate: f64, std_error: f64, df: f64, band: (f64, f64)) -> EstimateTost {
    let t_lower = (estimate - band.0) / std_error;
    let t_upper = (estimate - band.1) / std_error;
    let p_lower = upper_tail(t_lower, df);
    let p_upper = upper_tail(-t_upper, df);
    EstimateTost {
        estimate,
        std_error,
        df,
        t_lower,
        p_lower,
        t_upper,
        p_upper,
        p: p_lower.max(p_upper),
        ci90_half_width: t_quantile(0.95, df) * std_error,
        ci95_half_width: t_quantile(0.975, df) * std_error,
    }
}

/// Intervals of Simpson's rule in [`tost_power`]'s integral over the chi
/// variable; the integrand is smooth there, so the error is far below 1e-9.
const SIMPSON_INTERVALS: usize = 4000;

/// Exact power of TOST at level `alpha` with `n` ≥ 2 normal values of mean
/// `true_mean` and sd `sigma` > 0 against `band` (see the module docs); 0
/// when n < 2. Units of `sigma`, `band` and `true_mean` are the values'.
pub fn tost_power(n: usize, sigma: f64, band: (f64, f64), true_mean: f64, alpha: f64) -> f64 {
    if n < 2 || sigma <= 0.0 || band.1 <= band.0 {
        return 0.0;
    }
    let nu = (n - 1) as f64;
    let root_n = (n as f64).sqrt();
    let c = t_quantile(1.0 - alpha, nu);
    let normal = Normal::standard();
    let se = sigma / root_n;
    // S = σ·w/√ν; the rejection interval closes where 2·c·S/√n = hi − lo.
    let w_close = (band.1 - band.0) * root_n * nu.sqrt() / (2.0 * c * sigma);
    // Beyond √ν + 12 the chi density is below e⁻⁷² of its peak.
    let upper = w_close.min(nu.sqrt() + 12.0);
    let ln_norm = (0.5 * nu - 1.0) * std::f64::consts::LN_2 + ln_gamma(0.5 * nu);
    let integrand = |w: f64| {
        let density = if w == 0.0 {
            if nu == 1.0 {
                (2.0 / std::f64::consts::PI).sqrt()
            } else {
                0.0
            }
        } else {
            ((nu - 1.0) * w.ln() - 0.5 * w * w - ln_norm).exp()
        };
        let s = sigma * w / nu.sqrt();
        let shift = c * s / root_n;
        let inside = normal.cdf((band.1 - shift - true_mean) / se)
            - normal.cdf((band.0 + shift - true_mean) / se);
        inside.max(0.0) * density
    };
    let h = upper / SIMPSON_INTERVALS as f64;
    let mut sum = integrand(0.0) + integrand(upper);
    for i in 1..SIMPSON_INTERVALS {
        let weight = if i % 2 == 1 { 4.0 } else { 2.0 };
        sum += weight * integrand(i as f64 * h);
    }
    (sum * h / 3.0).clamp(0.0, 1.0)
}

/// The fewest replicates (≥ 2, ≤ `cap`) that give TOST at level `alpha` at
/// least `power` when the true mean is the band's centre and the sd is
/// `sigma`; `None` when even `cap` replicates do not.
pub fn replicates_for_power(
    sigma: f64,
    band: (f64, f64),
    alpha: f64,
    power: f64,
    cap: usize,
) -> Option<usize> {
    let centre = 0.5 * (band.0 + band.1);
    (2..=cap).find(|&n| tost_power(n, sigma, band, centre, alpha) >= power)
}

/// Largest replicate count [`replicates_to_decide`] looks at.
pub const DECIDE_SEARCH_LIMIT: usize = 1_000_000;

/// The fewest replicates N ≥ max(`t.n`, 2) at which a comparison with `t`'s
/// mean and sd would be decided: with the mean inside `band`, its interval
/// t_{`pass_quantile`}(N − 1)·sd/√N (0.95 for TOST at α = 0.05) fits on
/// both sides of it inside the band; with the mean outside, its interval
/// t_{`fail_quantile`}(N − 1)·sd/√N (0.975 for a 95 % interval) stays clear
/// of the band. `None` when the mean lies on a band edge (no count decides)
/// or more than [`DECIDE_SEARCH_LIMIT`] replicates would be needed. The
/// half-width falls monotonically with N, so the count is found by doubling
/// and bisection.
pub fn replicates_to_decide(
    t: &Tost,
    band: (f64, f64),
    pass_quantile: f64,
    fail_quantile: f64,
) -> Option<usize> {
    let (room, quantile) = if t.mean > band.0 && t.mean < band.1 {
        ((t.mean - band.0).min(band.1 - t.mean), pass_quantile)
    } else if t.mean < band.0 || t.mean > band.1 {
        ((band.0 - t.mean).max(t.mean - band.1), fail_quantile)
    } else {
        return None;
    };
    let decided = |n: usize| t_quantile(quantile, (n - 1) as f64) * t.sd / (n as f64).sqrt() < room;
    let mut lo = t.n.max(2);
    if decided(lo) {
        return Some(lo);
    }
    let mut hi = lo;
    while !decided(hi) {
        if hi >= DECIDE_SEARCH_LIMIT {
            return None;
        }
        lo = hi;
        hi = (2 * hi).min(DECIDE_SEARCH_LIMIT);
    }
    // decided(hi) and not decided(lo).
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if decided(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::assert_rel;

    const BAND: (f64, f64) = (45.41, 50.19);

    /// One table per verdict. Expected values from statsmodels 0.15.0:
    /// `d = DescrStatsW(np.array(x)); p, (t1, p1, _), (t2, p2, _) =
    /// d.ttost_mean(45.41, 50.19)`, and the interval half-widths from
    /// `d.tconfint_mean(0.05)` / `d.tconfint_mean(0.10)` (scipy's t).
    #[test]
    fn tost_matches_statsmodels() {
        // (values, p, t1, p1, t2, p2, ci95 half, ci90 half, sd)
        let cases: [(&[f64], [f64; 8]); 3] = [
            (
                &[47.1, 48.3, 47.9, 48.6, 47.5, 48.0, 48.8, 47.7],
                [
                    5.718976260823723e-06,
                    12.862402605198254,
                    1.992852892703644e-06,
                    -10.991054020542833,
                    5.718976260823723e-06,
                    0.473847631391763,
                    0.379655069469365,
                    0.5667892024377307,
                ],
            ),
            (
                &[53.2, 54.1, 52.8, 53.9, 54.4],
                [
                    0.9998526509670446,
                    27.973692283183407,
                    4.8577055253940445e-06,
                    11.805101096530862,
                    0.9998526509670446,
                    0.8208140987448047,
                    0.6302483327708615,
                    0.6610597552415366,
                ],
            ),
            (
                &[44.0, 52.5, 47.9, 49.5],
                [
                    0.20206070049825653,
                    1.731346007457895,
                    0.09090984604608,
                    -0.9687629372888349,
                    0.20206070049825653,
                    5.633881317586251,
                    4.166156791650451,
                    3.5405978779484877,
                ],
            ),
        ];
        for (x, e) in cases {
            let t = tost(x, BAND).unwrap();
            let got = [
                t.p,
                t.t_lower,
                t.p_lower,
                t.t_upper,
                t.p_upper,
                t.ci95_half_width,
                t.ci90_half_width,
                t.sd,
            ];
            assert_rel("tost", &got, &e);
        }
        assert!(tost(&[48.0], BAND).is_none());
    }

    #[test]
    fn zero_spread_is_decided_by_the_position_alone() {
        assert_eq!(tost(&[48.0, 48.0], BAND).unwrap().p, 0.0);
        assert_eq!(tost(&[52.0, 52.0], BAND).unwrap().p, 1.0);
        assert_eq!(tost(&[45.41, 45.41], BAND).unwrap().p, 1.0);
    }

    /// Exact power against scipy. With `c = t.ppf(0.95, n-1)`,
    /// `se = sigma/sqrt(n)` and `s(w) = sigma*w/sqrt(n-1)`, the reference is
    /// `integrate.quad(f, 0, w_close, epsabs=1e-13, epsrel=1e-12)` of
    /// `f(w) = max(0, norm.cdf((hi - c*s(w)/sqrt(n) - mu)/se) -
    /// norm.cdf((lo + c*s(w)/sqrt(n) - mu)/se)) * chi.pdf(w, n-1)`,
    /// confirmed by 2·10⁶-draw Monte Carlo for (5, 2.0, 47.8): 0.4758,
    /// 0.4768, 0.4762. The second column, the noncentral-t approximation
    /// `nct.sf(c, n-1, (mu-lo)/se) + nct.cdf(-c, n-1, (mu-hi)/se) - 1`,
    /// is a lower bound.
    #[test]
    fn power_matches_scipy() {
        let cases = [
            (5, 2.0, 47.8, 0.4758748520751148, 0.4177317938980243),
            (10, 2.0, 47.8, 0.9328266643094179, 0.9328252395574124),
            (20, 4.1, 47.8, 0.6144121895571323, 0.6143253531091319),
            (12, 3.0, 49.0, 0.34853139126905397, 0.34824199771584197),
            (3, 1.0, 47.8, 0.7141300602335373, 0.6466021481348152),
        ];
        for (n, sigma, mu, exact, nct) in cases {
            let p = tost_power(n, sigma, BAND, mu, 0.05);
            assert_rel("power", &[p], &[exact]);
            assert!(p >= nct);
        }
    }

    /// `next(n for n in range(2, 1000) if exact(n, sigma, band, centre) >= 0.8)`
    /// with `exact` as above: 8 for σ = 2.0 (power 0.7466 at 7, 0.8345 at
    /// 8), 27 for σ = 4.1 (0.7871 at 26, 0.8077 at 27).
    #[test]
    fn replicates_for_power_matches_scipy() {
        assert_eq!(replicates_for_power(2.0, BAND, 0.05, 0.8, 100), Some(8));
        assert_eq!(replicates_for_power(4.1, BAND, 0.05, 0.8, 100), Some(27));
        assert_eq!(replicates_for_power(4.1, BAND, 0.05, 0.8, 26), None);
    }

    /// `next(N for N in range(2, 10**6) if t.ppf(q, N-1)*sd/sqrt(N) < room)`:
    /// 14 for the inconclusive table (q = 0.95, room = 50.19 − 48.475), 56 for
    /// mean 51.0, sd 3.0 (q = 0.975, room = 51.0 − 50.19).
    #[test]
    fn replicates_to_decide_matches_scipy() {
        let t = tost(&[44.0, 52.5, 47.9, 49.5], BAND).unwrap();
        assert_eq!(replicates_to_decide(&t, BAND, 0.95, 0.975), Some(14));
        let outside = Tost {
            mean: 51.0,
            sd: 3.0,
            n: 3,
            ..t
        };
        assert_eq!(replicates_to_decide(&outside, BAND, 0.95, 0.975), Some(56));
        let edge = Tost { mean: 50.19, ..t };
        assert_eq!(replicates_to_decide(&edge, BAND, 0.95, 0.975), None);
        let decided = tost(&[47.1, 48.3, 47.9, 48.6, 47.5], BAND).unwrap();
        assert_eq!(replicates_to_decide(&decided, BAND, 0.95, 0.975), Some(5));
    }
}
