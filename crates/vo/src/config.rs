//! [`VoConfig`]: every setting of the visual odometry, serialisable so a run can be repeated
//! from its own files.

use endoloc_features::{MatcherConfig, SurfConfig};
use endoloc_geometry::{
    EssentialRansacConfig, RansacConfig, RefineConfig, RobustKernel, TriangulationConfig,
};
use serde::{Deserialize, Serialize};

/// Settings of [`crate::VisualOdometry`]. Lengths inside the odometry are in VO units (the
/// first baseline of each tracked segment is one unit); pixel thresholds are in pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct VoConfig {
    /// SURF detector and descriptor. Default: threshold 50 (a quarter of the paper's 200:
    /// tracking needs many more keypoints than zone-map matching; on the 320×240 test
    /// sequence 200 gave 5.7 mm / 10° worst errors over 36 mm of travel, 50 gave 2.3 mm /
    /// 2.2°), the paper's 4 octaves and 6 scale levels, serial (same results on any number
    /// of threads).
    pub surf: SurfConfig,
    /// Descriptor matching (frame↔frame at initialization, frame↔map while tracking).
    pub matcher: MatcherConfig,
    /// RANSAC of the essential matrix at initialization (Sampson threshold in pixels).
    pub essential: EssentialRansacConfig,
    /// RANSAC P3P against the map while tracking (reprojection threshold in pixels). Its
    /// seed is combined with the frame index, so every frame draws its own samples.
    pub pnp: RansacConfig,
    /// Gauss-Newton refinement of every tracked pose (inlier threshold in pixels).
    pub refine: RefineConfig,
    /// Two-view triangulation of new map points (δr in pixels, parallax in degrees; its
    /// `min_depth_mm` is in VO units here).
    pub triangulation: TriangulationConfig,
    /// Initialization needs at least this many descriptor matches between the reference
    /// frame and the current one; fewer → the current frame becomes the new reference.
    pub init_min_matches: usize,
    /// Initialization needs at least this many points triangulated in front of both views.
    pub init_min_points: usize,
    /// Initialization waits until the median triangulation angle of those points reaches
    /// this, degrees (too little parallax gives an unreliable map).
    pub init_min_parallax_deg: f64,
    /// The reference frame is replaced by the current one after this many frames without a
    /// successful initialization.
    pub init_max_frames: usize,
    /// Tracking is lost when fewer than this many map points are inliers of the frame's pose.
    pub min_tracked_inliers: usize,
    /// A new keyframe (with new triangulated points) is inserted at the latest after this
    /// many frames.
    pub keyframe_max_gap: usize,
    /// A new keyframe is inserted as soon as the inliers fall below this fraction of the
    /// inliers at the last keyframe (dimensionless).
    pub keyframe_min_inlier_ratio: f64,
    /// Map points not seen as inliers during the last this-many keyframes are dropped from
    /// the local map.
    pub local_map_keyframes: usize,
}

impl Default for VoConfig {
    fn default() -> Self {
        Self {
            surf: SurfConfig::default()
                .with_threshold(50.0)
                .with_parallel(false),
            matcher: MatcherConfig::default().with_parallel(false),
            essential: EssentialRansacConfig {
                threshold_px: 1.5,
                ..EssentialRansacConfig::default()
            },
            pnp: RansacConfig {
                threshold_px: 3.0,
                min_inliers: 8,
                ..RansacConfig::default()
            },
            refine: RefineConfig {
                kernel: RobustKernel::Huber { scale_px: 1.5 },
                inlier_threshold_px: 3.0,
                // Least squares on the inliers: the Cauchy polish was chosen on map
                // registrations and is not measured on VO's short-baseline points.
                polish_kernel: RobustKernel::None,
                ..RefineConfig::default()
            },
            triangulation: TriangulationConfig {
                delta_r_px: 3.0,
                min_parallax_deg: 1.0,
                ..TriangulationConfig::default()
            },
            init_min_matches: 40,
            init_min_points: 30,
            init_min_parallax_deg: 1.5,
            init_max_frames: 30,
            min_tracked_inliers: 15,
            keyframe_max_gap: 8,
            keyframe_min_inlier_ratio: 0.6,
            local_map_keyframes: 6,
        }
    }
}

impl VoConfig {
    /// Checks ranges.
    ///
    /// # Errors
    /// A message naming the first bad field and the expected range.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.init_min_parallax_deg.is_finite() && self.init_min_parallax_deg >= 0.0) {
            return Err(format!(
                "init_min_parallax_deg must be ≥ 0, got {}",
                self.init_min_parallax_deg
            ));
        }
        if !(self.keyframe_min_inlier_ratio.is_finite()
            && (0.0..=1.0).contains(&self.keyframe_min_inlier_ratio))
        {
            return Err(format!(
                "keyframe_min_inlier_ratio must be in [0, 1], got {}",
                self.keyframe_min_inlier_ratio
            ));
        }
        for (name, v, min) in [
            ("init_min_matches", self.init_min_matches, 8),
            ("init_min_points", self.init_min_points, 6),
            ("init_max_frames", self.init_max_frames, 1),
            ("min_tracked_inliers", self.min_tracked_inliers, 6),
            ("keyframe_max_gap", self.keyframe_max_gap, 1),
            ("local_map_keyframes", self.local_map_keyframes, 1),
        ] {
            if v < min {
                return Err(format!("{name} must be at least {min}, got {v}"));
            }
        }
        Ok(())
    }
}
