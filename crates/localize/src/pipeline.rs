//! Localizing one test frame: the paper's two steps, with an honest status.
//!
//! 1. **Zone**: the Siamese classifier gives the zone (live, filtered over time by the causal
//!    track filter over training frames, [`endoloc_net::track`], anchored at each refined
//!    pose; the zone-level HMM for predictions without a descriptor).
//! 2. **Initial pose**: the zone's median training pose.
//! 3. **Registration**: SURF on the frame, matched (ratio test, mutual nearest, Laplacian
//!    gating) to the map points of the zone and its `neighbour_zones` neighbours on each side.
//! 4. **Refinement and check**: [`endoloc_geometry::localize_pose`] — Gauss-Newton on SE(3)
//!    with left perturbation from the prior, a RANSAC restart when the prior is poor, and the
//!    validity check (`refined` / `init_only` / `rejected` with a reason).
//!
//! With [`LocalizerConfig::confirm`] on (beyond the paper), every registration is then
//! confirmed against all map points near its pose ([`confirm`](mod@crate::confirm)): refined again from
//! them, or flagged `unsupported`, `weakly_supported` or `ambiguous`.
//!
//! Beyond the paper, a frame that registers nowhere is described again at a lower SURF
//! threshold and tried once more ([`LocalizerConfig::retry_threshold`]): weakly textured
//! frames get the features they need, while the typical frame keeps the cheaper detection.

use std::borrow::Cow;
use std::time::Instant;

use endoloc_features::{Describe, Feature, Matcher, MatcherConfig, Surf, SurfConfig};
use endoloc_geometry::{
    Camera, Pose, Reason, RegistrationConfig, RobustKernel, Status, localize_pose,
};
use endoloc_net::{TemporalConfig, TemporalFilter, TrackFilter, ZoneClassifier, ZonePrediction};
use serde::{Deserialize, Serialize};

use crate::LocalizeError;
use crate::confirm::{ConfirmConfig, confirm};
use crate::map::{Map, MapPoint};
use crate::motion::{Gate, MotionConfig, Prediction, Track};

/// Settings of the localizer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LocalizerConfig {
    /// SURF on the test frames. `None` (default): the map's own SURF settings at twice the
    /// map's threshold (the stronger features: cheaper to detect and match). Any descriptor
    /// setting (`extended`, `upright`) must match the map's for the matching to mean anything.
    pub surf: Option<SurfConfig>,
    /// Matching test features to map points.
    pub matcher: MatcherConfig,
    /// Map points also come from this many zones on each side of the classified one.
    pub neighbour_zones: usize,
    /// Gauss-Newton, RANSAC restart and validity thresholds.
    pub localize: RegistrationConfig,
    /// Zone-level HMM for `--live` when a prediction carries no descriptor (the track filter,
    /// with the model's parameters, is used otherwise).
    pub temporal: TemporalConfig,
    /// Zones tried, best classifier score first, until one gives a `refined` pose with
    /// [`MotionConfig::trusted_inliers`] (beyond the paper, which trusts the top zone): a
    /// misclassified frame usually fails to register in the wrong zone's map and succeeds in
    /// the right one. When only weaker registrations come out, the one with the most inliers
    /// wins. 1 = the paper's behaviour.
    pub candidate_zones: usize,
    /// Live mode only (beyond the paper): after a `refined` frame, the next frame is first
    /// registered from that pose, in the zone it lies in, before the classified zones are
    /// tried — a scope moves little between frames at 30 fps. 0 = off; otherwise the number
    /// of frames a refined pose stays usable as the prior.
    pub track_frames: usize,
    /// Live mode only: when neither tracking nor the candidate zones register, also try the
    /// zones around the last refined pose's zone (one behind, two ahead) for this many frames
    /// after it — the scope cannot have gone far. 0 = off.
    pub recover_frames: usize,
    /// Live mode only: the motion model predicts a pose for at most this many frames after
    /// the last refined one; an `init_only` frame reports that prediction (source
    /// `predicted`) instead of its zone's median pose (a zone median can be a zone away;
    /// an `ambiguous` frame keeps its better-supported pose), and
    /// registrations are gated against it. 0 = no prediction: the zone median, as in the
    /// paper.
    pub hold_frames: usize,
    /// Live mode only: the motion model and its gate ([`MotionConfig`]).
    pub motion: MotionConfig,
    /// Live mode only: run the zone classifier on every frame. Off (default): a frame that
    /// registers from the motion model's prediction ([`LocalizerConfig::track_frames`]) is
    /// not classified — its zone is the one its pose lies in, its `zone_score` is NaN — and
    /// the classifier runs only when tracking fails. The zone filters are anchored at every
    /// refined pose, so what a tracked frame's classification would have told them is
    /// overwritten at once; skipping it saves the network's time on most frames.
    pub classify_tracked: bool,
    /// A frame that registers nowhere with features at the test threshold is described again
    /// at this lower SURF threshold and tried once more (beyond the paper; its time counts in
    /// the frame's SURF time). `None` (default): the map's threshold. `Some(0.0)`, or a value
    /// not below the test threshold, = off.
    pub retry_threshold: Option<f32>,
    /// Calibration of the reported uncertainty: the standard deviations in `frames.csv` are
    /// this many times those of the Gauss-Newton covariance (which sees only the test
    /// keypoints' noise, not the map points' own error), chosen so that
    /// 1.96 × `position_std_mm` bounds about 95 % of refined frames' position errors on
    /// simulated passes.
    pub uncertainty_scale: f64,
    /// Per frame only (no motion model to check a registration against): the largest
    /// calibrated position standard deviation (as in `frames.csv`) of a `refined` frame with
    /// [`MotionConfig::trusted_inliers`] inliers or more, mm. Above it the frame is
    /// `init_only` (reason `uncertain`) and keeps its registered pose (source `registered`).
    /// Infinity (default): off. The stated uncertainty grows as the images shrink, so a limit
    /// suits one camera: on the `paper` preset (640×480) 1.5 mm, with
    /// [`LocalizerConfig::weak_max_std_mm`] 0.75 mm, leaves 2 of 2603 refined frames more
    /// than 5 mm off instead of 85, at 81.9 % refined instead of 94.9 %.
    pub max_std_mm: f64,
    /// As [`LocalizerConfig::max_std_mm`], for registrations with fewer inliers: wrong
    /// registrations (a neighbouring zone's points in a spurious consensus, the camera placed
    /// millimetres too far along the lumen) come with few inliers and a larger stated
    /// uncertainty than right ones.
    pub weak_max_std_mm: f64,
    /// Every registration is confirmed against all map points near its pose and refined again
    /// from them ([`confirm`](mod@crate::confirm); beyond the paper). Off in this
    /// configuration's default, the paper's pipeline; [`ConfirmConfig::standard`] turns it on,
    /// as `endoloc localize` does unless told `--no-confirm`.
    pub confirm: ConfirmConfig,
}

