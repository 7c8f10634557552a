//! Pose refinement from 2D–3D correspondences: Gauss-Newton on SE(3) with left perturbation
//! (the paper's Eq. 2), robust weights, and an approximate covariance.
//!
//! # Model
//!
//! The pose is `T_wc` (camera-to-world, mm). A map point `p_w` is seen at
//! `camera.project(T_wc⁻¹ · p_w)`. Each iteration linearises the residuals at `T_wc`, solves the
//! 6×6 normal equations `(Jᵀ W J) δ = −Jᵀ W r` and updates `T_wc ← exp(δ) · T_wc` with
//! `δ = [ρ; φ]` (mm, rad; see [`crate::se3`] for the ordering). The analytic Jacobian of one
//! residual is `J = A · [−I, [p_w]×]`, `A = diag(fx, fy) · ∂π/∂p_c · R_cw`.
//!
//! Robust weights (iteratively re-weighted least squares) use the Huber or Cauchy kernel on
//! the residual norm in pixels ([`RobustKernel`]). Every step is accepted only if it does not
//! raise the robust cost (step halving otherwise), so the cost decreases monotonically.
//!
//! # Distortion
//!
//! Observed pixels are undistorted once, before the iterations, to normalized coordinates; the
//! residual is `(fx·(x/z − x̂), fy·(y/z − ŷ))`, i.e. pixels of the ideal pinhole (exactly the
//! pixel error without distortion). The reported RMS and the inlier test use the true camera
//! model (`Camera::project`, distortion included).
//!
//! # Convergence
//!
//! Converged when a step moves the camera centre by less than `min_step_mm` **and** rotates it
//! by less than `min_step_rad`, or when the relative cost decrease falls below
//! `min_relative_decrease`, or when no step along the Gauss-Newton direction lowers the cost.
//! After convergence with a robust kernel, an optional polish on the inliers
//! (`polish_inliers`) converges again with `polish_kernel`: by default a Cauchy kernel of
//! 1 px, since the residuals of a registration are dominated by the map points' own errors
//! (triangulated from a few views, some of them millimetres off along the ray), which are
//! heavy-tailed — a few points a pixel or two off pull a least-squares or Huber pose, the
//! Cauchy kernel all but ignores them.
//!
//! # Allocation
//!
//! The iterations accumulate `JᵀWJ` and `JᵀWr` in fixed-size `Matrix6`/`Vector6`; the only heap
//! use is one buffer of normalized observations and the returned inlier mask, per call.

use nalgebra::{Matrix3, Matrix6, Point2, Point3, SymmetricEigen, Vector2, Vector6};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::camera::Camera;
use crate::pose::Pose;
use crate::{reprojection, se3, so3};

/// Residual assigned to a point behind the camera (pixels): it enters the cost through the
/// kernel but not the normal equations.
const BEHIND_PENALTY_PX: f64 = 1.0e4;

/// Robust kernel on a correspondence's reprojection error `e` (pixels).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum RobustKernel {
    /// Plain least squares: `ρ(e) = e²/2`.
    None,
    /// Huber: quadratic up to `scale_px`, linear beyond.
    Huber {
        /// Transition point, pixels.
        scale_px: f64,
    },
    /// Cauchy (Lorentzian): `ρ(e) = s²/2 · ln(1 + (e/s)²)`, strongly down-weights outliers.
    Cauchy {
        /// Scale `s`, pixels.
        scale_px: f64,
    },
}

impl RobustKernel {
    /// The kernel's cost `ρ(e)` for an error `e ≥ 0`, px².
    pub fn cost(&self, e: f64) -> f64 {
        match *self {
            RobustKernel::None => 0.5 * e * e,
            RobustKernel::Huber { scale_px: k } => {
                if e <= k {
                    0.5 * e * e
                } else {
                    k * (e - 0.5 * k)
                }
            }
            RobustKernel::Cauchy { scale_px: s } => 0.5 * s * s * (1.0 + (e / s).powi(2)).ln(),
        }
    }

