//! TUM trajectory files: one line `timestamp tx ty tz qx qy qz qw` per pose, `#` comments.
//!
//! Poses are `T_wc` (camera-to-world), translations in millimetres, timestamps in seconds,
//! quaternions Hamilton `qx qy qz qw` (docs/CONVENTIONS.md). Files written here are read unchanged by
//! other TUM tools (e.g. `evo`).

use crate::DataError;
use crate::fsutil::{read_text, write_atomic};
use endoloc_geometry::{Pose, canonical_quaternion};
use nalgebra::{Quaternion, Translation3, UnitQuaternion};
use std::fmt::Write as _;
use std::path::Path;

/// Largest accepted deviation of a stored quaternion's norm from 1 (it is then normalized).
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// What every pose line must hold, quoted in parse errors.
pub(crate) const TUM_COLUMNS: &str = "timestamp tx ty tz qx qy qz qw";

/// A pose with its time stamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedPose {
    /// Time stamp, seconds.
    pub timestamp_s: f64,
    /// Camera-to-world pose `T_wc`, translation in mm.
    pub pose: Pose,
}

/// Parses one non-comment, non-blank TUM line; the error message says what was expected.
pub(crate) fn parse_tum_line(line: &str) -> Result<StampedPose, String> {
    let cols: Vec<&str> = line.split_whitespace().collect();
    if cols.len() != 8 {
        return Err(format!(
            "expected 8 columns: {TUM_COLUMNS}; found {}",
            cols.len()
        ));
    }
    const NAMES: [&str; 8] = ["timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"];
    let mut v = [0.0f64; 8];
    for (i, c) in cols.iter().enumerate() {
        let x: f64 = c
            .parse()
            .map_err(|_| format!("column {} ({}): {c:?} is not a number", i + 1, NAMES[i]))?;
        if !x.is_finite() {
            return Err(format!(
                "column {} ({}): {c} is not finite; expected a finite number",
                i + 1,
                NAMES[i]
            ));
        }
        v[i] = x;
    }
    let q = Quaternion::new(v[7], v[4], v[5], v[6]);
    let norm = q.norm();
    if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
        return Err(format!(
            "quaternion (qx qy qz qw) has norm {norm:.6}; expected a unit quaternion (norm within {QUATERNION_NORM_TOLERANCE} of 1)"
        ));
    }
    let rotation = UnitQuaternion::from_quaternion(q);
    Ok(StampedPose {
        timestamp_s: v[0],
        pose: Pose::from_parts(Translation3::new(v[1], v[2], v[3]), rotation),
    })
}

/// Parses TUM text; `Err((line, message))` at the first bad line (1-based).
pub(crate) fn parse_tum_text(text: &str) -> Result<Vec<StampedPose>, (usize, String)> {
    let mut order = TumOrder::default();
    let mut poses: Vec<StampedPose> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if let Some(pose) = order.line(line).map_err(|m| (i + 1, m))? {
            poses.push(pose);
        }
    }
    Ok(poses)
}

/// The per-line rule of a TUM file: comments and blank lines skipped, every pose line
/// parsed, time stamps strictly increasing.
#[derive(Debug, Default)]
struct TumOrder {
    last_s: Option<f64>,
}

impl TumOrder {
    fn line(&mut self, line: &str) -> Result<Option<StampedPose>, String> {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            return Ok(None);
        }
        let pose = parse_tum_line(t)?;
        if let Some(last) = self.last_s
            && pose.timestamp_s <= last
        {
            return Err(format!(
                "time stamp {} is not after the previous pose's {last}; expected strictly \
                 increasing time stamps (one pose per frame, in time order)",
                pose.timestamp_s
            ));
        }
        self.last_s = Some(pose.timestamp_s);
        Ok(Some(pose))
    }
}

/// A TUM trajectory read one pose at a time, with the rules of [`read_tum`] and memory
/// independent of the file's length: for passes too long to hold, or read several times.
pub struct TumReader<R> {
    lines: crate::fsutil::TextLines<R>,
    path: std::path::PathBuf,
    order: TumOrder,
    failed: bool,
}

impl TumReader<std::io::BufReader<std::fs::File>> {
    /// Opens the TUM file at `path`.
    ///
    /// # Errors
    /// [`DataError::Io`] naming `path` when it cannot be opened.
    pub fn open(path: &Path) -> Result<Self, DataError> {
        Ok(Self::new(path, crate::fsutil::TextLines::open(path)?))
    }
}

impl<R: std::io::BufRead> TumReader<R> {
    /// Reads TUM lines from `lines`; `path` names the file in errors.
    pub fn new(path: &Path, lines: crate::fsutil::TextLines<R>) -> Self {
        Self {
            lines,
            path: path.to_path_buf(),
            order: TumOrder::default(),
            failed: false,
        }
    }
}

impl<R: std::io::BufRead> Iterator for TumReader<R> {
    type Item = Result<StampedPose, DataError>;

