//! The GA-BP surrogate (he2019 §3.2–3.4): scaling, training one network
//! (genetic algorithm, then Levenberg–Marquardt), the hidden-size sweep of
//! Eq. 6 / Fig. 12, and the saved model that `search` reuses.
//!
//! Scaling: every input is mapped linearly from its range (the study's
//! parameter range, or for a bare table the training rows' min–max) onto
//! [−1, 1], and the angle from the training targets' min–max onto [−1, 1] —
//! MATLAB's `mapminmax` default, which he2019's MATLAB network would have used.
//!
//! Selection ([`Selection`]): the sweep trains one network per hidden size
//! on the training rows and keeps one of them, by one of two rules.
//!
//! - [`Selection::Validation`], he2019's rule: the highest validation R²
//!   (Eq. 7), ties going to the smaller network — as he2019 chose 7 neurons
//!   from Fig. 12. The validation rows therefore also choose the size, so the
//!   reported best validation R² is optimistic; the whole sweep is reported so
//!   that can be judged. Classic he2019 studies and `train --table` use it; it
//!   reproduces he2019's Table A1 sweep.
//! - [`Selection::CrossValidation`]: k-fold cross-validation within the
//!   training rows only. Training row j (in training order) belongs to fold
//!   j mod k — interleaved, so every fold spans the design order and a table
//!   sorted by one column still gives each fold its whole range; no random
//!   draw is needed. k is the setting's `folds`, capped at the number of
//!   training rows, so a small training set (10 rows with the default 10
//!   folds) gets leave-one-out, whose estimate has the least bias when every
//!   row is precious. For each hidden size, k networks each train on the
//!   other folds and predict the held-out one; the size's score is the pooled
//!   cross-validated MSE (every training row predicted once, by a network that
//!   never saw it; reported as its root, `cv_rmse_deg`, and as
//!   R² = 1 − PRESS / Σ(y − ȳ)², `cv_r2`). The size with the lowest score is
//!   kept, ties going to the smaller network, and its network trained on all
//!   training rows (the one the sweep reports) becomes the model. The
//!   validation rows play no part in the choice, so their R² is a genuinely
//!   held-out score. The folds use the scaling of all training rows (only the
//!   output's min–max, a linear map the linear output neuron absorbs, sees
//!   the held-out targets). Noise-aware he2019 studies use it: with a few
//!   noisy training rows, validation-R² selection kept networks with several
//!   times more weights than rows (train R² 1.000, validation R² −0.97).
//!
//! Every row of the sweep also reports the network's weights, its effective
//! degrees of freedom at the solution ([`objective`]: the trace of the
//! linearised hat matrix, at most the number of training rows), and the
//! number of training rows, so a network with more weights than rows is
//! visible ([`SweepRow::over_parameterised`]).
//!
//! Determinism: each hidden size draws from its own ChaCha stream (the seed and
//! the size; each cross-validation fold from its own stream of the seed, the
//! size and the fold), computes sequentially, and the sweep collects results
//! in size (and fold) order, so the outcome is bit-identical on any number of
//! threads.
//!
//! Refinement is Levenberg–Marquardt ([`levenberg`], as MATLAB's
//! `trainlm` that he2019 used), not Adam. he2019 gives none of the GA or LM
//! settings; the defaults here and why:
//!
//! - GA: 40 genomes, 60 generations ([`GaSettings::default`]), kept because
//!   the method prescribes it (on Table A1 it changes which local minimum LM
//!   reaches, not the best validation R²).
//! - LM: at most 200 accepted steps. The budget acts as early stopping:
//!   networks with many hidden neurons fit the training rows' noise long
//!   before trainlm's 1000-step maximum. trainlm itself stops on a validation
//!   subset it draws from the training data; the validation rows here are
//!   never used for training.
//! - No weight decay (λ = 0): on Table A1 a small decay flattens the sweep.
//!
//! Measured on Table A1 (the sweep with and without the GA, LM budgets, weight
//! decay, CPU time, seeds): docs/performance.md ("src/surrogate/ga_bp").

pub mod genetic;
pub mod levenberg;
pub mod network;
pub mod objective;

