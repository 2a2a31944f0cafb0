//! Plots drawn with `plotters` (SVG backend only): predicted against actual
//! values, contour maps of a response over two factors, and per-factor level
//! means with confidence intervals.
//!
//! Every function checks its input first (an empty series, a non-finite value
//! or mismatched lengths is a [`PlotError`] naming what is wrong), then returns
//! the SVG document as a `String` for the caller to write atomically. Text is
//! written as SVG `<text>` elements, so no system font is read, and nothing in
//! the output depends on the time or the machine: identical inputs give
//! identical bytes. Tick labels are formatted here (up to four significant
//! digits), not by `plotters`' defaults.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Why a plot could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// There is nothing to plot.
    #[error("{what}: nothing to plot")]
    Empty {
        /// Which input is empty.
        what: String,
    },
    /// A value is NaN or infinite.
    #[error("{what} is {value}, not a finite number")]
    NotFinite {
        /// Which value, e.g. `point 3: predicted`.
        what: String,
        /// The value.
        value: f64,
    },
    /// The input's parts do not fit together (lengths, order, signs).
    #[error("{0}")]
    Shape(String),
    /// `plotters` failed while drawing.
    #[error("drawing the plot failed: {0}")]
    Draw(String),
}

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for PlotError {
    fn from(e: DrawingAreaErrorKind<E>) -> PlotError {
        PlotError::Draw(e.to_string())
    }
}

/// Font family of all text (generic, so no font file is needed).
const FONT: &str = "sans-serif";
/// Colour of the data points and lines.
const INK: RGBColor = RGBColor(0x4e, 0x79, 0xa7);

/// `value` if finite, else an error naming it.
fn finite(what: impl FnOnce() -> String, value: f64) -> Result<f64, PlotError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(PlotError::NotFinite {
            what: what(),
            value,
        })
    }
}

/// The range `lo..hi` widened by 5 % on each side (or by 1 when it is a point),
/// so nothing sits on the frame.
fn padded(lo: f64, hi: f64) -> std::ops::Range<f64> {
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        0.05 * lo.abs().max(hi.abs()).max(1.0)
    };
    (lo - pad)..(hi + pad)
}

/// Smallest and largest of `values` (which must be non-empty).
fn extent(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    })
}

/// A tick label: up to four significant digits, trailing zeros dropped,
/// exponent notation for very large or small magnitudes.
fn tick(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v.is_finite() {
            "0".to_string()
        } else {
            v.to_string()
        };
    }
    let magnitude = v.abs().log10().floor() as i32;
    if !(-3..5).contains(&magnitude) {
        return format!("{v:.2e}");
    }
    let decimals = (3 - magnitude).max(0) as usize;
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" {
        "0".to_string()
    } else {
        s
    }
}

/// `text` with its unit in parentheses, or alone when the unit is empty.
fn with_unit(text: &str, unit: &str) -> String {
    if unit.is_empty() {
        text.to_string()
    } else {
        format!("{text} ({unit})")
    }
}

/// Predicted against actual values, with the y = x line and a note of n, R²
/// and RMSE. `points` are `(actual, predicted)`; `unit` labels both axes.
pub fn predicted_vs_actual(
    points: &[(f64, f64)],
    title: &str,
    unit: &str,
) -> Result<String, PlotError> {
    if points.is_empty() {
        return Err(PlotError::Empty {
            what: "predicted vs actual: points".to_string(),
        });
    }
    for (i, &(a, p)) in points.iter().enumerate() {
        finite(|| format!("point {i}: actual"), a)?;
        finite(|| format!("point {i}: predicted"), p)?;
    }
    let (lo, hi) = extent(points.iter().flat_map(|&(a, p)| [a, p]));
    let range = padded(lo, hi);
    let n = points.len() as f64;
    let mean = points.iter().map(|p| p.0).sum::<f64>() / n;
    let residual: f64 = points.iter().map(|(a, p)| (p - a).powi(2)).sum();
    let total: f64 = points.iter().map(|(a, _)| (a - mean).powi(2)).sum();
    let mut note = format!(
        "n = {}, RMSE = {}",
        points.len(),
        tick((residual / n).sqrt())
    );
    if !unit.is_empty() {
        note.push_str(&format!(" {unit}"));
    }
    if total > 0.0 {
        note.push_str(&format!(", R² = {:.3}", 1.0 - residual / total));
    }

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (560, 560)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, (FONT, 18))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(60)
            .build_cartesian_2d(range.clone(), range.clone())?;
        chart
            .configure_mesh()
            .x_desc(with_unit("actual", unit))
            .y_desc(with_unit("predicted", unit))
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 12))
            .light_line_style(BLACK.mix(0.04))
            .draw()?;
        chart.draw_series(std::iter::once(DashedPathElement::new(
            vec![(range.start, range.start), (range.end, range.end)],
            6,
            4,
            BLACK.stroke_width(1),
        )))?;
        chart.draw_series(
            points
                .iter()
                .map(|&(a, p)| Circle::new((a, p), 3, INK.mix(0.8).filled())),
        )?;
        chart.draw_series(std::iter::once(Text::new(
            note,
            (
                range.start + 0.03 * (range.end - range.start),
                range.end - 0.03 * (range.end - range.start),
            ),
            (FONT, 13),
        )))?;
        root.present()?;
    }
    Ok(svg)
}

