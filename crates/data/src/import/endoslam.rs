//! EndoSLAM import: the UnityCam synthetic recordings and the ex-vivo recordings.
//!
//! Both kinds are recognised from the pose file's header:
//! - **UnityCam** (`Poses/*.csv`, header `tX,tY,tZ,rX,rY,rZ,rW,time(s)`): one pose per row,
//!   paired with the frames by row (frames in natural order of their number). Unity's
//!   left-handed, y-up world and y-up camera are converted exactly as for SimCol3D
//!   ([`pose_from_unity`]: `R_wc = S R S`, `t = units · S t`, `S = diag(1, −1, 1)`); the time
//!   stamps are the `time(s)` column.
//! - **ex-vivo** (`.xlsx` sheets with columns `ImageFrame, Pose_Index, trans_x, trans_y,
//!   trans_z, quot_x, quot_y, quot_z, quot_w`): poses joined to the frames on `ImageFrame` (a
//!   frame number, or a file name/stem); frames without a pose are skipped (and counted in
//!   the notes). The workbook is read directly (feature `xlsx`, on by default): the sheet
//!   named by [`EndoSlamConfig::sheet`], else the first sheet whose header row (its first
//!   non-empty row) has an `ImageFrame` column; a CSV export of the sheet works too. Errors
//!   name the file, the sheet, the row (as numbered in the spreadsheet) and the cell (`D7`).
//!   These poses are taken as camera-to-world in a right-handed frame with OpenCV camera axes
//!   (not documented by EndoSLAM: check a few frames visually); time stamps are the frame
//!   number / fps.
//!
//! Neither kind documents its length unit, so [`EndoSlamConfig::units`] is required, and so
//! is the camera (EndoSLAM's cameras differ per recording). EndoSLAM publishes its
//! calibrations only as MATLAB Camera Calibration App files and `cameraParameters` objects
//! (`Calibration/Camera/<camera>/*_cameraParams_pinhole.mat`, `*_fisheye.mat`): MATLAB class
//! instances that no reader outside MATLAB decodes, so they are not read here; their
//! `ImageSize`, `FocalLength` and `PrincipalPoint` give the camera.
//!
//! Columns are found by their header names (surrounding spaces and case ignored), so column
//! order does not matter. Either kind may come as CSV or as an `.xlsx` sheet.

use super::simcol3d::pose_from_unity;
use super::table::Table;
use super::{ImportedFrame, ImportedSequence, list_files, natural_sort, unit_quaternion};
use crate::{DataError, StampedPose};
use endoloc_geometry::{Camera, Pose};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A length unit of a source whose unit is not documented.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Units {
    /// Millimetres.
    Mm,
    /// Centimetres.
    Cm,
    /// Metres.
    M,
}

impl Units {
    /// Millimetres per unit.
    pub fn mm_per_unit(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Cm => 10.0,
            Units::M => 1000.0,
        }
    }
}

/// Options of [`read_endoslam`]; no defaults for the camera and units (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct EndoSlamConfig {
    /// The camera of the images (size must match the images).
    pub camera: Camera,
    /// Length unit of the pose file.
    pub units: Units,
    /// The pose file (`.csv`, or `.xlsx` with the `xlsx` feature); default: the only `.csv` or
    /// `.xlsx` in `SRC/Poses/`, else in `SRC`.
    pub poses: Option<PathBuf>,
    /// The worksheet of an `.xlsx` pose file; default: the first sheet whose header row has an
    /// `ImageFrame` column, else the first sheet. Ignored for CSV.
    pub sheet: Option<String>,
    /// The frames folder; default `SRC/Frames` when it exists, else `SRC`.
    pub frames: Option<PathBuf>,
    /// Frame rate for ex-vivo time stamps (frame number / fps), frames per second.
    pub fps: f64,
}

impl EndoSlamConfig {
    /// A config with the given camera and units, default file discovery and 30 fps.
    pub fn new(camera: Camera, units: Units) -> Self {
        EndoSlamConfig {
            camera,
            units,
            poses: None,
            sheet: None,
            frames: None,
            fps: 30.0,
        }
    }
}

const IMAGE_EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "bmp", "tif", "tiff"];

fn is_image(name: &str) -> bool {
    name.rsplit_once('.')
        .is_some_and(|(_, e)| IMAGE_EXTENSIONS.iter().any(|x| x.eq_ignore_ascii_case(e)))
}

