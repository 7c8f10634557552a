//! Per-frame CSV files (`frames.csv`, `zones.csv`) read one row at a time, in memory
//! independent of their length: a header, then rows in increasing frame order (which also
//! rules out a repeated frame); blank lines are skipped; errors name the file and line.

use std::path::{Path, PathBuf};

use endoloc_data::fsutil::TextLines;

use crate::EvalError;

/// A per-frame CSV layout: how its header and rows are read.
pub trait FrameCsv {
    /// One parsed row.
    type Row;
    /// What the header says about the rows (e.g. which layout version).
    type Header: Copy;
    /// Reads the header line (`None`: the file has no non-blank line).
    ///
    /// # Errors
    /// [`EvalError::Parse`] naming `path` and the line.
    fn header(line: Option<(usize, &str)>, path: &Path) -> Result<Self::Header, EvalError>;
    /// Parses one row; the message says what was expected.
    ///
    /// # Errors
    /// What is wrong with the row.
    fn row(line: &str, header: Self::Header) -> Result<Self::Row, String>;
    /// The row's 0-based test frame index.
    fn frame(row: &Self::Row) -> usize;
}

/// Rows of a [`FrameCsv`] file, read line by line.
pub struct FrameRowsReader<R, F: FrameCsv> {
    lines: TextLines<R>,
    path: PathBuf,
    header: Option<F::Header>,
    last: Option<usize>,
    failed: bool,
}

impl<F: FrameCsv> FrameRowsReader<std::io::BufReader<std::fs::File>, F> {
    /// Opens the file at `path`.
    ///
    /// # Errors
    /// [`EvalError::Data`] naming `path` when it cannot be opened.
    pub fn open(path: &Path) -> Result<Self, EvalError> {
        Ok(Self::new(path, TextLines::open(path)?))
    }
}

impl<R: std::io::BufRead, F: FrameCsv> FrameRowsReader<R, F> {
    /// Rows from `lines`; `path` names the file in errors.
    pub fn new(path: &Path, lines: TextLines<R>) -> Self {
        Self {
            lines,
            path: path.to_path_buf(),
            header: None,
            last: None,
            failed: false,
        }
    }

    fn step(&mut self, line_no: usize, line: &str) -> Result<Option<F::Row>, EvalError> {
        if line.trim().is_empty() {
            return Ok(None);
        }
        let Some(header) = self.header else {
            self.header = Some(F::header(Some((line_no, line)), &self.path)?);
            return Ok(None);
        };
        let row =
            F::row(line.trim(), header).map_err(|m| EvalError::parse(&self.path, line_no, m))?;
        let frame = F::frame(&row);
        if let Some(last) = self.last
            && frame <= last
        {
            return Err(EvalError::parse(
                &self.path,
                line_no,
                format!(
                    "frame {frame} after frame {last}; expected one row per frame, in frame order"
                ),
            ));
        }
        self.last = Some(frame);
        Ok(Some(row))
    }
}

impl<R: std::io::BufRead, F: FrameCsv> Iterator for FrameRowsReader<R, F> {
    type Item = Result<F::Row, EvalError>;

    /// The next row; after the first error, `None`.
    fn next(&mut self) -> Option<Self::Item> {
        while !self.failed {
            let step = match self.lines.next() {
                None if self.header.is_none() => F::header(None, &self.path).map(|_| None),
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
