//! Colon mid-line paths and anatomical landmarks on them.
//!
//! A mid-line path is a polyline through the lumen from the anus to the caecum (the GCA
//! models: about one point per mm). Landmarks are indices into it. From the landmarks,
//! [`section_ranges`] cuts the path into the anatomical [`Section`]s.

use crate::fsutil::read_text;
use crate::{DataError, Section};
use nalgebra::Point3;
use serde::Deserialize;
use std::fmt;
use std::path::Path;

/// Reads a mid-line path (positions in the file's units, mm for the GCA models).
///
/// - `.jsn` / `.json`: the GCA layout `{"n": N, "points": [[x, y, z], …], "tangents": …,
///   "normals": …}`; `n` must equal the number of points when present.
/// - `.csv` / `.txt`: one point `x,y,z` per line (commas, semicolons or spaces); an optional
///   header line; `#` comments.
///
/// # Errors
/// [`DataError::Parse`] naming the line (CSV) or the point index (JSON, line 0 unless the JSON
/// itself is malformed) and what was expected — a non-finite coordinate (`NaN`, `Infinity`),
/// a point without 3 coordinates, `n` not matching; [`DataError::Invalid`] for an unknown
/// extension or an empty path; [`DataError::Io`].
pub fn read_path(path: &Path) -> Result<Vec<Point3<f64>>, DataError> {
    parse_path(path, &read_text(path)?)
}

/// Parses the text of a mid-line path file, in the format of `path`'s extension (see
/// [`read_path`]); `path` names the file in errors.
///
/// # Errors
/// As [`read_path`], without [`DataError::Io`].
pub fn parse_path(path: &Path, text: &str) -> Result<Vec<Point3<f64>>, DataError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let points = match ext.as_str() {
        "jsn" | "json" => parse_path_json(path, text)?,
        "csv" | "txt" => parse_path_csv(path, text)?,
        _ => {
            return Err(DataError::invalid(
                path,
                format!("unknown path extension {ext:?}; expected .jsn, .json, .csv or .txt"),
            ));
        }
    };
    if points.is_empty() {
        return Err(DataError::invalid(
            path,
            "the path has no points; expected at least 2",
        ));
    }
    Ok(points)
}

/// Replaces the non-standard JSON number tokens `NaN`, `Infinity`, `-Infinity` (as written by
/// Python's `json`), outside strings, with `null`, so that they can be reported per point.
/// Line numbers are unchanged.
fn nulls_for_non_finite(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.char_indices().peekable();
    let mut in_string = false;
    let mut escaped = false;
    while let Some((i, c)) = chars.next() {
        if in_string {
            out.push(c);
            if escaped {
                escaped = false;
            } else if c == '\\' {
                escaped = true;
            } else if c == '"' {
                in_string = false;
            }
            continue;
        }
        let starts_word = c.is_ascii_alphabetic()
            || (c == '-' && chars.peek().is_some_and(|(_, n)| n.is_ascii_alphabetic()));
        if c == '"' {
            in_string = true;
            out.push(c);
        } else if starts_word {
            let mut end = i + c.len_utf8();
            while let Some(&(j, n)) = chars.peek() {
                if n.is_ascii_alphanumeric() {
                    end = j + n.len_utf8();
                    chars.next();
                } else {
                    break;
                }
            }
            let word = &text[i..end];
            let bare = word.trim_start_matches('-').to_ascii_lowercase();
            if matches!(bare.as_str(), "nan" | "infinity" | "inf") {
                out.push_str("null");
            } else {
                out.push_str(word);
            }
        } else {
            out.push(c);
        }
    }
    out
}

#[derive(Deserialize)]
struct GcaPathFile {
    n: Option<usize>,
    points: Vec<Vec<Option<f64>>>,
}

fn parse_path_json(path: &Path, text: &str) -> Result<Vec<Point3<f64>>, DataError> {
    let clean = nulls_for_non_finite(text);
    let file: GcaPathFile = serde_json::from_str(&clean).map_err(|e| {
        DataError::parse(
            path,
            e.line(),
            format!("{e}; expected {{\"n\": N, \"points\": [[x, y, z], …]}}"),
        )
    })?;
    let mut points = Vec::with_capacity(file.points.len());
    for (i, p) in file.points.iter().enumerate() {
        let [Some(x), Some(y), Some(z)] = p.as_slice() else {
            let message = if p.len() != 3 {
                format!("point {i} has {} coordinates; expected [x, y, z]", p.len())
            } else {
                format!(
                    "point {i} has a non-finite coordinate (NaN, Infinity or null); expected finite numbers"
                )
            };
            return Err(DataError::parse(path, 0, message));
        };
        if ![x, y, z].iter().all(|v| v.is_finite()) {
            return Err(DataError::parse(
                path,
                0,
                format!("point {i} has a non-finite coordinate; expected finite numbers"),
            ));
        }
        points.push(Point3::new(*x, *y, *z));
    }
    if let Some(n) = file.n
        && n != points.len()
    {
        return Err(DataError::parse(
            path,
            0,
            format!(
                "\"n\" is {n} but there are {} points; expected them equal",
                points.len()
            ),
        ));
    }
    Ok(points)
}

