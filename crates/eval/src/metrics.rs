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
//!
//! **Memory does not grow with the pass.** The inputs are streams read several times
//! ([`EvalSource`]): once to check and count them, twice more for the alignment's means and
//! covariance when one is asked for, once to compute every pair's error. The errors go to
//! fixed-size records (memory, or an unnamed temporary file for [`EvalFiles`]), from which
//! the statistics are computed exactly in nine more passes (radix selection, `select.rs`); the plots
//! keep at most [`crate::plot_data::PLOT_FRAMES`] frames.

use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;

use endoloc_geometry::{Pose, Status};
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use crate::EvalError;
use crate::align::{AlignmentKind, Similarity3, UmeyamaSums};
use crate::ape::PoseRelation;
use crate::association::{AssociationConfig, PairStream, PosePair, TrajectoryScan, check_config};
use crate::frame_error::{status_code, status_of};
use crate::frames_csv::FrameRecord;
use crate::plot_data::{PlotCollector, PlotData};
use crate::rpe::{RpeConfig, relative_error_pose};
use crate::select::{GroupSummary, Want, summarise};
use crate::source::{EvalFiles, EvalSource, Rows};
use crate::spill::{Fields, Record, Spill};
use crate::stats::Statistics;
use crate::zones_csv::ZoneLabel;

pub use crate::frame_error::FrameEvaluation;
pub use crate::source::EvalInputs;

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

/// The errors of one associated pair (APE), one RPE pair or one error along the colon, with
/// the status of its frame.
#[derive(Debug, Clone, Copy)]
struct PairError {
    /// APE (0), RPE (1) or along the colon (2, in `position`).
    kind: u8,
    status: u8,
    position: f64,
    orientation: f64,
}

impl Record for PairError {
    const SIZE: usize = 18;
    fn encode(&self, out: &mut Vec<u8>) {
        out.push(self.kind);
        out.push(self.status);
        out.extend(self.position.to_le_bytes());
        out.extend(self.orientation.to_le_bytes());
    }
    fn decode(b: &[u8]) -> Self {
        let mut f = Fields(b);
        Self {
            kind: f.u8(),
            status: f.u8(),
            position: f.f64(),
            orientation: f.f64(),
        }
    }
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
    /// Error along the colon over the associated poses: mm of mid-line between the nearest
    /// mid-line points of the estimate and of the truth (`None` without a mid-line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub along_colon_mm: Option<Statistics>,
    /// The same over the refined frames only (`None` without a mid-line or `frames.csv`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub along_colon_refined_mm: Option<Statistics>,
    /// Where the mid-line came from (the dataset's, or the training pass standing in).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub midline: Option<String>,
    /// Association details.
    pub association: AssociationSummary,
    /// Alignment details.
    pub alignment: AlignmentSummary,
    /// Settings used.
    pub config: EvalConfig,
}

/// An evaluated run: the metrics, the per-frame errors behind them and what the plots show.
pub struct Evaluation {
    /// The summary written to `metrics.json`.
    pub metrics: Metrics,
    /// What the plots draw (at most [`crate::plot_data::PLOT_FRAMES`] frames).
    pub plots: PlotData,
    /// One record per ground-truth frame, in frame order.
    frames: Spill<FrameEvaluation>,
}

impl std::fmt::Debug for Evaluation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Evaluation")
            .field("metrics", &self.metrics)
            .field("frames", &self.frames.len())
            .finish_non_exhaustive()
    }
}

impl Evaluation {
    /// Calls `f` with the error of every test frame, in frame order (read back from memory
    /// or from the evaluation's temporary file).
    ///
    /// # Errors
    /// [`EvalError::Io`] when the temporary file cannot be read; whatever `f` returns.
    pub fn for_each_frame(
        &self,
        f: impl FnMut(FrameEvaluation) -> Result<(), EvalError>,
    ) -> Result<(), EvalError> {
        self.frames.for_each(f)
    }

