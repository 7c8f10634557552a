//! Timestamp association of an estimated trajectory with the ground truth, exactly as evo's
//! `evo.core.sync.associate_trajectories` (nearest timestamp, `--t_max_diff`, `--t_offset`).
//!
//! evo starts from the trajectory with fewer poses (the estimate when both have as many), and
//! for each of its timestamps, in file order, takes the nearest timestamp of the other one
//! within `max_diff_s`; a tie goes to the earlier pose. If the longer trajectory's timestamps
//! are not sorted, a linear search takes the first nearest one. The offset is added to the
//! estimate's timestamps for the association only.

use endoloc_data::StampedPose;
use endoloc_geometry::Pose;
use serde::{Deserialize, Serialize};

use crate::EvalError;
use crate::source::Rows;

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
    check_config(config)?;
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

/// Count and first and last time stamps of a trajectory, seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TrajectoryScan {
    pub count: usize,
    pub first_s: f64,
    pub last_s: f64,
}

impl TrajectoryScan {
    /// Reads `rows` once; `name` names the trajectory in the error when its time stamps do
    /// not increase strictly.
    pub(crate) fn read(rows: Rows<'_, StampedPose>, name: &str) -> Result<Self, EvalError> {
        let mut scan = Self {
            count: 0,
            first_s: f64::NAN,
            last_s: f64::NAN,
        };
        for p in rows {
            let t = p?.timestamp_s;
            if scan.count == 0 {
                scan.first_s = t;
            } else if t.is_nan() || t <= scan.last_s {
                return Err(EvalError::Invalid(format!(
                    "{name}: pose {} has time stamp {t} s, not after the previous pose's {} s; \
                     expected strictly increasing time stamps",
                    scan.count, scan.last_s
                )));
            }
            scan.last_s = t;
            scan.count += 1;
        }
        Ok(scan)
    }
}

/// One associated pair with both poses (`T_wc`, mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PosePair {
    pub gt_index: usize,
    pub est_index: usize,
    pub gt: Pose,
    pub est: Pose,
}

/// The nearest-time-stamp search of [`matching_time_indices`] over a sorted trajectory read
/// once from front to back, for query time stamps that do not decrease.
struct Nearest<'a> {
    rows: Rows<'a, StampedPose>,
    offset_s: f64,
    first_s: f64,
    last_s: f64,
    next_index: usize,
    prev: Option<(usize, Pose, f64)>,
    cur: Option<(usize, Pose, f64)>,
}

impl Nearest<'_> {
    fn pull(&mut self) -> Result<Option<(usize, Pose, f64)>, EvalError> {
        let Some(p) = self.rows.next().transpose()? else {
            return Ok(None);
        };
        let i = self.next_index;
        self.next_index += 1;
        Ok(Some((i, p.pose, p.timestamp_s + self.offset_s)))
    }

    fn find(&mut self, s1: f64, max_diff: f64) -> Result<Option<(usize, Pose)>, EvalError> {
        if s1 < self.first_s - max_diff || s1 > self.last_s + max_diff {
            return Ok(None);
        }
        if self.cur.is_none() {
            self.cur = self.pull()?;
        }
        let Some(mut cur) = self.cur else {
            return Ok(None);
        };
        // numpy.searchsorted(side="right"), clamped to the last pose.
        while cur.2 <= s1 {
            match self.pull()? {
                Some(next) => {
                    self.prev = Some(cur);
                    cur = next;
                }
                None => break,
            }
        }
        self.cur = Some(cur);
        let diff_ub = cur.2 - s1;
        let diff_lb = self.prev.map_or(f64::INFINITY, |p| s1 - p.2);
        Ok(if diff_ub <= max_diff && diff_ub < diff_lb {
            Some((cur.0, cur.1))
        } else if diff_lb <= max_diff && diff_lb <= diff_ub {
            self.prev.map(|p| (p.0, p.1))
        } else {
            None
        })
    }
}

/// The pairs of [`associate`], with their poses, read in one pass over both trajectories
/// (which must be sorted by time), in evo's order.
pub(crate) struct PairStream<'a> {
    short: Rows<'a, StampedPose>,
    short_index: usize,
    long: Nearest<'a>,
    /// The estimate is the longer trajectory (searched); the ground truth is walked.
    est_longer: bool,
    max_diff_s: f64,
}

