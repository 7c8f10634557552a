//! Frames one at a time, in order, as a scope delivers them: the causal zone filter, the
//! motion model's prediction and gate, recovery around the last refined pose.

use std::borrow::Cow;
use std::time::Instant;

use endoloc_features::Feature;
use endoloc_geometry::{Pose, Reason, Status, WallMotionPool};
use endoloc_net::{TemporalFilter, TrackFilter, ZonePrediction};

use crate::LocalizeError;
use crate::colon_scale::ScaleTrack;
use crate::motion::{Prediction, Track};

use super::frame::{Localizer, Prior, Retry, RetryFeatures, ms};
use super::result::{FrameResult, PoseSource, StageTimes};

/// Where a live frame's zone prediction comes from.
#[derive(Clone, Copy)]
enum Zones<'a> {
    /// Classified beforehand.
    Ready(&'a ZonePrediction),
    /// Classified from the image when needed.
    Image(&'a image::GrayImage),
}

/// The registration of a live frame from the motion model's prediction.
enum Tracked {
    /// No recent prediction (or it lies outside every zone): not tried.
    NotTried,
    /// Refined, and agrees with the prediction.
    Registered(Box<FrameResult>),
    /// Tried and failed: the matching and refinement time it took.
    Failed(StageTimes),
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
    /// The colon's scale followed so far, when the colon-scale step is on.
    scale: Option<ScaleTrack>,
    /// The wall's motion the recent registrations show together
    /// ([`WallCovarianceConfig::pooled_registrations`](endoloc_geometry::WallCovarianceConfig::pooled_registrations)).
    wall: WallMotionPool,
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
        self.scale = None;
        self.wall.clear();
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
            scale: None,
            wall: WallMotionPool::new(self.cfg.wall_covariance.pooled_registrations),
            frame: 0,
        }
    }

    /// Localizes the next frame of a live stream (frames in order, one at a time): predict the
    /// pose from the recent refined frames ([`crate::motion`]) and register from that
    /// prediction when it is recent ([`LocalizerConfig::track_frames`](crate::LocalizerConfig::track_frames)); otherwise (or if
    /// that fails) classify, fold the prediction into the causal filters (track filter, zone
    /// HMM) and register from the filtered zone and the candidate zones; then gate the
    /// registration against the prediction. [`LocalizerConfig::classify_tracked`](crate::LocalizerConfig::classify_tracked) classifies
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
        // Live frames retry only with a retry threshold below the test frames' (see
        // `LocalizerConfig::retry_live`); then a frame the motion model cannot track from is
        // searched for in the candidate zones, where features at the test threshold seldom
        // suffice once the track is lost: it is described once, at the retry threshold.
        let prediction = self.predict_next(state);
        let t = Instant::now();
        let (features, retry) = match &self.retry_surf {
            Some(dense) if self.retry_live => match self.recent(prediction.as_ref()) {
                None => (dense.detect_and_describe(img)?, Retry::None),
                Some(_) => (self.surf.detect_and_describe(img)?, Retry::Image(img)),
            },
            _ => (self.surf.detect_and_describe(img)?, Retry::None),
        };
        let times = StageTimes {
            surf_ms: ms(t),
            ..Default::default()
        };
        self.live_step(
            state,
            prediction,
            &features,
            retry,
            Zones::Image(img),
            times,
        )
    }

    /// The motion model's prediction of the next frame of `state`.
    fn predict_next(&self, state: &LiveState) -> Option<Prediction> {
        let confirmed = self.cfg.confirm.is_on().then_some(&self.gate);
        state.motion.predict(
            state.frame,
            self.cfg.hold_frames,
            &self.cfg.motion,
            confirmed,
        )
    }

    /// `prediction` when a frame is registered from it: at most
    /// [`LocalizerConfig::track_frames`](crate::LocalizerConfig::track_frames) old (0: never).
    fn recent<'p>(&self, prediction: Option<&'p Prediction>) -> Option<&'p Prediction> {
        prediction.filter(|p| self.cfg.track_frames > 0 && p.age <= self.cfg.track_frames)
    }

    /// [`Localizer::localize_live`] for a frame already classified (`pred`, not yet folded
    /// into the filter; `times.zone_ms` its time, reported only when the frame needs it) and
    /// described (`features`, and `retry` as in [`Localizer::localize_features`], used only
    /// when live frames retry — [`LocalizerConfig::retry_live`](crate::LocalizerConfig::retry_live) —
    /// and then alone for a frame the motion model cannot track from, as
    /// [`Localizer::localize_live`] does).
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
        // As in `localize_live`: live frames retry only when `retry_live`; then a frame the
        // motion model cannot track from is registered with the retry's features alone.
        let prediction = self.predict_next(state);
        let retry = retry.filter(|_| self.retry_live);
        match retry {
            Some(r) if self.recent(prediction.as_ref()).is_none() => {
                let times = StageTimes {
                    surf_ms: r.surf_ms,
                    ..times
                };
                let zones = Zones::Ready(pred);
                self.live_step(state, prediction, r.features, Retry::None, zones, times)
            }
            _ => {
                let zones = Zones::Ready(pred);
                self.live_step(state, prediction, features, retry.into(), zones, times)
            }
        }
    }

    /// One live frame, `prediction` the motion model's ([`Localizer::predict_next`], made
    /// before `state` moves on): register from the prediction, and when that fails classify,
    /// fold the zone prediction into the filters and register (with the retry); gate the
    /// registration against the prediction, report the prediction for a frame without a
    /// trusted registration, and remember a refined pose.
    fn live_step(
        &self,
        state: &mut LiveState,
        prediction: Option<Prediction>,
        features: &[Feature],
        retry: Retry<'_>,
        zones: Zones<'_>,
        times: StageTimes,
    ) -> Result<FrameResult, LocalizeError> {
        let frame = state.frame;
        state.frame += 1;
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
            Tracked::Registered(r) => *r,
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
        let r = self.scaled_live(r, &mut state.scale);
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
        self.pool_wall_motion(state, &mut r);
        self.remember(state, &r, frame);
        Ok(r)
    }

    /// Adds a registration reported with its uncertainty to the stream's wall-motion pool and
    /// states that uncertainty with the larger of the pooled wall motion and the
    /// registration's own: how far the colon changed is a property of the pass, which one
    /// registration's residuals often show too little of.
    fn pool_wall_motion(&self, state: &mut LiveState, r: &mut FrameResult) {
        let Some(wall) = r.uncertainty.and_then(|u| u.wall) else {
            return;
        };
        state.wall.push(&wall);
        let sigma_mm = state.wall.sigma_mm().max(wall.sigma_mm());
        self.state_uncertainty(r, sigma_mm);
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
        r.uncertainty = None;
        self.state_uncertainty(r, 0.0);
    }

    /// Registration from the motion model's `prediction` when it is recent
    /// ([`LocalizerConfig::track_frames`](crate::LocalizerConfig::track_frames)): guided matching in the zone the predicted pose
    /// lies in; it counts only when refined and in agreement with the prediction. `pred`
    /// gives the zone's score (NaN without it).
    fn track(
        &self,
        prediction: Option<&Prediction>,
        features: &[Feature],
        pred: Option<&ZonePrediction>,
        times: StageTimes,
    ) -> Result<Tracked, LocalizeError> {
        let Some((p, z)) = self
            .recent(prediction)
            .and_then(|p| Some((p, self.classifier.truth_zone(&p.t_wc)?)))
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
        // A registration against `map` (the map or its smoothed level), and whether it counts:
        // refined, and where the scope can be.
        let tracked = |map| -> Result<(FrameResult, bool), LocalizeError> {
            let r = self.register_from(map, features, z, &p.t_wc, origin, score, times)?;
            let r = self.disambiguate(r, Some(p));
            let agrees = r.status == Status::Refined
                && r.t_wc.is_some_and(|t| p.compare(&t, &self.gate).agrees);
            Ok((r, agrees))
        };
        let (mut r, mut agrees) = tracked(&self.map)?;
        if !agrees && let Some(level) = &self.smoothed {
            let (second, second_agrees) = tracked(level)?;
            let spent = r.times;
            (r, agrees) = (second, second_agrees);
            r.times.matching_ms += spent.matching_ms;
            r.times.refine_ms += spent.refine_ms;
        }
        if agrees {
            return Ok(Tracked::Registered(Box::new(r)));
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
                Tracked::Registered(r) => return Ok(*r),
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
    /// gate, and its 95 % bound as a measurement, [`FrameResult::measurement_std_mm`], fits
    /// inside the gate's base radius); one found
    /// `ambiguous` (two poses apart, nearly equally supported) when the better supported
    /// agrees with a recent prediction (at most [`LocalizerConfig::track_frames`](crate::LocalizerConfig::track_frames) old, while
    /// the gate is still narrow): the motion tells the two apart.
    fn disambiguate(&self, mut r: FrameResult, prediction: Option<&Prediction>) -> FrameResult {
        let std_mm = r.measurement_std_mm;
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