    /// The next pose; after the first error, `None`.
    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        for item in self.lines.by_ref() {
            let step = item.and_then(|(n, line)| {
                self.order
                    .line(&line)
                    .map_err(|m| DataError::parse(&self.path, n, m))
            });
            match step {
                Ok(Some(pose)) => return Some(Ok(pose)),
                Ok(None) => {}
                Err(e) => {
                    self.failed = true;
                    return Some(Err(e));
                }
            }
        }
        None
    }
}

/// Reads a TUM trajectory file.
///
/// Blank lines and lines starting with `#` are skipped. Every other line must have exactly 8
/// finite numbers, its time stamp after the previous line's; the quaternion must have a norm within [`QUATERNION_NORM_TOLERANCE`] of 1
/// and is normalized.
///
/// # Errors
/// [`DataError::Io`] if the file cannot be read; [`DataError::Parse`] naming the first bad
/// line and what was expected.
pub fn read_tum(path: &Path) -> Result<Vec<StampedPose>, DataError> {
    parse_tum(path, &read_text(path)?)
}

/// Parses the text of a TUM trajectory file (see [`read_tum`]); `path` names the file in
/// errors.
///
/// # Errors
/// [`DataError::Parse`] naming the first bad line and what was expected.
pub fn parse_tum(path: &Path, text: &str) -> Result<Vec<StampedPose>, DataError> {
    parse_tum_text(text).map_err(|(line, message)| DataError::parse(path, line, message))
}

/// The comment line that starts every TUM trajectory endoloc writes (with its line break).
pub const TUM_HEADER: &str =
    "# endoloc trajectory (TUM): timestamp[s] tx ty tz[mm] qx qy qz qw; T_wc camera-to-world\n";

/// Appends one TUM line (with its line break) for `p` to `out`: timestamp with microsecond
/// resolution, translation (mm) with 9 decimals, quaternion with 12 and `qw ≥ 0`, so that
/// reading gives back the pose to better than 1e-9 in every component.
///
/// # Errors
/// A message quoting the values when one is not finite (nothing is appended).
pub fn format_tum_line(p: &StampedPose, out: &mut String) -> Result<(), String> {
    let t = p.pose.translation.vector;
    let q = canonical_quaternion(p.pose.rotation);
    let all = [p.timestamp_s, t.x, t.y, t.z, q.i, q.j, q.k, q.w];
    if !all.iter().all(|v| v.is_finite()) {
        return Err(format!("a non-finite value: {all:?}"));
    }
    let _ = writeln!(
        out,
        "{:.6} {:.9} {:.9} {:.9} {:.12} {:.12} {:.12} {:.12}",
        p.timestamp_s, t.x, t.y, t.z, q.i, q.j, q.k, q.w
    );
    Ok(())
}

/// Formats poses as TUM text with a header comment (see [`write_tum`]).
///
/// # Errors
/// A message naming the first pose (0-based) with a non-finite value.
pub(crate) fn format_tum(poses: &[StampedPose]) -> Result<String, String> {
    let mut s = String::with_capacity(64 + poses.len() * 120);
    s.push_str(TUM_HEADER);
    for (i, p) in poses.iter().enumerate() {
        format_tum_line(p, &mut s).map_err(|m| format!("pose {i} has {m}"))?;
    }
    Ok(s)
}

/// Writes a TUM trajectory file atomically (temporary file in the same folder, flushed, then
/// renamed), with a header comment. Quaternions are written with `qw ≥ 0`; timestamps with
/// microsecond resolution, translations (mm) with 9 decimals and quaternions with 12.
///
/// # Errors
/// [`DataError::Invalid`] if a pose holds a non-finite value (nothing is written);
/// [`DataError::Io`] if writing fails.
pub fn write_tum(path: &Path, poses: &[StampedPose]) -> Result<(), DataError> {
    let text = format_tum(poses).map_err(|m| DataError::invalid(path, m))?;
    write_atomic(path, text.as_bytes())
}

/// The comment line that starts every frame-times file endoloc writes (with its line break).
pub const FRAME_TIMES_HEADER: &str =
    "# endoloc frame times: timestamp[s], one line per image (a pass without poses)\n";

/// Reads a frame-times file ([`FRAME_TIMES_FILE`](crate::FRAME_TIMES_FILE)): one time stamp (seconds)
/// per non-comment line, strictly increasing; blank lines and `#` comments skipped.
///
/// # Errors
/// [`DataError::Io`] if the file cannot be read; [`DataError::Parse`] naming the first line
/// that is not one finite number after the previous line's.
pub fn read_frame_times(path: &Path) -> Result<Vec<f64>, DataError> {
    let text = read_text(path)?;
    let mut times: Vec<f64> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let bad = |m: String| DataError::parse(path, i + 1, m);
        let cols: Vec<&str> = t.split_whitespace().collect();
        let [col] = cols[..] else {
            return Err(bad(format!(
                "expected 1 column: timestamp (seconds); found {}",
                cols.len()
            )));
        };
        let v: f64 = col
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| bad(format!("{col:?}: expected a finite time stamp in seconds")))?;
        if let Some(&last) = times.last()
            && v <= last
        {
            return Err(bad(format!(
                "time stamp {v} is not after the previous frame's {last}; expected strictly \
                 increasing time stamps (one line per image, in time order)"
            )));
        }
        times.push(v);
    }
    Ok(times)
}

