//! PNG plots of an evaluation (plotters, bitmap backend).
//!
//! - `trajectory_xy.png`: ground truth and estimate in the world X-Y plane (the paper's
//!   Fig. 5). Our simulator's world frame is coronal: x towards the patient's left, y cranial,
//!   so this is the colon seen from the front. Equal scale on both axes; each estimate is
//!   joined to its ground truth by a thin line and coloured by its `frames.csv` status.
//! - `errors_along.png`: position (mm) and orientation (°) error against the frame index.
//! - `error_cdf.png`: cumulative distribution of both errors.
//!
//! What they draw is [`PlotData`](crate::PlotData), collected during the evaluation and bounded whatever the
//! pass length (`crate::plot_data`).
//!
//! Text needs a system font, found through fontconfig (the workspace's plotters `ttf`
//! feature). When none is usable (a bare container), the plots are drawn without any text
//! rather than failing; [`text_available`] says which happened.

use std::io::Cursor;
use std::path::Path;
use std::sync::OnceLock;

use endoloc_geometry::Status;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::EvalError;
use crate::metrics::Evaluation;
use crate::output::write_atomic;
use crate::plot_data::{Cdf, TrackPoint};

/// Settings of the plots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotConfig {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Draw text (titles, axis labels, legends): `None` = when a font is available.
    pub text: Option<bool>,
}

impl Default for PlotConfig {
    fn default() -> Self {
        Self {
            width_px: 1000,
            height_px: 800,
            text: None,
        }
    }
}

/// Whether a sans-serif font can be loaded for plot text (probed once per process).
pub fn text_available() -> bool {
    static PROBE: OnceLock<bool> = OnceLock::new();
    *PROBE.get_or_init(|| {
        ("sans-serif", 14.0)
            .into_font()
            .box_size("Ag 0.5 mm")
            .is_ok()
    })
}

fn err(path: &Path, e: impl std::fmt::Display) -> EvalError {
    EvalError::Plot {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

const GT_COLOR: RGBColor = RGBColor(60, 60, 60);
const REFINED: RGBColor = RGBColor(0, 150, 70);
const INIT_ONLY: RGBColor = RGBColor(230, 140, 0);
const REJECTED: RGBColor = RGBColor(210, 30, 30);
const UNKNOWN: RGBColor = RGBColor(30, 90, 200);

fn status_color(s: Option<Status>) -> RGBColor {
    match s {
        Some(Status::Refined) => REFINED,
        Some(Status::InitOnly) => INIT_ONLY,
        Some(Status::Rejected) => REJECTED,
        None => UNKNOWN,
    }
}

/// Renders with `draw` into an RGB buffer and writes it as a PNG, atomically.
pub(crate) fn render_png(
    path: &Path,
    config: &PlotConfig,
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>, bool) -> Result<(), String>,
) -> Result<(), EvalError> {
    let (w, h) = (config.width_px.max(200), config.height_px.max(150));
    let text = config.text.unwrap_or_else(text_available);
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(path, e))?;
        draw(&root, text).map_err(|e| err(path, e))?;
        root.present().map_err(|e| err(path, e))?;
    }
    let img = image::RgbImage::from_raw(w, h, buf)
        .ok_or_else(|| err(path, "image buffer has the wrong size"))?;
    let mut png = Vec::new();
    img.write_to(&mut Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| err(path, e))?;
    write_atomic(path, &png)
}

pub(crate) type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Without text the mesh has no labels (and so no grid): draw the plot area's border.
pub(crate) fn border(
    chart: &mut Chart<'_, '_>,
    x: (f64, f64),
    y: (f64, f64),
) -> Result<(), String> {
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(x.0, y.0), (x.1, y.1)],
            BLACK.stroke_width(1),
        )))
        .map(|_| ())
        .map_err(|e| e.to_string())
}

pub(crate) fn padded(lo: f64, hi: f64) -> (f64, f64) {
    let span = (hi - lo).abs().max(1e-6);
    (lo - 0.05 * span, hi + 0.05 * span)
}

fn min_max(v: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    v.fold(None, |acc, x| match acc {
        None => Some((x, x)),
        Some((a, b)) => Some((a.min(x), b.max(x))),
    })
}

