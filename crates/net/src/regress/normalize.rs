//! Normalised regression targets and back.
//!
//! - position: `x = (t − mean) / scale`, with `mean` the mean training position (mm) and
//!   `scale` the RMS distance of the training positions from it (mm; 1 mm if they coincide);
//! - rotation: `q = canonical(q_ref⁻¹ ⊗ q_wc)`, the rotation relative to the reference
//!   `q_ref` (the chordal mean of the training rotations), sign chosen so that `w ≥ 0`. Left
//!   multiplication by `q_ref⁻¹` is an isometry of the quaternion 4-space, so the loss is the
//!   same as on absolute quaternions put in the hemisphere around `q_ref`; the sign flip (the
//!   seam of the hemisphere) is at 180° from the reference, where the fewest training
//!   rotations are.
//!
//! OffsetNet uses the same type for relative poses (its mean and reference are those of the
//! training offsets, near zero and the identity).

use crate::NetError;
use endoloc_geometry::pose::pose_from_parts;
use endoloc_geometry::rotation_mean::chordal_mean;
use endoloc_geometry::{Pose, canonical_quaternion};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// How poses map to the network's normalised targets (saved with the model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseNormalizer {
    /// Mean training position, mm (world frame for PoseNet, reference camera frame for
    /// OffsetNet).
    pub position_mean_mm: [f64; 3],
    /// Position scale, mm: RMS distance of the training positions from their mean.
    pub position_scale_mm: f64,
    /// Reference rotation, unit quaternion `x y z w` (`w ≥ 0`).
    pub reference_rotation_xyzw: [f64; 4],
}

impl PoseNormalizer {
    /// Fits the normaliser to training poses.
    ///
    /// # Errors
    /// [`NetError::Config`] for no poses or non-finite values.
    pub fn fit(poses: &[Pose]) -> Result<Self, NetError> {
        if poses.is_empty() {
            return Err(NetError::Config("no poses to normalise".into()));
        }
        let n = poses.len() as f64;
        let mean: Vector3<f64> = poses
            .iter()
            .map(|p| p.translation.vector)
            .sum::<Vector3<f64>>()
            / n;
        let ms = poses
            .iter()
            .map(|p| (p.translation.vector - mean).norm_squared())
            .sum::<f64>()
            / n;
        let scale = if ms.sqrt() > 1e-9 { ms.sqrt() } else { 1.0 };
        let rotations: Vec<UnitQuaternion<f64>> = poses.iter().map(|p| p.rotation).collect();
        let reference = chordal_mean(&rotations)
            .map_err(|e| NetError::Config(format!("training rotations: {e}")))?;
        if !(mean.iter().all(|v| v.is_finite()) && scale.is_finite()) {
            return Err(NetError::Config("training positions are not finite".into()));
        }
        Ok(PoseNormalizer {
            position_mean_mm: [mean.x, mean.y, mean.z],
            position_scale_mm: scale,
            reference_rotation_xyzw: [reference.i, reference.j, reference.k, reference.w],
        })
    }

    /// The reference rotation.
    pub fn reference_rotation(&self) -> UnitQuaternion<f64> {
        let [x, y, z, w] = self.reference_rotation_xyzw;
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
    }

    /// The normalised target of `pose`: position (`[3]`) and unit quaternion relative to the
    /// reference, `x y z w` with `w ≥ 0` (`[4]`).
    pub fn target(&self, pose: &Pose) -> ([f32; 3], [f32; 4]) {
        let t = pose.translation.vector;
        let s = self.position_scale_mm;
        let m = self.position_mean_mm;
        let x = [
            ((t.x - m[0]) / s) as f32,
            ((t.y - m[1]) / s) as f32,
            ((t.z - m[2]) / s) as f32,
        ];
        let q = canonical_quaternion(self.reference_rotation().inverse() * pose.rotation);
        (x, [q.i as f32, q.j as f32, q.k as f32, q.w as f32])
    }

    /// The pose of a network output: position (normalised, ≥ 3 values) and quaternion
    /// relative to the reference (any norm and sign, `x y z w`, ≥ 4 values). A zero or
    /// non-finite quaternion gives the reference rotation.
    pub fn pose_from_output(&self, x: &[f32], q: &[f32]) -> Pose {
        let s = self.position_scale_mm;
        let m = self.position_mean_mm;
        let get = |v: &[f32], i: usize| v.get(i).map_or(0.0, |&a| a as f64);
        let t = Vector3::new(
            get(x, 0) * s + m[0],
            get(x, 1) * s + m[1],
            get(x, 2) * s + m[2],
        );
        let raw = Quaternion::new(get(q, 3), get(q, 0), get(q, 1), get(q, 2));
        let rel = if raw.norm() > 1e-12 && raw.coords.iter().all(|v| v.is_finite()) {
            UnitQuaternion::from_quaternion(raw)
        } else {
            UnitQuaternion::identity()
        };
        pose_from_parts(t, canonical_quaternion(self.reference_rotation() * rel))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use endoloc_geometry::{orientation_error_deg, position_error_mm};

    #[test]
    fn targets_round_trip_and_q_and_minus_q_give_one_target() {
        let poses: Vec<Pose> = (0..20)
            .map(|i| {
                let a = i as f64 * 0.15;
                pose_from_parts(
                    Vector3::new(100.0 + 10.0 * i as f64, -5.0 * i as f64, 3.0),
                    UnitQuaternion::from_euler_angles(0.2, a, -0.5 * a),
                )
            })
            .collect();
        let nz = PoseNormalizer::fit(&poses).unwrap();
        // Positions: zero mean, unit RMS.
        let xs: Vec<[f32; 3]> = poses.iter().map(|p| nz.target(p).0).collect();
        let mean: f32 = xs.iter().map(|x| x[0] + x[1] + x[2]).sum::<f32>() / 20.0;
        let rms: f32 = (xs
            .iter()
            .map(|x| x.iter().map(|v| v * v).sum::<f32>())
            .sum::<f32>()
            / 20.0)
            .sqrt();
        assert!(
            mean.abs() < 1e-5 && (rms - 1.0).abs() < 1e-5,
            "{mean} {rms}"
        );
        for p in &poses {
            let (x, q) = nz.target(p);
            assert!(q[3] >= 0.0);
            let back = nz.pose_from_output(&x, &q);
            assert!(position_error_mm(&back, p) < 1e-3);
            assert!(orientation_error_deg(&back, p) < 1e-3);
            // The same rotation stored with the other sign maps to the same target.
            let flipped = Pose::from_parts(
                p.translation,
                UnitQuaternion::new_unchecked(-p.rotation.into_inner()),
            );
            assert_eq!(nz.target(&flipped), (x, q));
            // A scaled, sign-flipped output is the same pose.
            let q2 = q.map(|v| -3.0 * v);
            assert!(orientation_error_deg(&nz.pose_from_output(&x, &q2), p) < 1e-3);
        }
    }
}
