//! Pose logs of a tracker (electromagnetic or optical) or a robot arm, on their own clock: read,
//! checked, and resampled at the times of a recording's frames.
//!
//! # Formats
//!
//! - **CSV with a header row** (`,`, `;` or tab separated). Column names are matched in lower
//!   case, a unit in brackets dropped (`x [mm]` is `x`):
//!   - time: `time`, `t`, `timestamp` or `time_s` (seconds), `time_ms` / `timestamp_ms`
//!     (milliseconds), `time_us` / `timestamp_us` (microseconds), `time_ns` /
//!     `timestamp_ns` (nanoseconds);
//!   - position: `x y z`, `tx ty tz` or `px py pz`, in the log's length unit
//!     ([`TrackerLogConfig::units`]);
//!   - orientation: a quaternion `qx qy qz qw` (any column order; Hamilton, scalar `qw`), or a
//!     rotation matrix `r11 … r33` (row `i`, column `j`, 1-based) or `r00 … r22`;
//!   - optional dropout flag: `missing` (1 / true / yes = no valid sample) or `valid`, `ok`,
//!     `visible` (0 / false / no = no valid sample). A flagged row's pose cells may be empty
//!     or NaN.
//! - **TUM** (`t x y z qx qy qz qw`, space separated, `#` comments): chosen when the first
//!   line that is not a comment is eight numbers.
//! - **C3VD's `pose.txt`** (16 comma-separated values per line, a column-major 4×4
//!   camera-to-world transform, one line per frame, no time stamps): chosen when the first
//!   line that is not blank is sixteen numbers; line `k` is taken at `k / rate`
//!   ([`TrackerLogConfig::rate_hz`], the recording's frame rate).
//!
//! The pose of a sample is that of the *sensor* in the tracker's frame (`T_ws`); the camera's
//! is `T_ws · T_sc` with the hand-eye transform `T_sc` ([`ResampleConfig::sensor_to_camera`]).
//!
//! # Checks
//!
//! Every error names the file and the line: a row with another column count, a cell that is not
//! a number, NaN or infinity in an unflagged row (mark dropouts in a `missing` or `valid`
//! column), a quaternion far from unit length, a rotation matrix that is not one, time stamps
//! that repeat or go back, a log with no valid sample. A log whose implied speed is implausible
//! for an endoscope — positions in metres read as millimetres or the other way round — is read,
//! and [`PoseLog::notes`] says so with the speed and the likely `units`.
//!
//! # Resampling
//!
//! [`poses_at`] gives each frame time `t` the pose at log time `t + offset`: linear in position,
//! spherical-linear in rotation, between the two valid samples around it. A frame is left
//! without a pose when either of them is farther than [`ResampleConfig::max_gap_s`] from it —
//! inside a dropout, or outside the log — and the caller lists it.
//! [`estimate_time_offset`] finds the offset between the two clocks from the recording itself.

use std::path::{Path, PathBuf};

use endoloc_geometry::Pose;
use nalgebra::{Matrix3, Translation3, Vector3};

use super::table::Table;
use super::{parse_field, rotation_from_matrix, unit_quaternion};
use crate::DataError;
use crate::import::endoslam::Units;

/// Largest deviation of a rotation matrix from orthonormality that is accepted.
const ROTATION_TOLERANCE: f64 = 1e-3;

/// Implied speeds outside this range (mm/s, 90th percentile over consecutive valid samples)
/// are flagged: a colonoscope moves at a few to a few hundred millimetres per second.
const PLAUSIBLE_SPEED_MM_S: (f64, f64) = (0.1, 2000.0);

/// How to read a pose log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerLogConfig {
    /// Length unit of the positions.
    pub units: Units,
    /// The sample rate of a log without time stamps (C3VD's `pose.txt`: one pose per frame),
    /// Hz; sample `k` is at `k / rate_hz` s. Required for such a log, unused otherwise.
    pub rate_hz: Option<f64>,
}

impl Default for TrackerLogConfig {
    fn default() -> Self {
        TrackerLogConfig {
            units: Units::Mm,
            rate_hz: None,
        }
    }
}

/// One sample of a pose log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseSample {
    /// Time on the log's clock, seconds.
    pub time_s: f64,
    /// The sensor's pose `T_ws` (mm); `None` for a dropout.
    pub pose: Option<Pose>,
    /// Line of the log it came from (1-based).
    pub line: usize,
}

/// A pose log, samples in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseLog {
    /// The file it was read from.
    pub source: PathBuf,
    /// The samples, strictly increasing in time.
    pub samples: Vec<PoseSample>,
    /// Remarks for the user (dropouts, an implausible speed), one line each.
    pub notes: Vec<String>,
}

