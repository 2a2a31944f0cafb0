//! A two-level (multi-fidelity) Gaussian process: many cheap coarse runs
//! and a few expensive fine ones, predicting the fine level.
//!
//! # Model
//!
//! The autoregressive model of Kennedy & O'Hagan (2000), in the recursive
//! form of Le Gratiet & Garnier (2014):
//!
//! y_fine(x) = ρ · μ_coarse(x) + β + δ(x) + ε,  δ ~ GP(0, k_δ),
//!
//! - **Coarse level.** A [`GaussianProcess`] fitted to the coarse outputs
//!   with their known noise variances; μ_coarse and s_coarse are its
//!   predictive mean and latent sd.
//! - **Fine level.** The fine outputs are regressed on f(x) = (μ_coarse(x),
//!   1): ρ scales the coarse response, β shifts it, and the discrepancy δ is
//!   a GP (Matérn 5/2, one length scale per input, as the coarse level) with
//!   the fine points' known noise variances and its own nugget. Given δ's
//!   hyperparameters, (ρ, β) is the generalised least-squares estimate
//!   (FᵀK⁻¹F)⁻¹FᵀK⁻¹y with F the rows f(xᵢ) at the fine points and K δ's
//!   covariance of the fine observations; its covariance (FᵀK⁻¹F)⁻¹ gives
//!   ρ's and β's standard errors.
//! - **Designs.** The fine points need not be coarse points: the fine level
//!   reads the coarse level's predictive mean at them, which at a coarse
//!   point of a nearly noise-free coarse level is its output (the nested
//!   design of Le Gratiet, the case the equations are exact for; elsewhere
//!   the coarse level's own uncertainty at the fine points is not carried
//!   into ρ).
//!
//! # Prediction
//!
//! At x, with r = y − Fb̂ the fine residuals, k = k_δ(x, X_fine) and
//! u = f(x) − FᵀK⁻¹k:
//!
//! - mean: ρ μ_coarse(x) + β + kᵀK⁻¹r;
//! - latent variance: ρ² s²_coarse(x) + σ_δ² − kᵀK⁻¹k + uᵀ(FᵀK⁻¹F)⁻¹u,
//!   the last term the universal-kriging share of estimating ρ and β.
//!
//! # Fitting δ's hyperparameters
//!
//! [`TwoLevelGp::fit`] maximises δ's likelihood profiled over (ρ, β)
//! ([`GaussianProcess::fit_trend`]: at every trial of δ's hyperparameters,
//! ρ and β are their GLS estimates under that K), with the coarse level's
//! bounds, starts and optimiser, as SMT's `MFK` does with its
//! concentrated likelihood; alternating GP fits with GLS updates of ρ
//! settles at a different fixed point (docs/performance.md,
//! src/stats/gp_two_level.rs). Every step is deterministic, so a fit is bit-identical
//! across runs.

use nalgebra::{DVector, Matrix2, Vector2};
use serde::{Deserialize, Serialize};

use super::gp::{GaussianProcess, GpError, GpHyper, GpPrediction, GpSettings};
use super::summary::Z95;

/// One level's data: points in the unit cube, outputs and their known noise
/// variances (output units squared).
#[derive(Debug, Clone, Copy)]
pub struct LevelData<'a> {
    /// Points in [0, 1]^d.
    pub x: &'a [Vec<f64>],
    /// Outputs.
    pub y: &'a [f64],
    /// Known noise variance of each output (≥ 0).
    pub noise_var: &'a [f64],
}

/// Why a two-level process could not be built.
#[derive(Debug, thiserror::Error)]
pub enum TwoLevelError {
    /// A level's Gaussian process failed.
    #[error("{level} level: {source}")]
    Level {
        /// `coarse` or `fine`.
        level: &'static str,
        /// The process's error.
        source: GpError,
    },
    /// The regression of the fine outputs on the coarse prediction is
    /// singular (fewer than 3 fine points, or the coarse prediction is the
    /// same at every fine point).
    #[error(
        "the fine outputs cannot be regressed on the coarse prediction: {reason} \
         (the fine level needs at least 3 points where the coarse response differs)"
    )]
    Singular {
        /// What made it singular.
        reason: String,
    },
}

