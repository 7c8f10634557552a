//! The pose uncertainty that a wall which moved since the mapping pass adds.
//!
//! The Gauss-Newton covariance of [`refine_pose`](crate::refine_pose()) treats each
//! reprojection residual as independent pixel noise. A colon wall that moved between the
//! passes breaks that twice: the map points are displaced *together* — neighbours alike, a
//! fold or a haustrum as a whole — and the part of that displacement which a camera motion can
//! explain moves the pose without leaving a residual. A deformed pass is then registered a
//! millimetre or two off while its covariance still speaks of pixel noise.
//!
//! This module adds the missing term. Each map point `i` is taken as moved by `dᵢ` (world,
//! mm), a smooth random field with `cov(dᵢ, dⱼ) = σ_w² ρ(|pᵢ − pⱼ|) I₃` and
//! `ρ(r) = exp(−r² / 2L²)` (`L` = [`WallCovarianceConfig::correlation_mm`]). Through the
//! point Jacobians `Aᵢ = ∂rᵢ/∂pᵢ` and the pose Jacobians `Jᵢ` of the inliers, with
//! `H = Σ JᵢᵀJᵢ` and `M = Σᵢⱼ ρᵢⱼ JᵢᵀAᵢAⱼᵀJⱼ`:
//!
//! ```text
//! cov(δ) += σ_w² H⁻¹ M H⁻¹                                   (the pose the field moves)
//! E[rᵀr]  = σ_px² (2n − 6) + σ_w² (Σ |Aᵢ|²_F − tr(H⁻¹ M))   (what the field leaves visible)
//! ```
//!
//! `σ_w` is not assumed: it is read off the residuals by the second line (method of moments),
//! taking what exceeds the keypoint noise `σ_px` ([`WallCovarianceConfig::keypoint_noise_px`])
//! as wall motion. On a wall that did not move the residuals are the keypoint noise, `σ_w`
//! comes out (near) 0 and nothing is added; on a deformed wall the visible part of the motion
//! tells how much of it the pose absorbed. A `σ_px` set too low for the images reads noise as
//! motion and overstates the uncertainty, never understates it.
//!
//! One registration alone ([`WallCovariance::sigma_mm`]) often shows too little: a few dozen
//! inliers whose visible share of the motion drowns in their keypoint noise, so the estimate
//! comes out 0 for a wall that moved. How far the colon changed is a property of the pass, not
//! of one frame: a stream pools the last registrations' sums ([`WallMotionPool`],
//! `Σ excess / Σ visible`) and states each pose with the larger of the pooled and its own
//! estimate.
//!
//! Residuals and Jacobians are those of the refinement, divided by each point's
//! [`wall_motion_scale`](crate::reprojection::wall_motion_scale) when
//! [`RefineConfig::wall_motion_mm`] is on.

use std::collections::VecDeque;

use nalgebra::{Matrix6, Matrix6x3, Point2, Point3};
use serde::{Deserialize, Serialize};

use crate::camera::Camera;
use crate::pose::Pose;
use crate::refine_pose::{RefineConfig, checked_observations};
use crate::reprojection;

/// Settings of the wall-motion term of a pose's covariance (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WallCovarianceConfig {
    /// Keypoint noise of a registration to a wall that did not move, pixels per image axis
    /// (1σ): residuals beyond it are read as wall motion. 0 turns the term off (the
    /// residuals are all taken as independent noise).
    pub keypoint_noise_px: f64,
    /// Correlation length of the wall's motion, mm: map points this far apart moved alike
    /// to `e^(−1/2)`.
    pub correlation_mm: f64,
    /// Registrations a stream pools to read the wall's motion ([`WallMotionPool`]); 1: each
    /// registration alone.
    pub pooled_registrations: usize,
}

impl Default for WallCovarianceConfig {
    /// 1.4 px: the 80th percentile of the per-axis residual scale of registrations to
    /// unchanged simulated passes at 320×240 (median 1.2 px; a deformed pass's 25th
    /// percentile is 1.5 px). 50 mm: over the simulator's changed colons a correlation of
    /// 10 or 25 mm left more of the errors of shifted and insufflated passes outside their
    /// bounds, at about the same cost on unchanged ones. 20 registrations: chosen on two
    /// simulated colons between 5, 10 and 20, checked on four others (docs/RESULTS.md).
    fn default() -> Self {
        Self {
            keypoint_noise_px: 1.4,
            correlation_mm: 50.0,
            pooled_registrations: 20,
        }
    }
}

