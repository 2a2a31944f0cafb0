//! The acceptance rule: whether a candidate's replicate runs in one scene
//! reproduce the scene's target band. It is the one rule of every method —
//! he2019's verification (classic and noise-aware) and its adaptive stage,
//! cai2024's and yan2015's verified points, and `repose verdict --table` —
//! so nothing is judged twice by different standards.
//!
//! For n measured replicates (distinct packing seeds; a run that could not
//! measure the response is a missing replicate, not a value), the band
//! [lo, hi] = target × (1 ∓ tolerance) and the level α of the comparison:
//! - **pass** when both one-sided t-tests of TOST reject at α (the
//!   (1 − 2α) interval of the mean lies inside the band);
//! - **fail** when the (1 − α) interval of the mean lies wholly outside the
//!   band;
//! - **inconclusive** otherwise, with the replicates that would decide it at
//!   the measured mean and sd ([`equivalence::replicates_to_decide`]). With
//!   fewer than two measured replicates there is no interval, so the verdict
//!   is inconclusive and the count unknown.
//!
//! α is [`ALPHA`] = 0.05 (the 90 % and 95 % intervals) for one comparison.
//! A stage that judges K candidates and calls the study calibrated when any
//! of them passes — several search candidates, or the rounds of the adaptive
//! stage, each a new candidate until one passes — makes K chances of a
//! wrong pass, so each comparison is judged at α/K (Bonferroni,
//! [`comparison_alpha`]): the chance that any of them passes a candidate
//! whose true mean lies outside the band stays ≤ 0.05 whatever the
//! correlation between them and whenever the stage stops. K is fixed before
//! the first run from the study and the stage's settings (the adaptive
//! stage's K counts the rounds its budget allows, not those it ran), and
//! written in the record. Bonferroni rather than Pocock or O'Brien–Fleming
//! boundaries because the rounds test different candidates, whose
//! statistics are not the nested sums those boundaries are computed for.
//!
//! The statistics are in [`crate::stats::equivalence`]. Every verification
//! stage writes its [`Record`] (`acceptance.json`: the rule's wording
//! [`RULE`], α and K, each target's band and seeds and, where the study has
//! measured its noise, the power calculation that chose the seeds) with its
//! lineage before its first verification run, so neither the rule nor the
//! seeds can be chosen after the result is seen.

use serde::{Deserialize, Serialize};

use crate::stats::equivalence::{self, tost_power, EstimateTost, Tost};
use crate::stats::summary::t_quantile;

/// Level of each one-sided test of a single comparison (and the tails of
/// its fail interval: the two-sided 95 % one).
pub const ALPHA: f64 = 0.05;

/// Power a pre-registered seed count aims at when the candidate sits at the
/// band's centre.
pub const TARGET_POWER: f64 = 0.8;

/// The rule in words, as acceptance records and reports print it.
pub const RULE: &str = "pass when both one-sided t-tests (TOST) reject at level alpha, i.e. \
    the (1 - 2 alpha) interval of the mean of the measured seeds lies inside the band target x \
    (1 -/+ tolerance); fail when the (1 - alpha) interval lies wholly outside the band; \
    inconclusive otherwise (and with fewer than 2 measured seeds); alpha = 0.05 / K for K \
    candidates judged (Bonferroni: 0.05 for one, the 90 % and 95 % intervals)";

/// The level of each of `comparisons` comparisons whose family keeps a
/// chance ≤ [`ALPHA`] of any wrong pass (Bonferroni; module docs).
pub fn comparison_alpha(comparisons: usize) -> f64 {
    ALPHA / comparisons.max(1) as f64
}

/// The verdict on one candidate in one scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// The 90 % interval lies inside the band.
    Pass,
    /// The 95 % interval lies wholly outside the band.
    Fail,
    /// Neither: more seeds would decide.
    Inconclusive,
}

impl Verdict {
    /// `pass`, `fail` or `inconclusive`.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "fail",
            Verdict::Inconclusive => "inconclusive",
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The rule applied to one set of replicates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct Judgement {
    /// The band [lo, hi], units of the values.
    pub band: (f64, f64),
    /// Measured replicates.
    pub n: usize,
    /// Their mean (also for n = 1).
    pub mean: Option<f64>,
    /// TOST and the intervals (n ≥ 2).
    pub tost: Option<Tost>,
    /// The verdict.
    pub verdict: Verdict,
    /// Total measured replicates at which an inconclusive verdict would be
    /// decided at the measured mean and sd (none when decided, when n < 2
    /// or when the mean sits on a band edge).
    pub seeds_to_decide: Option<usize>,
}

impl Judgement {
    /// The 95 % interval's half-width (n ≥ 2).
    pub fn ci95_half_width(&self) -> Option<f64> {
        self.tost.map(|t| t.ci95_half_width)
    }

