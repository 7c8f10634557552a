//! Bringing VO poses into the ground-truth frame, as the paper did for ORB-SLAM and DSO: each
//! tracked segment is aligned by its first pose, with its scale taken from the ground truth.
//!
//! For a segment with frames `k ∈ S` (VO poses `(R_k, c_k)` in VO units, ground truth
//! `(R*_k, c*_k)` in mm) and first frame `f`:
//!
//! - rotation of the alignment `R_a = R*_f R_fᵀ` (the first pose matches exactly);
//! - scale `s` (mm per VO unit): least squares over the segment's positions relative to its
//!   first one, `s = Σ_k (R_a (c_k − c_f)) · (c*_k − c*_f) / Σ_k ‖c_k − c_f‖²`, clamped to
//!   `≥ 0` (a single-frame segment or one that never moved gets `s = 0`);
//! - aligned pose `R̂_k = R_a R_k`, `ĉ_k = c*_f + s R_a (c_k − c_f)`.
//!
//! Only the first pose and the scale use the ground truth; rotation and translation drift
//! along the segment remain in the errors.

use endoloc_geometry::Pose;
use nalgebra::{Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::VoError;
use crate::odometry::VoFrame;

/// Alignment of one tracked segment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentAlignment {
    /// Segment index (as in [`VoFrame::segment`]).
    pub segment: usize,
    /// First frame with a pose in the segment (its alignment anchor).
    pub first_frame: usize,
    /// Last frame with a pose in the segment.
    pub last_frame: usize,
    /// Frames of the segment with a pose.
    pub frames: usize,
    /// Scale from the ground truth, mm per VO unit.
    pub scale_mm_per_unit: f64,
    /// Ground-truth path length over the segment's posed frames, mm.
    pub distance_mm: f64,
}

/// The VO result of a whole sequence in the ground-truth frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VoReport {
    /// Aligned camera-to-world pose `T_wc` (mm, ground-truth world frame) per frame; `None`
    /// for frames without a pose.
    pub t_wc: Vec<Option<Pose>>,
    /// Fraction of frames with a pose, in `[0, 1]`.
    pub tracked_fraction: f64,
    /// Frame indices where tracking was lost.
    pub lost_at: Vec<usize>,
    /// One entry per tracked segment, in order.
    pub segments: Vec<SegmentAlignment>,
}

fn finite(p: &Pose) -> bool {
    p.translation.vector.iter().all(|v| v.is_finite())
        && p.rotation.coords.iter().all(|v| v.is_finite())
}

/// Aligns every tracked segment to the ground truth `gt` (`T_wc`, mm, one per frame) as
/// described in the module docs. Returns the aligned poses (`None` where the VO has none) and
/// one [`SegmentAlignment`] per segment.
///
/// # Errors
/// [`VoError::LengthMismatch`] when `gt` does not have one pose per frame;
/// [`VoError::NonFiniteGroundTruth`] for a NaN/∞ ground-truth pose of a posed frame.
pub fn align_segments(
    frames: &[VoFrame],
    gt: &[Pose],
) -> Result<(Vec<Option<Pose>>, Vec<SegmentAlignment>), VoError> {
    if frames.len() != gt.len() {
        return Err(VoError::LengthMismatch {
            vo: frames.len(),
            gt: gt.len(),
        });
    }
    let n_segments = frames
        .iter()
        .filter_map(|f| f.segment.filter(|_| f.t_wc.is_some()))
        .max()
        .map_or(0, |m| m + 1);
    let mut members: Vec<Vec<(usize, Pose)>> = vec![Vec::new(); n_segments];
    for (k, f) in frames.iter().enumerate() {
        if let (Some(s), Some(p)) = (f.segment, f.t_wc) {
            if !finite(&gt[k]) {
                return Err(VoError::NonFiniteGroundTruth { frame: k });
            }
            members[s].push((k, p));
        }
    }
    let mut out: Vec<Option<Pose>> = vec![None; frames.len()];
    let mut segments = Vec::new();
    for (segment, m) in members.iter().enumerate() {
        let Some(&(f0, p0)) = m.first() else {
            continue;
        };
        let g0 = gt[f0];
        let r_a: UnitQuaternion<f64> = g0.rotation * p0.rotation.inverse();
        let c0 = p0.translation.vector;
        let g0c = g0.translation.vector;
        let (mut num, mut den) = (0.0, 0.0);
        for &(k, p) in m {
            let d_vo = r_a * (p.translation.vector - c0);
            let d_gt = gt[k].translation.vector - g0c;
            num += d_vo.dot(&d_gt);
            den += d_vo.norm_squared();
        }
        let s = if den > 0.0 && num.is_finite() {
            (num / den).max(0.0)
        } else {
            0.0
        };
        for &(k, p) in m {
            let c: Vector3<f64> = g0c + r_a * (p.translation.vector - c0) * s;
            out[k] = Some(Pose::from_parts(Translation3::from(c), r_a * p.rotation));
        }
        let distance_mm = m
            .windows(2)
            .map(|w| (gt[w[1].0].translation.vector - gt[w[0].0].translation.vector).norm())
            .sum();
        segments.push(SegmentAlignment {
            segment,
            first_frame: f0,
            last_frame: m.last().map_or(f0, |l| l.0),
            frames: m.len(),
            scale_mm_per_unit: s,
            distance_mm,
        });
    }
    Ok((out, segments))
}