/// A response `z` over a grid of two factors, for [`contour`].
#[derive(Debug, Clone, PartialEq)]
pub struct ContourGrid {
    /// Name of the horizontal factor (with its unit).
    pub x_label: String,
    /// Name of the vertical factor (with its unit).
    pub y_label: String,
    /// Grid values of the horizontal factor, strictly increasing, at least two.
    pub x: Vec<f64>,
    /// Grid values of the vertical factor, strictly increasing, at least two.
    pub y: Vec<f64>,
    /// The response: `z[iy][ix]` at `(x[ix], y[iy])`.
    pub z: Vec<Vec<f64>>,
    /// Name of the response (with its unit), shown on the colour bar.
    pub z_label: String,
    /// Points to mark, such as an optimum: `(x, y, label)`.
    pub markers: Vec<(f64, f64, String)>,
}

impl ContourGrid {
    /// Checks sizes, order and finiteness; returns the range of `z`.
    fn check(&self) -> Result<(f64, f64), PlotError> {
        for (axis, values) in [("x", &self.x), ("y", &self.y)] {
            if values.is_empty() {
                return Err(PlotError::Empty {
                    what: format!("contour: {axis}"),
                });
            }
            for (i, v) in values.iter().enumerate() {
                finite(|| format!("contour: {axis}[{i}]"), *v)?;
            }
            if values.len() < 2 {
                return Err(PlotError::Shape(format!(
                    "contour: {axis} has 1 value, at least 2 are needed"
                )));
            }
            if let Some(i) = values.windows(2).position(|w| w[1] <= w[0]) {
                return Err(PlotError::Shape(format!(
                    "contour: {axis} must increase, but {axis}[{}] = {} follows {}",
                    i + 1,
                    values[i + 1],
                    values[i]
                )));
            }
        }
        if self.z.len() != self.y.len() {
            return Err(PlotError::Shape(format!(
                "contour: z has {} rows, y has {} values",
                self.z.len(),
                self.y.len()
            )));
        }
        for (iy, row) in self.z.iter().enumerate() {
            if row.len() != self.x.len() {
                return Err(PlotError::Shape(format!(
                    "contour: z[{iy}] has {} values, x has {}",
                    row.len(),
                    self.x.len()
                )));
            }
            for (ix, v) in row.iter().enumerate() {
                finite(|| format!("contour: z[{iy}][{ix}]"), *v)?;
            }
        }
        for (i, (x, y, label)) in self.markers.iter().enumerate() {
            finite(|| format!("contour: marker {i} ({label}) x"), *x)?;
            finite(|| format!("contour: marker {i} ({label}) y"), *y)?;
        }
        Ok(extent(self.z.iter().flatten().copied()))
    }
}

/// About `target` round levels strictly inside `lo..hi` (steps of 1, 2 or 5
/// times a power of ten); none when the range is a point.
fn levels(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    if hi <= lo {
        return Vec::new();
    }
    let raw = (hi - lo) / target as f64;
    let power = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * power);
    let first = (lo / step).floor() as i64 + 1;
    (first..)
        .map(|k| k as f64 * step)
        .take_while(|v| *v < hi)
        .filter(|v| *v > lo)
        .collect()
}

