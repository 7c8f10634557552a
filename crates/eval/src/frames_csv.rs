//! `frames.csv`: one row per test frame of a localization run (docs/CONVENTIONS.md, results on disk).
//!
//! The header is exactly [`FRAMES_CSV_HEADER`]:
//!
//! ```text
//! frame,zone,zone_score,status,reason,source,inliers,reprojection_rms_px,position_std_mm,orientation_std_deg,time_ms
//! 0,12,0.8731,refined,,refined,143,0.84,0.21,0.18,41.2
//! 1,12,0.8012,init_only,too_few_inliers,predicted,5,,,,38.9
//! 2,-1,,rejected,jump_too_large,none,61,1.20,,,40.0
//! ```
//!
//! | column | meaning |
//! |---|---|
//! | `frame` | 0-based test frame index = line order of the test sequence's `poses.txt` |
//! | `zone` | predicted zone index (0-based); `-1` or empty when none |
//! | `zone_score` | score of the predicted zone (e.g. descriptor similarity); empty when none |
//! | `status` | `refined` \| `init_only` \| `rejected` ([`endoloc_geometry::Status`]) |
//! | `reason` | why the frame is not `refined`: a keyword without commas or quotes (`Reason::code`); empty when refined |
//! | `source` | where the frame's pose comes from: `refined` (registered to the map), `predicted` (live motion model), `zone_median` (the zone's median training pose), `none` (no pose) |
//! | `inliers` | inlier count of the pose refinement; empty when not attempted |
//! | `reprojection_rms_px` | inlier reprojection RMS, pixels; empty when not available |
//! | `position_std_mm` | standard deviation of the camera centre along its least certain direction, mm, from the registration's covariance with the wall-motion term (calibrated: the 95 % bound is [`BOUND95_PER_STD`] × this); empty unless `refined` |
//! | `orientation_std_deg` | standard deviation of the orientation about its least certain axis, degrees (same calibration); empty unless `refined` |
//! | `time_ms` | wall time spent on the frame, milliseconds |
//!
//! No quoting: fields never contain commas. Blank lines are ignored. Files with the earlier
//! eight-column header ([`FRAMES_CSV_HEADER_V1`], without `source` and the standard
//! deviations) are still read.

use std::fmt::Write as _;
use std::path::Path;

use endoloc_geometry::Status;
use serde::{Deserialize, Serialize};

use crate::EvalError;
use crate::output::write_atomic;

/// The header line of `frames.csv`, exactly.
pub const FRAMES_CSV_HEADER: &str = "frame,zone,zone_score,status,reason,source,inliers,reprojection_rms_px,position_std_mm,orientation_std_deg,time_ms";

/// The header of the eight-column layout without `source` and the standard deviations; still
/// read.
pub const FRAMES_CSV_HEADER_V1: &str =
    "frame,zone,zone_score,status,reason,inliers,reprojection_rms_px,time_ms";

/// The 95 % bound on a refined frame's position (orientation) error is this many times its
/// `position_std_mm` (`orientation_std_deg`).
pub use endoloc_geometry::BOUND95_PER_STD;

const COLUMNS: usize = 11;
const COLUMNS_V1: usize = 8;

/// One row of `frames.csv`: what the localizer did with one test frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// 0-based test frame index (line order of the test `poses.txt`).
    pub frame: usize,
    /// Predicted zone index, `None` when no zone was chosen (written `-1`).
    pub zone: Option<usize>,
    /// Score of the predicted zone (higher is more confident), `None` when none.
    pub zone_score: Option<f64>,
    /// Outcome of the validity check.
    pub status: Status,
    /// Keyword saying why the frame is not `refined` (empty when refined); no commas, quotes
    /// or line breaks.
    pub reason: String,
    /// Where the pose comes from (`refined`, `predicted`, `zone_median`, `none`); a keyword
    /// without commas or quotes, empty when unknown (files in the eight-column layout).
    pub source: String,
    /// Inliers of the pose refinement, `None` when it was not attempted.
    pub inliers: Option<usize>,
    /// Inlier reprojection RMS, pixels; `None` when not available.
    pub reprojection_rms_px: Option<f64>,
    /// Calibrated standard deviation of the camera centre along its least certain direction,
    /// mm; `None` unless refined.
    pub position_std_mm: Option<f64>,
    /// Calibrated standard deviation of the orientation about its least certain axis, degrees;
    /// `None` unless refined.
    pub orientation_std_deg: Option<f64>,
    /// Wall time spent on the frame, milliseconds.
    pub time_ms: f64,
}