impl Default for LocalizerConfig {
    fn default() -> Self {
        LocalizerConfig {
            surf: None,
            matcher: MatcherConfig::default(),
            neighbour_zones: 1,
            localize: RegistrationConfig::new(),
            temporal: TemporalConfig::default(),
            candidate_zones: 3,
            track_frames: 5,
            recover_frames: 300,
            hold_frames: 60,
            motion: MotionConfig::default(),
            classify_tracked: false,
            retry_threshold: None,
            uncertainty_scale: 3.0,
            max_std_mm: f64::INFINITY,
            weak_max_std_mm: f64::INFINITY,
            confirm: ConfirmConfig::default(),
        }
    }
}

impl LocalizerConfig {
    /// The SURF settings of the test frames for a map built with `map_surf`: [`Self::surf`], or
    /// the map's at twice its threshold.
    pub fn test_surf(&self, map_surf: &SurfConfig) -> SurfConfig {
        self.surf
            .clone()
            .unwrap_or_else(|| map_surf.clone().with_threshold(2.0 * map_surf.threshold))
    }

    /// The retry threshold for a map built with `map_surf` (0 = off): [`Self::retry_threshold`],
    /// or the map's threshold.
    pub fn retry_threshold_for(&self, map_surf: &SurfConfig) -> f32 {
        self.retry_threshold.unwrap_or(map_surf.threshold)
    }
}

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

/// The outcome for one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameResult {
    /// Zone used (after temporal filtering, if any).
    pub zone: usize,
    /// The classifier's score of that zone (descriptor distance, lower = better); NaN when the
    /// frame was not classified (live, tracked from the motion model's prediction: see
    /// [`LocalizerConfig::classify_tracked`]).
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
    /// mm ([`LocalizerConfig::uncertainty_scale`] × the Gauss-Newton covariance's); NaN
    /// unless refined.
    pub position_std_mm: f64,
    /// Calibrated standard deviation of the orientation about its least certain axis,
    /// degrees; NaN unless refined.
    pub orientation_std_deg: f64,
    /// Correspondences found by matching.
    pub correspondences: usize,
    /// Inliers of the final estimate.
    pub inliers: usize,
    /// Pixel positions of those inliers' keypoints in the test image (origin at the centre of
    /// the top-left pixel, x right, y down), in match order.
    pub inlier_px: Vec<[f32; 2]>,
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
            correspondences: 0,
            inliers: 0,
            inlier_px: Vec::new(),
            reprojection_rms_px: f64::NAN,
            times: StageTimes::default(),
        }
    }

    /// Whether the frame was given a zone (false for an unreadable frame).
    pub fn has_zone(&self) -> bool {
        self.zone != Self::NO_ZONE
    }
}

/// A ready-to-run localizer: classifier, maps and settings.
pub struct Localizer {
    classifier: ZoneClassifier,
    map: Map,
    cfg: LocalizerConfig,
    surf: Surf,
    /// SURF at [`LocalizerConfig::retry_threshold`], when that is on.
    retry_surf: Option<Surf>,
    matcher: Matcher,
    /// The live motion gate for this model's training pass.
    gate: Gate,
    /// The image mask (non-zero = valid), when frames have one: the zone network sees frames
    /// black outside it, as in training.
    mask: Option<std::sync::Arc<image::GrayImage>>,
}

/// A frame's SURF features at [`LocalizerConfig::retry_threshold`], extracted beforehand.
#[derive(Debug, Clone, Copy)]
pub struct RetryFeatures<'a> {
    /// The features (with [`Localizer::retry_surf`]).
    pub features: &'a [Feature],
    /// Their extraction time, ms: added to the frame's SURF time when the retry is used.
    pub surf_ms: f64,
}

/// Where a frame's retry features come from.
#[derive(Clone, Copy)]
enum Retry<'a> {
    /// None: no retry.
    None,
    /// Extracted beforehand.
    Features(RetryFeatures<'a>),
    /// Detected from the image when needed.
    Image(&'a image::GrayImage),
}

impl<'a> From<Option<RetryFeatures<'a>>> for Retry<'a> {
    fn from(r: Option<RetryFeatures<'a>>) -> Self {
        r.map_or(Retry::None, Retry::Features)
    }
}

/// Where a live frame's zone prediction comes from.
#[derive(Clone, Copy)]
enum Zones<'a> {
    /// Classified beforehand.
    Ready(&'a ZonePrediction),
    /// Classified from the image when needed.
    Image(&'a image::GrayImage),
}

/// Where the prior of a registration comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Prior {
    /// A zone's median pose: matching by brute force against the zone's map points.
    ZoneMedian,
    /// The motion model's prediction: matching guided within this many pixels of it
    /// ([`crate::guided`]), or by brute force with `None`.
    Predicted { guide_px: Option<f64> },
}

