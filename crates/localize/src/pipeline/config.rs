//! The localizer's settings ([`LocalizerConfig`]), saved with every run.

use endoloc_features::{MatcherConfig, SurfConfig};
use endoloc_geometry::{RegistrationConfig, WallCovarianceConfig};
use endoloc_net::TemporalConfig;
use serde::{Deserialize, Serialize};

use crate::colon_scale::ColonScaleConfig;
use crate::confirm::ConfirmConfig;
use crate::motion::MotionConfig;

/// The test frames' SURF threshold by default, as a multiple of the map's: low (10 for the
/// default map threshold of 25), so that a frame whose responses all fall — blurred, dimmer,
/// fainter texture than the mapping pass — still has keypoints; [`TEST_KEYPOINT_BUDGET`]
/// keeps a sharp frame to its strongest ones.
pub const TEST_THRESHOLD_FACTOR: f32 = 0.4;

/// The test frames' keypoint budget by default ([`SurfConfig::keypoint_budget`]): at most
/// 2·√(width·height) keypoints, the strongest (554 at 320×240, 1 109 at 640×480), about
/// twice what a textured frame has at twice the map's threshold. Against that fixed
/// threshold (and its retry at the map's), over five procedural colons and the CT colon
/// (`small` preset, live): the unchanged pass 95.6 → 95.7 % refined, median 0.27 → 0.22 mm,
/// refined frames more than 5 mm off 0.7 → 0.1 %; blurred (`moderate`) 80.2 → 85.4 %; every
/// `moderate` look change 25.9 → 40.2 %; on the `paper` preset's development colon the
/// live mean error 0.22 → 0.12 mm. About 1 ms more per live frame at 320×240, 3 ms at
/// 640×480 (docs/RESULTS.md).
pub const TEST_KEYPOINT_BUDGET: f32 = 2.0;

/// The retry's SURF threshold by default ([`LocalizerConfig::retry_threshold`]), as a
/// multiple of the map's.
pub const RETRY_THRESHOLD_FACTOR: f32 = 2.0;