fn find_pose_file(src: &Path) -> Result<PathBuf, DataError> {
    for dir in [src.join("Poses"), src.to_path_buf()] {
        if !dir.is_dir() {
            continue;
        }
        let mut files = list_files(&dir, |n| {
            let l = n.to_ascii_lowercase();
            l.ends_with(".csv") || l.ends_with(".xlsx")
        })?;
        files.sort();
        match files.as_slice() {
            [] => continue,
            [one] => return Ok(one.clone()),
            many => {
                return Err(DataError::invalid(
                    &dir,
                    format!(
                        "{} pose files ({}); choose one with `poses`",
                        many.len(),
                        many.iter()
                            .filter_map(|p| p.file_name())
                            .map(|n| n.to_string_lossy().into_owned())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
        }
    }
    Err(DataError::invalid(
        src,
        "no pose file (.csv or .xlsx) in Poses/ or here; give one with `poses`",
    ))
}

const UNITY_COLUMNS: [&str; 8] = ["tx", "ty", "tz", "rx", "ry", "rz", "rw", "time(s)"];
const EX_VIVO_COLUMNS: [&str; 8] = [
    "imageframe",
    "trans_x",
    "trans_y",
    "trans_z",
    "quot_x",
    "quot_y",
    "quot_z",
    "quot_w",
];

/// Reads one EndoSLAM recording (see the [module docs](self)).
///
/// # Errors
/// [`DataError::Invalid`] for missing files, an unreadable workbook or a missing sheet, a
/// pose/frame count mismatch (UnityCam), poses naming no frame or no match at all (ex-vivo);
/// [`DataError::Parse`] naming the file and line (CSV) or sheet, row and cell (`.xlsx`) for a
/// wrong column count, an empty sheet, a missing header column, a value that is not a finite
/// number, a non-unit quaternion or a duplicate `ImageFrame`; [`DataError::Io`].
pub fn read_endoslam(src: &Path, config: &EndoSlamConfig) -> Result<ImportedSequence, DataError> {
    if !(config.fps.is_finite() && config.fps > 0.0) {
        return Err(DataError::invalid(
            src,
            format!("fps = {}; expected a positive number", config.fps),
        ));
    }
    let pose_path = match &config.poses {
        Some(p) => p.clone(),
        None => find_pose_file(src)?,
    };
    let frames_dir = config.frames.clone().unwrap_or_else(|| {
        let f = src.join("Frames");
        if f.is_dir() { f } else { src.to_path_buf() }
    });
    let table = Table::read(&pose_path, config.sheet.as_deref(), "imageframe")?;
    let images = natural_sort(&frames_dir, list_files(&frames_dir, is_image)?)?;
    if images.is_empty() {
        return Err(DataError::invalid(
            &frames_dir,
            "no images (png, jpg, bmp, tif) here",
        ));
    }
    let mut notes = Vec::new();
    if !is_ex_vivo(&table, &pose_path) {
        table.columns(UNITY_COLUMNS)?;
        if table.rows.len() != images.len() {
            return Err(DataError::invalid(
                &pose_path,
                format!(
                    "{} pose rows but {} images in {}; expected one row per frame",
                    table.rows.len(),
                    images.len(),
                    frames_dir.display()
                ),
            ));
        }
    }
    let frames = match poses_of_table(&table, &pose_path, config.units)? {
        PoseTable::ExVivo(by_key) => {
            let mut frames = Vec::new();
            let mut used = 0usize;
            for (n, img) in &images {
                let stem = img
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let name = img
                    .file_name()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let hit = [n.to_string(), stem, name]
                    .into_iter()
                    .find_map(|k| by_key.get(&k));
                if let Some((_, pose)) = hit {
                    used += 1;
                    frames.push(ImportedFrame {
                        image: img.clone(),
                        depth: None,
                        pose: StampedPose {
                            timestamp_s: *n as f64 / config.fps,
                            pose: *pose,
                        },
                    });
                }
            }
            if frames.is_empty() {
                return Err(DataError::invalid(
                    &pose_path,
                    format!(
                        "no ImageFrame matches an image in {}; expected frame numbers or file names of its images",
                        frames_dir.display()
                    ),
                ));
            }
            if used < images.len() {
                notes.push(format!(
                    "{} frames without a pose skipped",
                    images.len() - used
                ));
            }
            if used < by_key.len() {
                notes.push(format!(
                    "{} pose rows name no image and were ignored",
                    by_key.len() - used
                ));
            }
            frames
        }
        PoseTable::Unity(rows) => rows
            .into_iter()
            .zip(images)
            .map(|((_, pose), (_, img))| ImportedFrame {
                image: img,
                depth: None,
                pose,
            })
            .collect(),
    };
    Ok(ImportedSequence {
        posed: true,
        source: src.to_path_buf(),
        frames,
        depth_encoding: None,
        camera: config.camera,
        notes,
    })
}

/// The poses of an EndoSLAM pose table, before they are paired with the frames.
#[derive(Debug, Clone, PartialEq)]
pub enum PoseTable {
    /// Ex-vivo: `ImageFrame` (a frame number or an image's file name or stem, as written) →
    /// (line or spreadsheet row, `T_wc` in mm).
    ExVivo(BTreeMap<String, (usize, Pose)>),
    /// UnityCam: `(line or spreadsheet row, pose)` per row in order, converted from Unity's
    /// axes, time stamps from `time(s)`.
    Unity(Vec<(usize, StampedPose)>),
}

/// Parses the bytes of an EndoSLAM pose file (CSV text, or an `.xlsx` workbook when `path`
/// ends in `.xlsx`: sheet `sheet`, else the first with an `ImageFrame` column) into its poses,
/// as [`read_endoslam`] reads them; `path` names the file in errors.
///
/// # Errors
/// [`DataError::Parse`] naming the file, the line (or sheet and row) and the cell, for the
/// problems listed at [`read_endoslam`]; [`DataError::Invalid`] for an unreadable workbook.
pub fn parse_pose_table(
    path: &Path,
    bytes: Vec<u8>,
    sheet: Option<&str>,
    units: Units,
) -> Result<PoseTable, DataError> {
    let table = Table::parse(path, bytes, sheet, "imageframe")?;
    poses_of_table(&table, path, units)
}

/// Whether a table holds ex-vivo poses: it has `ImageFrame`; a workbook without UnityCam's
/// `tX` is taken as one too, so that its error lists the ex-vivo columns.
fn is_ex_vivo(table: &Table, pose_path: &Path) -> bool {
    let has = |name: &str| table.header.iter().any(|h| h == name);
    has("imageframe") || (super::table::is_xlsx(pose_path) && !has("tx"))
}

/// The poses of every row of `table`, read from `pose_path`.
fn poses_of_table(table: &Table, pose_path: &Path, units: Units) -> Result<PoseTable, DataError> {
    let scale = units.mm_per_unit();
    if is_ex_vivo(table, pose_path) {
        let c = table.columns(EX_VIVO_COLUMNS)?;
        let mut by_key: BTreeMap<String, (usize, Pose)> = BTreeMap::new();
        for (line, cells) in &table.rows {
            let v: Vec<f64> = c[1..]
                .iter()
                .map(|&k| table.number(*line, cells, k))
                .collect::<Result<_, _>>()?;
            let q = unit_quaternion(pose_path, *line, [v[3], v[4], v[5], v[6]])
                .map_err(|e| table.locate(e))?;
            let pose = super::canonical_pose(Vector3::new(v[0], v[1], v[2]) * scale, q);
            let raw = Table::text(cells, c[0]);
            if raw.trim().is_empty() {
                return Err(table.locate(DataError::parse(
                    pose_path,
                    *line,
                    "ImageFrame is empty; expected a frame number or image name",
                )));
            }
            let key = frame_key(raw);
            if let Some((first, _)) = by_key.insert(key, (*line, pose)) {
                return Err(table.locate(DataError::parse(
                    pose_path,
                    *line,
                    format!(
                        "ImageFrame {raw:?} already has a pose on {}; expected one row per frame",
                        table.row_name(first)
                    ),
                )));
            }
        }
        Ok(PoseTable::ExVivo(by_key))
    } else {
        let c = table.columns(UNITY_COLUMNS)?;
        let mut rows = Vec::with_capacity(table.rows.len());
        for (line, cells) in &table.rows {
            let v: Vec<f64> = c
                .iter()
                .map(|&k| table.number(*line, cells, k))
                .collect::<Result<_, _>>()?;
            let q = unit_quaternion(pose_path, *line, [v[3], v[4], v[5], v[6]])
                .map_err(|e| table.locate(e))?;
            rows.push((
                *line,
                StampedPose {
                    timestamp_s: v[7],
                    pose: pose_from_unity(Vector3::new(v[0], v[1], v[2]), q, scale),
                },
            ));
        }
        Ok(PoseTable::Unity(rows))
    }
}

/// Join key of an `ImageFrame` cell: an integer-valued number as its decimal digits
/// (`"12"`, `"12.0"`, `"0012"` → `"12"`), anything else as written.
fn frame_key(raw: &str) -> String {
    let t = raw.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v < 1e15 => {
            format!("{}", v as u64)
        }
        _ => t.to_string(),
    }
}
