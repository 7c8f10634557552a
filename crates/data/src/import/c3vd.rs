//! C3VD (Colonoscopy 3D Video Dataset) import.
//!
//! A C3VD recording folder holds:
//! - `pose.txt`: one pose per line, 16 comma-separated numbers. They are a 4×4 rigid transform
//!   stored column by column: reshaped row-major they give the *transpose* of the transform, so
//!   the translation is at values 13–15 (1-based) and values 4, 8, 12, 16 are `0 0 0 1`. The
//!   transform is camera-to-world (`T_wc`) in millimetres.
//! - `{n}_color.png`: the frames, numbered with or without zero padding (`0_color.png`,
//!   `1_color.png`, …, `10_color.png`). Each image takes the pose line of its number: pose line
//!   n (0-based, blank lines skipped) is frame n. A recording may keep every pose line but only
//!   some images (e.g. every 30th frame); the frames without an image are skipped. An image
//!   whose number has no pose line is an error.
//! - optional `{n}_depth.tiff` (usually padded: `0030_depth.tiff`): 16-bit depth along the
//!   optical axis, `mm = v / 65535 × 100` (0–100 mm), joined to the colour frames by number.
//!   The value 65535 is C3VD's clipped depth, which C3VD's own loader treats as invalid; it is
//!   imported as no depth (0).
//!
//! # Assumptions
//! - C3VD's camera frame already has OpenCV axes (x right, y down, z forward: its depth maps
//!   are depth along +z and its calibration uses the OpenCV/Scaramuzza pixel convention), so the
//!   poses are taken unchanged apart from re-orthonormalizing the rotation.
//! - Intrinsics: C3VD calibrates an omnidirectional (Scaramuzza) model. Like most users we
//!   approximate it by OpenCV's fisheye model with the widely used values in [`c3vd_camera`]
//!   (1350×1080). With [`WriteImportConfig::undistort`](super::WriteImportConfig) the images
//!   are resampled through that fisheye model into an ideal pinhole with the same size, focal
//!   lengths and principal point (bilinear; depth nearest-neighbour); the outer ring of the
//!   fisheye image that falls outside this pinhole's field of view is lost, and target pixels
//!   that map outside the source image are black (depth 0).
//! - C3VD has no time stamps; frame n (the number in the file name) gets `n / fps` seconds, so
//!   a subsampled recording keeps its real timing.

use super::{
    DepthEncoding, ImportedFrame, ImportedSequence, list_files, natural_sort, parse_field,
    rotation_from_matrix,
};
use crate::fsutil::read_text;
use crate::{DataError, StampedPose};
use endoloc_geometry::{Camera, Distortion, Pose};
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;
use std::path::Path;

/// File name of C3VD's pose file.
pub const POSE_FILE: &str = "pose.txt";

/// Largest accepted `‖RᵀR − I‖` (Frobenius) of a pose's rotation block before it is
/// re-orthonormalized.
pub const ROTATION_TOLERANCE: f64 = 1e-3;

/// C3VD's depth scale: millimetres per 16-bit unit (`100 / 65535`).
pub const DEPTH_MM_PER_UNIT: f64 = 100.0 / 65535.0;

/// C3VD's clipped depth value, imported as no depth.
pub const DEPTH_INVALID: u16 = u16::MAX;

/// The widely used pinhole + OpenCV-fisheye approximation of C3VD's camera, 1350×1080 pixels:
/// fx 767.386, fy 767.506, cx 679.054, cy 543.647; k1..k4 −0.18867, −0.00393, 0.03052,
/// −0.01276.
pub fn c3vd_camera() -> Camera {
    Camera {
        width: 1350,
        height: 1080,
        fx: 767.386,
        fy: 767.506,
        cx: 679.054,
        cy: 543.647,
        distortion: Distortion::Fisheye {
            k1: -0.18867,
            k2: -0.00393,
            k3: 0.03052,
            k4: -0.01276,
        },
    }
}

/// Options of [`read_c3vd`].
#[derive(Debug, Clone, PartialEq)]
pub struct C3vdConfig {
    /// The camera of the images (default [`c3vd_camera`]); its size must match the images.
    pub camera: Camera,
    /// Frame rate giving the time stamps `n / fps` (n: the frame number), frames per second
    /// (default 30).
    pub fps: f64,
    /// Import the depth maps when the folder has them (default true).
    pub depth: bool,
}

