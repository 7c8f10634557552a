//! Confirming a registration against every map point near it (beyond the paper).
//!
//! A registration matches the frame's features to the map points of a few zones by
//! descriptor alone, so a handful of look-alike matches can agree on a wrong pose: far points
//! near the image centre fix the viewing direction, and one or two wrong near points then
//! place the camera millimetres off, with a small reprojection error. Such a pose explains
//! few of the map points it should see.
//!
//! Confirmation asks the map. Starting from the registered pose `T_wc`, every map point of
//! the zone that pose lies in and of [`ConfirmConfig::neighbour_zones`] zones on each side is
//! projected into the frame and compared only with the features within a window around its
//! projection ([`crate::guided::match_guided`]), keeping matches whose descriptors are close
//! in absolute terms ([`ConfirmConfig::max_distance`]: a window holds a feature for nearly
//! every projected point, so the ratio test alone would accept a chance match in most of
//! them). The pose is refined again from these matches by Gauss-Newton from the current pose
//! (no RANSAC restart); the windows shrink round by round ([`ConfirmConfig::radii_px`]).
//!
//! A right registration comes out sharper (many more inliers, near points among them); a
//! pose a few millimetres off either moves to the right one (its windows still hold the true
//! matches) or keeps only a few inliers, and is then not `refined`: reason `unsupported` when
//! the rounds fail the validity check, `weakly_supported` when the confirmed pose is valid
//! but has fewer than [`ConfirmConfig::min_inliers`] (a weakly textured view; live, the
//! motion model's prediction decides).
//!
//! A wrong pose can also be a local optimum that a few dozen map points support while the
//! right one, some millimetres away, has several times more. So when the confirmed pose has
//! few inliers ([`ConfirmConfig::multi_start_below`]), confirmation also starts from six poses
//! around it (± [`ConfirmConfig::start_offset_mm`] along the camera axes) and the result with
//! the most inliers wins — unless another start ends more than
//! [`ConfirmConfig::ambiguity_mm`] away with nearly as many
//! ([`ConfirmConfig::ambiguity_ratio`]): then the frame does not tell the two apart and is not
//! `refined` (reason `ambiguous`).

use endoloc_features::{Feature, MatcherConfig};
use endoloc_geometry::{
    Camera, Pose, PoseEstimate, Reason, RegistrationConfig, Status, localize_pose,
};
use nalgebra::Point3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::LocalizeError;
use crate::map::{Map, MapPoint, correspondences, inlier_pixels, inlier_points};

/// Settings of the confirmation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConfirmConfig {
    /// Window radius of each round, pixels, widest first: a round projects the map points with
    /// the previous round's pose, matches in windows of this radius and refines. Empty
    /// (default): no confirmation, the registration is reported as it is (the paper's
    /// behaviour); [`ConfirmConfig::standard`] gives 25, 12, 6 and 4 px.
    pub radii_px: Vec<f64>,
    /// Largest L2 distance between unit descriptors of a confirming match. On the `paper`
    /// preset 0.3 keeps 81 % of the true matches and 2 % of the chance ones (features matched
    /// with a pose 8 mm off).
    pub max_distance: f32,
    /// Map points come from the zone of the registered pose and this many zones on each side.
    pub neighbour_zones: usize,
    /// Fewest inliers of the confirmed pose for the frame to stay `refined`, for a 640×480
    /// frame (scaled with the frame's area, as the features are; never below the validity
    /// check's minimum); below it the frame is `init_only` (reason `weakly_supported`) with the
    /// confirmed pose.
    pub min_inliers: usize,
    /// A confirmed pose with fewer inliers than this (for a 640×480 frame, scaled as
    /// [`ConfirmConfig::min_inliers`]) is also sought from six starts around it; 0 = a single
    /// start.
    pub multi_start_below: usize,
    /// Offset of those starts from the confirmed pose along each camera axis, mm.
    pub start_offset_mm: f64,
    /// Two results farther apart than this (camera centres, mm) are rivals.
    pub ambiguity_mm: f64,
    /// The best result is ambiguous when a rival has at least this fraction of its inliers.
    pub ambiguity_ratio: f64,
    /// Live: a registration tracked from the motion model's prediction (matched near a recent
    /// refined pose) with at least this many inliers, whatever the image size (as the motion
    /// gate's [`MotionConfig::trusted_inliers`](crate::motion::MotionConfig::trusted_inliers)),
    /// is trusted as it is, not confirmed; 0 = confirm every registration. The wrong
    /// `refined` poses that confirmation removes are weak registrations (8–30 inliers on the
    /// benchmark's colons), while a strong tracked one comes out no sharper for it; skipping
    /// those (three frames in four or more) makes confirmation cost a fraction of a
    /// millisecond per frame instead of about four.
    pub trust_tracked_inliers: usize,
}

