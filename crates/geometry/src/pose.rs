//! Pose conventions and pose errors.
//!
//! A pose is `T_wc`, camera-to-world: `p_world = R_wc * p_cam + t_wc`, translation in mm.

use nalgebra::{Isometry3, Matrix3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3};

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

/// The rotation nearest to a nearly orthonormal matrix, as a canonical (`w ≥ 0`) quaternion;
/// `None` when `m` has a non-finite entry, is farther than `tol` (Frobenius norm of `mᵀm − I`)
/// from a rotation, or has a non-positive determinant (a reflection).
pub fn rotation_from_matrix(m: &Matrix3<f64>, tol: f64) -> Option<UnitQuaternion<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    if (m.transpose() * m - Matrix3::identity()).norm() > tol || m.determinant() <= 0.0 {
        return None;
    }
    let r = Rotation3::from_matrix_eps(m, 1e-15, 100, Rotation3::identity());
    Some(canonical_quaternion(UnitQuaternion::from_rotation_matrix(
        &r,
    )))
}

/// A pose from a 4×4 homogeneous matrix `[R t; 0 0 0 1]` (`T_wc`, `t` in mm), its rotation
/// block projected onto the nearest rotation ([`rotation_from_matrix`]).
///
/// # Errors
/// A message saying what is wrong: a non-finite entry, a bottom row other than `0 0 0 1`, or
/// a rotation block farther than `tol` from a rotation.
pub fn pose_from_matrix(m: &Matrix4<f64>, tol: f64) -> Result<Pose, String> {
    if !m.iter().all(|v| v.is_finite()) {
        return Err("the matrix has a non-finite entry".into());
    }
    let bottom = m.fixed_view::<1, 4>(3, 0);
    if (bottom - nalgebra::RowVector4::new(0.0, 0.0, 0.0, 1.0)).norm() > tol {
        return Err(format!(
            "the bottom row is [{} {} {} {}]; expected [0 0 0 1]",
            m[(3, 0)],
            m[(3, 1)],
            m[(3, 2)],
            m[(3, 3)]
        ));
    }
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let q = rotation_from_matrix(&r, tol).ok_or_else(|| {
        format!(
            "the top-left 3x3 block is not a rotation (|RᵀR − I| = {:.3e}, det = {:.6}; expected an orthonormal matrix with det +1, within {tol:e})",
            (r.transpose() * r - Matrix3::identity()).norm(),
            r.determinant()
        )
    })?;
    Ok(pose_from_parts(m.fixed_view::<3, 1>(0, 3).into_owned(), q))
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

    #[test]
    fn a_pose_round_trips_through_its_matrix_and_bad_matrices_are_named() {
        let p = pose_from_parts(
            Vector3::new(1.5, -2.0, 30.25),
            UnitQuaternion::from_euler_angles(0.3, -1.2, 2.9),
        );
        let back = pose_from_matrix(&p.to_homogeneous(), 1e-9).unwrap();
        assert!((back.to_homogeneous() - p.to_homogeneous()).norm() < 1e-14);
        let mut m = p.to_homogeneous();
        m[(3, 0)] = 1.0;
        assert!(
            pose_from_matrix(&m, 1e-6)
                .unwrap_err()
                .contains("bottom row")
        );
        let mut m = p.to_homogeneous();
        m[(0, 0)] *= 2.0;
        assert!(
            pose_from_matrix(&m, 1e-6)
                .unwrap_err()
                .contains("not a rotation")
        );
        let reflection = Matrix4::from_diagonal(&nalgebra::Vector4::new(1.0, 1.0, -1.0, 1.0));
        assert!(pose_from_matrix(&reflection, 1e-6).is_err());
        let mut m = p.to_homogeneous();
        m[(1, 3)] = f64::NAN;
        assert!(
            pose_from_matrix(&m, 1e-6)
                .unwrap_err()
                .contains("non-finite")
        );
    }

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
