//! Hand-written SVG plots: the parity plot of `train` (he2019 Fig. 13), the
//! scatter matrix of `search` (Fig. 14b) and the learning curve of
//! `learning-curve` (R² and spread against DEM runs). Coordinates are printed with two
//! decimals, so identical data give identical files.

use std::fmt::Write;

/// Colours of the series and clusters (Tableau 10), cycled.
pub const PALETTE: [&str; 10] = [
    "#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7",
    "#9c755f", "#bab0ac",
];

/// An SVG document being built.
#[derive(Debug, Clone)]
pub struct Svg {
    width: f64,
    height: f64,
    body: String,
}

impl Svg {
    /// An empty `width` × `height` picture (pixels) with a white background.
    pub fn new(width: f64, height: f64) -> Svg {
        let mut s = Svg {
            width,
            height,
            body: String::new(),
        };
        s.rect(0.0, 0.0, width, height, "#ffffff", "none");
        s
    }

    /// A line segment.
    pub fn line(&mut self, x1: f64, y1: f64, x2: f64, y2: f64, stroke: &str, width: f64) {
        let _ = writeln!(
            self.body,
            r#"<line x1="{x1:.2}" y1="{y1:.2}" x2="{x2:.2}" y2="{y2:.2}" stroke="{stroke}" stroke-width="{width:.2}"/>"#
        );
    }

    /// A circle.
    pub fn circle(&mut self, cx: f64, cy: f64, r: f64, fill: &str, stroke: &str) {
        let _ = writeln!(
            self.body,
            r#"<circle cx="{cx:.2}" cy="{cy:.2}" r="{r:.2}" fill="{fill}" stroke="{stroke}"/>"#
        );
    }

    /// An axis-aligned rectangle.
    pub fn rect(&mut self, x: f64, y: f64, w: f64, h: f64, fill: &str, stroke: &str) {
        let _ = writeln!(
            self.body,
            r#"<rect x="{x:.2}" y="{y:.2}" width="{w:.2}" height="{h:.2}" fill="{fill}" stroke="{stroke}"/>"#
        );
    }

    /// Text; `anchor` is `start`, `middle` or `end`.
    pub fn text(&mut self, x: f64, y: f64, size: f64, anchor: &str, content: &str) {
        let _ = writeln!(
            self.body,
            r#"<text x="{x:.2}" y="{y:.2}" font-family="sans-serif" font-size="{size:.1}" text-anchor="{anchor}">{}</text>"#,
            escape(content)
        );
    }

    /// Text rotated by −90° about its anchor (a vertical axis label).
    pub fn vertical_text(&mut self, x: f64, y: f64, size: f64, content: &str) {
        let _ = writeln!(
            self.body,
            r#"<text x="{x:.2}" y="{y:.2}" font-family="sans-serif" font-size="{size:.1}" text-anchor="middle" transform="rotate(-90 {x:.2} {y:.2})">{}</text>"#,
            escape(content)
        );
    }

    /// The document.
    pub fn finish(self) -> String {
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.0} {h:.0}\">\n{}</svg>\n",
            self.body,
            w = self.width,
            h = self.height
        )
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A linear map from data `[lo, hi]` onto pixels `[p0, p1]`.
#[derive(Debug, Clone, Copy)]
struct Axis {
    lo: f64,
    hi: f64,
    p0: f64,
    p1: f64,
}

impl Axis {
    fn map(&self, v: f64) -> f64 {
        self.p0 + (v - self.lo) / (self.hi - self.lo) * (self.p1 - self.p0)
    }

    /// Round tick values (steps of 1, 2 or 5 × 10^k, about five of them).
    fn ticks(&self) -> Vec<f64> {
        let raw = (self.hi - self.lo) / 5.0;
        let magnitude = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * magnitude)
            .find(|s| *s >= raw)
            .unwrap_or(10.0 * magnitude);
        let first = (self.lo / step).ceil() as i64;
        let last = (self.hi / step).floor() as i64;
        (first..=last).map(|k| k as f64 * step).collect()
    }
}

/// One point of the parity plot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParityPoint {
    /// Simulated angle, degrees.
    pub simulated: f64,
    /// Predicted angle, degrees.
    pub predicted: f64,
    /// True for a training row, false for a validation row.
    pub train: bool,
}

