//! [`SurfConfig`]: the parameters of the fast-Hessian detector and the SURF descriptor.
//!
//! # Relation to MATLAB's `detectSURFFeatures` (the paper: MetricThreshold 200, NumOctaves 4,
//! NumScaleLevels 6)
//!
//! MATLAB's detector runs OpenCV's fast-Hessian code on the image converted to `uint8`
//! (`im2uint8`), with `hessianThreshold = MetricThreshold`, `nOctaves = NumOctaves` and
//! `nOctaveLayers = NumScaleLevels − 2`. This crate uses the same scale space and the same
//! response units, so the MATLAB values carry over unchanged:
//!
//! | MATLAB | OpenCV `SURF_create` | here |
//! |---|---|---|
//! | `MetricThreshold` 200 | `hessianThreshold` 200 | [`SurfConfig::threshold`] 200 |
//! | `NumOctaves` 4 | `nOctaves` 4 | [`SurfConfig::octaves`] 4 |
//! | `NumScaleLevels` 6 | `nOctaveLayers` 4 | [`SurfConfig::scale_levels`] 6 |
//! | (none, 1) | (none, 1) | [`SurfConfig::initial_step`] 1 |
//! | `SURFSize` 64/128 in `extractFeatures` | `extended` | [`SurfConfig::extended`] |
//! | `Upright` in `extractFeatures` | `upright` | [`SurfConfig::upright`] |
//!
//! Response units: intensities on the 0..255 scale (8-bit images as they are; `f32` images on
//! the 0..1 scale are multiplied by 255), each lobe of a box filter is normalised by its own
//! area (so `Dxx` is `mean(left lobe) − 2·mean(middle lobe) + mean(right lobe)`), and the
//! response is `Dxx·Dyy − (0.9·Dxy)²`. A keypoint is kept when that response exceeds
//! `threshold`. Filter side lengths are `(9 + 6·level)·2^octave` pixels, the sampling step of
//! octave `o` is `initial_step·2^o`, as in OpenCV and MATLAB.

use serde::{Deserialize, Serialize};

use crate::FeatureError;

/// Parameters of the SURF detector and descriptor. Build a detector with [`SurfConfig::init`].
///
/// ```
/// use endoloc_features::SurfConfig;
/// let surf = SurfConfig::default().with_threshold(400.0).with_upright(true).init()?;
/// # Ok::<(), endoloc_features::FeatureError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SurfConfig {
    /// Hessian-determinant threshold, in the units of MATLAB's `MetricThreshold` and OpenCV's
    /// `hessianThreshold` (0..255 intensities, lobe-area-normalised box filters).
    /// Default 200 (the paper's value). Larger → fewer, stronger keypoints.
    pub threshold: f32,
    /// Number of octaves (MATLAB `NumOctaves`). Octave `o` doubles the filter sizes and the
    /// sampling step of octave `o − 1`. Default 4 (the paper's value). Range 1..=8.
    pub octaves: usize,
    /// Number of filter sizes per octave (MATLAB `NumScaleLevels`); keypoints are searched in
    /// the `scale_levels − 2` inner levels. Default 6 (the paper's value). Range 3..=12.
    pub scale_levels: usize,
    /// Sampling step of the first octave in pixels (1 = every pixel, as MATLAB/OpenCV; 2 as
    /// in the original SURF code, about 3× faster and less precise). Default 1. Range 1..=8.
    pub initial_step: usize,
    /// U-SURF: skip the orientation assignment (orientation 0 = along +x). Faster and more
    /// distinctive when the camera does not roll. Default false.
    pub upright: bool,
    /// 128-d extended descriptor instead of the 64-d one. Default false.
    pub extended: bool,
    /// Use all rayon threads (filter responses row-parallel, descriptors keypoint-parallel).
    /// The output is identical either way. Default true.
    pub parallel: bool,
    /// Largest image accepted, in pixels; bigger images get
    /// [`FeatureError::ImageTooLarge`] instead of allocating gigabytes (memory use is about
    /// 32 bytes per pixel). Default 16 777 216 (4096 × 4096).
    pub max_pixels: usize,
    /// Keep only the strongest keypoints (largest Hessian response), at most this many, before
    /// orientation and description; 0 = keep all. A cap bounds the time per frame on richly
    /// textured frames (description and matching grow with the count). Default 0.
    pub max_keypoints: usize,
    /// Keep only the strongest keypoints, at most `keypoint_budget · √(width · height)` of
    /// them for a `width × height` image (2.0: 554 at 320×240, 1 109 at 640×480), before
    /// orientation and description; 0 = no budget. With a low [`SurfConfig::threshold`] this
    /// is a keypoint budget per frame instead of a fixed threshold: a sharp, well-lit frame
    /// keeps its strongest keypoints, a blurred or dim one (whose responses all fall) keeps
    /// what a fixed threshold would lose. The count grows with the image's side, not its
    /// area, as SURF's keypoints do on the same scene at a finer resolution. Applied together
    /// with [`SurfConfig::max_keypoints`] (the smaller cap wins). Default 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub keypoint_budget: f32,
    /// Compute the filter responses sample by sample at every level, the detector's plain
    /// reference loop, instead of in vectorised rows with the outer levels of each octave
    /// evaluated on demand. The keypoints are the same bit for bit; it is there to measure
    /// the speed-up (`endoloc bench live`). Default false.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub reference_filters: bool,
    /// How pixel intensities enter the detector and the descriptor: as they are (default,
    /// SURF as published) or on a log scale ([`Intensity::Log`]). Maps record it; a map's test
    /// frames are described the same way.
    #[serde(skip_serializing_if = "Intensity::is_linear")]
    pub intensity: Intensity,
}

