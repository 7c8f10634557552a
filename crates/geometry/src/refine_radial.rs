//! Pose refinement with the colon's scale: the map scaled radially about the colon's mid-line
//! (insufflation between the map's pass and the frame's).
//!
//! # Model
//!
//! The lumen of a colon that is insufflated more (or less) than when it was mapped is the
//! mapped lumen scaled about its mid-line. Each map point `X` (world, mm) comes with its
//! *foot* `f` — its nearest point on the mid-line (in practice the mapping pass's camera
//! path) — and is seen at
//!
//! ```text
//! X' = f + k · (X − f),    pixel = camera.project(T_wc⁻¹ · X')
//! ```
//!
//! with one scale `k` (dimensionless, 1 = as mapped) at the camera: insufflation varies over
//! hundreds of millimetres of colon, a view spans tens.
//!
//! The scale may also change along the mid-line, `k + κ · s` with `s` the foot's arc length
//! from the camera's foot (a colon wider ahead than here). Gaussian priors `k ~ N(k₀, σ_k²)`
//! (`k₀` = 1 for a frame on its own, the scale of the frames before it when localizing live)
//! and `κ ~ N(κ₀, σ_κ²)` keep both where the view cannot tell them from a camera moved along the
//! lumen (a straight tube seen down its axis): their cost `½ ((k − k₀)/σ_k)² + ½ ((κ − κ₀)/σ_κ)²` is
//! added to the robust cost (px²).
//!
//! The parameters are the left perturbation `δ = [ρ; φ]` of `T_wc` (as in
//! [`mod@crate::refine_pose`]), `k` and `κ`; the Jacobian of a residual is
//! `[A · [−I, [X']×],  A · (X − f),  A · (X − f) · s]`, `A = ∂r/∂p_w` at `X'`.
//!
//! # The anatomical pose
//!
//! `T_wc` above is the camera in the *scaled* colon. The camera rode through that colon too,
//! so its position in the mapped colon is carried back through the inverse scale about its
//! own foot `f_c`: `c = f_c + (c' − f_c) / k`; the orientation is kept (a radial scale turns
//! nothing). [`RadialFit::anatomical`] returns that pose with its covariance, the scale's
//! uncertainty included.
//!
//! # Robustness
//!
//! The inputs are the inliers of a rigid registration; the iterations use a robust kernel
//! (Cauchy, 1 px by default) with step halving, so the cost never rises.

use nalgebra::{Matrix3, Matrix6, Point2, Point3, SMatrix, SVector, Vector2};
use serde::{Deserialize, Serialize};

use crate::camera::Camera;
use crate::pose::Pose;
use crate::refine_pose::{PoseEstimate, RefineError, RobustKernel};
use crate::{reprojection, se3, so3};

/// The 8×8 covariance of `[δ; k; κ]`.
pub type Matrix8 = SMatrix<f64, 8, 8>;
type Vector8 = SVector<f64, 8>;

/// A map point's foot on the mid-line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Foot {
    /// The nearest mid-line point (world, mm).
    pub point: Point3<f64>,
    /// Its arc length along the mid-line from the camera's own foot, mm (either sign).
    pub along_mm: f64,
}

/// Settings of [`refine_radial`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RadialConfig {
    /// Robust kernel on the reprojection error, pixels.
    pub kernel: RobustKernel,
    /// Mean of the Gaussian prior on the scale `k`, and where the iterations start
    /// (dimensionless; 1 = as mapped).
    pub prior_mean: f64,
    /// Standard deviation of that prior (dimensionless).
    pub prior_sigma: f64,
    /// Mean of the Gaussian prior on the scale's change along the mid-line, per mm.
    pub slope_prior_mean_per_mm: f64,
    /// Standard deviation of that prior, per mm.
    pub slope_prior_sigma_per_mm: f64,
    /// Maximum number of Gauss-Newton iterations.
    pub max_iterations: usize,
    /// Converged when a step lowers the cost by less than this fraction of it.
    pub min_relative_decrease: f64,
    /// A correspondence is an inlier when its final reprojection error is below this, pixels.
    pub inlier_threshold_px: f64,
    /// Points closer than this to the image plane (depth, mm) count as behind the camera.
    pub min_depth_mm: f64,
}

impl Default for RadialConfig {
    fn default() -> Self {
        Self {
            kernel: RobustKernel::Cauchy { scale_px: 1.0 },
            prior_mean: 1.0,
            prior_sigma: 0.15,
            slope_prior_mean_per_mm: 0.0,
            slope_prior_sigma_per_mm: 0.002,
            max_iterations: 30,
            min_relative_decrease: 1e-9,
            inlier_threshold_px: 4.0,
            min_depth_mm: 1e-3,
        }
    }
}