/// A perceptually ordered colour map (viridis, linearly interpolated between
/// nine of its colours); `t` in 0..=1.
fn colour(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A straight piece of an iso-line, between two points of the plane.
type Segment = [(f64, f64); 2];

/// An iso-line: its level and its segments.
type IsoLine = (f64, Vec<Segment>);

/// The iso-line segments of `level` by marching squares, in grid order. A
/// saddle cell is resolved by the mean of its corners.
fn iso_segments(grid: &ContourGrid, level: f64) -> Vec<Segment> {
    let (x, y, z) = (&grid.x, &grid.y, &grid.z);
    let mut out = Vec::new();
    for iy in 0..y.len() - 1 {
        for ix in 0..x.len() - 1 {
            // Corners counter-clockwise from bottom left.
            let corners = [
                (x[ix], y[iy], z[iy][ix]),
                (x[ix + 1], y[iy], z[iy][ix + 1]),
                (x[ix + 1], y[iy + 1], z[iy + 1][ix + 1]),
                (x[ix], y[iy + 1], z[iy + 1][ix]),
            ];
            // Where the level crosses edge k (from corner k to corner k + 1).
            let crossing = |k: usize| {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                let above = (a.2 >= level, b.2 >= level);
                (above.0 != above.1).then(|| {
                    let t = (level - a.2) / (b.2 - a.2);
                    (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
                })
            };
            let edges: Vec<(usize, (f64, f64))> =
                (0..4).filter_map(|k| crossing(k).map(|p| (k, p))).collect();
            match edges.len() {
                2 => out.push([edges[0].1, edges[1].1]),
                4 => {
                    // Saddle: join the crossings around the corners on the
                    // centre's other side.
                    let centre = corners.iter().map(|c| c.2).sum::<f64>() / 4.0;
                    let corner0_high = corners[0].2 >= level;
                    if (centre >= level) == corner0_high {
                        out.push([edges[0].1, edges[3].1]);
                        out.push([edges[1].1, edges[2].1]);
                    } else {
                        out.push([edges[0].1, edges[1].1]);
                        out.push([edges[2].1, edges[3].1]);
                    }
                }
                _ => {}
            }
        }
    }
    out
}

/// A filled colour map of `grid.z` over `grid.x` × `grid.y`, with iso-lines at
/// round levels (each labelled with its value), a colour bar and the grid's
/// markers.
pub fn contour(grid: &ContourGrid, title: &str) -> Result<String, PlotError> {
    let (z_lo, z_hi) = grid.check()?;
    let span = z_hi - z_lo;
    let shade = |v: f64| colour(if span > 0.0 { (v - z_lo) / span } else { 0.5 });
    let shade = &shade;
    let lines: Vec<IsoLine> = levels(z_lo, z_hi, 8)
        .into_iter()
        .map(|l| (l, iso_segments(grid, l)))
        .filter(|(_, s)| !s.is_empty())
        .collect();
    let (x, y, z) = (&grid.x, &grid.y, &grid.z);
    let (x_range, y_range) = (x[0]..x[x.len() - 1], y[0]..y[y.len() - 1]);

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 560)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(title, (FONT, 18))?;
        let (plot, bar) = root.split_horizontally(640);
        let mut chart = ChartBuilder::on(&plot)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x_range.clone(), y_range.clone())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(grid.x_label.as_str())
            .y_desc(grid.y_label.as_str())
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 12))
            .draw()?;
        // One rectangle per grid cell, coloured by the mean of its corners.
        chart.draw_series((0..y.len() - 1).flat_map(|iy| {
            (0..x.len() - 1).map(move |ix| {
                let mean = (z[iy][ix] + z[iy][ix + 1] + z[iy + 1][ix] + z[iy + 1][ix + 1]) / 4.0;
                Rectangle::new(
                    [(x[ix], y[iy]), (x[ix + 1], y[iy + 1])],
                    shade(mean).filled(),
                )
            })
        }))?;
        for (level, segments) in &lines {
            chart.draw_series(
                segments
                    .iter()
                    .map(|s| PathElement::new(s.to_vec(), BLACK.mix(0.7).stroke_width(1))),
            )?;
            // The label sits on the middle segment (in grid order).
            let s = segments[segments.len() / 2];
            let at = ((s[0].0 + s[1].0) / 2.0, (s[0].1 + s[1].1) / 2.0);
            chart.draw_series(std::iter::once(Text::new(
                tick(*level),
                at,
                (FONT, 11).into_font().color(&BLACK),
            )))?;
        }
        for (mx, my, label) in &grid.markers {
            chart.draw_series(std::iter::once(Cross::new(
                (*mx, *my),
                6,
                RED.stroke_width(2),
            )))?;
            chart.draw_series(std::iter::once(Text::new(
                format!(" {label}"),
                (*mx, *my),
                (FONT, 13).into_font().color(&RED),
            )))?;
        }
        colour_bar(&bar, z_lo, z_hi, &lines, &grid.z_label, shade)?;
        root.present()?;
    }
    Ok(svg)
}

/// The colour bar of [`contour`]: a gradient from `lo` (bottom) to `hi` (top),
/// its ends and iso-line levels labelled, the response's name above it.
fn colour_bar(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    lo: f64,
    hi: f64,
    lines: &[IsoLine],
    label: &str,
    shade: &dyn Fn(f64) -> RGBColor,
) -> Result<(), PlotError> {
    let (top, bottom, left, width) = (40i32, 500i32, 12i32, 18i32);
    let steps = 64;
    let height = (bottom - top) as f64;
    let to_y = |v: f64| {
        if hi > lo {
            bottom - ((v - lo) / (hi - lo) * height).round() as i32
        } else {
            (top + bottom) / 2
        }
    };
    for k in 0..steps {
        let (y0, y1) = (
            bottom - (k as f64 * height / steps as f64).round() as i32,
            bottom - ((k + 1) as f64 * height / steps as f64).round() as i32,
        );
        let v = lo + (k as f64 + 0.5) / steps as f64 * (hi - lo);
        area.draw(&Rectangle::new(
            [(left, y1), (left + width, y0)],
            shade(v).filled(),
        ))?;
    }
    area.draw(&Rectangle::new(
        [(left, top), (left + width, bottom)],
        BLACK.stroke_width(1),
    ))?;
    area.draw(&Text::new(label.to_string(), (left, top - 16), (FONT, 12)))?;
    // The iso-line levels, and the ends unless a level's label is too close.
    let mut ticks: Vec<f64> = lines.iter().map(|(l, _)| *l).collect();
    for end in [lo, hi] {
        if ticks.iter().all(|t| (to_y(*t) - to_y(end)).abs() >= 14) {
            ticks.push(end);
        }
    }
    for v in ticks {
        let y = to_y(v);
        area.draw(&PathElement::new(
            vec![(left + width, y), (left + width + 4, y)],
            BLACK.stroke_width(1),
        ))?;
        area.draw(&Text::new(
            tick(v),
            (left + width + 6, y),
            TextStyle::from((FONT, 11).into_font()).pos(Pos::new(HPos::Left, VPos::Center)),
        ))?;
    }
    Ok(())
}

