//! Registration of an image to the map: its camera pose from 2D–3D matches in one call —
//! prior → Gauss-Newton, a RANSAC P3P restart when the prior is poor, then the validity check.
//!
//! 1. Too few correspondences: `init_only` (or `rejected`) right away.
//! 2. Gauss-Newton ([`refine_pose`]) from the prior (the zone median).
//! 3. If that failed, did not converge, kept less than `ransac_below_inlier_ratio` of the
//!    correspondences as inliers, or its RMS is above the validity limit — or when
//!    `always_ransac` is set — [`ransac_pnp`](crate::ransac_pnp) runs (with the refinement's
//!    [`RefineConfig::wall_motion_mm`]) and its pose seeds a second Gauss-Newton.
//!    The better of the two (more inliers, then lower robust cost) is kept.
//! 4. [`ValidityConfig::check`] classifies the result; on a local failure with
//!    `fallback_to_prior` the prior is reported as `init_only`.

use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::camera::Camera;
use crate::pnp::{RansacConfig, RansacError, ransac_pnp_tolerant};
use crate::pose::Pose;
use crate::refine_pose::{PoseEstimate, RefineConfig, refine_pose};
use crate::validity::{Reason, Status, ValidityConfig, Verdict};

/// Settings of [`localize_pose`]. [`Default`], [`RegistrationConfig::new`] and a missing
/// field when deserialising all give the same values (RANSAC restart below 50 % inliers).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RegistrationConfig {
    /// Gauss-Newton settings (both starts).
    pub refine: RefineConfig,
    /// RANSAC settings for the restart.
    pub ransac: RansacConfig,
    /// Validity thresholds.
    pub validity: ValidityConfig,
    /// Restart with RANSAC when the refinement from the prior keeps fewer than this fraction
    /// of the correspondences as inliers (dimensionless).
    pub ransac_below_inlier_ratio: f64,
    /// Always run RANSAC as well and keep the better result.
    pub always_ransac: bool,
}

impl Default for RegistrationConfig {
    /// Default Gauss-Newton, RANSAC and validity settings, a RANSAC restart below 50 %
    /// inliers, no unconditional RANSAC.
    fn default() -> Self {
        Self {
            refine: RefineConfig::default(),
            ransac: RansacConfig::default(),
            validity: ValidityConfig::default(),
            ransac_below_inlier_ratio: 0.5,
            always_ransac: false,
        }
    }
}

impl RegistrationConfig {
    /// The defaults ([`Default`]): a RANSAC restart below 50 % inliers.
    pub fn new() -> Self {
        Self::default()
    }
}

/// The outcome of [`localize_pose`].
#[derive(Debug, Clone, PartialEq)]
pub struct Localization {
    /// `refined`, `init_only` or `rejected`, and why.
    pub verdict: Verdict,
    /// The pose to report (`T_wc`, mm): the refined pose when `refined`, the prior when
    /// `init_only`, `None` when `rejected`.
    pub t_wc: Option<Pose>,
    /// The best refinement, when one succeeded (also for `init_only`/`rejected`, for logs).
    pub estimate: Option<PoseEstimate>,
    /// Whether the RANSAC restart ran.
    pub used_ransac: bool,
}

/// Input errors of [`localize_pose`] (geometric failures are verdicts, not errors).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RegistrationError {
    /// `points_world` and `pixels` differ in length.
    #[error("{points} map points but {pixels} pixels")]
    LengthMismatch {
        /// Number of map points.
        points: usize,
        /// Number of pixels.
        pixels: usize,
    },
    /// A map point or pixel had a NaN or infinite component.
    #[error("correspondence {index} has a non-finite point or pixel")]
    NonFinite {
        /// Index of the correspondence.
        index: usize,
    },
    /// The prior pose had a NaN or infinite component.
    #[error("the prior pose is not finite")]
    NonFinitePrior,
}

fn better(a: &PoseEstimate, b: &PoseEstimate) -> bool {
    a.inlier_count > b.inlier_count || (a.inlier_count == b.inlier_count && a.cost < b.cost)
}