use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::stats::levenberg::LmStop;
use crate::stats::metrics::{mse, r_squared};
use crate::streams::{rng, Stream};
use crate::surrogate::{Prediction, Surrogate, SurrogateError, Table};
use genetic::{evolve, GaSettings};
use levenberg::{refine, TrainlmSettings};
use network::Shape;
use objective::Objective;

/// A linear map of one quantity from `[min, max]` onto [−1, 1].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scale {
    /// Column name (a parameter address, a table column, or `angle_deg`).
    pub name: String,
    /// Value mapped to −1.
    pub min: f64,
    /// Value mapped to +1 (> min).
    pub max: f64,
}

impl Scale {
    /// `value` in scaled units.
    pub fn to_unit(&self, value: f64) -> f64 {
        2.0 * (value - self.min) / (self.max - self.min) - 1.0
    }

    /// A scaled value back in physical units.
    pub fn from_unit(&self, scaled: f64) -> f64 {
        self.min + (scaled + 1.0) / 2.0 * (self.max - self.min)
    }
}

/// Training data: physical inputs and targets with a train/validation split.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Input ranges (their names and the scaling of each input column).
    pub inputs: Vec<Scale>,
    /// Name of the target column.
    pub target: String,
    /// Physical inputs, one row per sample, in the order of `inputs`.
    pub rows: Vec<Vec<f64>>,
    /// Physical targets (angles, degrees), one per row.
    pub targets: Vec<f64>,
    /// Rows used for training.
    pub train: Vec<usize>,
    /// Rows used for validation (and for choosing the hidden size).
    pub validation: Vec<usize>,
}

/// How the sweep chooses the hidden size (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Selection {
    /// The highest validation R² (he2019's rule, Fig. 12).
    #[default]
    Validation,
    /// The lowest k-fold cross-validated MSE within the training rows.
    CrossValidation {
        /// Folds k (≥ 2), capped at the number of training rows
        /// (leave-one-out).
        folds: usize,
    },
}

/// Folds of [`Selection::CrossValidation`] by default: 10, which is
/// leave-one-out for the 10 or fewer training rows of a small noise-aware
/// design and ordinary 10-fold cross-validation for he2019's 80.
pub const DEFAULT_FOLDS: usize = 10;

/// Largest hidden size and largest fold count: each fold's stream index packs
/// both into 16 bits (see [`crate::streams::rng`]).
const MAX_STREAM_PART: usize = 0xffff;

/// Settings of the sweep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainSettings {
    /// Smallest hidden size tried (he2019 Eq. 6: 3).
    pub hidden_min: usize,
    /// Largest hidden size tried (he2019 Eq. 6: 12).
    pub hidden_max: usize,
    /// Seed of the genetic algorithm's streams.
    pub seed: u64,
    /// Ridge penalty λ on weights and thresholds (see [`Objective`]).
    pub weight_decay: f64,
    /// How the kept hidden size is chosen.
    pub selection: Selection,
    /// Genetic algorithm.
    pub ga: GaSettings,
    /// Levenberg–Marquardt.
    pub lm: TrainlmSettings,
}

impl TrainSettings {
    /// The defaults with a given seed: hidden sizes 3–12, no weight decay,
    /// he2019's validation selection, [`GaSettings::default`] and
    /// [`TrainlmSettings::default`].
    pub fn with_seed(seed: u64) -> TrainSettings {
        TrainSettings {
            hidden_min: 3,
            hidden_max: 12,
            seed,
            weight_decay: 0.0,
            selection: Selection::Validation,
            ga: GaSettings::default(),
            lm: TrainlmSettings::default(),
        }
    }

    /// What is wrong with these settings, if anything.
    pub fn check(&self) -> Result<(), String> {
        if self.hidden_min < 1 || self.hidden_min > self.hidden_max {
            return Err(format!(
                "hidden sizes {}..={}: need 1 <= min <= max",
                self.hidden_min, self.hidden_max
            ));
        }
        if self.hidden_max > MAX_STREAM_PART {
            return Err(format!(
                "hidden_max = {}: must be <= {MAX_STREAM_PART}",
                self.hidden_max
            ));
        }
        if let Selection::CrossValidation { folds } = self.selection {
            if !(2..=MAX_STREAM_PART).contains(&folds) {
                return Err(format!(
                    "cross-validation folds = {folds}: must be in 2..={MAX_STREAM_PART}"
                ));
            }
        }
        if !(self.weight_decay.is_finite() && self.weight_decay >= 0.0) {
            return Err(format!(
                "weight_decay = {}: must be a finite number >= 0",
                self.weight_decay
            ));
        }
        self.ga.check()
    }
}

