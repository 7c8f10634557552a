//! The reprojection residual shared by triangulation (Eq. 1) and pose refinement (Eq. 2), with
//! its analytic Jacobians.
//!
//! For a camera with pose `T_wc` (world-to-camera `R_cw = R_wcᵀ`, `t_cw = −R_cw t_wc`), a
//! world point `p_w` (mm) and an observation in undistorted normalized coordinates `x̂`:
//!
//! ```text
//! p_c = R_cw p_w + t_cw,   r = ( fx (p_c.x / p_c.z − x̂.x),  fy (p_c.y / p_c.z − x̂.y) )   [px]
//! ```
//!
//! - `∂r/∂p_w = A`, with `A = diag(fx, fy) · ∂π/∂p_c · R_cw` (px/mm);
//! - `∂r/∂δ` for the left perturbation `T_wc ← exp(δ) T_wc`, `δ = [ρ; φ]`:
//!   `p_c(δ) = R_cw (exp(−δ) p_w) + t_cw`, so `∂r/∂δ = A · [−I, [p_w]×]` (px/mm, px/rad).

use nalgebra::{Matrix2x3, Matrix2x6, Matrix3, Point3, Vector2, Vector3};

/// Residual and Jacobians of one observation (see the module docs for the formulas).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReprojectionTerm {
    /// Residual in ideal-pinhole pixels.
    pub residual: Vector2<f64>,
    /// `∂r/∂p_w`, px/mm.
    pub d_point: Matrix2x3<f64>,
    /// `∂r/∂δ` for the left perturbation of `T_wc`, `δ = [ρ; φ]` (px/mm, px/rad).
    pub d_pose: Matrix2x6<f64>,
}

/// The reprojection residual alone; `None` when the point is not deeper than `min_depth_mm`.
#[inline(always)]
pub fn residual(
    r_cw: &Matrix3<f64>,
    t_cw: &Vector3<f64>,
    p_w: &Point3<f64>,
    xn: &Vector2<f64>,
    fx: f64,
    fy: f64,
    min_depth_mm: f64,
) -> Option<Vector2<f64>> {
    let p_c = r_cw * p_w.coords + t_cw;
    if !(p_c.z > min_depth_mm) {
        return None;
    }
    let iz = 1.0 / p_c.z;
    Some(Vector2::new(
        fx * (p_c.x * iz - xn.x),
        fy * (p_c.y * iz - xn.y),
    ))
}

/// The reprojection residual with `∂r/∂p_w` only (for triangulation); `None` when the point
/// is not deeper than `min_depth_mm`.
#[inline(always)]
pub fn residual_and_point_jacobian(
    r_cw: &Matrix3<f64>,
    t_cw: &Vector3<f64>,
    p_w: &Point3<f64>,
    xn: &Vector2<f64>,
    fx: f64,
    fy: f64,
    min_depth_mm: f64,
) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
    let p_c = r_cw * p_w.coords + t_cw;
    if !(p_c.z > min_depth_mm) {
        return None;
    }
    let iz = 1.0 / p_c.z;
    let (u, v) = (p_c.x * iz, p_c.y * iz);
    let r = Vector2::new(fx * (u - xn.x), fy * (v - xn.y));
    let d_pi = Matrix2x3::new(fx * iz, 0.0, -fx * u * iz, 0.0, fy * iz, -fy * v * iz);
    Some((r, d_pi * r_cw))
}

/// The reprojection residual with both Jacobians; `None` when the point is not deeper than
/// `min_depth_mm`.
#[inline(always)]
pub fn term(
    r_cw: &Matrix3<f64>,
    t_cw: &Vector3<f64>,
    p_w: &Point3<f64>,
    xn: &Vector2<f64>,
    fx: f64,
    fy: f64,
    min_depth_mm: f64,
) -> Option<ReprojectionTerm> {
    let (residual, a) = residual_and_point_jacobian(r_cw, t_cw, p_w, xn, fx, fy, min_depth_mm)?;
    // A · [p]× row by row: aᵀ [p]× x = a · (p × x) = x · (a × p), so aᵀ [p]× = (a × p)ᵀ.
    let p = p_w.coords;
    let mut d_pose = Matrix2x6::zeros();
    for k in 0..2 {
        let a_k = Vector3::new(a[(k, 0)], a[(k, 1)], a[(k, 2)]);
        let b = a_k.cross(&p);
        d_pose[(k, 0)] = -a_k.x;
        d_pose[(k, 1)] = -a_k.y;
        d_pose[(k, 2)] = -a_k.z;
        d_pose[(k, 3)] = b.x;
        d_pose[(k, 4)] = b.y;
        d_pose[(k, 5)] = b.z;
    }
    Some(ReprojectionTerm {
        residual,
        d_point: a,
        d_pose,
    })
}