/// Localizes a camera from the prior `T_wc` (mm), map points (world, mm) and their pixels.
///
/// # Errors
/// Only for invalid input (length mismatch, NaN/∞); every geometric failure is returned as a
/// `init_only` or `rejected` [`Verdict`] with its [`Reason`].
pub fn localize_pose(
    prior: &Pose,
    points_world: &[Point3<f64>],
    pixels: &[Point2<f64>],
    camera: &Camera,
    cfg: &RegistrationConfig,
) -> Result<Localization, RegistrationError> {
    if points_world.len() != pixels.len() {
        return Err(RegistrationError::LengthMismatch {
            points: points_world.len(),
            pixels: pixels.len(),
        });
    }
    if !(prior.translation.vector.iter().all(|v| v.is_finite())
        && prior.rotation.coords.iter().all(|v| v.is_finite()))
    {
        return Err(RegistrationError::NonFinitePrior);
    }
    for (index, (p, px)) in points_world.iter().zip(pixels).enumerate() {
        if !(p.coords.iter().all(|v| v.is_finite()) && px.coords.iter().all(|v| v.is_finite())) {
            return Err(RegistrationError::NonFinite { index });
        }
    }
    let n = points_world.len();
    let v = &cfg.validity;
    let report = |verdict: Verdict, estimate: Option<PoseEstimate>, used_ransac: bool| {
        let t_wc = match verdict.status {
            Status::Refined => estimate.as_ref().map(|e| e.t_wc),
            Status::InitOnly => Some(*prior),
            Status::Rejected => None,
        };
        Localization {
            verdict,
            t_wc,
            estimate,
            used_ransac,
        }
    };
    if n < v.min_correspondences.max(3) {
        let verdict = v.local_failure(Reason::TooFewCorrespondences {
            count: n,
            min: v.min_correspondences.max(3),
        });
        return Ok(report(verdict, None, false));
    }

    let from_prior = refine_pose(prior, points_world, pixels, camera, &cfg.refine);
    let prior_good = match &from_prior {
        Ok(e) => {
            e.converged
                && e.inlier_count as f64 >= cfg.ransac_below_inlier_ratio * n as f64
                && e.rms_px <= v.max_rms_px
        }
        Err(_) => false,
    };
    let mut best: Option<PoseEstimate> = from_prior.as_ref().ok().cloned();
    let mut last_error: Option<String> = from_prior.as_ref().err().map(|e| e.to_string());
    let mut used_ransac = false;
    // RANSAC's best inlier count when it found no consensus.
    let mut no_consensus: Option<(usize, usize)> = None;
    if !prior_good || cfg.always_ransac {
        used_ransac = true;
        match ransac_pnp_tolerant(
            points_world,
            pixels,
            camera,
            &cfg.ransac,
            cfg.refine.wall_motion_mm,
        ) {
            Ok(r) => match refine_pose(&r.t_wc, points_world, pixels, camera, &cfg.refine) {
                Ok(e) => {
                    if best.as_ref().is_none_or(|b| better(&e, b)) {
                        best = Some(e);
                    }
                }
                Err(e) => last_error = Some(e.to_string()),
            },
            Err(e) => {
                if let RansacError::NoConsensus {
                    best_inliers,
                    min_inliers,
                } = e
                {
                    no_consensus = Some((best_inliers, min_inliers));
                }
                if best.is_none() {
                    last_error = Some(e.to_string());
                }
            }
        }
    }
    let Some(estimate) = best else {
        // No pose at all. When RANSAC found no pose that enough correspondences agree with
        // and the map points are spread in space, the matches are mostly wrong: too few
        // inliers. Collinear or coincident points leave the pose unobservable: degenerate.
        let reason = match no_consensus {
            Some((count, min)) if !collinear(points_world) => Reason::TooFewInliers { count, min },
            _ => Reason::DegenerateGeometry {
                detail: last_error.unwrap_or_else(|| "no pose found".to_owned()),
            },
        };
        return Ok(report(v.local_failure(reason), None, used_ransac));
    };
    let verdict = v.check(&estimate, prior, n);
    Ok(report(verdict, Some(estimate), used_ransac))
}

/// Whether `points` lie (nearly) on one line or at one point: the second eigenvalue of their
/// scatter matrix below 1e-9 of the first (or no spread at all).
fn collinear(points: &[Point3<f64>]) -> bool {
    if points.len() < 3 {
        return true;
    }
    let mean = points
        .iter()
        .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
        / points.len() as f64;
    let scatter = points.iter().fold(nalgebra::Matrix3::zeros(), |a, p| {
        let d = p.coords - mean;
        a + d * d.transpose()
    });
    let mut ev: Vec<f64> = scatter.symmetric_eigenvalues().iter().copied().collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    !(ev[0] > 0.0 && ev[1] > 1e-9 * ev[0])
}
