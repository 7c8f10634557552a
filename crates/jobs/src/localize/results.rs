//! The files of a localization run — `trajectory.txt`, `frames.csv`, `inliers.csv` and, with
//! a mid-line, `along.csv` — written row by row as frames are localized, so that a run's
//! memory does not grow with its length.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use endoloc_data::{Sequence, StampedPose};
use endoloc_eval::{FRAMES_CSV_HEADER, FrameRecord, Midline, format_frames_csv_row};
use endoloc_localize::FrameResult;
use nalgebra::Point3;

use crate::error::{JobError, Result};
use crate::output::StagedFiles;

/// The file of a localization run that lists the inlier keypoints of every frame.
pub const INLIERS_FILE: &str = "inliers.csv";

/// The trajectory of a localization run (TUM, `T_wc`, mm; one line per frame with a pose).
pub const TRAJECTORY_FILE: &str = "trajectory.txt";

/// One row per frame of a localization run (see [`endoloc_eval::frames_csv`]).
pub const FRAMES_FILE: &str = "frames.csv";

/// Where along the colon each frame with a pose is: header `frame,along_mm`, the arc length
/// (mm from the anus) of the mid-line point nearest to the estimated camera centre.
pub const ALONG_FILE: &str = "along.csv";

/// One output file written line by line: buffered, flushed and synced by
/// [`LineFile::finish`]. Errors name `shown`, the path the file will have once published,
/// not the staging path it may be written under.
#[derive(Debug)]
pub(super) struct LineFile {
    file: BufWriter<File>,
    shown: PathBuf,
}

impl LineFile {
    /// Creates `path` (shown in errors as `shown`) and writes `header` into it.
    pub(super) fn create(path: &Path, shown: PathBuf, header: &str) -> Result<Self> {
        let file = File::create(path).map_err(|e| JobError::io(&shown, e))?;
        let mut f = LineFile {
            file: BufWriter::with_capacity(64 * 1024, file),
            shown,
        };
        f.write(header)?;
        Ok(f)
    }

    fn staged(staged: &StagedFiles, dest: &Path, name: &str, header: &str) -> Result<Self> {
        Self::create(&staged.path(name), dest.join(name), header)
    }

    pub(super) fn write(&mut self, text: &str) -> Result<()> {
        self.file
            .write_all(text.as_bytes())
            .map_err(|e| JobError::io(&self.shown, e))
    }

    /// Hands what is buffered to the operating system: a process killed after this keeps it.
    pub(super) fn flush(&mut self) -> Result<()> {
        self.file.flush().map_err(|e| JobError::io(&self.shown, e))
    }

    pub(super) fn finish(self) -> Result<()> {
        let LineFile { file, shown } = self;
        let file = file
            .into_inner()
            .map_err(|e| JobError::io(&shown, e.into_error()))?;
        file.sync_all().map_err(|e| JobError::io(&shown, e))
    }
}

/// Writes a localization run's files into a [`StagedFiles`] folder as the frames arrive, in
/// frame order; nothing of a frame is kept once its rows are written.
///
/// ```text
/// trajectory.txt   TUM `timestamp tx ty tz qx qy qz qw` (T_wc, mm), frames with a pose
/// frames.csv       frame,zone,zone_score,status,reason,source,inliers,… (every frame)
/// inliers.csv      frame,x_px,y_px (the inlier keypoints of every frame's final estimate)
/// along.csv        frame,along_mm (with a mid-line: each pose's distance along the colon)
/// ```
#[derive(Debug)]
pub struct ResultWriter {
    trajectory: LineFile,
    frames: LineFile,
    inliers: LineFile,
    along: Option<(LineFile, Midline)>,
    /// Timestamps of the sequence's frames, seconds; `None` for a stream, whose frames come
    /// with their own ([`ResultWriter::push_at`]).
    timestamps: Option<Vec<f64>>,
    /// The next frame index ([`ResultWriter::push`]) or the lowest one allowed
    /// ([`ResultWriter::push_at`]).
    next: usize,
    written: usize,
    line: String,
}

