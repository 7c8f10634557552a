//! SimCol3D (MICCAI 2022 EndoVis challenge, Unity-rendered colons) import.
//!
//! A SimCol3D colon folder (e.g. `SyntheticColon_I/`) holds, per trajectory `S1`, `S2`, …:
//! - `SavedPosition_S1.txt`: one camera position per line, `tx ty tz`, centimetres, Unity world;
//! - `SavedRotationQuaternion_S1.txt`: one camera rotation per line, `qx qy qz qw`, Unity world;
//! - `Frames_S1/FrameBuffer_NNNN.png` (`NNNN` zero-padded to 4 digits): the frames. Each image
//!   takes the pose line of its number: line `n` (1-based `n + 1`, blank lines skipped) of both
//!   files is frame `n`. A folder may keep only some frames (e.g. every 10th): the pose lines
//!   without an image are skipped and time stamps stay `n / fps`; an image whose number has no
//!   pose line is an error;
//! - `Frames_S1/Depth_NNNN.png` (optional): the depth map of frame `NNNN`, see below;
//! - `cam.txt` (optional): the intrinsics, one line of 9 numbers, the 3×3 matrix row by row.
//!
//! The published dataset holds three colons, `SyntheticColon_I` (trajectories `S1`–`S15`),
//! `SyntheticColon_II` (`B1`–`B15`) and `SyntheticColon_III` (`O1`–`O3`), next to `misc/`.
//! `SRC` may be a colon folder (choose the trajectory with `sequence` when it holds several)
//! or a `Frames_S1` folder (the pose files and `cam.txt` are then looked up next to it and in
//! its parent); the dataset's root folder is refused with the colon folders it holds.
//!
//! # From Unity to endoloc's conventions
//! Unity's world is left-handed with y up; a Unity camera looks along its local +z with local
//! +y up and +x to the image's right. Let `S = diag(1, −1, 1)` (flip y), `t` the saved position
//! and `R` the rotation matrix of the saved quaternion (Unity's camera-to-world, acting on
//! column vectors: `p_world = R p_local + t`, in left-handed coordinates).
//! - World: `p' = S p` gives right-handed coordinates of the same scene (a change of
//!   coordinates, not a mirroring of the scene); positions become `t' = 10 · S t` mm.
//! - Camera: OpenCV's camera axes are Unity's camera axes with y flipped (x right, y *down*,
//!   z forward; pixel rows grow downwards), i.e. `p_local = S p_cv`.
//! - Together `p'_world = S R S p_cv + S t`: `R_wc = S R S`, which is the issue's
//!   `P' = TM · P · TM` with `TM = diag(1, −1, 1, 1)`. The right-hand `S` *is* the camera's
//!   y-up → y-down flip, so no further axis flip is applied: `S R S diag(1, −1, 1) = S R`
//!   would have determinant −1 and not be a rotation at all. As a quaternion,
//!   `(qx, qy, qz, qw) → (−qx, qy, −qz, qw)`.
//!
//! The rotation is re-orthonormalized and its quaternion canonicalized (`qw ≥ 0`: SimCol3D's
//! quaternions flip sign between rows). A camera whose Unity forward is `R e_z` looks along
//! `S R e_z` in the converted world, whose "up" is `−y`.
//!
//! Intrinsics: the `cam.txt` shipped with the data is ambiguous: its matrix has the focal length
//! at (0, 0) and (0, 2) and the image centre at (1, 1) and (1, 2). [`simcol3d_camera`] uses the
//! commonly used reading fx = fy = 227.60416, cx = cy = 237.5 for 475×475 images; when the
//! colon folder has a `cam.txt` (and [`SimCol3dConfig::cam_txt`]), its first value is taken as
//! fx = fy, the principal point staying that of [`SimCol3dConfig::camera`]. Time stamps are
//! `n / fps` for frame `n`.
//!
//! # Depth
//! `Depth_NNNN.png` is a 16-bit grey PNG of depth along the camera's optical axis (z), joined
//! to `FrameBuffer_NNNN.png` by number. Its scale is that of the challenge organisers' own
//! code (github.com/anitarau/simcol): `evaluation/eval_synthetic_depth.py` loads ground truth
//! as `png / 255 / 256` ("please use this to load ground truth depth") and multiplies by 20
//! "to get centimeters" (values above 1, i.e. 20 cm, are treated as out of range), and
//! `data_helpers/visualize_3D_data.py` back-projects `png / 256 / 255 * 20` (cm) along
//! `K⁻¹ (u, v, 1)`, i.e. as z-depth. So `mm = v × 200 / 65280` ([`DEPTH_MM_PER_UNIT`]): the
//! divisor is 255 × 256 = 65280, not 65535 (0.4 % apart), and 65535 is 200.8 mm. Depth is
//! imported when every frame has a map (an error when only some do), unless
//! [`SimCol3dConfig::depth`] is false.