impl PoseLog {
    /// The log of the camera, for a log of the sensor with the hand-eye transform `t_sc` (the
    /// camera in the sensor's frame, mm): every valid pose becomes `T_ws · T_sc`.
    pub fn to_camera(&self, t_sc: &Pose) -> PoseLog {
        PoseLog {
            samples: self
                .samples
                .iter()
                .map(|s| PoseSample {
                    pose: s.pose.map(|p| p * t_sc),
                    ..*s
                })
                .collect(),
            ..self.clone()
        }
    }
}

/// Reads a pose log (see the module docs for the formats and checks).
///
/// # Errors
/// [`DataError::Io`]; [`DataError::Parse`] naming the line of any problem the module docs list.
pub fn read_pose_log(path: &Path, cfg: &TrackerLogConfig) -> Result<PoseLog, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    parse_pose_log(path, bytes, cfg)
}

/// [`read_pose_log`] of a file's bytes; `path` names the file in errors.
///
/// # Errors
/// As [`read_pose_log`].
pub fn parse_pose_log(
    path: &Path,
    bytes: Vec<u8>,
    cfg: &TrackerLogConfig,
) -> Result<PoseLog, DataError> {
    let text = crate::fsutil::text_from_bytes(path, bytes)?;
    let samples = if looks_like_tum(&text) {
        parse_tum_log(path, &text, cfg)?
    } else if looks_like_c3vd(&text) {
        parse_c3vd_log(path, &text, cfg)?
    } else {
        parse_csv_log(path, &text, cfg)?
    };
    check_times(path, &samples)?;
    let valid = samples.iter().filter(|s| s.pose.is_some()).count();
    if valid == 0 {
        return Err(DataError::invalid(
            path,
            format!(
                "{} samples, none valid; expected at least one pose",
                samples.len()
            ),
        ));
    }
    let mut notes = Vec::new();
    if valid < samples.len() {
        notes.push(format!(
            "{}: {} of {} samples are dropouts",
            path.display(),
            samples.len() - valid,
            samples.len()
        ));
    }
    if let Some(note) = speed_note(path, &samples, cfg.units) {
        notes.push(note);
    }
    Ok(PoseLog {
        source: path.to_path_buf(),
        samples,
        notes,
    })
}

/// Whether the first line that is not blank or a comment is eight numbers (TUM).
fn looks_like_tum(text: &str) -> bool {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            f.len() == 8 && f.iter().all(|v| v.parse::<f64>().is_ok())
        })
}

/// Whether the first line that is not blank or a comment is sixteen comma-separated numbers
/// (C3VD's `pose.txt`).
fn looks_like_c3vd(text: &str) -> bool {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|l| {
            let f: Vec<&str> = l.split(',').collect();
            f.len() == 16 && f.iter().all(|v| v.trim().parse::<f64>().is_ok())
        })
}

/// C3VD's `pose.txt` as a log: the camera's pose `T_wc` per line, line `k` (blank lines
/// skipped) at `k / rate_hz`.
fn parse_c3vd_log(
    path: &Path,
    text: &str,
    cfg: &TrackerLogConfig,
) -> Result<Vec<PoseSample>, DataError> {
    let rate = match cfg.rate_hz {
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => {
            return Err(DataError::invalid(
                path,
                format!("log rate {r} Hz; expected a value > 0"),
            ));
        }
        None => {
            return Err(DataError::invalid(
                path,
                "a C3VD pose file (one 4x4 transform per line) has no time stamps; give its \
                 rate in Hz, the recording's frame rate (`log_rate_hz`)",
            ));
        }
    };
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let pose = super::c3vd::parse_pose_line(l, path, i + 1)?;
        let scaled = Pose::from_parts(
            Translation3::from(pose.translation.vector * cfg.units.mm_per_unit()),
            pose.rotation,
        );
        out.push(PoseSample {
            time_s: out.len() as f64 / rate,
            pose: Some(scaled),
            line: i + 1,
        });
    }
    Ok(out)
}

fn parse_tum_log(
    path: &Path,
    text: &str,
    cfg: &TrackerLogConfig,
) -> Result<Vec<PoseSample>, DataError> {
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let line = i + 1;
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() != 8 {
            return Err(DataError::parse(
                path,
                line,
                format!("{} fields; expected 8 (t x y z qx qy qz qw)", f.len()),
            ));
        }
        const NAMES: [&str; 8] = ["t", "x", "y", "z", "qx", "qy", "qz", "qw"];
        let mut v = [0.0; 8];
        for (k, (name, text)) in NAMES.iter().zip(&f).enumerate() {
            v[k] = parse_field(path, line, name, text)?;
        }
        let q = unit_quaternion(path, line, [v[4], v[5], v[6], v[7]])?;
        let t = Vector3::new(v[1], v[2], v[3]) * cfg.units.mm_per_unit();
        out.push(PoseSample {
            time_s: v[0],
            pose: Some(Pose::from_parts(Translation3::from(t), q)),
            line,
        });
    }
    Ok(out)
}

