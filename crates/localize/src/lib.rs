//! endoloc's localizer: the geometric half of the paper's method.
//!
//! [`map`] triangulates, for every zone of the training pass, SURF features of `m` evenly
//! chosen images with their known poses into 3-D map points (the paper's Eq. 1 with the
//! `δr` filter). [`pipeline`] localizes a test frame: zone from the Siamese classifier →
//! initial pose = the zone's median pose → SURF matched to the zone's map points (and its
//! neighbours') → robust Gauss-Newton on SE(3) with left perturbation (Eq. 2) → validity
//! check, giving `refined`, `init_only` or `rejected` with a reason.
//!
//! Conventions: mm; poses `T_wc`; OpenCV camera axes; pixels with the origin at the centre of
//! the top-left pixel.

#![warn(missing_docs)]

pub mod colon_scale;
pub mod confirm;
pub mod export;
pub mod guided;
pub mod map;
pub mod map_io;
pub mod map_point;
pub mod motion;
pub mod pipeline;

#[cfg(test)]
mod config_tests;

pub use confirm::{ConfirmConfig, Confirmation, confirm};
pub use map::{
    DEFAULT_MAP_THRESHOLD, Map, MapConfig, MapPoint, MapSummary, ZoneMap, build_map,
    build_map_masked,
};
pub use motion::{Gate, MotionConfig, Prediction, Track};
pub use pipeline::{
    FrameResult, LiveState, Localizer, LocalizerConfig, PoseSource, PoseUncertainty,
    RETRY_THRESHOLD_FACTOR, RetryFeatures, StageTimes, TEST_KEYPOINT_BUDGET, TEST_THRESHOLD_FACTOR,
};

/// Errors of the localizer.
#[derive(Debug, thiserror::Error)]
pub enum LocalizeError {
    /// A parameter is out of range; the message names it.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The model, map and sequence do not fit together (camera, frame counts).
    #[error("{0}")]
    Mismatch(String),
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
    /// Dataset errors (unreadable images, bad poses).
    #[error(transparent)]
    Data(#[from] endoloc_data::DataError),
    /// Zone classifier errors.
    #[error(transparent)]
    Net(#[from] endoloc_net::NetError),
    /// Feature extraction errors (invalid image, bad configuration).
    #[error(transparent)]
    Features(#[from] endoloc_features::FeatureError),
}
