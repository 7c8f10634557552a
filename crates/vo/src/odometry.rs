//! [`VisualOdometry`]: frame-by-frame monocular tracking.
//!
//! # Algorithm
//!
//! 1. **Features.** SURF keypoints and descriptors of every frame ([`VoConfig::surf`]).
//! 2. **Initialization** (at the start and after every loss). The first frame with enough
//!    keypoints becomes the *reference*. Each following frame is matched to it; when the
//!    essential matrix ([`endoloc_geometry::ransac_essential`]: 5-point RANSAC, cheirality)
//!    explains the matches and at least [`VoConfig::init_min_points`] points triangulate with
//!    a median triangulation angle of [`VoConfig::init_min_parallax_deg`], a new *segment*
//!    starts: the reference frame is its origin (`T_wc` = identity) and the baseline to the
//!    current frame is one VO unit. Frames between the two are then localized against the new
//!    map (PnP), so they too get poses. Too few matches, or
//!    [`VoConfig::init_max_frames`] frames without success, make the current frame the new
//!    reference.
//! 3. **Tracking.** Each frame's descriptors are matched to the local map points (mutual
//!    nearest neighbours with the ratio test), the pose comes from RANSAC P3P
//!    ([`endoloc_geometry::ransac_pnp`]) and Gauss-Newton ([`endoloc_geometry::refine_pose()`]),
//!    and inlier map points take the frame's descriptor (appearance changes slowly along a
//!    pass).
//! 4. **Keyframes.** After [`VoConfig::keyframe_max_gap`] frames, or when the inliers drop
//!    below [`VoConfig::keyframe_min_inlier_ratio`] of those at the last keyframe, the frame
//!    becomes a keyframe: its features without a map point are matched to the previous
//!    keyframe's and triangulated with both poses ([`endoloc_geometry::Triangulator`], δr and
//!    parallax checks). Map points unseen for [`VoConfig::local_map_keyframes`] keyframes
//!    leave the local map.
//! 5. **Loss.** Fewer than [`VoConfig::min_tracked_inliers`] inliers (or too few matches, or
//!    no PnP solution) marks the frame [`TrackStatus::Lost`], counts a loss, and restarts
//!    initialization from the next frame. The new segment has its own frame and scale; no
//!    relocalization against earlier segments is attempted.
//!
//! Poses are `T_wc` (camera-to-world) in the segment's own frame (the reference camera's,
//! OpenCV axes) and in VO units (see [`crate::align`] to bring them to millimetres).

use endoloc_features::{Describe, Feature, Match, Matcher, Surf};
use endoloc_geometry::{
    Camera, EssentialRansacConfig, Observation, Pose, RansacConfig, Triangulator, ransac_essential,
    ransac_pnp, refine_pose,
};
use image::GrayImage;
use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

use crate::config::VoConfig;
use crate::error::VoError;

/// What happened to a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrackStatus {
    /// No pose: waiting for a reference frame or for enough parallax to initialize.
    Initializing,
    /// Pose from a two-view initialization (the segment's reference frame, at the origin,
    /// and the frame that completed the initialization).
    Initialized,
    /// Pose from PnP against the local map.
    Tracked,
    /// Tracking was lost at this frame (no pose); initialization restarts.
    Lost,
}

impl std::fmt::Display for TrackStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TrackStatus::Initializing => "initializing",
            TrackStatus::Initialized => "initialized",
            TrackStatus::Tracked => "tracked",
            TrackStatus::Lost => "lost",
        })
    }
}