/// The aligned trajectory with the tracked fraction and the loss points.
///
/// `lost_at` is recomputed from the frames' [`crate::TrackStatus::Lost`] statuses.
///
/// # Errors
/// As [`align_segments`].
pub fn report(frames: &[VoFrame], gt: &[Pose]) -> Result<VoReport, VoError> {
    let (t_wc, segments) = align_segments(frames, gt)?;
    let tracked = t_wc.iter().filter(|p| p.is_some()).count();
    let tracked_fraction = if frames.is_empty() {
        0.0
    } else {
        tracked as f64 / frames.len() as f64
    };
    let lost_at = frames
        .iter()
        .filter(|f| f.status == crate::TrackStatus::Lost)
        .map(|f| f.index)
        .collect();
    Ok(VoReport {
        t_wc,
        tracked_fraction,
        lost_at,
        segments,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TrackStatus;
    use endoloc_geometry::{orientation_error_deg, position_error_mm};

    fn frame(index: usize, segment: Option<usize>, t_wc: Option<Pose>) -> VoFrame {
        VoFrame {
            index,
            status: if t_wc.is_some() {
                TrackStatus::Tracked
            } else {
                TrackStatus::Lost
            },
            segment,
            t_wc,
            reason: None,
            features: 0,
            matches: 0,
            inliers: 0,
            keyframe: false,
        }
    }

    /// Two segments, each the ground truth seen through its own similarity transform (VO
    /// frame at its first camera, its own scale): alignment restores the ground truth exactly.
    #[test]
    fn similarity_transformed_segments_align_exactly() {
        let gt: Vec<Pose> = (0..10)
            .map(|k| {
                let t = k as f64;
                Pose::from_parts(
                    Translation3::new(3.0 * t, 0.5 * t * t, -t),
                    UnitQuaternion::from_euler_angles(0.1 * t, 0.05 * t, -0.02 * t),
                )
            })
            .collect();
        let mut frames = Vec::new();
        for (k, g) in gt.iter().enumerate() {
            let (seg, first, scale) = match k {
                0..=4 => (0, 0, 0.25),
                5 => {
                    frames.push(frame(k, None, None));
                    continue;
                }
                _ => (1, 6, 4.0),
            };
            // VO pose: T_first⁻¹ · T_k with translation scaled by 1/scale.
            let rel = gt[first].inverse() * g;
            let vo = Pose::from_parts(
                Translation3::from(rel.translation.vector / scale),
                rel.rotation,
            );
            frames.push(frame(k, Some(seg), Some(vo)));
        }
        let r = report(&frames, &gt).unwrap();
        assert_eq!(r.lost_at, vec![5]);
        assert!((r.tracked_fraction - 0.9).abs() < 1e-12);
        assert_eq!(r.segments.len(), 2);
        assert!((r.segments[0].scale_mm_per_unit - 0.25).abs() < 1e-9);
        assert!((r.segments[1].scale_mm_per_unit - 4.0).abs() < 1e-9);
        assert_eq!(
            (r.segments[1].first_frame, r.segments[1].last_frame),
            (6, 9)
        );
        for (k, (est, g)) in r.t_wc.iter().zip(&gt).enumerate() {
            match est {
                Some(p) => {
                    assert!(position_error_mm(p, g) < 1e-9, "frame {k}");
                    assert!(orientation_error_deg(p, g) < 1e-6, "frame {k}");
                }
                None => assert_eq!(k, 5),
            }
        }
        let mut bad = gt.clone();
        bad[7] = Pose::from_parts(Translation3::new(f64::NAN, 0.0, 0.0), bad[7].rotation);
        assert!(matches!(
            report(&frames, &bad),
            Err(VoError::NonFiniteGroundTruth { frame: 7 })
        ));
    }
}
