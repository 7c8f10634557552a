//! Ground-truth zones of the test frames: `zones.csv` with header `frame,zone`.
//!
//! ```text
//! frame,zone
//! 0,0
//! 1,0
//! 2,1
//! ```
//!
//! `frame` is the 0-based test frame index (line order of the test `poses.txt`), `zone` the
//! 0-based zone the frame truly lies in (e.g. the zone of the nearest training frame, as the
//! zoning step labels it). Frames missing from the file have no known zone and are left out of
//! the zone accuracy. Blank lines are ignored.

use std::path::Path;

use crate::EvalError;

/// The header line of a ground-truth zones file, exactly.
pub const ZONES_CSV_HEADER: &str = "frame,zone";

/// One frame's true zone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ZoneLabel {
    /// 0-based test frame index.
    pub frame: usize,
    /// 0-based zone index.
    pub zone: usize,
}

fn parse_header(header: Option<(usize, &str)>, path: &Path) -> Result<(), EvalError> {
    match header {
        Some((_, h)) if h.trim() == ZONES_CSV_HEADER => Ok(()),
        Some((line, h)) => Err(EvalError::parse(
            path,
            line,
            format!("header {:?}; expected {ZONES_CSV_HEADER:?}", h.trim()),
        )),
        None => Err(EvalError::parse(
            path,
            1,
            format!("empty file; expected the header {ZONES_CSV_HEADER:?}"),
        )),
    }
}

fn parse_row(line: &str) -> Result<ZoneLabel, String> {
    let cols: Vec<&str> = line.split(',').map(str::trim).collect();
    let [f, z] = cols.as_slice() else {
        return Err(format!(
            "expected 2 columns (frame,zone); found {}",
            cols.len()
        ));
    };
    let frame: usize = f
        .parse()
        .map_err(|_| format!("frame: {f:?} is not a non-negative integer"))?;
    let zone: usize = z
        .parse()
        .map_err(|_| format!("zone: {z:?} is not a non-negative integer"))?;
    Ok(ZoneLabel { frame, zone })
}

/// Parses `zones.csv` text; `path` is only used in error messages.
///
/// # Errors
/// [`EvalError::Parse`] naming the file and 1-based line (bad header, column count, number,
/// repeated frame).
pub fn parse_zones_csv(text: &str, path: &Path) -> Result<Vec<ZoneLabel>, EvalError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.trim().is_empty());
    parse_header(lines.next(), path)?;
    let mut out: Vec<ZoneLabel> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for (line_no, line) in lines {
        let label = parse_row(line).map_err(|m| EvalError::parse(path, line_no, m))?;
        if !seen.insert(label.frame) {
            return Err(EvalError::parse(
                path,
                line_no,
                format!(
                    "frame {} is listed twice; expected one row per frame",
                    label.frame
                ),
            ));
        }
        out.push(label);
    }
    Ok(out)
}

/// The zones-file layout for [`crate::rows_reader::FrameRowsReader`].
#[derive(Debug, Clone, Copy)]
pub struct ZonesCsv;

impl crate::rows_reader::FrameCsv for ZonesCsv {
    type Row = ZoneLabel;
    type Header = ();
    fn header(line: Option<(usize, &str)>, path: &Path) -> Result<(), EvalError> {
        parse_header(line, path)
    }
    fn row(line: &str, (): ()) -> Result<ZoneLabel, String> {
        parse_row(line)
    }
    fn frame(row: &ZoneLabel) -> usize {
        row.frame
    }
}

/// A zones file read one row at a time, in memory independent of its length: the rows must
/// be in frame order, which also rules out a repeated frame.
pub type ZonesCsvReader<R> = crate::rows_reader::FrameRowsReader<R, ZonesCsv>;

/// Reads a ground-truth zones file (see the module docs).
///
/// # Errors
/// [`EvalError::Io`] if it cannot be read; [`EvalError::Parse`] as [`parse_zones_csv`].
pub fn read_zones_csv(path: &Path) -> Result<Vec<ZoneLabel>, EvalError> {
    let text = std::fs::read_to_string(path).map_err(|e| EvalError::io(path, e))?;
    parse_zones_csv(&text, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_names_bad_lines() {
        let p = Path::new("z.csv");
        let z = parse_zones_csv("frame,zone\n0,3\n\n2,4\n", p).unwrap();
        assert_eq!(
            z,
            vec![
                ZoneLabel { frame: 0, zone: 3 },
                ZoneLabel { frame: 2, zone: 4 }
            ]
        );
        let e = parse_zones_csv("frame,zone\n0,3\n1,-2\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("z.csv:3:") && e.contains("zone"), "{e}");
        let e = parse_zones_csv("frame,zone\n0,3,1\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("z.csv:2:") && e.contains("2 columns"), "{e}");
    }
}