/// Parses a status word: `refined`, `init_only` or `rejected`.
///
/// # Errors
/// A message naming the accepted words.
pub fn status_from_str(word: &str) -> Result<Status, String> {
    match word {
        "refined" => Ok(Status::Refined),
        "init_only" => Ok(Status::InitOnly),
        "rejected" => Ok(Status::Rejected),
        _ => Err(format!(
            "status {word:?} is not one of refined, init_only, rejected"
        )),
    }
}

fn opt_f64(s: &str, name: &str) -> Result<Option<f64>, String> {
    if s.is_empty() {
        return Ok(None);
    }
    let v: f64 = s
        .parse()
        .map_err(|_| format!("{name}: {s:?} is not a number (or empty)"))?;
    if !v.is_finite() {
        return Err(format!("{name}: {s} is not finite"));
    }
    Ok(Some(v))
}

fn opt_usize(s: &str, name: &str) -> Result<Option<usize>, String> {
    if s.is_empty() {
        return Ok(None);
    }
    s.parse()
        .map(Some)
        .map_err(|_| format!("{name}: {s:?} is not a non-negative integer (or empty)"))
}

fn parse_row(line: &str, v1: bool) -> Result<FrameRecord, String> {
    let mut cols: Vec<&str> = line.split(',').map(str::trim).collect();
    let (expected, header) = if v1 {
        (COLUMNS_V1, FRAMES_CSV_HEADER_V1)
    } else {
        (COLUMNS, FRAMES_CSV_HEADER)
    };
    if cols.len() != expected {
        return Err(format!(
            "expected {expected} comma-separated columns ({header}); found {}",
            cols.len()
        ));
    }
    if v1 {
        // Same meaning, fewer columns: read as the current layout with the new ones empty.
        cols.insert(5, "");
        cols.insert(8, "");
        cols.insert(9, "");
    }
    let frame = cols[0]
        .parse()
        .map_err(|_| format!("frame: {:?} is not a non-negative integer", cols[0]))?;
    let zone = match cols[1] {
        "" | "-1" => None,
        z => Some(
            z.parse()
                .map_err(|_| format!("zone: {z:?} is not a zone index, -1 or empty"))?,
        ),
    };
    let time_ms = opt_f64(cols[10], "time_ms")?.ok_or("time_ms: empty; expected milliseconds")?;
    Ok(FrameRecord {
        frame,
        zone,
        zone_score: opt_f64(cols[2], "zone_score")?,
        status: status_from_str(cols[3])?,
        reason: cols[4].to_string(),
        source: cols[5].to_string(),
        inliers: opt_usize(cols[6], "inliers")?,
        reprojection_rms_px: opt_f64(cols[7], "reprojection_rms_px")?,
        position_std_mm: opt_f64(cols[8], "position_std_mm")?,
        orientation_std_deg: opt_f64(cols[9], "orientation_std_deg")?,
        time_ms,
    })
}

/// Reads the header line: `Ok(true)` for the eight-column layout, `Ok(false)` for the current.
fn parse_header(header: Option<(usize, &str)>, path: &Path) -> Result<bool, EvalError> {
    match header {
        Some((_, h)) if h.trim() == FRAMES_CSV_HEADER => Ok(false),
        Some((_, h)) if h.trim() == FRAMES_CSV_HEADER_V1 => Ok(true),
        Some((line, h)) => Err(EvalError::parse(
            path,
            line,
            format!("header {:?}; expected {FRAMES_CSV_HEADER:?}", h.trim()),
        )),
        None => Err(EvalError::parse(
            path,
            1,
            format!("empty file; expected the header {FRAMES_CSV_HEADER:?}"),
        )),
    }
}