    /// The simulated mean as a table cell: `mean ± 95 % half-width` (°, two
    /// decimals), the mean alone for one seed, `not measurable` for none.
    pub fn mean_text(&self) -> String {
        match (self.mean, self.ci95_half_width()) {
            (Some(m), Some(h)) => format!("{m:.2} ± {h:.2}"),
            (Some(m), None) => format!("{m:.2}"),
            _ => "not measurable".into(),
        }
    }

    /// The TOST p-value (n ≥ 2).
    pub fn p(&self) -> Option<f64> {
        self.tost.map(|t| t.p)
    }

    /// The verdict as a table cell: an inconclusive one says how many more
    /// seeds would decide it, or that fewer than two were measured.
    pub fn verdict_text(&self) -> String {
        match (self.verdict, self.further_seeds()) {
            (Verdict::Inconclusive, Some(more)) => {
                format!("inconclusive ({more} more seeds decide)")
            }
            (Verdict::Inconclusive, None) if self.n < 2 => {
                "inconclusive (< 2 seeds measured)".into()
            }
            (v, _) => v.to_string(),
        }
    }

    /// Seeds beyond the measured ones that would decide it.
    pub fn further_seeds(&self) -> Option<usize> {
        self.seeds_to_decide.map(|s| s.saturating_sub(self.n))
    }
}

/// The rule (module docs) for one comparison (α = [`ALPHA`]) on the
/// measured `values` against `band` = (lo, hi).
pub fn judge(values: &[f64], band: (f64, f64)) -> Judgement {
    judge_at(values, band, ALPHA)
}

/// The rule (module docs) at level `alpha` (in (0, 0.5)) on the measured
/// `values` against `band` = (lo, hi).
pub fn judge_at(values: &[f64], band: (f64, f64), alpha: f64) -> Judgement {
    let n = values.len();
    let mean = (n > 0).then(|| values.iter().sum::<f64>() / n as f64);
    let tost = equivalence::tost(values, band);
    let verdict = match tost {
        Some(t) => {
            let half = t_quantile(1.0 - alpha / 2.0, t.df) * t.sd / (t.n as f64).sqrt();
            rule(t.p, t.mean, half, band, alpha)
        }
        None => Verdict::Inconclusive,
    };
    let seeds_to_decide = match (verdict, &tost) {
        (Verdict::Inconclusive, Some(t)) => {
            equivalence::replicates_to_decide(t, band, 1.0 - alpha, 1.0 - alpha / 2.0)
        }
        _ => None,
    };
    Judgement {
        band,
        n,
        mean,
        tost,
        verdict,
        seeds_to_decide,
    }
}

/// The rule (module docs) applied to an estimate other than a mean of
/// replicates — a fitted quantity with a t-distributed error, such as a
/// convergence trend's change over its sizes — at level `alpha`.
pub fn judge_estimate(test: &EstimateTost, band: (f64, f64), alpha: f64) -> Verdict {
    let half = t_quantile(1.0 - alpha / 2.0, test.df) * test.std_error;
    rule(test.p, test.estimate, half, band, alpha)
}

/// Pass when the TOST p-value is below `alpha`; fail when the (1 − α)
/// interval (estimate ± `half`) lies wholly outside `band`; inconclusive
/// otherwise.
fn rule(p: f64, estimate: f64, half: f64, band: (f64, f64), alpha: f64) -> Verdict {
    if p < alpha {
        Verdict::Pass
    } else if estimate + half < band.0 || estimate - half > band.1 {
        Verdict::Fail
    } else {
        Verdict::Inconclusive
    }
}

/// The seeds to pre-register for a scene whose per-run noise is `sigma`
/// (units of the band), judged at level `alpha`: the fewest with TOST power
/// ≥ [`TARGET_POWER`] at the band's centre, at most `cap`; `None` when `cap`
/// seeds do not reach it.
pub fn seeds_for_power(sigma: f64, band: (f64, f64), alpha: f64, cap: usize) -> Option<usize> {
    equivalence::replicates_for_power(sigma, band, alpha, TARGET_POWER, cap)
}

/// One judged target of an acceptance record: a scene's (or a design
/// study's) response, its band and the power its seeds have.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AcceptedTarget {
    /// Scene name (he2019) or point-independent response label (design
    /// studies).
    pub name: String,
    /// The response judged.
    pub response: String,
    /// The measured value, the response's units.
    pub target: f64,
    /// Accepted relative deviation.
    pub tolerance_fraction: f64,
    /// [lo, hi] = target × (1 ∓ tolerance).
    pub band: (f64, f64),
    /// Packing seeds each candidate (or point) runs for this target.
    pub seeds: usize,
    /// Seed-to-seed σ from the study's noise floor, when measured.
    pub sigma: Option<f64>,
    /// Seeds that give TOST power ≥ [`TARGET_POWER`] at the band's centre at
    /// that σ and the record's α (none without a σ, or when more than the
    /// cap would be needed).
    pub seeds_for_power: Option<usize>,
    /// TOST power at the band's centre with the seeds run (with a σ).
    pub power_at_seeds: Option<f64>,
}