    /// The IRLS weight `ρ'(e)/e` for an error `e ≥ 0` (dimensionless, in `(0, 1]`).
    pub fn weight(&self, e: f64) -> f64 {
        match *self {
            RobustKernel::None => 1.0,
            RobustKernel::Huber { scale_px: k } => {
                if e <= k {
                    1.0
                } else {
                    k / e
                }
            }
            RobustKernel::Cauchy { scale_px: s } => 1.0 / (1.0 + (e / s).powi(2)),
        }
    }
}

/// Settings of [`refine_pose`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RefineConfig {
    /// Robust kernel of the main iterations.
    pub kernel: RobustKernel,
    /// Maximum number of Gauss-Newton iterations (main stage and polish each).
    pub max_iterations: usize,
    /// Converged when the camera centre moves less than this in one step, mm (and the
    /// rotation condition holds).
    pub min_step_mm: f64,
    /// Converged when the camera rotates less than this in one step, radians (and the
    /// translation condition holds).
    pub min_step_rad: f64,
    /// Converged when one step lowers the cost by less than this fraction of it.
    pub min_relative_decrease: f64,
    /// A correspondence is an inlier when its final reprojection error is below this, pixels.
    pub inlier_threshold_px: f64,
    /// After the robust stage, refine again on its inliers with [`Self::polish_kernel`].
    pub polish_inliers: bool,
    /// Kernel of the polish ([`RobustKernel::None`]: plain least squares on the inliers).
    pub polish_kernel: RobustKernel,
    /// Points closer than this to the image plane (depth, mm) count as behind the camera.
    pub min_depth_mm: f64,
    /// Reject as degenerate when the smallest eigenvalue of the Jacobi-scaled normal matrix is
    /// below this (collinear points, a single point cluster; dimensionless, in `(0, 1]`).
    pub min_normalized_eigenvalue: f64,
    /// How far the colon wall may have moved since the map was built (standard deviation,
    /// mm): each residual is divided by [`reprojection::wall_motion_scale`] at the point's
    /// depth before the kernel, the inlier test and the RMS, so every pixel figure here
    /// (`kernel`, `inlier_threshold_px`, `polish_kernel`, the RMS) is in pixels of a point the
    /// wall did not move, and a near point may lie farther from its projection than a far
    /// one. 0 (default): a rigid colon, residuals in plain pixels.
    #[serde(skip_serializing_if = "is_zero")]
    pub wall_motion_mm: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for RefineConfig {
    fn default() -> Self {
        Self {
            kernel: RobustKernel::Huber { scale_px: 2.0 },
            max_iterations: 50,
            min_step_mm: 1e-10,
            min_step_rad: 1e-12,
            min_relative_decrease: 1e-14,
            inlier_threshold_px: 4.0,
            polish_inliers: true,
            polish_kernel: RobustKernel::Cauchy { scale_px: 1.0 },
            min_depth_mm: 1e-3,
            min_normalized_eigenvalue: 1e-10,
            wall_motion_mm: 0.0,
        }
    }
}

/// A stated 95 % bound on a position (orientation) error is this many times its standard
/// deviation: the two-sided 95 % quantile of a normal distribution along the least certain
/// direction. Localization's `position_std_mm` / `orientation_std_deg` are calibrated for it.
pub const BOUND95_PER_STD: f64 = 1.96;

/// A refined pose with its quality figures.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseEstimate {
    /// Refined camera-to-world pose `T_wc`, mm.
    pub t_wc: Pose,
    /// Final robust cost `Σ ρ(eᵢ)` over all correspondences with the main kernel, px².
    pub cost: f64,
    /// Root-mean-square reprojection error over the inliers (true camera model), pixels —
    /// each divided by its point's [`reprojection::wall_motion_scale`] when
    /// [`RefineConfig::wall_motion_mm`] is on; `NaN` when there are no inliers.
    pub rms_px: f64,
    /// Per correspondence: in front of the camera and reprojected within
    /// `inlier_threshold_px`.
    pub inliers: Vec<bool>,
    /// Number of `true` entries in `inliers`.
    pub inlier_count: usize,
    /// Gauss-Newton iterations performed (all stages).
    pub iterations: usize,
    /// Whether a convergence criterion was met (not just the iteration limit).
    pub converged: bool,
    /// Approximate covariance of the left perturbation `δ = [ρ; φ]` of `T_wc` (world frame;
    /// mm² / mm·rad / rad²): `σ² (JᵀWJ)⁻¹` on the inliers with `σ²` the weighted residual
    /// variance.
    pub covariance: Matrix6<f64>,
}