/// The registration of a live frame from the motion model's prediction.
enum Tracked {
    /// No recent prediction (or it lies outside every zone): not tried.
    NotTried,
    /// Refined, and agrees with the prediction.
    Registered(FrameResult),
    /// Tried and failed: the matching and refinement time it took.
    Failed(StageTimes),
}

impl Localizer {
    /// Combines a classifier and its map.
    ///
    /// # Errors
    /// [`LocalizeError::Mismatch`] when the map was built for another zone table or camera;
    /// [`LocalizeError::Config`] for invalid settings.
    pub fn new(
        classifier: ZoneClassifier,
        map: Map,
        cfg: LocalizerConfig,
    ) -> Result<Self, LocalizeError> {
        if map.zones.len() != classifier.zone_count() {
            return Err(LocalizeError::Mismatch(format!(
                "the map has {} zones but the model has {}: rebuild it with endoloc map",
                map.zones.len(),
                classifier.zone_count()
            )));
        }
        let model_zones = classifier.config().provenance.as_ref().map(|p| &p.zones);
        if let (Some(built_for), Some(model)) = (&map.model_zones, model_zones)
            && built_for != model
        {
            return Err(LocalizeError::Mismatch(format!(
                "the map in {} was built for zones with fingerprint {built_for}, but the \
                 model's zones.csv has fingerprint {model} (a map copied from another model?): \
                 rebuild it with endoloc map --model {} --data DATASET --force",
                classifier.dir().display(),
                classifier.dir().display()
            )));
        }
        classifier.check_compatible(&map.camera)?;
        cfg.motion.validate().map_err(LocalizeError::Config)?;
        cfg.confirm.validate()?;
        let refine = &cfg.localize.refine;
        for (name, kernel) in [
            ("kernel", refine.kernel),
            ("polish_kernel", refine.polish_kernel),
        ] {
            if let RobustKernel::Huber { scale_px } | RobustKernel::Cauchy { scale_px } = kernel
                && !(scale_px.is_finite() && scale_px > 0.0)
            {
                return Err(LocalizeError::Config(format!(
                    "refine {name} scale {scale_px} px (localize --polish-px for the polish); \
                     expected a finite value > 0, or 0 for least squares"
                )));
            }
        }
        if !(cfg.uncertainty_scale.is_finite() && cfg.uncertainty_scale > 0.0) {
            return Err(LocalizeError::Config(format!(
                "uncertainty_scale = {}; expected a finite value > 0",
                cfg.uncertainty_scale
            )));
        }
        let test_surf = cfg.test_surf(&map.config.surf);
        let retry = cfg.retry_threshold_for(&map.config.surf);
        let surf = test_surf.clone().init()?;
        let retry_surf = if retry > 0.0 && retry < test_surf.threshold {
            Some(test_surf.with_threshold(retry).init()?)
        } else {
            None
        };
        let matcher = Matcher::new(cfg.matcher.clone());
        let gate = Gate::new(&cfg.motion, classifier.train_poses());
        Ok(Localizer {
            gate,
            mask: None,
            classifier,
            map,
            cfg,
            surf,
            retry_surf,
            matcher,
        })
    }

    /// This localizer for frames with an image mask (black border, field stop): test-frame
    /// SURF, and the retry's, detect and describe only inside it, and the zone network sees
    /// each frame black outside it (as [`endoloc_data::Sequence`] loads the training frames).
    /// `None`: the whole image.
    pub fn with_mask(mut self, mask: Option<std::sync::Arc<endoloc_features::Mask>>) -> Self {
        self.mask = mask.as_ref().map(|m| std::sync::Arc::new(m.to_gray()));
        self.surf = self.surf.with_mask(mask.clone());
        self.retry_surf = self.retry_surf.map(|s| s.with_mask(mask));
        self
    }

    /// The camera of the model (test images must match it).
    pub fn camera(&self) -> &Camera {
        &self.map.camera
    }

    /// The classifier.
    pub fn classifier(&self) -> &ZoneClassifier {
        &self.classifier
    }

    /// The maps.
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// A fresh temporal filter for a live sequence.
    pub fn temporal_filter(&self) -> TemporalFilter {
        TemporalFilter::new(self.classifier.zone_count(), self.cfg.temporal)
    }

    /// Classifies a frame (step 1 alone).
    ///
    /// # Errors
    /// Classifier errors (image of the wrong size…).
    pub fn classify(&self, img: &image::GrayImage) -> Result<ZonePrediction, LocalizeError> {
        match &self.mask {
            // Frames loaded from a dataset are already black outside it: no copy for those.
            Some(mask)
                if img.dimensions() == mask.dimensions()
                    && img
                        .as_raw()
                        .iter()
                        .zip(mask.as_raw())
                        .any(|(&p, &m)| m == 0 && p != 0) =>
            {
                let mut masked = img.clone();
                endoloc_data::black_outside(&mut masked, mask);
                Ok(self.classifier.classify(&masked)?)
            }
            _ => Ok(self.classifier.classify(img)?),
        }
    }

    /// Localizes a frame whose zone is already decided (`zone`, with its score), e.g. by
    /// [`Localizer::classify`] and a temporal filter, or forced for a perturbation study.
    ///
    /// # Errors
    /// Only for invalid input (an image the feature extractor rejects, a zone out of range);
    /// a frame without features is an `init_only` result, not an error.
    pub fn localize_in_zone(
        &self,
        img: &image::GrayImage,
        zone: usize,
        zone_score: f32,
        zone_ms: f64,
    ) -> Result<FrameResult, LocalizeError> {
        let zones = &self.classifier.zones().zones;
        let Some(z) = zones.get(zone) else {
            return Err(LocalizeError::Config(format!(
                "zone {zone} out of range (the model has {})",
                zones.len()
            )));
        };
        let _ = z;
        let mut times = StageTimes {
            zone_ms,
            ..Default::default()
        };
        let t = Instant::now();
        let features = self.surf.detect_and_describe(img)?;
        times.surf_ms = ms(t);
        self.register(&features, zone, zone_score, times)
    }