impl ResultWriter {
    /// Starts the files in `staged` for a run over `seq` that will be published into `dest`
    /// (named in errors); `along.csv` too when the colon's `midline` is known.
    ///
    /// # Errors
    /// A file that cannot be created.
    pub fn create(
        staged: &StagedFiles,
        dest: &Path,
        seq: &Sequence,
        midline: Option<Midline>,
    ) -> Result<Self> {
        let along = match midline {
            Some(m) => Some((
                LineFile::staged(staged, dest, ALONG_FILE, "frame,along_mm\n")?,
                m,
            )),
            None => None,
        };
        Ok(ResultWriter {
            trajectory: LineFile::staged(staged, dest, TRAJECTORY_FILE, endoloc_data::TUM_HEADER)?,
            frames: LineFile::staged(staged, dest, FRAMES_FILE, &format!("{FRAMES_CSV_HEADER}\n"))?,
            inliers: LineFile::staged(staged, dest, INLIERS_FILE, "frame,x_px,y_px\n")?,
            along,
            timestamps: Some(seq.timestamps()),
            next: 0,
            written: 0,
            line: String::with_capacity(256),
        })
    }

    /// Starts the files of a stream's run straight in the folder `dest` (which exists), each
    /// frame's rows handed to the operating system as soon as they are written
    /// ([`ResultWriter::push_at`]): a run that is killed keeps every finished frame.
    ///
    /// # Errors
    /// A file that cannot be created.
    pub fn streaming(dest: &Path) -> Result<Self> {
        let file =
            |name: &str, header: &str| LineFile::create(&dest.join(name), dest.join(name), header);
        Ok(ResultWriter {
            trajectory: file(TRAJECTORY_FILE, endoloc_data::TUM_HEADER)?,
            frames: file(FRAMES_FILE, &format!("{FRAMES_CSV_HEADER}\n"))?,
            inliers: file(INLIERS_FILE, "frame,x_px,y_px\n")?,
            along: None,
            timestamps: None,
            next: 0,
            written: 0,
            line: String::with_capacity(256),
        })
    }

    /// Frames written so far.
    pub fn len(&self) -> usize {
        self.written
    }

    /// Whether no frame has been written yet.
    pub fn is_empty(&self) -> bool {
        self.written == 0
    }

    /// Writes the rows of the next frame of the sequence.
    ///
    /// # Errors
    /// More frames than the sequence has (or a stream's writer), a value that cannot be
    /// written (not finite), or a failed write.
    pub fn push(&mut self, r: &FrameResult) -> Result<()> {
        let i = self.next;
        let Some(timestamps) = &self.timestamps else {
            return Err(JobError::Invalid(
                "a stream's frames are written with their index and time".into(),
            ));
        };
        let Some(&timestamp_s) = timestamps.get(i) else {
            return Err(JobError::Invalid(format!(
                "frame {i}: the sequence has only {} frames",
                timestamps.len()
            )));
        };
        self.write_rows(i, timestamp_s, r)
    }

    /// Writes the rows of a stream's frame `frame` (its index in the source, above the last
    /// one written: dropped frames leave gaps) at `timestamp_s` (the source's clock, seconds),
    /// and flushes them.
    ///
    /// # Errors
    /// A sequence's writer, a frame index not above the last, a value that cannot be written
    /// (not finite), or a failed write.
    pub fn push_at(&mut self, frame: usize, timestamp_s: f64, r: &FrameResult) -> Result<()> {
        if self.timestamps.is_some() || frame < self.next {
            return Err(JobError::Invalid(format!(
                "{}: frame {frame} written out of order (next {})",
                self.frames.shown.display(),
                self.next
            )));
        }
        self.write_rows(frame, timestamp_s, r)?;
        for f in [&mut self.trajectory, &mut self.frames, &mut self.inliers] {
            f.flush()?;
        }
        Ok(())
    }

    fn write_rows(&mut self, i: usize, timestamp_s: f64, r: &FrameResult) -> Result<()> {
        if let Some(pose) = r.t_wc {
            self.line.clear();
            endoloc_data::format_tum_line(&StampedPose { timestamp_s, pose }, &mut self.line)
                .map_err(|m| {
                    JobError::Invalid(format!(
                        "{}: frame {i} has {m}",
                        self.trajectory.shown.display()
                    ))
                })?;
            self.trajectory.write(&self.line)?;
            if let Some((file, midline)) = &mut self.along {
                let s = midline.arc_length_at(&Point3::from(pose.translation.vector));
                file.write(&format!("{i},{s:.2}\n"))?;
            }
        }
        self.line.clear();
        format_frames_csv_row(&frame_record(i, r), &mut self.line)
            .map_err(|m| JobError::Invalid(format!("{}: {m}", self.frames.shown.display())))?;
        self.frames.write(&self.line)?;
        self.line.clear();
        append_inliers(i, &r.inlier_px, &mut self.line);
        self.inliers.write(&self.line)?;
        self.next = i + 1;
        self.written += 1;
        Ok(())
    }