impl<'a> PairStream<'a> {
    /// Pairs of `gt` and `est` (fresh streams of the scanned trajectories).
    pub(crate) fn new(
        gt: Rows<'a, StampedPose>,
        est: Rows<'a, StampedPose>,
        gt_scan: &TrajectoryScan,
        est_scan: &TrajectoryScan,
        config: &AssociationConfig,
    ) -> Self {
        let est_longer = est_scan.count > gt_scan.count;
        let (short, long, long_scan, offset_s) = if est_longer {
            (gt, est, est_scan, config.offset_s)
        } else {
            (est, gt, gt_scan, -config.offset_s)
        };
        Self {
            short,
            short_index: 0,
            long: Nearest {
                rows: long,
                offset_s,
                first_s: long_scan.first_s + offset_s,
                last_s: long_scan.last_s + offset_s,
                next_index: 0,
                prev: None,
                cur: None,
            },
            est_longer,
            max_diff_s: config.max_diff_s,
        }
    }

    fn step(&mut self) -> Result<Option<PosePair>, EvalError> {
        if self.long.first_s.is_nan() {
            return Ok(None);
        }
        while let Some(a) = self.short.next().transpose()? {
            let ia = self.short_index;
            self.short_index += 1;
            if let Some((ib, pose_b)) = self.long.find(a.timestamp_s, self.max_diff_s)? {
                return Ok(Some(if self.est_longer {
                    PosePair {
                        gt_index: ia,
                        est_index: ib,
                        gt: a.pose,
                        est: pose_b,
                    }
                } else {
                    PosePair {
                        gt_index: ib,
                        est_index: ia,
                        gt: pose_b,
                        est: a.pose,
                    }
                }));
            }
        }
        Ok(None)
    }
}

impl Iterator for PairStream<'_> {
    type Item = Result<PosePair, EvalError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.step().transpose()
    }
}

/// Checks `config` as [`associate`] does.
pub(crate) fn check_config(config: &AssociationConfig) -> Result<(), EvalError> {
    let valid =
        config.max_diff_s.is_finite() && config.max_diff_s >= 0.0 && config.offset_s.is_finite();
    if valid {
        Ok(())
    } else {
        Err(EvalError::Invalid(format!(
            "association: max. time difference must be finite and ≥ 0 and the offset finite; got {} s and {} s",
            config.max_diff_s, config.offset_s
        )))
    }
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

    fn stamped(ts: &[f64]) -> Vec<StampedPose> {
        ts.iter()
            .map(|&t| StampedPose {
                timestamp_s: t,
                pose: Pose::translation(t, 0.0, 0.0),
            })
            .collect()
    }

    #[test]
    fn the_stream_pairs_as_the_whole_association_does() {
        let cases: [(&[f64], &[f64], f64, f64); 6] = [
            (&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 3.0], 0.01, 0.0),
            (
                &[0.0, 1.0, 2.0],
                &[0.0, 0.004, 0.995, 1.005, 2.0, 5.0],
                0.01,
                0.0,
            ),
            (&[0.0, 1.0, 2.0, 3.0], &[0.5, 1.5, 2.5], 0.5, 0.0),
            (&[0.0, 1.0, 2.0], &[0.1, 1.1, 2.1, 3.1], 0.02, -0.1),
            (&[0.0, 0.1, 0.2, 0.3, 0.4], &[0.05, 0.25], 0.05, 0.0),
            (&[10.0, 11.0], &[0.0, 1.0, 2.0], 0.01, 0.0),
        ];
        for (k, (g, e, max_diff_s, offset_s)) in cases.into_iter().enumerate() {
            let config = AssociationConfig {
                max_diff_s,
                offset_s,
            };
            let whole = associate(g, e, &config)
                .map(|a| pairs(&a))
                .unwrap_or_default();
            let (gs, es) = (stamped(g), stamped(e));
            fn rows(v: &[StampedPose]) -> Rows<'_, StampedPose> {
                Box::new(v.iter().copied().map(Ok))
            }
            let gscan = TrajectoryScan::read(rows(&gs), "gt").unwrap();
            let escan = TrajectoryScan::read(rows(&es), "est").unwrap();
            let streamed: Vec<(usize, usize)> =
                PairStream::new(rows(&gs), rows(&es), &gscan, &escan, &config)
                    .map(|p| {
                        let p = p.unwrap();
                        assert_eq!(p.gt, gs[p.gt_index].pose);
                        assert_eq!(p.est, es[p.est_index].pose);
                        (p.gt_index, p.est_index)
                    })
                    .collect();
            assert_eq!(streamed, whole, "case {k}");
        }
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