    /// Steps 3–4 for precomputed SURF features of the frame, in one zone.
    fn register(
        &self,
        features: &[endoloc_features::Feature],
        zone: usize,
        zone_score: f32,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let prior = self.classifier.zones().zones[zone].median_pose;
        self.register_from(features, zone, &prior, Prior::ZoneMedian, zone_score, times)
    }

    /// Matches `features` to the map points of `zone` (and its neighbours) and refines from
    /// `prior` (`T_wc`, mm); the validity check measures the jump from `prior`. A predicted
    /// prior with a guide radius guides the matching ([`crate::guided`]: only map points
    /// projected within that many pixels of a feature compete for it); brute force otherwise.
    /// With confirmation on, the registration is confirmed unless it is tracked from a
    /// prediction with [`ConfirmConfig::trust_tracked_inliers`].
    fn register_from(
        &self,
        features: &[endoloc_features::Feature],
        zone: usize,
        prior: &Pose,
        origin: Prior,
        zone_score: f32,
        mut times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let prior = *prior;
        let t = Instant::now();
        let lo = zone.saturating_sub(self.cfg.neighbour_zones);
        let hi = (zone + self.cfg.neighbour_zones + 1).min(self.map.zones.len());
        let candidates: Vec<&MapPoint> = self.map.zones[lo..hi]
            .iter()
            .flat_map(|zm| zm.points.iter())
            .collect();
        let guide_px = match origin {
            Prior::Predicted { guide_px } => guide_px,
            Prior::ZoneMedian => None,
        };
        let matches = if features.is_empty() || candidates.is_empty() {
            Vec::new()
        } else if let Some(radius) = guide_px {
            crate::guided::match_guided(
                features,
                &candidates,
                &self.map.camera,
                &prior,
                radius,
                self.cfg.localize.refine.min_depth_mm,
                &self.cfg.matcher,
            )
        } else {
            self.matcher.match_descriptors(features, &candidates)?
        };
        times.matching_ms = ms(t);

        let t = Instant::now();
        let (points, pixels) = crate::map::correspondences(&matches, features, &candidates);
        let result = localize_pose(
            &prior,
            &points,
            &pixels,
            &self.map.camera,
            &self.cfg.localize,
        )
        .map_err(|e| LocalizeError::Config(format!("pose refinement input: {e}")))?;
        times.refine_ms = ms(t);
        let (inliers, rms) = result
            .estimate
            .as_ref()
            .map_or((0, f64::NAN), |e| (e.inlier_count, e.rms_px));
        let inlier_px = result
            .estimate
            .as_ref()
            .map_or_else(Vec::new, |e| crate::map::inlier_pixels(&pixels, &e.inliers));
        let mut result = result;
        let (mut inliers, mut rms, mut inlier_px, mut correspondences) =
            (inliers, rms, inlier_px, matches.len());
        let trust = self.cfg.confirm.trust_tracked_inliers;
        let trusted_as_is =
            matches!(origin, Prior::Predicted { .. }) && trust > 0 && inliers >= trust;
        if self.cfg.confirm.is_on()
            && !trusted_as_is
            && result.verdict.status == Status::Refined
            && let Some(t_wc) = result.t_wc
        {
            let t = Instant::now();
            let near = self.classifier.truth_zone(&t_wc).unwrap_or(zone);
            let c = confirm(
                features,
                &self.map,
                near,
                &t_wc,
                &self.cfg.matcher,
                &self.cfg.localize,
                &self.cfg.confirm,
            );
            times.refine_ms += ms(t);
            correspondences = c.correspondences;
            inlier_px = c.inlier_px;
            (inliers, rms) = c
                .estimate
                .as_ref()
                .map_or((0, f64::NAN), |e| (e.inlier_count, e.rms_px));
            result.verdict.status = c.status;
            result.t_wc = match (&c.reason, &c.estimate) {
                // Not supported: the registered pose stays, reported as such.
                (Some(Reason::Unsupported { .. }), _) | (_, None) => Some(t_wc),
                // Confirmed (with its own covariance), weakly supported, or the better of two
                // ambiguous poses.
                (_, Some(e)) => Some(e.t_wc),
            };
            result.verdict.reason = c.reason;
            result.estimate = c.estimate;
        }
        let status = result.verdict.status;
        let kept_registration = matches!(
            result.verdict.reason,
            Some(
                Reason::Unsupported { .. }
                    | Reason::WeaklySupported { .. }
                    | Reason::Ambiguous { .. }
            )
        );
        let source = match status {
            Status::InitOnly if kept_registration => PoseSource::Registered,
            Status::Refined => PoseSource::Refined,
            Status::InitOnly => PoseSource::ZoneMedian,
            Status::Rejected => PoseSource::None,
        };
        let pose_kept = matches!(
            result.verdict.reason,
            Some(Reason::Ambiguous { .. } | Reason::WeaklySupported { .. })
        );
        let (position_std_mm, orientation_std_deg) = match (&result.estimate, status) {
            (Some(e), _) if status == Status::Refined || pose_kept => (
                self.cfg.uncertainty_scale * e.position_sigma_mm(),
                self.cfg.uncertainty_scale * e.rotation_sigma_deg(),
            ),
            _ => (f64::NAN, f64::NAN),
        };
        Ok(FrameResult {
            zone,
            zone_score,
            status,
            reason: result.verdict.reason,
            t_wc: result.t_wc,
            source,
            position_std_mm,
            orientation_std_deg,
            correspondences,
            inliers,
            inlier_px,
            reprojection_rms_px: rms,
            times,
        })
    }

