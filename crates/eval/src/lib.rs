//! Trajectory evaluation for endoloc: the numbers, plots and report of a localization run.
//!
//! Inputs: the test sequence's ground truth (`poses.txt`, TUM), the run's estimate
//! (`trajectory.txt`, TUM), optionally its `frames.csv` ([`frames_csv`]) and the test frames'
//! true zones (`zones.csv`, [`zones_csv`]). Outputs: `metrics.json` ([`metrics`]), a per-frame
//! error table, plots ([`plots`]) and `report.md` ([`report`]).
//!
//! The metrics reproduce evo (<https://github.com/MichaelGrupp/evo>, checked against 1.38):
//! association by timestamp ([`association`]), APE ([`ape`]), RPE ([`rpe`]), Umeyama
//! alignment ([`align`]) and its statistics ([`stats`]).
//!
//! Conventions (docs/CONVENTIONS.md): poses `T_wc` camera-to-world, millimetres, timestamps in seconds;
//! position error `‖t_est − t_gt‖` mm, orientation error the geodesic angle of
//! `R_estᵀ R_gt` in degrees.

#![warn(missing_docs)]

pub mod align;
pub mod along;
pub mod ape;
pub mod association;
pub mod error;
pub mod experiment_plots;
pub mod frame_error;
pub mod frames_csv;
pub mod html;
pub mod metrics;
pub mod npy;
pub mod output;
pub mod plot_data;
pub mod plots;
pub mod report;
pub mod rows_reader;
pub mod rpe;
mod select;
pub mod source;
mod spill;
pub mod stats;
pub mod write;
pub mod zones_csv;

#[cfg(test)]
mod config_tests;

pub use align::{AlignmentKind, Similarity3, align_trajectory, umeyama};
pub use along::Midline;
pub use ape::{PoseRelation, ape_errors};
pub use association::{Association, AssociationConfig, MatchedPair, associate};
pub use error::EvalError;
pub use experiment_plots::{
    BarRow, BoxColumn, BoxStats, CurvePoint, MethodBar, Series, SeriesPanel, plot_error_boxes,
    plot_error_curve, plot_method_bars, plot_row_bars, plot_series,
};
pub use frames_csv::{
    BOUND95_PER_STD, FRAMES_CSV_HEADER, FRAMES_CSV_HEADER_V1, FrameRecord, FramesCsvReader,
    format_frames_csv, format_frames_csv_row, parse_frames_csv, read_frames_csv, write_frames_csv,
};
pub use html::{Block, HtmlReport};
pub use metrics::{
    EvalConfig, Evaluation, FrameEvaluation, METRICS_FORMAT, Metrics, evaluate, evaluate_files,
};
pub use output::{OutputDir, refuse_existing, write_atomic};
pub use plot_data::{Cdf, PLOT_FRAMES, PlotData, TrackPoint};
pub use plots::{PlotConfig, text_available};
pub use report::{Sources, render_report};
pub use rpe::{RpeConfig, RpeErrors, rpe_errors};
pub use source::{EvalFiles, EvalInputs, EvalSource};
pub use stats::Statistics;
pub use write::{WriteOptions, Written, write_errors_csv, write_results};
pub use zones_csv::{ZONES_CSV_HEADER, ZoneLabel, ZonesCsvReader, read_zones_csv};