impl Default for C3vdConfig {
    fn default() -> Self {
        C3vdConfig {
            camera: c3vd_camera(),
            fps: 30.0,
            depth: true,
        }
    }
}

/// Parses one line of C3VD's `pose.txt` into `T_wc` (mm); the message says what was expected.
pub fn parse_pose_line(line: &str, path: &Path, line_no: usize) -> Result<Pose, DataError> {
    let cols: Vec<&str> = line.split(',').collect();
    if cols.len() != 16 {
        return Err(DataError::parse(
            path,
            line_no,
            format!(
                "expected 16 comma-separated values (a column-major 4x4 camera-to-world transform); found {}",
                cols.len()
            ),
        ));
    }
    let mut v = [0.0f64; 16];
    for (i, c) in cols.iter().enumerate() {
        v[i] = parse_field(path, line_no, &format!("value {}", i + 1), c)?;
    }
    // Reshaped row-major, the values give Mᵀ: T[r][c] = v[4c + r].
    let bottom = [v[3], v[7], v[11], v[15]];
    if bottom
        .iter()
        .zip([0.0, 0.0, 0.0, 1.0])
        .any(|(a, b)| (a - b).abs() > 1e-6)
    {
        return Err(DataError::parse(
            path,
            line_no,
            format!(
                "values 4, 8, 12, 16 are {bottom:?}; expected 0 0 0 1 (C3VD stores the transform column by column, translation at values 13-15; is this file row-major?)"
            ),
        ));
    }
    let r = Matrix3::from_fn(|row, col| v[4 * col + row]);
    let q = rotation_from_matrix(&r, ROTATION_TOLERANCE).ok_or_else(|| {
        DataError::parse(
            path,
            line_no,
            format!(
                "the rotation block is not a rotation (‖RᵀR − I‖ = {:.3e}, det = {:.4}); expected an orthonormal matrix with determinant 1",
                (r.transpose() * r - Matrix3::identity()).norm(),
                r.determinant()
            ),
        )
    })?;
    Ok(super::canonical_pose(Vector3::new(v[12], v[13], v[14]), q))
}

/// Reads C3VD's `pose.txt` (blank lines skipped).
///
/// # Errors
/// [`DataError::Io`]; [`DataError::Parse`] naming the line: wrong value count, a value that is
/// not a finite number, a bottom row other than `0 0 0 1`, a rotation block that is not a
/// rotation.
pub fn read_c3vd_poses(path: &Path) -> Result<Vec<Pose>, DataError> {
    parse_c3vd_poses(path, &read_text(path)?)
}

/// Parses the text of C3VD's `pose.txt` (see [`read_c3vd_poses`]); `path` names the file in
/// errors.
///
/// # Errors
/// [`DataError::Parse`] naming the line, as [`read_c3vd_poses`].
pub fn parse_c3vd_poses(path: &Path, text: &str) -> Result<Vec<Pose>, DataError> {
    let mut poses = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        poses.push(parse_pose_line(line, path, i + 1)?);
    }
    Ok(poses)
}

