//! `endoloc dataset check`: finds every problem in a dataset, not just the first.
//!
//! Checked: `dataset.toml` (parses, `format_version`, `units`, camera valid); per sequence,
//! every `poses.txt` line (8 finite numbers, unit quaternion), increasing timestamps, one image
//! per pose, every image decodes (in parallel) as 8-bit grey or RGB of the camera's size,
//! `sections.csv` rows (header, frame order, valid labels, count), and the depth maps (count,
//! 16-bit grey, size). A pass without poses (`frames.txt` instead of `poses.txt`): its times
//! (finite, increasing), one image per time, every image.

use crate::dataset::{
    DEPTH_DIR, DatasetMeta, FRAME_TIMES_FILE, IMAGES_DIR, META_FILE, POSES_FILE, SECTIONS_FILE,
    list_pngs,
};
use crate::png_io::decode;
use crate::sections_csv::parse_sections_text;
use crate::trajectory::parse_tum_line;
use crate::{DataError, Section};
use endoloc_geometry::Camera;
use image::ColorType;
use rayon::prelude::*;
use std::fmt;
use std::path::{Path, PathBuf};

/// One problem found in a dataset.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    /// The file or folder concerned.
    pub path: PathBuf,
    /// 1-based line in that file, where it applies.
    pub line: Option<usize>,
    /// What is wrong and what was expected.
    pub message: String,
}

impl Problem {
    fn new(path: impl Into<PathBuf>, line: Option<usize>, message: impl Into<String>) -> Self {
        Problem {
            path: path.into(),
            line,
            message: message.into(),
        }
    }

    fn from_error(e: DataError) -> Self {
        match e {
            DataError::Parse {
                path,
                line,
                message,
            } => Problem::new(path, (line > 0).then_some(line), message),
            DataError::Io { path, source } => Problem::new(path, None, source.to_string()),
            DataError::Image { path, message } | DataError::Invalid { path, message } => {
                Problem::new(path, None, message)
            }
            DataError::AlreadyExists { path } => Problem::new(path, None, "already exists"),
            DataError::Anatomy { message } => Problem::new("", None, message),
        }
    }
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{l}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

/// The result of [`check_dataset`].
#[derive(Debug, Clone, Default)]
pub struct CheckReport {
    /// The dataset folder.
    pub root: PathBuf,
    /// Every problem found, by sequence then file.
    pub problems: Vec<Problem>,
    /// Sequences found (folders with a `poses.txt`).
    pub sequences: Vec<String>,
    /// Frames checked: pose lines over all sequences.
    pub frames_checked: usize,
    /// Image and depth files decoded.
    pub files_decoded: usize,
}

impl CheckReport {
    /// Whether no problem was found.
    pub fn is_ok(&self) -> bool {
        self.problems.is_empty()
    }
}

impl fmt::Display for CheckReport {
    /// Each problem on its own line, then a one-line summary.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for p in &self.problems {
            writeln!(f, "{p}")?;
        }
        write!(
            f,
            "{}: {} sequence(s) ({}), {} frames, {} files decoded: ",
            self.root.display(),
            self.sequences.len(),
            self.sequences.join(", "),
            self.frames_checked,
            self.files_decoded
        )?;
        match self.problems.len() {
            0 => write!(f, "OK"),
            1 => write!(f, "1 problem"),
            n => write!(f, "{n} problems"),
        }
    }
}

/// 1-based line of the first `key = …` line in TOML text (also matches `[key]` headers).
fn line_of_key(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            let t = l.trim_start();
            t.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
                || t.starts_with(&format!("[{key}]"))
        })
        .map(|i| i + 1)
}

