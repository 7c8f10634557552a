//! Plots of experiments that compare runs: methods side by side (bar chart, the paper's
//! Table I as a picture), errors against the zone count (box and whiskers, the paper's
//! Fig. 4), errors against a forced zone offset (the paper's Fig. 7), lines against a common
//! x and rows of horizontal bars (a study's conditions).
//!
//! Every plot has two panels, position error (mm) and orientation error (degrees), and is
//! written as a PNG atomically. Like [`crate::plots`], text is drawn when a font is available.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::EvalError;
use crate::plots::{PlotConfig, border, padded, render_png};

const MEAN: RGBColor = RGBColor(30, 90, 200);
const MEDIAN: RGBColor = RGBColor(0, 150, 70);
const BOX: RGBColor = RGBColor(30, 90, 200);
const OUTLIER: RGBColor = RGBColor(210, 30, 30);

/// One bar group of [`plot_method_bars`]: a method and its errors.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodBar {
    /// Method name (x-axis label).
    pub name: String,
    /// Mean position error, mm (`None`: no frame localized).
    pub mean_position_mm: Option<f64>,
    /// Median position error, mm.
    pub median_position_mm: Option<f64>,
    /// Mean orientation error, degrees.
    pub mean_orientation_deg: Option<f64>,
    /// Median orientation error, degrees.
    pub median_orientation_deg: Option<f64>,
}

/// Box-and-whisker statistics of one sample (Tukey: whiskers at the most extreme values
/// within 1.5 IQR of the quartiles; the rest are outliers).
#[derive(Debug, Clone, PartialEq)]
pub struct BoxStats {
    /// First quartile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub q3: f64,
    /// Lower whisker end.
    pub lo: f64,
    /// Upper whisker end.
    pub hi: f64,
    /// Values beyond the whiskers.
    pub outliers: Vec<f64>,
}

impl BoxStats {
    /// Statistics of the finite values of `values` (`None` if there are none). Quartiles by
    /// linear interpolation between order statistics (numpy's default).
    pub fn new(values: &[f64]) -> Option<Self> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let q = |p: f64| crate::stats::percentile_sorted(&v, p);
        let (q1, median, q3) = (q(25.0), q(50.0), q(75.0));
        let iqr = q3 - q1;
        let (fence_lo, fence_hi) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
        let inside = v
            .iter()
            .copied()
            .filter(|&x| x >= fence_lo && x <= fence_hi);
        let lo = inside.clone().fold(f64::INFINITY, f64::min);
        let hi = inside.fold(f64::NEG_INFINITY, f64::max);
        let outliers = v
            .iter()
            .copied()
            .filter(|&x| x < fence_lo || x > fence_hi)
            .collect();
        Some(BoxStats {
            q1,
            median,
            q3,
            lo,
            hi,
            outliers,
        })
    }
}

/// One box of [`plot_error_boxes`]: an x position (e.g. the zone count) and the per-run
/// errors there.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxColumn {
    /// Position on the x axis (e.g. number of zones).
    pub x: f64,
    /// Errors of the runs at this x (e.g. each run's mean position error, mm).
    pub position_mm: Vec<f64>,
    /// Orientation errors of the runs at this x, degrees.
    pub orientation_deg: Vec<f64>,
}

/// One point of [`plot_error_curve`]: an x value and the errors there.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvePoint {
    /// Position on the x axis (e.g. the forced zone offset e).
    pub x: f64,
    /// Mean position error, mm.
    pub mean_position_mm: Option<f64>,
    /// Median position error, mm.
    pub median_position_mm: Option<f64>,
    /// Mean orientation error, degrees.
    pub mean_orientation_deg: Option<f64>,
    /// Median orientation error, degrees.
    pub median_orientation_deg: Option<f64>,
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Grid, axis labels and descriptions (with text), or a plain border (without).
fn axes(
    chart: &mut crate::plots::Chart<'_, '_>,
    text: bool,
    x_desc: &str,
    unit: &str,
    x: (f64, f64),
    y: (f64, f64),
) -> Result<(), String> {
    let mut mesh = chart.configure_mesh();
    mesh.light_line_style(RGBColor(235, 235, 235));
    if text {
        mesh.x_desc(x_desc)
            .y_desc(unit)
            .x_label_formatter(&tick_label)
            .y_label_formatter(&tick_label)
            .label_style(("sans-serif", 13));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| e.to_string())?;
    if !text {
        border(chart, x, y)?;
    }
    Ok(())
}

