//! SURF keypoints, descriptors and matching for endoloc (Bay et al., "Speeded-Up Robust
//! Features", ECCV 2006 / CVIU 2008), written from the papers.
//!
//! - [`Surf`] (built from [`SurfConfig`]): fast-Hessian detector on an integral image,
//!   orientation from Haar responses in a sliding 60° window (or upright U-SURF), 64-d or
//!   128-d descriptor. Parameters and thresholds map one-to-one onto MATLAB's
//!   `detectSURFFeatures` (see [`config`]).
//! - [`Mask`]: the valid area of the frames (black border, circular field stop); a [`Surf`]
//!   given one with [`Surf::with_mask`] detects and describes only inside it.
//! - [`Matcher`]: brute-force L2 with Lowe's ratio test, mutual-nearest check and
//!   Laplacian-sign gating, for image↔image and image↔map-point matching ([`Describe`]).
//! - [`repeatability`], [`warp`] and [`texture`]: the evaluation behind `REPEATABILITY.md`.
//! - [`draw`] and [`io`]: overlays and keypoint files for the `endoloc features` command.
//!
//! Pixel coordinates: origin at the centre of the top-left pixel, x right, y down;
//! orientations in radians in image axes (0 = +x, π/2 = +y, clockwise on screen).
//!
//! ```
//! use endoloc_features::{SurfConfig, texture};
//! let image = texture::textured_image(160, 120, 7);
//! let surf = SurfConfig::default().with_parallel(false).init()?;
//! let features = surf.detect_and_describe(&image)?;
//! assert!(!features.is_empty());
//! assert_eq!(features[0].descriptor.len(), 64);
//! # Ok::<(), endoloc_features::FeatureError>(())
//! ```

#![warn(missing_docs)]

pub mod config;
mod descriptor;
pub mod draw;
mod error;
mod hessian;
pub mod integral;
pub mod io;
mod keypoint;
pub mod mask;
pub mod mask_detect;
pub mod matcher;
mod orientation;
pub mod repeatability;
pub mod texture;
pub mod warp;

#[cfg(test)]
mod config_tests;

pub use config::{Intensity, LOG_INTENSITY_OFFSET, SurfConfig};
pub use error::FeatureError;
pub use integral::IntegralImage;
pub use keypoint::{BLOB_SIGMA_PER_SCALE, Describe, Feature, Keypoint};
pub use mask::Mask;
pub use mask_detect::{DetectedMask, MaskDetectConfig, MaskShape, detect_mask};
pub use matcher::{Match, Matcher, MatcherConfig};

use std::sync::Arc;

use image::GrayImage;
use rayon::prelude::*;

/// The SURF detector and descriptor, built by [`SurfConfig::init`].
#[derive(Debug, Clone)]
pub struct Surf {
    config: SurfConfig,
    /// The valid area of the frames, when they have one.
    mask: Option<Arc<Mask>>,
    /// [`SurfConfig::intensity`]'s 8-bit lookup table (`None`: linear).
    table: Option<[u8; 256]>,
}

impl Surf {
    pub(crate) fn from_validated(config: SurfConfig) -> Self {
        let table = config.intensity.table();
        Self {
            config,
            mask: None,
            table,
        }
    }

    /// The configuration this detector was built from.
    pub fn config(&self) -> &SurfConfig {
        &self.config
    }

    /// This detector restricted to the valid area of `mask` (see [`mask`]): keypoints whose
    /// box filter reaches outside it are dropped, and orientation and descriptor samples
    /// outside it count as zero. Images must then have the mask's size. `None`: the whole
    /// image.
    pub fn with_mask(mut self, mask: Option<Arc<Mask>>) -> Self {
        self.mask = mask;
        self
    }

    /// The mask, when one is set.
    pub fn mask(&self) -> Option<&Mask> {
        self.mask.as_deref()
    }

    fn check_mask(&self, width: usize, height: usize) -> Result<(), FeatureError> {
        match &self.mask {
            Some(m) if (m.width(), m.height()) != (width, height) => Err(FeatureError::MaskSize {
                mask_width: m.width(),
                mask_height: m.height(),
                width,
                height,
            }),
            _ => Ok(()),
        }
    }

    /// Integral image of an 8-bit grey image (0..255), its intensities transformed as
    /// [`SurfConfig::intensity`] says.
    ///
    /// # Errors
    /// [`FeatureError::ImageTooLarge`] beyond [`SurfConfig::max_pixels`].
    pub fn integral_from_gray(&self, image: &GrayImage) -> Result<IntegralImage, FeatureError> {
        let (w, h) = (image.width() as usize, image.height() as usize);
        self.check_size(w, h)?;
        self.check_mask(w, h)?;
        match &self.table {
            None => Ok(IntegralImage::from_u8(image.as_raw(), w, h)),
            Some(table) => {
                let mapped: Vec<u8> = image
                    .as_raw()
                    .iter()
                    .map(|&v| table[usize::from(v)])
                    .collect();
                Ok(IntegralImage::from_u8(&mapped, w, h))
            }
        }
    }