use super::{
    DepthEncoding, ImportedFrame, ImportedSequence, list_files, natural_sort, parse_field,
    unit_quaternion,
};
use crate::fsutil::read_text;
use crate::{DataError, StampedPose};
use endoloc_geometry::{Camera, Distortion, Pose};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Millimetres per SimCol3D (Unity scene) unit: positions are in centimetres.
pub const MM_PER_CM: f64 = 10.0;

/// SimCol3D's depth scale, millimetres per 16-bit unit: `200 / (255 × 256)` (the organisers'
/// loader divides by 255 and 256 and multiplies by 20 cm; see the [module docs](self)).
pub const DEPTH_MM_PER_UNIT: f64 = 200.0 / (255.0 * 256.0);

/// The commonly used SimCol3D pinhole: 475×475, fx = fy = 227.60416, cx = cy = 237.5.
pub fn simcol3d_camera() -> Camera {
    Camera {
        width: 475,
        height: 475,
        fx: 227.60416,
        fy: 227.60416,
        cx: 237.5,
        cy: 237.5,
        distortion: Distortion::None,
    }
}

/// Options of [`read_simcol3d`].
#[derive(Debug, Clone, PartialEq)]
pub struct SimCol3dConfig {
    /// The camera of the images (default [`simcol3d_camera`]).
    pub camera: Camera,
    /// Frame rate giving the time stamps `i / fps`, frames per second (default 30).
    pub fps: f64,
    /// Trajectory suffix (`S1` for `SavedPosition_S1.txt` and `Frames_S1/`), needed when the
    /// folder holds several.
    pub sequence: Option<String>,
    /// Import the `Depth_NNNN.png` maps when the frames folder has them (default true).
    pub depth: bool,
    /// Take the focal length from the colon folder's `cam.txt` when there is one (default
    /// true; off when the camera is given explicitly).
    pub cam_txt: bool,
}

impl Default for SimCol3dConfig {
    fn default() -> Self {
        SimCol3dConfig {
            camera: simcol3d_camera(),
            fps: 30.0,
            sequence: None,
            depth: true,
            cam_txt: true,
        }
    }
}

/// File name of SimCol3D's intrinsics file, in the colon folder.
pub const CAM_FILE: &str = "cam.txt";

/// The focal length (pixels) in a SimCol3D `cam.txt`: its first value, from one line of 9
/// numbers (the 3×3 matrix row by row; spaces or commas).
///
/// # Errors
/// [`DataError::Parse`] naming the file and line for a value that is not a finite number, a
/// count other than 9, or a focal length that is not positive; [`DataError::Io`].
pub fn read_cam_txt(path: &Path) -> Result<f64, DataError> {
    parse_cam_txt(path, &read_text(path)?)
}

/// Parses the text of a SimCol3D `cam.txt` (see [`read_cam_txt`]); `path` names the file in
/// errors.
///
/// # Errors
/// [`DataError::Parse`] naming the line, as [`read_cam_txt`].
pub fn parse_cam_txt(path: &Path, text: &str) -> Result<f64, DataError> {
    let names = [
        "k00", "k01", "k02", "k10", "k11", "k12", "k20", "k21", "k22",
    ];
    let rows = parse_rows(path, text, names)?;
    match rows.as_slice() {
        [(line, k)] => {
            if k[0] > 0.0 {
                Ok(k[0])
            } else {
                Err(DataError::parse(
                    path,
                    *line,
                    format!(
                        "focal length {} (first value); expected a positive number of pixels",
                        k[0]
                    ),
                ))
            }
        }
        [] => Err(DataError::parse(
            path,
            1,
            "the file is empty; expected one line of 9 numbers (the 3×3 camera matrix, row by row)",
        )),
        [_, (line, _), ..] => Err(DataError::parse(
            path,
            *line,
            "a second line; expected one line of 9 numbers (the 3×3 camera matrix, row by row)",
        )),
    }
}