impl PoseEstimate {
    /// Largest standard deviation of the camera centre along any direction, mm (from
    /// [`PoseEstimate::covariance`]).
    pub fn position_sigma_mm(&self) -> f64 {
        position_sigma_mm(&self.t_wc, &self.covariance)
    }

    /// Largest standard deviation of the orientation about any axis, degrees.
    pub fn rotation_sigma_deg(&self) -> f64 {
        rotation_sigma_deg(&self.covariance)
    }
}

/// Largest standard deviation of the camera centre of `t_wc` along any direction, mm, for a
/// `covariance` of the left perturbation `δ = [ρ; φ]` of `T_wc` (world frame).
pub fn position_sigma_mm(t_wc: &Pose, covariance: &Matrix6<f64>) -> f64 {
    // Δc = ρ + φ × c = [I, −[c]×] δ for the left perturbation.
    let c = t_wc.translation.vector;
    let mut j = nalgebra::Matrix3x6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::identity());
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-so3::hat(&c)));
    let cov = j * covariance * j.transpose();
    SymmetricEigen::new(cov).eigenvalues.max().max(0.0).sqrt()
}

/// Largest standard deviation of the orientation about any axis, degrees, for a `covariance`
/// of the left perturbation `δ = [ρ; φ]` of `T_wc`.
pub fn rotation_sigma_deg(covariance: &Matrix6<f64>) -> f64 {
    let cov: Matrix3<f64> = covariance.fixed_view::<3, 3>(3, 3).into_owned();
    SymmetricEigen::new(cov)
        .eigenvalues
        .max()
        .max(0.0)
        .sqrt()
        .to_degrees()
}

/// Why a pose could not be refined.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RefineError {
    /// `points_world` and `pixels` differ in length.
    #[error("{points} map points but {pixels} pixels")]
    LengthMismatch {
        /// Number of map points.
        points: usize,
        /// Number of pixels.
        pixels: usize,
    },
    /// Fewer usable correspondences than the 3 a pose needs.
    #[error("too few correspondences: {usable} usable, at least 3 needed")]
    TooFewCorrespondences {
        /// Correspondences in front of the prior camera with an invertible pixel.
        usable: usize,
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
    /// The normal equations are (nearly) singular: collinear or coincident points, or too
    /// few inliers spread over the image.
    #[error("degenerate geometry: normalized eigenvalue {min_eigenvalue:.3e} of JᵀJ")]
    Degenerate {
        /// Smallest eigenvalue of the Jacobi-scaled normal matrix.
        min_eigenvalue: f64,
    },
}

/// One linearisation: robust cost, normal matrix and gradient.
struct Linearization {
    cost: f64,
    h: Matrix6<f64>,
    g: Vector6<f64>,
    /// Number of correspondences in front of the camera that entered `h`.
    used: usize,
}

struct Problem<'a> {
    points: &'a [Point3<f64>],
    /// Undistorted normalized observations; `NaN` where the pixel could not be undistorted.
    normalized: &'a [Vector2<f64>],
    fx: f64,
    fy: f64,
    min_depth_mm: f64,
    /// [`RefineConfig::wall_motion_mm`].
    wall_motion_mm: f64,
}

