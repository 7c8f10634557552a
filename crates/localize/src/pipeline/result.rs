//! What the localizer says of one frame: pose, status, where the pose came from, times.

use endoloc_geometry::{Pose, Reason, Status, WallCovariance};
use nalgebra::{Matrix6, Point3};
use serde::{Deserialize, Serialize};

/// Time spent in each stage of one frame, milliseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Siamese descriptor and zone look-up.
    pub zone_ms: f64,
    /// SURF detection and description.
    pub surf_ms: f64,
    /// Matching to the map points.
    pub matching_ms: f64,
    /// Gauss-Newton (and RANSAC) with the validity check.
    pub refine_ms: f64,
}

impl StageTimes {
    /// Sum of the stages, ms.
    pub fn total_ms(&self) -> f64 {
        self.zone_ms + self.surf_ms + self.matching_ms + self.refine_ms
    }
}

/// Where a frame's reported pose comes from (the `source` column of `frames.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseSource {
    /// Registered to the map and refined: the status is `refined`.
    Refined,
    /// Live mode: the motion model's prediction from the recent refined frames.
    Predicted,
    /// Registered to the map and refined, but not trusted (status `init_only`): too uncertain
    /// (per frame, reason `uncertain`) or not confirmed by the map points near it (reason
    /// `unsupported`, `weakly_supported` or `ambiguous`).
    Registered,
    /// The classified zone's median training pose (the paper's initial pose).
    ZoneMedian,
    /// No pose (`rejected`).
    None,
}

impl PoseSource {
    /// The keyword written to `frames.csv`.
    pub fn as_str(&self) -> &'static str {
        match self {
            PoseSource::Refined => "refined",
            PoseSource::Predicted => "predicted",
            PoseSource::Registered => "registered",
            PoseSource::ZoneMedian => "zone_median",
            PoseSource::None => "none",
        }
    }
}

impl std::fmt::Display for PoseSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What a registered pose's stated uncertainty is made of, before
/// [`LocalizerConfig::uncertainty_scale`](crate::LocalizerConfig::uncertainty_scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseUncertainty {
    /// The registered pose `T_wc` (mm) the covariances are of: the frame's reported pose,
    /// unless live reports the motion model's prediction for a pose it does not trust.
    pub t_wc: Pose,
    /// The refinement's covariance of the left perturbation `δ = [ρ; φ]` of `T_wc` (world
    /// frame; mm² / mm·rad / rad²), from independent residuals.
    pub covariance: Matrix6<f64>,
    /// The wall-motion term's parts
    /// ([`LocalizerConfig::wall_covariance`](crate::LocalizerConfig::wall_covariance)); `None`
    /// when it is off or the inliers do not allow it.
    pub wall: Option<WallCovariance>,
}

/// The outcome for one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameResult {
    /// Zone used (after temporal filtering, if any).
    pub zone: usize,
    /// The classifier's score of that zone (descriptor distance, lower = better); NaN when the
    /// frame was not classified (live, tracked from the motion model's prediction: see
    /// [`LocalizerConfig::classify_tracked`](crate::LocalizerConfig::classify_tracked)).
    pub zone_score: f32,
    /// `refined`, `init_only` or `rejected`.
    pub status: Status,
    /// Why, when not `refined`.
    pub reason: Option<Reason>,
    /// Pose `T_wc` (mm): refined, or for `init_only` the zone median (live: the motion
    /// model's prediction while it is fresh); `None` when rejected.
    pub t_wc: Option<Pose>,
    /// Where [`FrameResult::t_wc`] comes from.
    pub source: PoseSource,
    /// Calibrated standard deviation of the camera centre along its least certain direction,
    /// mm ([`LocalizerConfig::uncertainty_scale`](crate::LocalizerConfig::uncertainty_scale) ×
    /// that of the Gauss-Newton covariance plus the wall-motion term,
    /// [`LocalizerConfig::wall_covariance`](crate::LocalizerConfig::wall_covariance): per frame
    /// with the wall's motion this registration shows, live with the larger of that and what
    /// the stream's recent registrations show together); NaN unless refined.
    pub position_std_mm: f64,
    /// Calibrated standard deviation of the orientation about its least certain axis,
    /// degrees; NaN unless refined.
    pub orientation_std_deg: f64,
    /// The registration's position standard deviation as a measurement, mm: calibrated as
    /// [`FrameResult::position_std_mm`], without the wall-motion term. Live, the motion
    /// model's prediction — registered to the same wall, moved or not — checks a weak pose's
    /// sharpness against it before vouching for the pose. NaN unless refined.
    pub measurement_std_mm: f64,
    /// What [`FrameResult::position_std_mm`] and [`FrameResult::orientation_std_deg`] are
    /// made of; `None` exactly when they are NaN, or when another model states them (the
    /// colon-scale step).
    pub uncertainty: Option<PoseUncertainty>,
    /// Correspondences found by matching.
    pub correspondences: usize,
    /// Inliers of the final estimate.
    pub inliers: usize,
    /// Pixel positions of those inliers' keypoints in the test image (origin at the centre of
    /// the top-left pixel, x right, y down), in match order.
    pub inlier_px: Vec<[f32; 2]>,
    /// The map points of those inliers (world, mm), in the order of `inlier_px`.
    pub inlier_points: Vec<Point3<f64>>,
    /// The colon's scale about its mid-line against the map's, when the pose was refined
    /// with it ([`LocalizerConfig::colon_scale`](crate::LocalizerConfig::colon_scale));
    /// `None` otherwise.
    pub colon_scale: Option<f64>,
    /// RMS reprojection error of the inliers, pixels (NaN when no estimate).
    pub reprojection_rms_px: f64,
    /// Per-stage time.
    pub times: StageTimes,
}

impl FrameResult {
    /// The zone of a frame that has none ([`FrameResult::unreadable`]).
    pub const NO_ZONE: usize = usize::MAX;

    /// A frame whose image could not be read or decoded: `rejected` with reason
    /// `unreadable_image`, no zone ([`FrameResult::NO_ZONE`]) and no pose. A live scope drops
    /// and corrupts frames; a run reports them and goes on.
    pub fn unreadable(detail: impl Into<String>) -> Self {
        FrameResult {
            zone: Self::NO_ZONE,
            zone_score: f32::NAN,
            status: Status::Rejected,
            reason: Some(Reason::UnreadableImage {
                detail: detail.into(),
            }),
            t_wc: None,
            source: PoseSource::None,
            position_std_mm: f64::NAN,
            orientation_std_deg: f64::NAN,
            measurement_std_mm: f64::NAN,
            uncertainty: None,
            correspondences: 0,
            inliers: 0,
            inlier_px: Vec::new(),
            inlier_points: Vec::new(),
            colon_scale: None,
            reprojection_rms_px: f64::NAN,
            times: StageTimes::default(),
        }
    }

    /// Whether the frame was given a zone (false for an unreadable frame).
    pub fn has_zone(&self) -> bool {
        self.zone != Self::NO_ZONE
    }
}
