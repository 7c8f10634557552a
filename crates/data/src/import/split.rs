//! Cutting one imported recording into sequences (train/test) by frame ranges.
//!
//! A split is written `NAME:RANGE[,NAME:RANGE…]` with 0-based, end-exclusive frame ranges of
//! the imported (natural-sorted) recording: `train:0..1500,test:1500..` (an open end runs to
//! the last frame). Ranges must not overlap, so no test frame is also a training frame.
//! The other way to get a test sequence — a second recording of the same colon — needs no
//! split: import both and write them as `train` and `test`.

use super::ImportedSequence;
use crate::DataError;
use std::ops::Range;
use std::path::Path;

/// One named frame range of a split; `end = None` means "to the last frame".
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SplitPart {
    /// Sequence name (letters, digits, `_`, `-`).
    pub name: String,
    /// First frame (0-based).
    pub start: usize,
    /// One past the last frame, or `None` for the end of the recording.
    pub end: Option<usize>,
}

/// Parses `NAME:START..[END],…`.
///
/// # Errors
/// A message saying what was expected (bad name, bad range, duplicate name).
pub fn parse_split(spec: &str) -> Result<Vec<SplitPart>, String> {
    let mut parts: Vec<SplitPart> = Vec::new();
    for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, range) = item
            .split_once(':')
            .ok_or_else(|| format!("{item:?}: expected NAME:START..END (e.g. train:0..1500)"))?;
        let name = name.trim();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return Err(format!(
                "{item:?}: sequence name {name:?} must be letters, digits, '_' or '-'"
            ));
        }
        let (a, b) = range
            .split_once("..")
            .ok_or_else(|| format!("{item:?}: expected a range START..END or START.."))?;
        let start: usize = a
            .trim()
            .parse()
            .map_err(|_| format!("{item:?}: start {a:?} is not a frame number"))?;
        let end = match b.trim() {
            "" => None,
            e => Some(
                e.parse::<usize>()
                    .map_err(|_| format!("{item:?}: end {e:?} is not a frame number"))?,
            ),
        };
        if end.is_some_and(|e| e <= start) {
            return Err(format!("{item:?}: empty range; expected START < END"));
        }
        if parts.iter().any(|p| p.name == name) {
            return Err(format!("sequence {name:?} appears twice"));
        }
        parts.push(SplitPart {
            name: name.to_string(),
            start,
            end,
        });
    }
    if parts.is_empty() {
        return Err("empty split; expected e.g. train:0..1500,test:1500..".into());
    }
    Ok(parts)
}

/// Resolves the parts against a recording of `n` frames into concrete ranges.
///
/// # Errors
/// [`DataError::Invalid`] naming `source` for a range past the end or overlapping ranges.
pub fn resolve_split(
    parts: &[SplitPart],
    n: usize,
    source: &Path,
) -> Result<Vec<(String, Range<usize>)>, DataError> {
    let mut ranges = Vec::with_capacity(parts.len());
    for p in parts {
        let end = p.end.unwrap_or(n);
        if end > n || p.start >= end {
            return Err(DataError::invalid(
                source,
                format!(
                    "split {}:{}..{} is outside the recording's {n} frames (0..{n})",
                    p.name,
                    p.start,
                    p.end.map_or(String::new(), |e| e.to_string())
                ),
            ));
        }
        ranges.push((p.name.clone(), p.start..end));
    }
    for (i, (na, a)) in ranges.iter().enumerate() {
        for (nb, b) in &ranges[i + 1..] {
            if a.start < b.end && b.start < a.end {
                return Err(DataError::invalid(
                    source,
                    format!(
                        "split ranges {na}:{a:?} and {nb}:{b:?} overlap; expected disjoint frame ranges"
                    ),
                ));
            }
        }
    }
    Ok(ranges)
}

/// Cuts `seq` into the named parts (frames and poses keep their time stamps).
///
/// # Errors
/// See [`resolve_split`].
pub fn split_sequence(
    seq: &ImportedSequence,
    parts: &[SplitPart],
) -> Result<Vec<(String, ImportedSequence)>, DataError> {
    let ranges = resolve_split(parts, seq.frames.len(), &seq.source)?;
    Ok(ranges
        .into_iter()
        .map(|(name, r)| {
            let mut notes = seq.notes.clone();
            notes.push(format!("frames {r:?} of {}", seq.source.display()));
            let part = ImportedSequence {
                frames: seq.frames.get(r).unwrap_or_default().to_vec(),
                notes,
                ..seq.clone()
            };
            (name, part)
        })
        .collect())
}
