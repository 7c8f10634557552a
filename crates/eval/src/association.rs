//! Timestamp association of an estimated trajectory with the ground truth, exactly as evo's
//! `evo.core.sync.associate_trajectories` (nearest timestamp, `--t_max_diff`, `--t_offset`).
//!
//! evo starts from the trajectory with fewer poses (the estimate when both have as many), and
//! for each of its timestamps, in file order, takes the nearest timestamp of the other one
//! within `max_diff_s`; a tie goes to the earlier pose. If the longer trajectory's timestamps
//! are not sorted, a linear search takes the first nearest one. The offset is added to the
//! estimate's timestamps for the association only.

use serde::{Deserialize, Serialize};

use crate::EvalError;

/// How timestamps are matched.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AssociationConfig {
    /// Largest accepted |t_gt − (t_est + offset)|, seconds (evo `--t_max_diff`, default 0.01).
    pub max_diff_s: f64,
    /// Constant added to the estimate's timestamps before matching, seconds (evo `--t_offset`).
    pub offset_s: f64,
}

impl Default for AssociationConfig {
    fn default() -> Self {
        Self {
            max_diff_s: 0.01,
            offset_s: 0.0,
        }
    }
}

/// One ground-truth pose matched with one estimated pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MatchedPair {
    /// Index of the pose in the ground-truth file (0-based, comment lines not counted), which
    /// is the test frame index.
    pub gt_index: usize,
    /// Index of the pose in the estimate file (0-based).
    pub est_index: usize,
}

/// The result of [`associate`]: matched pairs in evo's order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Association {
    /// Matched pairs, in the order of the shorter trajectory (evo's order; the estimate's when
    /// both have as many poses).
    pub pairs: Vec<MatchedPair>,
    /// Poses in the ground truth.
    pub gt_poses: usize,
    /// Poses in the estimate.
    pub est_poses: usize,
}

/// For each timestamp of `stamps_1` (in order), the index of the nearest one in
/// `stamps_2 + offset_2` within `max_diff`; returns the two index lists (evo's
/// `matching_time_indices`).
///
/// Timestamps are in seconds.
pub fn matching_time_indices(
    stamps_1: &[f64],
    stamps_2: &[f64],
    max_diff: f64,
    offset_2: f64,
) -> (Vec<usize>, Vec<usize>) {
    let stamps_2: Vec<f64> = stamps_2.iter().map(|t| t + offset_2).collect();
    let mut idx_1 = Vec::new();
    let mut idx_2 = Vec::new();
    let Some((&first, &last)) = stamps_2.first().zip(stamps_2.last()) else {
        return (idx_1, idx_2);
    };
    let sorted = stamps_2.windows(2).all(|w| w[1] - w[0] >= 0.0);
    if !sorted {
        for (i1, &s1) in stamps_1.iter().enumerate() {
            // First index of the smallest |difference| (numpy argmin).
            let mut best = 0usize;
            let mut best_diff = f64::INFINITY;
            for (i2, &s2) in stamps_2.iter().enumerate() {
                let d = (s2 - s1).abs();
                if d < best_diff {
                    best_diff = d;
                    best = i2;
                }
            }
            if best_diff <= max_diff {
                idx_1.push(i1);
                idx_2.push(best);
            }
        }
        return (idx_1, idx_2);
    }
    for (i1, &s1) in stamps_1.iter().enumerate() {
        if s1 < first - max_diff || s1 > last + max_diff {
            continue;
        }
        // numpy.searchsorted(side="right"): first index with stamps_2[i] > s1.
        let mut i2 = stamps_2.partition_point(|&t| t <= s1);
        if i2 >= stamps_2.len() {
            i2 = stamps_2.len() - 1;
        }
        let diff_ub = stamps_2[i2] - s1;
        let diff_lb = if i2 > 0 {
            s1 - stamps_2[i2 - 1]
        } else {
            f64::INFINITY
        };
        let best = if diff_ub <= max_diff && diff_ub < diff_lb {
            i2
        } else if diff_lb <= max_diff && diff_lb <= diff_ub {
            i2 - 1
        } else {
            continue;
        };
        idx_1.push(i1);
        idx_2.push(best);
    }
    (idx_1, idx_2)
}

