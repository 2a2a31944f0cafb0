//! A convergence sweep as CSV (one row per size level and response),
//! Markdown (the level table, the trends, the cost law and the standard
//! size) and one SVG figure (each response against d/D with its fit and the
//! extrapolated value; the cost per run against d/D on log axes).

use std::fmt::Write as _;

use super::{Convergence, LevelRow};
use crate::report::markdown::{Align, MarkdownTable};
use crate::report::plots::{size_trends, CostPanel, PlotError, TrendPanel};
use crate::study::acceptance::Verdict;

/// CSV header. CPU and wall time are measured (they vary run to run); every
/// other column is deterministic.
pub const CSV_HEADER: &str = "size_factor,radius_m,d_over_D,response,replicates,completed,mean,\
ci95,sd,bias,bias_ci95,particles,particle_steps,planned_particle_steps,cpu_s_per_run,\
wall_s_per_run,unresolved,ids,failure";

use crate::report::table::{optional_cell as num, text_cell as csv_text};

/// The sweep as CSV: one row per level and response (a level without any
/// response still gets one row, with the response empty).
pub fn csv(c: &Convergence) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for (i, level) in c.levels.iter().enumerate() {
        let names: Vec<Option<&String>> = if level.values.is_empty() {
            vec![None]
        } else {
            level.values.keys().map(Some).collect()
        };
        for name in names {
            let stat = name.and_then(|n| level.responses.get(n).copied().flatten());
            let bias = name.and_then(|n| {
                c.trends
                    .iter()
                    .find(|t| &t.response == n)
                    .and_then(|t| t.bias[i])
            });
            let ids: Vec<&str> = level.ids.iter().map(|i| i.as_str()).collect();
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                level.factor,
                level.radius_m,
                num(level.x),
                name.map_or("", |n| n.as_str()),
                level.replicates,
                level.completed,
                num(stat.map(|s| s.mean)),
                num(stat.map(|s| s.half_width)),
                num(stat.map(|s| s.std)),
                num(bias.map(|b| b.0)),
                num(bias.map(|b| b.1)),
                num(level.particles),
                num(level.particle_steps),
                num(level.planned_particle_steps),
                num(level.mean_cpu_s()),
                num(level.wall_s),
                csv_text(&level.unresolved.join("; ")),
                ids.join(";"),
                csv_text(level.failure.as_deref().unwrap_or("")),
            );
        }
    }
    out
}

fn fixed(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "—".to_string(), |x| format!("{x:.digits$}"))
}

fn sci(v: Option<f64>) -> String {
    v.map_or_else(|| "—".to_string(), |x| format!("{x:.3e}"))
}

/// `mean ± half` of a level's response.
fn cell(level: &LevelRow, name: &str) -> String {
    match level.responses.get(name).copied().flatten() {
        Some(m) => format!("{:.2} ± {:.2} (σ {:.2})", m.mean, m.half_width, m.std),
        None => match level.values.get(name).map(Vec::len) {
            Some(1) => format!("{:.2} (one run)", level.values[name][0]),
            _ => "—".to_string(),
        },
    }
}

