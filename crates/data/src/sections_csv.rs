//! `sections.csv`: one anatomical label per frame, header `frame,section`.

use crate::fsutil::{read_text, write_atomic};
use crate::{DataError, Section};
use std::fmt::Write as _;
use std::path::Path;

/// The header line of `sections.csv`.
pub const SECTIONS_HEADER: &str = "frame,section";

/// Parses `sections.csv` text, collecting every problem as `(line, message)` (1-based lines).
/// Returns one entry per data row (`None` where the row is bad).
pub(crate) fn parse_sections_text(text: &str) -> (Vec<Option<Section>>, Vec<(usize, String)>) {
    let mut rows = Vec::new();
    let mut problems = Vec::new();
    let mut header_seen = false;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if !header_seen {
            header_seen = true;
            let norm: String = line.chars().filter(|c| !c.is_whitespace()).collect();
            if norm.eq_ignore_ascii_case(SECTIONS_HEADER) {
                continue;
            }
            problems.push((
                line_no,
                format!("expected the header `{SECTIONS_HEADER}`, found {line:?}"),
            ));
            // Fall through: the line may still be a data row.
        }
        let expected_frame = rows.len();
        let mut cols = line.split(',').map(str::trim);
        let (Some(f), Some(s), None) = (cols.next(), cols.next(), cols.next()) else {
            problems.push((
                line_no,
                format!("expected 2 columns `frame,section`, found {line:?}"),
            ));
            rows.push(None);
            continue;
        };
        match f.parse::<usize>() {
            Ok(frame) if frame == expected_frame => {}
            Ok(frame) => problems.push((
                line_no,
                format!(
                    "frame {frame}; expected frame {expected_frame} (rows in frame order, from 0)"
                ),
            )),
            Err(_) => problems.push((
                line_no,
                format!("frame {f:?} is not a frame index; expected {expected_frame}"),
            )),
        }
        match s.parse::<Section>() {
            Ok(sec) => rows.push(Some(sec)),
            Err(e) => {
                problems.push((line_no, e.to_string()));
                rows.push(None);
            }
        }
    }
    (rows, problems)
}

/// Reads `sections.csv` (header `frame,section`, frames 0, 1, 2, … in order).
///
/// # Errors
/// [`DataError::Io`] if unreadable; [`DataError::Parse`] naming the first bad line.
pub fn read_sections(path: &Path) -> Result<Vec<Section>, DataError> {
    parse_sections(path, &read_text(path)?)
}

/// Parses the text of `sections.csv` (see [`read_sections`]); `path` names the file in errors.
///
/// # Errors
/// [`DataError::Parse`] naming the first bad line.
pub fn parse_sections(path: &Path, text: &str) -> Result<Vec<Section>, DataError> {
    let (rows, problems) = parse_sections_text(text);
    if let Some((line, message)) = problems.into_iter().next() {
        return Err(DataError::parse(path, line, message));
    }
    Ok(rows.into_iter().flatten().collect())
}

/// Writes `sections.csv` atomically: the header then `frame,label` rows.
///
/// # Errors
/// [`DataError::Io`] if writing fails.
pub fn write_sections(path: &Path, sections: &[Section]) -> Result<(), DataError> {
    let mut s = String::with_capacity(16 + sections.len() * 16);
    s.push_str(SECTIONS_HEADER);
    s.push('\n');
    for (i, sec) in sections.iter().enumerate() {
        let _ = writeln!(s, "{i},{}", sec.as_str());
    }
    write_atomic(path, s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_problems_are_collected_with_lines() {
        let text = "frame,section\n0,rectum\n1,colon\n5,rectum\n3\n";
        let (rows, problems) = parse_sections_text(text);
        assert_eq!(rows.len(), 4);
        let lines: Vec<usize> = problems.iter().map(|p| p.0).collect();
        assert_eq!(lines, vec![3, 4, 5], "{problems:?}");
        assert!(problems[0].1.contains("\"colon\""));
        assert!(problems[1].1.contains("expected frame 2"));
    }

    #[test]
    fn missing_header_is_reported() {
        let (rows, problems) = parse_sections_text("0,rectum\n");
        assert_eq!(rows, vec![Some(Section::Rectum)]);
        assert_eq!(problems.len(), 1);
        assert!(problems[0].1.contains("header"));
    }
}