fn parse_path_csv(path: &Path, text: &str) -> Result<Vec<Point3<f64>>, DataError> {
    let mut points = Vec::new();
    let mut first_data_line = true;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cols: Vec<&str> = line
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .collect();
        let parsed: Vec<Option<f64>> = cols.iter().map(|c| c.parse::<f64>().ok()).collect();
        let is_first = std::mem::replace(&mut first_data_line, false);
        if is_first && parsed.iter().all(Option::is_none) {
            continue; // header, e.g. `x,y,z`
        }
        if cols.len() != 3 {
            return Err(DataError::parse(
                path,
                line_no,
                format!("found {} columns; expected 3: x,y,z", cols.len()),
            ));
        }
        let mut v = [0.0; 3];
        for (k, (c, p)) in cols.iter().zip(&parsed).enumerate() {
            match p {
                Some(x) if x.is_finite() => v[k] = *x,
                Some(_) => {
                    return Err(DataError::parse(
                        path,
                        line_no,
                        format!("{c} is not finite; expected a finite coordinate"),
                    ));
                }
                None => {
                    return Err(DataError::parse(
                        path,
                        line_no,
                        format!("{c:?} is not a number; expected x,y,z"),
                    ));
                }
            }
        }
        points.push(Point3::new(v[0], v[1], v[2]));
    }
    Ok(points)
}

/// Cumulative arc length along a polyline: element `i` is the length from point 0 to point
/// `i`, in the points' units (mm). Empty for an empty polyline.
pub fn cumulative_length(points: &[Point3<f64>]) -> Vec<f64> {
    let mut acc = 0.0;
    let mut out = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            acc += (p - points[i - 1]).norm();
        }
        out.push(acc);
    }
    out
}

/// An anatomical landmark on a mid-line path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Landmark {
    /// Anatomy text, e.g. "recto-sigmoid junction".
    pub name: String,
    /// Abbreviation, e.g. "RSJ".
    pub abbreviation: String,
    /// Index of the landmark's point on the path.
    pub path_index: usize,
}

/// Reads the landmarks of the large intestine from a GCA model configuration JSON
/// (e.g. `EdinGCA_3D_00090_1_1.json`).
///
/// Each entry of `"landmarks"` gives `"anatomy"[0].abbreviated_name` / `.text`, the ids of the
/// paths it lies on (`"paths"`) and its index on them (`"position"[0]`). The large-intestine
/// path is the one of the landmark abbreviated `anus`; only landmarks on that path are kept,
/// sorted by path index.
///
/// # Errors
/// [`DataError::Parse`] for malformed JSON (its line) or a landmark without these fields (line
/// 0, naming the landmark's index); [`DataError::Invalid`] when no landmark is abbreviated
/// `anus`; [`DataError::Io`].
pub fn read_gca_landmarks(path: &Path) -> Result<Vec<Landmark>, DataError> {
    parse_gca_landmarks(path, &read_text(path)?)
}