    /// The error of every test frame, in frame order, in memory (for small passes and tests).
    ///
    /// # Errors
    /// As [`Evaluation::for_each_frame`].
    pub fn frames(&self) -> Result<Vec<FrameEvaluation>, EvalError> {
        let mut v = Vec::with_capacity(self.frames.len());
        self.for_each_frame(|f| {
            v.push(f);
            Ok(())
        })?;
        Ok(v)
    }
}

/// Evaluates a run held in memory.
///
/// # Errors
/// [`EvalError::NoAssociation`] if no estimated pose matches a ground-truth timestamp;
/// [`EvalError::Alignment`] if the requested alignment is degenerate;
/// [`EvalError::Invalid`] if `frames.csv` or the zones name a frame the ground truth does not
/// have or are not in frame order, the time stamps do not increase, or the settings are
/// invalid (e.g. RPE delta 0).
pub fn evaluate(inputs: &EvalInputs<'_>, config: &EvalConfig) -> Result<Evaluation, EvalError> {
    evaluate_source(inputs, config)
}

/// Evaluates a run from its files, reading them line by line: memory does not grow with the
/// length of the pass (per-frame records go to unnamed temporary files in
/// [`EvalFiles::scratch_dir`]).
///
/// # Errors
/// As [`evaluate`], and unreadable or malformed files (named, with the line).
pub fn evaluate_files(files: &EvalFiles, config: &EvalConfig) -> Result<Evaluation, EvalError> {
    evaluate_source(files, config)
}

/// Rows of an optional per-frame file joined to the frame loop: rows must come in increasing
/// frame order; each is taken at its frame.
struct Joined<'a, T> {
    rows: Option<Rows<'a, T>>,
    peeked: Option<T>,
    last: Option<usize>,
    taken: usize,
    name: String,
    frame_of: fn(&T) -> usize,
}

impl<'a, T> Joined<'a, T> {
    fn new(
        rows: Option<Result<Rows<'a, T>, EvalError>>,
        name: String,
        frame_of: fn(&T) -> usize,
    ) -> Result<Self, EvalError> {
        Ok(Self {
            rows: rows.transpose()?,
            peeked: None,
            last: None,
            taken: 0,
            name,
            frame_of,
        })
    }

    fn present(&self) -> bool {
        self.rows.is_some()
    }

    /// The frame of the next row, if any.
    fn peek(&mut self) -> Result<Option<usize>, EvalError> {
        if self.peeked.is_none()
            && let Some(rows) = &mut self.rows
            && let Some(row) = rows.next().transpose()?
        {
            let f = (self.frame_of)(&row);
            if let Some(last) = self.last
                && f <= last
            {
                return Err(EvalError::Invalid(format!(
                    "{}: row {} names frame {f} after frame {last}; expected one row per frame, in frame order",
                    self.name,
                    self.taken + 1
                )));
            }
            self.last = Some(f);
            self.peeked = Some(row);
        }
        Ok(self.peeked.as_ref().map(self.frame_of))
    }

    /// The row of `frame`, if there is one.
    fn take(&mut self, frame: usize) -> Result<Option<T>, EvalError> {
        match self.peek()? {
            Some(f) if f == frame => {
                self.taken += 1;
                Ok(self.peeked.take())
            }
            _ => Ok(None),
        }
    }

    /// After the last of `n` frames: any row left names a frame the ground truth lacks.
    fn finish(&mut self, n: usize, what: &str) -> Result<(), EvalError> {
        match self.peek()? {
            Some(f) => Err(EvalError::Invalid(format!(
                "{} names frame {f} but the ground truth has {n} frames (0..{n}){what}",
                self.name
            ))),
            None => Ok(()),
        }
    }
}

/// Counters of one per-zone row.
#[derive(Debug, Clone, Copy, Default)]
struct ZoneCount {
    frames: usize,
    localized: usize,
    predicted_here: usize,
}

fn aligned(sim: &Similarity3, kind: AlignmentKind, est: &Pose) -> Pose {
    match kind {
        AlignmentKind::None => *est,
        AlignmentKind::Se3 | AlignmentKind::Sim3 => sim.transform_pose(est),
    }
}