/// The column names of a CSV log's header, and how each is read.
struct Columns {
    time: usize,
    time_scale: f64,
    position: [usize; 3],
    rotation: Rotation,
    flag: Option<(usize, bool)>,
}

enum Rotation {
    Quaternion([usize; 4]),
    Matrix([usize; 9]),
}

fn find(header: &[String], names: &[&str]) -> Option<usize> {
    names
        .iter()
        .find_map(|n| header.iter().position(|h| h == n))
}

fn find_all<const N: usize>(header: &[String], names: [&str; N]) -> Option<[usize; N]> {
    let mut out = [0; N];
    for (k, n) in names.iter().enumerate() {
        out[k] = header.iter().position(|h| h == n)?;
    }
    Some(out)
}

impl Columns {
    fn of(path: &Path, header: &[String]) -> Result<Self, DataError> {
        let missing = |what: &str| {
            DataError::parse(
                path,
                1,
                format!("header has no {what}; found columns {}", header.join(",")),
            )
        };
        let (time, time_scale) = [
            (
                &["time", "t", "timestamp", "time_s", "timestamp_s"][..],
                1.0,
            ),
            (&["time_ms", "timestamp_ms"][..], 1e-3),
            (&["time_us", "timestamp_us"][..], 1e-6),
            (&["time_ns", "timestamp_ns"][..], 1e-9),
        ]
        .iter()
        .find_map(|(names, scale)| find(header, names).map(|c| (c, *scale)))
        .ok_or_else(|| missing("time column (time, t, timestamp, time_ms, time_us, time_ns)"))?;
        let position = find_all(header, ["x", "y", "z"])
            .or_else(|| find_all(header, ["tx", "ty", "tz"]))
            .or_else(|| find_all(header, ["px", "py", "pz"]))
            .ok_or_else(|| missing("position columns (x y z, tx ty tz or px py pz)"))?;
        let rotation = if let Some(q) = find_all(header, ["qx", "qy", "qz", "qw"]) {
            Rotation::Quaternion(q)
        } else if let Some(r) = find_all(
            header,
            [
                "r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33",
            ],
        ) {
            Rotation::Matrix(r)
        } else if let Some(r) = find_all(
            header,
            [
                "r00", "r01", "r02", "r10", "r11", "r12", "r20", "r21", "r22",
            ],
        ) {
            Rotation::Matrix(r)
        } else {
            return Err(missing(
                "orientation columns (qx qy qz qw, or a rotation matrix r11 … r33 or r00 … r22)",
            ));
        };
        let flag = find(header, &["missing"])
            .map(|c| (c, true))
            .or_else(|| find(header, &["valid", "ok", "visible"]).map(|c| (c, false)));
        Ok(Columns {
            time,
            time_scale,
            position,
            rotation,
            flag,
        })
    }
}

/// A flag cell as a boolean: 1/0, true/false, yes/no (any case).
fn flag_value(path: &Path, line: usize, column: &str, text: &str) -> Result<bool, DataError> {
    match text.trim().to_ascii_lowercase().as_str() {
        "1" | "true" | "yes" | "y" => Ok(true),
        "0" | "false" | "no" | "n" => Ok(false),
        other => Err(DataError::parse(
            path,
            line,
            format!("{column}: {other:?}; expected 1/0, true/false or yes/no"),
        )),
    }
}

fn parse_csv_log(
    path: &Path,
    text: &str,
    cfg: &TrackerLogConfig,
) -> Result<Vec<PoseSample>, DataError> {
    let mut table = Table::parse(path, text.as_bytes().to_vec(), None, "time")?;
    // A unit in brackets or parentheses is dropped: `x [mm]` → `x`.
    for h in &mut table.header {
        if let Some(i) = h.find(['[', '(']) {
            *h = h[..i].trim().to_string();
        }
    }
    let cols = Columns::of(path, &table.header)?;
    let mut out = Vec::with_capacity(table.rows.len());
    for (line, cells) in &table.rows {
        let line = *line;
        let time_s = table.number(line, cells, cols.time)? * cols.time_scale;
        let dropout = match cols.flag {
            Some((c, means_missing)) => {
                flag_value(path, line, &table.header[c], Table::text(cells, c))? == means_missing
            }
            None => false,
        };
        let pose = if dropout {
            None
        } else {
            let mut p = [0.0; 3];
            for (v, &c) in p.iter_mut().zip(&cols.position) {
                *v = table.number(line, cells, c)?;
            }
            let q = match &cols.rotation {
                Rotation::Quaternion(c) => {
                    let mut v = [0.0; 4];
                    for (v, &c) in v.iter_mut().zip(c) {
                        *v = table.number(line, cells, c)?;
                    }
                    unit_quaternion(path, line, v)?
                }
                Rotation::Matrix(c) => {
                    let mut m = Matrix3::zeros();
                    for (k, &col) in c.iter().enumerate() {
                        m[(k / 3, k % 3)] = table.number(line, cells, col)?;
                    }
                    rotation_from_matrix(&m, ROTATION_TOLERANCE).ok_or_else(|| {
                        DataError::parse(
                            path,
                            line,
                            format!(
                                "the rotation matrix is not a rotation (orthonormal, determinant +1, within {ROTATION_TOLERANCE})"
                            ),
                        )
                    })?
                }
            };
            let t = Vector3::from(p) * cfg.units.mm_per_unit();
            Some(Pose::from_parts(Translation3::from(t), q))
        };
        out.push(PoseSample { time_s, pose, line });
    }
    Ok(out)
}