    /// Localizes one frame: classify, then [`Localizer::localize_in_zone`].
    ///
    /// # Errors
    /// As [`Localizer::localize_in_zone`], and classifier errors.
    pub fn localize(&self, img: &image::GrayImage) -> Result<FrameResult, LocalizeError> {
        let t = Instant::now();
        let pred = self.classify(img)?;
        let zone_ms = ms(t);
        self.localize_with_prediction(img, &pred, pred.zone, zone_ms)
    }

    /// Localizes a frame given the classifier's prediction and the zone chosen from it (the
    /// top zone, or a temporally filtered one): that zone first, then the next best-scoring
    /// zones (up to [`LocalizerConfig::candidate_zones`] in all) until one gives `refined`
    /// with the trusted inlier count; otherwise the refined result with the most inliers, or
    /// when none registers the chosen zone's verdict.
    ///
    /// # Errors
    /// As [`Localizer::localize_in_zone`].
    pub fn localize_with_prediction(
        &self,
        img: &image::GrayImage,
        pred: &ZonePrediction,
        chosen: usize,
        zone_ms: f64,
    ) -> Result<FrameResult, LocalizeError> {
        let t = Instant::now();
        let features = self.surf.detect_and_describe(img)?;
        let times = StageTimes {
            zone_ms,
            surf_ms: ms(t),
            ..Default::default()
        };
        let r = self.with_retry(&features, Retry::Image(img), times, |f, times, _| {
            self.localize_candidates(f, pred, chosen, &[], times)
        })?;
        Ok(self.trusted_alone(r))
    }

    /// [`Localizer::localize_with_prediction`] for SURF features already extracted from the
    /// frame (with this localizer's [`Localizer::surf`], and `retry` with its
    /// [`Localizer::retry_surf`] when that is on): experiments that localize the same frames
    /// many times extract them once. `times` carries the zone and SURF times spent so far;
    /// matching and refinement times are added.
    ///
    /// # Errors
    /// A zone out of range; invalid refinement input.
    pub fn localize_features(
        &self,
        features: &[Feature],
        retry: Option<RetryFeatures<'_>>,
        pred: &ZonePrediction,
        chosen: usize,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let r = self.with_retry(features, retry.into(), times, |f, times, _| {
            self.localize_candidates(f, pred, chosen, &[], times)
        })?;
        Ok(self.trusted_alone(r))
    }

    /// A per-frame registration stays `refined` only when its stated position uncertainty is
    /// within [`LocalizerConfig::max_std_mm`] (or [`LocalizerConfig::weak_max_std_mm`] with
    /// fewer than the trusted inlier count); otherwise it is `init_only` with reason
    /// `uncertain`, and keeps its pose and uncertainty.
    fn trusted_alone(&self, mut r: FrameResult) -> FrameResult {
        if r.status != Status::Refined {
            return r;
        }
        let max_mm = if r.inliers >= self.cfg.motion.trusted_inliers {
            self.cfg.max_std_mm
        } else {
            self.cfg.weak_max_std_mm
        };
        if r.position_std_mm <= max_mm {
            return r;
        }
        r.status = Status::InitOnly;
        r.reason = Some(Reason::Uncertain {
            position_std_mm: r.position_std_mm,
            max_mm,
            inliers: r.inliers,
        });
        r.source = PoseSource::Registered;
        r
    }

    /// Runs `attempt` on `features`; when that does not give `refined` and a retry is
    /// configured, on the retry features too (detected now from an image if need be; the
    /// attempt's last argument says which). The
    /// result carries the time of both attempts; when neither registers, the retry's verdict.
    fn with_retry(
        &self,
        features: &[Feature],
        retry: Retry<'_>,
        times: StageTimes,
        attempt: impl Fn(&[Feature], StageTimes, bool) -> Result<FrameResult, LocalizeError>,
    ) -> Result<FrameResult, LocalizeError> {
        let first = attempt(features, times, false)?;
        if first.status == Status::Refined {
            return Ok(first);
        }
        let t = Instant::now();
        let (dense, dense_ms): (Cow<'_, [Feature]>, f64) = match (retry, &self.retry_surf) {
            (Retry::Features(r), Some(_)) => (Cow::Borrowed(r.features), r.surf_ms),
            (Retry::Image(img), Some(surf)) => {
                let f = surf.detect_and_describe(img)?;
                (Cow::Owned(f), ms(t))
            }
            _ => return Ok(first),
        };
        let times = StageTimes {
            surf_ms: times.surf_ms + dense_ms,
            ..times
        };
        let mut second = attempt(&dense, times, true)?;
        second.times.matching_ms += first.times.matching_ms;
        second.times.refine_ms += first.times.refine_ms;
        Ok(second)
    }

