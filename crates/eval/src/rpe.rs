//! Relative pose error (RPE) over a fixed frame delta, as `evo_rpe tum gt est --delta N
//! --delta_unit f` computes it.
//!
//! On the associated pose lists (ground truth `Q`, estimate `P`, same order), evo takes the
//! index pairs `(i, i+Δ)` — consecutive pairs `(0, Δ), (Δ, 2Δ), …` by default, or every
//! `(i, i+Δ)` with `all_pairs` — and the error pose
//! `E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)`, from which a [`PoseRelation`] takes the scalar
//! (`trans_part` → ‖t_E‖ mm, `angle_deg` → rotation angle of `E`, …).
//!
//! The delta counts *associated* poses: where the estimate misses frames, a pair spans the
//! gap (evo does the same).

use endoloc_geometry::Pose;
use serde::{Deserialize, Serialize};

use crate::EvalError;
use crate::ape::PoseRelation;

/// Settings of the RPE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct RpeConfig {
    /// Index distance between the two poses of a pair, in associated poses (evo `--delta`,
    /// `--delta_unit f`; default 1).
    pub delta_frames: usize,
    /// Every pair `(i, i+Δ)` (true) or only `(0, Δ), (Δ, 2Δ), …` (false, evo's default).
    pub all_pairs: bool,
}

impl Default for RpeConfig {
    fn default() -> Self {
        Self {
            delta_frames: 1,
            all_pairs: false,
        }
    }
}

/// The index pairs evo uses for `n` poses (evo `filter_pairs_by_index`).
pub fn rpe_pairs(n: usize, config: &RpeConfig) -> Vec<(usize, usize)> {
    let d = config.delta_frames;
    if d == 0 {
        return Vec::new();
    }
    if config.all_pairs {
        (0..n).filter(|i| i + d < n).map(|i| (i, i + d)).collect()
    } else {
        let ids: Vec<usize> = (0..n).step_by(d).collect();
        ids.windows(2).map(|w| (w[0], w[1])).collect()
    }
}

/// The relative error pose `(Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` of one pair (TUM RGB-D benchmark
/// notation; translation in mm).
pub fn relative_error_pose(gt_i: &Pose, gt_j: &Pose, est_i: &Pose, est_j: &Pose) -> Pose {
    let q_rel = gt_i.inverse() * gt_j;
    let p_rel = est_i.inverse() * est_j;
    q_rel.inverse() * p_rel
}

/// RPE errors of one relation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RpeErrors {
    /// Index pairs `(i, j)` into the associated lists.
    pub pairs: Vec<(usize, usize)>,
    /// One error per pair, in the relation's unit.
    pub errors: Vec<f64>,
}

/// RPE of `est` against `gt` (associated, same length) for `relation`.
///
/// # Errors
/// [`EvalError::Invalid`] if the lengths differ, `delta_frames` is 0, or no pair exists
/// (fewer than `delta_frames + 1` poses; evo: "produced an empty index list").
pub fn rpe_errors(
    gt: &[Pose],
    est: &[Pose],
    config: &RpeConfig,
    relation: PoseRelation,
) -> Result<RpeErrors, EvalError> {
    if gt.len() != est.len() {
        return Err(EvalError::Invalid(format!(
            "RPE needs as many estimated as ground-truth poses; got {} and {}",
            est.len(),
            gt.len()
        )));
    }
    if config.delta_frames == 0 {
        return Err(EvalError::Invalid(
            "RPE delta must be at least 1 frame".into(),
        ));
    }
    let pairs = rpe_pairs(gt.len(), config);
    if pairs.is_empty() {
        return Err(EvalError::Invalid(format!(
            "RPE with delta {} frames needs at least {} associated poses; got {}",
            config.delta_frames,
            config.delta_frames + 1,
            gt.len()
        )));
    }
    let identity = Pose::identity();
    let errors = pairs
        .iter()
        .map(|&(i, j)| {
            let e = relative_error_pose(&gt[i], &gt[j], &est[i], &est[j]);
            // E against the identity: the relation then measures E itself (‖t_E‖, the
            // angle of E; for `rot_part`/`full` it sees E⁻¹, whose ‖· − I‖_F equals E's).
            relation.error(&e, &identity)
        })
        .collect();
    Ok(RpeErrors { pairs, errors })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    #[test]
    fn pairs_like_evo() {
        let c = |d, all| RpeConfig {
            delta_frames: d,
            all_pairs: all,
        };
        assert_eq!(
            rpe_pairs(5, &c(1, false)),
            vec![(0, 1), (1, 2), (2, 3), (3, 4)]
        );
        assert_eq!(rpe_pairs(6, &c(2, false)), vec![(0, 2), (2, 4)]);
        assert_eq!(rpe_pairs(5, &c(2, true)), vec![(0, 2), (1, 3), (2, 4)]);
        assert!(rpe_pairs(1, &c(1, false)).is_empty());
    }

    #[test]
    fn constant_offset_has_no_relative_error_but_drift_does() {
        let gt: Vec<Pose> = (0..6)
            .map(|i| {
                Pose::from_parts(
                    Translation3::new(i as f64 * 2.0, 0.0, 0.0),
                    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.1 * i as f64),
                )
            })
            .collect();
        // A rigid change of world frame leaves relative motion unchanged.
        let w = Pose::from_parts(
            Translation3::new(5.0, -3.0, 1.0),
            UnitQuaternion::from_euler_angles(0.3, 0.2, 0.1),
        );
        let est: Vec<Pose> = gt.iter().map(|p| w * p).collect();
        let r = rpe_errors(&gt, &est, &RpeConfig::default(), PoseRelation::TransPart).unwrap();
        assert_eq!(r.errors.len(), 5);
        assert!(r.errors.iter().all(|e| *e < 1e-12), "{:?}", r.errors);
        // An estimate that moves 2.5 mm per step instead of 2 mm along the camera path.
        let est: Vec<Pose> = gt
            .iter()
            .enumerate()
            .map(|(i, p)| Pose::from_parts(Translation3::new(i as f64 * 2.5, 0.0, 0.0), p.rotation))
            .collect();
        let r = rpe_errors(&gt, &est, &RpeConfig::default(), PoseRelation::TransPart).unwrap();
        assert!(
            r.errors.iter().all(|e| (e - 0.5).abs() < 1e-12),
            "{:?}",
            r.errors
        );
        let a = rpe_errors(&gt, &est, &RpeConfig::default(), PoseRelation::AngleDeg).unwrap();
        assert!(a.errors.iter().all(|e| *e < 1e-9));
        assert!(
            rpe_errors(
                &gt[..1],
                &est[..1],
                &RpeConfig::default(),
                PoseRelation::TransPart
            )
            .is_err()
        );
    }
}