impl WallCovarianceConfig {
    /// Whether the term is computed.
    pub fn is_on(&self) -> bool {
        self.keypoint_noise_px > 0.0
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// A message naming the setting out of range.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.keypoint_noise_px.is_finite() && self.keypoint_noise_px >= 0.0) {
            return Err(format!(
                "`keypoint_noise_px` {} px; expected a finite value ≥ 0 (0 turns the wall-motion term off)",
                self.keypoint_noise_px
            ));
        }
        if !(self.correlation_mm.is_finite() && self.correlation_mm > 0.0) {
            return Err(format!(
                "`correlation_mm` {} mm; expected a finite value > 0",
                self.correlation_mm
            ));
        }
        if self.pooled_registrations == 0 {
            return Err(
                "`pooled_registrations` 0; expected at least 1 (1: each registration alone)".into(),
            );
        }
        Ok(())
    }
}

/// The wall-motion term of one registration: what its residuals show of the wall's motion,
/// and the pose covariance per unit of that motion's variance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallCovariance {
    /// `Σ rᵀr − σ_px² (2n − 6)`, px²: the inliers' squared residuals beyond the keypoint
    /// noise (negative when they show less).
    pub excess_px2: f64,
    /// `Σ |Aᵢ|²_F − tr(H⁻¹ M)`, px² per mm²: the squared residuals a wall motion of 1 mm per
    /// axis leaves visible (the part no pose absorbs).
    pub visible_px2_per_mm2: f64,
    /// `H⁻¹ M H⁻¹`: covariance of the left perturbation `δ = [ρ; φ]` of `T_wc` (world frame)
    /// per mm² of the wall motion's variance.
    pub unit_covariance: Matrix6<f64>,
}

impl WallCovariance {
    /// The wall's motion this registration's residuals show alone, mm (1σ per axis); 0 when
    /// they are within the keypoint noise.
    pub fn sigma_mm(&self) -> f64 {
        sigma_from_sums(self.excess_px2, self.visible_px2_per_mm2)
    }

    /// The pose covariance a wall motion of `sigma_mm` (1σ per axis) causes (world frame;
    /// mm² / mm·rad / rad²), to add to the refinement's.
    pub fn covariance(&self, sigma_mm: f64) -> Matrix6<f64> {
        self.unit_covariance * (sigma_mm * sigma_mm)
    }
}

/// `√(excess / visible)`, 0 unless both are positive.
fn sigma_from_sums(excess_px2: f64, visible_px2_per_mm2: f64) -> f64 {
    if visible_px2_per_mm2 > 0.0 && excess_px2 > 0.0 {
        (excess_px2 / visible_px2_per_mm2).sqrt()
    } else {
        0.0
    }
}

/// The wall's motion read off a stream's recent registrations together: the method of
/// moments over the sums of their excess and visible parts (see the module docs). An
/// unchanged pass's excesses scatter about 0 and pool to (near) 0; a changed pass's add up
/// even where each registration alone shows nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct WallMotionPool {
    capacity: usize,
    recent: VecDeque<(f64, f64)>,
}

impl WallMotionPool {
    /// An empty pool of the last `registrations` (at least 1).
    pub fn new(registrations: usize) -> Self {
        let capacity = registrations.max(1);
        Self {
            capacity,
            recent: VecDeque::with_capacity(capacity),
        }
    }

    /// Adds a registration, forgetting the oldest beyond the pool's size.
    pub fn push(&mut self, w: &WallCovariance) {
        if !(w.excess_px2.is_finite() && w.visible_px2_per_mm2.is_finite()) {
            return;
        }
        if self.recent.len() == self.capacity {
            self.recent.pop_front();
        }
        self.recent.push_back((w.excess_px2, w.visible_px2_per_mm2));
    }

    /// The wall's motion the pooled registrations show, mm (1σ per axis); 0 when empty.
    pub fn sigma_mm(&self) -> f64 {
        let (excess, visible) = self
            .recent
            .iter()
            .fold((0.0, 0.0), |(e, v), &(de, dv)| (e + de, v + dv));
        sigma_from_sums(excess, visible)
    }

    /// Forgets every registration (a new pass).
    pub fn clear(&mut self) {
        self.recent.clear();
    }
}