/// One factor's panel of [`level_means`].
#[derive(Debug, Clone, PartialEq)]
pub struct LevelPanel {
    /// The factor's name (x axis).
    pub factor: String,
    /// The factor's unit (empty for none).
    pub unit: String,
    /// The response's name with its unit (y axis); panels with the same
    /// response share the y range, so their effects compare by eye.
    pub response: String,
    /// The factor's levels.
    pub levels: Vec<f64>,
    /// The response's mean at each level.
    pub means: Vec<f64>,
    /// Half-width of the 95 % confidence interval of each mean (≥ 0).
    pub ci_half: Vec<f64>,
    /// A line under the panel's name, e.g. the one-way ANOVA p-value.
    pub note: String,
}

impl LevelPanel {
    /// Checks lengths, finiteness and signs; `i` numbers the panel in errors.
    fn check(&self, i: usize) -> Result<(), PlotError> {
        let name = format!("level means: panel {i} ({})", self.factor);
        if self.levels.is_empty() {
            return Err(PlotError::Empty {
                what: format!("{name}: levels"),
            });
        }
        if self.means.len() != self.levels.len() || self.ci_half.len() != self.levels.len() {
            return Err(PlotError::Shape(format!(
                "{name}: {} levels, {} means, {} CI half-widths",
                self.levels.len(),
                self.means.len(),
                self.ci_half.len()
            )));
        }
        for (what, values) in [
            ("level", &self.levels),
            ("mean", &self.means),
            ("CI half-width", &self.ci_half),
        ] {
            for (k, v) in values.iter().enumerate() {
                finite(|| format!("{name}: {what} {k}"), *v)?;
            }
        }
        if let Some(k) = self.ci_half.iter().position(|h| *h < 0.0) {
            return Err(PlotError::Shape(format!(
                "{name}: CI half-width {k} is {}, must be ≥ 0",
                self.ci_half[k]
            )));
        }
        Ok(())
    }

    /// The lowest and highest end of the CIs.
    fn span(&self) -> (f64, f64) {
        extent(
            self.means
                .iter()
                .zip(&self.ci_half)
                .flat_map(|(m, h)| [m - h, m + h]),
        )
    }
}

/// One panel per factor (at most three a row): the response's mean at each
/// level with its 95 % CI as an error bar, the means joined by a line.
pub fn level_means(panels: &[LevelPanel], title: &str) -> Result<String, PlotError> {
    if panels.is_empty() {
        return Err(PlotError::Empty {
            what: "level means: panels".to_string(),
        });
    }
    for (i, p) in panels.iter().enumerate() {
        p.check(i)?;
    }
    let columns = panels.len().min(3);
    let rows = panels.len().div_ceil(columns);
    let (panel_w, panel_h) = (360u32, 320u32);

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(
            &mut svg,
            (panel_w * columns as u32, panel_h * rows as u32 + 40),
        )
        .into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(title, (FONT, 18))?;
        for (panel, area) in panels.iter().zip(root.split_evenly((rows, columns))) {
            // The y range is shared by the panels of the same response.
            let (lo, hi) = panels
                .iter()
                .filter(|p| p.response == panel.response)
                .map(LevelPanel::span)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |a, b| {
                    (a.0.min(b.0), a.1.max(b.1))
                });
            let (x_lo, x_hi) = extent(panel.levels.iter().copied());
            let x_range = padded(x_lo, x_hi);
            let caption = if panel.note.is_empty() {
                panel.factor.clone()
            } else {
                format!("{} — {}", panel.factor, panel.note)
            };
            let mut chart = ChartBuilder::on(&area)
                .caption(caption, (FONT, 14))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(56)
                .build_cartesian_2d(x_range.clone(), padded(lo, hi))?;
            chart
                .configure_mesh()
                .x_labels(6)
                .x_desc(with_unit(&panel.factor, &panel.unit))
                .y_desc(panel.response.as_str())
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v))
                .label_style((FONT, 11))
                .light_line_style(BLACK.mix(0.04))
                .draw()?;
            let mut order: Vec<usize> = (0..panel.levels.len()).collect();
            order.sort_by(|a, b| panel.levels[*a].total_cmp(&panel.levels[*b]));
            chart.draw_series(LineSeries::new(
                order.iter().map(|&k| (panel.levels[k], panel.means[k])),
                INK.stroke_width(1),
            ))?;
            let cap = 0.015 * (x_range.end - x_range.start);
            for k in order {
                let (x, m, h) = (panel.levels[k], panel.means[k], panel.ci_half[k]);
                chart.draw_series([
                    PathElement::new(vec![(x, m - h), (x, m + h)], INK.stroke_width(1)),
                    PathElement::new(
                        vec![(x - cap, m - h), (x + cap, m - h)],
                        INK.stroke_width(1),
                    ),
                    PathElement::new(
                        vec![(x - cap, m + h), (x + cap, m + h)],
                        INK.stroke_width(1),
                    ),
                ])?;
                chart.draw_series(std::iter::once(Circle::new((x, m), 4, INK.filled())))?;
            }
        }
        root.present()?;
    }
    Ok(svg)
}