/// Converts a Unity camera pose (left-handed world, y up; camera looking along +z with y up)
/// into endoloc's `T_wc` (right-handed world `S p`, OpenCV camera axes), translation scaled by
/// `mm_per_unit`: `R_wc = S R S`, `t_wc = mm_per_unit · S t` with `S = diag(1, −1, 1)`.
/// See the [module docs](self) for the derivation. The quaternion is canonical (`qw ≥ 0`).
pub fn pose_from_unity(
    t_unity: Vector3<f64>,
    q_unity: UnitQuaternion<f64>,
    mm_per_unit: f64,
) -> Pose {
    let s = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0));
    let r = s * q_unity.to_rotation_matrix().into_inner() * s;
    let q = super::rotation_from_matrix(&r, 1e-6).unwrap_or_else(|| {
        UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
            q_unity.w, -q_unity.i, q_unity.j, -q_unity.k,
        ))
    });
    super::canonical_pose(s * t_unity * mm_per_unit, q)
}

/// Parses the texts of a SimCol3D `SavedPosition_*.txt` (`tx ty tz`, Unity units: cm) and its
/// `SavedRotationQuaternion_*.txt` (`qx qy qz qw`) into `T_wc` poses, one per line, converted
/// as by the importer ([`pose_from_unity`]); the paths name the files in errors.
///
/// # Errors
/// [`DataError::Parse`] naming the file and line for a wrong column count, a value that is not
/// a finite number or a quaternion whose norm is not 1; [`DataError::Invalid`] when the counts
/// differ.
pub fn parse_simcol3d_poses(
    pos_path: &Path,
    pos_text: &str,
    rot_path: &Path,
    rot_text: &str,
) -> Result<Vec<Pose>, DataError> {
    let positions = parse_rows(pos_path, pos_text, ["tx", "ty", "tz"])?;
    let rotations = parse_rows(rot_path, rot_text, ["qx", "qy", "qz", "qw"])?;
    if positions.len() != rotations.len() {
        return Err(DataError::invalid(
            rot_path,
            format!(
                "{} quaternions but {} positions in {}; expected one per frame",
                rotations.len(),
                positions.len(),
                pos_path.display()
            ),
        ));
    }
    positions
        .iter()
        .zip(&rotations)
        .map(|((_, t), (line, q))| {
            let q = unit_quaternion(rot_path, *line, *q)?;
            Ok(pose_from_unity(
                Vector3::new(t[0], t[1], t[2]),
                q,
                MM_PER_CM,
            ))
        })
        .collect()
}

/// Reads a text file of `n` whitespace- (or comma-) separated numbers per line; blank lines
/// skipped. Returns `(line number, values)`.
pub(crate) fn read_rows<const N: usize>(
    path: &Path,
    names: [&str; N],
) -> Result<Vec<(usize, [f64; N])>, DataError> {
    parse_rows(path, &read_text(path)?, names)
}

/// [`read_rows`] of a file's text.
fn parse_rows<const N: usize>(
    path: &Path,
    text: &str,
    names: [&str; N],
) -> Result<Vec<(usize, [f64; N])>, DataError> {
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let cols: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .collect();
        if cols.is_empty() {
            continue;
        }
        if cols.len() != N {
            return Err(DataError::parse(
                path,
                i + 1,
                format!(
                    "expected {N} values ({}); found {}",
                    names.join(" "),
                    cols.len()
                ),
            ));
        }
        let mut v = [0.0; N];
        for (k, c) in cols.iter().enumerate() {
            v[k] = parse_field(path, i + 1, &format!("column {} ({})", k + 1, names[k]), c)?;
        }
        rows.push((i + 1, v));
    }
    Ok(rows)
}

/// The trajectory suffix from a `SavedPosition_<suffix>.txt` name.
fn suffix_of(name: &str) -> Option<&str> {
    name.strip_prefix("SavedPosition_")?.strip_suffix(".txt")
}