/// The wall-motion term for a pose `t_wc` (camera-to-world, mm) registered to the inlier
/// correspondences `points_world` (world, mm) ↔ `pixels` (distorted pixels of `camera`),
/// with the refinement's settings `refine` (its `min_depth_mm` and `wall_motion_mm`).
///
/// `None` when the term is off, or when there are too few usable inliers (fewer than 4) or
/// the normal equations are singular — the refinement's own covariance then stands alone.
pub fn wall_covariance(
    t_wc: &Pose,
    points_world: &[Point3<f64>],
    pixels: &[Point2<f64>],
    camera: &Camera,
    refine: &RefineConfig,
    cfg: &WallCovarianceConfig,
) -> Option<WallCovariance> {
    if !cfg.is_on() {
        return None;
    }
    let normalized = checked_observations(t_wc, points_world, pixels, camera).ok()?;
    let r_cw = t_wc.rotation.to_rotation_matrix().into_inner().transpose();
    let t_cw = -(r_cw * t_wc.translation.vector);
    let mut h = Matrix6::zeros();
    // Per inlier: Jᵢᵀ Aᵢ (6×3) and its map point.
    let mut b: Vec<(Matrix6x3<f64>, Point3<f64>)> = Vec::with_capacity(points_world.len());
    let (mut trace_c, mut rr) = (0.0, 0.0);
    for (p_w, xn) in points_world.iter().zip(&normalized) {
        if xn.x.is_nan() {
            continue;
        }
        let Some(t) = reprojection::term(
            &r_cw,
            &t_cw,
            p_w,
            xn,
            camera.fx,
            camera.fy,
            refine.min_depth_mm,
        ) else {
            continue;
        };
        let s =
            reprojection::wall_motion_weight(&r_cw, &t_cw, p_w, camera.fx, refine.wall_motion_mm);
        let (j, a, r) = (t.d_pose * s, t.d_point * s, t.residual * s);
        h += j.transpose() * j;
        b.push((j.transpose() * a, *p_w));
        trace_c += a.norm_squared();
        rr += r.norm_squared();
    }
    if b.len() < 4 {
        return None;
    }
    let h_inv = h.try_inverse()?;
    let inv_two_l2 = 1.0 / (2.0 * cfg.correlation_mm * cfg.correlation_mm);
    // M = Σᵢ Bᵢ (Bᵢ + Sᵢ)ᵀ with Sᵢ = Σⱼ≠ᵢ ρᵢⱼ Bⱼ: one exponential per pair, the 6×3 blocks as
    // flat arrays (column-major) so that the pair loop is plain multiply-adds.
    let n = b.len();
    let flat: Vec<[f64; 18]> = b
        .iter()
        .map(|(m, _)| {
            let mut a = [0.0; 18];
            a.copy_from_slice(m.as_slice());
            a
        })
        .collect();
    let mut s = vec![[0.0f64; 18]; n];
    let mut rho = vec![0.0f64; n];
    for i in 0..n {
        let p_i = b[i].1;
        for j in i + 1..n {
            rho[j] = (-(p_i - b[j].1).norm_squared() * inv_two_l2).exp();
        }
        let (b_i, mut s_i) = (flat[i], s[i]);
        for j in i + 1..n {
            let (r, b_j, s_j) = (rho[j], &flat[j], &mut s[j]);
            for k in 0..18 {
                s_i[k] += r * b_j[k];
                s_j[k] += r * b_i[k];
            }
        }
        s[i] = s_i;
    }
    let mut m = Matrix6::zeros();
    for ((bi, _), si) in b.iter().zip(&s) {
        m += bi * (bi + Matrix6x3::from_column_slice(si)).transpose();
    }
    // Symmetric in exact arithmetic; made so in floating point.
    let m = (m + m.transpose()) * 0.5;
    let dof = (2 * b.len() - 6) as f64;
    Some(WallCovariance {
        excess_px2: rr - cfg.keypoint_noise_px * cfg.keypoint_noise_px * dof,
        visible_px2_per_mm2: trace_c - (h_inv * m).trace(),
        unit_covariance: h_inv * m * h_inv,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pool reads its registrations' sums together and forgets the oldest beyond its size.
    #[test]
    fn the_pool_sums_its_registrations_and_forgets_the_oldest() {
        let registration = |excess_px2| WallCovariance {
            excess_px2,
            visible_px2_per_mm2: 1000.0,
            unit_covariance: Matrix6::zeros(),
        };
        let (moved, still) = (registration(40.0), registration(-5.0));
        let mut pool = WallMotionPool::new(3);
        assert_eq!(pool.sigma_mm(), 0.0);
        pool.push(&moved);
        assert!((pool.sigma_mm() - 0.2).abs() < 1e-12);
        // Alone, a still registration shows nothing; pooled with the moved one, (40 − 10) / 3000.
        pool.push(&still);
        pool.push(&still);
        assert_eq!(still.sigma_mm(), 0.0);
        assert!((pool.sigma_mm() - 0.1).abs() < 1e-12);
        pool.push(&still);
        assert_eq!(pool.sigma_mm(), 0.0);
    }
}
