//! Whitespace tokens of a text file, each with its 1-based line number.

use crate::DataError;
use std::path::Path;
use std::str::FromStr;

/// A cursor over the whitespace-separated tokens of a text, remembering line numbers.
pub(crate) struct Tokens<'a> {
    path: &'a Path,
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    current: std::str::SplitWhitespace<'a>,
    line_no: usize,
    /// Line number of the last line of the text (for end-of-file errors).
    last_line: usize,
    peeked: Option<(&'a str, usize)>,
}

impl<'a> Tokens<'a> {
    /// Tokens of `text` from line `first_line` (1-based; earlier lines are skipped).
    pub fn new(path: &'a Path, text: &'a str, first_line: usize) -> Self {
        let mut lines = text.lines().enumerate();
        let mut skipped = 0;
        while skipped + 1 < first_line {
            if lines.next().is_none() {
                break;
            }
            skipped += 1;
        }
        Tokens {
            path,
            lines,
            current: "".split_whitespace(),
            line_no: skipped,
            last_line: text.lines().count().max(1),
            peeked: None,
        }
    }

    /// The file the tokens come from.
    pub fn path(&self) -> &'a Path {
        self.path
    }

    /// Line number of the last token returned (0 before the first).
    pub fn line(&self) -> usize {
        self.line_no
    }

    /// Line number of the last line of the text.
    pub fn last_line(&self) -> usize {
        self.last_line
    }

    /// The next token and its line, or `None` at the end of the text.
    pub fn next_token(&mut self) -> Option<(&'a str, usize)> {
        if let Some(p) = self.peeked.take() {
            return Some(p);
        }
        loop {
            if let Some(t) = self.current.next() {
                return Some((t, self.line_no));
            }
            let (i, line) = self.lines.next()?;
            self.line_no = i + 1;
            self.current = line.split_whitespace();
        }
    }

    /// The next token without consuming it.
    pub fn peek(&mut self) -> Option<(&'a str, usize)> {
        if self.peeked.is_none() {
            self.peeked = self.next_token();
        }
        self.peeked
    }

    /// Drops the rest of the current line and every following line up to and including the
    /// next blank line (legacy VTK `METADATA` blocks end with a blank line).
    pub fn skip_block_until_blank_line(&mut self) {
        self.peeked = None;
        self.current = "".split_whitespace();
        for (i, line) in self.lines.by_ref() {
            self.line_no = i + 1;
            if line.trim().is_empty() {
                break;
            }
        }
    }

    /// An end-of-file error: "file ends at line N; expected WHAT".
    pub fn eof(&self, expected: &str) -> DataError {
        DataError::parse(
            self.path,
            self.last_line,
            format!("file ends here (truncated?); expected {expected}"),
        )
    }

    /// The next token, or an end-of-file error saying what was expected.
    pub fn expect(&mut self, expected: &str) -> Result<(&'a str, usize), DataError> {
        self.next_token().ok_or_else(|| self.eof(expected))
    }

    /// The next token parsed as `T`, with an error naming the line and what was expected.
    pub fn parse<T: FromStr>(&mut self, expected: &str) -> Result<(T, usize), DataError> {
        let (tok, line) = self.expect(expected)?;
        let v = tok.parse::<T>().map_err(|_| {
            DataError::parse(
                self.path,
                line,
                format!("found {tok:?}; expected {expected}"),
            )
        })?;
        Ok((v, line))
    }

    /// The next token as a finite `f64`.
    pub fn finite(&mut self, expected: &str) -> Result<f64, DataError> {
        let (v, line) = self.parse::<f64>(expected)?;
        if !v.is_finite() {
            return Err(DataError::parse(
                self.path,
                line,
                format!("found {v}; expected {expected} (a finite number)"),
            ));
        }
        Ok(v)
    }

    /// The next token as a vertex index `< n_vertices`.
    pub fn index(&mut self, n_vertices: usize, expected: &str) -> Result<u32, DataError> {
        let (v, line) = self.parse::<i64>(expected)?;
        if v < 0 || v as u64 >= n_vertices as u64 {
            return Err(DataError::parse(
                self.path,
                line,
                format!(
                    "vertex index {v} out of range; expected 0 ≤ index < {n_vertices} (the number of points)"
                ),
            ));
        }
        Ok(v as u32)
    }
}
