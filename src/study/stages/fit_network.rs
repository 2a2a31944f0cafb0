//! `repose train STUDY`: the GA-BP network sweep on the batch's angles (he2019
//! §3.2–3.4), and `repose train --table`: the same on any CSV table (e.g.
//! he2019's printed Table A1).
//!
//! Split: the first `train_fraction` of the design (by sample index, rounded
//! to whole rows) trains, the rest validates — he2019's 80 of 120, the default
//! fraction 2/3. A run without an angle (failed, or never run) is left out of
//! whichever part it belongs to and counted.
//!
//! Selection of the hidden size ([`crate::surrogate::ga_bp::Selection`]):
//! he2019's highest validation R² for classic studies and tables (it
//! reproduces Table A1), k-fold cross-validation within the training rows for
//! noise-aware studies ([`TrainOptions::defaults`]), whose few noisy training
//! rows would otherwise keep networks with more weights than rows; `repose
//! train --selection` overrides either. The rule is part of the options
//! recorded in every output's lineage.
//!
//! Outputs (each with its lineage record): `sweep.csv` (one row per hidden
//! size: the Fig. 12 table, with each network's weights, effective degrees of
//! freedom, training rows, whether the weights outnumber the rows, and the
//! cross-validated score when that rule chose), `model.json` (the kept network, see
//! [`crate::surrogate::ga_bp::Model`]), `parity.svg` (Fig. 13: predicted against
//! simulated, train and validation marked) and `summary.json` (the split, the
//! kept size and, for a table with printed predictions, their R²).

use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::json;

use crate::manifest::Study;
use crate::report::svg::{parity_plot, ParityPoint};
use crate::report::table::{parse_number, Cell, CsvWriter, Table};
use crate::stats::metrics::r_squared;
use crate::store::InputRef;
use crate::store::Lineage;
use crate::study::dir::json_bytes;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::create_dir;
use crate::study::plan::calibration::parameter_names;
use crate::study::plan::calibration::serde_name;
use crate::study::plan::Method;
use crate::study::records::read_angles;
use crate::study::StudyError;
use crate::surrogate::ga_bp::{
    sweep, Dataset, Scale, Selection, Sweep, TrainSettings, DEFAULT_FOLDS, DEFAULT_TRAIN_FRACTION,
};

/// Options of the train stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrainOptions {
    /// Network sweep settings.
    pub settings: TrainSettings,
    /// Fraction of the rows (in design order) that trains, in (0, 1).
    pub train_fraction: f64,
}

/// A CSV table to train on.
#[derive(Debug, Clone, Copy)]
pub struct TableSpec<'a> {
    /// The table.
    pub path: &'a Path,
    /// Input columns.
    pub inputs: &'a [String],
    /// Target column (the angle, degrees).
    pub target: &'a str,
    /// Optional column of printed predictions to score on the validation rows.
    pub reference: Option<&'a str>,
}

/// What the train stage produced.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainOutcome {
    /// The sweep and the kept model.
    pub sweep: Sweep,
    /// Rows used for training.
    pub train_rows: usize,
    /// Rows used for validation.
    pub validation_rows: usize,
    /// Rows without an angle, left out.
    pub skipped: usize,
    /// Eq. 7 R² of the table's reference predictions on the validation rows.
    pub reference_r2: Option<f64>,
    /// Where the outputs were written.
    pub out_dir: PathBuf,
}

