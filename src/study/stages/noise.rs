//! `repose noise STUDY`: the noise floor of the calibration response — one
//! point, the centre of every range, simulated with `noise_seeds` packing
//! seeds (`noise_aware` of the study).
//!
//! It reports the seed-to-seed standard deviation σ, the mean with its
//! Student-t 95 % interval, the wall time per run and the precision per cost
//! σ² × (CPU seconds per run), the figure of merit of a measurement protocol:
//! the variance one run buys per second, so halving σ is worth four times
//! the cost. CPU seconds are wall seconds × the threads each run had (runs
//! are pinned to one thread when several run at once). The wall-time cells
//! are the only non-deterministic ones (`noise.md`, `noise.json`); the
//! per-seed table `noise.csv` is a pure function of the study.
//!
//! The centre's runs are also a point of the surrogate's training data (the
//! replicate mean of many seeds), so the noise floor is not spent only on
//! itself.

use std::fmt::Write as _;

use serde_json::json;

use crate::exec::Executor;
use crate::manifest::{Experiment, Study};
use crate::report::markdown::MarkdownTable;
use crate::store::{RunDir, RunResult, Store};
use crate::study::dir::json_bytes;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::{noise_aware, to_physical, NOISE_INDEX};
use crate::study::records::NoiseFloor;
use crate::study::runs::replicated::{replicates_csv, run_replicated, Replicated};
use crate::study::sweeps::noise_floor::{response_noise, run_cost};
use crate::study::StudyError;

/// What the noise stage did.
#[derive(Debug, Clone)]
pub struct NoiseOutcome {
    /// The floor.
    pub floor: NoiseFloor,
    /// The centre's runs.
    pub runs: Replicated,
    /// The Markdown report (also noise.md).
    pub markdown: String,
}

/// Runs the noise floor (see the module docs).
pub fn noise<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    pool: &Executor,
    runner: F,
) -> Result<NoiseOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let spec = noise_aware(study)?;
    let centre = to_physical(study, &vec![0.5; study.parameters.len()]);
    let target = &study.calibration;
    let runs = run_replicated(
        study,
        target,
        &[(NOISE_INDEX, centre.clone())],
        spec.noise_seeds,
        store,
        pool,
        &runner,
        false,
    )?
    .0
    .remove(0);
    let name = target
        .response
        .clone()
        .unwrap_or_else(|| "headline_angle_deg".into());
    let cost = run_cost(store, pool, runs.runs.iter().map(|r| &r.id));
    let n = response_noise(&name, "deg", &runs.values(), cost.cpu_s_per_run);
    let floor = NoiseFloor {
        response: name,
        centre,
        seeds: runs.runs.len(),
        measured: n.measured,
        mean_deg: n.mean,
        sd_deg: n.sd,
        ci95_half_width_deg: n.ci95_half_width,
        wall_s_per_run: cost.wall_s_per_run,
        threads_per_run: cost.threads_per_run,
        precision_per_cost_deg2_s: n.precision_per_cost,
    };
    dir.prepare_stage(study, Stage::Noise)?;
    let lineage = dir.lineage(
        Stage::Noise,
        json!({ "seeds": spec.noise_seeds, "point": "centre of the ranges",
                "sample_index": NOISE_INDEX }),
    );
    let lineage = runs.runs.iter().try_fold(lineage, |l, r| {
        let path = store.run_dir(&r.id).result_path();
        if path.is_file() {
            Ok::<_, StudyError>(l.with_input(dir.input("result", &path)?))
        } else {
            Ok(l)
        }
    })?;
    let out = dir.stage(Stage::Noise);
    let markdown = markdown(study, &floor);
    write_output(&out.join("noise.md"), markdown.as_bytes(), &lineage)?;
    write_output(
        &dir.noise_runs_path(),
        replicates_csv(
            study,
            &[(&study.calibration.name, std::slice::from_ref(&runs))],
        )
        .as_bytes(),
        &lineage,
    )?;
    write_output(&dir.noise_path(), &json_bytes(&floor), &lineage)?;
    Ok(NoiseOutcome {
        floor,
        runs,
        markdown,
    })
}

fn markdown(study: &Study, f: &NoiseFloor) -> String {
    let fmt =
        |v: Option<f64>, digits: usize| v.map_or("—".to_string(), |v| format!("{v:.digits$}"));
    let mut t = MarkdownTable::new(&[
        "scene",
        "response",
        "seeds (measured)",
        "mean (°)",
        "σ (°)",
        "95 % CI of the mean (°)",
        "wall s per run",
        "σ² × CPU s (deg²·s)",
    ]);
    t.row(&[
        study.calibration.name.clone(),
        f.response.clone(),
        format!("{} ({})", f.seeds, f.measured),
        fmt(f.mean_deg, 2),
        fmt(f.sd_deg, 2),
        f.ci95_half_width_deg
            .map_or("—".into(), |h| format!("± {h:.2}")),
        fmt(f.wall_s_per_run, 1),
        fmt(f.precision_per_cost_deg2_s, 0),
    ]);
    let mut out = format!(
        "Noise floor of `{}` at the centre of the ranges ({} packing seeds, {} thread(s) per run):\n\n",
        study.calibration.name, f.seeds, f.threads_per_run
    );
    out.push_str(&t.render());
    let band = study.calibration.band_deg();
    if let Some(sd) = f.sd_deg {
        let _ = writeln!(
            out,
            "\nThe target band is {:.2}–{:.2}° (± {:.2}°); one run's σ is {:.1} band half-widths.",
            band.0,
            band.1,
            0.5 * (band.1 - band.0),
            sd / (0.5 * (band.1 - band.0))
        );
    }
    out
}