/// A trained network with its scaling: predicts angles from physical inputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Model {
    /// Always `ga_bp_network`.
    pub kind: String,
    /// Input scalings, in input order.
    pub inputs: Vec<Scale>,
    /// Output scaling (training targets' min–max), degrees.
    pub output: Scale,
    /// Hidden neurons.
    pub hidden: usize,
    /// Hidden activation (always `logistic`).
    pub activation: String,
    /// Weights and thresholds, laid out as in [`network`].
    pub parameters: Vec<f64>,
}

impl Model {
    /// The network shape.
    pub fn shape(&self) -> Shape {
        Shape {
            inputs: self.inputs.len(),
            hidden: self.hidden,
        }
    }

    /// Predicted angle (degrees) at physical inputs `x` (in input order).
    pub fn predict(&self, x: &[f64]) -> f64 {
        let scaled: Vec<f64> = self
            .inputs
            .iter()
            .zip(x)
            .map(|(s, v)| s.to_unit(*v))
            .collect();
        self.output
            .from_unit(self.shape().forward(&self.parameters, &scaled))
    }

    /// What is wrong with a loaded model, if anything.
    pub fn check(&self) -> Result<(), String> {
        if self.kind != MODEL_KIND || self.activation != "logistic" {
            return Err(format!(
                "kind `{}` / activation `{}`: expected `{MODEL_KIND}` / `logistic`",
                self.kind, self.activation
            ));
        }
        if self.parameters.len() != self.shape().parameter_count() {
            return Err(format!(
                "{} parameters for {} inputs and {} hidden neurons (expected {})",
                self.parameters.len(),
                self.inputs.len(),
                self.hidden,
                self.shape().parameter_count()
            ));
        }
        let scales = self.inputs.iter().chain(std::iter::once(&self.output));
        for s in scales {
            if !(s.min.is_finite() && s.max.is_finite() && s.min < s.max) {
                return Err(format!(
                    "scale of `{}`: [{}, {}] is not a finite range with min < max",
                    s.name, s.min, s.max
                ));
            }
        }
        Ok(())
    }
}

/// The `kind` of a saved [`Model`].
pub const MODEL_KIND: &str = "ga_bp_network";

/// he2019's split: 80 of 120 samples train, the rest validate (and choose
/// the hidden size).
pub const DEFAULT_TRAIN_FRACTION: f64 = 2.0 / 3.0;

/// The row index where validation starts for `rows` rows split at
/// `train_fraction` (rounded to the nearest row).
pub fn split_at(rows: usize, train_fraction: f64) -> usize {
    (rows as f64 * train_fraction).round() as usize
}

/// Settings of the network as a [`Surrogate`]: the sweep's settings and the
/// fraction of the table's rows (the first ones) that train; the rest
/// validate and choose the hidden size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaBpSettings {
    /// The hidden-size sweep, GA and LM.
    pub train: TrainSettings,
    /// Fraction of the rows, in table order, that train (0 < f < 1).
    pub train_fraction: f64,
}

impl Default for GaBpSettings {
    /// [`TrainSettings::with_seed`] 0 and he2019's two-thirds split.
    fn default() -> Self {
        GaBpSettings {
            train: TrainSettings::with_seed(0),
            train_fraction: DEFAULT_TRAIN_FRACTION,
        }
    }
}

impl Surrogate for Model {
    type Settings = GaBpSettings;
    const KIND: &'static str = MODEL_KIND;

    /// The sweep's kept network; the response's column is named `response`.
    fn fit(table: &Table, settings: &GaBpSettings) -> Result<Self, SurrogateError> {
        table.check()?;
        let n = table.y.len();
        let cut = split_at(n, settings.train_fraction);
        let data = Dataset {
            inputs: table
                .names
                .iter()
                .zip(table.ranges)
                .map(|(name, (min, max))| Scale {
                    name: name.clone(),
                    min: *min,
                    max: *max,
                })
                .collect(),
            target: "response".to_string(),
            rows: table.x.to_vec(),
            targets: table.y.to_vec(),
            train: (0..cut).collect(),
            validation: (cut..n).collect(),
        };
        sweep(&data, &settings.train)
            .map(|s| s.model)
            .map_err(|e| SurrogateError::Fit {
                kind: MODEL_KIND,
                message: e.to_string(),
            })
    }

