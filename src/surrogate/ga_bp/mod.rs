//! The GA-BP surrogate (he2019 §3.2–3.4): scaling, training one network
//! (genetic algorithm, then Levenberg–Marquardt), the hidden-size sweep of
//! Eq. 6 / Fig. 12, and the saved model that `search` reuses.
//!
//! Scaling: every input is mapped linearly from its range (the study's
//! parameter range, or for a bare table the training rows' min–max) onto
//! [−1, 1], and the angle from the training targets' min–max onto [−1, 1] —
//! MATLAB's `mapminmax` default, which he2019's MATLAB network would have used.
//!
//! Selection: the sweep trains one network per hidden size and keeps the one
//! with the highest validation R² (Eq. 7), ties going to the smaller network —
//! as he2019 chose 7 neurons from Fig. 12. The validation rows therefore also
//! choose the size, so the reported best validation R² is optimistic; the
//! whole sweep is reported so that can be judged.
//!
//! Determinism: each hidden size draws from its own ChaCha stream (the seed and
//! the size), computes sequentially, and the sweep collects results in size
//! order, so the outcome is bit-identical on any number of threads.
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
    /// Genetic algorithm.
    pub ga: GaSettings,
    /// Levenberg–Marquardt.
    pub lm: TrainlmSettings,
}

impl TrainSettings {
    /// The defaults with a given seed: hidden sizes 3–12, no weight decay,
    /// [`GaSettings::default`] and [`TrainlmSettings::default`].
    pub fn with_seed(seed: u64) -> TrainSettings {
        TrainSettings {
            hidden_min: 3,
            hidden_max: 12,
            seed,
            weight_decay: 0.0,
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
}

/// The whole sweep and the network it keeps.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
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

/// Trains one network per hidden size and keeps the best by validation R².
pub fn sweep(data: &Dataset, settings: &TrainSettings) -> Result<Sweep, TrainError> {
    settings.check().map_err(TrainError::Settings)?;
    let prepared = Prepared::new(data)?;
    let sizes: Vec<usize> = (settings.hidden_min..=settings.hidden_max).collect();
    let trained: Vec<(SweepRow, Vec<f64>)> = sizes
        .par_iter()
        .map(|&h| prepared.train_one(h, settings))
        .collect();
    let mut best = 0;
    for (i, (row, _)) in trained.iter().enumerate() {
        if row.validation_r2 > trained[best].0.validation_r2 {
            best = i;
        }
    }
    let model = prepared.model(trained[best].0.hidden, trained[best].1.clone());
    Ok(Sweep {
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

    fn train_one(&self, hidden: usize, settings: &TrainSettings) -> (SweepRow, Vec<f64>) {
        let shape = Shape {
            inputs: self.data.inputs.len(),
            hidden,
        };
        let objective = Objective {
            shape,
            xs: &self.train_x,
            ts: &self.train_t,
            weight_decay: settings.weight_decay,
        };
        let mut stream: ChaCha8Rng = rng(settings.seed, Stream::Genetic, hidden as u64);
        let ga = evolve(
            shape.parameter_count(),
            |theta| objective.mean(theta),
            &settings.ga,
            &mut stream,
        );
        let lm = refine(&objective, &ga.best, &settings.lm);
        let model = self.model(hidden, lm.theta);
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
        let row = SweepRow {
            hidden,
            train_r2,
            validation_r2,
            train_rmse_deg,
            validation_rmse_deg,
            ga_objective: ga.best_fitness,
            lm_objective: lm.objective / objective.len() as f64,
            lm_epochs: lm.accepted,
            lm_stop: lm.stop,
        };
        (row, model.parameters)
    }
}

fn scale_row(data: &Dataset, i: usize) -> Vec<f64> {
    data.inputs
        .iter()
        .zip(&data.rows[i])
        .map(|(s, v)| s.to_unit(*v))
        .collect()
}
