//! The localizer and one frame on its own: classify, initialise at the zone's median pose,
//! register against the zone's map, refine and check.

use std::borrow::Cow;
use std::time::Instant;

use endoloc_features::{Describe, Feature, Matcher, Surf};
use endoloc_geometry::{Camera, Pose, Reason, RobustKernel, Status, localize_pose};
use endoloc_net::{TemporalFilter, ZoneClassifier, ZonePrediction};

use crate::LocalizeError;
use crate::colon_scale::ColonScale;
use crate::confirm::confirm;
use crate::map::{Map, MapPoint};
use crate::motion::Gate;

use super::config::LocalizerConfig;
use super::result::{FrameResult, PoseSource, PoseUncertainty, StageTimes};

/// A ready-to-run localizer: classifier, maps and settings.
pub struct Localizer {
    pub(super) classifier: ZoneClassifier,
    pub(super) map: Map,
    /// The camera of the frames localized: the map's unless [`Localizer::with_camera`] names
    /// another scope (same image size).
    pub(super) camera: Camera,
    pub(super) cfg: LocalizerConfig,
    pub(super) surf: Surf,
    /// SURF at [`LocalizerConfig::retry_threshold`](crate::LocalizerConfig::retry_threshold), when that is on.
    pub(super) retry_surf: Option<Surf>,
    /// Whether live frames retry too ([`LocalizerConfig::retry_live`](crate::LocalizerConfig::retry_live)).
    pub(super) retry_live: bool,
    pub(super) matcher: Matcher,
    /// The live motion gate for this model's training pass.
    pub(super) gate: Gate,
    /// The image mask (non-zero = valid), when frames have one: the zone network sees frames
    /// black outside it, as in training.
    pub(super) mask: Option<std::sync::Arc<image::GrayImage>>,
    /// The colon-scale refinement, when [`LocalizerConfig::colon_scale`] is on.
    pub(super) colon_scale: Option<ColonScale>,
    /// The map's smoothed level ([`Localizer::with_smoothed_level`]): the map of the training
    /// images smoothed by a Gaussian, where a frame that the map does not register goes next.
    pub(super) smoothed: Option<Map>,
}

/// A frame's SURF features at [`LocalizerConfig::retry_threshold`](crate::LocalizerConfig::retry_threshold), extracted beforehand.
#[derive(Debug, Clone, Copy)]
pub struct RetryFeatures<'a> {
    /// The features (with [`Localizer::retry_surf`]).
    pub features: &'a [Feature],
    /// Their extraction time, ms: added to the frame's SURF time when the retry is used.
    pub surf_ms: f64,
}

/// Where a frame's retry features come from.
#[derive(Clone, Copy)]
pub(super) enum Retry<'a> {
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