/// Parses `frames.csv` text; `path` is only used in error messages.
///
/// # Errors
/// [`EvalError::Parse`] naming the file and 1-based line: a missing or different header, a
/// wrong column count, a bad number or status, or a frame index that repeats.
pub fn parse_frames_csv(text: &str, path: &Path) -> Result<Vec<FrameRecord>, EvalError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.trim().is_empty());
    let v1 = parse_header(lines.next(), path)?;
    let mut rows = Vec::new();
    let mut seen = std::collections::HashMap::new();
    for (line_no, line) in lines {
        let row = parse_row(line.trim(), v1).map_err(|m| EvalError::parse(path, line_no, m))?;
        if let Some(first) = seen.insert(row.frame, line_no) {
            return Err(EvalError::parse(
                path,
                line_no,
                format!(
                    "frame {} already listed on line {first}; expected one row per frame",
                    row.frame
                ),
            ));
        }
        rows.push(row);
    }
    Ok(rows)
}

/// The `frames.csv` layout for [`crate::rows_reader::FrameRowsReader`].
#[derive(Debug, Clone, Copy)]
pub struct FramesCsv;

impl crate::rows_reader::FrameCsv for FramesCsv {
    type Row = FrameRecord;
    /// `true`: the eight-column layout.
    type Header = bool;
    fn header(line: Option<(usize, &str)>, path: &Path) -> Result<bool, EvalError> {
        parse_header(line, path)
    }
    fn row(line: &str, v1: bool) -> Result<FrameRecord, String> {
        parse_row(line, v1)
    }
    fn frame(row: &FrameRecord) -> usize {
        row.frame
    }
}

/// `frames.csv` read one row at a time, in memory independent of its length: the rows must
/// be in frame order (as endoloc writes them), which also rules out a repeated frame.
pub type FramesCsvReader<R> = crate::rows_reader::FrameRowsReader<R, FramesCsv>;

/// Reads `frames.csv` (see the module docs for the format).
///
/// # Errors
/// [`EvalError::Io`] if the file cannot be read; [`EvalError::Parse`] as
/// [`parse_frames_csv`].
pub fn read_frames_csv(path: &Path) -> Result<Vec<FrameRecord>, EvalError> {
    let text = std::fs::read_to_string(path).map_err(|e| EvalError::io(path, e))?;
    parse_frames_csv(&text, path)
}

fn fmt_opt_f64(v: Option<f64>) -> String {
    v.map(|x| format!("{x}")).unwrap_or_default()
}

/// Formats rows as `frames.csv` text (header first; numbers in Rust's shortest round-trip
/// form, so reading gives back the same values).
///
/// # Errors
/// A message naming the first row (0-based) whose `reason` holds a comma, quote or line
/// break, or whose numbers are not finite.
pub fn format_frames_csv(rows: &[FrameRecord]) -> Result<String, String> {
    let mut s = String::with_capacity(64 + rows.len() * 48);
    s.push_str(FRAMES_CSV_HEADER);
    s.push('\n');
    for (i, r) in rows.iter().enumerate() {
        format_frames_csv_row(r, &mut s).map_err(|m| format!("row {i} {m}"))?;
    }
    Ok(s)
}

/// Appends one `frames.csv` row (with its line break) to `out`, in the column order of
/// [`FRAMES_CSV_HEADER`].
///
/// # Errors
/// A message naming the frame when `reason` or `source` holds a comma, quote or line break,
/// or a number is not finite (nothing is appended).
pub fn format_frames_csv_row(r: &FrameRecord, out: &mut String) -> Result<(), String> {
    for (name, word) in [("reason", &r.reason), ("source", &r.source)] {
        if word.contains([',', '"', '\n', '\r']) {
            return Err(format!(
                "(frame {}): {name} {word:?} holds a comma, quote or line break; expected a keyword",
                r.frame
            ));
        }
    }
    let finite = [
        r.zone_score,
        r.reprojection_rms_px,
        r.position_std_mm,
        r.orientation_std_deg,
        Some(r.time_ms),
    ]
    .iter()
    .all(|v| v.is_none_or(f64::is_finite));
    if !finite {
        return Err(format!("(frame {}): a number is not finite", r.frame));
    }
    let zone = r.zone.map(|z| z.to_string()).unwrap_or_else(|| "-1".into());
    let inliers = r.inliers.map(|n| n.to_string()).unwrap_or_default();
    let _ = writeln!(
        out,
        "{},{},{},{},{},{},{},{},{},{},{}",
        r.frame,
        zone,
        fmt_opt_f64(r.zone_score),
        r.status.as_str(),
        r.reason,
        r.source,
        inliers,
        fmt_opt_f64(r.reprojection_rms_px),
        fmt_opt_f64(r.position_std_mm),
        fmt_opt_f64(r.orientation_std_deg),
        r.time_ms
    );
    Ok(())
}