/// The alignment of the estimate onto the ground truth: two passes over the pairs.
fn alignment(
    src: &dyn EvalSource,
    scans: &(TrajectoryScan, TrajectoryScan),
    config: &EvalConfig,
) -> Result<Similarity3, EvalError> {
    let kind = config.alignment;
    if kind == AlignmentKind::None {
        return Ok(Similarity3::identity());
    }
    let pairs = || -> Result<PairStream<'_>, EvalError> {
        Ok(PairStream::new(
            src.gt()?,
            src.est()?,
            &scans.0,
            &scans.1,
            &config.association,
        ))
    };
    let mut sums = UmeyamaSums::new();
    for p in pairs()? {
        let p = p?;
        sums.add_mean(&p.est.translation.vector, &p.gt.translation.vector);
    }
    for p in pairs()? {
        let p = p?;
        sums.add_centred(&p.est.translation.vector, &p.gt.translation.vector);
    }
    sums.solve(kind == AlignmentKind::Sim3)
}

const STATUSES: [Status; 3] = [Status::Refined, Status::InitOnly, Status::Rejected];

/// The streamed evaluation behind [`evaluate`] and [`evaluate_files`].
fn evaluate_source(src: &dyn EvalSource, config: &EvalConfig) -> Result<Evaluation, EvalError> {
    if config.rpe.delta_frames == 0 {
        return Err(EvalError::Invalid(
            "RPE delta must be at least 1 frame".into(),
        ));
    }
    check_config(&config.association)?;
    let [gt_name, est_name, frames_name, zones_name] = src.names();
    let scans = (
        TrajectoryScan::read(src.gt()?, &gt_name)?,
        TrajectoryScan::read(src.est()?, &est_name)?,
    );
    let n = scans.0.count;
    let sim = alignment(src, &scans, config)?;

    let scratch: Option<PathBuf> = src.scratch_dir();
    let mut frame_spill = Spill::<FrameEvaluation>::new(scratch.as_deref())?;
    let mut pair_spill = Spill::<PairError>::new(scratch.as_deref())?;
    let mut rows = Joined::new(src.frames(), frames_name, |r: &FrameRecord| r.frame)?;
    let mut zones = Joined::new(src.gt_zones(), zones_name, |z: &ZoneLabel| z.frame)?;
    let zone_source = if zones.present() {
        Some(ZoneSource::GroundTruth)
    } else if rows.present() {
        Some(ZoneSource::Predicted)
    } else {
        None
    };
    let mut plots = PlotCollector::new(n);
    let midline = src.midline();

    let mut gt_rows = src.gt()?;
    let mut pairs = PairStream::new(
        src.gt()?,
        src.est()?,
        &scans.0,
        &scans.1,
        &config.association,
    );
    let mut next_pair: Option<PosePair> = pairs.next().transpose()?;
    let delta = config.rpe.delta_frames;
    let mut recent: VecDeque<(Pose, Pose)> = VecDeque::with_capacity(delta + 1);
    let (mut matched, mut rpe_pairs, mut distinct_est, mut localized) =
        (0usize, 0usize, 0usize, 0usize);
    let mut last_est: Option<usize> = None;
    let mut counts = StatusCounts::default();
    let (mut labelled, mut exact, mut near) = (0usize, 0usize, 0usize);
    let mut per_zone: BTreeMap<usize, ZoneCount> = BTreeMap::new();

    for i in 0..n {
        let g = gt_rows.next().transpose()?.ok_or_else(|| {
            EvalError::Invalid(format!(
                "{gt_name}: changed while it was read (fewer poses)"
            ))
        })?;
        let row = rows.take(i)?;
        let gt_zone = zones.take(i)?.map(|z| z.zone);
        let status = row.as_ref().map(|r| r.status);
        let zone = row.as_ref().and_then(|r| r.zone);
        match status {
            Some(Status::Refined) => counts.refined += 1,
            Some(Status::InitOnly) => counts.init_only += 1,
            Some(Status::Rejected) => counts.rejected += 1,
            None => counts.without_row += 1,
        }
        let mut first: Option<(Pose, f64, f64)> = None;
        while let Some(p) = next_pair.filter(|p| p.gt_index == i) {
            let est = aligned(&sim, config.alignment, &p.est);
            let pos = PoseRelation::TransPart.error(&est, &p.gt);
            let rot = PoseRelation::AngleDeg.error(&est, &p.gt);
            pair_spill.push(&PairError {
                kind: 0,
                status: status_code(status),
                position: pos,
                orientation: rot,
            })?;
            if let Some(m) = midline {
                let at = |pose: &Pose| Point3::from(pose.translation.vector);
                pair_spill.push(&PairError {
                    kind: 2,
                    status: status_code(status),
                    position: m.along_error_mm(&at(&est), &at(&p.gt)),
                    orientation: 0.0,
                })?;
            }
            if last_est != Some(p.est_index) {
                distinct_est += 1;
                last_est = Some(p.est_index);
            }
            // RPE over associated pairs (i, i + Δ): consecutive ones step by Δ.
            if recent.len() == delta + 1 {
                recent.pop_front();
            }
            recent.push_back((p.gt, est));
            if matched >= delta && (config.rpe.all_pairs || matched % delta == 0) {
                let (gi, ei) = recent[0];
                let e = relative_error_pose(&gi, &p.gt, &ei, &est);
                let identity = Pose::identity();
                pair_spill.push(&PairError {
                    kind: 1,
                    status: 0,
                    position: PoseRelation::TransPart.error(&e, &identity),
                    orientation: PoseRelation::AngleDeg.error(&e, &identity),
                })?;
                rpe_pairs += 1;
            }
            matched += 1;
            first.get_or_insert((est, pos, rot));
            next_pair = pairs.next().transpose()?;
        }
        if first.is_some() {
            localized += 1;
        }
        let frame = FrameEvaluation {
            frame: i,
            timestamp_s: g.timestamp_s,
            localized: first.is_some(),
            position_mm: first.map(|f| f.1),
            orientation_deg: first.map(|f| f.2),
            status,
            zone,
            gt_zone,
        };
        frame_spill.push(&frame)?;
        plots.add(&frame, &g.pose, first.map(|f| f.0).as_ref());
        if rows.present()
            && let Some(t) = gt_zone
        {
            labelled += 1;
            exact += usize::from(zone == Some(t));
            near += usize::from(zone.is_some_and(|z| z.abs_diff(t) <= 1));
        }
        let key = match zone_source {
            Some(ZoneSource::GroundTruth) => gt_zone,
            Some(ZoneSource::Predicted) => zone,
            None => None,
        };
        if let Some(z) = key {
            let c = per_zone.entry(z).or_default();
            c.frames += 1;
            c.localized += usize::from(first.is_some());
            c.predicted_here += usize::from(zone == Some(z));
        }
    }
    if let Some(p) = next_pair {
        return Err(EvalError::Invalid(format!(
            "{gt_name}: changed while it was read (pose {} beyond its {n} poses)",
            p.gt_index
        )));
    }
    rows.finish(n, "; are they from the same sequence?")?;
    zones.finish(n, "")?;
    frame_spill.seal()?;
    pair_spill.seal()?;
    if matched == 0 {
        return Err(EvalError::NoAssociation {
            gt_poses: n,
            est_poses: scans.1.count,
            max_diff_s: config.association.max_diff_s,
            offset_s: config.association.offset_s,
        });
    }

    // Exact statistics, streamed back from the records: groups 0/1 all pairs, 2..8 per
    // status, 8/9 RPE, 10/11 along the colon (all, refined), then two per zone.
    let zone_groups: BTreeMap<usize, usize> = per_zone
        .keys()
        .enumerate()
        .map(|(k, &z)| (z, 12 + 2 * k))
        .collect();
    let mut wants = vec![Want::Full; 12];
    wants.extend(std::iter::repeat_n(Want::MeanMedian, 2 * zone_groups.len()));
    let summaries: Vec<GroupSummary> = summarise(&wants, &mut |emit| {
        pair_spill.for_each(|p| {
            if p.kind == 2 {
                emit(10, p.position);
                if status_of(p.status) == Some(Status::Refined) {
                    emit(11, p.position);
                }
                return Ok(());
            }
            let base = if p.kind == 1 {
                8
            } else {
                emit(0, p.position);
                emit(1, p.orientation);
                match status_of(p.status) {
                    Some(s) => 2 + 2 * STATUSES.iter().position(|&x| x == s).unwrap_or(0),
                    None => return Ok(()),
                }
            };
            emit(base, p.position);
            emit(base + 1, p.orientation);
            Ok(())
        })?;
        frame_spill.for_each(|f| {
            let key = match zone_source {
                Some(ZoneSource::GroundTruth) => f.gt_zone,
                Some(ZoneSource::Predicted) => f.zone,
                None => None,
            };
            if let (Some(z), Some(p), Some(r)) = (key, f.position_mm, f.orientation_deg)
                && let Some(&g) = zone_groups.get(&z)
            {
                emit(g, p);
                emit(g + 1, r);
            }
            Ok(())
        })
    })?;
    let plots = plots.finish(&frame_spill)?;

    let mut by_status = BTreeMap::new();
    if rows.present() {
        for (k, s) in STATUSES.iter().enumerate() {
            let (p, r) = (&summaries[2 + 2 * k], &summaries[3 + 2 * k]);
            if p.count > 0 {
                by_status.insert(
                    s.as_str().to_string(),
                    ErrorSummary {
                        position_mm: p.statistics(&format!("{} position", s.as_str()))?,
                        orientation_deg: r.statistics(&format!("{} orientation", s.as_str()))?,
                    },
                );
            }
        }
    }
    let rpe = if rpe_pairs > 0 {
        Some(RpeMetrics {
            delta_frames: delta,
            all_pairs: config.rpe.all_pairs,
            translation_mm: summaries[8].statistics("RPE translation")?,
            rotation_deg: summaries[9].statistics("RPE rotation")?,
        })
    } else {
        None
    };
    let per_zone: Vec<ZoneRow> = per_zone
        .iter()
        .map(|(&zone, c)| {
            let g = zone_groups[&zone];
            let (pm, pmed) = summaries[g].mean_median();
            let (rm, rmed) = summaries[g + 1].mean_median();
            ZoneRow {
                zone,
                frames: c.frames,
                localized: c.localized,
                position_mm_mean: pm,
                position_mm_median: pmed,
                orientation_deg_mean: rm,
                orientation_deg_median: rmed,
                zone_accuracy: (zone_source == Some(ZoneSource::GroundTruth) && rows.present())
                    .then(|| c.predicted_here as f64 / c.frames as f64),
            }
        })
        .collect();
    let both = zones.present() && rows.present();
    let metrics = Metrics {
        format: METRICS_FORMAT.to_string(),
        frames: n,
        localized,
        localized_fraction: if n > 0 {
            localized as f64 / n as f64
        } else {
            0.0
        },
        position_mm: summaries[0].statistics("position")?,
        orientation_deg: summaries[1].statistics("orientation")?,
        rpe,
        zone_accuracy: (both && labelled > 0).then(|| exact as f64 / labelled as f64),
        zone_within_one: (both && labelled > 0).then(|| near as f64 / labelled as f64),
        zone_frames: both.then_some(labelled),
        status_counts: rows.present().then_some(counts),
        by_status,
        zone_source,
        per_zone,
        along_colon_mm: match midline {
            Some(_) => Some(summaries[10].statistics("along the colon")?),
            None => None,
        },
        along_colon_refined_mm: match midline {
            Some(_) if summaries[11].count > 0 => {
                Some(summaries[11].statistics("refined, along the colon")?)
            }
            _ => None,
        },
        midline: midline.map(|m| m.source().to_string()),
        association: AssociationSummary {
            config: config.association,
            gt_poses: n,
            est_poses: scans.1.count,
            matched,
            unmatched_est: scans.1.count - distinct_est,
        },
        alignment: alignment_summary(config.alignment, &sim),
        config: *config,
    };
    Ok(Evaluation {
        metrics,
        plots,
        frames: frame_spill,
    })
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
