//! Pose conventions and pose errors.
//!
//! A pose is `T_wc`, camera-to-world: `p_world = R_wc * p_cam + t_wc`, translation in mm.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// Camera-to-world rigid transform `T_wc` (rotation + translation in mm).
pub type Pose = Isometry3<f64>;

/// Builds a pose from a position (mm, world frame) and a camera-to-world rotation.
pub fn pose_from_parts(t_wc: Vector3<f64>, r_wc: UnitQuaternion<f64>) -> Pose {
    Isometry3::from_parts(Translation3::from(t_wc), r_wc)
}

/// Returns the quaternion with its sign chosen so that `w ≥ 0` (the canonical sign used before
/// any averaging, median or file output; DESIGN.md).
pub fn canonical_quaternion(q: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    if q.w < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        q
    }
}

/// Position error `‖t_est − t_gt‖`, mm.
pub fn position_error_mm(est: &Pose, gt: &Pose) -> f64 {
    (est.translation.vector - gt.translation.vector).norm()
}

/// Orientation error: geodesic angle of `R_estᵀ R_gt`, degrees, in `[0, 180]`.
pub fn orientation_error_deg(est: &Pose, gt: &Pose) -> f64 {
    est.rotation.angle_to(&gt.rotation).to_degrees()
}
