//! The colon-scale step of a registered frame ([`crate::colon_scale`]), alone or live.

use endoloc_geometry::Status;
use nalgebra::Point2;

use crate::colon_scale::{ScaleState, ScaleTrack, ScaledPose};

use super::frame::Localizer;
use super::result::FrameResult;

impl Localizer {
    /// A frame on its own: its `refined` pose refined again with the colon's scale from the
    /// frame's own prior, when [`LocalizerConfig::colon_scale`](crate::LocalizerConfig::colon_scale)
    /// is on.
    pub(super) fn scaled_alone(&self, r: FrameResult) -> FrameResult {
        self.with_colon_scale(r, None).0
    }

    /// Live: as [`Localizer::scaled_alone`] from the scale followed so far, which the frame's
    /// estimate then updates.
    pub(super) fn scaled_live(
        &self,
        r: FrameResult,
        track: &mut Option<ScaleTrack>,
    ) -> FrameResult {
        let (Some(scale), Some(t_wc)) = (&self.colon_scale, r.t_wc) else {
            return r;
        };
        let track = track.get_or_insert_with(ScaleTrack::default);
        let prior = track.prior(scale.at_mm(&t_wc), scale.config());
        let (r, scaled) = self.with_colon_scale(r, Some(&prior));
        if let Some(s) = &scaled {
            track.update(s, scale.config());
        }
        r
    }

    /// `r` with its `refined` pose, uncertainty and RMS from the colon-scale refinement
    /// (prior on the scale: `prior`, or the frame's own); unchanged when the step is off, the
    /// frame is not `refined` or the refinement fails.
    fn with_colon_scale(
        &self,
        mut r: FrameResult,
        prior: Option<&ScaleState>,
    ) -> (FrameResult, Option<ScaledPose>) {
        let (Some(scale), Status::Refined, Some(t_wc)) = (&self.colon_scale, r.status, r.t_wc)
        else {
            return (r, None);
        };
        let t = std::time::Instant::now();
        let pixels: Vec<Point2<f64>> = r
            .inlier_px
            .iter()
            .map(|p| Point2::new(f64::from(p[0]), f64::from(p[1])))
            .collect();
        let scaled = scale.refine(&t_wc, &r.inlier_points, &pixels, &self.camera, prior);
        if let Some(s) = &scaled {
            let e = &s.estimate;
            r.t_wc = Some(e.t_wc);
            r.position_std_mm = self.cfg.uncertainty_scale * e.position_sigma_mm();
            r.orientation_std_deg = self.cfg.uncertainty_scale * e.rotation_sigma_deg();
            r.measurement_std_mm = r.position_std_mm;
            // Stated by the scaled model, which the wall-motion term does not extend.
            r.uncertainty = None;
            r.reprojection_rms_px = e.rms_px;
            r.colon_scale = Some(s.scale.scale);
        }
        r.times.refine_ms += super::frame::ms(t);
        (r, scaled)
    }
}