/// How many times wider a map point's reprojection tolerance is when the colon wall may
/// have moved since the point was mapped (deformation, insufflation): `√(1 + (f·σ/z)²)` for a
/// wall displacement of standard deviation `wall_motion_mm` (σ, mm) seen at depth `depth_mm`
/// (z, mm) by a camera of focal length `focal_px` (f, pixels) — such a displacement moves the
/// image point by about `f·σ/z` pixels, on top of the one pixel of image noise that every
/// pixel threshold is set for. 1 when `wall_motion_mm` is 0: a rigid colon.
///
/// Registration divides each residual by it ([`crate::RefineConfig::wall_motion_mm`]): near
/// points, whose image moves most when the wall does, are trusted less and kept as inliers
/// farther from their projection; far points keep almost their rigid tolerance.
#[inline]
pub fn wall_motion_scale(focal_px: f64, depth_mm: f64, wall_motion_mm: f64) -> f64 {
    if wall_motion_mm > 0.0 && depth_mm > 0.0 {
        let px = focal_px * wall_motion_mm / depth_mm;
        (1.0 + px * px).sqrt()
    } else {
        1.0
    }
}

/// The weight `1 / wall_motion_scale` of a residual of the map point `p_w` (world, mm) in the
/// camera `(r_cw, t_cw)`: what the residual and its Jacobians are multiplied by for a wall that
/// may have moved by `wall_motion_mm` (σ, mm). 1 when `wall_motion_mm` is 0: a rigid colon.
#[inline]
pub fn wall_motion_weight(
    r_cw: &Matrix3<f64>,
    t_cw: &Vector3<f64>,
    p_w: &Point3<f64>,
    focal_px: f64,
    wall_motion_mm: f64,
) -> f64 {
    if wall_motion_mm > 0.0 {
        let z = r_cw.row(2).dot(&p_w.coords.transpose()) + t_cw.z;
        1.0 / wall_motion_scale(focal_px, z, wall_motion_mm)
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::Pose;
    use crate::se3;
    use crate::synthetic::{random_rotation, standard_normal};
    use nalgebra::{Translation3, Vector6};
    use proptest::prelude::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn split(t_wc: &Pose) -> (Matrix3<f64>, Vector3<f64>) {
        let r_cw = t_wc.rotation.to_rotation_matrix().into_inner().transpose();
        (r_cw, -(r_cw * t_wc.translation.vector))
    }

    proptest! {
        /// Both analytic Jacobians equal central finite differences.
        #[test]
        fn analytic_jacobians_equal_finite_differences(seed in 0u64..100_000) {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let t_wc = Pose::from_parts(
                Translation3::new(
                    100.0 * standard_normal(&mut rng),
                    100.0 * standard_normal(&mut rng),
                    100.0 * standard_normal(&mut rng),
                ),
                random_rotation(&mut rng),
            );
            let p_c = Point3::new(
                20.0 * standard_normal(&mut rng),
                20.0 * standard_normal(&mut rng),
                30.0 + 50.0 * standard_normal(&mut rng).abs(),
            );
            let p_w = t_wc * p_c;
            let xn = Vector2::new(0.1 * standard_normal(&mut rng), 0.1 * standard_normal(&mut rng));
            let (fx, fy) = (320.0, 300.0);
            let (r_cw, t_cw) = split(&t_wc);
            let t = term(&r_cw, &t_cw, &p_w, &xn, fx, fy, 1e-3).unwrap();
            let scale = t.d_pose.norm() + t.d_point.norm();
            for k in 0..6 {
                let h = if k < 3 { 1e-4 } else { 1e-6 };
                let mut e = Vector6::zeros();
                e[k] = h;
                let (rp, tp) = split(&se3::left_update(&t_wc, &e));
                let (rm, tm) = split(&se3::left_update(&t_wc, &(-e)));
                let fd = (residual(&rp, &tp, &p_w, &xn, fx, fy, 1e-3).unwrap()
                    - residual(&rm, &tm, &p_w, &xn, fx, fy, 1e-3).unwrap()) / (2.0 * h);
                prop_assert!((fd - t.d_pose.column(k)).norm() < 1e-6 * scale,
                    "pose column {k}: fd {fd:?} analytic {:?}", t.d_pose.column(k));
            }
            for k in 0..3 {
                let h = 1e-4;
                let mut d = Vector3::zeros();
                d[k] = h;
                let fd = (residual(&r_cw, &t_cw, &(p_w + d), &xn, fx, fy, 1e-3).unwrap()
                    - residual(&r_cw, &t_cw, &(p_w - d), &xn, fx, fy, 1e-3).unwrap()) / (2.0 * h);
                prop_assert!((fd - t.d_point.column(k)).norm() < 1e-6 * scale);
            }
        }
    }

    #[test]
    fn points_behind_the_camera_have_no_residual() {
        let (r, t) = (Matrix3::identity(), Vector3::zeros());
        let xn = Vector2::zeros();
        assert!(residual(&r, &t, &Point3::new(0.0, 0.0, -5.0), &xn, 1.0, 1.0, 1e-3).is_none());
        assert!(term(&r, &t, &Point3::new(0.0, 0.0, 0.0), &xn, 1.0, 1.0, 1e-3).is_none());
        assert!(
            term(
                &r,
                &t,
                &Point3::new(0.0, 0.0, f64::NAN),
                &xn,
                1.0,
                1.0,
                1e-3
            )
            .is_none()
        );
    }
}