impl TrainOutcome {
    /// The sweep as text (the Fig. 12 table: per hidden size the weights,
    /// effective degrees of freedom, R², RMSE and LM steps), the kept size
    /// and why, and where the outputs were written — what `repose train`
    /// prints.
    pub fn text(&self) -> String {
        let mut out = format!(
            "{} training rows, {} validation rows{}\n",
            self.train_rows,
            self.validation_rows,
            if self.skipped > 0 {
                format!(", {} without an angle left out", self.skipped)
            } else {
                String::new()
            }
        );
        let rows = &self.sweep.rows;
        let cv = rows.iter().any(|r| r.cv_rmse_deg.is_some());
        out.push_str(&format!(
            "{:>6}  {:>7}  {:>6}  {:>9}  {:>9}  {:>11}  {:>9}{}\n",
            "hidden",
            "weights",
            "edf",
            "train R2",
            "valid R2",
            "valid RMSE",
            "LM steps",
            if cv {
                format!("  {:>9}", "CV RMSE")
            } else {
                String::new()
            }
        ));
        for (i, r) in rows.iter().enumerate() {
            out.push_str(&format!(
                "{:>6}  {:>6}{}  {:>6.2}  {:>9.4}  {:>9.4}  {:>11.3}  {:>9}{}{}\n",
                r.hidden,
                r.parameters,
                if r.over_parameterised() { "!" } else { " " },
                r.effective_dof,
                r.train_r2,
                r.validation_r2,
                r.validation_rmse_deg,
                r.lm_epochs,
                r.cv_rmse_deg
                    .map_or(String::new(), |v| format!("  {v:>9.3}")),
                if i == self.sweep.best {
                    "  <- kept"
                } else {
                    ""
                }
            ));
        }
        if rows.iter().any(|r| r.over_parameterised()) {
            out.push_str(&format!(
                "!: more weights than the {} training rows (edf: effective degrees of freedom, \
                 at most the rows)\n",
                self.train_rows
            ));
        }
        let best = &rows[self.sweep.best];
        out.push_str(&match self.sweep.selection {
            Selection::Validation => format!(
                "kept: {} hidden neurons, validation R2 {:.4} (Eq. 7; the validation rows chose \
                 the size)\n",
                best.hidden, best.validation_r2
            ),
            Selection::CrossValidation { folds } => format!(
                "kept: {} hidden neurons by {}-fold cross-validation within the training rows \
                 (CV RMSE {:.3} deg); held-out validation R2 {:.4} (Eq. 7)\n",
                best.hidden,
                folds.min(self.train_rows),
                best.cv_rmse_deg.unwrap_or(f64::NAN),
                best.validation_r2
            ),
        });
        if best.validation_r2 < 0.9 {
            out.push_str(
                "note: below the R2 >= 0.9 that he2019 (§3.4) requires before using the network\n",
            );
        }
        if let Some(r) = self.reference_r2 {
            out.push_str(&format!(
                "reference predictions on the validation rows: R2 {r:.4} (Eq. 7)\n"
            ));
        }
        out.push_str(&format!("outputs: {}\n", self.out_dir.display()));
        out
    }
}

/// Contents of summary.json.
#[derive(Debug, Serialize)]
struct Summary {
    train_rows: usize,
    validation_rows: usize,
    skipped_rows: usize,
    selection: Selection,
    best_hidden: usize,
    best_parameters: usize,
    best_effective_dof: f64,
    best_train_r2: f64,
    best_validation_r2: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    reference_validation_r2: Option<f64>,
}

impl TrainOptions {
    /// A study's defaults: [`TrainSettings::with_seed`] of its design seed,
    /// he2019's two-thirds split and the study's [`TrainOptions::selection`].
    pub fn defaults(study: &Study) -> TrainOptions {
        let mut settings = TrainSettings::with_seed(study.design.seed);
        settings.selection = TrainOptions::selection(study);
        TrainOptions {
            settings,
            train_fraction: DEFAULT_TRAIN_FRACTION,
        }
    }

    /// The selection rule a study's network uses unless told otherwise:
    /// he2019's validation R² for a classic he2019 study (the paper's rule),
    /// [`DEFAULT_FOLDS`]-fold cross-validation within the training rows for a
    /// noise-aware one (few noisy rows; see the module docs).
    pub fn selection(study: &Study) -> Selection {
        match Method::of_calibration(study) {
            Method::He2019NoiseAware => Selection::CrossValidation {
                folds: DEFAULT_FOLDS,
            },
            _ => Selection::Validation,
        }
    }

    /// What is wrong with these options, if anything.
    fn check(&self) -> Result<(), StudyError> {
        let f = self.train_fraction;
        if !(f > 0.0 && f < 1.0) {
            return Err(StudyError::Settings(format!(
                "--train-fraction = {f}: must be in (0, 1)"
            )));
        }
        self.settings.check().map_err(StudyError::Settings)
    }