impl AcceptedTarget {
    /// The target `name`/`response` at `target` ± `tolerance_fraction`,
    /// judged with `seeds` replicates, its noise unmeasured.
    pub fn new(
        name: &str,
        response: &str,
        target: f64,
        tolerance_fraction: f64,
        seeds: usize,
    ) -> AcceptedTarget {
        AcceptedTarget {
            name: name.to_string(),
            response: response.to_string(),
            target,
            tolerance_fraction,
            band: equivalence::band(target, tolerance_fraction),
            seeds,
            sigma: None,
            seeds_for_power: None,
            power_at_seeds: None,
        }
    }

    /// The target with its per-run noise `sigma` measured: its seeds become
    /// the fewest that reach [`TARGET_POWER`] at the band's centre at level
    /// `alpha`, at least the seeds it had and at most `cap` (the cap when
    /// even `cap` does not reach it, which the record then shows).
    pub fn with_power(self, sigma: f64, cap: usize, alpha: f64) -> AcceptedTarget {
        let needed = seeds_for_power(sigma, self.band, alpha, cap);
        let seeds = needed.unwrap_or(cap).max(self.seeds);
        let centre = 0.5 * (self.band.0 + self.band.1);
        AcceptedTarget {
            seeds,
            sigma: Some(sigma),
            seeds_for_power: needed,
            power_at_seeds: Some(tost_power(seeds, sigma, self.band, centre, alpha)),
            ..self
        }
    }
}

/// The acceptance record, written before the first verification run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// The rule in words ([`RULE`]).
    pub rule: String,
    /// Chance of any wrong pass the record's comparisons keep ([`ALPHA`]).
    pub family_alpha: f64,
    /// Candidates judged (K of the module docs).
    pub comparisons: usize,
    /// Level of each one-sided test of each comparison, α/K.
    pub alpha: f64,
    /// Every target judged.
    pub targets: Vec<AcceptedTarget>,
}

impl Record {
    /// The record of `targets` for `comparisons` candidates (≥ 1).
    pub fn new(comparisons: usize, targets: Vec<AcceptedTarget>) -> Record {
        Record {
            rule: RULE.to_string(),
            family_alpha: ALPHA,
            comparisons: comparisons.max(1),
            alpha: comparison_alpha(comparisons),
            targets,
        }
    }

    /// The rule at the record's α on `values` measured for `target` (an
    /// index into [`Record::targets`]).
    pub fn judge(&self, target: usize, values: &[f64]) -> Judgement {
        judge_at(values, self.targets[target].band, self.alpha)
    }