/// Time stamps must increase strictly.
fn check_times(path: &Path, samples: &[PoseSample]) -> Result<(), DataError> {
    if samples.is_empty() {
        return Err(DataError::parse(
            path,
            1,
            "no samples; expected one pose per line",
        ));
    }
    for w in samples.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if b.time_s == a.time_s {
            return Err(DataError::parse(
                path,
                b.line,
                format!(
                    "time {} s repeats that of line {}; expected increasing time stamps",
                    b.time_s, a.line
                ),
            ));
        }
        if b.time_s < a.time_s {
            return Err(DataError::parse(
                path,
                b.line,
                format!(
                    "time {} s is before that of line {} ({} s); expected increasing time stamps",
                    b.time_s, a.line, a.time_s
                ),
            ));
        }
    }
    Ok(())
}

/// A note when the 90th percentile of the speed between consecutive valid samples is outside
/// what an endoscope does.
fn speed_note(path: &Path, samples: &[PoseSample], units: Units) -> Option<String> {
    let mut speeds: Vec<f64> = samples
        .windows(2)
        .filter_map(|w| {
            let (a, b) = (w[0].pose?, w[1].pose?);
            let d = (b.translation.vector - a.translation.vector).norm();
            Some(d / (w[1].time_s - w[0].time_s))
        })
        .collect();
    if speeds.len() < 10 {
        return None;
    }
    speeds.sort_by(f64::total_cmp);
    let p90 = speeds[speeds.len() * 9 / 10];
    let (lo, hi) = PLAUSIBLE_SPEED_MM_S;
    let unit = match units {
        Units::Mm => "mm",
        Units::Cm => "cm",
        Units::M => "m",
    };
    if p90 < lo {
        Some(format!(
            "{}: the sensor moves at {p90:.3} mm/s (90th percentile) with positions read in {unit}: \
             an endoscope moves at millimetres to centimetres per second — positions in metres \
             (`units = m`)?",
            path.display()
        ))
    } else if p90 > hi {
        Some(format!(
            "{}: the sensor moves at {:.1} m/s (90th percentile) with positions read in {unit}: \
             an endoscope moves at millimetres to centimetres per second — positions in \
             millimetres (`units = mm`)?",
            path.display(),
            p90 / 1000.0
        ))
    } else {
        None
    }
}

/// How frame times map to poses of a [`PoseLog`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResampleConfig {
    /// Log time of a frame = its time + this, seconds.
    pub time_offset_s: f64,
    /// A frame gets a pose only when the valid samples on both sides of it are within this,
    /// seconds.
    pub max_gap_s: f64,
    /// The hand-eye transform `T_sc` (camera in the sensor's frame, mm); `None`: the sensor is
    /// the camera.
    pub sensor_to_camera: Option<Pose>,
}

impl Default for ResampleConfig {
    fn default() -> Self {
        ResampleConfig {
            time_offset_s: 0.0,
            max_gap_s: 0.05,
            sensor_to_camera: None,
        }
    }
}

/// The camera pose `T_wc` (mm) at each of `frame_times_s` (seconds, the recording's clock), or
/// `None` where the log has no valid sample within [`ResampleConfig::max_gap_s`] on both sides
/// (see the module docs).
pub fn poses_at(log: &PoseLog, frame_times_s: &[f64], cfg: &ResampleConfig) -> Vec<Option<Pose>> {
    let valid: Vec<(f64, Pose)> = log
        .samples
        .iter()
        .filter_map(|s| s.pose.map(|p| (s.time_s, p)))
        .collect();
    frame_times_s
        .iter()
        .map(|&t| {
            let pose = sensor_pose_at(&valid, t + cfg.time_offset_s, cfg.max_gap_s)?;
            Some(match cfg.sensor_to_camera {
                Some(t_sc) => pose * t_sc,
                None => pose,
            })
        })
        .collect()
}