/// Reads one C3VD recording folder `src` (see the [module docs](self)).
///
/// # Errors
/// [`DataError::Io`] / [`DataError::Parse`] from `pose.txt`; [`DataError::Invalid`] when an
/// image's frame number has no pose line, when no image is found, when two images (or depth
/// maps) share a frame number, when some frames have a depth map and others not, or for a bad
/// `fps`.
pub fn read_c3vd(src: &Path, config: &C3vdConfig) -> Result<ImportedSequence, DataError> {
    if !(config.fps.is_finite() && config.fps > 0.0) {
        return Err(DataError::invalid(
            src,
            format!("fps = {}; expected a positive number", config.fps),
        ));
    }
    let pose_path = src.join(POSE_FILE);
    let poses = read_c3vd_poses(&pose_path)?;
    let colors = natural_sort(src, list_files(src, |n| n.ends_with("_color.png"))?)?;
    if colors.is_empty() {
        return Err(DataError::invalid(
            src,
            "no `{n}_color.png` images; expected a C3VD recording folder",
        ));
    }
    if let Some((n, img)) = colors.iter().find(|(n, _)| *n >= poses.len() as u64) {
        let have = match poses.len() {
            0 => "no pose lines".to_string(),
            1 => "1 pose line (frame 0)".to_string(),
            k => format!("{k} pose lines (frames 0-{})", k - 1),
        };
        return Err(DataError::invalid(
            &pose_path,
            format!(
                "{} is frame {n} but {POSE_FILE} has {have}; expected a pose line (line n = frame n) for every image's number",
                img.display()
            ),
        ));
    }
    let depth: BTreeMap<u64, std::path::PathBuf> = if config.depth {
        natural_sort(src, list_files(src, |n| n.ends_with("_depth.tiff"))?)?
            .into_iter()
            .collect()
    } else {
        BTreeMap::new()
    };
    let mut notes = Vec::new();
    if colors.len() < poses.len() {
        notes.push(format!(
            "{} of {} pose lines have an image ({}); time stamps are frame number / fps",
            colors.len(),
            poses.len(),
            describe_frames(&colors)
        ));
    }
    if !depth.is_empty() {
        if let Some((n, p)) = colors.iter().find(|(n, _)| !depth.contains_key(n)) {
            return Err(DataError::invalid(
                src,
                format!(
                    "{} has no depth map ({n:04}_depth.tiff) while {} other frames have one; expected depth for every frame or none",
                    p.display(),
                    depth.len()
                ),
            ));
        }
        let unused = depth.len() - colors.len();
        if unused > 0 {
            notes.push(format!(
                "{unused} depth maps without a colour image ignored"
            ));
        }
        notes.push(format!(
            "depth value {DEPTH_INVALID} (C3VD's clipped depth) imported as no depth"
        ));
    }
    let frames = colors
        .iter()
        .map(|(n, img)| ImportedFrame {
            image: img.clone(),
            depth: depth.get(n).cloned(),
            pose: StampedPose {
                timestamp_s: *n as f64 / config.fps,
                pose: poses[*n as usize],
            },
        })
        .collect();
    Ok(ImportedSequence {
        posed: true,
        source: src.to_path_buf(),
        frames,
        depth_encoding: (!depth.is_empty()).then_some(DepthEncoding {
            mm_per_unit: DEPTH_MM_PER_UNIT,
            invalid_value: Some(DEPTH_INVALID),
        }),
        camera: config.camera,
        notes,
    })
}

/// Which frames `frames` (sorted, distinct, non-empty) are: "every 30th frame", "frames
/// 5-99" or "frames 0-270, irregularly spaced".
fn describe_frames(frames: &[(u64, std::path::PathBuf)]) -> String {
    let first = frames.first().map_or(0, |f| f.0);
    let last = frames.last().map_or(0, |f| f.0);
    let steps: Vec<u64> = frames.windows(2).map(|w| w[1].0 - w[0].0).collect();
    match steps.first() {
        Some(&d) if d > 1 && steps.iter().all(|&s| s == d) => {
            let start = if first == 0 {
                String::new()
            } else {
                format!(", from frame {first}")
            };
            format!("every {} frame{start}", ordinal(d))
        }
        Some(_) if steps.iter().any(|&s| s != steps[0]) => {
            format!("frames {first}-{last}, irregularly spaced")
        }
        _ if first == last => format!("frame {first}"),
        _ => format!("frames {first}-{last}"),
    }
}

/// `2` → "2nd", `30` → "30th".
fn ordinal(n: u64) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn frames(ns: &[u64]) -> Vec<(u64, PathBuf)> {
        ns.iter()
            .map(|&n| (n, PathBuf::from(format!("{n}_color.png"))))
            .collect()
    }

    #[test]
    fn describes_which_frames_have_an_image() {
        let every_30th: Vec<u64> = (0..10).map(|k| 30 * k).collect();
        assert_eq!(describe_frames(&frames(&every_30th)), "every 30th frame");
        assert_eq!(
            describe_frames(&frames(&[5, 7, 9])),
            "every 2nd frame, from frame 5"
        );
        assert_eq!(describe_frames(&frames(&[0, 1, 2, 3])), "frames 0-3");
        assert_eq!(
            describe_frames(&frames(&[0, 1, 5])),
            "frames 0-5, irregularly spaced"
        );
        assert_eq!(describe_frames(&frames(&[4])), "frame 4");
        assert_eq!(ordinal(1), "1st");
        assert_eq!(ordinal(3), "3rd");
        assert_eq!(ordinal(11), "11th");
        assert_eq!(ordinal(22), "22nd");
    }
}