/// One series of [`curves`]: measured points and the fitted model drawn
/// through them, in one colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Legend text.
    pub label: String,
    /// Measured (x, y) points, drawn as dots.
    pub points: Vec<(f64, f64)>,
    /// The model's (x, y) values, drawn as a line (may be empty).
    pub fit: Vec<(f64, f64)>,
}

/// Palette of [`curves`] (Tableau 10, colour-blind friendly), cycled.
const PALETTE: [RGBColor; 6] = [
    RGBColor(0x4e, 0x79, 0xa7),
    RGBColor(0xf2, 0x8e, 0x2b),
    RGBColor(0xe1, 0x57, 0x59),
    RGBColor(0x59, 0xa1, 0x4f),
    RGBColor(0xb0, 0x7a, 0xa1),
    RGBColor(0x76, 0xb7, 0xb2),
];

/// Several measured series with their fitted models on one pair of axes
/// (e.g. flow rate against time with yan2015 Eq. 20 through each run), with
/// a legend. `x_label` and `y_label` include their units.
pub fn curves(
    series: &[Curve],
    title: &str,
    x_label: &str,
    y_label: &str,
) -> Result<String, PlotError> {
    if series.iter().all(|c| c.points.is_empty()) {
        return Err(PlotError::Empty {
            what: "curves: points".to_string(),
        });
    }
    for (i, c) in series.iter().enumerate() {
        for (k, (x, y)) in c.points.iter().chain(&c.fit).enumerate() {
            finite(|| format!("curve {i} ({}): x {k}", c.label), *x)?;
            finite(|| format!("curve {i} ({}): y {k}", c.label), *y)?;
        }
    }
    let all = || series.iter().flat_map(|c| c.points.iter().chain(&c.fit));
    let (x_lo, x_hi) = extent(all().map(|p| p.0));
    let (y_lo, y_hi) = extent(all().map(|p| p.1));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (720, 480)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, (FONT, 18))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(padded(x_lo, x_hi), padded(y_lo.min(0.0), y_hi))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 12))
            .light_line_style(BLACK.mix(0.04))
            .draw()?;
        for (i, c) in series.iter().enumerate() {
            let colour = PALETTE[i % PALETTE.len()];
            chart.draw_series(
                c.points
                    .iter()
                    .map(|&(x, y)| Circle::new((x, y), 2, colour.mix(0.7).filled())),
            )?;
            chart
                .draw_series(LineSeries::new(
                    c.fit.iter().copied(),
                    colour.stroke_width(2),
                ))?
                .label(c.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .label_font((FONT, 12))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}

/// One response's panel of [`size_trends`].
#[derive(Debug, Clone, PartialEq)]
pub struct TrendPanel {
    /// The response's name with its unit (y axis).
    pub response: String,
    /// Each level's (d/D, mean, 95 % half-width).
    pub levels: Vec<(f64, f64, f64)>,
    /// The fitted line as (d/D, mean, 95 % half-width of the line), drawn
    /// solid with its interval dashed; may be empty.
    pub fit: Vec<(f64, f64, f64)>,
    /// The extrapolated value at the real size, (d/D, mean, half-width).
    pub extrapolated: Option<(f64, f64, f64)>,
}

/// The cost panel of [`size_trends`]: CPU-seconds per run against d/D on
/// log axes.
#[derive(Debug, Clone, PartialEq)]
pub struct CostPanel {
    /// Each run's (d/D, CPU-s).
    pub runs: Vec<(f64, f64)>,
    /// The fitted power law's (d/D, CPU-s); may be empty.
    pub fit: Vec<(f64, f64)>,
}

/// Colour of extrapolated values.
const EXTRAPOLATED: RGBColor = RGBColor(0xe1, 0x57, 0x59);

/// A response against particle size (one panel per response: each level's
/// mean with its 95 % interval, the fitted line and its interval, and the
/// value extrapolated to the real size in red), then the cost per run
/// against size on log axes.
pub fn size_trends(
    panels: &[TrendPanel],
    cost: Option<&CostPanel>,
    title: &str,
) -> Result<String, PlotError> {
    if panels.is_empty() && cost.is_none() {
        return Err(PlotError::Empty {
            what: "size trends: panels".to_string(),
        });
    }
    for (i, p) in panels.iter().enumerate() {
        if p.levels.is_empty() {
            return Err(PlotError::Empty {
                what: format!("size trends: panel {i} ({}) levels", p.response),
            });
        }
        let all = p.levels.iter().chain(&p.fit).chain(&p.extrapolated);
        for (k, (x, m, h)) in all.enumerate() {
            for v in [x, m, h] {
                finite(
                    || format!("size trends: panel {i} ({}) value {k}", p.response),
                    *v,
                )?;
            }
        }
    }
    if let Some(c) = cost {
        for (k, (x, y)) in c.runs.iter().chain(&c.fit).enumerate() {
            if !(x.is_finite() && *x > 0.0 && y.is_finite() && *y > 0.0) {
                return Err(PlotError::Shape(format!(
                    "size trends: cost point {k} ({x}, {y}) must be finite and > 0 (log axes)"
                )));
            }
        }
        if c.runs.is_empty() {
            return Err(PlotError::Empty {
                what: "size trends: cost runs".to_string(),
            });
        }
    }
    let count = panels.len() + usize::from(cost.is_some());
    let columns = count.min(3);
    let rows = count.div_ceil(columns);
    let (panel_w, panel_h) = (380u32, 330u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(
            &mut svg,
            (panel_w * columns as u32, panel_h * rows as u32 + 40),
        )
        .into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(title, (FONT, 18))?;
        let areas = root.split_evenly((rows, columns));
        for (panel, area) in panels.iter().zip(&areas) {
            let spans = panel
                .levels
                .iter()
                .chain(&panel.fit)
                .chain(&panel.extrapolated);
            let (x_lo, x_hi) = extent(spans.clone().map(|p| p.0));
            let (y_lo, y_hi) = extent(spans.flat_map(|&(_, m, h)| [m - h, m + h]));
            let x_range = padded(x_lo.min(0.0), x_hi);
            let mut chart = ChartBuilder::on(area)
                .caption(panel.response.as_str(), (FONT, 14))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(56)
                .build_cartesian_2d(x_range.clone(), padded(y_lo, y_hi))?;
            chart
                .configure_mesh()
                .x_labels(5)
                .x_desc("d/D")
                .y_desc(panel.response.as_str())
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v))
                .label_style((FONT, 11))
                .light_line_style(BLACK.mix(0.04))
                .draw()?;
            chart.draw_series(LineSeries::new(
                panel.fit.iter().map(|&(x, m, _)| (x, m)),
                INK.stroke_width(1),
            ))?;
            for sign in [-1.0, 1.0] {
                chart.draw_series(std::iter::once(DashedPathElement::new(
                    panel.fit.iter().map(|&(x, m, h)| (x, m + sign * h)),
                    4,
                    3,
                    INK.mix(0.6).stroke_width(1),
                )))?;
            }
            let cap = 0.015 * (x_range.end - x_range.start);
            let bars = panel
                .levels
                .iter()
                .map(|&p| (p, INK))
                .chain(panel.extrapolated.map(|p| (p, EXTRAPOLATED)));
            for ((x, m, h), colour) in bars {
                chart.draw_series([
                    PathElement::new(vec![(x, m - h), (x, m + h)], colour.stroke_width(1)),
                    PathElement::new(
                        vec![(x - cap, m - h), (x + cap, m - h)],
                        colour.stroke_width(1),
                    ),
                    PathElement::new(
                        vec![(x - cap, m + h), (x + cap, m + h)],
                        colour.stroke_width(1),
                    ),
                ])?;
                chart.draw_series(std::iter::once(Circle::new((x, m), 4, colour.filled())))?;
            }
        }
        if let (Some(c), Some(area)) = (cost, areas.get(panels.len())) {
            // Log axes drawn as log10 values on linear axes, so a range
            // narrower than a decade still gets tick labels (in real units).
            let log = |p: &(f64, f64)| (p.0.log10(), p.1.log10());
            let (x_lo, x_hi) = extent(c.runs.iter().chain(&c.fit).map(|p| log(p).0));
            let (y_lo, y_hi) = extent(c.runs.iter().chain(&c.fit).map(|p| log(p).1));
            let mut chart = ChartBuilder::on(area)
                .caption("cost per run (log axes)", (FONT, 14))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(56)
                .build_cartesian_2d(padded(x_lo, x_hi), padded(y_lo, y_hi))?;
            chart
                .configure_mesh()
                .x_labels(5)
                .y_labels(6)
                .x_desc("d/D")
                .y_desc("CPU-s per run")
                .x_label_formatter(&|v| tick(10f64.powf(*v)))
                .y_label_formatter(&|v| tick(10f64.powf(*v)))
                .label_style((FONT, 11))
                .light_line_style(BLACK.mix(0.04))
                .draw()?;
            chart.draw_series(LineSeries::new(c.fit.iter().map(log), INK.stroke_width(1)))?;
            chart.draw_series(
                c.runs
                    .iter()
                    .map(|p| Circle::new(log(p), 3, INK.mix(0.7).filled())),
            )?;
        }
        root.present()?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A change that makes a valid input invalid.
    type Spoil<T> = Box<dyn Fn(&mut T)>;

    fn bowl() -> ContourGrid {
        let x: Vec<f64> = (0..21).map(|i| i as f64 * 0.05).collect();
        let y: Vec<f64> = (0..17).map(|i| 10.0 + i as f64 * 2.5).collect();
        let z = y
            .iter()
            .map(|yv| {
                x.iter()
                    .map(|xv| 30.0 + 40.0 * (xv - 0.4).powi(2) + 0.01 * (yv - 25.0).powi(2))
                    .collect()
            })
            .collect();
        ContourGrid {
            x_label: "friction".into(),
            y_label: "restitution (%)".into(),
            x,
            y,
            z,
            z_label: "angle (deg)".into(),
            markers: vec![(0.4, 25.0, "optimum".into())],
        }
    }

    fn panels() -> Vec<LevelPanel> {
        ["friction", "rolling", "restitution", "density"]
            .iter()
            .enumerate()
            .map(|(i, f)| LevelPanel {
                factor: f.to_string(),
                unit: if i == 3 {
                    "kg/m³".into()
                } else {
                    String::new()
                },
                response: "angle (deg)".into(),
                levels: vec![0.1, 0.3, 0.5],
                means: vec![25.0 + i as f64, 28.0, 30.0 - i as f64],
                ci_half: vec![0.5, 0.7, 0.0],
                note: format!("ANOVA p = 0.0{i}"),
            })
            .collect()
    }

    fn looks_like_svg(svg: &str, title: &str) {
        assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(80)]);
        assert!(svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains(title), "title {title} missing");
        assert!(svg.contains("<text"));
    }

    #[test]
    fn predicted_vs_actual_draws_points_and_the_diagonal() {
        let points: Vec<(f64, f64)> = (0..30)
            .map(|i| (20.0 + i as f64 * 0.5, 20.3 + i as f64 * 0.48))
            .collect();
        let svg = predicted_vs_actual(&points, "Parity of the surrogate", "deg").unwrap();
        looks_like_svg(&svg, "Parity of the surrogate");
        assert!(svg.contains("predicted (deg)") && svg.contains("actual (deg)"));
        assert!(svg.contains("n = 30, RMSE = "), "note missing");
        assert_eq!(svg.matches("<circle").count(), 30);
        assert!(svg.contains("stroke-dasharray") || svg.matches("<polyline").count() > 1);
        assert_eq!(
            svg,
            predicted_vs_actual(&points, "Parity of the surrogate", "deg").unwrap()
        );
        // One point, or all points equal, still plot.
        predicted_vs_actual(&[(1.0, 1.0)], "one", "").unwrap();
    }

    #[test]
    fn predicted_vs_actual_refuses_empty_or_non_finite_input() {
        let err = predicted_vs_actual(&[], "t", "deg")
            .unwrap_err()
            .to_string();
        assert_eq!(err, "predicted vs actual: points: nothing to plot");
        let err = predicted_vs_actual(&[(1.0, 2.0), (1.0, f64::NAN)], "t", "deg")
            .unwrap_err()
            .to_string();
        assert_eq!(err, "point 1: predicted is NaN, not a finite number");
        let err = predicted_vs_actual(&[(f64::INFINITY, 2.0)], "t", "deg")
            .unwrap_err()
            .to_string();
        assert_eq!(err, "point 0: actual is inf, not a finite number");
    }

    #[test]
    fn contour_draws_colours_labelled_lines_bar_and_markers() {
        let grid = bowl();
        let svg = contour(&grid, "Angle over friction and restitution").unwrap();
        looks_like_svg(&svg, "Angle over friction and restitution");
        for text in ["friction", "restitution (%)", "angle (deg)", "optimum"] {
            assert!(svg.contains(text), "{text} missing");
        }
        assert!(svg.matches("<rect").count() >= 20 * 16 + 64);
        assert!(svg.matches("<polyline").count() > 20, "iso-lines missing");
        assert_eq!(
            svg,
            contour(&grid, "Angle over friction and restitution").unwrap()
        );
        // A flat response has no iso-lines but still plots.
        let mut flat = bowl();
        flat.z.iter_mut().flatten().for_each(|v| *v = 3.0);
        contour(&flat, "flat").unwrap();
    }

    #[test]
    fn contour_refuses_bad_grids_naming_the_fault() {
        let cases: Vec<(Spoil<ContourGrid>, &str)> = vec![
            (Box::new(|g| g.x.clear()), "contour: x: nothing to plot"),
            (
                Box::new(|g| g.y.truncate(1)),
                "contour: y has 1 value, at least 2 are needed",
            ),
            (
                Box::new(|g| g.x[3] = g.x[2]),
                "contour: x must increase, but x[3] = 0.1 follows 0.1",
            ),
            (
                Box::new(|g| g.z[2][3] = f64::NAN),
                "contour: z[2][3] is NaN, not a finite number",
            ),
            (
                Box::new(|g| g.z.pop().map(drop).unwrap_or(())),
                "contour: z has 16 rows, y has 17 values",
            ),
            (
                Box::new(|g| g.z[4].push(1.0)),
                "contour: z[4] has 22 values, x has 21",
            ),
            (
                Box::new(|g| g.markers[0].1 = f64::INFINITY),
                "contour: marker 0 (optimum) y is inf, not a finite number",
            ),
        ];
        for (spoil, message) in cases {
            let mut grid = bowl();
            spoil(&mut grid);
            assert_eq!(contour(&grid, "t").unwrap_err().to_string(), message);
        }
    }

    #[test]
    fn level_means_draws_one_panel_per_factor() {
        let panels = panels();
        let svg = level_means(&panels, "Main effects on the angle").unwrap();
        looks_like_svg(&svg, "Main effects on the angle");
        for p in &panels {
            assert!(
                svg.contains(&p.factor) && svg.contains(&p.note),
                "{}",
                p.factor
            );
        }
        assert!(svg.contains("density (kg/m³)"));
        assert_eq!(svg.matches("<circle").count(), 12);
        assert_eq!(
            svg,
            level_means(&panels, "Main effects on the angle").unwrap()
        );
        // A single level plots too.
        let mut one = panels[..1].to_vec();
        one[0].levels.truncate(1);
        one[0].means.truncate(1);
        one[0].ci_half.truncate(1);
        level_means(&one, "one").unwrap();
    }

    #[test]
    fn level_means_refuses_bad_panels_naming_the_fault() {
        let err = level_means(&[], "t").unwrap_err().to_string();
        assert_eq!(err, "level means: panels: nothing to plot");
        let cases: Vec<(Spoil<LevelPanel>, &str)> = vec![
            (
                Box::new(|p| p.levels.clear()),
                "level means: panel 1 (rolling): levels: nothing to plot",
            ),
            (
                Box::new(|p| p.means.pop().map(drop).unwrap_or(())),
                "level means: panel 1 (rolling): 3 levels, 2 means, 3 CI half-widths",
            ),
            (
                Box::new(|p| p.means[2] = f64::NEG_INFINITY),
                "level means: panel 1 (rolling): mean 2 is -inf, not a finite number",
            ),
            (
                Box::new(|p| p.ci_half[0] = -0.5),
                "level means: panel 1 (rolling): CI half-width 0 is -0.5, must be ≥ 0",
            ),
        ];
        for (spoil, message) in cases {
            let mut panels = panels();
            spoil(&mut panels[1]);
            assert_eq!(level_means(&panels, "t").unwrap_err().to_string(), message);
        }
    }

    #[test]
    fn ticks_and_levels_are_round() {
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(0.6000000000000001), "0.6");
        assert_eq!(tick(31.25), "31.25");
        assert_eq!(tick(12345.0), "12345");
        assert_eq!(tick(123456.0), "1.23e5");
        assert_eq!(tick(-0.00001), "-1.00e-5");
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(-0.00001 + 0.00001), "0");
        let l: Vec<String> = levels(0.0, 1.0, 8).into_iter().map(tick).collect();
        assert_eq!(l, ["0.2", "0.4", "0.6", "0.8"]);
        assert!(levels(2.0, 2.0, 8).is_empty());
    }

    #[test]
    fn marching_squares_finds_the_level_of_a_plane() {
        let grid = ContourGrid {
            x_label: "x".into(),
            y_label: "y".into(),
            x: vec![0.0, 1.0, 2.0],
            y: vec![0.0, 1.0],
            z: vec![vec![0.0, 1.0, 2.0], vec![0.0, 1.0, 2.0]],
            z_label: "z".into(),
            markers: Vec::new(),
        };
        let segments = iso_segments(&grid, 1.5);
        assert_eq!(segments.len(), 1);
        for (x, _) in segments[0] {
            assert!((x - 1.5).abs() < 1e-12);
        }
        // A saddle cell gives two segments.
        let saddle = ContourGrid {
            x: vec![0.0, 1.0],
            y: vec![0.0, 1.0],
            z: vec![vec![1.0, 0.0], vec![0.0, 1.0]],
            ..grid
        };
        assert_eq!(iso_segments(&saddle, 0.5).len(), 2);
    }

    /// Each level's bar, the extrapolated bar in red, the cost panel with
    /// labelled log ticks; identical input, identical bytes; bad input named.
    #[test]
    fn size_trends_draws_levels_extrapolation_and_cost() {
        let panel = TrendPanel {
            response: "angle (°)".into(),
            levels: vec![(0.064, 42.0, 1.5), (0.048, 43.0, 1.0), (0.032, 44.5, 0.8)],
            fit: vec![(0.001, 46.0, 2.0), (0.064, 42.0, 0.9)],
            extrapolated: Some((0.001, 46.0, 2.0)),
        };
        let cost = CostPanel {
            runs: vec![(0.064, 12.0), (0.048, 40.0), (0.032, 190.0)],
            fit: vec![(0.064, 12.0), (0.032, 190.0)],
        };
        let svg = size_trends(std::slice::from_ref(&panel), Some(&cost), "sizes").unwrap();
        assert_eq!(
            svg,
            size_trends(std::slice::from_ref(&panel), Some(&cost), "sizes").unwrap()
        );
        assert!(svg.contains("cost per run") && svg.contains("CPU-s per run"));
        assert!(
            svg.contains("#E15759"),
            "the extrapolated value is drawn in red"
        );
        let circles = svg.matches("<circle").count();
        assert_eq!(
            circles,
            3 + 1 + 3,
            "three levels, one extrapolation, three runs"
        );
        let mut bad = panel.clone();
        bad.levels[1].1 = f64::NAN;
        let err = size_trends(&[bad], None, "t").unwrap_err().to_string();
        assert!(err.contains("panel 0 (angle (°)) value 1"), "{err}");
        let zero = CostPanel {
            runs: vec![(0.05, 0.0)],
            fit: vec![],
        };
        let err = size_trends(&[], Some(&zero), "t").unwrap_err().to_string();
        assert!(err.contains("cost point 0"), "{err}");
    }
}