/// Checks the dataset at `dir` and reports every problem found.
///
/// # Errors
/// Only when `dir/dataset.toml` cannot be read at all ([`DataError::Io`]); everything else is
/// a [`Problem`] in the report.
pub fn check_dataset(dir: &Path) -> Result<CheckReport, DataError> {
    let meta_path = dir.join(META_FILE);
    let bytes = std::fs::read(&meta_path).map_err(|e| DataError::io(&meta_path, e))?;
    let mut report = CheckReport {
        root: dir.to_path_buf(),
        ..CheckReport::default()
    };
    let mut camera: Option<Camera> = None;
    match String::from_utf8(bytes) {
        Err(_) => report.problems.push(Problem::new(
            &meta_path,
            None,
            "not UTF-8 text; expected TOML",
        )),
        Ok(text) => match DatasetMeta::from_toml_str(&meta_path, &text) {
            Err(e) => report.problems.push(Problem::from_error(e)),
            Ok(meta) => {
                for m in meta.problems() {
                    let key = if m.starts_with("format_version") {
                        "format_version"
                    } else if m.starts_with("units") {
                        "units"
                    } else {
                        "camera"
                    };
                    report
                        .problems
                        .push(Problem::new(&meta_path, line_of_key(&text, key), m));
                }
                if meta.camera.validate().is_ok() {
                    camera = Some(meta.camera);
                    if meta.mask.is_some() {
                        let ds = crate::Dataset {
                            root: dir.to_path_buf(),
                            meta: meta.clone(),
                            sequences: Vec::new(),
                            unposed: Vec::new(),
                        };
                        if let Err(e) = ds.load_mask() {
                            report.problems.push(Problem::from_error(e));
                        }
                    }
                }
            }
        },
    }

    let mut dirs = Vec::new();
    match std::fs::read_dir(dir) {
        Err(e) => report.problems.push(Problem::new(dir, None, e.to_string())),
        Ok(entries) => {
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if !name.starts_with('.') && entry.path().is_dir() {
                    dirs.push(name);
                }
            }
        }
    }
    dirs.sort();
    for name in dirs {
        let seq_dir = dir.join(&name);
        if seq_dir.join(POSES_FILE).is_file() {
            report.sequences.push(name);
            check_sequence(&seq_dir, camera.as_ref(), &mut report);
        } else if seq_dir.join(FRAME_TIMES_FILE).is_file() {
            report.sequences.push(format!("{name} (no poses)"));
            check_sequence(&seq_dir, camera.as_ref(), &mut report);
        } else if seq_dir.join(IMAGES_DIR).is_dir() {
            report.problems.push(Problem::new(
                seq_dir.join(POSES_FILE),
                None,
                "missing; expected a TUM trajectory with one pose per image",
            ));
        }
    }
    if report.sequences.is_empty() {
        report.problems.push(Problem::new(
            dir,
            None,
            "no sequence found; expected at least one folder with images/ and poses.txt",
        ));
    }
    Ok(report)
}

/// Checks one sequence folder, adding its problems to the report.
fn check_sequence(seq: &Path, camera: Option<&Camera>, report: &mut CheckReport) {
    let problems = &mut report.problems;
    // The sequence's own camera (another scope), when it has one.
    if let Some(c) = camera
        && let Err(e) = crate::sequence_camera(seq, c)
    {
        problems.push(Problem::from_error(e));
    }
    // A pass without poses: frames.txt, one time per image.
    if !seq.join(POSES_FILE).is_file() {
        let n = match crate::read_frame_times(&seq.join(FRAME_TIMES_FILE)) {
            Ok(t) => t.len(),
            Err(e) => {
                problems.push(Problem::from_error(e));
                0
            }
        };
        report.frames_checked += n;
        check_images(seq, n, FRAME_TIMES_FILE, camera, report);
        return;
    }
    // poses.txt: every line.
    let poses_path = seq.join(POSES_FILE);
    let mut n_poses = 0usize;
    match crate::fsutil::read_text(&poses_path) {
        Err(e) => problems.push(Problem::from_error(e)),
        Ok(text) => {
            let mut previous: Option<(f64, usize)> = None;
            for (i, raw) in text.lines().enumerate() {
                let line = raw.trim();
                if line.is_empty() || line.starts_with('#') {
                    continue;
                }
                n_poses += 1;
                match parse_tum_line(line) {
                    Err(m) => problems.push(Problem::new(&poses_path, Some(i + 1), m)),
                    Ok(p) => {
                        if let Some((t0, l0)) = previous
                            && p.timestamp_s <= t0
                        {
                            problems.push(Problem::new(
                                &poses_path,
                                Some(i + 1),
                                format!(
                                    "timestamp {} is not after {t0} (line {l0}); expected increasing timestamps",
                                    p.timestamp_s
                                ),
                            ));
                        }
                        previous = Some((p.timestamp_s, i + 1));
                    }
                }
            }
            if n_poses == 0 {
                problems.push(Problem::new(
                    &poses_path,
                    None,
                    "no poses; expected one line `timestamp tx ty tz qx qy qz qw` per image",
                ));
            }
        }
    }
    report.frames_checked += n_poses;
    check_images(seq, n_poses, POSES_FILE, camera, report);
    let problems = &mut report.problems;

    // sections.csv
    let sections_path = seq.join(SECTIONS_FILE);
    if sections_path.is_file() {
        match crate::fsutil::read_text(&sections_path) {
            Err(e) => problems.push(Problem::from_error(e)),
            Ok(text) => {
                let (rows, row_problems) = parse_sections_text(&text);
                problems.extend(
                    row_problems
                        .into_iter()
                        .map(|(l, m)| Problem::new(&sections_path, Some(l), m)),
                );
                if rows.len() != n_poses {
                    problems.push(Problem::new(
                        &sections_path,
                        None,
                        format!(
                            "{} rows but {n_poses} poses; expected one `frame,section` row per frame (labels: {})",
                            rows.len(),
                            Section::ALL.map(|s| s.as_str()).join(", ")
                        ),
                    ));
                }
            }
        }
    }

    // depth/
    let depth_dir = seq.join(DEPTH_DIR);
    if depth_dir.is_dir() {
        match list_pngs(&depth_dir) {
            Err(e) => problems.push(Problem::from_error(e)),
            Ok(depth) => {
                if depth.len() != n_poses {
                    problems.push(Problem::new(
                        &depth_dir,
                        None,
                        format!(
                            "{} depth maps but {n_poses} poses; expected one per frame",
                            depth.len()
                        ),
                    ));
                }
                problems.extend(decode_all(&depth, camera, true));
                report.files_decoded += depth.len();
            }
        }
    }
}