impl Problem<'_> {
    /// Linearises at `t_wc` with `kernel`, over the correspondences selected by `mask`.
    fn linearize(
        &self,
        t_wc: &Pose,
        kernel: &RobustKernel,
        mask: Option<&[bool]>,
    ) -> Linearization {
        let r_cw = t_wc.rotation.to_rotation_matrix().into_inner().transpose();
        let t_cw = -(r_cw * t_wc.translation.vector);
        let mut h = Matrix6::zeros();
        let mut g = Vector6::zeros();
        let mut cost = 0.0;
        let mut used = 0;
        for (i, (p_w, xn)) in self.points.iter().zip(self.normalized).enumerate() {
            if let Some(m) = mask
                && !m.get(i).copied().unwrap_or(false)
            {
                continue;
            }
            if xn.x.is_nan() {
                continue;
            }
            let Some(t) =
                reprojection::term(&r_cw, &t_cw, p_w, xn, self.fx, self.fy, self.min_depth_mm)
            else {
                cost += kernel.cost(BEHIND_PENALTY_PX);
                continue;
            };
            // Residual and Jacobian divided by the point's tolerance (1 for a rigid colon).
            let scale =
                reprojection::wall_motion_weight(&r_cw, &t_cw, p_w, self.fx, self.wall_motion_mm);
            let e = scale * t.residual.norm();
            let w = kernel.weight(e) * scale * scale;
            cost += kernel.cost(e);
            // Upper triangle of the rank-2 update w·JᵀJ (mirrored once after the loop).
            let j = &t.d_pose;
            let (r0, r1) = (w * t.residual.x, w * t.residual.y);
            for a in 0..6 {
                let (wa0, wa1) = (w * j[(0, a)], w * j[(1, a)]);
                for b in a..6 {
                    h[(a, b)] += wa0 * j[(0, b)] + wa1 * j[(1, b)];
                }
                g[a] += j[(0, a)] * r0 + j[(1, a)] * r1;
            }
            used += 1;
        }
        h.fill_lower_triangle_with_upper_triangle();
        Linearization { cost, h, g, used }
    }

    /// Gauss-Newton with step halving from `t_wc`; returns the pose, its linearisation, the
    /// number of iterations and whether it converged.
    fn solve(
        &self,
        mut t_wc: Pose,
        kernel: &RobustKernel,
        mask: Option<&[bool]>,
        cfg: &RefineConfig,
    ) -> (Pose, Linearization, usize, bool) {
        let mut lin = self.linearize(&t_wc, kernel, mask);
        let mut iterations = 0;
        let mut converged = false;
        while iterations < cfg.max_iterations {
            iterations += 1;
            if lin.used < 3 || lin.cost == 0.0 {
                converged = lin.cost == 0.0;
                break;
            }
            let Some(chol) = lin.h.cholesky() else {
                break;
            };
            let delta = -chol.solve(&lin.g);
            if !delta.iter().all(|v| v.is_finite()) {
                break;
            }
            // A step below the thresholds ends the iterations without evaluating it.
            let phi = delta.fixed_rows::<3>(3).into_owned();
            let rho = delta.fixed_rows::<3>(0).into_owned();
            let centre_move = (rho + phi.cross(&t_wc.translation.vector)).norm();
            if centre_move < cfg.min_step_mm && phi.norm() < cfg.min_step_rad {
                t_wc = se3::left_update(&t_wc, &delta);
                converged = true;
                break;
            }
            let mut alpha = 1.0;
            let mut accepted = None;
            for _ in 0..12 {
                let candidate = se3::left_update(&t_wc, &(delta * alpha));
                let cand_lin = self.linearize(&candidate, kernel, mask);
                if cand_lin.used >= 3 && cand_lin.cost <= lin.cost {
                    accepted = Some((candidate, cand_lin));
                    break;
                }
                alpha *= 0.5;
            }
            let Some((candidate, cand_lin)) = accepted else {
                converged = true; // no descent left along the Gauss-Newton direction
                break;
            };
            let moved_mm = (candidate.translation.vector - t_wc.translation.vector).norm();
            let rotated_rad = (delta.fixed_rows::<3>(3) * alpha).norm();
            let decrease = lin.cost - cand_lin.cost;
            let small_step = moved_mm < cfg.min_step_mm && rotated_rad < cfg.min_step_rad;
            let small_decrease = decrease <= cfg.min_relative_decrease * lin.cost;
            t_wc = candidate;
            lin = cand_lin;
            if small_step || small_decrease {
                converged = true;
                break;
            }
        }
        (t_wc, lin, iterations, converged)
    }
}