/// Why a frame has no pose (for [`TrackStatus::Lost`] and [`TrackStatus::Initializing`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum NoPoseReason {
    /// Too few SURF keypoints in the frame (a black, blurred or textureless image).
    TooFewFeatures {
        /// Keypoints found.
        count: usize,
        /// Keypoints needed.
        min: usize,
    },
    /// Too few descriptor matches (to the reference frame or to the map).
    TooFewMatches {
        /// Matches found.
        count: usize,
        /// Matches needed.
        min: usize,
    },
    /// Too few inliers of the estimated pose (map points while tracking, triangulated points
    /// at initialization).
    TooFewInliers {
        /// Inliers found.
        count: usize,
        /// Inliers needed.
        min: usize,
    },
    /// Too little parallax yet between the reference and the current frame.
    LowParallax {
        /// Median triangulation angle, degrees.
        median_deg: f64,
        /// The configured minimum, degrees.
        min_deg: f64,
    },
    /// The robust estimator found no pose; the detail comes from it.
    NoPose {
        /// The estimator's message.
        detail: String,
    },
    /// This frame became the reference of a new initialization.
    Reference,
}

impl NoPoseReason {
    /// A short machine-readable code (`too_few_features`, …) for CSV files.
    pub fn code(&self) -> &'static str {
        match self {
            NoPoseReason::TooFewFeatures { .. } => "too_few_features",
            NoPoseReason::TooFewMatches { .. } => "too_few_matches",
            NoPoseReason::TooFewInliers { .. } => "too_few_inliers",
            NoPoseReason::LowParallax { .. } => "low_parallax",
            NoPoseReason::NoPose { .. } => "no_pose",
            NoPoseReason::Reference => "reference",
        }
    }
}

impl std::fmt::Display for NoPoseReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoPoseReason::TooFewFeatures { count, min } => {
                write!(f, "{count} keypoints, {min} needed")
            }
            NoPoseReason::TooFewMatches { count, min } => {
                write!(f, "{count} matches, {min} needed")
            }
            NoPoseReason::TooFewInliers { count, min } => {
                write!(f, "{count} inliers, {min} needed")
            }
            NoPoseReason::LowParallax {
                median_deg,
                min_deg,
            } => {
                write!(f, "median parallax {median_deg:.2}° below {min_deg}°")
            }
            NoPoseReason::NoPose { detail } => write!(f, "no pose: {detail}"),
            NoPoseReason::Reference => f.write_str("reference frame of a new initialization"),
        }
    }
}

/// The odometry's result for one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VoFrame {
    /// Frame index (0-based, in the order given to [`VisualOdometry::track`]).
    pub index: usize,
    /// What happened to the frame.
    pub status: TrackStatus,
    /// The tracked segment the pose belongs to (0-based; a new one starts at every
    /// initialization); `None` without a pose.
    pub segment: Option<usize>,
    /// Camera-to-world pose `T_wc` in the segment's frame (its reference camera, OpenCV axes),
    /// translation in VO units; `None` when the frame has no pose.
    pub t_wc: Option<Pose>,
    /// Why there is no pose, when there is none.
    pub reason: Option<NoPoseReason>,
    /// SURF keypoints in the frame.
    pub features: usize,
    /// Descriptor matches used (to the map, or to the reference frame at initialization).
    pub matches: usize,
    /// Inliers of the pose (map points, or triangulated points at initialization).
    pub inliers: usize,
    /// Whether the frame became a keyframe.
    pub keyframe: bool,
}

/// One frame's keypoints.
#[derive(Debug, Clone)]
struct FrameObs {
    index: usize,
    features: Vec<Feature>,
    pixels: Vec<Point2<f64>>,
}

/// A 3D point of the local map.
#[derive(Debug, Clone)]
struct MapPoint {
    /// Position in the segment's frame, VO units.
    p: Point3<f64>,
    descriptor: Vec<f32>,
    laplacian: i8,
    /// Keyframe counter when last seen as an inlier (or created).
    last_seen_kf: usize,
}

impl Describe for MapPoint {
    fn descriptor(&self) -> &[f32] {
        &self.descriptor
    }
    fn laplacian(&self) -> i8 {
        self.laplacian
    }
}

#[derive(Debug, Clone)]
struct Keyframe {
    obs: FrameObs,
    t_wc: Pose,
    /// Map point id (index into `Tracker::points`) of each feature, when it has one.
    point_of: Vec<Option<usize>>,
}

