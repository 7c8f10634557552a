//! The evaluation of one localization run and its `metrics.json`.
//!
//! [`evaluate`] associates the estimate with the ground truth by timestamp (evo's rule,
//! [`crate::association`]), optionally aligns it ([`crate::align`]), and computes:
//! - `position_mm` / `orientation_deg`: APE statistics (evo `trans_part` / `angle_deg`);
//! - `rpe`: relative pose error over `delta_frames` associated poses (evo_rpe);
//! - `frames`, `localized`, `localized_fraction`: ground-truth frames, how many have an
//!   associated estimate, and the ratio;
//! - with `frames.csv`: counts per status and errors per status;
//! - with ground-truth zones and `frames.csv`: `zone_accuracy` (predicted zone = true zone,
//!   over the frames whose true zone is known; a frame without a prediction counts as wrong)
//!   and `zone_within_one` (|predicted − true| ≤ 1);
//! - `per_zone`: a table keyed by the true zone when known, else by the predicted zone.
//!
//! The frame index of a ground-truth pose is its line order in the file (docs/CONVENTIONS.md).

use std::collections::BTreeMap;

use endoloc_data::StampedPose;
use endoloc_geometry::{Pose, Status};
use serde::{Deserialize, Serialize};

use crate::EvalError;
use crate::align::{AlignmentKind, Similarity3, align_trajectory};
use crate::ape::{PoseRelation, ape_errors};
use crate::association::{AssociationConfig, associate};
use crate::frames_csv::FrameRecord;
use crate::rpe::{RpeConfig, rpe_errors};
use crate::stats::Statistics;
use crate::zones_csv::ZoneLabel;

/// Identifies the layout of `metrics.json`.
pub const METRICS_FORMAT: &str = "endoloc-metrics/1";

/// Settings of an evaluation (saved in `metrics.json`, so a run can be repeated).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct EvalConfig {
    /// Timestamp association (evo `--t_max_diff`, `--t_offset`).
    pub association: AssociationConfig,
    /// Alignment applied to the estimate before any error (none by default).
    pub alignment: AlignmentKind,
    /// Relative pose error settings.
    pub rpe: RpeConfig,
}

/// What is evaluated: trajectories and the optional per-frame files.
#[derive(Debug, Clone, Copy)]
pub struct EvalInputs<'a> {
    /// Ground truth of the test sequence (its `poses.txt`), one pose per frame.
    pub gt: &'a [StampedPose],
    /// Estimated poses (the run's `trajectory.txt`).
    pub est: &'a [StampedPose],
    /// The run's `frames.csv` rows, if any.
    pub frames: Option<&'a [FrameRecord]>,
    /// True zones of the test frames, if known.
    pub gt_zones: Option<&'a [ZoneLabel]>,
}

/// The error of one test frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameEvaluation {
    /// 0-based test frame index.
    pub frame: usize,
    /// Ground-truth timestamp, seconds.
    pub timestamp_s: f64,
    /// Ground-truth pose `T_wc`, mm.
    pub gt: Pose,
    /// Estimated pose `T_wc` (after alignment, if any), mm; `None` if not localized.
    pub est: Option<Pose>,
    /// Position error, mm.
    pub position_mm: Option<f64>,
    /// Orientation error, degrees.
    pub orientation_deg: Option<f64>,
    /// Status from `frames.csv`.
    pub status: Option<Status>,
    /// Predicted zone from `frames.csv`.
    pub zone: Option<usize>,
    /// True zone.
    pub gt_zone: Option<usize>,
}

/// Position and orientation error statistics of a group of frames.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorSummary {
    /// Position error, mm.
    pub position_mm: Statistics,
    /// Orientation error, degrees.
    pub orientation_deg: Statistics,
}

/// Relative pose error statistics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RpeMetrics {
    /// Index distance between the poses of a pair, in associated poses.
    pub delta_frames: usize,
    /// Every `(i, i+Δ)` pair (true) or consecutive pairs only (false).
    pub all_pairs: bool,
    /// Translation part of the relative error, mm (evo_rpe `trans_part`).
    pub translation_mm: Statistics,
    /// Rotation angle of the relative error, degrees (evo_rpe `angle_deg`).
    pub rotation_deg: Statistics,
}