/// Checks a sequence's images: as many as `n_poses` lines in `listed` (`poses.txt` or
/// `frames.txt`), each decodable at the camera's size.
fn check_images(
    seq: &Path,
    n_poses: usize,
    listed: &str,
    camera: Option<&Camera>,
    report: &mut CheckReport,
) {
    let problems = &mut report.problems;
    let images_dir = seq.join(IMAGES_DIR);
    let images = if images_dir.is_dir() {
        match list_pngs(&images_dir) {
            Ok(v) => v,
            Err(e) => {
                problems.push(Problem::from_error(e));
                Vec::new()
            }
        }
    } else {
        problems.push(Problem::new(
            &images_dir,
            None,
            "missing; expected a folder of PNG images, one per pose",
        ));
        Vec::new()
    };
    if images_dir.is_dir() && images.len() != n_poses {
        let (what, one) = if listed == POSES_FILE {
            ("poses", "pose")
        } else {
            ("times", "time")
        };
        problems.push(Problem::new(
            &images_dir,
            None,
            format!(
                "{} images but {n_poses} {what} in {listed}; expected one image per {one}",
                images.len()
            ),
        ));
    }
    problems.extend(decode_all(&images, camera, false));
    report.files_decoded += images.len();
}

/// Decodes every file in parallel; returns the problems in file order.
fn decode_all(files: &[PathBuf], camera: Option<&Camera>, depth: bool) -> Vec<Problem> {
    files
        .par_iter()
        .filter_map(|p| {
            let img = match decode(p) {
                Ok(img) => img,
                Err(e) => return Some(Problem::from_error(e)),
            };
            let color = img.color();
            let ok_color = if depth {
                color == ColorType::L16
            } else {
                matches!(color, ColorType::L8 | ColorType::Rgb8)
            };
            if !ok_color {
                let expected = if depth {
                    "16-bit grey (depth mm x 100)"
                } else {
                    "8-bit grey or RGB"
                };
                return Some(Problem::new(
                    p,
                    None,
                    format!("pixel type {color:?}; expected {expected}"),
                ));
            }
            let (w, h) = (img.width(), img.height());
            if let Some(cam) = camera
                && (w, h) != (cam.width, cam.height)
            {
                return Some(Problem::new(
                    p,
                    None,
                    format!(
                        "image is {w}x{h}; expected the camera's size {}x{}",
                        cam.width, cam.height
                    ),
                ));
            }
            None
        })
        .collect()
}