/// The result of [`refine_radial`].
#[derive(Debug, Clone, PartialEq)]
pub struct RadialFit {
    /// The camera in the scaled colon (`T_wc`, mm).
    pub t_wc_scaled: Pose,
    /// The scale `k` of the colon about its mid-line (1 = as mapped).
    pub scale: f64,
    /// Standard deviation of `scale` (from the covariance below).
    pub scale_sigma: f64,
    /// The scale's change along the mid-line, per mm (ahead of the camera's foot: `k +
    /// slope · along_mm`).
    pub slope_per_mm: f64,
    /// Covariance of `[δ; k; slope]` (left perturbation of `t_wc_scaled`, the scale, its
    /// slope):
    /// `σ² (JᵀWJ + prior)⁻¹` with `σ²` the weighted residual variance.
    pub covariance: Matrix8,
    /// Final robust cost, prior included, px².
    pub cost: f64,
    /// Root-mean-square reprojection error over the inliers (true camera model), pixels.
    pub rms_px: f64,
    /// Per correspondence: in front of the camera and reprojected within the threshold.
    pub inliers: Vec<bool>,
    /// Number of `true` entries in `inliers`.
    pub inlier_count: usize,
    /// Gauss-Newton iterations performed.
    pub iterations: usize,
}

impl RadialFit {
    /// The pose in the mapped colon (see the module docs) as a [`PoseEstimate`] whose
    /// covariance is that of the anatomical pose's left perturbation (the scale's share
    /// included); `camera_foot` is the foot of the camera centre on the mid-line (world, mm).
    pub fn anatomical(&self, camera_foot: &Point3<f64>) -> PoseEstimate {
        let k = self.scale;
        let c_s = self.t_wc_scaled.translation.vector;
        let f = camera_foot.coords;
        let c = f + (c_s - f) / k;
        let mut t_wc = self.t_wc_scaled;
        t_wc.translation.vector = c;
        // θ = [ρ; φ; k] → the anatomical perturbation [ρ'; φ]: Δc = (Δc' − (c − f) Δk) / k,
        // Δc' = ρ − [c']× φ, and ρ' = Δc + [c]× φ.
        let mut t = SMatrix::<f64, 6, 8>::zeros();
        t.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() / k));
        t.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(so3::hat(&c) - so3::hat(&c_s) / k));
        t.fixed_view_mut::<3, 1>(0, 6).copy_from(&(-(c - f) / k));
        t.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&Matrix3::identity());
        let covariance: Matrix6<f64> = t * self.covariance * t.transpose();
        PoseEstimate {
            t_wc,
            cost: self.cost,
            rms_px: self.rms_px,
            inliers: self.inliers.clone(),
            inlier_count: self.inlier_count,
            iterations: self.iterations,
            converged: true,
            covariance,
        }
    }
}

struct Problem<'a> {
    points: &'a [Point3<f64>],
    feet: &'a [Foot],
    normalized: &'a [Vector2<f64>],
    fx: f64,
    fy: f64,
    cfg: &'a RadialConfig,
}

impl Problem<'_> {
    /// The priors' cost, px².
    fn prior_cost(&self, k: f64, slope: f64) -> f64 {
        0.5 * ((k - self.cfg.prior_mean) / self.cfg.prior_sigma).powi(2)
            + 0.5
                * ((slope - self.cfg.slope_prior_mean_per_mm) / self.cfg.slope_prior_sigma_per_mm)
                    .powi(2)
    }
}

struct Linearization {
    cost: f64,
    h: Matrix8,
    g: Vector8,
    used: usize,
}

impl Problem<'_> {
    fn scaled(&self, i: usize, k: f64, slope: f64) -> Point3<f64> {
        let f = self.feet[i];
        f.point + (self.points[i] - f.point) * (k + slope * f.along_mm)
    }

    fn linearize(&self, t_wc: &Pose, k: f64, slope: f64, kernel: &RobustKernel) -> Linearization {
        let r_cw = t_wc.rotation.to_rotation_matrix().into_inner().transpose();
        let t_cw = -(r_cw * t_wc.translation.vector);
        let mut h = Matrix8::zeros();
        let mut g = Vector8::zeros();
        let mut cost = 0.0;
        let mut used = 0;
        for (i, xn) in self.normalized.iter().enumerate() {
            if xn.x.is_nan() {
                continue;
            }
            let x = self.scaled(i, k, slope);
            let Some(t) = reprojection::term(
                &r_cw,
                &t_cw,
                &x,
                xn,
                self.fx,
                self.fy,
                self.cfg.min_depth_mm,
            ) else {
                cost += kernel.cost(1.0e4);
                continue;
            };
            let e = t.residual.norm();
            let w = kernel.weight(e);
            cost += kernel.cost(e);
            let d_k = t.d_point * (self.points[i] - self.feet[i].point);
            let mut j = SMatrix::<f64, 2, 8>::zeros();
            j.fixed_view_mut::<2, 6>(0, 0).copy_from(&t.d_pose);
            j.fixed_view_mut::<2, 1>(0, 6).copy_from(&d_k);
            j.fixed_view_mut::<2, 1>(0, 7)
                .copy_from(&(d_k * self.feet[i].along_mm));
            h += j.transpose() * j * w;
            g += j.transpose() * t.residual * w;
            used += 1;
        }
        let s2 = self.cfg.prior_sigma * self.cfg.prior_sigma;
        let t2 = self.cfg.slope_prior_sigma_per_mm * self.cfg.slope_prior_sigma_per_mm;
        cost += self.prior_cost(k, slope);
        h[(6, 6)] += 1.0 / s2;
        g[6] += (k - self.cfg.prior_mean) / s2;
        h[(7, 7)] += 1.0 / t2;
        g[7] += (slope - self.cfg.slope_prior_mean_per_mm) / t2;
        Linearization { cost, h, g, used }
    }
}