/// Refines `prior` (`T_wc`, mm) so that the map points `points_world` (world frame, mm)
/// reproject onto `pixels`, by robust Gauss-Newton on SE(3) with left perturbation.
///
/// See the module docs for the model, the robust weights, the convergence criteria and how
/// distortion is handled.
///
/// # Errors
/// [`RefineError::LengthMismatch`], [`RefineError::NonFinite`] / [`RefineError::NonFinitePrior`]
/// for bad input; [`RefineError::TooFewCorrespondences`] when fewer than 3 correspondences are
/// usable at the prior (in front of the camera, invertible pixel); [`RefineError::Degenerate`]
/// when the final normal equations are (nearly) singular.
pub fn refine_pose(
    prior: &Pose,
    points_world: &[Point3<f64>],
    pixels: &[Point2<f64>],
    camera: &Camera,
    cfg: &RefineConfig,
) -> Result<PoseEstimate, RefineError> {
    let normalized = checked_observations(prior, points_world, pixels, camera)?;
    let problem = Problem {
        points: points_world,
        normalized: &normalized,
        fx: camera.fx,
        fy: camera.fy,
        min_depth_mm: cfg.min_depth_mm,
        wall_motion_mm: cfg.wall_motion_mm,
    };
    let start = problem.linearize(prior, &RobustKernel::None, None);
    if start.used < 3 {
        return Err(RefineError::TooFewCorrespondences { usable: start.used });
    }

    let polish = cfg.polish_inliers && cfg.kernel != RobustKernel::None;
    // With a polish to follow, the robust stage only has to settle the inlier set: it stops
    // at a coarser step (1e-4 mm / 1e-6 rad by default) and the polish converges fully.
    let robust_cfg = if polish {
        RefineConfig {
            min_step_mm: cfg.min_step_mm.max(1e-4),
            min_step_rad: cfg.min_step_rad.max(1e-6),
            min_relative_decrease: cfg.min_relative_decrease.max(1e-9),
            ..*cfg
        }
    } else {
        *cfg
    };
    let (mut t_wc, mut lin, mut iterations, mut converged) =
        problem.solve(*prior, &cfg.kernel, None, &robust_cfg);
    let mut inliers = inlier_mask(&t_wc, points_world, pixels, camera, cfg);
    if polish {
        let count = inliers.iter().filter(|&&b| b).count();
        if count >= 3 {
            // A robust polish converges linearly (its weights change with every step): it stops
            // once a step moves the camera by less than 1e-6 mm / 1e-8 rad or lowers the cost
            // by less than 1e-9 of it, far below any error that matters (least squares, which
            // converges in a step or two, keeps the configured thresholds).
            let polish_cfg = if cfg.polish_kernel == RobustKernel::None {
                *cfg
            } else {
                RefineConfig {
                    min_step_mm: cfg.min_step_mm.max(1e-6),
                    min_step_rad: cfg.min_step_rad.max(1e-8),
                    min_relative_decrease: cfg.min_relative_decrease.max(1e-9),
                    ..*cfg
                }
            };
            let (t2, _, it2, conv2) =
                problem.solve(t_wc, &cfg.polish_kernel, Some(&inliers), &polish_cfg);
            iterations += it2;
            converged &= conv2;
            t_wc = t2;
            lin = problem.linearize(&t_wc, &cfg.kernel, None);
            inliers = inlier_mask(&t_wc, points_world, pixels, camera, cfg);
        }
    }

    // Degeneracy and covariance from the inlier normal equations.
    let inlier_count = inliers.iter().filter(|&&b| b).count();
    let lin_in = problem.linearize(&t_wc, &RobustKernel::None, Some(&inliers));
    let min_eigenvalue = normalized_min_eigenvalue(&lin_in.h);
    if !(min_eigenvalue >= cfg.min_normalized_eigenvalue) {
        return Err(RefineError::Degenerate { min_eigenvalue });
    }
    let mut sum_sq = 0.0;
    for ((p, px), _) in points_world
        .iter()
        .zip(pixels)
        .zip(&inliers)
        .filter(|(_, b)| **b)
    {
        if let Some(e) = tolerant_error_px(&t_wc, p, px, camera, cfg.wall_motion_mm) {
            sum_sq += e * e;
        }
    }
    let rms_px = if inlier_count > 0 {
        (sum_sq / inlier_count as f64).sqrt()
    } else {
        f64::NAN
    };
    let dof = (2 * inlier_count).saturating_sub(6).max(1) as f64;
    let sigma2 = 2.0 * lin_in.cost / dof;
    let covariance = lin_in
        .h
        .try_inverse()
        .map(|inv| inv * sigma2)
        .unwrap_or(Matrix6::from_element(f64::INFINITY));
    Ok(PoseEstimate {
        t_wc,
        cost: lin.cost,
        rms_px,
        inliers,
        inlier_count,
        iterations,
        converged,
        covariance,
    })
}