/// Parses the text of a GCA model configuration JSON (see [`read_gca_landmarks`]); `path`
/// names the file in errors.
///
/// # Errors
/// As [`read_gca_landmarks`], without [`DataError::Io`].
pub fn parse_gca_landmarks(path: &Path, text: &str) -> Result<Vec<Landmark>, DataError> {
    let root: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| DataError::parse(path, e.line(), format!("{e}; expected a GCA model JSON")))?;
    let entries = root
        .get("landmarks")
        .and_then(|l| l.as_array())
        .ok_or_else(|| DataError::parse(path, 0, "expected a top-level \"landmarks\" array"))?;
    struct Raw {
        lm: Landmark,
        paths: Vec<String>,
    }
    let mut raws = Vec::with_capacity(entries.len());
    for (i, e) in entries.iter().enumerate() {
        let bad = |what: &str| {
            DataError::parse(
                path,
                0,
                format!("landmark {i} (0-based in \"landmarks\"): expected {what}"),
            )
        };
        let anatomy = e
            .get("anatomy")
            .and_then(|a| a.get(0))
            .ok_or_else(|| bad("\"anatomy\": [{…}]"))?;
        let abbreviation = anatomy
            .get("abbreviated_name")
            .and_then(|v| v.as_str())
            .ok_or_else(|| bad("\"anatomy\"[0].\"abbreviated_name\" (a string)"))?;
        let name = anatomy
            .get("text")
            .and_then(|v| v.as_str())
            .unwrap_or(abbreviation);
        let paths: Vec<String> = e
            .get("paths")
            .and_then(|p| p.as_array())
            .ok_or_else(|| bad("\"paths\": [\"PATH_ID\", …]"))?
            .iter()
            .filter_map(|p| p.as_str().map(str::to_string))
            .collect();
        let position = e
            .get("position")
            .and_then(|p| p.get(0))
            .and_then(|p| p.as_u64())
            .ok_or_else(|| bad("\"position\": [INDEX] with a non-negative integer"))?;
        raws.push(Raw {
            lm: Landmark {
                name: name.to_string(),
                abbreviation: abbreviation.to_string(),
                path_index: position as usize,
            },
            paths,
        });
    }
    let anus = raws
        .iter()
        .find(|r| r.lm.abbreviation.eq_ignore_ascii_case("anus"))
        .ok_or_else(|| {
            DataError::invalid(
                path,
                "no landmark abbreviated \"anus\"; expected one, to identify the large-intestine path",
            )
        })?;
    let path_id = anus.paths.first().cloned().ok_or_else(|| {
        DataError::invalid(
            path,
            "the \"anus\" landmark lists no path; expected its path id",
        )
    })?;
    let mut out: Vec<Landmark> = raws
        .into_iter()
        .filter(|r| r.paths.contains(&path_id))
        .map(|r| r.lm)
        .collect();
    out.sort_by_key(|l| l.path_index);
    Ok(out)
}

/// A contiguous run of path points with one anatomical label.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SectionRange {
    /// The label.
    pub section: Section,
    /// First path index (inclusive).
    pub start: usize,
    /// One past the last path index.
    pub end: usize,
}

/// Half-widths (path points, ≈ mm on the GCA paths) of the windows around junctions.
const ANAL_CANAL_POINTS: usize = 30;
const RECTOSIGMOID_HALF: usize = 15;
const FLEXURE_HALF: usize = 40;

/// Path index of the landmark abbreviated `abbr` (case-insensitive).
fn find(landmarks: &[Landmark], abbr: &str) -> Option<usize> {
    landmarks
        .iter()
        .find(|l| l.abbreviation.eq_ignore_ascii_case(abbr))
        .map(|l| l.path_index)
}

/// The six landmarks that bound the sections, in insertion order: abbreviation (GCA), name,
/// and typical distance from the anus along an adult colon, mm (from the typical section
/// lengths: anal canal 35, rectum 120, recto-sigmoid 30, sigmoid 400, descending 250, splenic
/// flexure 80, transverse 450, hepatic flexure 80, ascending 150, caecum 60).
const BOUNDS: [(&str, &str, f64); 6] = [
    ("anus", "anus", 0.0),
    ("RSJ", "recto-sigmoid junction", 170.0),
    ("DSJ", "descending-sigmoid junction", 585.0),
    ("SF", "splenic flexure", 875.0),
    ("HF", "hepatic flexure", 1405.0),
    ("CCJ", "caeco-colonic junction", 1595.0),
];

/// Typical distance from the anus to the caecal pole (where the appendix orifice lies), mm.
const TYPICAL_CAECAL_POLE_MM: f64 = 1655.0;

/// A section-bounding landmark that the landmark file lacks, and where the cut placed it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EstimatedLandmark {
    /// Abbreviation of the missing landmark, e.g. "RSJ".
    pub abbreviation: &'static str,
    /// Its anatomy text, e.g. "recto-sigmoid junction".
    pub name: &'static str,
    /// The path index it was placed at.
    pub path_index: usize,
    /// How: e.g. "the caecum starts at ICVc (path index 1549)", or "by typical section lengths
    /// between anus (path index 0) and DSJ (path index 910)".
    pub how: String,
}

impl fmt::Display for EstimatedLandmark {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "landmark {} ({}) is missing: placed at path index {}, {}",
            self.abbreviation, self.name, self.path_index, self.how
        )
    }
}