/// The sweep as Markdown.
pub fn markdown(c: &Convergence, title: &str) -> String {
    let mut out = format!("## {title}\n\n");
    let rule = c
        .rule
        .map_or("the manifest's coarse-graining rule".to_string(), |r| {
            format!("`{}`", r.name())
        });
    let _ = writeln!(
        out,
        "Levels: the base particle × size factor; surface energy by {rule}. Responses: mean \
         ± 95 % CI (σ: seed-to-seed sd). CPU-s: per run, the run's thread. Plan: `repose \
         plan`'s particle-steps estimate over the measured.\n"
    );
    let names: Vec<String> = c
        .levels
        .first()
        .map(|l| l.values.keys().cloned().collect())
        .unwrap_or_default();
    let mut header = vec![
        "size".to_string(),
        "radius (mm)".into(),
        "d/D".into(),
        "runs".into(),
        "particles".into(),
    ];
    header.extend(names.iter().map(|n| format!("{n} (°)")));
    header.extend([
        "CPU-s/run".into(),
        "particle-steps".into(),
        "plan / measured".into(),
        "resolution".into(),
    ]);
    let mut table = MarkdownTable::new(&header);
    for k in [0, 1, 2, 3, 4] {
        table = table.align(k, Align::Right);
    }
    for level in &c.levels {
        let mut row = vec![
            format!("{}", level.factor),
            format!("{:.3}", level.radius_m * 1e3),
            fixed(level.x, 4),
            format!("{}/{}", level.completed, level.replicates),
            fixed(level.particles, 0),
        ];
        row.extend(names.iter().map(|n| cell(level, n)));
        let ratio = level
            .planned_particle_steps
            .zip(level.particle_steps)
            .map(|(p, m)| p / m);
        let figures: Vec<String> = level
            .resolution
            .iter()
            .map(|(k, v)| format!("{k} {v:.3}"))
            .collect();
        let mut resolution = figures.join(", ");
        if !level.unresolved.is_empty() {
            resolution.push_str(&format!(" — unresolved: {}", level.unresolved.join("; ")));
        }
        row.extend([
            fixed(level.mean_cpu_s(), 1),
            sci(level.particle_steps),
            fixed(ratio, 2),
            resolution,
        ]);
        table.row(&row);
    }
    out.push_str(&table.render());
    for level in c.levels.iter().filter(|l| l.failure.is_some()) {
        let _ = writeln!(
            out,
            "\nsize {}: {} of {} runs failed; first: {}",
            level.factor,
            level.replicates - level.completed,
            level.replicates,
            level.failure.as_deref().unwrap_or("")
        );
    }
    let real = match (c.real_x, c.real_radius_m) {
        (Some(x), Some(r)) => format!("the real particle (radius {:.4} mm, d/D {x:.3e})", r * 1e3),
        _ => "d/D → 0 (the real particle's size was not given)".to_string(),
    };
    let _ = writeln!(
        out,
        "\n### Trends (a line in d/D over the runs, weighted; read at {real})\n"
    );
    let mut trends = MarkdownTable::new(&[
        "response",
        "weighting",
        "slope (°)",
        "lack of fit p",
        "extrapolated (°)",
        "bias per size (°)",
        "coarsest within T/2",
        "d/D for T/2 (size factor, CPU-s/run)",
    ]);
    for t in &c.trends {
        let (slope, at_real) = match &t.fit {
            Ok(fit) => (
                format!("{:.1} ± {:.1}", fit.slope, fit.slope_half_width()),
                t.at_real.map_or("—".into(), |p| {
                    format!("{:.2} ± {:.2}", p.mean, p.half_width)
                }),
            ),
            Err(why) => (format!("no fit: {why}"), "—".into()),
        };
        let bias: Vec<String> = c
            .levels
            .iter()
            .zip(&t.bias)
            .map(|(l, b)| match b {
                Some((b, h)) => format!("{}: {b:+.2} ± {h:.2}", l.factor),
                None => format!("{}: —", l.factor),
            })
            .collect();
        let needed = t.needed.map_or("—".into(), |n| {
            format!(
                "{:.3e} ({:.3}, {})",
                n.x,
                n.factor,
                n.cpu_s.map_or("—".into(), |s| format!("{s:.3e}"))
            )
        });
        let lof = t.lack_of_fit.as_ref().map_or("—".into(), |l| {
            let verdict = if l.p_value < super::LACK_OF_FIT_ALPHA {
                ": the line misses the sizes, not extrapolated"
            } else {
                ""
            };
            format!("{:.3}{verdict}", l.p_value)
        });
        trends.row(&[
            t.response.clone(),
            t.weighting.to_string(),
            slope,
            lof,
            at_real,
            bias.join("; "),
            t.standard_factor
                .map_or("none measured".into(), |f| format!("size {f}")),
            needed,
        ]);
    }
    out.push_str(&trends.render());
    size_effects(&mut out, c);
    if let Some(cost) = &c.cost {
        let _ = writeln!(
            out,
            "\nCost: CPU-s per run ∝ (d/D)^{:.2} ± {:.2} (95 %; about −4 expected: particles ∝ \
             (d/D)⁻³, time step ∝ d).",
            cost.exponent.0, cost.exponent.1
        );
    }
    match (c.tolerance, c.standard_factor) {
        (Some(t), Some(f)) => {
            let _ = writeln!(
                out,
                "\nStandard size for tolerance ±{t}: size factor {f}, the coarsest level whose \
                 estimated bias is within ±{} for every response.",
                0.5 * t
            );
        }
        (Some(t), None) => {
            let _ = writeln!(
                out,
                "\nNo measured level has every response's estimated bias within ±{} (half \
                 the tolerance ±{t}); the table gives the size and cost the trend asks for.",
                0.5 * t
            );
        }
        _ => {}
    }
    out
}