/// Checks the inputs of a pose refinement — as many pixels as points, a finite prior, finite
/// points and pixels — and undistorts the pixels to normalized coordinates (`NaN` where a
/// pixel cannot be undistorted).
pub(crate) fn checked_observations(
    prior: &Pose,
    points_world: &[Point3<f64>],
    pixels: &[Point2<f64>],
    camera: &Camera,
) -> Result<Vec<Vector2<f64>>, RefineError> {
    if points_world.len() != pixels.len() {
        return Err(RefineError::LengthMismatch {
            points: points_world.len(),
            pixels: pixels.len(),
        });
    }
    let prior_finite = prior.translation.vector.iter().all(|v| v.is_finite())
        && prior.rotation.coords.iter().all(|v| v.is_finite());
    if !prior_finite {
        return Err(RefineError::NonFinitePrior);
    }
    let mut normalized = Vec::with_capacity(pixels.len());
    for (index, (p, px)) in points_world.iter().zip(pixels).enumerate() {
        if !(p.coords.iter().all(|v| v.is_finite()) && px.coords.iter().all(|v| v.is_finite())) {
            return Err(RefineError::NonFinite { index });
        }
        normalized.push(
            camera
                .normalized(px)
                .unwrap_or(Vector2::new(f64::NAN, f64::NAN)),
        );
    }
    Ok(normalized)
}

/// Smallest eigenvalue of `D^{-1/2} H D^{-1/2}` (`D = diag(H)`), in `[0, 1]` for a PSD `H`.
fn normalized_min_eigenvalue(h: &Matrix6<f64>) -> f64 {
    let mut s = Vector6::zeros();
    for k in 0..6 {
        let d = h[(k, k)];
        if !(d > 0.0) {
            return 0.0;
        }
        s[k] = 1.0 / d.sqrt();
    }
    let scaled = Matrix6::from_fn(|i, j| h[(i, j)] * s[i] * s[j]);
    SymmetricEigen::new(scaled).eigenvalues.min()
}

/// Reprojection error of one correspondence at `t_wc` with the true camera model, pixels;
/// `None` when the point is behind the camera.
pub fn reprojection_error_px(
    t_wc: &Pose,
    p_world: &Point3<f64>,
    pixel: &Point2<f64>,
    camera: &Camera,
) -> Option<f64> {
    let p_c = t_wc.inverse_transform_point(p_world);
    camera.project(&p_c).map(|q| (q - pixel).norm())
}

/// [`reprojection_error_px`] divided by the point's [`reprojection::wall_motion_scale`].
fn tolerant_error_px(
    t_wc: &Pose,
    p_world: &Point3<f64>,
    pixel: &Point2<f64>,
    camera: &Camera,
    wall_motion_mm: f64,
) -> Option<f64> {
    let p_c = t_wc.inverse_transform_point(p_world);
    camera.project(&p_c).map(|q| {
        (q - pixel).norm() / reprojection::wall_motion_scale(camera.fx, p_c.z, wall_motion_mm)
    })
}

fn inlier_mask(
    t_wc: &Pose,
    points: &[Point3<f64>],
    pixels: &[Point2<f64>],
    camera: &Camera,
    cfg: &RefineConfig,
) -> Vec<bool> {
    points
        .iter()
        .zip(pixels)
        .map(|(p, px)| {
            t_wc.inverse_transform_point(p).z > cfg.min_depth_mm
                && tolerant_error_px(t_wc, p, px, camera, cfg.wall_motion_mm)
                    .is_some_and(|e| e < cfg.inlier_threshold_px)
        })
        .collect()
}