/// The anatomical sections of a path and the landmarks that had to be estimated for them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SectionCut {
    /// The ten sections in insertion order, covering the path.
    pub ranges: Vec<SectionRange>,
    /// Section-bounding landmarks absent from the file, with where they were placed; empty
    /// when the file has all of anus, RSJ, DSJ, SF, HF and CCJ.
    pub estimated: Vec<EstimatedLandmark>,
}

/// Cuts a path of `n_points` points into the ten anatomical sections, in insertion order,
/// from the landmarks abbreviated `anus`, `RSJ`, `DSJ`, `SF`, `HF`, `CCJ` (GCA names):
///
/// | section | path indices |
/// |---|---|
/// | anal canal | from 0 to anus + 30 points, at most a third of the way to RSJ |
/// | rectum | to RSJ − 15 |
/// | recto-sigmoid | RSJ ± 15 |
/// | sigmoid | to DSJ |
/// | descending | to SF − 40 |
/// | splenic flexure | SF ± 40 |
/// | transverse | to HF − 40 |
/// | hepatic flexure | HF ± 40 |
/// | ascending | to CCJ |
/// | caecum | from CCJ to the end |
///
/// (GCA paths have about one point per mm, so these are about mm.) A window never takes
/// more than a third of the way to the neighbouring landmark, and every section keeps at least
/// one point. `ICVc` and `AO`, when present, must lie in the caecum.
///
/// Landmark files do not always have all six (several GCA models lack RSJ and CCJ). A
/// missing one is placed, and listed in [`SectionCut::estimated`]:
///
/// - `anus`: path index 0 (paths start at the anus);
/// - `CCJ`: at the ileocaecal valve `ICVc` when present (the caecum starts at the valve);
/// - any other: between its nearest present neighbours, in proportion to typical adult
///   section lengths (see `BOUNDS` above: RSJ 170 mm from the anus, DSJ 585, SF 875, HF
///   1405, CCJ 1595, caecal pole 1655). Beyond the last present landmark the far anchor is
///   the appendix orifice `AO` (the caecal pole) when present, else the end of the path.
///
/// # Errors
/// [`DataError::Anatomy`] naming present landmarks out of order or beyond the path, `ICVc`
/// or `AO` before the caecum, or a path with fewer than 10 points.
pub fn section_cut(n_points: usize, landmarks: &[Landmark]) -> Result<SectionCut, DataError> {
    if n_points < Section::ALL.len() {
        return Err(DataError::Anatomy {
            message: format!(
                "the path has {n_points} points; expected at least {} (one per section)",
                Section::ALL.len()
            ),
        });
    }
    for l in landmarks {
        if l.path_index >= n_points {
            return Err(DataError::Anatomy {
                message: format!(
                    "landmark {} is at path index {}; expected < {n_points} (the number of path points)",
                    l.abbreviation, l.path_index
                ),
            });
        }
    }
    // The present bounds, with CCJ taken from ICVc when it is missing.
    let mut at: [Option<usize>; 6] = BOUNDS.map(|(abbr, _, _)| find(landmarks, abbr));
    let mut estimated = Vec::new();
    let icvc = find(landmarks, "ICVc");
    let ao = find(landmarks, "AO");
    if at[5].is_none()
        && let Some(i) = icvc
    {
        at[5] = Some(i);
        estimated.push(EstimatedLandmark {
            abbreviation: BOUNDS[5].0,
            name: BOUNDS[5].1,
            path_index: i,
            how: format!("the caecum starts at ICVc (path index {i})"),
        });
    }
    let present: Vec<(usize, usize)> = at
        .iter()
        .enumerate()
        .filter_map(|(k, i)| i.map(|i| (k, i)))
        .collect();
    for w in present.windows(2) {
        let ((k0, i0), (k1, i1)) = (w[0], w[1]);
        if i1 <= i0 {
            let order = BOUNDS.map(|b| b.0).join(" < ");
            return Err(DataError::Anatomy {
                message: format!(
                    "landmark {} (index {i1}) is not after {} (index {i0}); expected the order {order} along the path",
                    BOUNDS[k1].0, BOUNDS[k0].0
                ),
            });
        }
    }
    // The far anchor: the caecal pole (AO) or the end of the path.
    let (pole, pole_name) = match ao {
        Some(i) => (i, "AO"),
        None => (n_points - 1, "the end of the path"),
    };
    for k in 0..6 {
        if at[k].is_some() {
            continue;
        }
        if k == 0 {
            at[0] = Some(0);
            estimated.push(EstimatedLandmark {
                abbreviation: BOUNDS[0].0,
                name: BOUNDS[0].1,
                path_index: 0,
                how: "the start of the path".into(),
            });
            continue;
        }
        // Nearest present (or already placed) neighbour before, present one after.
        let (kp, ip) = (0..k)
            .rev()
            .find_map(|q| at[q].map(|i| (q, i)))
            .unwrap_or((0, 0));
        let next = (k + 1..6).find_map(|q| at[q].map(|i| (q, i)));
        let (tn, in_, next_name) = match next {
            Some((q, i)) => (BOUNDS[q].2, i, format!("{} (path index {i})", BOUNDS[q].0)),
            None => (
                TYPICAL_CAECAL_POLE_MM,
                pole.max(ip),
                format!("{pole_name} (path index {pole})"),
            ),
        };
        let tp = BOUNDS[kp].2;
        let f = (BOUNDS[k].2 - tp) / (tn - tp);
        let i = ip + ((in_ - ip) as f64 * f).round() as usize;
        at[k] = Some(i);
        estimated.push(EstimatedLandmark {
            abbreviation: BOUNDS[k].0,
            name: BOUNDS[k].1,
            path_index: i,
            how: format!(
                "by typical section lengths between {} (path index {ip}) and {next_name}",
                BOUNDS[kp].0
            ),
        });
    }
    estimated.sort_by_key(|e| BOUNDS.iter().position(|b| b.0 == e.abbreviation));
    let [a, r, d, s, h, c] = at.map(|i| i.unwrap_or(0));
    for (abbr, name, i) in [
        ("ICVc", "ileocaecal valve", icvc),
        ("AO", "appendix orifice", ao),
    ] {
        if let Some(i) = i
            && i < c
        {
            return Err(DataError::Anatomy {
                message: format!(
                    "landmark {abbr} ({name}) is at path index {i}; expected in the caecum, {c}..{n_points}"
                ),
            });
        }
    }
    // A window around landmark `l` between neighbours `p` and `n`, each side at most a third
    // of the way to the neighbour.
    let window = |l: usize, p: usize, n: usize, half: usize| {
        (
            l - half.min(l.saturating_sub(p) / 3),
            l + half.min(n.saturating_sub(l) / 3),
        )
    };
    let anal_end = a + ANAL_CANAL_POINTS.min(r.saturating_sub(a) / 3);
    let (rs_lo, rs_hi) = window(r, a, d, RECTOSIGMOID_HALF);
    let (sf_lo, sf_hi) = window(s, d, h, FLEXURE_HALF);
    let (hf_lo, hf_hi) = window(h, s, c, FLEXURE_HALF);
    let mut b = [
        0, anal_end, rs_lo, rs_hi, d, sf_lo, sf_hi, hf_lo, hf_hi, c, n_points,
    ];
    // Keep every section non-empty and the order strict (only bites on tiny paths).
    for k in 1..10 {
        b[k] = b[k].max(b[k - 1] + 1);
    }
    for k in (1..10).rev() {
        b[k] = b[k].min(b[k + 1] - 1);
    }
    let ranges = Section::ALL
        .iter()
        .enumerate()
        .map(|(k, &section)| SectionRange {
            section,
            start: b[k],
            end: b[k + 1],
        })
        .collect();
    Ok(SectionCut { ranges, estimated })
}