impl Default for ConfirmConfig {
    /// Off (no radii), with [`ConfirmConfig::standard`]'s other settings.
    fn default() -> Self {
        ConfirmConfig {
            radii_px: Vec::new(),
            max_distance: 0.3,
            neighbour_zones: 2,
            min_inliers: 25,
            multi_start_below: 80,
            start_offset_mm: 6.0,
            ambiguity_mm: 3.0,
            ambiguity_ratio: 0.8,
            trust_tracked_inliers: 50,
        }
    }
}

impl ConfirmConfig {
    /// Confirmation on: windows of 25, 12, 6 and 4 px, descriptor distance ≤ 0.3, the zone of
    /// the pose and two on each side, at least 25 inliers; six more starts 6 mm around a pose
    /// with fewer than 80 inliers, ambiguous when a rival 3 mm away has 80 % of the inliers;
    /// live, tracked registrations with 50 inliers or more trusted as they are.
    pub fn standard() -> Self {
        ConfirmConfig {
            radii_px: vec![25.0, 12.0, 6.0, 4.0],
            ..Self::default()
        }
    }

    /// Whether confirmation runs.
    pub fn is_on(&self) -> bool {
        !self.radii_px.is_empty()
    }

    /// These settings for frames of `camera`'s size: the inlier counts scaled with the image
    /// area from 640×480, `min_inliers` at least `floor`.
    pub fn for_camera(&self, camera: &Camera, floor: usize) -> ConfirmConfig {
        let scale = (camera.width as f64 * camera.height as f64) / (640.0 * 480.0);
        let scaled = |n: usize| (n as f64 * scale).round() as usize;
        ConfirmConfig {
            min_inliers: scaled(self.min_inliers).max(floor),
            multi_start_below: scaled(self.multi_start_below),
            ..self.clone()
        }
    }

    /// Checks the settings; the message names the field.
    ///
    /// # Errors
    /// [`LocalizeError::Config`] for a non-positive radius, distance or offset, or a ratio
    /// outside (0, 1].
    pub fn validate(&self) -> Result<(), LocalizeError> {
        if let Some(r) = self.radii_px.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
            return Err(LocalizeError::Config(format!(
                "confirm.radii_px must be positive pixel radii, got {r}"
            )));
        }
        let positive = [
            ("max_distance", self.max_distance as f64),
            ("start_offset_mm", self.start_offset_mm),
            ("ambiguity_mm", self.ambiguity_mm),
        ];
        if let Some((name, v)) = positive.iter().find(|(_, v)| !v.is_finite() || *v <= 0.0) {
            return Err(LocalizeError::Config(format!(
                "confirm.{name} must be positive, got {v}"
            )));
        }
        if !(self.ambiguity_ratio > 0.0 && self.ambiguity_ratio <= 1.0) {
            return Err(LocalizeError::Config(format!(
                "confirm.ambiguity_ratio must be in (0, 1], got {}",
                self.ambiguity_ratio
            )));
        }
        Ok(())
    }
}

/// The outcome of [`confirm`].
#[derive(Debug, Clone)]
pub struct Confirmation {
    /// `refined` with the confirmed pose, or `init_only` with the reason.
    pub status: Status,
    /// Why the registration was not confirmed; `None` when it was.
    pub reason: Option<Reason>,
    /// The winning start's last refinement (the confirmed pose when `refined`).
    pub estimate: Option<PoseEstimate>,
    /// Pixels of that refinement's inliers.
    pub inlier_px: Vec<[f32; 2]>,
    /// The map points of those inliers (world, mm), in the order of `inlier_px`.
    pub inlier_points: Vec<Point3<f64>>,
    /// Guided matches of that refinement.
    pub correspondences: usize,
    /// Starts tried (1, or 7 with the starts around a weakly supported pose).
    pub starts: usize,
}

impl Confirmation {
    fn inliers(&self) -> usize {
        self.estimate.as_ref().map_or(0, |e| e.inlier_count)
    }
}

