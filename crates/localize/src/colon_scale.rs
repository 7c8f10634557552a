//! The colon's scale about its mid-line, estimated with each pose (beyond the paper): a colon
//! insufflated more or less than when it was mapped is the mapped colon scaled about its
//! mid-line, and a rigid pose fitted to it lands millimetres off along the lumen.
//!
//! After a frame is registered, its inlier correspondences are refined again with the scale
//! `k` of the map about the mid-line and its change along it
//! ([`endoloc_geometry::refine_radial()`]); the reported pose is the camera carried back into
//! the mapped colon, and its covariance includes the scale's uncertainty. The mid-line is the
//! training pass's camera path, smoothed over [`MIDLINE_HALF_WINDOW_MM`] on each side; each
//! map point's foot is its nearest point on it.
//!
//! A frame on its own starts from the prior `k ~ N(1, σ²)`. Live, the scale is followed from
//! frame to frame ([`ScaleTrack`]): a random walk whose variance grows with the distance the
//! camera moves ([`ColonScaleConfig::walk_per_sqrt_mm`]), so the scale found on the frames
//! before is the next frame's prior — one frame's view tells the scale from a camera moved
//! along the lumen only roughly, a stretch of frames much better.

use endoloc_geometry::{Camera, Foot, Polyline, Pose, PoseEstimate, RadialConfig, refine_radial};
use nalgebra::{Matrix2, Point2, Point3};
use serde::{Deserialize, Serialize};

/// Half-width of the running mean that turns the training camera path into a mid-line, mm of
/// path.
pub const MIDLINE_HALF_WINDOW_MM: f64 = 10.0;

/// Settings of the colon-scale refinement.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ColonScaleConfig {
    /// Gauss-Newton settings and, for a frame on its own, the priors (`fit.prior_mean` 1).
    pub fit: RadialConfig,
    /// Live: how far the scale may wander as the camera moves, the standard deviation of its
    /// random walk per √mm of camera travel along the mid-line (0.003: about 0.02 over 50 mm;
    /// its slope walks 100 times slower per mm).
    pub walk_per_sqrt_mm: f64,
    /// Live: a frame's scale covariance is this many times the fit's before it becomes the
    /// next frame's prior (the fit sees the keypoints' noise, not the map points' own error).
    pub covariance_scale: f64,
}

impl Default for ColonScaleConfig {
    fn default() -> Self {
        ColonScaleConfig {
            fit: RadialConfig::default(),
            walk_per_sqrt_mm: 0.003,
            covariance_scale: 9.0,
        }
    }
}

impl ColonScaleConfig {
    /// Checks the settings.
    ///
    /// # Errors
    /// A message naming the setting and what is expected.
    pub fn validate(&self) -> Result<(), String> {
        let fit = &self.fit;
        for (name, v) in [
            ("fit.prior_sigma", fit.prior_sigma),
            ("fit.slope_prior_sigma_per_mm", fit.slope_prior_sigma_per_mm),
            ("fit.prior_mean", fit.prior_mean),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "colon_scale {name} = {v}; expected a finite value > 0"
                ));
            }
        }
        if !(self.walk_per_sqrt_mm.is_finite() && self.walk_per_sqrt_mm >= 0.0) {
            return Err(format!(
                "colon_scale walk_per_sqrt_mm = {}; expected a finite value >= 0",
                self.walk_per_sqrt_mm
            ));
        }
        Ok(())
    }
}

/// The mid-line and settings of the scale refinement.
#[derive(Debug, Clone)]
pub struct ColonScale {
    midline: Polyline,
    cfg: ColonScaleConfig,
}

/// A pose refined with the colon's scale.
#[derive(Debug, Clone)]
pub struct ScaledPose {
    /// The pose in the mapped colon, with its covariance (the scale's share included).
    pub estimate: PoseEstimate,
    /// The scale of the colon about its mid-line at the camera, against the map's (1 = as
    /// mapped), and its change along the mid-line (per mm).
    pub scale: ScaleState,
    /// Arc length of the camera's foot on the mid-line, mm.
    pub at_mm: f64,
}

/// The colon's scale at the camera and its change along the mid-line, with their
/// covariance: what a frame's fit found, or the prior of the next frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleState {
    /// Scale `k` (1 = as mapped).
    pub scale: f64,
    /// Its change along the mid-line, per mm.
    pub slope_per_mm: f64,
    /// Covariance of `(scale, slope_per_mm)`.
    pub covariance: Matrix2<f64>,
}

impl ScaleState {
    /// The prior of a frame on its own (`cfg.fit`'s).
    pub fn prior_alone(cfg: &ColonScaleConfig) -> Self {
        ScaleState {
            scale: cfg.fit.prior_mean,
            slope_per_mm: cfg.fit.slope_prior_mean_per_mm,
            covariance: Matrix2::new(
                cfg.fit.prior_sigma.powi(2),
                0.0,
                0.0,
                cfg.fit.slope_prior_sigma_per_mm.powi(2),
            ),
        }
    }
}

/// The scale followed from frame to frame (live): the last frame's estimate and where its
/// camera was along the mid-line.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScaleTrack {
    last: Option<(ScaleState, f64)>,
}