#[derive(Debug, Clone)]
struct Tracker {
    segment: usize,
    /// Map point slots; `None` once dropped from the local map.
    points: Vec<Option<MapPoint>>,
    last_kf: Keyframe,
    kf_count: usize,
    kf_inliers: usize,
    frames_since_kf: usize,
}

#[derive(Debug, Clone)]
enum State {
    Initializing {
        reference: Option<FrameObs>,
        /// Frames after the reference, localized once the map exists.
        pending: Vec<FrameObs>,
    },
    Tracking(Box<Tracker>),
}

/// A successful PnP localization against the map.
struct Localized {
    t_wc: Pose,
    matches: usize,
    /// `(feature index, map point id)` of each inlier.
    inliers: Vec<(usize, usize)>,
}

/// Monocular visual odometry; feed it frames in order with [`VisualOdometry::track`].
///
/// ```no_run
/// use endoloc_vo::{VisualOdometry, VoConfig};
/// # fn frames() -> Vec<image::GrayImage> { Vec::new() }
/// # let camera = endoloc_geometry::Camera::from_hfov(320, 240, 90.0);
/// let mut vo = VisualOdometry::new(camera, VoConfig::default())?;
/// for image in frames() {
///     let frame = vo.track(&image)?;
///     println!("{} {}", frame.index, frame.status);
/// }
/// let frames = vo.frames(); // final per-frame results (earlier frames may gain poses)
/// # Ok::<(), endoloc_vo::VoError>(())
/// ```
#[derive(Debug, Clone)]
pub struct VisualOdometry {
    camera: Camera,
    cfg: VoConfig,
    surf: Surf,
    matcher: Matcher,
    triangulator: Triangulator,
    state: State,
    frames: Vec<VoFrame>,
    lost_at: Vec<usize>,
    segments: usize,
}

impl VisualOdometry {
    /// A new odometry for images of `camera` (intrinsics in pixels, any distortion model).
    ///
    /// # Errors
    /// [`VoError::InvalidCamera`] for unusable intrinsics, [`VoError::InvalidConfig`] for an
    /// out-of-range setting (including the SURF and matcher settings).
    pub fn new(camera: Camera, cfg: VoConfig) -> Result<Self, VoError> {
        camera.validate().map_err(VoError::InvalidCamera)?;
        cfg.validate().map_err(VoError::InvalidConfig)?;
        if !(cfg.matcher.ratio > 0.0 && cfg.matcher.ratio <= 1.0) {
            return Err(VoError::InvalidConfig(format!(
                "matcher.ratio must be in (0, 1], got {}",
                cfg.matcher.ratio
            )));
        }
        let surf = cfg
            .surf
            .clone()
            .init()
            .map_err(|e| VoError::InvalidConfig(format!("surf: {e}")))?;
        let matcher = Matcher::new(cfg.matcher.clone());
        let triangulator = Triangulator::new(camera, cfg.triangulation);
        Ok(Self {
            camera,
            cfg,
            surf,
            matcher,
            triangulator,
            state: State::Initializing {
                reference: None,
                pending: Vec::new(),
            },
            frames: Vec::new(),
            lost_at: Vec::new(),
            segments: 0,
        })
    }

    /// This odometry for frames with an image mask (black border, field stop): SURF detects
    /// and describes only inside it. `None`: the whole image.
    pub fn with_mask(mut self, mask: Option<std::sync::Arc<endoloc_features::Mask>>) -> Self {
        self.surf = self.surf.with_mask(mask);
        self
    }

    /// The configuration in use.
    pub fn config(&self) -> &VoConfig {
        &self.cfg
    }

    /// The camera in use.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Results of every frame so far, in order. Final for all frames up to the last
    /// initialization; frames still waiting for an initialization may gain a pose later.
    pub fn frames(&self) -> &[VoFrame] {
        &self.frames
    }

    /// Consumes the odometry and returns every frame's result.
    pub fn into_frames(self) -> Vec<VoFrame> {
        self.frames
    }

