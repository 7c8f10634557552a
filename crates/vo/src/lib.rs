//! Monocular feature-based visual odometry: the `vo` baseline of the paper's comparison
//! (where the paper ran ORB-SLAM and DSO with the first pose aligned and the scale taken from
//! the ground truth, reporting where they lost track).
//!
//! - [`VisualOdometry`] ([`odometry`]): SURF features, two-view initialization from the
//!   essential matrix (5-point RANSAC + cheirality), PnP tracking against a local map with
//!   keyframes and new triangulations, loss detection and re-initialization. Poses come out
//!   per tracked *segment*, each in its own frame and scale.
//! - [`align_segments`] / [`report`] ([`align`]): each segment aligned to the ground truth by
//!   its first pose with a least-squares scale from the ground truth; the tracked fraction and
//!   the frames where tracking was lost.
//!
//! Conventions (`docs/CONVENTIONS.md`): poses `T_wc` (camera-to-world), OpenCV camera axes, pixel origin
//! at the top-left pixel's centre; VO poses are in VO units (the first baseline of a segment
//! is one unit), aligned poses in millimetres.
//!
//! ```no_run
//! use endoloc_vo::{VisualOdometry, VoConfig, report};
//! # let camera = endoloc_geometry::Camera::from_hfov(320, 240, 90.0);
//! # let images: Vec<image::GrayImage> = Vec::new();
//! # let ground_truth: Vec<endoloc_geometry::Pose> = Vec::new();
//! let mut vo = VisualOdometry::new(camera, VoConfig::default())?;
//! for image in &images {
//!     vo.track(image)?;
//! }
//! let r = report(vo.frames(), &ground_truth)?;
//! println!("tracked {:.0} %, lost at {:?}", 100.0 * r.tracked_fraction, r.lost_at);
//! # Ok::<(), endoloc_vo::VoError>(())
//! ```

#![warn(missing_docs)]

pub mod align;
pub mod config;
mod error;
pub mod odometry;

#[cfg(test)]
mod config_tests;

pub use align::{SegmentAlignment, VoReport, align_segments, report};
pub use config::VoConfig;
pub use error::VoError;
pub use odometry::{NoPoseReason, TrackStatus, VisualOdometry, VoFrame};