    /// [`Localizer::localize_features`], then `extra` zones (not already tried) if none of the
    /// candidate zones registered.
    fn localize_candidates(
        &self,
        features: &[Feature],
        pred: &ZonePrediction,
        chosen: usize,
        extra: &[usize],
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let n_zones = self.classifier.zone_count();
        if chosen >= n_zones {
            return Err(LocalizeError::Config(format!(
                "zone {chosen} out of range (the model has {n_zones})"
            )));
        }
        let mut order: Vec<usize> = (0..n_zones).filter(|&z| z != chosen).collect();
        order.sort_by(|&a, &b| {
            let sa = pred.zone_scores.get(a).copied().unwrap_or(f32::INFINITY);
            let sb = pred.zone_scores.get(b).copied().unwrap_or(f32::INFINITY);
            sa.total_cmp(&sb)
        });
        order.insert(0, chosen);
        order.truncate(self.cfg.candidate_zones.max(1));
        for &z in extra {
            if z < n_zones && !order.contains(&z) {
                order.push(z);
            }
        }

        let mut first: Option<FrameResult> = None;
        let mut spent = StageTimes::default();
        let with_times = |r: FrameResult, spent: &StageTimes| FrameResult {
            times: StageTimes {
                matching_ms: spent.matching_ms,
                refine_ms: spent.refine_ms,
                ..times
            },
            ..r
        };
        // A registration with the trusted inlier count ends the search; a weaker one may be a
        // spurious consensus in a wrong zone, so the other candidates are tried too and the
        // refined result with the most inliers wins.
        let trusted = self.search_ends_at();
        let mut weak: Option<FrameResult> = None;
        let mut queue = order;
        let mut next = 0;
        let mut extended = false;
        while let Some(&zone) = queue.get(next) {
            next += 1;
            let score = pred.zone_scores.get(zone).copied().unwrap_or(f32::NAN);
            let r = self.register(features, zone, score, times)?;
            spent.matching_ms += r.times.matching_ms;
            spent.refine_ms += r.times.refine_ms;
            if r.status == Status::Refined {
                if r.inliers >= trusted {
                    return Ok(with_times(r, &spent));
                }
                if weak.as_ref().is_none_or(|w| r.inliers > w.inliers) {
                    weak = Some(r);
                }
            } else {
                first.get_or_insert(r);
            }
            // With confirmation, once the candidates are tried and none is trusted, the two
            // zones beside the best (the weak winner, or the chosen zone when none registered)
            // are tried too, once: confirmation lifts a pose one zone off to a few dozen
            // inliers, the right zone's to several times more.
            if next == queue.len() && !extended && self.cfg.confirm.is_on() {
                extended = true;
                let best = weak.as_ref().map_or(chosen, |w| w.zone);
                let beside = [best.wrapping_sub(1), best + 1];
                queue.extend(
                    beside
                        .into_iter()
                        .filter(|&z| z < n_zones && !queue.contains(&z))
                        .collect::<Vec<_>>(),
                );
            }
        }
        if let Some(r) = weak {
            return Ok(with_times(r, &spent));
        }
        // No zone registered: report the chosen zone's verdict (its median pose, or rejected).
        let r = first.ok_or_else(|| LocalizeError::Config("no candidate zone".into()))?;
        Ok(with_times(r, &spent))
    }

    /// Inliers of a refined registration that end the search over candidate zones:
    /// [`MotionConfig::trusted_inliers`], or with confirmation on, the confirmed-pose count
    /// below which more starts are tried ([`ConfirmConfig::multi_start_below`], scaled to the
    /// image size) when that is higher — confirmation can lift a wrong zone's spurious
    /// consensus to a few dozen inliers, while the right zone gives several times more.
    fn search_ends_at(&self) -> usize {
        let trusted = self.cfg.motion.trusted_inliers;
        if !self.cfg.confirm.is_on() {
            return trusted;
        }
        let floor = self.cfg.localize.validity.min_inliers;
        let c = self.cfg.confirm.for_camera(&self.map.camera, floor);
        trusted.max(c.multi_start_below)
    }

    /// Registers precomputed SURF features in one forced zone (its median pose as the prior,
    /// its map points and its neighbours'), e.g. for the perturbation study.
    ///
    /// # Errors
    /// A zone out of range; invalid refinement input.
    pub fn register_in_zone(
        &self,
        features: &[Feature],
        zone: usize,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let n_zones = self.classifier.zone_count();
        if zone >= n_zones {
            return Err(LocalizeError::Config(format!(
                "zone {zone} out of range (the model has {n_zones})"
            )));
        }
        self.register(features, zone, f32::NAN, times)
    }

    /// The settings.
    pub fn config(&self) -> &LocalizerConfig {
        &self.cfg
    }

    /// The SURF extractor of test frames (as configured), for callers that cache features.
    pub fn surf(&self) -> &Surf {
        &self.surf
    }

    /// The SURF extractor of the retry ([`LocalizerConfig::retry_threshold`]), when on.
    pub fn retry_surf(&self) -> Option<&Surf> {
        self.retry_surf.as_ref()
    }
}

/// State of a live stream ([`Localizer::localize_live`]): the causal zone filter, the track
/// filter over training frames, and the motion model's recent refined poses.
#[derive(Debug, Clone)]
pub struct LiveState {
    filter: TemporalFilter,
    /// The track filter ([`endoloc_net::track`]); its zone is used for frames whose prediction
    /// carries a descriptor, the zone filter's otherwise.
    track: Option<TrackFilter>,
    /// Recent refined poses: the motion model's evidence.
    motion: Track,
    /// The last registration the motion gate refused (frame, `T_wc`): a next registration
    /// that agrees with it confirms both (the scope really is there).
    pending: Option<(usize, Pose)>,
    /// Frames seen so far.
    frame: usize,
}

impl LiveState {
    /// The frames seen so far.
    pub fn frames(&self) -> usize {
        self.frame
    }

    /// Forgets the past (a new video).
    pub fn reset(&mut self) {
        self.filter.reset();
        if let Some(t) = &mut self.track {
            t.reset();
        }
        self.motion.clear();
        self.pending = None;
        self.frame = 0;
    }
}

impl Localizer {
    /// A fresh state for a live stream.
    pub fn live_state(&self) -> LiveState {
        LiveState {
            filter: self.temporal_filter(),
            // Parameters were validated when the model was loaded; a model without training
            // frames has no track and keeps the zone HMM.
            track: self.classifier.track_filter().ok(),
            motion: Track::default(),
            pending: None,
            frame: 0,
        }
    }