    /// The row index where validation starts for `n` rows.
    fn split_at(&self, n: usize) -> usize {
        crate::surrogate::ga_bp::split_at(n, self.train_fraction)
    }
}

/// The network's input scales: one per calibrated parameter of `study`, in
/// the study's order, mapping the parameter's range onto [−1, 1].
pub(crate) fn input_scales(study: &Study) -> Vec<Scale> {
    study
        .parameters
        .iter()
        .map(|(name, r)| Scale {
            name: name.clone(),
            min: r.min,
            max: r.max,
        })
        .collect()
}

/// Trains on the study's batch/angles.csv and writes into `train/`.
pub fn train_study(
    dir: &StudyDir,
    study: &Study,
    options: &TrainOptions,
) -> Result<TrainOutcome, StudyError> {
    options.check()?;
    let (angles_file, rows) = read_angles(dir, study)?;
    let cut = options.split_at(rows.len());
    let inputs = input_scales(study);
    let with_angle: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].angle_deg.is_some())
        .collect();
    let data = Dataset {
        inputs,
        target: "angle_deg".to_string(),
        rows: rows.iter().map(|r| r.point.clone()).collect(),
        targets: rows
            .iter()
            .map(|r| r.angle_deg.unwrap_or(f64::NAN))
            .collect(),
        train: with_angle.iter().copied().filter(|&i| i < cut).collect(),
        validation: with_angle.iter().copied().filter(|&i| i >= cut).collect(),
    };
    debug_assert_eq!(
        parameter_names(study),
        data.inputs
            .iter()
            .map(|s| s.name.clone())
            .collect::<Vec<_>>()
    );
    let out_dir = dir.stage(Stage::Train);
    dir.prepare_stage(study, Stage::Train)?;
    let lineage = dir
        .lineage(Stage::Train, json!(options))
        .with_input(dir.input("angles", &angles_file)?);
    let skipped = rows.len() - with_angle.len();
    run(&data, options, &out_dir, &lineage, skipped, None)
}

/// Trains on a CSV table and writes into `out_dir`. Inputs are scaled by the
/// training rows' min–max (a table has no ranges).
pub fn train_table(
    spec: &TableSpec,
    out_dir: &Path,
    options: &TrainOptions,
) -> Result<TrainOutcome, StudyError> {
    options.check()?;
    let table = Table::read(spec.path)?;
    let n = table.rows.len();
    let cut = options.split_at(n);
    let columns = spec
        .inputs
        .iter()
        .map(|c| table.numbers(spec.path, c))
        .collect::<Result<Vec<_>, _>>()?;
    let targets = table.numbers(spec.path, spec.target)?;
    let mut inputs = Vec::new();
    for (name, values) in spec.inputs.iter().zip(&columns) {
        let train = &values[..cut.min(n)];
        let min = train.iter().copied().fold(f64::INFINITY, f64::min);
        let max = train.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if min >= max {
            return Err(StudyError::Settings(format!(
                "{}: input column `{name}` is constant over the training rows",
                spec.path.display()
            )));
        }
        inputs.push(Scale {
            name: name.clone(),
            min,
            max,
        });
    }
    let data = Dataset {
        inputs,
        target: spec.target.to_string(),
        rows: (0..n)
            .map(|i| columns.iter().map(|c| c[i]).collect())
            .collect(),
        targets,
        train: (0..cut.min(n)).collect(),
        validation: (cut.min(n)..n).collect(),
    };
    let reference = match spec.reference {
        None => None,
        Some(column) => Some(reference_r2(&table, spec.path, column, &data)?),
    };
    create_dir(out_dir)?;
    let lineage = Lineage::new(
        Stage::Train.name(),
        json!({
            "options": options,
            "inputs": spec.inputs,
            "target": spec.target,
            "reference": spec.reference,
        }),
    )
    .with_input(InputRef::file("table", spec.path, None)?);
    run(&data, options, out_dir, &lineage, 0, reference)
}