/// Finds `(frames folder, position file, quaternion file)`.
fn layout(src: &Path, sequence: Option<&str>) -> Result<(PathBuf, PathBuf, PathBuf), DataError> {
    let has_frames = |d: &Path| -> Result<bool, DataError> {
        Ok(!list_files(d, |n| n.starts_with("FrameBuffer_") && n.ends_with(".png"))?.is_empty())
    };
    let (frames_dir, pose_dirs, wanted) = if has_frames(src)? {
        let dir_name = src.file_name().map(|n| n.to_string_lossy().into_owned());
        let from_dir = dir_name
            .as_deref()
            .and_then(|n| n.strip_prefix("Frames_"))
            .map(str::to_string);
        let parent = src.parent().map(Path::to_path_buf).unwrap_or_default();
        (
            Some(src.to_path_buf()),
            vec![src.to_path_buf(), parent],
            sequence.map(str::to_string).or(from_dir),
        )
    } else {
        (None, vec![src.to_path_buf()], sequence.map(str::to_string))
    };
    let suffix = match wanted {
        Some(s) => s,
        None => {
            let mut found: Vec<String> = Vec::new();
            for d in &pose_dirs {
                if d.as_os_str().is_empty() || !d.is_dir() {
                    continue;
                }
                for f in list_files(d, |n| suffix_of(n).is_some())? {
                    if let Some(s) = f.file_name().and_then(|n| n.to_str()).and_then(suffix_of) {
                        found.push(s.to_string());
                    }
                }
            }
            found.sort();
            found.dedup();
            match found.as_slice() {
                [one] => one.clone(),
                [] => {
                    let mut colons: Vec<String> = std::fs::read_dir(src)
                        .map_err(|e| DataError::io(src, e))?
                        .filter_map(|e| e.ok())
                        .filter(|e| e.path().is_dir())
                        .map(|e| e.file_name().to_string_lossy().into_owned())
                        .filter(|n| n.starts_with("SyntheticColon"))
                        .collect();
                    colons.sort();
                    if !colons.is_empty() {
                        return Err(DataError::invalid(
                            src,
                            format!(
                                "this is the SimCol3D dataset folder; expected one colon folder: {} (e.g. {} with `sequence` S1)",
                                colons.join(", "),
                                src.join(&colons[0]).display()
                            ),
                        ));
                    }
                    return Err(DataError::invalid(
                        src,
                        "no SavedPosition_*.txt here; expected a SimCol3D colon folder or a Frames_* folder next to its pose files",
                    ));
                }
                many => {
                    return Err(DataError::invalid(
                        src,
                        format!(
                            "several trajectories ({}); choose one (e.g. `sequence` {})",
                            many.join(", "),
                            many[0]
                        ),
                    ));
                }
            }
        }
    };
    let pos_name = format!("SavedPosition_{suffix}.txt");
    let rot_name = format!("SavedRotationQuaternion_{suffix}.txt");
    let pose_dir = pose_dirs
        .iter()
        .find(|d| d.join(&pos_name).is_file())
        .ok_or_else(|| {
            DataError::invalid(
                src,
                format!("{pos_name} not found here or in the parent folder"),
            )
        })?;
    let frames_dir = frames_dir.unwrap_or_else(|| src.join(format!("Frames_{suffix}")));
    Ok((frames_dir, pose_dir.join(pos_name), pose_dir.join(rot_name)))
}