/// A fitted two-level process's coefficients, for reports.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TwoLevelFit {
    /// ρ and its standard error.
    pub rho: (f64, f64),
    /// β (δ's mean, response units) and its standard error.
    pub beta: (f64, f64),
    /// δ's prior standard deviation √σ_f² (response units).
    pub delta_sd: f64,
    /// The coarse process's prior standard deviation, for scale.
    pub coarse_sd: f64,
}

impl TwoLevelFit {
    /// One sentence: ρ and β with normal 95 % intervals, δ's prior sd
    /// beside the coarse process's.
    pub fn describe(&self) -> String {
        format!(
            "y_fine = ρ·y_coarse + δ: ρ = {:.3} ± {:.3} (95 %, normal, δ's hyperparameters as \
             fitted), β = {:.2} ± {:.2}, δ's prior sd {:.2} against the coarse process's {:.2}.",
            self.rho.0,
            Z95 * self.rho.1,
            self.beta.0,
            Z95 * self.beta.1,
            self.delta_sd,
            self.coarse_sd
        )
    }
}

/// A fitted two-level process (see the module docs).
#[derive(Debug, Clone)]
pub struct TwoLevelGp {
    coarse: GaussianProcess,
    /// δ conditioned on the fine residuals y − ρ μ_coarse, with mean β.
    delta: GaussianProcess,
    /// (ρ, β).
    coefficients: Vector2<f64>,
    /// (FᵀK⁻¹F)⁻¹.
    coefficients_cov: Matrix2<f64>,
    /// The rows f(xᵢ) = (μ_coarse(xᵢ), 1) at the fine points.
    f_fine: Vec<Vector2<f64>>,
}

impl TwoLevelGp {
    /// Fits both levels (the coarse process, then ρ, β and δ alternately;
    /// module docs) with `settings` for every likelihood maximisation.
    pub fn fit(
        coarse: LevelData,
        fine: LevelData,
        settings: &GpSettings,
    ) -> Result<TwoLevelGp, TwoLevelError> {
        let coarse_gp = GaussianProcess::fit(coarse.x, coarse.y, coarse.noise_var, settings)
            .map_err(|source| TwoLevelError::Level {
                level: "coarse",
                source,
            })?;
        Self::fit_on(coarse_gp, fine, settings)
    }

    /// The fine level fitted on a coarse process already fitted (a study's
    /// trained GP), with `settings` for δ's likelihood maximisation.
    pub fn fit_on(
        coarse_gp: GaussianProcess,
        fine: LevelData,
        settings: &GpSettings,
    ) -> Result<TwoLevelGp, TwoLevelError> {
        let f_fine = regressors(&coarse_gp, fine.x);
        let rows: Vec<Vec<f64>> = f_fine.iter().map(|f| vec![f.x, f.y]).collect();
        // The regression must be identifiable before δ is fitted around it.
        check_regressors(&f_fine)?;
        let hyper = GaussianProcess::fit_trend(fine.x, fine.y, fine.noise_var, &rows, settings)
            .map_err(|source| TwoLevelError::Level {
                level: "fine",
                source,
            })?;
        Self::condition(coarse_gp, fine, hyper, f_fine)
    }

    /// Both levels with the hyperparameters given: `coarse_hyper` for the
    /// coarse process (its mean used as given) and `delta_hyper` for δ (its
    /// mean ignored: β is estimated with ρ by GLS). For tests and for
    /// refitting new data with earlier hyperparameters.
    pub fn with_hyper(
        coarse: LevelData,
        coarse_hyper: &GpHyper,
        fine: LevelData,
        delta_hyper: &GpHyper,
    ) -> Result<TwoLevelGp, TwoLevelError> {
        let coarse_gp =
            GaussianProcess::with_hyper(coarse.x, coarse.y, coarse.noise_var, coarse_hyper)
                .map_err(|source| TwoLevelError::Level {
                    level: "coarse",
                    source,
                })?;
        Self::with_delta(coarse_gp, fine, delta_hyper)
    }