    /// The record in words, as a Markdown paragraph for the head of a
    /// verification table: the rule, α, each target's seeds and each power
    /// calculation.
    pub fn describe(&self) -> String {
        let seeds: Vec<String> = self
            .targets
            .iter()
            .map(|t| format!("{} {}", t.name, t.seeds))
            .collect();
        let mut out = format!(
            "Acceptance rule (recorded before the runs): {}. {} candidate(s) judged, so alpha = \
             {:.4} per one-sided test. Packing seeds per candidate: {}.\n",
            self.rule,
            self.comparisons,
            self.alpha,
            seeds.join(", ")
        );
        for t in &self.targets {
            if let (Some(sigma), Some(power)) = (t.sigma, t.power_at_seeds) {
                out.push_str(&format!(
                    "\n{} at σ = {sigma:.2} (noise floor): power {power:.2} with {} seeds at the \
                     band's centre; {}.\n",
                    t.name,
                    t.seeds,
                    t.seeds_for_power.map_or_else(
                        || format!("more than {} seeds would reach {TARGET_POWER}", t.seeds),
                        |n| format!("{n} seeds reach {TARGET_POWER}")
                    )
                ));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BAND: (f64, f64) = (45.41, 50.19);

    /// The three tables of `stats::equivalence`'s statsmodels test, one per
    /// verdict (TOST p 5.7e-6; 95 % interval 53.68 ± 0.82; TOST p 0.20 with
    /// 48.475 ± 5.63 and 14 seeds to decide).
    #[test]
    fn one_table_per_verdict() {
        let pass = judge(&[47.1, 48.3, 47.9, 48.6, 47.5, 48.0, 48.8, 47.7], BAND);
        assert_eq!(pass.verdict, Verdict::Pass);
        assert_eq!(pass.seeds_to_decide, None);
        let fail = judge(&[53.2, 54.1, 52.8, 53.9, 54.4], BAND);
        assert_eq!(fail.verdict, Verdict::Fail);
        let open = judge(&[44.0, 52.5, 47.9, 49.5], BAND);
        assert_eq!(open.verdict, Verdict::Inconclusive);
        assert_eq!(open.seeds_to_decide, Some(14));
        assert_eq!(open.further_seeds(), Some(10));
    }

    /// The issue's own example: a mean in the band whose interval is wider
    /// than the band is not a pass.
    #[test]
    fn a_mean_in_the_band_is_not_enough() {
        let j = judge(&[41.0, 55.0, 48.0, 50.0], BAND);
        assert!(j.mean.unwrap() > BAND.0 && j.mean.unwrap() < BAND.1);
        assert_eq!(j.verdict, Verdict::Inconclusive);
    }

    #[test]
    fn fewer_than_two_seeds_cannot_decide() {
        let one = judge(&[48.0], BAND);
        assert_eq!(one.verdict, Verdict::Inconclusive);
        assert_eq!(one.mean, Some(48.0));
        assert_eq!(one.seeds_to_decide, None);
        assert_eq!(judge(&[], BAND).mean, None);
    }

    #[test]
    fn seeds_for_power_caps() {
        assert_eq!(seeds_for_power(2.0, BAND, ALPHA, 20), Some(8));
        assert_eq!(seeds_for_power(4.1, BAND, ALPHA, 20), None);
    }

    /// Bonferroni keeps the family's error: K = 5 candidates whose true
    /// mean sits on the band's lower edge (the null hypothesis at its most
    /// likely to pass), 8 normal seeds each at σ = 2 (at the funnel's 4.1
    /// the band is too narrow for 8 seeds to pass anything); the fraction of
    /// 4000 trials in which any candidate passes stays within 3 standard
    /// errors of ≤ 0.05 at α/K, and is about 1 − 0.95⁵ ≈ 0.23 unadjusted.
    #[test]
    fn bonferroni_keeps_the_chance_of_any_wrong_pass() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(39);
        let mut normal = || {
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        let (k, trials, sigma) = (5, 4000, 2.0);
        let (mut adjusted, mut unadjusted) = (0usize, 0usize);
        for _ in 0..trials {
            let (mut any_adjusted, mut any_unadjusted) = (false, false);
            for _ in 0..k {
                let values: Vec<f64> = (0..8).map(|_| BAND.0 + sigma * normal()).collect();
                any_adjusted |=
                    judge_at(&values, BAND, comparison_alpha(k)).verdict == Verdict::Pass;
                any_unadjusted |= judge(&values, BAND).verdict == Verdict::Pass;
            }
            adjusted += usize::from(any_adjusted);
            unadjusted += usize::from(any_unadjusted);
        }
        let rate = |c: usize| c as f64 / trials as f64;
        let se = (ALPHA * (1.0 - ALPHA) / trials as f64).sqrt();
        assert!(rate(adjusted) <= ALPHA + 3.0 * se, "{}", rate(adjusted));
        assert!(rate(unadjusted) > 0.18, "{}", rate(unadjusted));
    }

    /// A record of K comparisons judges at α/K: a table that passes one
    /// comparison is inconclusive among four (TOST p 0.0251: statsmodels
    /// `DescrStatsW(np.array(values)).ttost_mean(45.41, 50.19)[0]`).
    #[test]
    fn a_record_judges_at_its_comparisons_alpha() {
        let target = || AcceptedTarget::new("funnel", "angle", 47.8, 0.05, 5);
        let values = [47.0, 50.9, 48.1, 45.4, 49.8, 47.5];
        let one = Record::new(1, vec![target()]);
        let four = Record::new(4, vec![target()]);
        assert_eq!(four.alpha, 0.0125);
        assert_eq!(one.judge(0, &values).verdict, Verdict::Pass);
        assert_eq!(four.judge(0, &values).verdict, Verdict::Inconclusive);
    }

    /// The power calculation picks the seeds between the minimum and the
    /// cap, and the cap when the power is out of reach.
    #[test]
    fn seeds_are_chosen_by_power_within_their_bounds() {
        let t = || AcceptedTarget::new("funnel", "angle", 47.8, 0.05, 5);
        let powered = t().with_power(2.0, 40, ALPHA);
        assert_eq!((powered.seeds, powered.seeds_for_power), (8, Some(8)));
        assert!(powered.power_at_seeds.unwrap() >= TARGET_POWER);
        let small = t().with_power(0.5, 40, ALPHA);
        assert_eq!(small.seeds, 5, "never fewer than the minimum");
        let capped = t().with_power(4.1, 12, ALPHA);
        assert_eq!((capped.seeds, capped.seeds_for_power), (12, None));
        assert!(capped.power_at_seeds.unwrap() < TARGET_POWER);
    }
}