/// Predicted against simulated angle with the 1:1 line; training rows as blue
/// circles, validation rows as orange squares; `legend` lines top left.
pub fn parity_plot(points: &[ParityPoint], title: &str, legend: &[String]) -> String {
    let (size, margin) = (520.0, 64.0);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for p in points {
        lo = lo.min(p.simulated).min(p.predicted);
        hi = hi.max(p.simulated).max(p.predicted);
    }
    if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
        lo -= 1.0;
        hi += 1.0;
    }
    let pad = 0.05 * (hi - lo);
    let (lo, hi) = (lo - pad, hi + pad);
    let x = Axis {
        lo,
        hi,
        p0: margin,
        p1: size - 16.0,
    };
    let y = Axis {
        lo,
        hi,
        p0: size - margin,
        p1: 40.0,
    };
    let mut svg = Svg::new(size, size);
    svg.text(size / 2.0, 24.0, 15.0, "middle", title);
    frame(&mut svg, &x, &y);
    for t in x.ticks() {
        svg.line(x.map(t), y.p0, x.map(t), y.p0 + 5.0, "#333", 1.0);
        svg.text(x.map(t), y.p0 + 18.0, 11.0, "middle", &format!("{t}"));
        svg.line(x.p0 - 5.0, y.map(t), x.p0, y.map(t), "#333", 1.0);
        svg.text(x.p0 - 8.0, y.map(t) + 4.0, 11.0, "end", &format!("{t}"));
    }
    svg.text(
        (x.p0 + x.p1) / 2.0,
        size - 16.0,
        13.0,
        "middle",
        "simulated angle (deg)",
    );
    svg.vertical_text(18.0, (y.p0 + y.p1) / 2.0, 13.0, "predicted angle (deg)");
    svg.line(x.map(lo), y.map(lo), x.map(hi), y.map(hi), "#999", 1.0);
    for p in points.iter().filter(|p| p.train) {
        svg.circle(
            x.map(p.simulated),
            y.map(p.predicted),
            3.5,
            PALETTE[0],
            "none",
        );
    }
    for p in points.iter().filter(|p| !p.train) {
        let (cx, cy) = (x.map(p.simulated), y.map(p.predicted));
        svg.rect(cx - 3.5, cy - 3.5, 7.0, 7.0, PALETTE[1], "#333");
    }
    for (i, line) in legend.iter().enumerate() {
        let ly = 58.0 + 18.0 * i as f64;
        match i {
            0 => svg.circle(x.p0 + 14.0, ly - 4.0, 3.5, PALETTE[0], "none"),
            1 => svg.rect(x.p0 + 10.5, ly - 7.5, 7.0, 7.0, PALETTE[1], "#333"),
            _ => {}
        }
        svg.text(x.p0 + 24.0, ly, 12.0, "start", line);
    }
    svg.finish()
}

fn frame(svg: &mut Svg, x: &Axis, y: &Axis) {
    svg.rect(x.p0, y.p1, x.p1 - x.p0, y.p0 - y.p1, "none", "#333");
}

/// One size of the learning curve plot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvePoint {
    /// DEM runs trained on.
    pub size: usize,
    /// Validation R² of the kept network.
    pub validation_r2: f64,
    /// Mean relative spread of the kept search points (none if nothing kept).
    pub relative_spread: Option<f64>,
    /// Summed DEM wall time of the runs, s.
    pub dem_wall_s: f64,
}

/// The learning curve: validation R² (top panel) and the calibrated
/// parameters' relative spread (bottom panel) against the number of DEM runs,
/// each R² point labelled with the DEM wall time it cost.
pub fn learning_curve_plot(points: &[CurvePoint], title: &str) -> String {
    let (width, height, margin) = (560.0, 560.0, 64.0);
    let max_n = points.iter().map(|p| p.size).max().unwrap_or(1) as f64;
    let x = Axis {
        lo: 0.0,
        hi: max_n * 1.05,
        p0: margin,
        p1: width - 24.0,
    };
    let r2_lo = points
        .iter()
        .map(|p| p.validation_r2)
        .fold(0.0, f64::min)
        .max(-1.0);
    let top = Axis {
        lo: r2_lo,
        hi: 1.0,
        p0: 260.0,
        p1: 48.0,
    };
    let spread_hi = points
        .iter()
        .filter_map(|p| p.relative_spread)
        .fold(0.0, f64::max)
        .max(0.05)
        * 1.1;
    let bottom = Axis {
        lo: 0.0,
        hi: spread_hi,
        p0: height - margin,
        p1: 310.0,
    };
    let mut svg = Svg::new(width, height);
    svg.text(width / 2.0, 24.0, 15.0, "middle", title);
    for (y, label) in [
        (&top, "validation R²"),
        (&bottom, "relative spread of kept points"),
    ] {
        frame(&mut svg, &x, y);
        for t in y.ticks() {
            svg.line(x.p0 - 5.0, y.map(t), x.p0, y.map(t), "#333", 1.0);
            svg.text(x.p0 - 8.0, y.map(t) + 4.0, 11.0, "end", &format!("{t}"));
        }
        for t in x.ticks() {
            svg.line(x.map(t), y.p0, x.map(t), y.p0 + 5.0, "#333", 1.0);
            svg.text(x.map(t), y.p0 + 18.0, 11.0, "middle", &format!("{t}"));
        }
        svg.vertical_text(18.0, (y.p0 + y.p1) / 2.0, 13.0, label);
    }
    svg.text(
        (x.p0 + x.p1) / 2.0,
        height - 16.0,
        13.0,
        "middle",
        "DEM runs in the training set",
    );
    let mut previous: Option<(f64, f64)> = None;
    for p in points {
        let (cx, cy) = (x.map(p.size as f64), top.map(p.validation_r2.max(r2_lo)));
        if let Some((px, py)) = previous {
            svg.line(px, py, cx, cy, PALETTE[0], 1.5);
        }
        previous = Some((cx, cy));
        svg.circle(cx, cy, 4.0, PALETTE[0], "none");
        svg.text(
            cx,
            cy - 9.0,
            10.0,
            "middle",
            &format!("{:.0} s", p.dem_wall_s),
        );
    }
    let mut previous: Option<(f64, f64)> = None;
    for p in points {
        let Some(spread) = p.relative_spread else {
            previous = None;
            continue;
        };
        let (cx, cy) = (x.map(p.size as f64), bottom.map(spread));
        if let Some((px, py)) = previous {
            svg.line(px, py, cx, cy, PALETTE[1], 1.5);
        }
        previous = Some((cx, cy));
        svg.rect(cx - 3.5, cy - 3.5, 7.0, 7.0, PALETTE[1], "#333");
    }
    svg.finish()
}

