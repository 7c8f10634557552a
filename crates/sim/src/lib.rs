//! endoloc's colonoscopy simulator.
//!
//! Renders image sequences with exact 6-DoF poses from a colon model — the built-in
//! [`colon::procedural`] large intestine or a surface mesh with its mid-line
//! ([`colon::from_mesh`], e.g. a CT colon) — along clinical passes anus → caecum
//! ([`trajectory`]), with a mucosa texture that is homogeneous within an anatomical section
//! ([`appearance`]) and a light at the scope tip ([`render`]). [`simulate::simulate`] writes an
//! endoloc dataset (format v1, see `docs/CONVENTIONS.md`).
//!
//! Conventions: mm; poses `T_wc`; OpenCV camera axes; pixel origin at the top-left pixel's
//! centre.

#![warn(missing_docs)]
// `!(x > limit)` is used on purpose: it rejects NaN as well as small values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod appearance;
pub mod centerline;
pub mod change;
pub mod colon;
pub mod config;
pub mod render;
pub mod simulate;
pub mod trajectory;

#[cfg(test)]
mod config_tests;

pub use change::{ChangeConfig, Severity};
pub use config::{CameraConfig, ColonSource, Preset, SimConfig};
pub use simulate::{Progress, SimSummary, simulate};

/// Errors of the simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A parameter is out of range or inconsistent; the message names it.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// A mid-line path that cannot be used (too short, non-finite points).
    #[error("invalid mid-line path: {0}")]
    InvalidPath(String),
    /// The lumen is too narrow somewhere along a pass for the requested clearance.
    #[error(
        "the lumen is too narrow at {s_mm:.0} mm along the mid-line (frame {frame}): the lens can \
         be kept only {achieved_mm:.2} mm from the wall, {required_mm} mm was asked; inflate the \
         colon (`inflation` 1.5) or lower the clearance (`clearance`)"
    )]
    Clearance {
        /// Frame of the pass.
        frame: usize,
        /// Arc length along the mid-line, mm.
        s_mm: f64,
        /// Best distance to the wall found, mm.
        achieved_mm: f64,
        /// Requested clearance, mm.
        required_mm: f64,
    },
    /// Reading inputs or writing the dataset failed.
    #[error(transparent)]
    Data(#[from] endoloc_data::DataError),
}