/// Number of `frames.csv` rows per status.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct StatusCounts {
    /// Rows with status `refined`.
    pub refined: usize,
    /// Rows with status `init_only`.
    pub init_only: usize,
    /// Rows with status `rejected`.
    pub rejected: usize,
    /// Ground-truth frames without a row.
    pub without_row: usize,
}

/// Where the per-zone table's zone comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ZoneSource {
    /// The true zone (`--gt-zones`).
    GroundTruth,
    /// The zone predicted by the localizer (`frames.csv`).
    Predicted,
}

/// One row of the per-zone table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ZoneRow {
    /// Zone index.
    pub zone: usize,
    /// Frames in the zone.
    pub frames: usize,
    /// Frames in the zone with an estimated pose.
    pub localized: usize,
    /// Mean position error, mm (`None` when nothing was localized).
    pub position_mm_mean: Option<f64>,
    /// Median position error, mm.
    pub position_mm_median: Option<f64>,
    /// Mean orientation error, degrees.
    pub orientation_deg_mean: Option<f64>,
    /// Median orientation error, degrees.
    pub orientation_deg_median: Option<f64>,
    /// Fraction of the zone's frames classified into it (only when keyed by the true zone
    /// and predictions are known).
    pub zone_accuracy: Option<f64>,
}

/// How the trajectories were associated.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AssociationSummary {
    /// Settings used.
    pub config: AssociationConfig,
    /// Poses in the ground truth.
    pub gt_poses: usize,
    /// Poses in the estimate.
    pub est_poses: usize,
    /// Matched pairs (the number of APE errors).
    pub matched: usize,
    /// Estimated poses matched with no ground-truth pose.
    pub unmatched_est: usize,
}

/// The alignment applied.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AlignmentSummary {
    /// Which alignment.
    pub kind: AlignmentKind,
    /// Rotation matrix, rows (identity when none).
    pub rotation: [[f64; 3]; 3],
    /// Translation, mm.
    pub translation_mm: [f64; 3],
    /// Scale (1 unless Sim(3)).
    pub scale: f64,
}

/// The content of `metrics.json` (docs/CONVENTIONS.md: results on disk).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Layout identifier, [`METRICS_FORMAT`].
    pub format: String,
    /// Test frames (ground-truth poses).
    pub frames: usize,
    /// Test frames with an associated estimated pose.
    pub localized: usize,
    /// `localized / frames`.
    pub localized_fraction: f64,
    /// Position error over the associated poses, mm (evo_ape `trans_part`).
    pub position_mm: Statistics,
    /// Orientation error over the associated poses, degrees (evo_ape `angle_deg`).
    pub orientation_deg: Statistics,
    /// Relative pose error (`None` with fewer than `delta_frames + 1` associated poses).
    pub rpe: Option<RpeMetrics>,
    /// Fraction of frames with a known true zone whose predicted zone equals it.
    pub zone_accuracy: Option<f64>,
    /// Fraction of frames with a known true zone predicted within one zone of it.
    pub zone_within_one: Option<f64>,
    /// Frames with a known true zone (the denominator of the zone accuracies).
    pub zone_frames: Option<usize>,
    /// `frames.csv` rows per status.
    pub status_counts: Option<StatusCounts>,
    /// Errors of the localized frames per `frames.csv` status (`refined`, `init_only`, ...).
    pub by_status: BTreeMap<String, ErrorSummary>,
    /// Where `per_zone`'s zone comes from.
    pub zone_source: Option<ZoneSource>,
    /// Per-zone table.
    pub per_zone: Vec<ZoneRow>,
    /// Association details.
    pub association: AssociationSummary,
    /// Alignment details.
    pub alignment: AlignmentSummary,
    /// Settings used.
    pub config: EvalConfig,
}

/// An evaluated run: the metrics and the per-frame errors behind them.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// The summary written to `metrics.json`.
    pub metrics: Metrics,
    /// One entry per ground-truth frame, in frame order.
    pub frames: Vec<FrameEvaluation>,
}

fn summary(pos: &[f64], rot: &[f64], what: &str) -> Result<ErrorSummary, EvalError> {
    Ok(ErrorSummary {
        position_mm: Statistics::from_errors(pos, &format!("{what} position"))?,
        orientation_deg: Statistics::from_errors(rot, &format!("{what} orientation"))?,
    })
}