    fn predict(&self, x: &[f64]) -> Prediction {
        Prediction {
            mean: Model::predict(self, x),
            sd: None,
        }
    }

    fn parameter_count(&self) -> usize {
        self.parameters.len()
    }
}

/// One row of the hidden-size sweep (the Fig. 12 table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepRow {
    /// Hidden neurons.
    pub hidden: usize,
    /// R² (Eq. 7) on the training rows.
    pub train_r2: f64,
    /// R² (Eq. 7) on the validation rows.
    pub validation_r2: f64,
    /// Root mean squared error on the training rows, degrees.
    pub train_rmse_deg: f64,
    /// Root mean squared error on the validation rows, degrees.
    pub validation_rmse_deg: f64,
    /// Best GA objective (scaled units) before refinement.
    pub ga_objective: f64,
    /// Objective after Levenberg–Marquardt.
    pub lm_objective: f64,
    /// Accepted LM steps.
    pub lm_epochs: usize,
    /// Why LM stopped.
    pub lm_stop: LmStop,
    /// Weights and thresholds of the network (its free parameters).
    pub parameters: usize,
    /// Effective degrees of freedom of the network trained on all training
    /// rows, at its solution ([`objective`]); at most `train_rows`.
    pub effective_dof: f64,
    /// Training rows the network was fitted to.
    pub train_rows: usize,
    /// Root of the pooled cross-validated MSE on the training rows, degrees
    /// ([`Selection::CrossValidation`] only).
    pub cv_rmse_deg: Option<f64>,
    /// 1 − PRESS / Σ(y − ȳ)² of the cross-validated predictions of the
    /// training rows ([`Selection::CrossValidation`] only).
    pub cv_r2: Option<f64>,
}

impl SweepRow {
    /// More weights than training rows: the network can interpolate the
    /// training rows, so its training R² says nothing about its predictions.
    pub fn over_parameterised(&self) -> bool {
        self.parameters > self.train_rows
    }
}

/// The whole sweep and the network it keeps.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// The rule that chose `best`.
    pub selection: Selection,
    /// One row per hidden size, ascending.
    pub rows: Vec<SweepRow>,
    /// Index into `rows` of the kept network.
    pub best: usize,
    /// The kept network.
    pub model: Model,
}

/// Why training could not start.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The settings are invalid.
    #[error("training settings: {0}")]
    Settings(String),
    /// Too few rows, or degenerate targets.
    #[error("training data: {0}")]
    Data(String),
}