/// Settings of the localizer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LocalizerConfig {
    /// SURF on the test frames. `None` (default): the map's own SURF settings with a keypoint
    /// budget ([`LocalizerConfig::test_surf`]). Any descriptor setting (`extended`, `upright`)
    /// must match the map's for the matching to mean anything.
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
    /// registers from the motion model's prediction ([`LocalizerConfig::track_frames`](crate::LocalizerConfig::track_frames)) is
    /// not classified — its zone is the one its pose lies in, its `zone_score` is NaN — and
    /// the classifier runs only when tracking fails. The zone filters are anchored at every
    /// refined pose, so what a tracked frame's classification would have told them is
    /// overwritten at once; skipping it saves the network's time on most frames.
    pub classify_tracked: bool,
    /// A frame that registers nowhere with its test features is described again with every
    /// keypoint above this SURF threshold (no budget) and tried once more (beyond the paper;
    /// its time counts in the frame's SURF time). `None` (default): twice the map's threshold
    /// — the strongest keypoints alone, among which brute-force matching against three zones'
    /// points finds fewer look-alikes than among a budget's weaker ones — per frame only:
    /// live, a lost frame is not described twice. `Some(t)`: at `t` in both modes, and a live
    /// stream that has lost its track describes each frame once, at `t`, when `t` is below
    /// the test threshold. `Some(0.0)`: off.
    pub retry_threshold: Option<f32>,
    /// Calibration of the reported uncertainty: the standard deviations in `frames.csv` are
    /// this many times those of the Gauss-Newton covariance (which sees only the test
    /// keypoints' noise, not the map points' own error) with the wall-motion term
    /// ([`Self::wall_covariance`]), chosen so that 1.96 × `position_std_mm` bounds about 95 %
    /// of refined frames' position errors on simulated unchanged passes.
    pub uncertainty_scale: f64,
    /// The stated uncertainty also counts a wall that moved since the mapping pass
    /// ([`endoloc_geometry::wall_covariance`](mod@endoloc_geometry::wall_covariance)):
    /// residuals beyond the keypoint noise are read as motion of the wall, correlated over
    /// `correlation_mm`, and the pose error such a motion causes is added to the covariance
    /// (before [`Self::uncertainty_scale`]). On a wall that did not move it adds (nearly)
    /// nothing. Live, the wall's motion is read off the stream's last
    /// [`WallCovarianceConfig::pooled_registrations`] registrations together, and a pose is
    /// stated with the larger of that and what its own residuals show. It changes no status:
    /// live, the prediction vouches for a weak pose by the pose's uncertainty without it
    /// ([`FrameResult::measurement_std_mm`](crate::FrameResult::measurement_std_mm)); only the
    /// opt-in per-frame limits [`Self::max_std_mm`] and [`Self::weak_max_std_mm`] read it.
    pub wall_covariance: WallCovarianceConfig,
    /// Per frame only (no motion model to check a registration against): the largest
    /// calibrated position standard deviation (as in `frames.csv`) of a `refined` frame with
    /// [`MotionConfig::trusted_inliers`] inliers or more, mm. Above it the frame is
    /// `init_only` (reason `uncertain`) and keeps its registered pose (source `registered`).
    /// Infinity (default): off. The stated uncertainty grows as the images shrink, so a limit
    /// suits one camera: on the `paper` preset (640×480) 1.5 mm, with
    /// [`LocalizerConfig::weak_max_std_mm`](crate::LocalizerConfig::weak_max_std_mm) 0.75 mm, leaves 2 of 2603 refined frames more
    /// than 5 mm off instead of 85, at 81.9 % refined instead of 94.9 %.
    pub max_std_mm: f64,
    /// As [`LocalizerConfig::max_std_mm`](crate::LocalizerConfig::max_std_mm), for registrations with fewer inliers: wrong
    /// registrations (a neighbouring zone's points in a spurious consensus, the camera placed
    /// millimetres too far along the lumen) come with few inliers and a larger stated
    /// uncertainty than right ones.
    pub weak_max_std_mm: f64,
    /// Every registration is confirmed against all map points near its pose and refined again
    /// from them ([`confirm`](mod@crate::confirm); beyond the paper). Off in this
    /// configuration's default, the paper's pipeline; [`ConfirmConfig::standard`] turns it on,
    /// as `endoloc localize` does unless `confirm` is off.
    pub confirm: ConfirmConfig,
    /// Refine every `refined` pose once more with the colon's scale about its mid-line
    /// ([`crate::colon_scale`]; beyond the paper): the pose reported is the camera carried
    /// back into the mapped colon. `None` (default): rigid poses, as in the paper.
    pub colon_scale: Option<ColonScaleConfig>,
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
            wall_covariance: WallCovarianceConfig::default(),
            max_std_mm: f64::INFINITY,
            weak_max_std_mm: f64::INFINITY,
            confirm: ConfirmConfig::default(),
            colon_scale: None,
        }
    }
}

impl LocalizerConfig {
    /// The SURF settings of the test frames for a map built with `map_surf`: [`Self::surf`], or
    /// the map's at [`TEST_THRESHOLD_FACTOR`] × its threshold with the
    /// [`TEST_KEYPOINT_BUDGET`] ([`SurfConfig::keypoint_budget`]).
    pub fn test_surf(&self, map_surf: &SurfConfig) -> SurfConfig {
        self.surf.clone().unwrap_or_else(|| {
            map_surf
                .clone()
                .with_threshold(TEST_THRESHOLD_FACTOR * map_surf.threshold)
                .with_keypoint_budget(TEST_KEYPOINT_BUDGET)
        })
    }

    /// The SURF settings of the retry for a map built with `map_surf`
    /// ([`Self::retry_threshold`]: every keypoint above it, no budget), `None` when off or
    /// when they would be the test frames' own.
    pub fn retry_surf(&self, map_surf: &SurfConfig) -> Option<SurfConfig> {
        let test = self.test_surf(map_surf);
        let threshold = self
            .retry_threshold
            .unwrap_or(RETRY_THRESHOLD_FACTOR * map_surf.threshold);
        let retry = test
            .clone()
            .with_threshold(threshold)
            .with_keypoint_budget(0.0)
            .with_max_keypoints(0);
        (threshold > 0.0 && retry != test).then_some(retry)
    }

    /// Whether a live stream retries too ([`Self::retry_threshold`]): only with a retry
    /// threshold given, and below the test frames'. Then a frame that the motion model
    /// cannot track from is described once, at the retry threshold.
    pub fn retry_live(&self, map_surf: &SurfConfig) -> bool {
        self.retry_threshold
            .is_some_and(|t| t > 0.0 && t < self.test_surf(map_surf).threshold)
    }
}