/// Eq. 7 R² of a column of printed predictions on the validation rows.
fn reference_r2(
    table: &Table,
    path: &Path,
    column: &str,
    data: &Dataset,
) -> Result<f64, StudyError> {
    let k = table.require(path, column)?;
    let mut predicted = Vec::new();
    for &i in &data.validation {
        let cell = &table.rows[i][k];
        predicted.push(parse_number(cell).ok_or_else(|| {
            StudyError::Settings(format!(
                "{}:{}: reference column `{column}` = `{cell}`: every validation row needs a number",
                path.display(),
                i + 2
            ))
        })?);
    }
    let simulated: Vec<f64> = data.validation.iter().map(|&i| data.targets[i]).collect();
    r_squared(&simulated, &predicted).ok_or_else(|| {
        StudyError::Settings("the validation angles are all equal: R² undefined".to_string())
    })
}

/// Sweeps, then writes sweep.csv, model.json, parity.svg and summary.json.
fn run(
    data: &Dataset,
    options: &TrainOptions,
    out_dir: &Path,
    lineage: &Lineage,
    skipped: usize,
    reference_r2: Option<f64>,
) -> Result<TrainOutcome, StudyError> {
    let result = sweep(data, &options.settings)?;
    let best = &result.rows[result.best];
    write_output(
        &out_dir.join("model.json"),
        &json_bytes(&result.model),
        lineage,
    )?;
    let mut points = Vec::new();
    for (rows, train) in [(&data.train, true), (&data.validation, false)] {
        for &i in rows.iter() {
            points.push(ParityPoint {
                simulated: data.targets[i],
                predicted: result.model.predict(&data.rows[i]),
                train,
            });
        }
    }
    let mut legend = vec![
        format!(
            "train (n = {}): R² = {:.3}",
            data.train.len(),
            best.train_r2
        ),
        format!(
            "validation (n = {}): R² = {:.3}",
            data.validation.len(),
            best.validation_r2
        ),
    ];
    if let Some(r) = reference_r2 {
        legend.push(format!("printed predictions, validation: R² = {r:.3}"));
    }
    let title = format!("GA-BP network, {} hidden neurons", best.hidden);
    write_output(
        &out_dir.join("parity.svg"),
        parity_plot(&points, &title, &legend).as_bytes(),
        lineage,
    )?;
    let summary = Summary {
        train_rows: data.train.len(),
        validation_rows: data.validation.len(),
        skipped_rows: skipped,
        selection: result.selection,
        best_hidden: best.hidden,
        best_parameters: best.parameters,
        best_effective_dof: best.effective_dof,
        best_train_r2: best.train_r2,
        best_validation_r2: best.validation_r2,
        reference_validation_r2: reference_r2,
    };
    write_output(
        &out_dir.join("summary.json"),
        &json_bytes(&summary),
        lineage,
    )?;
    write_output(
        &out_dir.join("sweep.csv"),
        sweep_csv(&result).as_bytes(),
        lineage,
    )?;
    Ok(TrainOutcome {
        train_rows: data.train.len(),
        validation_rows: data.validation.len(),
        skipped,
        reference_r2,
        out_dir: out_dir.to_path_buf(),
        sweep: result,
    })
}

/// Header of sweep.csv: he2019's Fig. 12 columns and the kept mark, then
/// each network's weights, effective degrees of freedom, training rows,
/// whether the weights outnumber the rows (`yes`/`no`), and the
/// cross-validated RMSE (degrees) and R² (empty unless cross-validation chose).
pub const SWEEP_HEADER: [&str; 16] = [
    "hidden",
    "train_r2",
    "validation_r2",
    "train_rmse_deg",
    "validation_rmse_deg",
    "ga_objective",
    "lm_objective",
    "lm_epochs",
    "lm_stop",
    "kept",
    "parameters",
    "effective_dof",
    "train_rows",
    "over_parameterised",
    "cv_rmse_deg",
    "cv_r2",
];

