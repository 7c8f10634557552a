//! Writes an evaluation's files into an output folder: `metrics.json`, `errors.csv`,
//! `report.md` and the plots, each atomically, refusing to replace existing files unless
//! forced.
//!
//! `errors.csv` has one row per test frame:
//! `frame,timestamp_s,localized,position_mm,orientation_deg,status,zone,gt_zone`
//! (empty cells where unknown; `zone` is the predicted zone).

use std::path::{Path, PathBuf};

use crate::EvalError;
use crate::metrics::Evaluation;
use crate::output::OutputDir;
use crate::plots::{
    PlotConfig, plot_error_cdf, plot_errors_along, plot_trajectory_xy, text_available,
};
use crate::report::{PlotRef, Sources, render_report};

/// The metrics file name.
pub const METRICS_JSON: &str = "metrics.json";
/// The per-frame error table's file name.
pub const ERRORS_CSV: &str = "errors.csv";
/// The report's file name.
pub const REPORT_MD: &str = "report.md";
/// The header of `errors.csv`.
pub const ERRORS_CSV_HEADER: &str =
    "frame,timestamp_s,localized,position_mm,orientation_deg,status,zone,gt_zone";

const PLOTS: [(&str, &str); 3] = [
    (
        "trajectory_xy.png",
        "Ground truth (line) and estimates (dots, coloured by status) in the world X-Y plane (x: patient's left, y: cranial); grey segments join each estimate to its ground truth; red crosses mark frames without an estimate.",
    ),
    (
        "errors_along.png",
        "Position and orientation error against the test frame index.",
    ),
    (
        "error_cdf.png",
        "Cumulative distribution of the errors over all test frames (the plateau is the localized fraction).",
    ),
];

/// What to write.
#[derive(Debug, Clone, Default)]
pub struct WriteOptions {
    /// Replace files that already exist in the output folder.
    pub force: bool,
    /// Skip the PNG plots (and their references in the report).
    pub no_plots: bool,
    /// Plot settings.
    pub plot: PlotConfig,
    /// Input names for the report.
    pub sources: Sources,
}

/// What was written.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// Every file written, in order.
    pub files: Vec<PathBuf>,
    /// Whether the plots carry text (false when no font was found).
    pub plot_text: bool,
}

/// Writes the per-frame error table as CSV to `out`, one frame at a time; `path` names the
/// file in errors.
///
/// # Errors
/// [`EvalError::Io`] naming `path` when writing fails, or reading the evaluation's records.
pub fn write_errors_csv(
    eval: &Evaluation,
    out: &mut dyn std::io::Write,
    path: &Path,
) -> Result<(), EvalError> {
    let io = |e| EvalError::io(path, e);
    writeln!(out, "{ERRORS_CSV_HEADER}").map_err(io)?;
    let o = |v: Option<f64>| v.map(|x| format!("{x:.9}")).unwrap_or_default();
    let u = |v: Option<usize>| v.map(|x| x.to_string()).unwrap_or_default();
    eval.for_each_frame(|f| {
        writeln!(
            out,
            "{},{:.6},{},{},{},{},{},{}",
            f.frame,
            f.timestamp_s,
            u8::from(f.localized),
            o(f.position_mm),
            o(f.orientation_deg),
            f.status.map(|s| s.as_str()).unwrap_or(""),
            u(f.zone),
            u(f.gt_zone)
        )
        .map_err(io)
    })
}

/// The per-frame error table as CSV text (small passes; [`write_errors_csv`] streams).
///
/// # Errors
/// As [`write_errors_csv`].
pub fn format_errors_csv(eval: &Evaluation) -> Result<String, EvalError> {
    let mut v = Vec::new();
    write_errors_csv(eval, &mut v, Path::new(ERRORS_CSV))?;
    String::from_utf8(v).map_err(|e| EvalError::Invalid(e.to_string()))
}

/// Writes all outputs of `eval` into `dir` (created if missing).
///
/// # Errors
/// [`EvalError::AlreadyExists`] if one of the files exists and `force` is off (nothing is
/// written); [`EvalError::Io`], [`EvalError::Json`], [`EvalError::Plot`] if writing fails.
pub fn write_results(
    eval: &Evaluation,
    dir: &Path,
    options: &WriteOptions,
) -> Result<Written, EvalError> {
    let mut names = vec![METRICS_JSON, ERRORS_CSV, REPORT_MD];
    if !options.no_plots {
        names.extend(PLOTS.iter().map(|p| p.0));
    }
    let out = OutputDir::prepare(dir, &names, options.force)?;
    let mut files = Vec::new();
    let json = serde_json::to_string_pretty(&eval.metrics).map_err(|e| EvalError::Json {
        path: out.path(METRICS_JSON),
        source: e,
    })?;
    out.write(METRICS_JSON, format!("{json}\n").as_bytes())?;
    files.push(out.path(METRICS_JSON));
    let errors_csv = out.path(ERRORS_CSV);
    out.write_with(ERRORS_CSV, |w| write_errors_csv(eval, w, &errors_csv))?;
    files.push(out.path(ERRORS_CSV));
    let mut plots = Vec::new();
    let plot_text = !options.no_plots && options.plot.text.unwrap_or_else(text_available);
    if !options.no_plots {
        let cfg = PlotConfig {
            text: Some(plot_text),
            ..options.plot
        };
        plot_trajectory_xy(eval, &out.path(PLOTS[0].0), &cfg)?;
        plot_errors_along(eval, &out.path(PLOTS[1].0), &cfg)?;
        plot_error_cdf(eval, &out.path(PLOTS[2].0), &cfg)?;
        let k = eval.plots.stride;
        let thinned = [
            format!(" Every {k}th frame of the {} is drawn.", eval.plots.frames),
            format!(" Each run of {k} frames shows its smallest and largest error."),
            format!(
                " Drawn from a 4096-bin histogram of the {} frames.",
                eval.plots.frames
            ),
        ];
        for ((file, caption), note) in PLOTS.into_iter().zip(thinned) {
            files.push(out.path(file));
            plots.push(PlotRef {
                file: file.into(),
                caption: if k > 1 {
                    format!("{caption}{note}")
                } else {
                    caption.into()
                },
            });
        }
    }
    out.write(
        REPORT_MD,
        render_report(&eval.metrics, &options.sources, &plots).as_bytes(),
    )?;
    files.push(out.path(REPORT_MD));
    Ok(Written { files, plot_text })
}