/// The scatter matrix of kept search points: cell (row i, column j) plots
/// parameter j (x) against parameter i (y) in unit coordinates of the study
/// ranges, points coloured by cluster, cluster centres as black crosses; the
/// diagonal names each parameter with its physical range.
pub fn scatter_matrix(
    names: &[String],
    ranges: &[(f64, f64)],
    points: &[Vec<f64>],
    labels: &[usize],
    centres: &[Vec<f64>],
    title: &str,
) -> String {
    let d = names.len();
    let (cell, gap, margin) = (150.0, 8.0, 30.0);
    let width = margin * 2.0 + d as f64 * (cell + gap);
    let legend_height = 24.0;
    let mut svg = Svg::new(width, width + legend_height);
    svg.text(width / 2.0, 20.0, 15.0, "middle", title);
    let origin = |k: usize| margin + k as f64 * (cell + gap);
    for i in 0..d {
        for j in 0..d {
            let (x0, y0) = (origin(j), origin(i) + 10.0);
            let xa = Axis {
                lo: 0.0,
                hi: 1.0,
                p0: x0,
                p1: x0 + cell,
            };
            let ya = Axis {
                lo: 0.0,
                hi: 1.0,
                p0: y0 + cell,
                p1: y0,
            };
            frame(&mut svg, &xa, &ya);
            if i == j {
                // Addresses are long (particle_wall.*.static_friction): one
                // line per dotted part.
                let parts: Vec<&str> = names[i].split('.').collect();
                let top = y0 + cell / 2.0 - 7.0 * parts.len() as f64;
                for (k, part) in parts.iter().enumerate() {
                    svg.text(x0 + cell / 2.0, top + 14.0 * k as f64, 11.0, "middle", part);
                }
                let (lo, hi) = ranges[i];
                svg.text(
                    x0 + cell / 2.0,
                    top + 14.0 * parts.len() as f64 + 6.0,
                    10.0,
                    "middle",
                    &format!("{lo} – {hi}"),
                );
                continue;
            }
            for (p, &label) in points.iter().zip(labels) {
                let colour = PALETTE[label % PALETTE.len()];
                svg.circle(xa.map(p[j]), ya.map(p[i]), 2.2, colour, "none");
            }
            for c in centres {
                let (cx, cy) = (xa.map(c[j]), ya.map(c[i]));
                svg.line(cx - 5.0, cy, cx + 5.0, cy, "#000", 1.5);
                svg.line(cx, cy - 5.0, cx, cy + 5.0, "#000", 1.5);
            }
        }
    }
    let ly = width + 8.0;
    for (k, _) in centres.iter().enumerate() {
        let lx = margin + 90.0 * k as f64;
        svg.circle(lx + 5.0, ly, 4.0, PALETTE[k % PALETTE.len()], "none");
        svg.text(
            lx + 14.0,
            ly + 4.0,
            11.0,
            "start",
            &format!("cluster {}", k + 1),
        );
    }
    svg.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside() {
        let a = Axis {
            lo: 31.1,
            hi: 55.2,
            p0: 0.0,
            p1: 1.0,
        };
        assert_eq!(a.ticks(), vec![35.0, 40.0, 45.0, 50.0, 55.0]);
    }

    #[test]
    fn text_is_escaped() {
        let mut s = Svg::new(10.0, 10.0);
        s.text(0.0, 0.0, 10.0, "start", "R² < 1 & > 0");
        assert!(s.finish().contains("R² &lt; 1 &amp; &gt; 0"));
    }
}