/// Where the prior of a registration comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Prior {
    /// A zone's median pose: matching by brute force against the zone's map points.
    ZoneMedian,
    /// The motion model's prediction: matching guided within this many pixels of it
    /// ([`crate::guided`]), or by brute force with `None`.
    Predicted { guide_px: Option<f64> },
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
                 rebuild it with the map job (`model` {}, `force`)",
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
                    "refine {name} scale {scale_px} px (`polish_px` for the polish); \
                     expected a finite value > 0, or 0 for least squares"
                )));
            }
        }
        let wall = refine.wall_motion_mm;
        if !(wall.is_finite() && wall >= 0.0) {
            return Err(LocalizeError::Config(format!(
                "`wall_motion_mm` {wall} mm; expected a finite value ≥ 0 (0 for a rigid colon)"
            )));
        }
        cfg.wall_covariance
            .validate()
            .map_err(LocalizeError::Config)?;
        if !(cfg.uncertainty_scale.is_finite() && cfg.uncertainty_scale > 0.0) {
            return Err(LocalizeError::Config(format!(
                "uncertainty_scale = {}; expected a finite value > 0",
                cfg.uncertainty_scale
            )));
        }
        let surf = cfg.test_surf(&map.config.surf).init()?;
        let retry_surf = cfg
            .retry_surf(&map.config.surf)
            .map(|s| s.init())
            .transpose()?;
        let retry_live = retry_surf.is_some() && cfg.retry_live(&map.config.surf);
        let matcher = Matcher::new(cfg.matcher.clone());
        let gate = Gate::new(&cfg.motion, classifier.train_poses());
        let colon_scale = match cfg.colon_scale {
            Some(cfg) => {
                cfg.validate().map_err(LocalizeError::Config)?;
                Some(
                    ColonScale::new(classifier.train_poses(), cfg).ok_or_else(|| {
                        LocalizeError::Config(
                            "colon_scale needs a training pass that moves (its camera path is \
                         the mid-line)"
                                .into(),
                        )
                    })?,
                )
            }
            None => None,
        };
        Ok(Localizer {
            smoothed: None,
            colon_scale,
            gate,
            mask: None,
            classifier,
            camera: map.camera,
            map,
            cfg,
            surf,
            retry_surf,
            retry_live,
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

    /// This localizer for frames from another scope than the map's: `camera`'s intrinsics
    /// and distortion project the map points into them (the zone network sees the frames as
    /// they are). The image size must be the map camera's.
    ///
    /// # Errors
    /// [`LocalizeError::Mismatch`] for another image size; [`LocalizeError::Config`] for an
    /// invalid camera.
    pub fn with_camera(mut self, camera: Camera) -> Result<Self, LocalizeError> {
        camera.validate().map_err(LocalizeError::Config)?;
        let m = &self.map.camera;
        if (camera.width, camera.height) != (m.width, m.height) {
            return Err(LocalizeError::Mismatch(format!(
                "the frames' camera is {}x{} but the model's is {}x{}: give frames of the \
                 model's size (resize them, with the camera's intrinsics scaled alike)",
                camera.width, camera.height, m.width, m.height
            )));
        }
        self.camera = camera;
        Ok(self)
    }

    /// This localizer with the map's smoothed level (`None`: without): a frame that does not
    /// register against the map — tracked from the prediction, or searched for in the
    /// candidate zones — is registered the same way against `level`, the map of the training
    /// images smoothed by a Gaussian ([`crate::MapConfig::blur_px`]), whose coarser
    /// structure holds when the pass has another look than the mapping pass. The frame's
    /// features are the same; the level's registration counts only when it is `refined`.
    /// [`Localizer::register_in_zone`] and [`Localizer::localize_in_zone`] use the map alone.
    ///
    /// # Errors
    /// [`LocalizeError::Mismatch`] when the level was built for other zones or another camera
    /// than the map.
    pub fn with_smoothed_level(mut self, level: Option<Map>) -> Result<Self, LocalizeError> {
        if let Some(level) = &level {
            let m = &self.map;
            if level.zones.len() != m.zones.len()
                || level.camera != m.camera
                || (level.model_zones.is_some()
                    && m.model_zones.is_some()
                    && level.model_zones != m.model_zones)
            {
                return Err(LocalizeError::Mismatch(format!(
                    "the map's smoothed level has {} zones for a {}x{} camera (zones {}), the map \
                     {} zones for a {}x{} camera (zones {}): they come from different builds; \
                     rebuild the map with the map job (`force`)",
                    level.zones.len(),
                    level.camera.width,
                    level.camera.height,
                    level
                        .model_zones
                        .as_ref()
                        .map_or("?".into(), |f| f.to_string()),
                    m.zones.len(),
                    m.camera.width,
                    m.camera.height,
                    m.model_zones.as_ref().map_or("?".into(), |f| f.to_string()),
                )));
            }
        }
        self.smoothed = level;
        Ok(self)
    }

    /// The map's smoothed level, when it has one ([`Localizer::with_smoothed_level`]).
    pub fn smoothed_level(&self) -> Option<&Map> {
        self.smoothed.as_ref()
    }

    /// The camera of the frames localized (the model's unless [`Localizer::with_camera`] set
    /// another; test images must have its size).
    pub fn camera(&self) -> &Camera {
        &self.camera
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
        Ok(self.scaled_alone(self.register(&self.map, &features, zone, zone_score, times)?))
    }

    /// Steps 3–4 for precomputed SURF features of the frame, in one zone of `map` (the map or
    /// its smoothed level).
    pub(super) fn register(
        &self,
        map: &Map,
        features: &[endoloc_features::Feature],
        zone: usize,
        zone_score: f32,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let prior = self.classifier.zones().zones[zone].median_pose;
        self.register_from(
            map,
            features,
            zone,
            &prior,
            Prior::ZoneMedian,
            zone_score,
            times,
        )
    }

    /// Matches `features` to the points of `map` (the map or its smoothed level) in `zone`
    /// (and its neighbours) and refines from `prior` (`T_wc`, mm); the validity check
    /// measures the jump from `prior`. A predicted
    /// prior with a guide radius guides the matching ([`crate::guided`]: only map points
    /// projected within that many pixels of a feature compete for it); brute force otherwise.
    /// With confirmation on, the registration is confirmed unless it is tracked from a
    /// prediction with [`ConfirmConfig::trust_tracked_inliers`].
    ///
    /// With [`RefineConfig::wall_motion_mm`](endoloc_geometry::RefineConfig::wall_motion_mm)
    /// on, the frame is registered as to a rigid wall first, and only when that gives no
    /// `refined` pose again with each map point's tolerance widened for wall motion: a
    /// frame of an unchanged colon keeps its rigid registration (a wider tolerance also
    /// lets more chance agreements count as inliers), a frame of a deformed one gets the
    /// near points that a rigid registration drops. Both attempts' times count.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn register_from(
        &self,
        map: &Map,
        features: &[endoloc_features::Feature],
        zone: usize,
        prior: &Pose,
        origin: Prior,
        zone_score: f32,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let attempt = |registration: &endoloc_geometry::RegistrationConfig| {
            self.register_with(
                map,
                features,
                zone,
                prior,
                origin,
                zone_score,
                times,
                registration,
            )
        };
        let tolerant = &self.cfg.localize;
        if tolerant.refine.wall_motion_mm == 0.0 {
            return attempt(tolerant);
        }
        let mut rigid = *tolerant;
        rigid.refine.wall_motion_mm = 0.0;
        let first = attempt(&rigid)?;
        if first.status == Status::Refined {
            return Ok(first);
        }
        let second = attempt(tolerant)?;
        let (a, b) = (first.times, second.times);
        let mut kept = if second.status == Status::Refined {
            second
        } else {
            first
        };
        kept.times.matching_ms = a.matching_ms + b.matching_ms;
        kept.times.refine_ms = a.refine_ms + b.refine_ms;
        Ok(kept)
    }

    /// [`Localizer::register_from`] with the registration settings `registration` (the
    /// localizer's, or those of a rigid wall).
    #[allow(clippy::too_many_arguments)]
    fn register_with(
        &self,
        map: &Map,
        features: &[endoloc_features::Feature],
        zone: usize,
        prior: &Pose,
        origin: Prior,
        zone_score: f32,
        mut times: StageTimes,
        registration: &endoloc_geometry::RegistrationConfig,
    ) -> Result<FrameResult, LocalizeError> {
        let prior = *prior;
        let t = Instant::now();
        let lo = zone.saturating_sub(self.cfg.neighbour_zones);
        let hi = (zone + self.cfg.neighbour_zones + 1).min(map.zones.len());
        let candidates: Vec<&MapPoint> = map.zones[lo..hi]
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
                &self.camera,
                &prior,
                crate::guided::Window::rigid(radius, self.cfg.localize.refine.min_depth_mm)
                    .with_wall_motion(registration.refine.wall_motion_mm),
                &self.cfg.matcher,
            )
        } else {
            self.matcher.match_descriptors(features, &candidates)?
        };
        times.matching_ms = ms(t);

        let t = Instant::now();
        let (points, pixels) = crate::map::correspondences(&matches, features, &candidates);
        let result = localize_pose(&prior, &points, &pixels, &self.camera, registration)
            .map_err(|e| LocalizeError::Config(format!("pose refinement input: {e}")))?;
        times.refine_ms = ms(t);
        let (inliers, rms) = result
            .estimate
            .as_ref()
            .map_or((0, f64::NAN), |e| (e.inlier_count, e.rms_px));
        let (inlier_px, inlier_points) = result.estimate.as_ref().map_or_else(
            || (Vec::new(), Vec::new()),
            |e| {
                (
                    crate::map::inlier_pixels(&pixels, &e.inliers),
                    crate::map::inlier_points(&points, &e.inliers),
                )
            },
        );
        let mut result = result;
        let (mut inliers, mut rms, mut inlier_px, mut inlier_points, mut correspondences) =
            (inliers, rms, inlier_px, inlier_points, matches.len());
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
                map,
                &self.camera,
                near,
                &t_wc,
                &self.cfg.matcher,
                registration,
                &self.cfg.confirm,
            );
            times.refine_ms += ms(t);
            correspondences = c.correspondences;
            inlier_px = c.inlier_px;
            inlier_points = c.inlier_points;
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
        let uncertainty = match (&result.estimate, status) {
            (Some(e), _) if status == Status::Refined || pose_kept => {
                Some(self.uncertainty(e, &inlier_points, &inlier_px, &registration.refine))
            }
            _ => None,
        };
        let mut r = FrameResult {
            zone,
            zone_score,
            status,
            reason: result.verdict.reason,
            t_wc: result.t_wc,
            source,
            position_std_mm: f64::NAN,
            orientation_std_deg: f64::NAN,
            measurement_std_mm: f64::NAN,
            uncertainty,
            correspondences,
            inliers,
            inlier_px,
            inlier_points,
            colon_scale: None,
            reprojection_rms_px: rms,
            times,
        };
        let own = uncertainty
            .and_then(|u| u.wall)
            .map_or(0.0, |w| w.sigma_mm());
        self.state_uncertainty(&mut r, own);
        Ok(r)
    }

    /// What the stated uncertainty of a registered pose `e` is made of: its refinement's
    /// covariance and the wall-motion term of its inliers `points` ↔ `px`
    /// ([`LocalizerConfig::wall_covariance`](crate::LocalizerConfig::wall_covariance)).
    fn uncertainty(
        &self,
        e: &endoloc_geometry::PoseEstimate,
        points: &[nalgebra::Point3<f64>],
        px: &[[f32; 2]],
        refine: &endoloc_geometry::RefineConfig,
    ) -> PoseUncertainty {
        let pixels: Vec<nalgebra::Point2<f64>> = px
            .iter()
            .map(|p| nalgebra::Point2::new(f64::from(p[0]), f64::from(p[1])))
            .collect();
        let wall = endoloc_geometry::wall_covariance(
            &e.t_wc,
            points,
            &pixels,
            &self.camera,
            refine,
            &self.cfg.wall_covariance,
        );
        PoseUncertainty {
            t_wc: e.t_wc,
            covariance: e.covariance,
            wall,
        }
    }

    /// States `r`'s uncertainty from [`FrameResult::uncertainty`] with a wall motion of
    /// `wall_sigma_mm` (1σ per axis): the position (mm, along its least certain direction) and
    /// orientation (degrees) standard deviations with the wall-motion term, the position's
    /// without it ([`FrameResult::measurement_std_mm`]); all times
    /// [`LocalizerConfig::uncertainty_scale`](crate::LocalizerConfig::uncertainty_scale). NaN
    /// without a registration to state.
    pub(super) fn state_uncertainty(&self, r: &mut FrameResult, wall_sigma_mm: f64) {
        let Some(u) = &r.uncertainty else {
            (
                r.position_std_mm,
                r.orientation_std_deg,
                r.measurement_std_mm,
            ) = (f64::NAN, f64::NAN, f64::NAN);
            return;
        };
        let scale = self.cfg.uncertainty_scale;
        let total = match &u.wall {
            Some(w) => u.covariance + w.covariance(wall_sigma_mm),
            None => u.covariance,
        };
        r.position_std_mm = scale * endoloc_geometry::position_sigma_mm(&u.t_wc, &total);
        r.orientation_std_deg = scale * endoloc_geometry::rotation_sigma_deg(&total);
        r.measurement_std_mm = scale * endoloc_geometry::position_sigma_mm(&u.t_wc, &u.covariance);
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
    /// zones (up to [`LocalizerConfig::candidate_zones`](crate::LocalizerConfig::candidate_zones) in all) until one gives `refined`
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
        Ok(self.trusted_alone(self.scaled_alone(r)))
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
        Ok(self.trusted_alone(self.scaled_alone(r)))
    }

    /// A per-frame registration stays `refined` only when its stated position uncertainty is
    /// within [`LocalizerConfig::max_std_mm`](crate::LocalizerConfig::max_std_mm) (or [`LocalizerConfig::weak_max_std_mm`](crate::LocalizerConfig::weak_max_std_mm) with
    /// fewer than the trusted inlier count); otherwise it is `init_only` with reason
    /// `uncertain`, and keeps its pose and uncertainty.
    pub(super) fn trusted_alone(&self, mut r: FrameResult) -> FrameResult {
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
    pub(super) fn with_retry(
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

    /// [`Localizer::localize_candidates_in`] the map, then, when no zone registered there and
    /// the map has a smoothed level, in that level; the level's result counts only when
    /// `refined` (with the time of both searches), else the map's verdict stands.
    pub(super) fn localize_candidates(
        &self,
        features: &[Feature],
        pred: &ZonePrediction,
        chosen: usize,
        extra: &[usize],
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let first = self.localize_candidates_in(&self.map, features, pred, chosen, extra, times)?;
        let Some(level) = self
            .smoothed
            .as_ref()
            .filter(|_| first.status != Status::Refined)
        else {
            return Ok(first);
        };
        let second = self.localize_candidates_in(level, features, pred, chosen, extra, times)?;
        Ok(Self::level_fallback(first, second))
    }

    /// `second` (a registration against the smoothed level after `first`, against the map,
    /// failed) when it is `refined`, with the time of both; else `first` with the time of both.
    pub(super) fn level_fallback(first: FrameResult, second: FrameResult) -> FrameResult {
        let (mut kept, spent) = if second.status == Status::Refined {
            let spent = first.times;
            (second, spent)
        } else {
            let spent = second.times;
            (first, spent)
        };
        kept.times.matching_ms += spent.matching_ms;
        kept.times.refine_ms += spent.refine_ms;
        kept
    }

    /// The candidate zones of `map` (the map or its smoothed level) in turn, then `extra`
    /// zones (not already tried) if none of them registered.
    fn localize_candidates_in(
        &self,
        map: &Map,
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
            let r = self.register(map, features, zone, score, times)?;
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
    pub(super) fn search_ends_at(&self) -> usize {
        let trusted = self.cfg.motion.trusted_inliers;
        if !self.cfg.confirm.is_on() {
            return trusted;
        }
        let floor = self.cfg.localize.validity.min_inliers;
        let c = self.cfg.confirm.for_camera(&self.camera, floor);
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
        Ok(self.scaled_alone(self.register(&self.map, features, zone, f32::NAN, times)?))
    }

    /// The settings.
    pub fn config(&self) -> &LocalizerConfig {
        &self.cfg
    }

    /// The SURF extractor of test frames (as configured), for callers that cache features.
    pub fn surf(&self) -> &Surf {
        &self.surf
    }

    /// The SURF extractor of the retry ([`LocalizerConfig::retry_threshold`](crate::LocalizerConfig::retry_threshold)), when on.
    pub fn retry_surf(&self) -> Option<&Surf> {
        self.retry_surf.as_ref()
    }
}

pub(crate) fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

// Map points are matched through the features crate's `Describe` trait.
const _: fn() = || {
    fn describes<T: Describe>() {}
    describes::<&MapPoint>();
};
