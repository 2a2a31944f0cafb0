//! The tradeoff table as CSV (machine-readable), Markdown (for a README or an
//! issue) and an SVG plot: |angle error| against wall time on a log axis, the
//! Pareto front drawn as a line, each point named by its knob setting.

use std::fmt::Write as _;

use super::Row;

/// CSV header; wall time, particle-steps and speed-up are measured (they vary
/// run to run), every other column is deterministic.
pub const CSV_HEADER: &str = "label,knob,value,replicates,healthy,angle_mean_deg,angle_ci95_deg,\
error_deg,error_ci95_deg,dt_s,wall_time_s,particle_steps,speed_up,pareto,ids,failure";

use crate::report::table::{optional_cell as num, text_cell as csv_text};

/// The table as CSV, one row per point.
pub fn csv(rows: &[Row]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        let ids: Vec<&str> = r.ids.iter().map(|i| i.as_str()).collect();
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.label,
            r.knob,
            num(r.value),
            r.replicates,
            r.healthy,
            num(r.angle.map(|a| a.mean)),
            num(r.angle.map(|a| a.half_width)),
            num(r.error_deg.map(|e| e.0)),
            num(r.error_deg.map(|e| e.1)),
            num(r.dt_s),
            num(r.wall_time_s),
            num(r.particle_steps),
            num(r.speed_up),
            r.pareto,
            ids.join(";"),
            csv_text(r.failure.as_deref().unwrap_or("")),
        );
    }
    out
}

/// The table as Markdown, with a one-line legend.
pub fn markdown(rows: &[Row], title: &str) -> String {
    let mut out = format!(
        "## {title}\n\nAngle: mean ± 95 % CI over healthy replicates. Error: angle − \
         reference (Welch 95 % CI). ★: Pareto front of (|error|, wall time).\n\n\
         | point | healthy | angle (°) | error (°) | dt (s) | wall time (s) | particle-steps | speed-up | |\n\
         |---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        let angle = r
            .angle
            .map(|a| format!("{:.2} ± {:.2}", a.mean, a.half_width))
            .unwrap_or_else(|| "—".into());
        let error = r
            .error_deg
            .map(|e| format!("{:+.2} ± {:.2}", e.0, e.1))
            .unwrap_or_else(|| "—".into());
        let _ = writeln!(
            out,
            "| {} | {}/{} | {} | {} | {} | {} | {} | {} | {} |",
            r.label,
            r.healthy,
            r.replicates,
            angle,
            error,
            r.dt_s
                .map(|t| format!("{t:.3e}"))
                .unwrap_or_else(|| "—".into()),
            r.wall_time_s
                .map(|t| format!("{t:.1}"))
                .unwrap_or_else(|| "—".into()),
            r.particle_steps
                .map(|p| format!("{p:.3e}"))
                .unwrap_or_else(|| "—".into()),
            r.speed_up
                .map(|s| format!("{s:.2}×"))
                .unwrap_or_else(|| "—".into()),
            if r.pareto { "★" } else { "" },
        );
    }
    out
}

/// |error| (with its CI as a bar) against wall time (log axis), the Pareto
/// front joined by a line, every point labelled.
pub fn svg(rows: &[Row], title: &str) -> String {
    let pts: Vec<(&Row, f64, f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            let (e, h) = r.error_deg?;
            Some((r, r.wall_time_s?.max(1e-3), e.abs(), h))
        })
        .collect();
    let (w, h, left, right, top, bottom) = (760.0, 480.0, 70.0, 160.0, 40.0, 50.0);
    let mut out = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" \
         font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{left}\" y=\"20\" font-size=\"14\">{}</text>\n",
        xml(title)
    );
    if pts.is_empty() {
        out.push_str("<text x=\"70\" y=\"100\">no healthy points to plot</text>\n</svg>\n");
        return out;
    }
    let lt: Vec<f64> = pts.iter().map(|p| p.1.log10()).collect();
    let (t0, t1) = (
        lt.iter().cloned().fold(f64::INFINITY, f64::min).floor(),
        lt.iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil()
            .max(lt.iter().cloned().fold(f64::INFINITY, f64::min).floor() + 1.0),
    );
    let e1 = pts.iter().map(|p| p.2 + p.3).fold(0.0, f64::max).max(1e-3) * 1.1;
    let (pw, ph) = (w - left - right, h - top - bottom);
    let x = |t: f64| left + (t.log10() - t0) / (t1 - t0) * pw;
    let y = |e: f64| top + ph - e / e1 * ph;
    let _ = writeln!(
        out,
        "<rect x=\"{left}\" y=\"{top}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"black\"/>"
    );
    for d in (t0 as i32)..=(t1 as i32) {
        let xx = x(10f64.powi(d));
        let _ = writeln!(
            out,
            "<line x1=\"{xx:.1}\" y1=\"{}\" x2=\"{xx:.1}\" y2=\"{}\" stroke=\"#ddd\"/>\
             <text x=\"{xx:.1}\" y=\"{}\" text-anchor=\"middle\">1e{d} s</text>",
            top,
            top + ph,
            top + ph + 15.0
        );
    }
    for k in 0..=4 {
        let e = e1 * k as f64 / 4.0;
        let _ = writeln!(
            out,
            "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{e:.2}</text>",
            left - 5.0,
            y(e) + 4.0
        );
    }
    let _ = writeln!(
        out,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">wall time per run (log)</text>\
         <text x=\"15\" y=\"{}\" transform=\"rotate(-90 15 {})\" text-anchor=\"middle\">|angle error| vs reference (°)</text>",
        left + pw / 2.0,
        h - 10.0,
        top + ph / 2.0,
        top + ph / 2.0
    );
    let mut front: Vec<&(&Row, f64, f64, f64)> = pts.iter().filter(|p| p.0.pareto).collect();
    front.sort_by(|a, b| a.1.total_cmp(&b.1));
    let line: Vec<String> = front
        .iter()
        .map(|p| format!("{:.1},{:.1}", x(p.1), y(p.2)))
        .collect();
    let _ = writeln!(
        out,
        "<polyline points=\"{}\" fill=\"none\" stroke=\"#c33\" stroke-width=\"2\"/>",
        line.join(" ")
    );
    for (r, t, e, hw) in &pts {
        let (cx, cy) = (x(*t), y(*e));
        let colour = if r.pareto { "#c33" } else { "#357" };
        let _ = writeln!(
            out,
            "<line x1=\"{cx:.1}\" y1=\"{:.1}\" x2=\"{cx:.1}\" y2=\"{:.1}\" stroke=\"{colour}\"/>\
             <circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"4\" fill=\"{colour}\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
            y((e - hw).max(0.0)),
            y(e + hw),
            cx + 6.0,
            cy - 6.0,
            xml(&r.label)
        );
    }
    out.push_str("</svg>\n");
    out
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
