//! Seeded RANSAC around [`p3p`] with MSAC scoring and an adaptive iteration count.
//!
//! Each iteration draws three distinct correspondences (ChaCha8 with `cfg.seed`: the same
//! input and seed give the same result), skips near-collinear samples, solves P3P (up to four
//! poses) and scores every pose with the MSAC truncated quadratic `Σ min(e², τ²)` — `e` the
//! reprojection error in ideal-pinhole pixels, `τ = threshold_px`, points behind the camera
//! count as `τ²`. Scoring stops early once a pose cannot beat the best. The iteration count
//! adapts to the best inlier ratio `w`: `N = ln(1 − confidence) / ln(1 − w³)`, clamped to
//! `[min_iterations, max_iterations]`.

use nalgebra::{Matrix3, Point2, Point3, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::p3p::p3p;
use crate::camera::Camera;
use crate::pose::Pose;
use crate::reprojection;

/// Settings of [`ransac_pnp`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RansacConfig {
    /// Inlier threshold `τ` on the reprojection error, pixels.
    pub threshold_px: f64,
    /// Probability of drawing at least one all-inlier sample, in `(0, 1)`.
    pub confidence: f64,
    /// Minimum number of iterations.
    pub min_iterations: usize,
    /// Maximum number of iterations.
    pub max_iterations: usize,
    /// Random seed of the sampler.
    pub seed: u64,
    /// A consensus needs at least this many inliers.
    pub min_inliers: usize,
}

impl Default for RansacConfig {
    fn default() -> Self {
        Self {
            threshold_px: 4.0,
            confidence: 0.999,
            min_iterations: 20,
            max_iterations: 2000,
            seed: 0,
            min_inliers: 6,
        }
    }
}

/// The best RANSAC hypothesis.
#[derive(Debug, Clone, PartialEq)]
pub struct RansacPose {
    /// Camera-to-world pose `T_wc` of the best sample, mm (not yet refined).
    pub t_wc: Pose,
    /// Per correspondence: reprojection error below the threshold at `t_wc`.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// Iterations (samples) drawn.
    pub iterations: usize,
    /// MSAC score of `t_wc`, px² (lower is better).
    pub score_px2: f64,
}

/// Why RANSAC found no pose.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RansacError {
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
    /// Fewer than the 4 correspondences RANSAC needs (3 to sample, 1 to verify).
    #[error("too few correspondences: {usable} usable, at least 4 needed")]
    TooFewCorrespondences {
        /// Correspondences with an invertible pixel.
        usable: usize,
    },
    /// No hypothesis reached the minimum inlier count (outliers only, or degenerate points).
    #[error("no consensus: best hypothesis has {best_inliers} inliers, {min_inliers} needed")]
    NoConsensus {
        /// Inliers of the best hypothesis found (0 if none).
        best_inliers: usize,
        /// The configured minimum.
        min_inliers: usize,
    },
}

/// Estimates `T_wc` (mm) from map points (world, mm) and their pixels without a prior.
///
/// # Errors
/// [`RansacError::LengthMismatch`] / [`RansacError::NonFinite`] for bad input,
/// [`RansacError::TooFewCorrespondences`] below 4 usable correspondences, and
/// [`RansacError::NoConsensus`] when no pose gathers `cfg.min_inliers` inliers.
pub fn ransac_pnp(
    points_world: &[Point3<f64>],
    pixels: &[Point2<f64>],
    camera: &Camera,
    cfg: &RansacConfig,
) -> Result<RansacPose, RansacError> {
    ransac_pnp_tolerant(points_world, pixels, camera, cfg, 0.0)
}