impl ScaleTrack {
    /// The prior for a frame whose camera is `at_mm` along the mid-line: the last estimate
    /// carried there (`k + κ Δs`), its covariance grown by the walk over `|Δs|`, each
    /// variance capped at a frame's own prior; a frame's own prior when nothing is known.
    pub fn prior(&self, at_mm: f64, cfg: &ColonScaleConfig) -> ScaleState {
        let alone = ScaleState::prior_alone(cfg);
        let Some((last, from)) = self.last else {
            return alone;
        };
        let ds = at_mm - from;
        let f = Matrix2::new(1.0, ds, 0.0, 1.0);
        let walk = cfg.walk_per_sqrt_mm.powi(2) * ds.abs();
        let mut covariance = f * last.covariance * f.transpose();
        covariance[(0, 0)] += walk;
        covariance[(1, 1)] += walk / 100.0_f64.powi(2);
        for i in 0..2 {
            covariance[(i, i)] = covariance[(i, i)].min(alone.covariance[(i, i)]);
        }
        ScaleState {
            scale: last.scale + last.slope_per_mm * ds,
            slope_per_mm: last.slope_per_mm,
            covariance,
        }
    }

    /// Takes a frame's estimate (made with [`ScaleTrack::prior`] as its prior, so it already
    /// holds what was known before).
    pub fn update(&mut self, scaled: &ScaledPose, cfg: &ColonScaleConfig) {
        let mut state = scaled.scale;
        state.covariance *= cfg.covariance_scale;
        self.last = Some((state, scaled.at_mm));
    }
}

impl ColonScale {
    /// The scale refinement along the training pass `train_poses`; `None` when the pass has
    /// fewer than two distinct camera positions.
    pub fn new(train_poses: &[Pose], cfg: ColonScaleConfig) -> Option<Self> {
        let centres: Vec<Point3<f64>> = train_poses
            .iter()
            .map(|p| Point3::from(p.translation.vector))
            .collect();
        let midline = Polyline::new(&centres)?.smoothed(MIDLINE_HALF_WINDOW_MM);
        Some(ColonScale { midline, cfg })
    }

    /// The settings.
    pub fn config(&self) -> &ColonScaleConfig {
        &self.cfg
    }

    /// Arc length along the mid-line of the point nearest to `t_wc`'s camera centre, mm.
    pub fn at_mm(&self, t_wc: &Pose) -> f64 {
        self.midline
            .nearest(&Point3::from(t_wc.translation.vector))
            .s_mm
    }

    /// Refines the registered pose `t_wc` (camera-to-world, mm) from its inlier
    /// correspondences (map points, world mm; pixels) with the colon's scale, from `prior`
    /// (`None`: a frame's own, [`ColonScaleConfig::fit`]; the priors on scale and slope are
    /// taken as independent); `None` when the refinement fails (too few points, singular
    /// normal equations), when the rigid pose stands.
    pub fn refine(
        &self,
        t_wc: &Pose,
        points: &[Point3<f64>],
        pixels: &[Point2<f64>],
        camera: &Camera,
        prior: Option<&ScaleState>,
    ) -> Option<ScaledPose> {
        let at = self.at_mm(t_wc);
        let feet: Vec<Foot> = points
            .iter()
            .map(|p| {
                let n = self.midline.nearest(p);
                Foot {
                    point: n.point,
                    along_mm: n.s_mm - at,
                }
            })
            .collect();
        let mut cfg = self.cfg.fit;
        if let Some(p) = prior {
            cfg.prior_mean = p.scale;
            cfg.prior_sigma = p.covariance[(0, 0)].sqrt();
            cfg.slope_prior_mean_per_mm = p.slope_per_mm;
            cfg.slope_prior_sigma_per_mm = p.covariance[(1, 1)].sqrt();
        }
        let fit = refine_radial(t_wc, points, &feet, pixels, camera, &cfg).ok()?;
        let camera_foot = self
            .midline
            .nearest(&Point3::from(fit.t_wc_scaled.translation.vector))
            .point;
        Some(ScaledPose {
            estimate: fit.anatomical(&camera_foot),
            scale: ScaleState {
                scale: fit.scale,
                slope_per_mm: fit.slope_per_mm,
                covariance: fit.covariance.fixed_view::<2, 2>(6, 6).into_owned(),
            },
            at_mm: at,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_followed_scale_is_carried_along_and_grows_uncertain_with_distance() {
        let cfg = ColonScaleConfig::default();
        let mut track = ScaleTrack::default();
        assert_eq!(track.prior(100.0, &cfg), ScaleState::prior_alone(&cfg));
        let estimate = |scale, at_mm| ScaledPose {
            estimate: PoseEstimate {
                t_wc: Pose::identity(),
                cost: 0.0,
                rms_px: 0.5,
                inliers: Vec::new(),
                inlier_count: 0,
                iterations: 1,
                converged: true,
                covariance: nalgebra::Matrix6::identity(),
            },
            scale: ScaleState {
                scale,
                slope_per_mm: 0.001,
                covariance: Matrix2::new(1e-6, 0.0, 0.0, 1e-10),
            },
            at_mm,
        };
        track.update(&estimate(1.1, 100.0), &cfg);
        // 20 mm further: carried along its slope, variance inflated and grown by the walk.
        let p = track.prior(120.0, &cfg);
        assert!((p.scale - 1.12).abs() < 1e-12, "{}", p.scale);
        let var = p.covariance[(0, 0)];
        let inflated = cfg.covariance_scale * (1e-6 + 400.0 * 1e-10);
        let walk = cfg.walk_per_sqrt_mm.powi(2) * 20.0;
        assert!((var - (inflated + walk)).abs() < 1e-12, "{var}");
        // Far away the prior is a frame's own width again, never wider.
        let far = track.prior(1.0e6, &cfg);
        assert_eq!(far.covariance[(0, 0)], cfg.fit.prior_sigma.powi(2));
    }
}