    /// Localizes the next frame of a live stream (frames in order, one at a time): predict the
    /// pose from the recent refined frames ([`crate::motion`]) and register from that
    /// prediction when it is recent ([`LocalizerConfig::track_frames`]); otherwise (or if
    /// that fails) classify, fold the prediction into the causal filters (track filter, zone
    /// HMM) and register from the filtered zone and the candidate zones; then gate the
    /// registration against the prediction. [`LocalizerConfig::classify_tracked`] classifies
    /// every frame.
    ///
    /// # Errors
    /// As [`Localizer::localize`].
    pub fn localize_live(
        &self,
        state: &mut LiveState,
        img: &image::GrayImage,
    ) -> Result<FrameResult, LocalizeError> {
        // A refused frame must not advance the stream, and a tracked frame is never
        // classified: its size is checked first.
        self.classifier.check_image(img)?;
        let t = Instant::now();
        let features = self.surf.detect_and_describe(img)?;
        let times = StageTimes {
            surf_ms: ms(t),
            ..Default::default()
        };
        self.live_step(
            state,
            &features,
            Retry::Image(img),
            Zones::Image(img),
            times,
        )
    }

    /// [`Localizer::localize_live`] for a frame already classified (`pred`, not yet folded
    /// into the filter; `times.zone_ms` its time, reported only when the frame needs it) and
    /// described (`features`, and `retry` as in [`Localizer::localize_features`]).
    ///
    /// # Errors
    /// As [`Localizer::localize_features`].
    pub fn localize_live_features(
        &self,
        state: &mut LiveState,
        features: &[Feature],
        retry: Option<RetryFeatures<'_>>,
        pred: &ZonePrediction,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        self.live_step(state, features, retry.into(), Zones::Ready(pred), times)
    }

    /// One live frame: predict, register from the prediction, and when that fails classify,
    /// fold the zone prediction into the filters and register (with the retry); gate the
    /// registration against the prediction, report the prediction for a frame without a
    /// trusted registration, and remember a refined pose.
    fn live_step(
        &self,
        state: &mut LiveState,
        features: &[Feature],
        retry: Retry<'_>,
        zones: Zones<'_>,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let frame = state.frame;
        state.frame += 1;
        let motion = &self.cfg.motion;
        let confirmed = self.cfg.confirm.is_on().then_some(&self.gate);
        let prediction = state
            .motion
            .predict(frame, self.cfg.hold_frames, motion, confirmed);
        let tracked = if self.cfg.classify_tracked {
            Tracked::NotTried
        } else {
            let untimed = StageTimes {
                zone_ms: 0.0,
                ..times
            };
            self.track(prediction.as_ref(), features, None, untimed)?
        };
        let r = match tracked {
            Tracked::Registered(r) => r,
            tracked => {
                let (pred, zone_ms) = match zones {
                    Zones::Ready(p) => (Cow::Borrowed(p), times.zone_ms),
                    Zones::Image(img) => {
                        let t = Instant::now();
                        (Cow::Owned(self.classify(img)?), ms(t))
                    }
                };
                let times = StageTimes { zone_ms, ..times };
                let mut zone = state.filter.update(&pred);
                if let Some(track) = &mut state.track
                    && !pred.descriptor.is_empty()
                {
                    let distances = self.classifier.frame_distances(&pred.descriptor)?;
                    zone = track.update(&distances)?.zone;
                }
                let seen: &LiveState = state;
                let tried = match tracked {
                    Tracked::Failed(spent) => Some(spent),
                    _ => None,
                };
                let mut r = self.with_retry(features, retry, times, |f, times, is_retry| {
                    // The first features were already tried from the prediction.
                    let skip = if is_retry { None } else { tried };
                    self.live_register(
                        seen,
                        frame,
                        zone,
                        prediction.as_ref(),
                        f,
                        &pred,
                        times,
                        skip,
                    )
                })?;
                if let Some(spent) = tried {
                    r.times.matching_ms += spent.matching_ms;
                    r.times.refine_ms += spent.refine_ms;
                }
                r
            }
        };
        let mut r = self.disambiguate(r, prediction.as_ref());
        if r.status == Status::Refined
            && let Some(t_wc) = r.t_wc
        {
            self.gate(state, frame, prediction.as_ref(), t_wc, &mut r);
        }
        // An ambiguous frame keeps the better supported of its two poses: on simulated passes
        // it is nearly always the right one, and closer than a prediction coasting through a
        // stretch that registers badly.
        if r.status == Status::InitOnly
            && !matches!(r.reason, Some(Reason::Ambiguous { .. }))
            && let Some(p) = &prediction
        {
            r.t_wc = Some(p.t_wc);
            r.source = PoseSource::Predicted;
        }
        self.remember(state, &r, frame);
        Ok(r)
    }

    /// The motion gate: a refined registration `t_wc` of `frame` stays `refined` when it has
    /// [`MotionConfig::trusted_inliers`], agrees with the prediction, or agrees with the last
    /// refused registration (two consecutive frames confirm each other); otherwise it becomes
    /// `init_only` and is remembered as pending.
    fn gate(
        &self,
        state: &mut LiveState,
        frame: usize,
        prediction: Option<&Prediction>,
        t_wc: Pose,
        r: &mut FrameResult,
    ) {
        let motion = &self.cfg.motion;
        let versus_prediction = prediction.map(|p| p.compare(&t_wc, &self.gate));
        let confirmed =
            state
                .pending
                .filter(|(at, _)| frame - at <= 2)
                .is_some_and(|(at, pose)| {
                    let p = Prediction {
                        t_wc: pose,
                        age: frame - at,
                    };
                    p.compare(&t_wc, &self.gate).agrees
                });
        let trusted = r.inliers >= motion.trusted_inliers;
        if trusted || confirmed || versus_prediction.is_some_and(|d| d.agrees) {
            state.pending = None;
            return;
        }
        state.pending = Some((frame, t_wc));
        r.status = Status::InitOnly;
        r.reason = Some(match versus_prediction {
            Some(d) => Reason::InconsistentMotion {
                position_mm: d.position_mm,
                orientation_deg: d.orientation_deg,
                inliers: r.inliers,
            },
            None => Reason::Unconfirmed { inliers: r.inliers },
        });
        r.t_wc = Some(self.classifier.zones().zones[r.zone].median_pose);
        r.source = PoseSource::ZoneMedian;
        r.position_std_mm = f64::NAN;
        r.orientation_std_deg = f64::NAN;
    }