/// Associates estimated poses with ground-truth poses by timestamp (seconds), as
/// `evo_ape tum gt est --t_max_diff max_diff_s --t_offset offset_s` does.
///
/// # Errors
/// [`EvalError::Invalid`] if `max_diff_s` is negative or not finite;
/// [`EvalError::NoAssociation`] if no pair matches.
pub fn associate(
    gt_stamps_s: &[f64],
    est_stamps_s: &[f64],
    config: &AssociationConfig,
) -> Result<Association, EvalError> {
    let valid =
        config.max_diff_s.is_finite() && config.max_diff_s >= 0.0 && config.offset_s.is_finite();
    if !valid {
        return Err(EvalError::Invalid(format!(
            "association: max. time difference must be finite and ≥ 0 and the offset finite; got {} s and {} s",
            config.max_diff_s, config.offset_s
        )));
    }
    // evo: traj_1 = reference, traj_2 = estimate; start from the shorter one.
    let second_longer = est_stamps_s.len() > gt_stamps_s.len();
    let pairs: Vec<MatchedPair> = if second_longer {
        let (g, e) = matching_time_indices(
            gt_stamps_s,
            est_stamps_s,
            config.max_diff_s,
            config.offset_s,
        );
        g.into_iter()
            .zip(e)
            .map(|(gt_index, est_index)| MatchedPair {
                gt_index,
                est_index,
            })
            .collect()
    } else {
        let (e, g) = matching_time_indices(
            est_stamps_s,
            gt_stamps_s,
            config.max_diff_s,
            -config.offset_s,
        );
        e.into_iter()
            .zip(g)
            .map(|(est_index, gt_index)| MatchedPair {
                gt_index,
                est_index,
            })
            .collect()
    };
    if pairs.is_empty() {
        return Err(EvalError::NoAssociation {
            gt_poses: gt_stamps_s.len(),
            est_poses: est_stamps_s.len(),
            max_diff_s: config.max_diff_s,
            offset_s: config.offset_s,
        });
    }
    Ok(Association {
        pairs,
        gt_poses: gt_stamps_s.len(),
        est_poses: est_stamps_s.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pairs(a: &Association) -> Vec<(usize, usize)> {
        a.pairs.iter().map(|p| (p.gt_index, p.est_index)).collect()
    }

    #[test]
    fn missing_estimates_are_skipped() {
        let gt: Vec<f64> = (0..10).map(|i| i as f64 * 0.1).collect();
        let est = [0.0, 0.2, 0.3, 0.9];
        let a = associate(&gt, &est, &AssociationConfig::default()).unwrap();
        assert_eq!(pairs(&a), vec![(0, 0), (2, 1), (3, 2), (9, 3)]);
    }

    #[test]
    fn extra_estimates_and_jitter() {
        // The estimate has more poses than the ground truth: evo starts from the ground truth.
        let gt = [1.0, 2.0, 3.0];
        let est = [0.5, 1.004, 1.5, 2.02, 2.996, 3.5];
        let a = associate(&gt, &est, &AssociationConfig::default()).unwrap();
        // 2.0 has no estimate within 10 ms.
        assert_eq!(pairs(&a), vec![(0, 1), (2, 4)]);
        let loose = AssociationConfig {
            max_diff_s: 0.05,
            ..Default::default()
        };
        let a = associate(&gt, &est, &loose).unwrap();
        assert_eq!(pairs(&a), vec![(0, 1), (1, 3), (2, 4)]);
    }

    #[test]
    fn tie_goes_to_the_earlier_pose_and_offset_applies_to_the_estimate() {
        let gt = [0.0, 0.02];
        let est = [0.01];
        let a = associate(
            &gt,
            &est,
            &AssociationConfig {
                max_diff_s: 0.01,
                offset_s: 0.0,
            },
        )
        .unwrap();
        assert_eq!(pairs(&a), vec![(0, 0)]);
        let a = associate(
            &gt,
            &[10.02],
            &AssociationConfig {
                max_diff_s: 0.001,
                offset_s: -10.0,
            },
        )
        .unwrap();
        assert_eq!(pairs(&a), vec![(1, 0)]);
    }

    #[test]
    fn unsorted_timestamps_use_linear_search() {
        let gt = [0.3, 0.1, 0.2];
        let est = [0.1, 0.2];
        let a = associate(&gt, &est, &AssociationConfig::default()).unwrap();
        assert_eq!(pairs(&a), vec![(1, 0), (2, 1)]);
    }

    #[test]
    fn no_match_is_an_error() {
        let e = associate(&[0.0, 1.0], &[5.0], &AssociationConfig::default()).unwrap_err();
        assert!(e.to_string().contains("no matching timestamps"), "{e}");
        let e = associate(
            &[0.0],
            &[0.0],
            &AssociationConfig {
                max_diff_s: -1.0,
                offset_s: 0.0,
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("≥ 0"), "{e}");
    }
}