/// Confirms the registered pose `t_wc` (camera-to-world, mm) of a frame with `features`
/// against the map points near it (the zone `t_wc` lies in, `zone`, and
/// [`ConfirmConfig::neighbour_zones`] on each side): the rounds of
/// [`ConfirmConfig::radii_px`], each guided matching then Gauss-Newton from the previous pose,
/// validity checked with `registration`'s thresholds; from more starts when the result is
/// weakly supported, as the [module documentation](self) describes. `camera` is the frame's
/// (the map's, or another scope's of the same size). Inlier counts are those of `cfg` scaled
/// to the image size ([`ConfirmConfig::for_camera`]).
#[allow(clippy::too_many_arguments)]
pub fn confirm(
    features: &[Feature],
    map: &Map,
    camera: &Camera,
    zone: usize,
    t_wc: &Pose,
    matcher: &MatcherConfig,
    registration: &RegistrationConfig,
    cfg: &ConfirmConfig,
) -> Confirmation {
    let cfg = &cfg.for_camera(camera, registration.validity.min_inliers);
    let lo = zone.saturating_sub(cfg.neighbour_zones);
    let hi = (zone + cfg.neighbour_zones + 1).min(map.zones.len());
    let candidates: Vec<&MapPoint> = map
        .zones
        .get(lo..hi)
        .unwrap_or_default()
        .iter()
        .flat_map(|zm| zm.points.iter())
        .collect();
    let matcher = MatcherConfig {
        max_distance: cfg.max_distance.min(matcher.max_distance),
        ..matcher.clone()
    };
    // From the current pose only: a RANSAC restart would search for any consensus again.
    let registration = RegistrationConfig {
        ransac_below_inlier_ratio: 0.0,
        always_ransac: false,
        ..*registration
    };
    let run = |start: &Pose| {
        confirm_from(
            features,
            &candidates,
            camera,
            start,
            &matcher,
            &registration,
            cfg,
        )
    };
    let first = run(t_wc);
    if cfg.multi_start_below == 0 || first.inliers() >= cfg.multi_start_below {
        return first;
    }
    // Starts around the confirmed pose (or the registered one when confirmation failed).
    let centre = first.estimate.as_ref().map_or(*t_wc, |e| e.t_wc);
    let starts: Vec<Pose> = (0..3)
        .flat_map(|axis| {
            [-1.0, 1.0].map(|sign| {
                let mut offset = nalgebra::Vector3::zeros();
                offset[axis] = sign * cfg.start_offset_mm;
                let mut start = centre;
                start.translation.vector += centre.rotation * offset;
                start
            })
        })
        .collect();
    // The starts are independent: run side by side, collected in order.
    let mut results = vec![first];
    results.par_extend(starts.par_iter().map(run));
    let starts = results.len();
    let best = (0..results.len())
        .max_by_key(|&i| (results[i].inliers(), std::cmp::Reverse(i)))
        .unwrap_or(0);
    let mut winner = results.swap_remove(best);
    winner.starts = starts;
    if winner.status != Status::Refined {
        return winner;
    }
    let Some(pose) = winner.estimate.as_ref().map(|e| e.t_wc) else {
        return winner;
    };
    let inliers = winner.inliers();
    let rival = results
        .iter()
        .filter_map(|r| {
            let e = r.estimate.as_ref()?;
            let d = (e.t_wc.translation.vector - pose.translation.vector).norm();
            (d > cfg.ambiguity_mm).then_some((d, e.inlier_count))
        })
        .max_by_key(|&(_, n)| n);
    if let Some((distance_mm, rival_inliers)) = rival
        && rival_inliers as f64 >= cfg.ambiguity_ratio * inliers as f64
    {
        winner.status = Status::InitOnly;
        winner.reason = Some(Reason::Ambiguous {
            distance_mm,
            inliers,
            rival_inliers,
        });
    }
    winner
}

/// One start of [`confirm`]: the rounds from `start`.
fn confirm_from(
    features: &[Feature],
    candidates: &[&MapPoint],
    camera: &Camera,
    start: &Pose,
    matcher: &MatcherConfig,
    registration: &RegistrationConfig,
    cfg: &ConfirmConfig,
) -> Confirmation {
    let mut pose = *start;
    let mut last = Confirmation {
        status: Status::InitOnly,
        reason: Some(Reason::Unsupported {
            inliers: 0,
            min: cfg.min_inliers,
        }),
        estimate: None,
        inlier_px: Vec::new(),
        inlier_points: Vec::new(),
        correspondences: 0,
        starts: 1,
    };
    for (i, &radius) in cfg.radii_px.iter().enumerate() {
        let matches = crate::guided::match_guided(
            features,
            candidates,
            camera,
            &pose,
            crate::guided::Window::rigid(radius, registration.refine.min_depth_mm)
                .with_wall_motion(registration.refine.wall_motion_mm),
            matcher,
        );
        let (points, pixels) = correspondences(&matches, features, candidates);
        // Inputs come from the map and the detector: finite by construction.
        let Ok(result) = localize_pose(&pose, &points, &pixels, camera, registration) else {
            return last;
        };
        let inliers = result.estimate.as_ref().map_or(0, |e| e.inlier_count);
        last.correspondences = matches.len();
        last.inlier_px = result
            .estimate
            .as_ref()
            .map_or_else(Vec::new, |e| inlier_pixels(&pixels, &e.inliers));
        last.inlier_points = result
            .estimate
            .as_ref()
            .map_or_else(Vec::new, |e| inlier_points(&points, &e.inliers));
        let min = cfg.min_inliers;
        let failure = if result.verdict.status != Status::Refined {
            Some(Reason::Unsupported { inliers, min })
        } else if i + 1 == cfg.radii_px.len() && inliers < min {
            Some(Reason::WeaklySupported { inliers, min })
        } else {
            None
        };
        if failure.is_some() {
            last.status = Status::InitOnly;
            last.reason = failure;
            last.estimate = result.estimate;
            return last;
        }
        let estimate = result.estimate.expect("a refined verdict has an estimate");
        pose = estimate.t_wc;
        last.status = Status::Refined;
        last.reason = None;
        last.estimate = Some(estimate);
    }
    last
}