    /// Registration from the motion model's `prediction` when it is recent
    /// ([`LocalizerConfig::track_frames`]): guided matching in the zone the predicted pose
    /// lies in; it counts only when refined and in agreement with the prediction. `pred`
    /// gives the zone's score (NaN without it).
    fn track(
        &self,
        prediction: Option<&Prediction>,
        features: &[Feature],
        pred: Option<&ZonePrediction>,
        times: StageTimes,
    ) -> Result<Tracked, LocalizeError> {
        let recent =
            prediction.filter(|p| self.cfg.track_frames > 0 && p.age <= self.cfg.track_frames);
        let Some((p, z)) = recent.and_then(|p| Some((p, self.classifier.truth_zone(&p.t_wc)?)))
        else {
            return Ok(Tracked::NotTried);
        };
        let score = pred
            .and_then(|pred| pred.zone_scores.get(z).copied())
            .unwrap_or(f32::NAN);
        let m = &self.cfg.motion;
        let radius =
            (m.search_px > 0.0).then_some(m.search_px + m.search_px_per_frame * p.age as f64);
        let origin = Prior::Predicted { guide_px: radius };
        let r = self.register_from(features, z, &p.t_wc, origin, score, times)?;
        let r = self.disambiguate(r, Some(p));
        if r.status == Status::Refined && r.t_wc.is_some_and(|t| p.compare(&t, &self.gate).agrees) {
            return Ok(Tracked::Registered(r));
        }
        Ok(Tracked::Failed(StageTimes {
            matching_ms: r.times.matching_ms,
            refine_ms: r.times.refine_ms,
            ..StageTimes::default()
        }))
    }

    /// Registration of live frame `frame` (filtered zone `zone`): from the motion model's
    /// prediction when it is recent (unless `tracked` says that was already tried, and
    /// failed), else the candidate zones plus the zones around the last refined pose.
    #[allow(clippy::too_many_arguments)]
    fn live_register(
        &self,
        state: &LiveState,
        frame: usize,
        zone: usize,
        prediction: Option<&Prediction>,
        features: &[Feature],
        pred: &ZonePrediction,
        times: StageTimes,
        tracked: Option<StageTimes>,
    ) -> Result<FrameResult, LocalizeError> {
        let mut spent = StageTimes::default();
        if tracked.is_none() {
            match self.track(prediction, features, Some(pred), times)? {
                Tracked::Registered(r) => return Ok(r),
                Tracked::Failed(s) => spent = s,
                Tracked::NotTried => {}
            }
        }
        let extra: Vec<usize> = match state.motion.last() {
            Some((at, pose))
                if self.cfg.recover_frames > 0 && frame - at <= self.cfg.recover_frames =>
            {
                match self.classifier.truth_zone(&pose) {
                    Some(z) => (z.saturating_sub(1)..=z + 2).collect(),
                    None => Vec::new(),
                }
            }
            _ => Vec::new(),
        };
        let mut r = self.localize_candidates(features, pred, zone, &extra, times)?;
        r.times.matching_ms += spent.matching_ms;
        r.times.refine_ms += spent.refine_ms;
        Ok(r)
    }

    /// Live: a registration that confirmation found `weakly_supported` (valid, few inliers)
    /// is `refined` when the motion model's `prediction` vouches for it
    /// ([`Prediction::vouches_for`]: it agrees, as a weak registration must at the motion
    /// gate, and its stated 95 % bound fits inside the gate's base radius); one found
    /// `ambiguous` (two poses apart, nearly equally supported) when the better supported
    /// agrees with a recent prediction (at most [`LocalizerConfig::track_frames`] old, while
    /// the gate is still narrow): the motion tells the two apart.
    fn disambiguate(&self, mut r: FrameResult, prediction: Option<&Prediction>) -> FrameResult {
        let std_mm = r.position_std_mm;
        let agrees = |t: &Pose| match r.reason {
            Some(Reason::WeaklySupported { .. }) => {
                prediction.is_some_and(|p| p.vouches_for(t, std_mm, &self.gate))
            }
            Some(Reason::Ambiguous { .. }) => prediction
                .filter(|p| p.age <= self.cfg.track_frames)
                .is_some_and(|p| p.compare(t, &self.gate).agrees),
            _ => false,
        };
        if r.status == Status::InitOnly && r.t_wc.as_ref().is_some_and(agrees) {
            r.status = Status::Refined;
            r.reason = None;
            r.source = PoseSource::Refined;
        }
        r
    }

    fn remember(&self, state: &mut LiveState, r: &FrameResult, frame: usize) {
        if r.status != Status::Refined {
            return;
        }
        if let Some(pose) = r.t_wc {
            state.motion.push(frame, pose, &self.cfg.motion);
            if let Some(z) = self.classifier.truth_zone(&pose) {
                state.filter.anchor(z);
            }
            if let (Some(track), Some(f)) =
                (&mut state.track, self.classifier.nearest_train_frame(&pose))
            {
                track.anchor(f);
            }
        }
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

// Map points are matched through the features crate's `Describe` trait.
const _: fn() = || {
    fn describes<T: Describe>() {}
    describes::<&MapPoint>();
};