/// The ten sections of a path from its landmarks; see [`section_cut`] for the rules and for
/// the landmarks that were estimated.
///
/// # Errors
/// As [`section_cut`].
pub fn section_ranges(
    n_points: usize,
    landmarks: &[Landmark],
) -> Result<Vec<SectionRange>, DataError> {
    Ok(section_cut(n_points, landmarks)?.ranges)
}

/// One [`Section`] per path point, from the landmarks; see [`section_ranges`] for the rules.
///
/// # Errors
/// As [`section_ranges`].
pub fn sections_from_landmarks(
    n_points: usize,
    landmarks: &[Landmark],
) -> Result<Vec<Section>, DataError> {
    let ranges = section_cut(n_points, landmarks)?.ranges;
    let mut out = Vec::with_capacity(n_points);
    for r in ranges {
        out.extend(std::iter::repeat_n(r.section, r.end - r.start));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn python_non_finite_tokens_become_null_outside_strings() {
        let t = "{\"a\": [NaN, -Infinity, 1.5e3], \"s\": \"NaN \\\" Infinity\", \"b\": true}";
        assert_eq!(
            nulls_for_non_finite(t),
            "{\"a\": [null, null, 1.5e3], \"s\": \"NaN \\\" Infinity\", \"b\": true}"
        );
    }
}