/// The interpolated sensor pose at log time `t` from the valid samples `(time, pose)`.
fn sensor_pose_at(valid: &[(f64, Pose)], t: f64, max_gap_s: f64) -> Option<Pose> {
    if !t.is_finite() {
        return None;
    }
    // First sample at or after t, where a sample within a microsecond of t is at t: frame
    // times come as decimals rounded to the microsecond (ffprobe), and a log of one pose per
    // frame (C3VD's) must give its last frame its own pose, not none.
    const SAME_TIME_S: f64 = 1e-6;
    let after = valid.partition_point(|(ts, _)| *ts < t - SAME_TIME_S);
    let (tb, pb) = *valid.get(after)?;
    if (tb - t).abs() <= SAME_TIME_S {
        return Some(pb);
    }
    let (ta, pa) = *valid.get(after.checked_sub(1)?)?;
    if t - ta > max_gap_s || tb - t > max_gap_s {
        return None;
    }
    let s = (t - ta) / (tb - ta);
    let position = pa.translation.vector.lerp(&pb.translation.vector, s);
    let rotation = pa
        .rotation
        .try_slerp(&pb.rotation, s, 1e-12)
        .unwrap_or(pa.rotation);
    Some(Pose::from_parts(Translation3::from(position), rotation))
}

/// The camera's speed on a log (valid samples only) at time `t`: translation mm/s and rotation
/// rad/s, from the interpolated poses `h` seconds either side; `None` outside the log or in a
/// dropout.
fn speeds_at(valid: &[(f64, Pose)], t: f64, h: f64, max_gap_s: f64) -> Option<(f64, f64)> {
    let a = sensor_pose_at(valid, t - h, max_gap_s)?;
    let b = sensor_pose_at(valid, t + h, max_gap_s)?;
    let v = (b.translation.vector - a.translation.vector).norm() / (2.0 * h);
    let w = a.rotation.angle_to(&b.rotation) / (2.0 * h);
    Some((v, w))
}

/// The offset between a recording's clock and a pose log's, found by [`estimate_time_offset`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetEstimate {
    /// Log time of a frame = its time + this, seconds.
    pub offset_s: f64,
    /// Square root of the fraction of the image motion's variance the tracker's speeds explain
    /// at that offset (0 … 1).
    pub correlation: f64,
    /// How much better it is than the best offset more than [`OffsetSearch::separation_s`]
    /// away: the difference of the two correlations (0 = as good, ambiguous).
    pub margin: f64,
    /// Frames that entered the correlation at the best offset.
    pub frames: usize,
}

/// Where [`estimate_time_offset`] looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetSearch {
    /// Offsets from `-max_s` to `max_s` are tried, seconds.
    pub max_s: f64,
    /// Step of the search, seconds (refined to a fraction of it by a parabola through the
    /// best three).
    pub step_s: f64,
    /// A rival offset must be at least this far from the best, seconds.
    pub separation_s: f64,
    /// Fewest frames that must overlap the log at an offset for it to count.
    pub min_frames: usize,
}

impl Default for OffsetSearch {
    fn default() -> Self {
        OffsetSearch {
            max_s: 2.0,
            step_s: 0.005,
            separation_s: 0.25,
            min_frames: 30,
        }
    }
}