/// How pixel intensities enter SURF.
///
/// SURF's descriptor is normalised, so it ignores a gain, but not a change of contrast that
/// differs from place to place: another exposure curve (gamma), a light that falls off
/// differently, stronger highlights and sheen. On a log scale a gain is an offset and a gamma
/// a gain, both of which the box filters and the normalisation ignore, and a dim region's
/// texture counts as much as a bright one's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Intensity {
    /// Intensities as they are, 0..255.
    #[default]
    Linear,
    /// `255 · ln(1 + v / 8) / ln(1 + 255 / 8)` of each intensity `v` (0..255): still 0..255,
    /// the offset 8 keeping the sensor noise of black regions from being amplified without
    /// bound. Thresholds keep their units (a mid-grey region's contrast is scaled by about
    /// 0.6, a dark one's raised).
    Log,
}

/// The offset of [`Intensity::Log`], in 0..255 intensity units.
pub const LOG_INTENSITY_OFFSET: f32 = 8.0;

impl std::fmt::Display for Intensity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Intensity::Linear => "linear",
            Intensity::Log => "log",
        })
    }
}

impl Intensity {
    /// Whether intensities are used as they are.
    pub fn is_linear(&self) -> bool {
        *self == Intensity::Linear
    }

    /// The transformed value of intensity `v` on the 0..255 scale.
    pub fn apply(self, v: f32) -> f32 {
        match self {
            Intensity::Linear => v,
            Intensity::Log => {
                255.0 * (v.max(0.0) / LOG_INTENSITY_OFFSET).ln_1p()
                    / (255.0 / LOG_INTENSITY_OFFSET).ln_1p()
            }
        }
    }

    /// The 8-bit lookup table of [`Intensity::apply`] (rounded), `None` for linear.
    pub fn table(self) -> Option<[u8; 256]> {
        match self {
            Intensity::Linear => None,
            Intensity::Log => {
                let mut t = [0u8; 256];
                for (v, out) in t.iter_mut().enumerate() {
                    *out = self.apply(v as f32).round().clamp(0.0, 255.0) as u8;
                }
                Some(t)
            }
        }
    }
}

impl Default for SurfConfig {
    fn default() -> Self {
        Self {
            threshold: 200.0,
            octaves: 4,
            scale_levels: 6,
            initial_step: 1,
            upright: false,
            extended: false,
            parallel: true,
            max_pixels: 1 << 24,
            max_keypoints: 0,
            keypoint_budget: 0.0,
            reference_filters: false,
            intensity: Intensity::Linear,
        }
    }
}

