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
//! frames get the features they need, while the typical frame keeps the cheaper detection. A
//! live stream that has lost its track (no refined frame recent enough to register from the
//! motion model's prediction) describes each frame once, at the lower threshold: there the
//! first attempt seldom registers, and a lost frame costs about a third less.

mod config;
mod frame;
mod live;
mod result;
mod scale;

pub use config::LocalizerConfig;
pub use frame::{Localizer, RetryFeatures};
pub use live::LiveState;
pub use result::{FrameResult, PoseSource, StageTimes};