/// [`ransac_pnp`] for a wall that may have moved by `wall_motion_mm` (standard deviation, mm)
/// since it was mapped: each reprojection error is divided by
/// [`reprojection::wall_motion_scale`] at the point's depth in the hypothesis before the
/// MSAC score and the inlier test ([`crate::RefineConfig::wall_motion_mm`]). 0 = [`ransac_pnp`].
///
/// # Errors
/// As [`ransac_pnp`].
pub fn ransac_pnp_tolerant(
    points_world: &[Point3<f64>],
    pixels: &[Point2<f64>],
    camera: &Camera,
    cfg: &RansacConfig,
    wall_motion_mm: f64,
) -> Result<RansacPose, RansacError> {
    if points_world.len() != pixels.len() {
        return Err(RansacError::LengthMismatch {
            points: points_world.len(),
            pixels: pixels.len(),
        });
    }
    let mut normalized = Vec::with_capacity(pixels.len());
    let mut usable = Vec::with_capacity(pixels.len());
    for (index, (p, px)) in points_world.iter().zip(pixels).enumerate() {
        if !(p.coords.iter().all(|v| v.is_finite()) && px.coords.iter().all(|v| v.is_finite())) {
            return Err(RansacError::NonFinite { index });
        }
        match camera.normalized(px) {
            Some(xn) => {
                normalized.push(xn);
                usable.push(index);
            }
            None => normalized.push(Vector2::new(f64::NAN, f64::NAN)),
        }
    }
    let m = usable.len();
    if m < 4 {
        return Err(RansacError::TooFewCorrespondences { usable: m });
    }

    let (fx, fy) = (camera.fx, camera.fy);
    let tau2 = cfg.threshold_px * cfg.threshold_px;
    let min_depth = 1e-6;
    // Squared reprojection error of correspondence `i`, divided by its tolerance.
    let error2 = |r_cw: &Matrix3<f64>, t_cw: &Vector3<f64>, i: usize| -> Option<f64> {
        let r = reprojection::residual(
            r_cw,
            t_cw,
            &points_world[i],
            &normalized[i],
            fx,
            fy,
            min_depth,
        )?;
        let e2 = r.norm_squared();
        if wall_motion_mm > 0.0 {
            let z = r_cw.row(2).dot(&points_world[i].coords.transpose()) + t_cw.z;
            let s = reprojection::wall_motion_scale(fx, z, wall_motion_mm);
            Some(e2 / (s * s))
        } else {
            Some(e2)
        }
    };
    // MSAC score of a pose, abandoning once it exceeds `limit`.
    let score = |t_wc: &Pose, limit: f64| -> f64 {
        let r_cw: Matrix3<f64> = t_wc.rotation.to_rotation_matrix().into_inner().transpose();
        let t_cw = -(r_cw * t_wc.translation.vector);
        let mut s = 0.0;
        for &i in &usable {
            let e2 = error2(&r_cw, &t_cw, i).map_or(tau2, |e2| e2.min(tau2));
            s += e2;
            if s > limit {
                return f64::INFINITY;
            }
        }
        s
    };
    let count_inliers = |t_wc: &Pose| -> usize {
        let r_cw: Matrix3<f64> = t_wc.rotation.to_rotation_matrix().into_inner().transpose();
        let t_cw = -(r_cw * t_wc.translation.vector);
        usable
            .iter()
            .filter(|&&i| error2(&r_cw, &t_cw, i).is_some_and(|e2| e2 < tau2))
            .count()
    };

    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut best: Option<(f64, Pose)> = None;
    let mut best_inliers = 0usize;
    let mut needed = cfg.max_iterations.max(cfg.min_iterations);
    let mut iterations = 0;
    let log_fail = (1.0 - cfg.confidence.clamp(1e-9, 1.0 - 1e-12)).ln();
    while iterations
        < needed
            .max(cfg.min_iterations)
            .min(cfg.max_iterations.max(1))
    {
        iterations += 1;
        let a = rng.random_range(0..m);
        let mut b = rng.random_range(0..m - 1);
        if b >= a {
            b += 1;
        }
        let mut c = rng.random_range(0..m - 2);
        for lo in [a.min(b), a.max(b)] {
            if c >= lo {
                c += 1;
            }
        }
        let idx = [usable[a], usable[b], usable[c]];
        let pts = idx.map(|i| points_world[i]);
        // Skip near-collinear samples (their P3P is ill-conditioned).
        let (e1, e2) = (pts[1] - pts[0], pts[2] - pts[0]);
        let longest = e1
            .norm_squared()
            .max(e2.norm_squared())
            .max((pts[2] - pts[1]).norm_squared());
        if e1.cross(&e2).norm() < 1e-3 * longest {
            continue;
        }
        let bearings = idx.map(|i| Vector3::new(normalized[i].x, normalized[i].y, 1.0).normalize());
        for t_wc in p3p(&pts, &bearings).iter() {
            let limit = best.map_or(f64::INFINITY, |b| b.0);
            let s = score(&t_wc, limit);
            if s < limit {
                best = Some((s, t_wc));
                best_inliers = count_inliers(&t_wc);
                let w = best_inliers as f64 / m as f64;
                let p_all = w * w * w;
                needed = if p_all >= 1.0 - 1e-12 {
                    cfg.min_iterations
                } else if p_all <= 0.0 {
                    cfg.max_iterations
                } else {
                    let n = (log_fail / (1.0 - p_all).ln()).ceil();
                    if n.is_finite() {
                        (n as usize).min(cfg.max_iterations)
                    } else {
                        cfg.max_iterations
                    }
                };
            }
        }
    }
    let Some((score_px2, t_wc)) = best else {
        return Err(RansacError::NoConsensus {
            best_inliers: 0,
            min_inliers: cfg.min_inliers,
        });
    };
    if best_inliers < cfg.min_inliers.max(4) {
        return Err(RansacError::NoConsensus {
            best_inliers,
            min_inliers: cfg.min_inliers,
        });
    }
    let r_cw: Matrix3<f64> = t_wc.rotation.to_rotation_matrix().into_inner().transpose();
    let t_cw = -(r_cw * t_wc.translation.vector);
    let inliers: Vec<bool> = (0..points_world.len())
        .map(|i| !normalized[i].x.is_nan() && error2(&r_cw, &t_cw, i).is_some_and(|e2| e2 < tau2))
        .collect();
    Ok(RansacPose {
        t_wc,
        inlier_count: best_inliers,
        inliers,
        iterations,
        score_px2,
    })
}