/// Finds the offset between a recording's clock and a pose log's: the one at which the image
/// motion between consecutive frames (`image_motion[i]`: from frame `i − 1` to frame `i`, at
/// time between their times; any measure that grows with the motion, such as
/// [`frame_motion`]) is best explained by the tracker's speed: by a linear fit on its
/// translation and rotation speeds (an endoscope's image moves with both, in proportions that
/// depend on the scene), scored by the square root of the fraction of the image motion's
/// variance it explains over *all* frames (those the log does not cover at that offset count
/// as unexplained). `None` when no offset has [`OffsetSearch::min_frames`] overlapping frames.
pub fn estimate_time_offset(
    log: &PoseLog,
    frame_times_s: &[f64],
    image_motion: &[f64],
    search: &OffsetSearch,
) -> Option<OffsetEstimate> {
    let valid: Vec<(f64, Pose)> = log
        .samples
        .iter()
        .filter_map(|s| s.pose.map(|p| (s.time_s, p)))
        .collect();
    let n = frame_times_s.len().min(image_motion.len());
    // Frame pairs (time between the two frames, half their interval, image motion).
    let pairs: Vec<(f64, f64, f64)> = (1..n)
        .filter(|&i| image_motion[i].is_finite())
        .map(|i| {
            let (a, b) = (frame_times_s[i - 1], frame_times_s[i]);
            (0.5 * (a + b), 0.5 * (b - a), image_motion[i])
        })
        .filter(|(_, h, _)| *h > 0.0)
        .collect();
    let gap = 0.25;
    // Every frame pair counts at every offset: one the log does not cover there is left
    // unexplained (its motion's deviation from the mean), so a short overlap cannot win by
    // chance.
    let n_pairs = pairs.len().max(1) as f64;
    let mean = pairs.iter().map(|p| p.2).sum::<f64>() / n_pairs;
    let total: f64 = pairs.iter().map(|p| (p.2 - mean).powi(2)).sum();
    let score = |offset: f64| -> Option<(f64, usize)> {
        let mut speed = Vec::with_capacity(pairs.len());
        let mut motion = Vec::with_capacity(pairs.len());
        let mut unexplained = 0.0;
        for &(t, h, m) in &pairs {
            match speeds_at(&valid, t + offset, h, gap) {
                Some(s) => {
                    speed.push(s);
                    motion.push(m);
                }
                None => unexplained += (m - mean).powi(2),
            }
        }
        if speed.len() < search.min_frames || total <= 0.0 {
            return None;
        }
        let residual = fit_residual(&speed, &motion)? + unexplained;
        Some(((1.0 - residual / total).max(0.0).sqrt(), speed.len()))
    };
    let steps = (search.max_s / search.step_s).round() as i64;
    let scores: Vec<(f64, Option<(f64, usize)>)> = (-steps..=steps)
        .map(|k| {
            let o = k as f64 * search.step_s;
            (o, score(o))
        })
        .collect();
    let (best_i, &(best_o, best)) = scores
        .iter()
        .enumerate()
        .filter(|(_, (_, s))| s.is_some())
        .max_by(|a, b| a.1.1.unwrap().0.total_cmp(&b.1.1.unwrap().0))?;
    let (best_r, frames) = best?;
    // Parabola through the best and its neighbours.
    let mut offset_s = best_o;
    let before = best_i.checked_sub(1).and_then(|i| scores.get(i));
    if let (Some((_, Some((l, _)))), Some((_, Some((r, _))))) = (before, scores.get(best_i + 1)) {
        let denom = l - 2.0 * best_r + r;
        if denom < 0.0 {
            offset_s += 0.5 * (l - r) / denom * search.step_s;
        }
    }
    let rival = scores
        .iter()
        .filter(|(o, _)| (o - best_o).abs() >= search.separation_s)
        .filter_map(|(_, s)| s.map(|s| s.0))
        .fold(f64::NEG_INFINITY, f64::max);
    Some(OffsetEstimate {
        offset_s,
        correlation: best_r,
        margin: if rival.is_finite() {
            best_r - rival
        } else {
            best_r
        },
        frames,
    })
}

/// The residual sum of squares of `motion` fitted by `a·v + b·ω + c` over the `(v, ω)` speeds
/// (least squares; both speeds, or the better of either alone when one does not vary, as in a
/// log without rotation); `None` when no fit can be made.
fn fit_residual(speed: &[(f64, f64)], motion: &[f64]) -> Option<f64> {
    [(true, true), (true, false), (false, true)]
        .iter()
        .filter_map(|&(use_v, use_w)| {
            let row = |(v, w): (f64, f64)| {
                Vector3::new(
                    if use_v { v } else { 0.0 },
                    if use_w { w } else { 0.0 },
                    1.0,
                )
            };
            let mut ata = Matrix3::zeros();
            let mut atb = Vector3::zeros();
            for (&s, &m) in speed.iter().zip(motion) {
                let x = row(s);
                ata += x * x.transpose();
                atb += x * m;
            }
            // An unused column is pinned to 0.
            for (k, used) in [(0, use_v), (1, use_w)] {
                if !used {
                    ata[(k, k)] = 1.0;
                }
            }
            let coef = ata.cholesky()?.solve(&atb);
            Some(
                speed
                    .iter()
                    .zip(motion)
                    .map(|(&s, &m)| (m - coef.dot(&row(s))).powi(2))
                    .sum::<f64>(),
            )
        })
        .min_by(f64::total_cmp)
}

