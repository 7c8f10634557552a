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

/// A zones file read one row at a time, in memory independent of its length: the rows must
/// be in frame order, which also rules out a repeated frame.
pub struct ZonesCsvReader<R> {
    lines: endoloc_data::fsutil::TextLines<R>,
    path: std::path::PathBuf,
    header: bool,
    last: Option<usize>,
    failed: bool,
}

impl ZonesCsvReader<std::io::BufReader<std::fs::File>> {
    /// Opens the zones file at `path`.
    ///
    /// # Errors
    /// [`EvalError::Data`] naming `path` when it cannot be opened.
    pub fn open(path: &Path) -> Result<Self, EvalError> {
        Ok(Self::new(
            path,
            endoloc_data::fsutil::TextLines::open(path)?,
        ))
    }
}

impl<R: std::io::BufRead> ZonesCsvReader<R> {
    /// Rows from `lines`; `path` names the file in errors.
    pub fn new(path: &Path, lines: endoloc_data::fsutil::TextLines<R>) -> Self {
        Self {
            lines,
            path: path.to_path_buf(),
            header: false,
            last: None,
            failed: false,
        }
    }

    fn step(&mut self, line_no: usize, line: &str) -> Result<Option<ZoneLabel>, EvalError> {
        if line.trim().is_empty() {
            return Ok(None);
        }
        if !self.header {
            parse_header(Some((line_no, line)), &self.path)?;
            self.header = true;
            return Ok(None);
        }
        let label = parse_row(line).map_err(|m| EvalError::parse(&self.path, line_no, m))?;
        if let Some(last) = self.last
            && label.frame <= last
        {
            return Err(EvalError::parse(
                &self.path,
                line_no,
                format!(
                    "frame {} after frame {last}; expected one row per frame, in frame order",
                    label.frame
                ),
            ));
        }
        self.last = Some(label.frame);
        Ok(Some(label))
    }
}

impl<R: std::io::BufRead> Iterator for ZonesCsvReader<R> {
    type Item = Result<ZoneLabel, EvalError>;

    /// The next row; after the first error, `None`.
    fn next(&mut self) -> Option<Self::Item> {
        while !self.failed {
            let step = match self.lines.next() {
                None if !self.header => parse_header(None, &self.path).map(|()| None),
                None => return None,
                Some(Err(e)) => Err(e.into()),
                Some(Ok((n, line))) => self.step(n, &line),
            };
            match step {
                Ok(Some(row)) => return Some(Ok(row)),
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