impl SurfConfig {
    /// Sets [`SurfConfig::threshold`].
    pub fn with_threshold(mut self, threshold: f32) -> Self {
        self.threshold = threshold;
        self
    }
    /// Sets [`SurfConfig::octaves`].
    pub fn with_octaves(mut self, octaves: usize) -> Self {
        self.octaves = octaves;
        self
    }
    /// Sets [`SurfConfig::scale_levels`].
    pub fn with_scale_levels(mut self, scale_levels: usize) -> Self {
        self.scale_levels = scale_levels;
        self
    }
    /// Sets [`SurfConfig::max_keypoints`].
    pub fn with_max_keypoints(mut self, max_keypoints: usize) -> Self {
        self.max_keypoints = max_keypoints;
        self
    }
    /// Sets [`SurfConfig::keypoint_budget`].
    pub fn with_keypoint_budget(mut self, keypoint_budget: f32) -> Self {
        self.keypoint_budget = keypoint_budget;
        self
    }
    /// Sets [`SurfConfig::initial_step`].
    pub fn with_initial_step(mut self, initial_step: usize) -> Self {
        self.initial_step = initial_step;
        self
    }
    /// Sets [`SurfConfig::upright`].
    pub fn with_upright(mut self, upright: bool) -> Self {
        self.upright = upright;
        self
    }
    /// Sets [`SurfConfig::extended`].
    pub fn with_extended(mut self, extended: bool) -> Self {
        self.extended = extended;
        self
    }
    /// Sets [`SurfConfig::parallel`].
    pub fn with_parallel(mut self, parallel: bool) -> Self {
        self.parallel = parallel;
        self
    }
    /// Sets [`SurfConfig::intensity`].
    pub fn with_intensity(mut self, intensity: Intensity) -> Self {
        self.intensity = intensity;
        self
    }
    /// Sets [`SurfConfig::max_pixels`].
    pub fn with_max_pixels(mut self, max_pixels: usize) -> Self {
        self.max_pixels = max_pixels;
        self
    }

    /// The most keypoints kept in a `width × height` image ([`SurfConfig::max_keypoints`] and
    /// [`SurfConfig::keypoint_budget`], the smaller); `None` = all.
    pub fn keypoint_cap(&self, width: usize, height: usize) -> Option<usize> {
        let budget = (self.keypoint_budget > 0.0).then(|| {
            (self.keypoint_budget as f64 * ((width * height) as f64).sqrt()).round() as usize
        });
        let fixed = (self.max_keypoints > 0).then_some(self.max_keypoints);
        match (budget, fixed) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Length of the descriptors this configuration produces: 64, or 128 when extended.
    pub fn descriptor_len(&self) -> usize {
        if self.extended { 128 } else { 64 }
    }

    /// Checks every field against its documented range.
    ///
    /// # Errors
    /// [`FeatureError::InvalidConfig`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), FeatureError> {
        let bad = |field, reason: &str| {
            Err(FeatureError::InvalidConfig {
                field,
                reason: reason.to_string(),
            })
        };
        if !self.threshold.is_finite() || self.threshold < 0.0 {
            return bad("threshold", "must be a finite number ≥ 0");
        }
        if !(1..=8).contains(&self.octaves) {
            return bad("octaves", "must be in 1..=8");
        }
        if !(3..=12).contains(&self.scale_levels) {
            return bad("scale_levels", "must be in 3..=12");
        }
        if !(1..=8).contains(&self.initial_step) {
            return bad("initial_step", "must be in 1..=8");
        }
        if !self.keypoint_budget.is_finite() || self.keypoint_budget < 0.0 {
            return bad("keypoint_budget", "must be a finite number ≥ 0");
        }
        if self.max_pixels == 0 {
            return bad("max_pixels", "must be > 0");
        }
        Ok(())
    }

    /// Validates the configuration and builds the detector.
    ///
    /// # Errors
    /// [`FeatureError::InvalidConfig`] when a field is out of range.
    pub fn init(self) -> Result<crate::Surf, FeatureError> {
        self.validate()?;
        Ok(crate::Surf::from_validated(self))
    }
}

fn is_zero(v: &f32) -> bool {
    *v == 0.0
}