    /// The fine level on a coarse process already fitted, with δ's
    /// hyperparameters given (its mean ignored): how a stage rebuilds the
    /// model another stage fitted.
    pub fn with_delta(
        coarse_gp: GaussianProcess,
        fine: LevelData,
        delta_hyper: &GpHyper,
    ) -> Result<TwoLevelGp, TwoLevelError> {
        let f_fine = regressors(&coarse_gp, fine.x);
        Self::condition(coarse_gp, fine, delta_hyper.clone(), f_fine)
    }

    /// Estimates ρ, β by GLS under δ's `hyper` and conditions δ on the fine
    /// residuals.
    fn condition(
        coarse: GaussianProcess,
        fine: LevelData,
        hyper: GpHyper,
        f_fine: Vec<Vector2<f64>>,
    ) -> Result<TwoLevelGp, TwoLevelError> {
        let level = |source| TwoLevelError::Level {
            level: "fine",
            source,
        };
        // K does not depend on y or the mean: condition once on the outputs
        // to reach K⁻¹ for the GLS, then on the residuals with mean β.
        let probe =
            GaussianProcess::with_hyper(fine.x, fine.y, fine.noise_var, &hyper).map_err(level)?;
        let (coefficients, coefficients_cov) = generalised_least_squares(&probe, &f_fine, fine.y)?;
        let residual = residuals(&f_fine, fine.y, &Vector2::new(coefficients.x, 0.0));
        let delta = GaussianProcess::with_hyper(
            fine.x,
            &residual,
            fine.noise_var,
            &GpHyper {
                mean: coefficients.y,
                ..hyper
            },
        )
        .map_err(level)?;
        Ok(TwoLevelGp {
            coarse,
            delta,
            coefficients,
            coefficients_cov,
            f_fine,
        })
    }

    /// The fine level's predictive mean and latent sd at `x` (module docs).
    pub fn predict(&self, x: &[f64]) -> GpPrediction {
        let c = self.coarse.predict(x);
        let d = self.delta.predict(x);
        let rho = self.coefficients.x;
        let f = Vector2::new(c.mean, 1.0);
        let k = self.delta.covariances(x);
        let kinv_k = self.delta.solve(&k);
        let ft_kinv_k = self
            .f_fine
            .iter()
            .zip(kinv_k.iter())
            .fold(Vector2::zeros(), |acc, (fi, w)| acc + fi * *w);
        let u = f - ft_kinv_k;
        let estimation = (u.transpose() * self.coefficients_cov * u).x.max(0.0);
        GpPrediction {
            mean: rho * c.mean + d.mean,
            sd: (rho * rho * c.sd * c.sd + d.sd * d.sd + estimation).sqrt(),
        }
    }

    /// The coarse level's prediction at `x`.
    pub fn predict_coarse(&self, x: &[f64]) -> GpPrediction {
        self.coarse.predict(x)
    }

    /// ρ, the scale of the coarse response in the fine one.
    pub fn rho(&self) -> f64 {
        self.coefficients.x
    }

    /// β, the constant part of the discrepancy (output units).
    pub fn beta(&self) -> f64 {
        self.coefficients.y
    }

    /// Standard errors of ρ and β (GLS, δ's hyperparameters taken as known).
    pub fn standard_errors(&self) -> (f64, f64) {
        (
            self.coefficients_cov[(0, 0)].max(0.0).sqrt(),
            self.coefficients_cov[(1, 1)].max(0.0).sqrt(),
        )
    }

    /// ρ, β with their standard errors and both levels' prior sd.
    pub fn summary(&self) -> TwoLevelFit {
        let (se_rho, se_beta) = self.standard_errors();
        let (coarse, delta) = self.hyper();
        TwoLevelFit {
            rho: (self.rho(), se_rho),
            beta: (self.beta(), se_beta),
            delta_sd: delta.signal_var.sqrt(),
            coarse_sd: coarse.signal_var.sqrt(),
        }
    }

    /// The hyperparameters of the coarse process and of δ (δ's mean is β).
    pub fn hyper(&self) -> (&GpHyper, &GpHyper) {
        (self.coarse.hyper(), self.delta.hyper())
    }
}

/// The rows f(x) = (μ_coarse(x), 1) at `x`.
fn regressors(coarse: &GaussianProcess, x: &[Vec<f64>]) -> Vec<Vector2<f64>> {
    x.iter()
        .map(|xi| Vector2::new(coarse.predict(xi).mean, 1.0))
        .collect()
}