/// Without text: the plot area's background mesh without labels, and its border.
fn bare_frame(
    chart: &mut crate::plots::Chart<'_, '_>,
    x: (f64, f64),
    y: (f64, f64),
) -> Result<(), String> {
    chart
        .configure_mesh()
        .x_labels(0)
        .y_labels(0)
        .draw()
        .map_err(|e| e.to_string())?;
    border(chart, x, y)
}

/// An axis tick as a person writes it: `40` rather than `40.0`, `0.25` rather than
/// `0.25000000000000006`.
fn tick_label(v: &f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

fn panel_chart<'a, 'b>(
    area: &'a Area<'b>,
    text: bool,
    title: &str,
    x: (f64, f64),
    y: (f64, f64),
) -> Result<crate::plots::Chart<'a, 'b>, String> {
    let mut b = ChartBuilder::on(area);
    b.margin(15)
        .x_label_area_size(if text { 45 } else { 0 })
        .y_label_area_size(if text { 60 } else { 0 });
    if text {
        b.caption(title, ("sans-serif", 18));
    }
    b.build_cartesian_2d(x.0..x.1, y.0..y.1)
        .map_err(|e| e.to_string())
}

/// Draws mean and median errors per method as grouped bars (two panels) to `path`.
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_method_bars(
    methods: &[MethodBar],
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    let names: Vec<String> = methods.iter().map(|m| m.name.clone()).collect();
    let pos: Vec<(Option<f64>, Option<f64>)> = methods
        .iter()
        .map(|m| (m.mean_position_mm, m.median_position_mm))
        .collect();
    let rot: Vec<(Option<f64>, Option<f64>)> = methods
        .iter()
        .map(|m| (m.mean_orientation_deg, m.median_orientation_deg))
        .collect();
    render_png(path, config, |root, text| {
        let (a, b) = root.split_vertically(root.dim_in_pixel().1 / 2);
        bar_panel(&a, text, "Position error by method", "mm", &names, &pos)?;
        bar_panel(
            &b,
            text,
            "Orientation error by method",
            "degrees",
            &names,
            &rot,
        )
    })
}

fn bar_panel(
    area: &Area<'_>,
    text: bool,
    title: &str,
    unit: &str,
    names: &[String],
    values: &[(Option<f64>, Option<f64>)],
) -> Result<(), String> {
    let n = names.len().max(1) as f64;
    let ymax = values
        .iter()
        .flat_map(|(a, b)| [*a, *b])
        .flatten()
        .filter(|v| v.is_finite())
        .fold(0.0_f64, f64::max)
        .max(1e-6)
        * 1.1;
    let mut chart = panel_chart(area, text, title, (-0.5, n - 0.5), (0.0, ymax))?;
    let mut mesh = chart.configure_mesh();
    let label = |x: &f64| {
        let i = x.round();
        if (x - i).abs() < 1e-6 && i >= 0.0 {
            names.get(i as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    mesh.light_line_style(RGBColor(235, 235, 235))
        .disable_x_mesh();
    if text {
        mesh.x_labels(names.len() * 2 + 1)
            .x_label_formatter(&label)
            .y_desc(unit)
            .label_style(("sans-serif", 13));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| e.to_string())?;
    if !text {
        border(&mut chart, (-0.5, n - 0.5), (0.0, ymax))?;
    }
    for (i, (mean, median)) in values.iter().enumerate() {
        let x = i as f64;
        for (v, dx, color) in [(mean, -0.2, MEAN), (median, 0.2, MEDIAN)] {
            if let Some(v) = v.filter(|v| v.is_finite()) {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x + dx - 0.18, 0.0), (x + dx + 0.18, v)],
                        color.filled(),
                    )))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    if text {
        legend(&mut chart, &[("mean", MEAN), ("median", MEDIAN)])?;
    }
    Ok(())
}

fn legend<'a, 'b: 'a>(
    chart: &mut crate::plots::Chart<'a, 'b>,
    items: &[(&str, RGBColor)],
) -> Result<(), String> {
    legend_at(chart, items, None)
}

/// [`legend`] at `position` (`None`: plotters' default place).
fn legend_at<'a, 'b: 'a>(
    chart: &mut crate::plots::Chart<'a, 'b>,
    items: &[(&str, RGBColor)],
    position: Option<SeriesLabelPosition>,
) -> Result<(), String> {
    for &(name, color) in items {
        chart
            .draw_series(std::iter::once(Circle::new((f64::NAN, f64::NAN), 0, color)))
            .map_err(|e| e.to_string())?
            .label(name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    let mut labels = chart.configure_series_labels();
    if let Some(position) = position {
        labels.position(position);
    }
    labels
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(|e| e.to_string())
}

/// Draws box-and-whisker plots of the errors at each x (two panels) to `path`; `x_desc`
/// names the x axis (e.g. "number of zones").
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_error_boxes(
    columns: &[BoxColumn],
    x_desc: &str,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    let pos: Vec<(f64, Option<BoxStats>)> = columns
        .iter()
        .map(|c| (c.x, BoxStats::new(&c.position_mm)))
        .collect();
    let rot: Vec<(f64, Option<BoxStats>)> = columns
        .iter()
        .map(|c| (c.x, BoxStats::new(&c.orientation_deg)))
        .collect();
    render_png(path, config, |root, text| {
        let (a, b) = root.split_vertically(root.dim_in_pixel().1 / 2);
        box_panel(&a, text, "Position error", "mm", x_desc, &pos)?;
        box_panel(&b, text, "Orientation error", "degrees", x_desc, &rot)
    })
}

fn box_panel(
    area: &Area<'_>,
    text: bool,
    title: &str,
    unit: &str,
    x_desc: &str,
    boxes: &[(f64, Option<BoxStats>)],
) -> Result<(), String> {
    let xs: Vec<f64> = boxes.iter().map(|b| b.0).collect();
    let (xlo, xhi) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let (xlo, xhi) = if xlo.is_finite() {
        (xlo, xhi)
    } else {
        (0.0, 1.0)
    };
    // Box width: 60 % of the smallest spacing between columns.
    let mut sorted = xs.clone();
    sorted.sort_by(f64::total_cmp);
    let spacing = sorted
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let spacing = if spacing.is_finite() { spacing } else { 1.0 };
    let half = 0.3 * spacing;
    let ymax = boxes
        .iter()
        .filter_map(|b| b.1.as_ref())
        .flat_map(|s| std::iter::once(s.hi).chain(s.outliers.iter().copied()))
        .fold(0.0_f64, f64::max)
        .max(1e-6)
        * 1.08;
    let x = padded(xlo - half, xhi + half);
    let mut chart = panel_chart(area, text, title, x, (0.0, ymax))?;
    axes(&mut chart, text, x_desc, unit, x, (0.0, ymax))?;
    for (cx, stats) in boxes {
        let Some(s) = stats else { continue };
        let cx = *cx;
        let style = BOX.stroke_width(2);
        let elements = vec![
            PathElement::new(vec![(cx, s.lo), (cx, s.q1)], style),
            PathElement::new(vec![(cx, s.q3), (cx, s.hi)], style),
            PathElement::new(
                vec![(cx - half / 2.0, s.lo), (cx + half / 2.0, s.lo)],
                style,
            ),
            PathElement::new(
                vec![(cx - half / 2.0, s.hi), (cx + half / 2.0, s.hi)],
                style,
            ),
            PathElement::new(
                vec![
                    (cx - half, s.q1),
                    (cx + half, s.q1),
                    (cx + half, s.q3),
                    (cx - half, s.q3),
                    (cx - half, s.q1),
                ],
                style,
            ),
            PathElement::new(
                vec![(cx - half, s.median), (cx + half, s.median)],
                MEDIAN.stroke_width(3),
            ),
        ];
        chart.draw_series(elements).map_err(|e| e.to_string())?;
        chart
            .draw_series(
                s.outliers
                    .iter()
                    .map(|&y| Circle::new((cx, y), 3, OUTLIER.stroke_width(1))),
            )
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Draws mean and median errors against x as lines with markers (two panels) to `path`.
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_error_curve(
    points: &[CurvePoint],
    x_desc: &str,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    let pos: Vec<(f64, Option<f64>, Option<f64>)> = points
        .iter()
        .map(|p| (p.x, p.mean_position_mm, p.median_position_mm))
        .collect();
    let rot: Vec<(f64, Option<f64>, Option<f64>)> = points
        .iter()
        .map(|p| (p.x, p.mean_orientation_deg, p.median_orientation_deg))
        .collect();
    render_png(path, config, |root, text| {
        let (a, b) = root.split_vertically(root.dim_in_pixel().1 / 2);
        curve_panel(&a, text, "Position error", "mm", x_desc, &pos)?;
        curve_panel(&b, text, "Orientation error", "degrees", x_desc, &rot)
    })
}

fn curve_panel(
    area: &Area<'_>,
    text: bool,
    title: &str,
    unit: &str,
    x_desc: &str,
    points: &[(f64, Option<f64>, Option<f64>)],
) -> Result<(), String> {
    let (xlo, xhi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    let (xlo, xhi) = if xlo.is_finite() {
        (xlo, xhi)
    } else {
        (0.0, 1.0)
    };
    let ymax = points
        .iter()
        .flat_map(|p| [p.1, p.2])
        .flatten()
        .filter(|v| v.is_finite())
        .fold(0.0_f64, f64::max)
        .max(1e-6)
        * 1.1;
    let x = padded(xlo, xhi);
    let mut chart = panel_chart(area, text, title, x, (0.0, ymax))?;
    axes(&mut chart, text, x_desc, unit, x, (0.0, ymax))?;
    for (pick, color) in [(1usize, MEAN), (2, MEDIAN)] {
        let line: Vec<(f64, f64)> = points
            .iter()
            .filter_map(|p| {
                let v = if pick == 1 { p.1 } else { p.2 };
                v.filter(|v| v.is_finite()).map(|v| (p.0, v))
            })
            .collect();
        chart
            .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(line.iter().map(|&p| Circle::new(p, 4, color.filled())))
            .map_err(|e| e.to_string())?;
    }
    if text {
        legend(&mut chart, &[("mean", MEAN), ("median", MEDIAN)])?;
    }
    Ok(())
}

/// One line of [`plot_series`]: a name (its legend entry) and its points `(x, y)`; a `None`
/// y leaves a gap.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points in x order.
    pub points: Vec<(f64, Option<f64>)>,
}

/// One panel of [`plot_series`]: its title, y unit, y range and lines.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesPanel {
    /// Panel title.
    pub title: String,
    /// The y axis' description.
    pub unit: String,
    /// The y range drawn (values beyond it are clipped to it).
    pub y: (f64, f64),
    /// The lines, one colour each.
    pub series: Vec<Series>,
}

/// Draws panels of lines with markers against a common x (e.g. one line per factor against
/// severity), one above the other, to `path`; `x_ticks` names the x positions 0, 1, 2, ….
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_series(
    panels: &[SeriesPanel],
    x_ticks: &[&str],
    x_desc: &str,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    let ticks: Vec<String> = x_ticks.iter().map(|s| s.to_string()).collect();
    render_png(path, config, |root, text| {
        let areas = root.split_evenly((panels.len().max(1), 1));
        for (area, panel) in areas.iter().zip(panels) {
            series_panel(area, text, panel, &ticks, x_desc)?;
        }
        Ok(())
    })
}

fn series_panel(
    area: &Area<'_>,
    text: bool,
    panel: &SeriesPanel,
    ticks: &[String],
    x_desc: &str,
) -> Result<(), String> {
    let x = (-0.3, (ticks.len().max(2) - 1) as f64 + 0.3);
    let y = panel.y;
    let mut chart = panel_chart(area, text, &panel.title, x, y)?;
    {
        let mut mesh = chart.configure_mesh();
        mesh.light_line_style(RGBColor(235, 235, 235))
            .x_labels(ticks.len().max(2));
        if text {
            let name = |v: &f64| {
                let k = v.round();
                if (v - k).abs() < 1e-6 && k >= 0.0 {
                    ticks.get(k as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            };
            mesh.x_desc(x_desc)
                .y_desc(panel.unit.as_str())
                .x_label_formatter(&name)
                .y_label_formatter(&tick_label)
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(|e| e.to_string())?;
        }
    }
    if !text {
        bare_frame(&mut chart, x, y)?;
    }
    for (k, s) in panel.series.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let clip = |v: f64| v.clamp(y.0, y.1);
        // Gaps split a line; each run of points is drawn on its own.
        let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
        for &(px, py) in &s.points {
            match py.filter(|v| v.is_finite()) {
                Some(v) => runs.last_mut().expect("one run").push((px, clip(v))),
                None => runs.push(Vec::new()),
            }
        }
        let mut first = true;
        for run in runs.iter().filter(|r| !r.is_empty()) {
            chart
                .draw_series(run.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|e| e.to_string())?;
            let line = chart
                .draw_series(LineSeries::new(run.clone(), color.stroke_width(2)))
                .map_err(|e| e.to_string())?;
            if first && text {
                line.label(s.name.as_str()).legend(move |(lx, ly)| {
                    PathElement::new(vec![(lx, ly), (lx + 14, ly)], color.stroke_width(2))
                });
            }
            first = false;
        }
    }
    if text && !panel.series.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// One row of [`plot_row_bars`]: a name and one value per bar series (`None`: missing).
#[derive(Debug, Clone, PartialEq)]
pub struct BarRow {
    /// The row's label, drawn left of its bars.
    pub name: String,
    /// One value per series, in the series' order.
    pub values: Vec<Option<f64>>,
}

/// Draws one group of horizontal bars per row (e.g. one row per condition of a study, one bar
/// per figure), the first row at the top, to `path`: for labels too long to stand under a
/// bar. `series` names the bars of a group (legend), `x` is their common range (values beyond
/// it are clipped) and `unit` its description.
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_row_bars(
    rows: &[BarRow],
    series: &[&str],
    title: &str,
    unit: &str,
    x: (f64, f64),
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    render_png(path, config, |root, text| {
        let n = rows.len().max(1) as f64;
        // Row k sits at y = n − 1 − k, so the first row is at the top.
        let y = (-0.5, n - 0.5);
        let longest = rows
            .iter()
            .map(|r| r.name.chars().count())
            .max()
            .unwrap_or(0);
        let mut b = ChartBuilder::on(root);
        b.margin(15)
            .x_label_area_size(if text { 45 } else { 0 })
            .y_label_area_size(if text {
                (longest as u32 * 7 + 20).clamp(60, config.width_px / 2)
            } else {
                0
            });
        if text {
            b.caption(title, ("sans-serif", 18));
        }
        let mut chart = b
            .build_cartesian_2d(x.0..x.1, y.0..y.1)
            .map_err(|e| e.to_string())?;
        {
            let name = |v: &f64| {
                let k = (n - 1.0 - v).round();
                if (n - 1.0 - v - k).abs() < 1e-6 && k >= 0.0 {
                    rows.get(k as usize)
                        .map(|r| r.name.clone())
                        .unwrap_or_default()
                } else {
                    String::new()
                }
            };
            let mut mesh = chart.configure_mesh();
            mesh.light_line_style(RGBColor(235, 235, 235))
                .disable_y_mesh()
                .y_labels(rows.len() * 2 + 1);
            if text {
                mesh.x_desc(unit)
                    .x_label_formatter(&tick_label)
                    .y_label_formatter(&name)
                    .label_style(("sans-serif", 12))
                    .draw()
                    .map_err(|e| e.to_string())?;
            }
        }
        if !text {
            bare_frame(&mut chart, x, y)?;
        }
        let h = 0.8 / series.len().max(1) as f64;
        for (k, row) in rows.iter().enumerate() {
            let top = n - 1.0 - k as f64 + 0.4;
            for (j, v) in row.values.iter().enumerate() {
                let Some(v) = v.filter(|v| v.is_finite()) else {
                    continue;
                };
                let color = Palette99::pick(j).to_rgba();
                let y1 = top - j as f64 * h;
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x.0, y1 - h * 0.9), (v.clamp(x.0, x.1), y1)],
                        color.filled(),
                    )))
                    .map_err(|e| e.to_string())?;
            }
        }
        if text && !series.is_empty() {
            let items: Vec<(&str, RGBColor)> = series
                .iter()
                .enumerate()
                .map(|(j, name)| {
                    let c = Palette99::pick(j).to_rgba();
                    (*name, RGBColor(c.0, c.1, c.2))
                })
                .collect();
            // Lower right, where the bars are shortest.
            legend_at(&mut chart, &items, Some(SeriesLabelPosition::LowerRight))?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_stats_match_numpy_quartiles_and_tukey_fences() {
        // numpy.percentile([1..=9, 100], [25, 50, 75]) = 3.25, 5.5, 7.75; IQR 4.5,
        // fences −3.5 and 14.5: 100 is an outlier, whiskers 1 and 9.
        let mut v: Vec<f64> = (1..=9).map(f64::from).collect();
        v.push(100.0);
        let s = BoxStats::new(&v).unwrap();
        assert!((s.q1 - 3.25).abs() < 1e-12);
        assert!((s.median - 5.5).abs() < 1e-12);
        assert!((s.q3 - 7.75).abs() < 1e-12);
        assert_eq!((s.lo, s.hi), (1.0, 9.0));
        assert_eq!(s.outliers, vec![100.0]);
    }

    #[test]
    fn tick_labels_drop_needless_decimals() {
        let l = |v: f64| tick_label(&v);
        assert_eq!(
            (l(40.0), l(-5.0), l(-0.0)),
            ("40".into(), "-5".into(), "0".into())
        );
        assert_eq!(
            (l(0.25), l(0.1 + 0.2), l(2.5)),
            ("0.25".into(), "0.3".into(), "2.5".into())
        );
    }

    #[test]
    fn box_stats_ignore_non_finite_and_empty() {
        assert!(BoxStats::new(&[]).is_none());
        assert!(BoxStats::new(&[f64::NAN]).is_none());
        let s = BoxStats::new(&[2.0, f64::NAN, 2.0]).unwrap();
        assert_eq!(
            (s.q1, s.median, s.q3, s.lo, s.hi),
            (2.0, 2.0, 2.0, 2.0, 2.0)
        );
    }

    #[test]
    fn plots_are_written_as_png() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = PlotConfig {
            width_px: 400,
            height_px: 300,
            text: Some(false),
        };
        let bars = [MethodBar {
            name: "endoloc".into(),
            mean_position_mm: Some(2.0),
            median_position_mm: Some(1.0),
            mean_orientation_deg: Some(3.0),
            median_orientation_deg: None,
        }];
        let p = dir.path().join("bars.png");
        plot_method_bars(&bars, &p, &cfg).unwrap();
        let cols = [
            BoxColumn {
                x: 10.0,
                position_mm: vec![1.0, 2.0, 3.0],
                orientation_deg: vec![1.0],
            },
            BoxColumn {
                x: 20.0,
                position_mm: vec![],
                orientation_deg: vec![2.0, 5.0],
            },
        ];
        let q = dir.path().join("boxes.png");
        plot_error_boxes(&cols, "zones", &q, &cfg).unwrap();
        let pts = [CurvePoint {
            x: 0.0,
            mean_position_mm: Some(1.0),
            median_position_mm: Some(0.5),
            mean_orientation_deg: Some(2.0),
            median_orientation_deg: Some(1.0),
        }];
        let r = dir.path().join("curve.png");
        plot_error_curve(&pts, "e", &r, &cfg).unwrap();
        let rows = [
            BarRow {
                name: "none".into(),
                values: vec![Some(96.0), Some(0.1)],
            },
            BarRow {
                name: "shape+texture".into(),
                values: vec![Some(40.0), None],
            },
        ];
        let b = dir.path().join("rows.png");
        plot_row_bars(
            &rows,
            &["refined", "wrong"],
            "t",
            "%",
            (0.0, 100.0),
            &b,
            &cfg,
        )
        .unwrap();
        for f in [p, q, r, b] {
            let img = image::open(&f).unwrap();
            assert_eq!((img.width(), img.height()), (400, 300));
        }
    }
}