/// Trains one network per hidden size on the training rows (and, for
/// [`Selection::CrossValidation`], one per size and fold) and keeps one by
/// the settings' selection rule (module docs).
pub fn sweep(data: &Dataset, settings: &TrainSettings) -> Result<Sweep, TrainError> {
    settings.check().map_err(TrainError::Settings)?;
    let prepared = Prepared::new(data)?;
    let sizes: Vec<usize> = (settings.hidden_min..=settings.hidden_max).collect();
    let folds = match settings.selection {
        Selection::Validation => 0,
        Selection::CrossValidation { folds } => folds.min(prepared.train_t.len()),
    };
    // Every network of the sweep is one job: (size, None) on all training
    // rows, (size, Some(fold)) without one fold.
    let jobs: Vec<(usize, Option<usize>)> = sizes
        .iter()
        .flat_map(|&h| std::iter::once((h, None)).chain((0..folds).map(move |f| (h, Some(f)))))
        .collect();
    let fits: Vec<Fit> = jobs
        .par_iter()
        .map(|&(h, fold)| match fold {
            None => prepared.fit(h, None, settings),
            Some(f) => prepared.fit(h, Some((f, folds)), settings),
        })
        .collect();
    let mut fits = fits.into_iter();
    let mut trained: Vec<(SweepRow, Vec<f64>)> = Vec::with_capacity(sizes.len());
    for &h in &sizes {
        let full = fits.next().expect("one fit on all training rows per size");
        let mut row = prepared.row(h, &full, settings.weight_decay);
        if folds > 0 {
            let mut predicted = vec![0.0; prepared.train_t.len()];
            for _ in 0..folds {
                let fit = fits.next().expect("one fit per fold");
                for (j, p) in fit.held_out {
                    predicted[j] = p;
                }
            }
            let y: Vec<f64> = data.train.iter().map(|&i| data.targets[i]).collect();
            row.cv_rmse_deg = Some(mse(&y, &predicted).sqrt());
            row.cv_r2 = Some(r_squared(&y, &predicted).unwrap_or(f64::NEG_INFINITY));
        }
        trained.push((row, full.theta));
    }
    let better = |a: &SweepRow, b: &SweepRow| match settings.selection {
        Selection::Validation => a.validation_r2 > b.validation_r2,
        // A non-finite score (a diverged fold) never wins.
        Selection::CrossValidation { .. } => {
            let score = |r: &SweepRow| r.cv_rmse_deg.filter(|v| v.is_finite());
            match (score(a), score(b)) {
                (Some(x), Some(y)) => x < y,
                (Some(_), None) => true,
                _ => false,
            }
        }
    };
    let mut best = 0;
    for i in 1..trained.len() {
        if better(&trained[i].0, &trained[best].0) {
            best = i;
        }
    }
    let model = prepared.model(trained[best].0.hidden, trained[best].1.clone());
    Ok(Sweep {
        selection: settings.selection,
        rows: trained.into_iter().map(|(row, _)| row).collect(),
        best,
        model,
    })
}

/// A dataset in scaled units, split.
struct Prepared<'a> {
    data: &'a Dataset,
    output: Scale,
    train_x: Vec<Vec<f64>>,
    train_t: Vec<f64>,
}

/// One trained network of the sweep.
struct Fit {
    /// Weights and thresholds after Levenberg–Marquardt.
    theta: Vec<f64>,
    /// Best GA objective (scaled units).
    ga_objective: f64,
    /// Mean objective after LM.
    lm_objective: f64,
    /// Accepted LM steps.
    lm_epochs: usize,
    /// Why LM stopped.
    lm_stop: LmStop,
    /// For a fold's network: (position among the training rows, predicted
    /// angle in degrees) of every held-out row.
    held_out: Vec<(usize, f64)>,
}