/// y − F b.
fn residuals(f: &[Vector2<f64>], y: &[f64], b: &Vector2<f64>) -> Vec<f64> {
    f.iter().zip(y).map(|(fi, yi)| yi - fi.dot(b)).collect()
}

/// Refuses a regression on `f` that cannot be estimated (fewer than 3
/// fine points, or the coarse prediction the same at all of them).
fn check_regressors(f: &[Vector2<f64>]) -> Result<(), TwoLevelError> {
    let a = f
        .iter()
        .fold(Matrix2::zeros(), |a, fi| a + fi * fi.transpose());
    solve_normal(f.len(), a, Vector2::zeros()).map(|_| ())
}

/// (ρ, β) = (FᵀK⁻¹F)⁻¹FᵀK⁻¹y under the covariance K of `gp`'s
/// observations, with (FᵀK⁻¹F)⁻¹.
fn generalised_least_squares(
    gp: &GaussianProcess,
    f: &[Vector2<f64>],
    y: &[f64],
) -> Result<(Vector2<f64>, Matrix2<f64>), TwoLevelError> {
    let column = |j: usize| DVector::from_iterator(f.len(), f.iter().map(|fi| fi[j]));
    let kinv_f = [gp.solve(&column(0)), gp.solve(&column(1))];
    let y = DVector::from_column_slice(y);
    let a = Matrix2::from_fn(|i, j| column(i).dot(&kinv_f[j]));
    let rhs = Vector2::new(kinv_f[0].dot(&y), kinv_f[1].dot(&y));
    solve_normal(f.len(), a, rhs)
}

/// Solves the 2 × 2 normal equations a b = rhs of `n` fine points; with a⁻¹.
fn solve_normal(
    n: usize,
    a: Matrix2<f64>,
    rhs: Vector2<f64>,
) -> Result<(Vector2<f64>, Matrix2<f64>), TwoLevelError> {
    if n < 3 {
        return Err(TwoLevelError::Singular {
            reason: format!("{n} fine point(s)"),
        });
    }
    let scale = a.abs().max().max(f64::MIN_POSITIVE);
    let inverse = (a.determinant().abs() > 1e-12 * scale * scale)
        .then(|| a.try_inverse())
        .flatten()
        .ok_or_else(|| TwoLevelError::Singular {
            reason: "the coarse prediction is (nearly) the same at every fine point".into(),
        })?;
    Ok((inverse * rhs, inverse))
}

/// The surrogate a calibration's search and verification answer to: the
/// fine level of a two-level process, or a one-level GP.
#[derive(Debug, Clone)]
pub enum Predictor {
    /// A two-level study's fine level.
    TwoLevel(Box<TwoLevelGp>),
    /// A one-level study's GP.
    OneLevel(GaussianProcess),
}

impl Predictor {
    /// The predictive mean and latent sd at `x` in the unit cube (the
    /// response's units).
    pub fn predict(&self, x: &[f64]) -> GpPrediction {
        match self {
            Predictor::TwoLevel(m) => m.predict(x),
            Predictor::OneLevel(gp) => gp.predict(x),
        }
    }