/// Evaluates a run.
///
/// # Errors
/// [`EvalError::NoAssociation`] if no estimated pose matches a ground-truth timestamp;
/// [`EvalError::Alignment`] if the requested alignment is degenerate;
/// [`EvalError::Invalid`] if `frames.csv` or the zones name a frame the ground truth does not
/// have, or the settings are invalid (e.g. RPE delta 0).
pub fn evaluate(inputs: &EvalInputs<'_>, config: &EvalConfig) -> Result<Evaluation, EvalError> {
    let n = inputs.gt.len();
    if config.rpe.delta_frames == 0 {
        return Err(EvalError::Invalid(
            "RPE delta must be at least 1 frame".into(),
        ));
    }
    let gt_stamps: Vec<f64> = inputs.gt.iter().map(|p| p.timestamp_s).collect();
    let est_stamps: Vec<f64> = inputs.est.iter().map(|p| p.timestamp_s).collect();
    let assoc = associate(&gt_stamps, &est_stamps, &config.association)?;
    let gt_poses: Vec<Pose> = assoc
        .pairs
        .iter()
        .map(|p| inputs.gt[p.gt_index].pose)
        .collect();
    let est_raw: Vec<Pose> = assoc
        .pairs
        .iter()
        .map(|p| inputs.est[p.est_index].pose)
        .collect();
    let (sim, est_poses) = align_trajectory(&gt_poses, &est_raw, config.alignment)?;
    let pos = ape_errors(&gt_poses, &est_poses, PoseRelation::TransPart)?;
    let rot = ape_errors(&gt_poses, &est_poses, PoseRelation::AngleDeg)?;

    let rpe = if assoc.pairs.len() > config.rpe.delta_frames {
        let t = rpe_errors(&gt_poses, &est_poses, &config.rpe, PoseRelation::TransPart)?;
        let r = rpe_errors(&gt_poses, &est_poses, &config.rpe, PoseRelation::AngleDeg)?;
        Some(RpeMetrics {
            delta_frames: config.rpe.delta_frames,
            all_pairs: config.rpe.all_pairs,
            translation_mm: Statistics::from_errors(&t.errors, "RPE translation")?,
            rotation_deg: Statistics::from_errors(&r.errors, "RPE rotation")?,
        })
    } else {
        None
    };

    // Per-frame view: the first pair of each ground-truth frame.
    let mut frames: Vec<FrameEvaluation> = inputs
        .gt
        .iter()
        .enumerate()
        .map(|(i, g)| FrameEvaluation {
            frame: i,
            timestamp_s: g.timestamp_s,
            gt: g.pose,
            est: None,
            position_mm: None,
            orientation_deg: None,
            status: None,
            zone: None,
            gt_zone: None,
        })
        .collect();
    let mut pair_frame = Vec::with_capacity(assoc.pairs.len());
    let mut matched_est = vec![false; inputs.est.len()];
    for (k, p) in assoc.pairs.iter().enumerate() {
        pair_frame.push(p.gt_index);
        matched_est[p.est_index] = true;
        let f = &mut frames[p.gt_index];
        if f.est.is_none() {
            f.est = Some(est_poses[k]);
            f.position_mm = Some(pos[k]);
            f.orientation_deg = Some(rot[k]);
        }
    }
    let localized = frames.iter().filter(|f| f.est.is_some()).count();

    let mut status_counts = None;
    let mut by_status = BTreeMap::new();
    if let Some(rows) = inputs.frames {
        let mut c = StatusCounts::default();
        for r in rows {
            let Some(f) = frames.get_mut(r.frame) else {
                return Err(EvalError::Invalid(format!(
                    "frames.csv names frame {} but the ground truth has {n} frames (0..{n}); are they from the same sequence?",
                    r.frame
                )));
            };
            f.status = Some(r.status);
            f.zone = r.zone;
            match r.status {
                Status::Refined => c.refined += 1,
                Status::InitOnly => c.init_only += 1,
                Status::Rejected => c.rejected += 1,
            }
        }
        c.without_row = frames.iter().filter(|f| f.status.is_none()).count();
        status_counts = Some(c);
        for status in [Status::Refined, Status::InitOnly, Status::Rejected] {
            let (p, r): (Vec<f64>, Vec<f64>) = pair_frame
                .iter()
                .enumerate()
                .filter(|(_, fi)| frames[**fi].status == Some(status))
                .map(|(k, _)| (pos[k], rot[k]))
                .unzip();
            if !p.is_empty() {
                by_status.insert(
                    status.as_str().to_string(),
                    summary(&p, &r, status.as_str())?,
                );
            }
        }
    }
    if let Some(zones) = inputs.gt_zones {
        for z in zones {
            let Some(f) = frames.get_mut(z.frame) else {
                return Err(EvalError::Invalid(format!(
                    "the ground-truth zones name frame {} but the ground truth has {n} frames",
                    z.frame
                )));
            };
            f.gt_zone = Some(z.zone);
        }
    }

    let (mut zone_accuracy, mut zone_within_one, mut zone_frames) = (None, None, None);
    if inputs.gt_zones.is_some() && inputs.frames.is_some() {
        let labelled: Vec<&FrameEvaluation> =
            frames.iter().filter(|f| f.gt_zone.is_some()).collect();
        if !labelled.is_empty() {
            let m = labelled.len() as f64;
            let exact = labelled
                .iter()
                .filter(|f| f.zone.is_some() && f.zone == f.gt_zone)
                .count();
            let near = labelled
                .iter()
                .filter(|f| match (f.zone, f.gt_zone) {
                    (Some(a), Some(b)) => a.abs_diff(b) <= 1,
                    _ => false,
                })
                .count();
            zone_accuracy = Some(exact as f64 / m);
            zone_within_one = Some(near as f64 / m);
        }
        zone_frames = Some(labelled.len());
    }

    let zone_source = if inputs.gt_zones.is_some() {
        Some(ZoneSource::GroundTruth)
    } else if inputs.frames.is_some() {
        Some(ZoneSource::Predicted)
    } else {
        None
    };
    let mut per_zone = Vec::new();
    if let Some(src) = zone_source {
        let mut groups: BTreeMap<usize, Vec<&FrameEvaluation>> = BTreeMap::new();
        for f in &frames {
            let key = match src {
                ZoneSource::GroundTruth => f.gt_zone,
                ZoneSource::Predicted => f.zone,
            };
            if let Some(z) = key {
                groups.entry(z).or_default().push(f);
            }
        }
        for (zone, fs) in groups {
            let p: Vec<f64> = fs.iter().filter_map(|f| f.position_mm).collect();
            let r: Vec<f64> = fs.iter().filter_map(|f| f.orientation_deg).collect();
            let (pm, pmed) = crate::stats::mean_median(&p);
            let (rm, rmed) = crate::stats::mean_median(&r);
            let acc = (src == ZoneSource::GroundTruth && inputs.frames.is_some()).then(|| {
                fs.iter().filter(|f| f.zone == Some(zone)).count() as f64 / fs.len() as f64
            });
            per_zone.push(ZoneRow {
                zone,
                frames: fs.len(),
                localized: p.len(),
                position_mm_mean: pm,
                position_mm_median: pmed,
                orientation_deg_mean: rm,
                orientation_deg_median: rmed,
                zone_accuracy: acc,
            });
        }
    }

    let metrics = Metrics {
        format: METRICS_FORMAT.to_string(),
        frames: n,
        localized,
        localized_fraction: if n > 0 {
            localized as f64 / n as f64
        } else {
            0.0
        },
        position_mm: Statistics::from_errors(&pos, "position")?,
        orientation_deg: Statistics::from_errors(&rot, "orientation")?,
        rpe,
        zone_accuracy,
        zone_within_one,
        zone_frames,
        status_counts,
        by_status,
        zone_source,
        per_zone,
        association: AssociationSummary {
            config: config.association,
            gt_poses: inputs.gt.len(),
            est_poses: inputs.est.len(),
            matched: assoc.pairs.len(),
            unmatched_est: matched_est.iter().filter(|m| !**m).count(),
        },
        alignment: alignment_summary(config.alignment, &sim),
        config: *config,
    };
    Ok(Evaluation { metrics, frames })
}

fn alignment_summary(kind: AlignmentKind, sim: &Similarity3) -> AlignmentSummary {
    let m = sim.rotation.matrix();
    let mut rotation = [[0.0; 3]; 3];
    for (i, row) in rotation.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = m[(i, j)];
        }
    }
    AlignmentSummary {
        kind,
        rotation,
        translation_mm: [
            sim.translation_mm.x,
            sim.translation_mm.y,
            sim.translation_mm.z,
        ],
        scale: sim.scale,
    }
}