/// The sweep as CSV (one row per hidden size; `kept` marks the chosen one).
pub fn sweep_csv(sweep: &Sweep) -> String {
    let mut csv = CsvWriter::new(&SWEEP_HEADER);
    for (i, r) in sweep.rows.iter().enumerate() {
        csv.row(&[
            Cell::Integer(r.hidden as u64),
            Cell::Number(r.train_r2),
            Cell::Number(r.validation_r2),
            Cell::Number(r.train_rmse_deg),
            Cell::Number(r.validation_rmse_deg),
            Cell::Number(r.ga_objective),
            Cell::Number(r.lm_objective),
            Cell::Integer(r.lm_epochs as u64),
            Cell::Text(serde_name(r.lm_stop)),
            Cell::Text(yes_no(i == sweep.best)),
            Cell::Integer(r.parameters as u64),
            Cell::Number(r.effective_dof),
            Cell::Integer(r.train_rows as u64),
            Cell::Text(yes_no(r.over_parameterised())),
            r.cv_rmse_deg.map_or(Cell::Empty, Cell::Number),
            r.cv_r2.map_or(Cell::Empty, Cell::Number),
        ]);
    }
    csv.finish()
}

fn yes_no(flag: bool) -> String {
    if flag { "yes" } else { "no" }.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::parse_study;
    use crate::stats::levenberg::LmStop;
    use crate::surrogate::ga_bp::{Model, SweepRow};

    fn example(name: &str) -> Study {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("experiments")
            .join(name);
        parse_study(&std::fs::read_to_string(path).unwrap()).unwrap()
    }

    #[test]
    fn noise_aware_studies_cross_validate_and_classic_ones_keep_he2019s_rule() {
        let classic = example("calibrate-smoke/study.json");
        let noisy = example("he2019-quick/study.json");
        assert!(classic.noise_aware.is_none() && noisy.noise_aware.is_some());
        assert_eq!(
            TrainOptions::defaults(&classic).settings.selection,
            Selection::Validation
        );
        let options = TrainOptions::defaults(&noisy);
        assert_eq!(
            options.settings.selection,
            Selection::CrossValidation {
                folds: DEFAULT_FOLDS
            }
        );
        assert_eq!(options.settings.seed, noisy.design.seed);
        // The rule is recorded with the options in every output's lineage.
        assert_eq!(
            json!(options)["settings"]["selection"],
            json!({ "cross_validation": { "folds": DEFAULT_FOLDS } })
        );
        assert_eq!(
            json!(TrainOptions::defaults(&classic))["settings"]["selection"],
            json!("validation")
        );
    }

    fn row(hidden: usize, cv: Option<f64>) -> SweepRow {
        SweepRow {
            hidden,
            train_r2: 1.0,
            validation_r2: -0.5,
            train_rmse_deg: 0.0,
            validation_rmse_deg: 2.0,
            ga_objective: 0.1,
            lm_objective: 0.0,
            lm_epochs: 3,
            lm_stop: LmStop::Epochs,
            parameters: 6 * hidden + 1,
            effective_dof: 9.5,
            train_rows: 10,
            cv_rmse_deg: cv,
            cv_r2: cv.map(|v| 1.0 - v),
        }
    }

    #[test]
    fn sweep_csv_appends_the_dof_columns_and_leaves_cv_empty_without_it() {
        let model = Model {
            kind: "ga_bp_network".to_string(),
            inputs: Vec::new(),
            output: Scale {
                name: "angle_deg".to_string(),
                min: 0.0,
                max: 1.0,
            },
            hidden: 1,
            activation: "logistic".to_string(),
            parameters: vec![0.0; 4],
        };
        let sweep = Sweep {
            selection: Selection::Validation,
            rows: vec![row(1, None), row(2, Some(0.25))],
            best: 0,
            model,
        };
        let csv = sweep_csv(&sweep);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], SWEEP_HEADER.join(","));
        assert!(lines[1].starts_with("1,"), "{csv}");
        assert!(lines[1].ends_with(",yes,7,9.5,10,no,,"), "{csv}");
        assert!(lines[2].ends_with(",no,13,9.5,10,yes,0.25,0.75"), "{csv}");
    }
}