    /// Whether it is a two-level process's fine level.
    pub fn is_two_level(&self) -> bool {
        matches!(self, Predictor::TwoLevel(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_2d() -> (Vec<Vec<f64>>, Vec<f64>, Vec<f64>) {
        let x: Vec<Vec<f64>> = [
            [0.05, 0.1],
            [0.2, 0.8],
            [0.35, 0.4],
            [0.5, 0.95],
            [0.6, 0.2],
            [0.75, 0.6],
            [0.9, 0.3],
            [0.98, 0.9],
        ]
        .iter()
        .map(|p| p.to_vec())
        .collect();
        let y = x.iter().map(|p| (6.0 * p[0]).sin() + p[1]).collect();
        (x, y, vec![0.01; 8])
    }

    #[test]
    fn fixed_hyperparameters_match_the_closed_form() {
        // Expected values: tests/data/two_level_gp_reference.py (numpy
        // 2.4.6, `python3 tests/data/two_level_gp_reference.py`): simple
        // kriging of the coarse level, universal kriging of the fine level
        // on (μ_coarse, 1), the same data and hyperparameters as here.
        let (xc, yc, nc) = unit_2d();
        let fine_rows = [1, 3, 4, 6];
        let xf: Vec<Vec<f64>> = fine_rows.iter().map(|&i| xc[i].clone()).collect();
        let yf: Vec<f64> = xf
            .iter()
            .map(|p| 1.8 * ((6.0 * p[0]).sin() + p[1]) + 0.5 + 0.3 * p[0])
            .collect();
        let nf = [0.02, 0.03, 0.02, 0.04];
        let coarse_hyper = GpHyper {
            signal_var: 1.2,
            length_scales: vec![0.3, 0.6],
            nugget_var: 1e-6,
            mean: 0.4,
        };
        let delta_hyper = GpHyper {
            signal_var: 0.5,
            length_scales: vec![0.4, 0.8],
            nugget_var: 1e-5,
            mean: 0.0,
        };
        let gp = TwoLevelGp::with_hyper(
            LevelData {
                x: &xc,
                y: &yc,
                noise_var: &nc,
            },
            &coarse_hyper,
            LevelData {
                x: &xf,
                y: &yf,
                noise_var: &nf,
            },
            &delta_hyper,
        )
        .unwrap();
        let close = |got: f64, want: f64| (got - want).abs() <= 1e-9 * (1.0 + want.abs());
        assert!(close(gp.rho(), 1.7418750872149196), "{}", gp.rho());
        assert!(close(gp.beta(), 0.7012992829619108), "{}", gp.beta());
        let (se_rho, se_beta) = gp.standard_errors();
        assert!(close(se_rho, 0.3871854150830342), "{se_rho}");
        assert!(close(se_beta, 0.5909493608464088), "{se_beta}");
        for (p, mean, sd) in [
            ([0.1, 0.5], 2.748614151422971, 0.9204780217772854),
            ([0.5, 0.5], 1.7982302160018944, 0.6971009312477432),
            ([0.8, 0.7], 0.3973131337912175, 0.5397293885283329),
        ] {
            let got = gp.predict(&p);
            assert!(close(got.mean, mean), "{p:?}: mean {} vs {mean}", got.mean);
            assert!(close(got.sd, sd), "{p:?}: sd {} vs {sd}", got.sd);
        }
    }

    #[test]
    fn a_known_scale_and_shift_are_recovered_within_their_intervals() {
        // Coarse: 20 points of f(x) = sin(2πx) + x; fine: 1.5 f(x) + 0.7 at 8
        // of them (δ constant), small known noise on both. The fitted ρ and β
        // lie within 1.96 standard errors of 1.5 and 0.7.
        let xc: Vec<Vec<f64>> = (0..20).map(|i| vec![(i as f64 + 0.5) / 20.0]).collect();
        let f = |x: f64| (2.0 * std::f64::consts::PI * x).sin() + x;
        let yc: Vec<f64> = xc.iter().map(|p| f(p[0])).collect();
        let xf: Vec<Vec<f64>> = (0..8).map(|k| xc[1 + 5 * k / 2].clone()).collect();
        let yf: Vec<f64> = xf.iter().map(|p| 1.5 * f(p[0]) + 0.7).collect();
        let gp = TwoLevelGp::fit(
            LevelData {
                x: &xc,
                y: &yc,
                noise_var: &[1e-4; 20],
            },
            LevelData {
                x: &xf,
                y: &yf,
                noise_var: &[1e-4; 8],
            },
            &GpSettings::default(),
        )
        .unwrap();
        let (se_rho, se_beta) = gp.standard_errors();
        assert!(
            (gp.rho() - 1.5).abs() <= 1.96 * se_rho,
            "ρ {} ± {se_rho}",
            gp.rho()
        );
        assert!(
            (gp.beta() - 0.7).abs() <= 1.96 * se_beta,
            "β {} ± {se_beta}",
            gp.beta()
        );
        // And the fine level is predicted between the fine points.
        let x = 0.33;
        let p = gp.predict(&[x]);
        assert!(
            (p.mean - (1.5 * f(x) + 0.7)).abs() < 3.0 * p.sd + 1e-3,
            "{p:?}"
        );
    }

    #[test]
    fn too_few_fine_points_are_refused() {
        let (xc, yc, nc) = unit_2d();
        let err = TwoLevelGp::fit(
            LevelData {
                x: &xc,
                y: &yc,
                noise_var: &nc,
            },
            LevelData {
                x: &xc[..2],
                y: &yc[..2],
                noise_var: &nc[..2],
            },
            &GpSettings::default(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("2 fine point(s)"), "{err}");
    }
}

#[cfg(test)]
mod smt_comparison {
    use super::*;

    fn hf(x: f64) -> f64 {
        (6.0 * x - 2.0).powi(2) * (12.0 * x - 4.0).sin()
    }

    fn lf(x: f64) -> f64 {
        0.5 * hf(x) + 10.0 * (x - 0.5) - 5.0
    }

    #[test]
    fn the_forrester_pair_is_predicted_as_smt_mfk_predicts_it() {
        let xl: Vec<Vec<f64>> = (0..=10).map(|i| vec![i as f64 / 10.0]).collect();
        let yl: Vec<f64> = xl.iter().map(|p| lf(p[0])).collect();
        let xh: Vec<Vec<f64>> = [0.0, 0.4, 0.6, 1.0].iter().map(|&x| vec![x]).collect();
        let yh: Vec<f64> = xh.iter().map(|p| hf(p[0])).collect();
        let gp = TwoLevelGp::fit(
            LevelData {
                x: &xl,
                y: &yl,
                noise_var: &[0.0; 11],
            },
            LevelData {
                x: &xh,
                y: &yh,
                noise_var: &[0.0; 4],
            },
            &GpSettings {
                fit_nugget: false,
                ..GpSettings::default()
            },
        )
        .unwrap();
        // SMT 2.15.0's MFK, corr "matern52": tests/data/mfk_forrester_reference.py
        // (x, mean, sd). Tolerance: means within 0.5 % of the high-fidelity
        // range (22.3); sds within 25 % where either exceeds that mean
        // tolerance (between the coarse points: SMT 0.28–0.40). At the
        // coarse points both sds are below it (SMT 0.002–0.006, here
        // 0.006–0.05, the discrepancy's uncertainty between the 4 fine
        // points, scaled by its fitted variance, which 4 points identify
        // weakly). The two fits differ in
        // their optimisers (SMT: COBYLA on the likelihood concentrated over
        // σ², unbounded; here projected BFGS within the documented bounds)
        // and in the coarse level's constant (SMT: GLS; here the arithmetic
        // mean), which moves the hyperparameters by a few percent; measured
        // 2026-11-28: largest mean difference 0.061 (x = 0.95), where both
        // models are 0.7 from the true function.
        let smt = [
            (0.05, 0.7284242181708156, 0.3952334982712453),
            (0.1, -0.6565764113149795, 0.0025095733240653203),
            (0.2, -0.6397265387401871, 0.002142692817556601),
            (0.25, -0.21462900336777624, 0.28638227823273577),
            (0.3, -0.015576320397270305, 0.0020899711573265376),
            (0.45, 0.49727723010533165, 0.28310132828876433),
            (0.5, 0.9092982694812823, 0.002152692156623694),
            (0.7, -4.605746941931821, 0.005110504651294636),
            (0.8, -4.949121360357353, 0.006227688116219232),
            (0.85, -0.5095257721781754, 0.3022003413313337),
            (0.9, 5.711953991319542, 0.003263971920019036),
            (0.95, 11.54581537144779, 0.3952335060125482),
        ];
        let range = 22.3;
        for (x, mean, sd) in smt {
            let p = gp.predict(&[x]);
            assert!(
                (p.mean - mean).abs() <= 0.005 * range,
                "x {x}: mean {} vs SMT {mean}",
                p.mean
            );
            assert!(
                (p.sd - sd).abs() <= 0.25 * sd || p.sd.max(sd) <= 0.005 * range,
                "x {x}: sd {} vs SMT {sd}",
                p.sd
            );
        }
        // ρ: the pair is built with 2 (hf = 2 lf + a linear discrepancy).
        let (se, _) = gp.standard_errors();
        assert!((gp.rho() - 2.0).abs() <= 1.96 * se, "ρ {} ± {se}", gp.rho());
    }
}