/// Writes `frames.csv` atomically (temporary file in the same folder, then rename).
///
/// # Errors
/// [`EvalError::Invalid`] for a row [`format_frames_csv`] refuses (nothing is written);
/// [`EvalError::Io`] if writing fails.
pub fn write_frames_csv(path: &Path, rows: &[FrameRecord]) -> Result<(), EvalError> {
    let text = format_frames_csv(rows)
        .map_err(|m| EvalError::Invalid(format!("{}: {m}", path.display())))?;
    write_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows() -> Vec<FrameRecord> {
        vec![
            FrameRecord {
                frame: 0,
                zone: Some(12),
                zone_score: Some(0.873_1),
                status: Status::Refined,
                reason: String::new(),
                source: "refined".into(),
                inliers: Some(143),
                reprojection_rms_px: Some(0.1 + 0.2),
                position_std_mm: Some(0.25),
                orientation_std_deg: Some(0.125),
                time_ms: 41.25,
            },
            FrameRecord {
                frame: 1,
                zone: None,
                zone_score: None,
                status: Status::Rejected,
                reason: "jump_too_large".into(),
                source: "none".into(),
                inliers: None,
                reprojection_rms_px: None,
                position_std_mm: None,
                orientation_std_deg: None,
                time_ms: 3.0,
            },
        ]
    }

    #[test]
    fn round_trip_is_exact() {
        let text = format_frames_csv(&rows()).unwrap();
        assert!(text.starts_with(FRAMES_CSV_HEADER));
        assert!(
            text.contains("\n1,-1,,rejected,jump_too_large,none,,,,,3\n"),
            "{text}"
        );
        let back = parse_frames_csv(&text, Path::new("f.csv")).unwrap();
        assert_eq!(back, rows());
    }

    #[test]
    fn errors_name_file_and_line() {
        let p = Path::new("run/frames.csv");
        let text = format!(
            "{FRAMES_CSV_HEADER}\n0,1,0.5,refined,,refined,10,0.5,0.1,0.1,3\n1,2,0.5,refined,refined,10,0.5,0.1,0.1,3\n"
        );
        let e = parse_frames_csv(&text, p).unwrap_err().to_string();
        assert!(
            e.starts_with("run/frames.csv:3:")
                && e.contains("expected 11")
                && e.contains("found 10"),
            "{e}"
        );
        let e = parse_frames_csv("frame,zone\n", p).unwrap_err().to_string();
        assert!(
            e.starts_with("run/frames.csv:1:") && e.contains("header"),
            "{e}"
        );
        let text = format!("{FRAMES_CSV_HEADER}\n0,1,0.5,lost,,,10,0.5,,,3\n");
        let e = parse_frames_csv(&text, p).unwrap_err().to_string();
        assert!(e.contains(":2:") && e.contains("\"lost\""), "{e}");
        let text = format!("{FRAMES_CSV_HEADER}\n0,1,,refined,,,,,,,3\n0,1,,refined,,,,,,,3\n");
        let e = parse_frames_csv(&text, p).unwrap_err().to_string();
        assert!(e.contains(":3:") && e.contains("line 2"), "{e}");
    }

    #[test]
    fn the_eight_column_layout_is_still_read() {
        let text = format!(
            "{FRAMES_CSV_HEADER_V1}\n0,3,0.5,refined,,40,0.7,12.5\n1,-1,,rejected,unreadable_image,,,0\n"
        );
        let rows = parse_frames_csv(&text, Path::new("old/frames.csv")).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(
            (rows[0].zone, rows[0].inliers, rows[0].time_ms),
            (Some(3), Some(40), 12.5)
        );
        assert_eq!(rows[0].reprojection_rms_px, Some(0.7));
        assert!(rows[0].source.is_empty() && rows[0].position_std_mm.is_none());
        assert_eq!(rows[1].reason, "unreadable_image");
    }

    #[test]
    fn writer_refuses_commas_in_reason() {
        let mut r = rows();
        r[1].reason = "degenerate, collinear".into();
        assert!(format_frames_csv(&r).unwrap_err().contains("row 1"));
    }
}
