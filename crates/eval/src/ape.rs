//! Absolute pose error (APE), with evo's pose relations (`evo_ape -r ...`).
//!
//! For an estimated pose `P` and its ground truth `Q` (both `T_wc`, mm), evo's error pose is
//! `E = P⁻¹ Q`. The relations:
//! - `trans_part` (evo's default): `‖t_P − t_Q‖`, mm — the same as
//!   [`endoloc_geometry::position_error_mm`];
//! - `angle_deg` / `angle_rad`: the rotation angle of `R_Pᵀ R_Q` — the same as
//!   [`endoloc_geometry::orientation_error_deg`] (docs/CONVENTIONS.md's rotation error);
//! - `rot_part`: `‖R_Pᵀ R_Q − I‖_F`, dimensionless (the *chordal* distance, equal to
//!   `2√2·sin(θ/2)`, not an angle);
//! - `full`: `‖E − I‖_F` over the 4×4 matrix, mixing mm and the chordal term.

use endoloc_geometry::{Pose, orientation_error_deg, position_error_mm};
use nalgebra::Matrix4;
use serde::{Deserialize, Serialize};

use crate::EvalError;

/// Which scalar is taken from the error pose (evo's `--pose_relation`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseRelation {
    /// `‖t_est − t_gt‖`, mm (evo `trans_part`).
    TransPart,
    /// `‖R_estᵀ R_gt − I‖_F`, dimensionless (evo `rot_part`).
    RotPart,
    /// `‖T_est⁻¹ T_gt − I‖_F` of the 4×4 matrices (evo `full`).
    Full,
    /// Geodesic angle of `R_estᵀ R_gt`, degrees (evo `angle_deg`).
    AngleDeg,
    /// Geodesic angle of `R_estᵀ R_gt`, radians (evo `angle_rad`).
    AngleRad,
}

impl PoseRelation {
    /// All relations, in a fixed order.
    pub const ALL: [PoseRelation; 5] = [
        PoseRelation::TransPart,
        PoseRelation::RotPart,
        PoseRelation::Full,
        PoseRelation::AngleDeg,
        PoseRelation::AngleRad,
    ];

    /// evo's name for the relation: `trans_part`, `rot_part`, `full`, `angle_deg`, `angle_rad`.
    pub fn evo_name(&self) -> &'static str {
        match self {
            PoseRelation::TransPart => "trans_part",
            PoseRelation::RotPart => "rot_part",
            PoseRelation::Full => "full",
            PoseRelation::AngleDeg => "angle_deg",
            PoseRelation::AngleRad => "angle_rad",
        }
    }

    /// The relation with evo's name `name`.
    ///
    /// # Errors
    /// [`EvalError::Invalid`] listing the accepted names.
    pub fn from_evo_name(name: &str) -> Result<Self, EvalError> {
        Self::ALL
            .into_iter()
            .find(|r| r.evo_name() == name)
            .ok_or_else(|| {
                EvalError::Invalid(format!(
                    "unknown pose relation {name:?}; expected one of trans_part, rot_part, full, angle_deg, angle_rad"
                ))
            })
    }

    /// The scalar error of `est` against `gt` for this relation (units above).
    pub fn error(&self, est: &Pose, gt: &Pose) -> f64 {
        match self {
            PoseRelation::TransPart => position_error_mm(est, gt),
            PoseRelation::AngleDeg => orientation_error_deg(est, gt),
            PoseRelation::AngleRad => orientation_error_deg(est, gt).to_radians(),
            PoseRelation::RotPart => {
                let r = est.rotation.to_rotation_matrix().matrix().transpose()
                    * gt.rotation.to_rotation_matrix().matrix();
                (r - nalgebra::Matrix3::identity()).norm()
            }
            PoseRelation::Full => {
                let e: Matrix4<f64> = (est.inverse() * gt).to_homogeneous();
                (e - Matrix4::identity()).norm()
            }
        }
    }
}

/// APE of `est[i]` against `gt[i]` for every `i` (already associated, same length).
///
/// # Errors
/// [`EvalError::Invalid`] if the lengths differ or the lists are empty.
pub fn ape_errors(
    gt: &[Pose],
    est: &[Pose],
    relation: PoseRelation,
) -> Result<Vec<f64>, EvalError> {
    if gt.len() != est.len() || gt.is_empty() {
        return Err(EvalError::Invalid(format!(
            "APE needs as many estimated as ground-truth poses, at least one; got {} and {}",
            est.len(),
            gt.len()
        )));
    }
    Ok(gt
        .iter()
        .zip(est)
        .map(|(g, e)| relation.error(e, g))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    #[test]
    fn relations_on_a_known_pose_pair() {
        let gt = Pose::from_parts(
            Translation3::new(10.0, 0.0, 0.0),
            UnitQuaternion::identity(),
        );
        let theta = 0.3f64;
        let est = Pose::from_parts(
            Translation3::new(10.0, 3.0, 4.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta),
        );
        let r = |rel: PoseRelation| rel.error(&est, &gt);
        assert!((r(PoseRelation::TransPart) - 5.0).abs() < 1e-12);
        assert!((r(PoseRelation::AngleRad) - theta).abs() < 1e-12);
        assert!((r(PoseRelation::AngleDeg) - theta.to_degrees()).abs() < 1e-10);
        let chordal = 2.0 * 2f64.sqrt() * (theta / 2.0).sin();
        assert!((r(PoseRelation::RotPart) - chordal).abs() < 1e-12);
        // full: the rotation block contributes the chordal term, the translation block
        // ‖R_estᵀ (t_gt − t_est)‖ = 5.
        let full = (chordal * chordal + 25.0).sqrt();
        assert!((r(PoseRelation::Full) - full).abs() < 1e-12);
        for rel in PoseRelation::ALL {
            assert_eq!(PoseRelation::from_evo_name(rel.evo_name()).unwrap(), rel);
        }
        assert!(PoseRelation::from_evo_name("angle").is_err());
    }
}
