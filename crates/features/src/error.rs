//! Errors of the SURF detector, descriptor and matcher.

use thiserror::Error;

/// Everything that can go wrong in `endoloc-features`.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FeatureError {
    /// A mask without a single valid pixel.
    #[error("the {width} × {height} mask has no valid (non-zero) pixel")]
    EmptyMask {
        /// Mask width in pixels.
        width: usize,
        /// Mask height in pixels.
        height: usize,
    },
    /// The mask and the image differ in size.
    #[error(
        "the mask is {mask_width} × {mask_height} pixels but the image is {width} × {height}; \
         expected a mask of the frames' size"
    )]
    MaskSize {
        /// Mask width.
        mask_width: usize,
        /// Mask height.
        mask_height: usize,
        /// Image width.
        width: usize,
        /// Image height.
        height: usize,
    },
    /// The pixel buffer does not hold `width × height` values.
    #[error(
        "pixel buffer holds {actual} values, expected width {width} × height {height} = {expected}"
    )]
    BufferSize {
        /// Image width in pixels.
        width: usize,
        /// Image height in pixels.
        height: usize,
        /// `width × height`.
        expected: usize,
        /// Length of the buffer that was passed.
        actual: usize,
    },
    /// The image has more pixels than [`crate::SurfConfig::max_pixels`] allows.
    #[error(
        "image of {width} × {height} pixels exceeds the limit of {max_pixels} pixels \
         (SurfConfig::max_pixels); downscale it or raise the limit"
    )]
    ImageTooLarge {
        /// Image width in pixels.
        width: usize,
        /// Image height in pixels.
        height: usize,
        /// The configured limit.
        max_pixels: usize,
    },
    /// A pixel of a floating-point image is NaN or infinite.
    #[error("pixel ({x}, {y}) is {value}, expected a finite intensity on the 0..1 scale")]
    NonFinitePixel {
        /// Column of the pixel.
        x: usize,
        /// Row of the pixel.
        y: usize,
        /// The offending value.
        value: f32,
    },
    /// A configuration field is out of its valid range.
    #[error("invalid SURF/matcher configuration: `{field}` {reason}")]
    InvalidConfig {
        /// Name of the field.
        field: &'static str,
        /// What is wrong and what was expected.
        reason: String,
    },
    /// Two descriptors that should be compared have different lengths (64 vs 128).
    #[error(
        "descriptor length mismatch: {which} #{index} has {actual} values, expected {expected} \
         (do not mix 64-d and 128-d/extended descriptors)"
    )]
    DescriptorLength {
        /// `"query"` or `"train"`.
        which: &'static str,
        /// Index of the offending item.
        index: usize,
        /// Expected length (that of the first query descriptor).
        expected: usize,
        /// Actual length.
        actual: usize,
    },
    /// A keypoint file could not be parsed.
    #[error("{file}: line {line}: {reason}")]
    ParseKeypoints {
        /// File name (or other description of the source).
        file: String,
        /// 1-based line number.
        line: usize,
        /// What was found and what was expected.
        reason: String,
    },
}