/// Reads one SimCol3D trajectory (see the [module docs](self)) with poses converted to
/// endoloc's conventions.
///
/// # Errors
/// [`DataError::Invalid`] when the files cannot be found (naming the colon folders when `src`
/// is the dataset's root), for a bad `fps`, when the position and quaternion counts differ,
/// when an image's frame number has no pose line, or when some frames have a depth map and
/// others not; [`DataError::Parse`] naming the file and line for a wrong column count, a value
/// that is not a finite number, a quaternion whose norm is not 1, or a malformed `cam.txt`;
/// [`DataError::Io`].
pub fn read_simcol3d(src: &Path, config: &SimCol3dConfig) -> Result<ImportedSequence, DataError> {
    if !(config.fps.is_finite() && config.fps > 0.0) {
        return Err(DataError::invalid(
            src,
            format!("fps = {}; expected a positive number", config.fps),
        ));
    }
    let (frames_dir, pos_path, rot_path) = layout(src, config.sequence.as_deref())?;
    let positions = read_rows(&pos_path, ["tx", "ty", "tz"])?;
    let rotations = read_rows(&rot_path, ["qx", "qy", "qz", "qw"])?;
    if positions.len() != rotations.len() {
        return Err(DataError::invalid(
            &rot_path,
            format!(
                "{} quaternions but {} positions in {}; expected one per frame",
                rotations.len(),
                positions.len(),
                pos_path.display()
            ),
        ));
    }
    let images = natural_sort(
        &frames_dir,
        list_files(&frames_dir, |n| {
            n.starts_with("FrameBuffer_") && n.ends_with(".png")
        })?,
    )?;
    if images.is_empty() {
        return Err(DataError::invalid(
            &frames_dir,
            "no FrameBuffer_NNNN.png images; expected a SimCol3D Frames_* folder",
        ));
    }
    if let Some((n, img)) = images.iter().find(|(n, _)| *n >= positions.len() as u64) {
        let have = match positions.len() {
            0 => "no pose lines".to_string(),
            1 => "1 pose line (frame 0)".to_string(),
            k => format!("{k} pose lines (frames 0-{})", k - 1),
        };
        return Err(DataError::invalid(
            &pos_path,
            format!(
                "{} is frame {n} but the file has {have}; expected a pose line (line n + 1 = frame n) for every image's number",
                img.display()
            ),
        ));
    }
    let mut camera = config.camera;
    let mut notes = Vec::new();
    if config.cam_txt {
        let dirs = [
            pos_path.parent().map(Path::to_path_buf),
            Some(frames_dir.clone()),
        ];
        if let Some(cam_path) = dirs
            .iter()
            .flatten()
            .map(|d| d.join(CAM_FILE))
            .find(|p| p.is_file())
        {
            let f = read_cam_txt(&cam_path)?;
            camera.fx = f;
            camera.fy = f;
            notes.push(format!(
                "focal length fx = fy = {f} px from {}; principal point ({}, {})",
                cam_path.display(),
                camera.cx,
                camera.cy
            ));
        }
    }
    if images.len() < positions.len() {
        notes.push(format!(
            "{} of {} pose lines have an image; time stamps are frame number / fps",
            images.len(),
            positions.len()
        ));
    }
    let depth: BTreeMap<u64, PathBuf> = if config.depth {
        natural_sort(
            &frames_dir,
            list_files(&frames_dir, |n| {
                n.starts_with("Depth_") && n.ends_with(".png")
            })?,
        )?
        .into_iter()
        .collect()
    } else {
        BTreeMap::new()
    };
    if !depth.is_empty() {
        if let Some((n, p)) = images.iter().find(|(n, _)| !depth.contains_key(n)) {
            return Err(DataError::invalid(
                &frames_dir,
                format!(
                    "{} has no depth map (Depth_{n:04}.png) while {} other frames have one; expected depth for every frame or none (`no_depth` skips depth)",
                    p.display(),
                    depth.len()
                ),
            ));
        }
        if depth.len() > images.len() {
            notes.push(format!(
                "{} Depth_*.png without a FrameBuffer image ignored",
                depth.len() - images.len()
            ));
        }
    }
    let depth_encoding = (!depth.is_empty()).then_some(DepthEncoding {
        mm_per_unit: DEPTH_MM_PER_UNIT,
        invalid_value: None,
    });
    let mut frames = Vec::with_capacity(images.len());
    for (n, image) in images {
        let (_, t) = positions[n as usize];
        let (line, q) = rotations[n as usize];
        let q = unit_quaternion(&rot_path, line, q)?;
        frames.push(ImportedFrame {
            image,
            depth: depth.get(&n).cloned(),
            pose: StampedPose {
                timestamp_s: n as f64 / config.fps,
                pose: pose_from_unity(Vector3::new(t[0], t[1], t[2]), q, MM_PER_CM),
            },
        });
    }
    Ok(ImportedSequence {
        posed: true,
        source: frames_dir,
        frames,
        depth_encoding,
        camera,
        notes: {
            notes.insert(0, format!(
                "poses from {} and {} (Unity, cm) converted with R = S R S, t = 10 S t, S = diag(1,-1,1)",
                pos_path.display(),
                rot_path.display()
            ));
            if depth_encoding.is_some() {
                notes.push("depth from Depth_NNNN.png, mm = v × 200 / 65280".into());
            }
            notes
        },
    })
}