/// Draws the trajectory in the world X-Y plane (equal axis scale) to `path`.
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_trajectory_xy(
    eval: &Evaluation,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    let frames = &eval.plots.track;
    let pts = frames
        .iter()
        .flat_map(|f| std::iter::once(f.gt).chain(f.est));
    let (xs, ys): (Vec<f64>, Vec<f64>) = pts.unzip();
    let (x0, x1) = padded_range(&xs);
    let (y0, y1) = padded_range(&ys);
    render_png(path, config, |root, text| {
        let margin = 20u32;
        let (label_x, label_y) = if text { (45u32, 60u32) } else { (0, 0) };
        let top = if text { 40u32 } else { 0 };
        // Equal scale: widen the range of the axis with fewer mm per pixel.
        let (w, h) = root.dim_in_pixel();
        let pw = (w.saturating_sub(2 * margin + label_y)).max(1) as f64;
        let ph = (h.saturating_sub(2 * margin + label_x + top)).max(1) as f64;
        let (sx, sy) = ((x1 - x0) / pw, (y1 - y0) / ph);
        let s = sx.max(sy);
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let (xr, yr) = (
            cx - 0.5 * s * pw..cx + 0.5 * s * pw,
            cy - 0.5 * s * ph..cy + 0.5 * s * ph,
        );
        let mut b = ChartBuilder::on(root);
        b.margin(margin)
            .x_label_area_size(label_x)
            .y_label_area_size(label_y);
        if text {
            b.caption(
                "Trajectory, world X-Y plane (coronal view)",
                ("sans-serif", 22),
            );
        }
        let (xb, yb) = ((xr.start, xr.end), (yr.start, yr.end));
        let mut chart = b.build_cartesian_2d(xr, yr).map_err(|e| e.to_string())?;
        let mut mesh = chart.configure_mesh();
        mesh.light_line_style(RGBColor(235, 235, 235));
        if text {
            mesh.x_desc("x (mm, patient's left)")
                .y_desc("y (mm, cranial)")
                .label_style(("sans-serif", 14));
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw().map_err(|e| e.to_string())?;
        if !text {
            border(&mut chart, xb, yb)?;
        }
        // Error segments estimate → ground truth.
        chart
            .draw_series(frames.iter().filter_map(|f| {
                f.est.map(|e| {
                    PathElement::new(vec![e, f.gt], RGBColor(200, 200, 200).stroke_width(1))
                })
            }))
            .map_err(|e| e.to_string())?;
        let gt_line = chart
            .draw_series(LineSeries::new(
                frames.iter().map(|f| f.gt),
                GT_COLOR.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?;
        if text {
            gt_line.label("ground truth").legend(|(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], GT_COLOR.stroke_width(2))
            });
        }
        // Frames without an estimate: a cross on the ground truth.
        if frames.iter().any(|f| f.est.is_none()) {
            let lost = chart
                .draw_series(
                    frames
                        .iter()
                        .filter(|f| f.est.is_none())
                        .map(|f| Cross::new(f.gt, 4, REJECTED.stroke_width(2))),
                )
                .map_err(|e| e.to_string())?;
            if text {
                lost.label("not localized (at ground truth)")
                    .legend(|(x, y)| Cross::new((x + 10, y), 4, REJECTED.stroke_width(2)));
            }
        }
        for (status, name) in [
            (Some(Status::Refined), "refined"),
            (Some(Status::InitOnly), "init_only"),
            (Some(Status::Rejected), "rejected (pose given)"),
            (None, "estimate"),
        ] {
            let sel: Vec<&TrackPoint> = frames
                .iter()
                .filter(|f| f.est.is_some() && f.status == status)
                .collect();
            if sel.is_empty() {
                continue;
            }
            let c = status_color(status);
            let series = chart
                .draw_series(
                    sel.iter()
                        .filter_map(|f| f.est.map(|e| Circle::new(e, 3, c.filled()))),
                )
                .map_err(|e| e.to_string())?;
            if text {
                series
                    .label(name)
                    .legend(move |(x, y)| Circle::new((x + 10, y), 4, c.filled()));
            }
        }
        if text {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    })
}

fn padded_range(v: &[f64]) -> (f64, f64) {
    let (lo, hi) = min_max(v.iter().copied()).unwrap_or((0.0, 1.0));
    padded(lo, hi)
}

/// One panel: `values` (frame, error) as points joined where frames are consecutive.
fn error_panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    text: bool,
    title: &str,
    y_desc: &str,
    n_frames: usize,
    values: &[(usize, f64, Option<Status>)],
    join: bool,
) -> Result<(), String> {
    let ymax = values.iter().map(|v| v.1).fold(0.0f64, f64::max).max(1e-6) * 1.05;
    let mut b = ChartBuilder::on(area);
    b.margin(15)
        .x_label_area_size(if text { 40 } else { 0 })
        .y_label_area_size(if text { 60 } else { 0 });
    if text {
        b.caption(title, ("sans-serif", 18));
    }
    let mut chart = b
        .build_cartesian_2d(0f64..(n_frames.max(2) - 1) as f64, 0f64..ymax)
        .map_err(|e| e.to_string())?;
    let mut mesh = chart.configure_mesh();
    mesh.light_line_style(RGBColor(235, 235, 235));
    if text {
        mesh.x_desc("frame")
            .y_desc(y_desc)
            .x_label_formatter(&|x| format!("{x:.0}"))
            .label_style(("sans-serif", 13));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| e.to_string())?;
    if !text {
        border(&mut chart, (0.0, (n_frames.max(2) - 1) as f64), (0.0, ymax))?;
    }
    for w in values.windows(2).filter(|_| join) {
        if w[1].0 == w[0].0 + 1 {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(w[0].0 as f64, w[0].1), (w[1].0 as f64, w[1].1)],
                    RGBColor(120, 120, 120).stroke_width(1),
                )))
                .map_err(|e| e.to_string())?;
        }
    }
    chart
        .draw_series(
            values
                .iter()
                .map(|&(f, e, s)| Circle::new((f as f64, e), 2, status_color(s).filled())),
        )
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Draws position and orientation error against the frame index to `path`.
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_errors_along(
    eval: &Evaluation,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    let n = eval.plots.frames;
    let (pos, rot) = (&eval.plots.along_position, &eval.plots.along_orientation);
    render_png(path, config, |root, text| {
        let (a, b) = root.split_vertically(root.dim_in_pixel().1 / 2);
        error_panel(
            &a,
            text,
            "Position error along the trajectory",
            "mm",
            n,
            pos,
            eval.plots.stride == 1,
        )?;
        error_panel(
            &b,
            text,
            "Orientation error along the trajectory",
            "degrees",
            n,
            rot,
            eval.plots.stride == 1,
        )
    })
}