    /// Frame indices where tracking was lost.
    pub fn lost_at(&self) -> &[usize] {
        &self.lost_at
    }

    /// Number of tracked segments started so far.
    pub fn segments(&self) -> usize {
        self.segments
    }

    /// Whether the odometry is currently tracking (has a map).
    pub fn is_tracking(&self) -> bool {
        matches!(self.state, State::Tracking(_))
    }

    /// Processes the next frame (8-bit grey, the camera's size) and returns its result.
    ///
    /// Losing track is not an error: it is reported as [`TrackStatus::Lost`] with a
    /// [`NoPoseReason`].
    ///
    /// # Errors
    /// [`VoError::ImageSize`] when the image is not the camera's size, [`VoError::Features`]
    /// when SURF fails on it.
    pub fn track(&mut self, image: &GrayImage) -> Result<VoFrame, VoError> {
        let index = self.frames.len();
        if image.width() != self.camera.width || image.height() != self.camera.height {
            return Err(VoError::ImageSize {
                frame: index,
                width: image.width(),
                height: image.height(),
                expected_width: self.camera.width,
                expected_height: self.camera.height,
            });
        }
        let features =
            self.surf
                .detect_and_describe(image)
                .map_err(|source| VoError::Features {
                    frame: index,
                    source,
                })?;
        let pixels = features
            .iter()
            .map(|f| Point2::new(f.keypoint.x as f64, f.keypoint.y as f64))
            .collect();
        let obs = FrameObs {
            index,
            features,
            pixels,
        };
        let frame = VoFrame {
            index,
            status: TrackStatus::Initializing,
            segment: None,
            t_wc: None,
            reason: None,
            features: obs.features.len(),
            matches: 0,
            inliers: 0,
            keyframe: false,
        };
        self.frames.push(frame);
        let state = std::mem::replace(
            &mut self.state,
            State::Initializing {
                reference: None,
                pending: Vec::new(),
            },
        );
        self.state = match state {
            State::Initializing { reference, pending } => self.initialize(reference, pending, obs),
            State::Tracking(tracker) => self.track_frame(*tracker, obs),
        };
        Ok(self.frames[index].clone())
    }

    fn frame_mut(&mut self, index: usize) -> &mut VoFrame {
        // `index` always comes from a frame pushed by `track`.
        &mut self.frames[index]
    }

    fn no_pose(&mut self, index: usize, status: TrackStatus, reason: NoPoseReason) {
        let f = self.frame_mut(index);
        f.status = status;
        f.t_wc = None;
        f.segment = None;
        f.reason = Some(reason);
    }