/// Writes a frame-times file atomically: [`FRAME_TIMES_HEADER`], then one time stamp per line
/// (seconds, microsecond resolution).
///
/// # Errors
/// [`DataError::Invalid`] if a time is not finite or not after the one before (nothing is
/// written); [`DataError::Io`] if writing fails.
pub fn write_frame_times(path: &Path, times: &[f64]) -> Result<(), DataError> {
    let mut text = String::from(FRAME_TIMES_HEADER);
    for (i, &t) in times.iter().enumerate() {
        if !t.is_finite() || (i > 0 && t <= times[i - 1]) {
            return Err(DataError::invalid(
                path,
                format!("frame {i}: time {t}; expected finite, strictly increasing time stamps"),
            ));
        }
        let _ = writeln!(text, "{t:.6}");
    }
    write_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_times_round_trip_and_a_bad_line_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frames.txt");
        write_frame_times(&path, &[0.0, 0.033367, 0.066733]).unwrap();
        assert_eq!(read_frame_times(&path).unwrap(), [0.0, 0.033367, 0.066733]);
        assert!(write_frame_times(&path, &[0.1, 0.1]).is_err());
        std::fs::write(&path, "# t\n0.0\n0.5 1\n").unwrap();
        let e = read_frame_times(&path).unwrap_err().to_string();
        assert!(e.contains(":3") && e.contains("expected 1 column"), "{e}");
        std::fs::write(&path, "0.2\nNaN\n").unwrap();
        let e = read_frame_times(&path).unwrap_err().to_string();
        assert!(e.contains(":2") && e.contains("finite"), "{e}");
        std::fs::write(&path, "0.2\n0.1\n").unwrap();
        let e = read_frame_times(&path).unwrap_err().to_string();
        assert!(e.contains(":2") && e.contains("increasing"), "{e}");
    }

    #[test]
    fn line_errors_say_what_was_expected() {
        let e = parse_tum_line("0 1 2 3 0 0 0").unwrap_err();
        assert!(
            e.contains("expected 8 columns") && e.contains("found 7"),
            "{e}"
        );
        let e = parse_tum_line("0 1 2 3 0 0 0 2").unwrap_err();
        assert!(e.contains("norm 2.000000"), "{e}");
        let e = parse_tum_line("0 1 x 3 0 0 0 1").unwrap_err();
        assert!(e.contains("column 3 (ty)"), "{e}");
        let e = parse_tum_line("0 1 2 inf 0 0 0 1").unwrap_err();
        assert!(
            e.contains("column 4 (tz)") && e.contains("not finite"),
            "{e}"
        );
    }

    #[test]
    fn the_streaming_reader_reads_what_read_tum_reads_and_names_the_same_line() {
        let text = "# c\n0.1 1 2 3 0 0 0 1\n\n0.2 4 5 6 0 0 0 1\r\n0.15 1 2 3 0 0 0 1\n";
        let p = Path::new("t.txt");
        let read = |t: &str| -> Result<Vec<StampedPose>, DataError> {
            TumReader::new(p, crate::fsutil::TextLines::new(p, t.as_bytes())).collect()
        };
        let whole = parse_tum(p, text).unwrap_err().to_string();
        let streamed = read(text).unwrap_err().to_string();
        assert_eq!(whole, streamed);
        assert!(streamed.starts_with("t.txt:5:"), "{streamed}");
        let ok = "0.1 1 2 3 0 0 0 1\n0.2 4 5 6 0 0 0 1";
        assert_eq!(read(ok).unwrap(), parse_tum(p, ok).unwrap());
        let e = read("0.1 1 2 3 0 0 0 1\n\u{0}\u{ff}")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.txt:2:"), "{e}");
        let bad = [b'0', b' ', 0xff, b'\n'];
        let e: Result<Vec<_>, _> =
            TumReader::new(p, crate::fsutil::TextLines::new(p, &bad[..])).collect();
        assert!(e.unwrap_err().to_string().contains("UTF-8"));
    }

    #[test]
    fn slightly_off_quaternion_is_normalized() {
        let p = parse_tum_line("0.5 1 2 3 0 0 0 1.0005").unwrap();
        assert!((p.pose.rotation.into_inner().norm() - 1.0).abs() < 1e-12);
        assert_eq!(p.timestamp_s, 0.5);
    }
}