impl<'a> Prepared<'a> {
    fn new(data: &'a Dataset) -> Result<Prepared<'a>, TrainError> {
        if data.train.len() < 2 || data.validation.len() < 2 {
            return Err(TrainError::Data(format!(
                "{} training and {} validation rows: need at least 2 of each",
                data.train.len(),
                data.validation.len()
            )));
        }
        let targets: Vec<f64> = data.train.iter().map(|&i| data.targets[i]).collect();
        let lo = targets.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = targets.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if lo >= hi {
            return Err(TrainError::Data(format!(
                "every training angle equals {lo}: nothing to learn"
            )));
        }
        let output = Scale {
            name: data.target.clone(),
            min: lo,
            max: hi,
        };
        let train_x = data.train.iter().map(|&i| scale_row(data, i)).collect();
        let train_t = targets.iter().map(|t| output.to_unit(*t)).collect();
        Ok(Prepared {
            data,
            output,
            train_x,
            train_t,
        })
    }

    fn model(&self, hidden: usize, parameters: Vec<f64>) -> Model {
        Model {
            kind: MODEL_KIND.to_string(),
            inputs: self.data.inputs.clone(),
            output: self.output.clone(),
            hidden,
            activation: "logistic".to_string(),
            parameters,
        }
    }

    /// Trains a network of `hidden` neurons by GA then LM: on every training
    /// row (`fold` None, the [`Stream::Genetic`] stream of the size), or on
    /// all but fold `f` of `k` (`fold` Some((f, k)), the
    /// [`Stream::CrossValidation`] stream of the size and fold), predicting
    /// the held-out rows.
    fn fit(&self, hidden: usize, fold: Option<(usize, usize)>, settings: &TrainSettings) -> Fit {
        let shape = Shape {
            inputs: self.data.inputs.len(),
            hidden,
        };
        let held = |j: usize| fold.is_some_and(|(f, k)| j % k == f);
        let n = self.train_t.len();
        let (xs, ts): (Vec<Vec<f64>>, Vec<f64>) = (0..n)
            .filter(|&j| !held(j))
            .map(|j| (self.train_x[j].clone(), self.train_t[j]))
            .unzip();
        let objective = Objective {
            shape,
            xs: &xs,
            ts: &ts,
            weight_decay: settings.weight_decay,
        };
        let mut stream: ChaCha8Rng = match fold {
            None => rng(settings.seed, Stream::Genetic, hidden as u64),
            Some((f, _)) => rng(
                settings.seed,
                Stream::CrossValidation,
                ((hidden as u64) << 16) | f as u64,
            ),
        };
        let ga = evolve(
            shape.parameter_count(),
            |theta| objective.mean(theta),
            &settings.ga,
            &mut stream,
        );
        let lm = refine(&objective, &ga.best, &settings.lm);
        let held_out = (0..n)
            .filter(|&j| held(j))
            .map(|j| {
                let scaled = shape.forward(&lm.theta, &self.train_x[j]);
                (j, self.output.from_unit(scaled))
            })
            .collect();
        Fit {
            ga_objective: ga.best_fitness,
            lm_objective: lm.objective / objective.len() as f64,
            lm_epochs: lm.accepted,
            lm_stop: lm.stop,
            held_out,
            theta: lm.theta,
        }
    }

    /// The sweep row of a network trained on every training row, with the
    /// weight decay `weight_decay` it was trained with (for its effective
    /// degrees of freedom).
    fn row(&self, hidden: usize, fit: &Fit, weight_decay: f64) -> SweepRow {
        let model = self.model(hidden, fit.theta.clone());
        let objective = Objective {
            shape: model.shape(),
            xs: &self.train_x,
            ts: &self.train_t,
            weight_decay,
        };
        let score = |rows: &[usize]| {
            let y: Vec<f64> = rows.iter().map(|&i| self.data.targets[i]).collect();
            let p: Vec<f64> = rows
                .iter()
                .map(|&i| model.predict(&self.data.rows[i]))
                .collect();
            (
                r_squared(&y, &p).unwrap_or(f64::NEG_INFINITY),
                mse(&y, &p).sqrt(),
            )
        };
        let (train_r2, train_rmse_deg) = score(&self.data.train);
        let (validation_r2, validation_rmse_deg) = score(&self.data.validation);
        SweepRow {
            hidden,
            train_r2,
            validation_r2,
            train_rmse_deg,
            validation_rmse_deg,
            ga_objective: fit.ga_objective,
            lm_objective: fit.lm_objective,
            lm_epochs: fit.lm_epochs,
            lm_stop: fit.lm_stop,
            parameters: fit.theta.len(),
            effective_dof: objective.effective_dof(&fit.theta),
            train_rows: self.train_t.len(),
            cv_rmse_deg: None,
            cv_r2: None,
        }
    }
}

fn scale_row(data: &Dataset, i: usize) -> Vec<f64> {
    data.inputs
        .iter()
        .zip(&data.rows[i])
        .map(|(s, v)| s.to_unit(*v))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A low-dimensional noisy table: angle = 30 + 4·x₁ − 3·x₂ (x in [0, 1])
    /// plus uniform noise of ±1.5°, 10 training rows then 6 validation rows.
    /// The truth is linear, so one logistic neuron (5 weights) is ample and
    /// anything from 3 neurons up has more weights than training rows.
    fn noisy_linear() -> Dataset {
        let mut draw = ChaCha8Rng::seed_from_u64(2024);
        let rows: Vec<Vec<f64>> = (0..16)
            .map(|_| vec![draw.random::<f64>(), draw.random::<f64>()])
            .collect();
        let targets = rows
            .iter()
            .map(|x| 30.0 + 4.0 * x[0] - 3.0 * x[1] + 3.0 * (draw.random::<f64>() - 0.5))
            .collect();
        let unit = |name: &str| Scale {
            name: name.to_string(),
            min: 0.0,
            max: 1.0,
        };
        Dataset {
            inputs: vec![unit("a"), unit("b")],
            target: "angle_deg".to_string(),
            rows,
            targets,
            train: (0..10).collect(),
            validation: (10..16).collect(),
        }
    }

    fn settings(selection: Selection) -> TrainSettings {
        let mut s = TrainSettings::with_seed(5);
        s.hidden_min = 1;
        s.hidden_max = 6;
        s.selection = selection;
        s
    }

    const LOO: Selection = Selection::CrossValidation { folds: 10 };

    #[test]
    fn cross_validation_keeps_a_small_network_on_a_noisy_linear_table() {
        let sweep = sweep(&noisy_linear(), &settings(LOO)).unwrap();
        for r in &sweep.rows {
            eprintln!(
                "h = {}: {} weights, edf {:.2}, train R² {:.3}, CV RMSE {:.3}, validation R² {:.3}",
                r.hidden,
                r.parameters,
                r.effective_dof,
                r.train_r2,
                r.cv_rmse_deg.unwrap(),
                r.validation_r2
            );
        }
        let kept = &sweep.rows[sweep.best];
        assert!(kept.hidden <= 2, "kept {} neurons", kept.hidden);
        assert!(!kept.over_parameterised(), "{kept:?}");
        assert_eq!(sweep.model.hidden, kept.hidden);
        // The kept size has the lowest CV error; ties would go to the smaller.
        let score = |r: &SweepRow| r.cv_rmse_deg.unwrap();
        for (i, r) in sweep.rows.iter().enumerate() {
            assert!(score(r) >= score(kept), "h = {}", r.hidden);
            if i < sweep.best {
                assert!(score(r) > score(kept), "tie must go to h = {}", r.hidden);
            }
        }
    }

    #[test]
    fn every_row_reports_weights_dof_and_rows() {
        let sweep = sweep(&noisy_linear(), &settings(LOO)).unwrap();
        for r in &sweep.rows {
            assert_eq!(r.train_rows, 10);
            assert_eq!(r.parameters, 4 * r.hidden + 1);
            assert_eq!(r.over_parameterised(), r.hidden >= 3);
            assert!(r.effective_dof <= 10.0, "{r:?}");
            assert!(r.effective_dof <= r.parameters as f64, "{r:?}");
            assert!(r.cv_r2.is_some());
        }
    }

    #[test]
    fn validation_selection_reports_no_cv_score_and_keeps_the_best_validation_r2() {
        let sweep = sweep(&noisy_linear(), &settings(Selection::Validation)).unwrap();
        let kept = &sweep.rows[sweep.best];
        for r in &sweep.rows {
            assert_eq!((r.cv_rmse_deg, r.cv_r2), (None, None));
            assert!(r.validation_r2 <= kept.validation_r2);
        }
    }

    #[test]
    fn the_full_networks_do_not_depend_on_the_selection_rule() {
        // Cross-validation adds fold networks on their own streams; the
        // networks trained on all rows are the same as under he2019's rule.
        let a = sweep(&noisy_linear(), &settings(Selection::Validation)).unwrap();
        let b = sweep(&noisy_linear(), &settings(LOO)).unwrap();
        for (x, y) in a.rows.iter().zip(&b.rows) {
            let mut y = y.clone();
            (y.cv_rmse_deg, y.cv_r2) = (None, None);
            assert_eq!(x, &y);
        }
    }

    #[test]
    fn the_cross_validated_sweep_is_bit_identical_on_one_and_two_threads() {
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    sweep(
                        &noisy_linear(),
                        &settings(Selection::CrossValidation { folds: 3 }),
                    )
                })
                .unwrap()
        };
        let one = run(1);
        let two = run(2);
        let bits = |s: &Sweep| {
            s.rows
                .iter()
                .flat_map(|r| [r.cv_rmse_deg.unwrap(), r.validation_r2, r.effective_dof])
                .chain(s.model.parameters.iter().copied())
                .map(f64::to_bits)
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&one), bits(&two));
        assert_eq!(one, two);
    }

    #[test]
    fn folds_below_two_are_refused() {
        let err = sweep(
            &noisy_linear(),
            &settings(Selection::CrossValidation { folds: 1 }),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("folds = 1"), "{err}");
    }
}
