//! What an evaluation reads, as streams that can be read more than once: the ground truth,
//! the estimate and the optional `frames.csv` and true zones, either already in memory
//! ([`EvalInputs`]) or as files read line by line ([`EvalFiles`]) so that memory does not
//! grow with the length of the pass.

use std::path::{Path, PathBuf};

use endoloc_data::{StampedPose, TumReader};

use crate::EvalError;
use crate::along::Midline;
use crate::frames_csv::{FrameRecord, FramesCsvReader};
use crate::zones_csv::{ZoneLabel, ZonesCsvReader};

/// A stream of rows, each of which may fail to read.
pub type Rows<'a, T> = Box<dyn Iterator<Item = Result<T, EvalError>> + 'a>;

/// Inputs of an evaluation, each readable from the start as often as needed. Poses must come
/// in strictly increasing time order and rows in increasing frame order (the evaluation
/// checks both).
pub trait EvalSource {
    /// The ground truth of the test sequence (its `poses.txt`), one pose per frame.
    fn gt(&self) -> Result<Rows<'_, StampedPose>, EvalError>;
    /// The estimated poses (the run's `trajectory.txt`).
    fn est(&self) -> Result<Rows<'_, StampedPose>, EvalError>;
    /// The run's `frames.csv` rows; `None` when there is none.
    fn frames(&self) -> Option<Result<Rows<'_, FrameRecord>, EvalError>>;
    /// The test frames' true zones; `None` when unknown.
    fn gt_zones(&self) -> Option<Result<Rows<'_, ZoneLabel>, EvalError>>;
    /// Where per-frame records are kept between passes: a folder for unnamed temporary files,
    /// or `None` for memory.
    fn scratch_dir(&self) -> Option<PathBuf> {
        None
    }
    /// The colon's mid-line, for the error along the colon; `None` when unknown.
    fn midline(&self) -> Option<&Midline> {
        None
    }
    /// How the inputs are named in messages: ground truth, estimate, frames, zones.
    fn names(&self) -> [String; 4] {
        [
            "the ground truth".into(),
            "the estimate".into(),
            "frames.csv".into(),
            "the ground-truth zones".into(),
        ]
    }
}

/// What is evaluated, already in memory: trajectories and the optional per-frame rows.
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
    /// The colon's mid-line, if known (enables the error along the colon).
    pub midline: Option<&'a Midline>,
}

fn rows<'a, T: Clone + 'a>(v: &'a [T]) -> Rows<'a, T> {
    Box::new(v.iter().cloned().map(Ok))
}

impl EvalSource for EvalInputs<'_> {
    fn gt(&self) -> Result<Rows<'_, StampedPose>, EvalError> {
        Ok(rows(self.gt))
    }
    fn est(&self) -> Result<Rows<'_, StampedPose>, EvalError> {
        Ok(rows(self.est))
    }
    fn frames(&self) -> Option<Result<Rows<'_, FrameRecord>, EvalError>> {
        self.frames.map(|f| Ok(rows(f)))
    }
    fn gt_zones(&self) -> Option<Result<Rows<'_, ZoneLabel>, EvalError>> {
        self.gt_zones.map(|z| Ok(rows(z)))
    }
    fn midline(&self) -> Option<&Midline> {
        self.midline
    }
}

/// What is evaluated, as files read line by line on every pass.
#[derive(Debug, Clone, Default)]
pub struct EvalFiles {
    /// Ground truth, TUM.
    pub gt: PathBuf,
    /// Estimate, TUM.
    pub est: PathBuf,
    /// The run's `frames.csv`, if any.
    pub frames: Option<PathBuf>,
    /// The true zones (`zones.csv`), if known.
    pub gt_zones: Option<PathBuf>,
    /// Folder for the unnamed temporary files that hold per-frame records between passes
    /// (`None`: the system's temporary folder).
    pub scratch_dir: Option<PathBuf>,
    /// The colon's mid-line, if known (enables the error along the colon).
    pub midline: Option<Midline>,
}

fn tum(path: &Path) -> Result<Rows<'static, StampedPose>, EvalError> {
    Ok(Box::new(
        TumReader::open(path)?.map(|r| r.map_err(EvalError::from)),
    ))
}

impl EvalSource for EvalFiles {
    fn gt(&self) -> Result<Rows<'_, StampedPose>, EvalError> {
        tum(&self.gt)
    }
    fn est(&self) -> Result<Rows<'_, StampedPose>, EvalError> {
        tum(&self.est)
    }
    fn frames(&self) -> Option<Result<Rows<'_, FrameRecord>, EvalError>> {
        self.frames
            .as_deref()
            .map(|p| FramesCsvReader::open(p).map(|r| Box::new(r) as Rows<'_, FrameRecord>))
    }
    fn gt_zones(&self) -> Option<Result<Rows<'_, ZoneLabel>, EvalError>> {
        self.gt_zones
            .as_deref()
            .map(|p| ZonesCsvReader::open(p).map(|r| Box::new(r) as Rows<'_, ZoneLabel>))
    }
    fn scratch_dir(&self) -> Option<PathBuf> {
        Some(self.scratch_dir.clone().unwrap_or_else(std::env::temp_dir))
    }
    fn midline(&self) -> Option<&Midline> {
        self.midline.as_ref()
    }
    fn names(&self) -> [String; 4] {
        let show = |p: &Path| p.display().to_string();
        [
            show(&self.gt),
            show(&self.est),
            self.frames.as_deref().map_or("frames.csv".into(), show),
            self.gt_zones.as_deref().map_or("zones".into(), show),
        ]
    }
}