    /// Integral image of a row-major `f32` image with intensities on the 0..1 scale
    /// (multiplied by 255 so that thresholds mean the same as for 8-bit images).
    ///
    /// # Errors
    /// [`FeatureError::BufferSize`] when `pixels.len() != width·height`,
    /// [`FeatureError::ImageTooLarge`] beyond [`SurfConfig::max_pixels`],
    /// [`FeatureError::NonFinitePixel`] for NaN/∞ values.
    pub fn integral_from_f32(
        &self,
        pixels: &[f32],
        width: usize,
        height: usize,
    ) -> Result<IntegralImage, FeatureError> {
        let expected = width
            .checked_mul(height)
            .ok_or(FeatureError::ImageTooLarge {
                width,
                height,
                max_pixels: self.config.max_pixels,
            })?;
        self.check_size(width, height)?;
        self.check_mask(width, height)?;
        if pixels.len() != expected {
            return Err(FeatureError::BufferSize {
                width,
                height,
                expected,
                actual: pixels.len(),
            });
        }
        if let Some(i) = pixels.iter().position(|v| !v.is_finite()) {
            return Err(FeatureError::NonFinitePixel {
                x: i % width,
                y: i / width,
                value: pixels[i],
            });
        }
        let intensity = self.config.intensity;
        if intensity.is_linear() {
            Ok(IntegralImage::from_f32_unit(pixels, width, height))
        } else {
            let mapped: Vec<f32> = pixels
                .iter()
                .map(|&v| intensity.apply(v * 255.0) / 255.0)
                .collect();
            Ok(IntegralImage::from_f32_unit(&mapped, width, height))
        }
    }

    fn check_size(&self, width: usize, height: usize) -> Result<(), FeatureError> {
        match width.checked_mul(height) {
            Some(n) if n <= self.config.max_pixels => Ok(()),
            _ => Err(FeatureError::ImageTooLarge {
                width,
                height,
                max_pixels: self.config.max_pixels,
            }),
        }
    }

    /// Keypoints of an 8-bit grey image, with orientations unless upright. Black, constant and
    /// tiny images give no keypoints.
    ///
    /// # Errors
    /// [`FeatureError::ImageTooLarge`] beyond [`SurfConfig::max_pixels`].
    pub fn detect(&self, image: &GrayImage) -> Result<Vec<Keypoint>, FeatureError> {
        let ii = self.integral_from_gray(image)?;
        Ok(self.detect_integral(&ii))
    }

    /// Keypoints and descriptors of an 8-bit grey image.
    ///
    /// # Errors
    /// [`FeatureError::ImageTooLarge`] beyond [`SurfConfig::max_pixels`].
    pub fn detect_and_describe(&self, image: &GrayImage) -> Result<Vec<Feature>, FeatureError> {
        let ii = self.integral_from_gray(image)?;
        let kps = self.detect_integral(&ii);
        Ok(self.describe_integral(&ii, &kps))
    }

    /// Keypoints and descriptors of a row-major `f32` image on the 0..1 scale.
    ///
    /// # Errors
    /// As [`Surf::integral_from_f32`].
    pub fn detect_and_describe_f32(
        &self,
        pixels: &[f32],
        width: usize,
        height: usize,
    ) -> Result<Vec<Feature>, FeatureError> {
        let ii = self.integral_from_f32(pixels, width, height)?;
        let kps = self.detect_integral(&ii);
        Ok(self.describe_integral(&ii, &kps))
    }

    /// Descriptors of given keypoints (their orientation is used as it is).
    ///
    /// # Errors
    /// [`FeatureError::ImageTooLarge`] beyond [`SurfConfig::max_pixels`].
    pub fn describe(
        &self,
        image: &GrayImage,
        keypoints: &[Keypoint],
    ) -> Result<Vec<Feature>, FeatureError> {
        let ii = self.integral_from_gray(image)?;
        Ok(self.describe_integral(&ii, keypoints))
    }

    /// Fast-Hessian detection plus orientation assignment on a prepared integral image (of the
    /// mask's size when a mask is set).
    pub fn detect_integral(&self, ii: &IntegralImage) -> Vec<Keypoint> {
        let mut kps = hessian::detect(ii, &self.config);
        if let Some(m) = &self.mask {
            kps.retain(|kp| m.contains_disc(kp.x, kp.y, mask::DETECTOR_REACH_PER_SCALE * kp.scale));
        }
        if let Some(cap) = self.config.keypoint_cap(ii.width(), ii.height())
            && kps.len() > cap
        {
            // Strongest first; ties broken by position so the result does not depend on the
            // detector's (parallel) output order.
            kps.sort_by(|a, b| {
                b.response
                    .abs()
                    .total_cmp(&a.response.abs())
                    .then(a.y.total_cmp(&b.y))
                    .then(a.x.total_cmp(&b.x))
                    .then(a.scale.total_cmp(&b.scale))
            });
            kps.truncate(cap);
        }
        if !self.config.upright {
            let mask = self.mask.as_deref();
            let orient = |kp: &mut Keypoint| {
                kp.orientation = orientation::orientation(ii, mask, kp.x, kp.y, kp.scale);
            };
            if self.config.parallel {
                kps.par_iter_mut().for_each(orient);
            } else {
                kps.iter_mut().for_each(orient);
            }
        }
        kps
    }

    /// Descriptors for keypoints on a prepared integral image.
    pub fn describe_integral(&self, ii: &IntegralImage, keypoints: &[Keypoint]) -> Vec<Feature> {
        let extended = self.config.extended;
        let mask = self.mask.as_deref();
        let one = |kp: &Keypoint| {
            let mut d = Vec::with_capacity(self.config.descriptor_len());
            descriptor::describe(
                ii,
                mask,
                kp.x,
                kp.y,
                kp.scale,
                kp.orientation,
                extended,
                &mut d,
            );
            Feature {
                keypoint: *kp,
                descriptor: d,
            }
        };
        if self.config.parallel {
            keypoints.par_iter().map(one).collect()
        } else {
            keypoints.iter().map(one).collect()
        }
    }
}
