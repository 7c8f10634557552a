//! Localizing one test frame: the paper's two steps, with an honest status.
//!
//! 1. **Zone**: the Siamese classifier gives the zone (live, filtered over time by the causal
//!    track filter over training frames, [`endoloc_net::track`], anchored at each refined
//!    pose; the zone-level HMM for predictions without a descriptor).
//! 2. **Initial pose**: the zone's median training pose.
//! 3. **Registration**: SURF on the frame (beyond the paper: a keypoint budget per frame at a
//!    low threshold, [`LocalizerConfig::test_surf`]), matched (ratio test, mutual nearest, Laplacian
//!    gating) to the map points of the zone and its `neighbour_zones` neighbours on each side.
//! 4. **Refinement and check**: [`endoloc_geometry::localize_pose`] — Gauss-Newton on SE(3)
//!    with left perturbation from the prior, a RANSAC restart when the prior is poor, and the
//!    validity check (`refined` / `init_only` / `rejected` with a reason).
//!
//! With [`LocalizerConfig::confirm`] on (beyond the paper), every registration is then
//! confirmed against all map points near its pose ([`confirm`](mod@crate::confirm)): refined again from
//! them, or flagged `unsupported`, `weakly_supported` or `ambiguous`.
//!
//! Test frames keep their strongest keypoints up to a budget that grows with the image's side,
//! above a threshold well below the map's ([`TEST_KEYPOINT_BUDGET`]): a sharp frame
//! is described as with a high threshold, a blurred, dim or faint one (all of whose responses
//! fall, as on a pass through a changed colon) keeps the keypoints a fixed threshold would
//! lose. Per frame, a frame that registers nowhere is described again with its strongest
//! keypoints alone (every keypoint above twice the map's threshold,
//! [`LocalizerConfig::retry_threshold`]) and tried once more: brute-force matching finds
//! fewer look-alikes among them.
//!
//! A map may have a smoothed level ([`Localizer::with_smoothed_level`]; the map job builds one
//! by default): the map of the training images smoothed by a Gaussian. A frame that the map
//! does not register, tracked or searched for, is registered the same way against the level,
//! whose coarser structure holds when the pass has another look than the mapping pass.

mod config;
mod frame;
mod live;
mod result;
mod scale;

pub use config::{
    LocalizerConfig, RETRY_THRESHOLD_FACTOR, TEST_KEYPOINT_BUDGET, TEST_THRESHOLD_FACTOR,
};
pub use frame::{Localizer, RetryFeatures};
pub use live::LiveState;
pub use result::{FrameResult, PoseSource, PoseUncertainty, StageTimes};
