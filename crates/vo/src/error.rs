//! Errors of the visual odometry (invalid input; losing track is a status, not an error).

use endoloc_features::FeatureError;
use thiserror::Error;

/// Why the visual odometry could not process its input.
#[derive(Debug, Error)]
pub enum VoError {
    /// The configuration is out of range; the message names the field.
    #[error("invalid VO configuration: {0}")]
    InvalidConfig(String),
    /// The camera intrinsics are unusable; the message says why.
    #[error("invalid camera: {0}")]
    InvalidCamera(String),
    /// An image does not have the camera's size.
    #[error(
        "frame {frame}: image is {width}x{height} pixels but the camera is {expected_width}x{expected_height}"
    )]
    ImageSize {
        /// Index of the frame (0-based, in the order given to `track`).
        frame: usize,
        /// Width of the image, pixels.
        width: u32,
        /// Height of the image, pixels.
        height: u32,
        /// Camera width, pixels.
        expected_width: u32,
        /// Camera height, pixels.
        expected_height: u32,
    },
    /// SURF detection or matching failed (e.g. an image beyond the size limit).
    #[error("frame {frame}: features: {source}")]
    Features {
        /// Index of the frame.
        frame: usize,
        /// The feature error.
        #[source]
        source: FeatureError,
    },
    /// Alignment: the VO frames and the ground truth differ in length.
    #[error("{vo} VO frames but {gt} ground-truth poses")]
    LengthMismatch {
        /// Number of VO frames.
        vo: usize,
        /// Number of ground-truth poses.
        gt: usize,
    },
    /// Alignment: a ground-truth pose has a NaN or infinite component.
    #[error("ground-truth pose of frame {frame} is not finite")]
    NonFiniteGroundTruth {
        /// Index of the frame.
        frame: usize,
    },
}