/// The table of the size-effect tests (when a tolerance was given).
fn size_effects(out: &mut String, c: &Convergence) {
    let rows: Vec<_> = c
        .trends
        .iter()
        .filter_map(|t| Some((t, t.size_effect?)))
        .collect();
    let Some((_, first)) = rows.first() else {
        return;
    };
    let _ = writeln!(
        out,
        "\n### Size effect over the swept sizes (the line's change across d/D {:.3e}, \
         TOST against ±{} = half the tolerance, α = 0.05)\n",
        first.span, first.margin
    );
    let mut table = MarkdownTable::new(&[
        "response",
        "change (°)",
        "90 % interval (°)",
        "TOST p",
        "size-independent",
    ]);
    for (t, e) in rows {
        let verdict = match e.verdict {
            Some(Verdict::Pass) => "yes: the change is within ±T/2".to_string(),
            Some(Verdict::Fail) => "no: the change exceeds T/2".to_string(),
            Some(Verdict::Inconclusive) => "inconclusive".to_string(),
            None => "not a line: the sizes differ beyond their scatter".to_string(),
        };
        table.row(&[
            t.response.clone(),
            format!("{:+.2} ± {:.2}", e.test.estimate, e.test.ci95_half_width),
            format!(
                "{:+.2} … {:+.2}",
                e.test.estimate - e.test.ci90_half_width,
                e.test.estimate + e.test.ci90_half_width
            ),
            format!("{:.3}", e.test.p),
            verdict,
        ]);
    }
    out.push_str(&table.render());
}

/// The figure: one panel per response and the cost panel.
pub fn svg(c: &Convergence, title: &str) -> Result<String, PlotError> {
    let real_x = c.real_x.unwrap_or(0.0);
    let panels: Vec<TrendPanel> = c
        .trends
        .iter()
        .filter_map(|t| {
            let levels: Vec<(f64, f64, f64)> = c
                .levels
                .iter()
                .filter_map(|l| {
                    let m = l.responses.get(&t.response).copied().flatten()?;
                    Some((l.x?, m.mean, m.half_width))
                })
                .collect();
            if levels.is_empty() {
                return None;
            }
            let fit = match &t.fit {
                Ok(line) => {
                    let hi = levels.iter().map(|l| l.0).fold(real_x, f64::max);
                    (0..=40)
                        .map(|k| {
                            let p = line.at(real_x + (hi - real_x) * k as f64 / 40.0);
                            (p.x, p.mean, p.half_width)
                        })
                        .collect()
                }
                Err(_) => Vec::new(),
            };
            Some(TrendPanel {
                response: format!("{} (°)", t.response),
                levels,
                fit,
                extrapolated: t.at_real.map(|p| (p.x, p.mean, p.half_width)),
            })
        })
        .collect();
    let runs: Vec<(f64, f64)> = c
        .levels
        .iter()
        .filter_map(|l| {
            let x = l.x?;
            Some(l.cpu_s.iter().map(move |&s| (x, s)))
        })
        .flatten()
        .filter(|p| p.1 > 0.0)
        .collect();
    let cost = (!runs.is_empty()).then(|| {
        let (lo, hi) = runs.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
            (lo.min(p.0), hi.max(p.0))
        });
        let fit = c.cost.map_or(Vec::new(), |law| {
            (0..=20)
                .map(|k| {
                    let x = lo * (hi / lo).powf(k as f64 / 20.0);
                    (x, law.at(x))
                })
                .collect()
        });
        CostPanel { runs, fit }
    });
    size_trends(&panels, cost.as_ref(), title)
}
