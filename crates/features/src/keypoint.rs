//! [`Keypoint`] and [`Feature`]: what the detector returns.

use serde::{Deserialize, Serialize};

/// A SURF keypoint.
///
/// Pixel coordinates have their origin at the centre of the top-left pixel, x to the right,
/// y down (`docs/CONVENTIONS.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Keypoint {
    /// Column of the blob centre, pixels (sub-pixel, interpolated).
    pub x: f32,
    /// Row of the blob centre, pixels (sub-pixel, interpolated).
    pub y: f32,
    /// Scale σ in pixels: `1.2 · filter_size / 9` (σ of the Gaussian whose second derivatives
    /// the box filters approximate). OpenCV's `KeyPoint::size` is `filter_size = 7.5·σ`.
    pub scale: f32,
    /// Dominant orientation in radians in `[0, 2π)`, measured in image axes: 0 points along
    /// +x (right), π/2 along +y (down), i.e. clockwise on screen. 0 for upright (U-SURF).
    pub orientation: f32,
    /// Hessian-determinant response (interpolated), in the units of
    /// [`crate::SurfConfig::threshold`].
    pub response: f32,
    /// Sign of the Laplacian (trace of the Hessian): +1 for a dark blob on a bright
    /// background, −1 for a bright blob on a dark background.
    pub laplacian: i8,
    /// Octave the keypoint was found in (0-based).
    pub octave: u8,
}

/// Ratio of a Gaussian blob's standard deviation to the SURF scale at which it is detected
/// (measured in `tests/blobs.rs`: a blob of σ_b peaks at filter size `L ≈ 5.3·σ_b`, reported
/// as `scale = 1.2·L/9 ≈ 0.70·σ_b`; OpenCV/MATLAB share this convention and this bias).
pub const BLOB_SIGMA_PER_SCALE: f32 = 1.42;

impl Keypoint {
    /// Standard deviation in pixels of the Gaussian blob this keypoint best responds to:
    /// `scale · BLOB_SIGMA_PER_SCALE`.
    pub fn blob_sigma(&self) -> f32 {
        self.scale * BLOB_SIGMA_PER_SCALE
    }
}

/// A keypoint with its SURF descriptor (unit L2 norm, 64 or 128 values).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Feature {
    /// Where and at which scale/orientation.
    pub keypoint: Keypoint,
    /// The descriptor, L2-normalised; 64 values, or 128 when extended.
    pub descriptor: Vec<f32>,
}

/// Anything the [`crate::Matcher`] can match: an image feature, or a 3-D map point that
/// carries the descriptor and Laplacian sign of the observations it was triangulated from.
pub trait Describe {
    /// The descriptor (all items matched together must have the same length).
    fn descriptor(&self) -> &[f32];
    /// Sign of the Laplacian (+1 / −1; 0 = unknown, matches either sign).
    fn laplacian(&self) -> i8;
}

impl Describe for Feature {
    fn descriptor(&self) -> &[f32] {
        &self.descriptor
    }
    fn laplacian(&self) -> i8 {
        self.keypoint.laplacian
    }
}

impl<T: Describe + ?Sized> Describe for &T {
    fn descriptor(&self) -> &[f32] {
        (**self).descriptor()
    }
    fn laplacian(&self) -> i8 {
        (**self).laplacian()
    }
}