/// Refines `prior` (`T_wc`, mm) and a radial scale of the map about its mid-line so that the
/// map points `points` (world, mm), each with its foot `feet` on the mid-line, reproject onto
/// `pixels`: robust Gauss-Newton from `k = 1` (see the module docs).
///
/// # Errors
/// [`RefineError::LengthMismatch`] when the three slices differ in length,
/// [`RefineError::NonFinite`] / [`RefineError::NonFinitePrior`] for bad input,
/// [`RefineError::TooFewCorrespondences`] with fewer than 4 usable correspondences,
/// [`RefineError::Degenerate`] when the normal equations cannot be solved.
pub fn refine_radial(
    prior: &Pose,
    points: &[Point3<f64>],
    feet: &[Foot],
    pixels: &[Point2<f64>],
    camera: &Camera,
    cfg: &RadialConfig,
) -> Result<RadialFit, RefineError> {
    if feet.len() != points.len() {
        return Err(RefineError::LengthMismatch {
            points: points.len().min(feet.len()),
            pixels: pixels.len(),
        });
    }
    if let Some(index) = feet
        .iter()
        .position(|f| !(f.point.coords.iter().all(|v| v.is_finite()) && f.along_mm.is_finite()))
    {
        return Err(RefineError::NonFinite { index });
    }
    let normalized = crate::refine_pose::checked_observations(prior, points, pixels, camera)?;
    let problem = Problem {
        points,
        feet,
        normalized: &normalized,
        fx: camera.fx,
        fy: camera.fy,
        cfg,
    };
    let (mut t_wc, mut k, mut slope) = (*prior, cfg.prior_mean, cfg.slope_prior_mean_per_mm);
    let mut lin = problem.linearize(&t_wc, k, slope, &cfg.kernel);
    if lin.used < 4 {
        return Err(RefineError::TooFewCorrespondences { usable: lin.used });
    }
    let mut iterations = 0;
    while iterations < cfg.max_iterations {
        iterations += 1;
        let Some(chol) = lin.h.cholesky() else {
            break;
        };
        let delta = -chol.solve(&lin.g);
        if !delta.iter().all(|v| v.is_finite()) {
            break;
        }
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..12 {
            let step = delta * alpha;
            let pose_step = step.fixed_rows::<6>(0).into_owned();
            let candidate = se3::left_update(&t_wc, &pose_step);
            let (cand_k, cand_slope) = (k + step[6], slope + step[7]);
            let cand = problem.linearize(&candidate, cand_k, cand_slope, &cfg.kernel);
            if cand.used >= 4 && cand.cost <= lin.cost && cand_k > 0.0 {
                accepted = Some((candidate, cand_k, cand_slope, cand));
                break;
            }
            alpha *= 0.5;
        }
        let Some((candidate, cand_k, cand_slope, cand)) = accepted else {
            break;
        };
        let decrease = lin.cost - cand.cost;
        (t_wc, k, slope, lin) = (candidate, cand_k, cand_slope, cand);
        if decrease <= cfg.min_relative_decrease * lin.cost {
            break;
        }
    }

    // Inliers, RMS and covariance at the solution, with the true camera model.
    let mut inliers = Vec::with_capacity(points.len());
    let mut sum_sq = 0.0;
    for (i, px) in pixels.iter().enumerate() {
        let p_c = t_wc.inverse_transform_point(&problem.scaled(i, k, slope));
        let e = (p_c.z > cfg.min_depth_mm)
            .then(|| camera.project(&p_c).map(|q| (q - px).norm()))
            .flatten();
        let inlier = e.is_some_and(|e| e < cfg.inlier_threshold_px);
        if let (true, Some(e)) = (inlier, e) {
            sum_sq += e * e;
        }
        inliers.push(inlier);
    }
    let inlier_count = inliers.iter().filter(|&&b| b).count();
    let rms_px = if inlier_count > 0 {
        (sum_sq / inlier_count as f64).sqrt()
    } else {
        f64::NAN
    };
    let dof = (2 * lin.used).saturating_sub(8).max(1) as f64;
    let data_cost = lin.cost - problem.prior_cost(k, slope);
    let sigma2 = 2.0 * data_cost.max(0.0) / dof;
    let Some(inverse) = lin.h.try_inverse() else {
        return Err(RefineError::Degenerate {
            min_eigenvalue: 0.0,
        });
    };
    let covariance = inverse * sigma2;
    Ok(RadialFit {
        t_wc_scaled: t_wc,
        scale: k,
        scale_sigma: covariance[(6, 6)].max(0.0).sqrt(),
        slope_per_mm: slope,
        covariance,
        cost: lin.cost,
        rms_px,
        inliers,
        inlier_count,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    /// Camera, true anatomical pose, map points, their feet and the pixels they are seen at.
    type Scene = (Camera, Pose, Vec<Point3<f64>>, Vec<Foot>, Vec<Point2<f64>>);

    /// A tube of radius 15 mm along +z, seen from inside, 3 mm off its axis.
    fn scene(k: f64) -> Scene {
        let camera = Camera::from_hfov(320, 240, 80.0);
        let anatomical = crate::pose::pose_from_parts(
            Vector3::new(3.0, -1.0, 0.0),
            UnitQuaternion::from_euler_angles(0.05, -0.08, 0.02),
        );
        let mut points = Vec::new();
        let mut feet = Vec::new();
        for i in 0..120 {
            let z = 15.0 + (i % 12) as f64 * 5.0;
            let theta = i as f64 * 2.399;
            let foot = Point3::new(0.0, 0.0, z);
            points.push(foot + Vector3::new(theta.cos(), theta.sin(), 0.0) * 15.0);
            feet.push(Foot {
                point: foot,
                along_mm: z,
            });
        }
        // The colon scaled by k about its axis, the camera with it.
        let mut scaled_camera = anatomical;
        scaled_camera.translation.vector.x *= k;
        scaled_camera.translation.vector.y *= k;
        let pixels = points
            .iter()
            .zip(&feet)
            .filter_map(|(p, f)| {
                let x = f.point + (p - f.point) * k;
                camera.project(&scaled_camera.inverse_transform_point(&x))
            })
            .collect();
        (camera, anatomical, points, feet, pixels)
    }

    #[test]
    fn a_scaled_colon_gives_back_its_scale_and_the_anatomical_pose() {
        for k in [0.85, 1.0, 1.15] {
            let (camera, truth, points, feet, pixels) = scene(k);
            assert_eq!(pixels.len(), points.len());
            // A prior 2 mm and a few degrees off.
            let mut prior = truth;
            prior.translation.vector += Vector3::new(1.0, 1.0, -1.5);
            prior.rotation = UnitQuaternion::from_euler_angles(0.02, 0.03, 0.0) * prior.rotation;
            // Wide priors: exact data, nothing to pull k towards 1.
            let cfg = RadialConfig {
                prior_sigma: 10.0,
                slope_prior_sigma_per_mm: 1.0,
                ..RadialConfig::default()
            };
            let fit = refine_radial(&prior, &points, &feet, &pixels, &camera, &cfg).unwrap();
            assert!((fit.scale - k).abs() < 1e-5, "k {k}: fitted {}", fit.scale);
            assert!(fit.slope_per_mm.abs() < 1e-4, "slope {}", fit.slope_per_mm);
            let foot = Point3::new(0.0, 0.0, fit.t_wc_scaled.translation.z);
            let anatomical = fit.anatomical(&foot);
            let err = (anatomical.t_wc.translation.vector - truth.translation.vector).norm();
            assert!(err < 1e-4, "k {k}: {err} mm off");
            assert!(fit.rms_px < 0.01, "{}", fit.rms_px);
            assert_eq!(fit.inlier_count, points.len());
        }
    }

    #[test]
    fn mismatched_lengths_and_too_few_points_are_errors() {
        let (camera, truth, points, feet, pixels) = scene(1.0);
        let cfg = RadialConfig::default();
        assert!(matches!(
            refine_radial(&truth, &points, &feet[1..], &pixels, &camera, &cfg),
            Err(RefineError::LengthMismatch { .. })
        ));
        assert!(matches!(
            refine_radial(
                &truth,
                &points[..3],
                &feet[..3],
                &pixels[..3],
                &camera,
                &cfg
            ),
            Err(RefineError::TooFewCorrespondences { usable: 3 })
        ));
    }
}