fn cdf_panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    text: bool,
    title: &str,
    x_desc: &str,
    cdf: &Cdf,
    frames: usize,
) -> Result<(), String> {
    let largest = match cdf {
        Cdf::Sorted(v) => v.last().copied(),
        Cdf::Histogram { max, .. } => Some(*max),
    };
    let xmax = largest.unwrap_or(1.0).max(1e-6) * 1.05;
    let mut b = ChartBuilder::on(area);
    b.margin(15)
        .x_label_area_size(if text { 40 } else { 0 })
        .y_label_area_size(if text { 55 } else { 0 });
    if text {
        b.caption(title, ("sans-serif", 18));
    }
    let mut chart = b
        .build_cartesian_2d(0f64..xmax, 0f64..1.0)
        .map_err(|e| e.to_string())?;
    let mut mesh = chart.configure_mesh();
    mesh.light_line_style(RGBColor(235, 235, 235));
    if text {
        mesh.x_desc(x_desc)
            .y_desc("fraction of test frames")
            .label_style(("sans-serif", 13));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(|e| e.to_string())?;
    if !text {
        border(&mut chart, (0.0, xmax), (0.0, 1.0))?;
    }
    // Fraction of *all* test frames with an error ≤ x: frames never localized keep the
    // curve below 1 (its plateau is the localized fraction).
    let denom = frames.max(1) as f64;
    let mut step = vec![(0.0, 0.0)];
    let mut below = 0u64;
    match cdf {
        Cdf::Sorted(sorted) => {
            for (i, &e) in sorted.iter().enumerate() {
                step.push((e, i as f64 / denom));
                step.push((e, (i + 1) as f64 / denom));
            }
            below = sorted.len() as u64;
        }
        Cdf::Histogram { max, counts } => {
            let w = max / counts.len() as f64;
            for (b, &c) in counts.iter().enumerate() {
                if c > 0 {
                    let x = b as f64 * w;
                    step.push((x, below as f64 / denom));
                    below += c;
                    step.push((x + w, below as f64 / denom));
                }
            }
        }
    }
    step.push((xmax, below as f64 / denom));
    chart
        .draw_series(LineSeries::new(step, UNKNOWN.stroke_width(2)))
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Draws the cumulative distributions of position and orientation error to `path`.
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails; [`EvalError::Io`] if writing fails.
pub fn plot_error_cdf(
    eval: &Evaluation,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), EvalError> {
    let (pos, rot) = (&eval.plots.cdf_position, &eval.plots.cdf_orientation);
    let n = eval.plots.frames;
    let cfg = PlotConfig {
        height_px: config.height_px / 2 + 50,
        ..*config
    };
    render_png(path, &cfg, |root, text| {
        let (a, b) = root.split_horizontally(root.dim_in_pixel().0 / 2);
        cdf_panel(
            &a,
            text,
            "Position error CDF",
            "position error (mm)",
            pos,
            n,
        )?;
        cdf_panel(
            &b,
            text,
            "Orientation error CDF",
            "orientation error (degrees)",
            rot,
            n,
        )
    })
}
