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
/// any averaging, median or file output; docs/CONVENTIONS.md).
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
///
/// Computed as `2·atan2(‖v‖, |w|)` of the relative quaternion, which stays accurate for tiny
/// angles (an `acos(w)` formula cannot resolve angles below ~1e-6°).
pub fn orientation_error_deg(est: &Pose, gt: &Pose) -> f64 {
    crate::so3::geodesic_distance(&est.rotation, &gt.rotation).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: `angle_to` (acos-based) returned 0 or ~1e-6° for rotations 1e-9 rad apart.
    #[test]
    fn orientation_error_resolves_tiny_angles() {
        let a = Pose::identity();
        let b = pose_from_parts(
            Vector3::zeros(),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 1e-9),
        );
        let e = orientation_error_deg(&a, &b);
        assert!((e - 1e-9f64.to_degrees()).abs() < 1e-20, "{e}");
        let c = pose_from_parts(
            Vector3::new(3.0, 4.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 3.0),
        );
        assert!((orientation_error_deg(&a, &c) - 3.0f64.to_degrees()).abs() < 1e-12);
        assert!((position_error_mm(&a, &c) - 5.0).abs() < 1e-15);
    }
}