/// How much the image moved between two frames of one size: the mean absolute difference of
/// their grey values after both are shrunk to at most 80 pixels wide (8-bit levels; larger =
/// more motion). Cheap, and for a camera in a lumen it grows with both its translation and its
/// rotation.
///
/// # Panics
/// Never; frames of different sizes compare their shrunk versions over the common part.
pub fn frame_motion(a: &image::GrayImage, b: &image::GrayImage) -> f64 {
    let shrink = |img: &image::GrayImage| {
        let w = img.width().clamp(1, 80);
        let h =
            ((img.height() as f64 * w as f64 / img.width().max(1) as f64).round() as u32).max(1);
        image::imageops::resize(img, w, h, image::imageops::FilterType::Triangle)
    };
    let (sa, sb) = (shrink(a), shrink(b));
    let (w, h) = (sa.width().min(sb.width()), sa.height().min(sb.height()));
    let mut sum = 0.0;
    for y in 0..h {
        for x in 0..w {
            sum += (f64::from(sa.get_pixel(x, y)[0]) - f64::from(sb.get_pixel(x, y)[0])).abs();
        }
    }
    sum / f64::from((w * h).max(1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn parse(text: &str, units: Units) -> Result<PoseLog, DataError> {
        parse_pose_log(
            Path::new("log.csv"),
            text.as_bytes().to_vec(),
            &TrackerLogConfig {
                units,
                rate_hz: None,
            },
        )
    }

    #[test]
    fn a_c3vd_pose_file_is_a_log_at_the_frame_rate() {
        // Two frames: the identity, then 5 mm along x turned 90° about z (column-major).
        let text = "1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\n\n0,1,0,0,-1,0,0,0,0,0,1,0,5,0,0,1\n";
        let path = Path::new("pose.txt");
        let read = |rate_hz| {
            parse_pose_log(
                path,
                text.as_bytes().to_vec(),
                &TrackerLogConfig {
                    units: Units::Mm,
                    rate_hz,
                },
            )
        };
        let log = read(Some(30.0)).unwrap();
        let times: Vec<f64> = log.samples.iter().map(|s| s.time_s).collect();
        assert_eq!(times, [0.0, 1.0 / 30.0]);
        assert_eq!(log.samples[1].line, 3);
        let second = log.samples[1].pose.unwrap();
        assert_eq!(
            second,
            super::super::c3vd::parse_pose_line(text.lines().nth(2).unwrap(), path, 3).unwrap()
        );
        assert!((second.translation.vector - Vector3::new(5.0, 0.0, 0.0)).norm() < 1e-12);
        let e = read(None).unwrap_err().to_string();
        assert!(
            e.contains("pose.txt") && e.contains("no time stamps"),
            "{e}"
        );
        // A broken line of such a file names its line.
        let bad = "1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\n1,0,0\n";
        let e = parse_pose_log(
            path,
            bad.as_bytes().to_vec(),
            &TrackerLogConfig {
                units: Units::Mm,
                rate_hz: Some(30.0),
            },
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("pose.txt:2") && e.contains("16 comma-separated"),
            "{e}"
        );
    }

    /// A log of a sensor moving along x at 20 mm/s and turning about z, sampled at 100 Hz.
    fn moving_log(n: usize, missing: std::ops::Range<usize>) -> String {
        let mut s = String::from("time_ms,x [mm],y,z,qx,qy,qz,qw,missing\n");
        for i in 0..n {
            let t = i as f64 * 0.01;
            let a = 0.2 * t;
            let q = UnitQuaternion::from_euler_angles(0.0, 0.0, a);
            let flag = missing.contains(&i);
            if flag {
                s.push_str(&format!("{},nan,,,,,,,1\n", t * 1000.0));
            } else {
                s.push_str(&format!(
                    "{},{},{},{},{},{},{},{},0\n",
                    t * 1000.0,
                    20.0 * t,
                    1.0,
                    2.0,
                    q.i,
                    q.j,
                    q.k,
                    q.w
                ));
            }
        }
        s
    }

    #[test]
    fn a_csv_log_resamples_at_frame_times_and_leaves_dropouts_without_pose() {
        let log = parse(&moving_log(300, 100..120), Units::Mm).unwrap();
        assert_eq!(log.samples.len(), 300);
        assert!(
            log.notes[0].contains("20 of 300 samples are dropouts"),
            "{:?}",
            log.notes
        );
        // Frames at 30 fps, the log 0.1 s ahead of the video's clock.
        let times: Vec<f64> = (0..80).map(|i| i as f64 / 30.0).collect();
        let cfg = ResampleConfig {
            time_offset_s: 0.1,
            max_gap_s: 0.02,
            ..ResampleConfig::default()
        };
        let poses = poses_at(&log, &times, &cfg);
        for (t, p) in times.iter().zip(&poses) {
            let lt = t + 0.1;
            // Valid samples at 0.99 s and 1.20 s around the dropout, the last at 2.99 s.
            let in_dropout = lt > 0.99 + 1e-9 && lt < 1.20 - 1e-9;
            match p {
                Some(p) => {
                    assert!(!in_dropout, "{lt}");
                    assert!((p.translation.x - 20.0 * lt).abs() < 1e-9, "{lt}");
                    let want = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.2 * lt);
                    assert!(p.rotation.angle_to(&want) < 1e-9);
                }
                None => assert!(in_dropout || lt > 2.99, "{lt} has no pose"),
            }
        }
        assert!(poses.iter().filter(|p| p.is_none()).count() >= 5);
        // The hand-eye transform moves the camera 5 mm along the sensor's z.
        let t_sc = Pose::from_parts(Translation3::new(0.0, 0.0, 5.0), UnitQuaternion::identity());
        let cam = poses_at(
            &log,
            &[0.5],
            &ResampleConfig {
                sensor_to_camera: Some(t_sc),
                ..cfg
            },
        );
        assert!((cam[0].unwrap().translation.z - 7.0).abs() < 1e-9);
    }

    #[test]
    fn bad_logs_are_refused_with_their_line() {
        let err = |text: &str| parse(text, Units::Mm).unwrap_err().to_string();
        let head = "t,x,y,z,qx,qy,qz,qw\n";
        let row = |t: f64| format!("{t},1,2,3,0,0,0,1\n");
        let e = err(&format!("{head}{}{}{}", row(0.0), row(0.1), row(0.1)));
        assert!(
            e.contains("log.csv:4:") && e.contains("repeats that of line 3"),
            "{e}"
        );
        let e = err(&format!("{head}{}{}{}", row(0.0), row(0.2), row(0.1)));
        assert!(e.contains("log.csv:4:") && e.contains("is before"), "{e}");
        let e = err(&format!("{head}{}0.1,nan,2,3,0,0,0,1\n", row(0.0)));
        assert!(e.contains("log.csv:3:") && e.contains("x"), "{e}");
        let e = err(&format!("{head}{}0.1,1,2\n", row(0.0)));
        assert!(e.contains("log.csv:3:") && e.contains("columns"), "{e}");
        let e = err("time,x,y,z\n0,1,2,3\n");
        assert!(e.contains("orientation columns"), "{e}");
        let e = err("t,x,y,z,qx,qy,qz,qw,valid\n0,,,,,,,,0\n");
        assert!(e.contains("none valid"), "{e}");
        let e = err(&format!("{head}0,1,2,3,0,0,0,2\n"));
        assert!(
            e.contains("log.csv:2:") && e.contains("unit quaternion"),
            "{e}"
        );
        let e = err("t,x,y,z,r11,r12,r13,r21,r22,r23,r31,r32,r33\n0,0,0,0,1,0,0,0,1,0,0,0,2\n");
        assert!(
            e.contains("log.csv:2:") && e.contains("not a rotation"),
            "{e}"
        );
    }

    #[test]
    fn a_metre_log_read_as_millimetres_is_flagged_by_its_speed() {
        // Positions in metres (20 mm/s = 0.02 m/s) read as mm: 0.02 mm/s.
        let text: String = std::iter::once("t x y z qx qy qz qw\n".replace(' ', ","))
            .chain((0..50).map(|i| {
                let t = i as f64 * 0.01;
                format!("{t},{},0,0,0,0,0,1\n", 0.02 * t)
            }))
            .collect();
        let as_mm = parse(&text, Units::Mm).unwrap();
        assert!(
            as_mm.notes.iter().any(|n| n.contains("units = m")),
            "{:?}",
            as_mm.notes
        );
        assert!(parse(&text, Units::M).unwrap().notes.is_empty());
    }

    #[test]
    fn tum_logs_and_rotation_matrices_read_as_the_same_poses() {
        let q = UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3);
        let tum = format!(
            "# t x y z qx qy qz qw\n0.5 0.001 0.002 0.003 {} {} {} {}\n",
            q.i, q.j, q.k, q.w
        );
        let a = parse(&tum, Units::M).unwrap();
        let r = q.to_rotation_matrix().into_inner();
        let mut csv =
            String::from("timestamp_us,px,py,pz,r00,r01,r02,r10,r11,r12,r20,r21,r22\n500000,1,2,3");
        for i in 0..3 {
            for j in 0..3 {
                csv.push_str(&format!(",{}", r[(i, j)]));
            }
        }
        let b = parse(&csv, Units::Mm).unwrap();
        let (pa, pb) = (a.samples[0].pose.unwrap(), b.samples[0].pose.unwrap());
        assert_eq!(a.samples[0].time_s, b.samples[0].time_s);
        assert!((pa.translation.vector - pb.translation.vector).norm() < 1e-12);
        assert!(pa.rotation.angle_to(&pb.rotation) < 1e-9);
    }

    #[test]
    fn the_clock_offset_is_found_from_motion_alone() {
        // The sensor's speed varies (stop, go, turn); the images move as it does, 0.35 s
        // earlier on the video's clock than on the log's.
        let speed = |t: f64| 10.0 + 8.0 * (1.3 * t).sin() + 5.0 * (3.1 * t).sin().max(0.0);
        let mut text = String::from("t,x,y,z,qx,qy,qz,qw\n");
        let mut x = 0.0;
        for i in 0..1200 {
            let t = i as f64 * 0.01;
            x += speed(t) * 0.01;
            text.push_str(&format!("{t},{x},0,0,0,0,0,1\n"));
        }
        let log = parse(&text, Units::Mm).unwrap();
        let times: Vec<f64> = (0..300).map(|i| i as f64 / 30.0).collect();
        // Image motion from frame i − 1 to frame i, as fast as the sensor midway.
        let motion: Vec<f64> = (0..times.len())
            .map(|i| match i {
                0 => f64::NAN,
                _ => speed(0.5 * (times[i - 1] + times[i]) + 0.35),
            })
            .collect();
        let e = estimate_time_offset(&log, &times, &motion, &OffsetSearch::default()).unwrap();
        assert!((e.offset_s - 0.35).abs() < 1.0 / 30.0, "{e:?}");
        assert!(e.correlation > 0.9 && e.margin > 0.05, "{e:?}");
    }
}