    /// Flushes and syncs the files; they are complete (in the staging folder, ready to be
    /// published, for a sequence).
    ///
    /// # Errors
    /// A failed write (disk full), or fewer frames written than the sequence has.
    pub fn finish(self) -> Result<()> {
        if let Some(timestamps) = &self.timestamps
            && self.written != timestamps.len()
        {
            return Err(JobError::Invalid(format!(
                "{}: {} of {} frames written",
                self.frames.shown.display(),
                self.written,
                timestamps.len()
            )));
        }
        self.trajectory.finish()?;
        self.frames.finish()?;
        if let Some((file, _)) = self.along {
            file.finish()?;
        }
        self.inliers.finish()
    }
}

/// Appends the `inliers.csv` rows of frame `i` to `out`.
fn append_inliers(i: usize, inlier_px: &[[f32; 2]], out: &mut String) {
    use std::fmt::Write as _;
    for [x, y] in inlier_px {
        let _ = writeln!(out, "{i},{x:.2},{y:.2}");
    }
}

/// `inliers.csv`: header `frame,x_px,y_px`, then one row per inlier keypoint of each frame's
/// final estimate (pixels, origin at the centre of the top-left pixel).
pub fn inliers_csv(results: &[FrameResult]) -> String {
    let mut csv = String::from("frame,x_px,y_px\n");
    for (i, r) in results.iter().enumerate() {
        append_inliers(i, &r.inlier_px, &mut csv);
    }
    csv
}

/// Reads an `inliers.csv`: the inlier keypoints of each of `frames` frames.
///
/// # Errors
/// A row that is not `frame,x_px,y_px` with numbers, or a frame index out of range, named by
/// its line.
pub fn read_inliers_csv(path: &Path, frames: usize) -> Result<Vec<Vec<[f32; 2]>>> {
    let text = std::fs::read_to_string(path).map_err(|e| JobError::io(path, e))?;
    parse_inliers_csv(path, &text, frames)
}

/// Parses the text of an `inliers.csv` (see [`read_inliers_csv`]); `path` names the file in
/// errors.
///
/// # Errors
/// A row that is not `frame,x_px,y_px` with numbers, or a frame index out of range, named by
/// its line.
pub fn parse_inliers_csv(path: &Path, text: &str, frames: usize) -> Result<Vec<Vec<[f32; 2]>>> {
    let mut out = vec![Vec::new(); frames];
    for (k, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let bad = || {
            JobError::Invalid(format!(
                "{} line {}: expected `frame,x_px,y_px` with a frame below {frames}, found {line:?}",
                path.display(),
                k + 1
            ))
        };
        let mut cols = line.split(',').map(str::trim);
        let (Some(f), Some(x), Some(y), None) =
            (cols.next(), cols.next(), cols.next(), cols.next())
        else {
            return Err(bad());
        };
        let (Ok(f), Ok(x), Ok(y)) = (f.parse::<usize>(), x.parse::<f32>(), y.parse::<f32>()) else {
            return Err(bad());
        };
        if f >= frames || !x.is_finite() || !y.is_finite() {
            return Err(bad());
        }
        out[f].push([x, y]);
    }
    Ok(out)
}

/// The `frames.csv` row of frame `frame`.
pub fn frame_record(frame: usize, r: &FrameResult) -> FrameRecord {
    FrameRecord {
        frame,
        zone: r.has_zone().then_some(r.zone),
        zone_score: (r.has_zone() && r.zone_score.is_finite()).then_some(f64::from(r.zone_score)),
        status: r.status,
        reason: r
            .reason
            .as_ref()
            .map_or(String::new(), |x| x.code().to_string()),
        source: r.source.as_str().to_string(),
        inliers: r.has_zone().then_some(r.inliers),
        reprojection_rms_px: r
            .reprojection_rms_px
            .is_finite()
            .then_some(r.reprojection_rms_px),
        position_std_mm: r.position_std_mm.is_finite().then_some(r.position_std_mm),
        orientation_std_deg: r
            .orientation_std_deg
            .is_finite()
            .then_some(r.orientation_std_deg),
        time_ms: r.times.total_ms(),
    }
}

/// The `frames.csv` rows of a run, one per frame in order.
pub fn frame_records(results: &[FrameResult]) -> Vec<FrameRecord> {
    results
        .iter()
        .enumerate()
        .map(|(i, r)| frame_record(i, r))
        .collect()
}