    /// One initialization step; returns the next state.
    fn initialize(
        &mut self,
        reference: Option<FrameObs>,
        mut pending: Vec<FrameObs>,
        obs: FrameObs,
    ) -> State {
        let index = obs.index;
        let min_features = self.cfg.init_min_matches;
        let Some(reference) = reference else {
            if obs.features.len() >= min_features {
                self.no_pose(index, TrackStatus::Initializing, NoPoseReason::Reference);
                return State::Initializing {
                    reference: Some(obs),
                    pending: Vec::new(),
                };
            }
            let count = obs.features.len();
            self.no_pose(
                index,
                TrackStatus::Initializing,
                NoPoseReason::TooFewFeatures {
                    count,
                    min: min_features,
                },
            );
            return State::Initializing {
                reference: None,
                pending: Vec::new(),
            };
        };
        let restart = |this: &mut Self, obs: FrameObs, reason: NoPoseReason| -> State {
            // The current frame becomes the new reference when it can serve as one.
            if obs.features.len() >= min_features {
                this.no_pose(obs.index, TrackStatus::Initializing, reason);
                State::Initializing {
                    reference: Some(obs),
                    pending: Vec::new(),
                }
            } else {
                let count = obs.features.len();
                this.no_pose(
                    obs.index,
                    TrackStatus::Initializing,
                    NoPoseReason::TooFewFeatures {
                        count,
                        min: min_features,
                    },
                );
                State::Initializing {
                    reference: None,
                    pending: Vec::new(),
                }
            }
        };
        let matches: Vec<Match> = self
            .matcher
            .match_descriptors(&obs.features, &reference.features)
            .unwrap_or_default();
        self.frame_mut(index).matches = matches.len();
        if matches.len() < self.cfg.init_min_matches {
            let reason = NoPoseReason::TooFewMatches {
                count: matches.len(),
                min: self.cfg.init_min_matches,
            };
            return restart(self, obs, reason);
        }
        let p_ref: Vec<Point2<f64>> = matches.iter().map(|m| reference.pixels[m.train]).collect();
        let p_cur: Vec<Point2<f64>> = matches.iter().map(|m| obs.pixels[m.query]).collect();
        let ess_cfg = EssentialRansacConfig {
            seed: self.cfg.essential.seed ^ (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            ..self.cfg.essential
        };
        let wait_or_restart = |this: &mut Self,
                               reference: FrameObs,
                               mut pending: Vec<FrameObs>,
                               obs: FrameObs,
                               reason: NoPoseReason|
         -> State {
            if pending.len() + 1 >= this.cfg.init_max_frames {
                return restart(this, obs, reason);
            }
            this.no_pose(obs.index, TrackStatus::Initializing, reason);
            pending.push(obs);
            State::Initializing {
                reference: Some(reference),
                pending,
            }
        };
        let est = match ransac_essential(&p_ref, &p_cur, &self.camera, &ess_cfg) {
            Ok(e) => e,
            Err(e) => {
                let reason = NoPoseReason::NoPose {
                    detail: e.to_string(),
                };
                return wait_or_restart(self, reference, pending, obs, reason);
            }
        };
        let t_ref = Pose::identity();
        let t_cur = est.pose.pose_2_in_1(1.0);
        // Triangulate the inliers in front of both views.
        let mut new_points: Vec<(usize, usize, Point3<f64>, f64)> = Vec::new(); // (query, train, p, parallax)
        for (k, m) in matches.iter().enumerate() {
            if !est.in_front[k] {
                continue;
            }
            let track = [
                Observation {
                    pose: t_ref,
                    pixel: p_ref[k],
                },
                Observation {
                    pose: t_cur,
                    pixel: p_cur[k],
                },
            ];
            if let Ok(tp) = self.triangulator.triangulate(&track) {
                new_points.push((m.query, m.train, tp.p_world, tp.parallax_deg));
            }
        }
        self.frame_mut(index).inliers = new_points.len();
        if new_points.len() < self.cfg.init_min_points {
            let reason = NoPoseReason::TooFewInliers {
                count: new_points.len(),
                min: self.cfg.init_min_points,
            };
            return wait_or_restart(self, reference, pending, obs, reason);
        }
        let mut parallax: Vec<f64> = new_points.iter().map(|p| p.3).collect();
        parallax.sort_by(f64::total_cmp);
        let median_deg = parallax[parallax.len() / 2];
        if median_deg < self.cfg.init_min_parallax_deg {
            let reason = NoPoseReason::LowParallax {
                median_deg,
                min_deg: self.cfg.init_min_parallax_deg,
            };
            return wait_or_restart(self, reference, pending, obs, reason);
        }

        // A new segment: the map from the two views.
        let segment = self.segments;
        self.segments += 1;
        let mut points = Vec::with_capacity(new_points.len());
        let mut point_of = vec![None; obs.features.len()];
        for (q, _t, p, _) in &new_points {
            let f = &obs.features[*q];
            point_of[*q] = Some(points.len());
            points.push(Some(MapPoint {
                p: *p,
                descriptor: f.descriptor.clone(),
                laplacian: f.keypoint.laplacian,
                last_seen_kf: 0,
            }));
        }
        for (i, pose) in [(reference.index, t_ref), (index, t_cur)] {
            let f = self.frame_mut(i);
            f.status = TrackStatus::Initialized;
            f.segment = Some(segment);
            f.t_wc = Some(pose);
            f.reason = None;
            f.keyframe = true;
        }
        self.frame_mut(reference.index).inliers = new_points.len();
        let n_inliers = new_points.len();
        let mut tracker = Tracker {
            segment,
            points,
            last_kf: Keyframe {
                obs,
                t_wc: t_cur,
                point_of,
            },
            kf_count: 0,
            kf_inliers: n_inliers,
            frames_since_kf: 0,
        };
        // Frames between the reference and this one: localize against the new map.
        for p in pending.drain(..) {
            if let Ok(loc) = self.localize(&mut tracker, &p, false) {
                let f = self.frame_mut(p.index);
                f.status = TrackStatus::Tracked;
                f.segment = Some(segment);
                f.t_wc = Some(loc.t_wc);
                f.reason = None;
                f.matches = loc.matches;
                f.inliers = loc.inliers.len();
            }
        }
        State::Tracking(Box::new(tracker))
    }

    /// Matches a frame to the local map and estimates its pose (RANSAC P3P + Gauss-Newton).
    /// With `update`, inlier map points take the frame's descriptors.
    fn localize(
        &self,
        tracker: &mut Tracker,
        obs: &FrameObs,
        update: bool,
    ) -> Result<Localized, NoPoseReason> {
        let min = self.cfg.min_tracked_inliers;
        let ids: Vec<usize> = tracker
            .points
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.as_ref().map(|_| i))
            .collect();
        let active: Vec<&MapPoint> = ids
            .iter()
            .filter_map(|&i| tracker.points[i].as_ref())
            .collect();
        let matches = self
            .matcher
            .match_descriptors(&obs.features, &active)
            .unwrap_or_default();
        if matches.len() < min {
            return Err(NoPoseReason::TooFewMatches {
                count: matches.len(),
                min,
            });
        }
        let pts: Vec<Point3<f64>> = matches.iter().map(|m| active[m.train].p).collect();
        let px: Vec<Point2<f64>> = matches.iter().map(|m| obs.pixels[m.query]).collect();
        let pnp_cfg = RansacConfig {
            seed: self.cfg.pnp.seed ^ (obs.index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            ..self.cfg.pnp
        };
        let r = ransac_pnp(&pts, &px, &self.camera, &pnp_cfg).map_err(|e| match e {
            endoloc_geometry::RansacError::NoConsensus { best_inliers, .. } => {
                NoPoseReason::TooFewInliers {
                    count: best_inliers,
                    min,
                }
            }
            other => NoPoseReason::NoPose {
                detail: other.to_string(),
            },
        })?;
        let est = refine_pose(&r.t_wc, &pts, &px, &self.camera, &self.cfg.refine).map_err(|e| {
            NoPoseReason::NoPose {
                detail: e.to_string(),
            }
        })?;
        if est.inlier_count < min {
            return Err(NoPoseReason::TooFewInliers {
                count: est.inlier_count,
                min,
            });
        }
        let inliers: Vec<(usize, usize)> = matches
            .iter()
            .zip(&est.inliers)
            .filter(|(_, inl)| **inl)
            .map(|(m, _)| (m.query, ids[m.train]))
            .collect();
        if update {
            for &(q, id) in &inliers {
                if let Some(Some(mp)) = tracker.points.get_mut(id) {
                    let f = &obs.features[q];
                    mp.descriptor.clone_from(&f.descriptor);
                    mp.last_seen_kf = tracker.kf_count;
                }
            }
        }
        Ok(Localized {
            t_wc: est.t_wc,
            matches: matches.len(),
            inliers,
        })
    }

    /// One tracking step; returns the next state.
    fn track_frame(&mut self, mut tracker: Tracker, obs: FrameObs) -> State {
        let index = obs.index;
        let loc = match self.localize(&mut tracker, &obs, true) {
            Ok(l) => l,
            Err(reason) => {
                if let NoPoseReason::TooFewMatches { count, .. } = reason {
                    self.frame_mut(index).matches = count;
                }
                let reason = if obs.features.len() < self.cfg.min_tracked_inliers {
                    NoPoseReason::TooFewFeatures {
                        count: obs.features.len(),
                        min: self.cfg.min_tracked_inliers,
                    }
                } else {
                    reason
                };
                self.no_pose(index, TrackStatus::Lost, reason);
                self.lost_at.push(index);
                return State::Initializing {
                    reference: None,
                    pending: Vec::new(),
                };
            }
        };
        tracker.frames_since_kf += 1;
        let n_inliers = loc.inliers.len();
        {
            let f = self.frame_mut(index);
            f.status = TrackStatus::Tracked;
            f.segment = Some(tracker.segment);
            f.t_wc = Some(loc.t_wc);
            f.reason = None;
            f.matches = loc.matches;
            f.inliers = n_inliers;
        }
        let need_kf = tracker.frames_since_kf >= self.cfg.keyframe_max_gap
            || (n_inliers as f64) < self.cfg.keyframe_min_inlier_ratio * tracker.kf_inliers as f64;
        if need_kf {
            self.insert_keyframe(&mut tracker, obs, loc);
            self.frame_mut(index).keyframe = true;
        }
        State::Tracking(Box::new(tracker))
    }

    /// Makes `obs` a keyframe: triangulates its unmapped features with the previous
    /// keyframe's and prunes the local map.
    fn insert_keyframe(&mut self, tracker: &mut Tracker, obs: FrameObs, loc: Localized) {
        tracker.kf_count += 1;
        let mut point_of = vec![None; obs.features.len()];
        for &(q, id) in &loc.inliers {
            point_of[q] = Some(id);
            if let Some(Some(mp)) = tracker.points.get_mut(id) {
                mp.last_seen_kf = tracker.kf_count;
            }
        }
        // Unmapped features of both keyframes.
        let cur_free: Vec<usize> = (0..obs.features.len())
            .filter(|&i| point_of[i].is_none())
            .collect();
        let prev = &tracker.last_kf;
        let prev_free: Vec<usize> = (0..prev.obs.features.len())
            .filter(|&i| prev.point_of[i].is_none())
            .collect();
        let q: Vec<&Feature> = cur_free.iter().map(|&i| &obs.features[i]).collect();
        let t: Vec<&Feature> = prev_free.iter().map(|&i| &prev.obs.features[i]).collect();
        let matches = self.matcher.match_descriptors(&q, &t).unwrap_or_default();
        let mut added = 0;
        for m in matches {
            let (ci, pi) = (cur_free[m.query], prev_free[m.train]);
            let track = [
                Observation {
                    pose: prev.t_wc,
                    pixel: prev.obs.pixels[pi],
                },
                Observation {
                    pose: loc.t_wc,
                    pixel: obs.pixels[ci],
                },
            ];
            if let Ok(tp) = self.triangulator.triangulate(&track) {
                let f = &obs.features[ci];
                point_of[ci] = Some(tracker.points.len());
                tracker.points.push(Some(MapPoint {
                    p: tp.p_world,
                    descriptor: f.descriptor.clone(),
                    laplacian: f.keypoint.laplacian,
                    last_seen_kf: tracker.kf_count,
                }));
                added += 1;
            }
        }
        // Local map: drop points unseen for `local_map_keyframes` keyframes.
        let keep = self.cfg.local_map_keyframes;
        let now = tracker.kf_count;
        for slot in tracker.points.iter_mut() {
            if slot.as_ref().is_some_and(|p| p.last_seen_kf + keep < now) {
                *slot = None;
            }
        }
        tracker.kf_inliers = loc.inliers.len() + added;
        tracker.frames_since_kf = 0;
        tracker.last_kf = Keyframe {
            obs,
            t_wc: loc.t_wc,
            point_of,
        };
    }
}
