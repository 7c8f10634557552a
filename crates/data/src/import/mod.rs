//! Import of public colonoscopy datasets into the endoloc dataset format v1 (`docs/CONVENTIONS.md`:
//! millimetres, `T_wc` camera-to-world, OpenCV camera axes x right / y down / z forward).
//!
//! One file per source format, each documenting its conventions and pitfalls:
//! - [`c3vd`]: C3VD (`pose.txt`, `{n}_color.png`, optional `{NNNN}_depth.tiff`);
//! - [`simcol3d`]: SimCol3D (Unity, left-handed, cm; optional `Depth_NNNN.png`);
//! - [`endoslam`]: EndoSLAM (UnityCam CSV poses; ex-vivo `.xlsx` pose sheets with undocumented
//!   units);
//! - [`split`]: cutting one imported recording into train/test sequences;
//! - [`tracker`]: pose logs of a tracker or robot on their own clock (CSV, TUM), resampled at a
//!   recording's frame times, with the clock offset found from the images;
//! - [`video`]: a video file (decoded with FFmpeg) with such a log.
//!
//! Every reader returns an [`ImportedSequence`] (image files, optional depth files and converted
//! poses, in frame order); [`write_import`] then writes the dataset through
//! [`DatasetWriter`], which never overwrites an existing folder unless
//! asked to.

pub mod c3vd;
pub mod endoslam;
pub mod simcol3d;
pub mod split;
mod table;
pub mod tracker;
pub mod video;

use crate::dataset::{DatasetMeta, DatasetWriter, SequenceWriter};
use crate::{DataError, StampedPose};
use endoloc_geometry::{Camera, Distortion, Pose};
use nalgebra::{Matrix3, UnitQuaternion, Vector2};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// How a source stores depth maps: a single-channel 8- or 16-bit image whose value `v` means
/// `v × mm_per_unit` millimetres along the optical axis (0 = no depth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthEncoding {
    /// Millimetres per stored unit (C3VD: 100 / 65535; SimCol3D: 200 / 65280).
    pub mm_per_unit: f64,
    /// A stored value that means "no depth" besides 0 (C3VD: 65535, its clipped depth); such
    /// pixels are imported as 0 (no depth).
    pub invalid_value: Option<u16>,
}

/// One frame of an imported recording.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedFrame {
    /// The source image file (any format the `image` crate reads: PNG, TIFF, JPEG…).
    pub image: PathBuf,
    /// The source depth map, when the recording has depth.
    pub depth: Option<PathBuf>,
    /// Converted pose: `T_wc` camera-to-world, mm, OpenCV camera axes, canonical quaternion.
    pub pose: StampedPose,
}

/// One imported recording, in frame order, with poses already in endoloc's conventions.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedSequence {
    /// The source folder or file it came from (provenance).
    pub source: PathBuf,
    /// The frames, in frame order.
    pub frames: Vec<ImportedFrame>,
    /// How the depth files are encoded (`None` when the recording has no depth).
    pub depth_encoding: Option<DepthEncoding>,
    /// The camera of the source images (size, intrinsics, distortion).
    pub camera: Camera,
    /// Remarks for the user (skipped frames, assumptions), one line each.
    pub notes: Vec<String>,
    /// Whether the frames have poses. `false` for a recording without a pose log (a video
    /// imported without one): each frame's `pose` then holds its time only (the pose is the
    /// identity and never written), and the sequence is written with
    /// [`FRAME_TIMES_FILE`](crate::FRAME_TIMES_FILE) instead of `poses.txt`.
    pub posed: bool,
}

impl ImportedSequence {
    /// The converted poses, in frame order.
    pub fn poses(&self) -> Vec<StampedPose> {
        self.frames.iter().map(|f| f.pose).collect()
    }
}

/// Options of [`write_import`].
#[derive(Debug, Clone, Default)]
pub struct WriteImportConfig {
    /// Dataset name stored in `dataset.toml`.
    pub name: String,
    /// Resample every image (bilinear) and depth map (nearest) through the source camera's
    /// distortion into an ideal pinhole of the same size, focal lengths and principal point;
    /// the dataset's camera is then that pinhole. Ignored for a camera without distortion.
    pub undistort: bool,
    /// Replace an existing dataset at the destination (with `add`: the sequences of the same
    /// names only).
    pub overwrite: bool,
    /// When the destination is an existing dataset, add the sequences to it (its images must
    /// be the size of the dataset's camera; a pass with other intrinsics gets its own
    /// `camera.toml`) and record their provenance under `[source.NAME]`; the dataset's other
    /// sequences and files are not touched.
    pub add: bool,
    /// Provenance written to `dataset.toml` `[source]` (tool, command line, source paths…).
    pub source: toml::Table,
}

/// What [`write_import`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportSummary {
    /// The dataset folder.
    pub dir: PathBuf,
    /// The camera stored in `dataset.toml`.
    pub camera: Camera,
    /// `(sequence name, frames, has depth)` per written sequence.
    pub sequences: Vec<(String, usize, bool)>,
}

/// Sorts files by the number in their name (the last run of ASCII digits of the file stem,
/// so `10_color.png` comes after `9_color.png`), then by name; returns `(number, path)`.
///
/// # Errors
/// [`DataError::Invalid`] naming `dir` when a file has no number or two files share one.
pub fn natural_sort(dir: &Path, files: Vec<PathBuf>) -> Result<Vec<(u64, PathBuf)>, DataError> {
    let mut out = Vec::with_capacity(files.len());
    for f in files {
        let n = frame_number(&f).ok_or_else(|| {
            DataError::invalid(
                &f,
                "file name has no frame number; expected digits in the name",
            )
        })?;
        out.push((n, f));
    }
    out.sort();
    for w in out.windows(2) {
        if let [(a, pa), (b, pb)] = w
            && a == b
        {
            return Err(DataError::invalid(
                dir,
                format!(
                    "{} and {} have the same frame number {a}; expected one file per frame",
                    pa.display(),
                    pb.display()
                ),
            ));
        }
    }
    Ok(out)
}

/// The last run of ASCII digits in a file's stem, as a number.
pub fn frame_number(path: &Path) -> Option<u64> {
    let stem = path.file_stem()?.to_str()?;
    let bytes = stem.as_bytes();
    let end = bytes.iter().rposition(u8::is_ascii_digit)? + 1;
    let start = bytes[..end]
        .iter()
        .rposition(|b| !b.is_ascii_digit())
        .map_or(0, |i| i + 1);
    stem.get(start..end)?.parse().ok()
}

/// The visible files of `dir` whose name matches `pred`.
///
/// # Errors
/// [`DataError::Io`] when `dir` cannot be listed.
pub fn list_files(dir: &Path, pred: impl Fn(&str) -> bool) -> Result<Vec<PathBuf>, DataError> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))? {
        let entry = entry.map_err(|e| DataError::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.starts_with('.') && pred(&name) && entry.path().is_file() {
            files.push(entry.path());
        }
    }
    Ok(files)
}

/// Parses a number field of a text file; the error names the file, line and column.
pub(crate) fn parse_field(
    path: &Path,
    line: usize,
    column: &str,
    text: &str,
) -> Result<f64, DataError> {
    let t = text.trim();
    let v: f64 = t.parse().map_err(|_| {
        DataError::parse(
            path,
            line,
            format!("{column}: {t:?} is not a number; expected a finite number"),
        )
    })?;
    if !v.is_finite() {
        return Err(DataError::parse(
            path,
            line,
            format!("{column}: {t} is not finite; expected a finite number"),
        ));
    }
    Ok(v)
}

/// Largest accepted deviation of a source quaternion's norm from 1 (it is then normalized).
pub const SOURCE_QUATERNION_TOLERANCE: f64 = 1e-3;

/// A unit quaternion from `qx qy qz qw`, normalized; an error naming the file and line when
/// its norm is off by more than [`SOURCE_QUATERNION_TOLERANCE`].
pub(crate) fn unit_quaternion(
    path: &Path,
    line: usize,
    [qx, qy, qz, qw]: [f64; 4],
) -> Result<UnitQuaternion<f64>, DataError> {
    let q = nalgebra::Quaternion::new(qw, qx, qy, qz);
    let norm = q.norm();
    if (norm - 1.0).abs() > SOURCE_QUATERNION_TOLERANCE {
        return Err(DataError::parse(
            path,
            line,
            format!(
                "quaternion (qx qy qz qw) = ({qx} {qy} {qz} {qw}) has norm {norm:.6}; expected a unit quaternion (norm within {SOURCE_QUATERNION_TOLERANCE} of 1)"
            ),
        ));
    }
    Ok(UnitQuaternion::from_quaternion(q))
}

/// The nearest rotation to a nearly orthonormal matrix, as a canonical (`w ≥ 0`) quaternion;
/// `None` when `m` is not within `tol` (Frobenius norm of `mᵀm − I`) of a rotation or has a
/// negative determinant.
pub(crate) fn rotation_from_matrix(m: &Matrix3<f64>, tol: f64) -> Option<UnitQuaternion<f64>> {
    endoloc_geometry::pose::rotation_from_matrix(m, tol)
}

/// A pose with a canonical (`w ≥ 0`) re-normalized quaternion.
pub(crate) fn canonical_pose(t_mm: nalgebra::Vector3<f64>, q: UnitQuaternion<f64>) -> Pose {
    let q = UnitQuaternion::from_quaternion(q.into_inner());
    endoloc_geometry::pose::pose_from_parts(t_mm, endoloc_geometry::canonical_quaternion(q))
}

/// Sampling positions of an undistorting resampler: for each pixel of the target pinhole, the
/// position in the distorted source image (or `None` outside it).
struct UndistortMap {
    width: u32,
    height: u32,
    /// Source pixel position per target pixel, row-major.
    src: Vec<Option<(f32, f32)>>,
}

impl UndistortMap {
    /// Map from `source` (with distortion) to the pinhole with the same intrinsics.
    fn new(source: &Camera) -> Self {
        let (w, h) = (source.width, source.height);
        let mut src = Vec::with_capacity(w as usize * h as usize);
        for v in 0..h {
            for u in 0..w {
                let xn = Vector2::new(
                    (u as f64 - source.cx) / source.fx,
                    (v as f64 - source.cy) / source.fy,
                );
                let xd = source.distortion.distort(xn);
                let (su, sv) = (source.fx * xd.x + source.cx, source.fy * xd.y + source.cy);
                let inside = su >= 0.0
                    && sv >= 0.0
                    && su <= (w - 1) as f64
                    && sv <= (h - 1) as f64
                    && su.is_finite()
                    && sv.is_finite();
                src.push(inside.then_some((su as f32, sv as f32)));
            }
        }
        UndistortMap {
            width: w,
            height: h,
            src,
        }
    }

    /// Bilinear resampling of an interleaved 8-bit image with `channels` channels.
    fn bilinear(&self, data: &[u8], channels: usize) -> Vec<u8> {
        let w = self.width as usize;
        let h = self.height as usize;
        let mut out = vec![0u8; w * h * channels];
        let at = |x: usize, y: usize, c: usize| -> f32 {
            data.get((y * w + x) * channels + c).copied().unwrap_or(0) as f32
        };
        for (i, s) in self.src.iter().enumerate() {
            let Some((su, sv)) = *s else { continue };
            let (x0, y0) = (su.floor() as usize, sv.floor() as usize);
            let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
            let (fx, fy) = (su - x0 as f32, sv - y0 as f32);
            for c in 0..channels {
                let top = at(x0, y0, c) * (1.0 - fx) + at(x1, y0, c) * fx;
                let bottom = at(x0, y1, c) * (1.0 - fx) + at(x1, y1, c) * fx;
                let v = top * (1.0 - fy) + bottom * fy;
                if let Some(o) = out.get_mut(i * channels + c) {
                    *o = v.round().clamp(0.0, 255.0) as u8;
                }
            }
        }
        out
    }

    /// Nearest-neighbour resampling of a depth map (no mixing across depth edges; the depth
    /// along z of a scene point does not depend on the projection model).
    fn nearest(&self, depth: &[f32]) -> Vec<f32> {
        let w = self.width as usize;
        self.src
            .iter()
            .map(|s| match *s {
                Some((su, sv)) => {
                    let (x, y) = (su.round() as usize, sv.round() as usize);
                    depth.get(y * w + x).copied().unwrap_or(0.0)
                }
                None => 0.0,
            })
            .collect()
    }
}

fn decode_image(path: &Path) -> Result<image::DynamicImage, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    decode_source_image(path, &bytes)
}

/// Decodes the bytes of a source image (any format the `image` crate reads: PNG, TIFF,
/// JPEG…, recognised by its content), as the importers do; `path` names the file in errors.
///
/// # Errors
/// [`DataError::Image`] for bytes that are not an image the decoder reads.
pub fn decode_source_image(path: &Path, bytes: &[u8]) -> Result<image::DynamicImage, DataError> {
    image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| DataError::io(path, e))?
        .decode()
        .map_err(|e| DataError::image(path, format!("cannot decode: {e}")))
}

/// Reads a depth map as millimetres along z, row-major.
fn read_depth_mm(path: &Path, enc: DepthEncoding) -> Result<(u32, u32, Vec<f32>), DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    source_depth_mm(path, &bytes, enc)
}

/// Decodes the bytes of a source depth map (one channel, 8- or 16-bit; PNG, TIFF…) into
/// millimetres along z with `enc`, 0 where there is no depth, as the importers do; returns
/// `(width, height, depth_mm)`, row-major. `path` names the file in errors.
///
/// # Errors
/// [`DataError::Image`] for bytes that are not an image, or an image with more than one
/// channel.
pub fn source_depth_mm(
    path: &Path,
    bytes: &[u8],
    enc: DepthEncoding,
) -> Result<(u32, u32, Vec<f32>), DataError> {
    let img = decode_source_image(path, bytes)?;
    if img.color().channel_count() != 1 {
        return Err(DataError::image(
            path,
            format!(
                "depth map has {:?} pixels; expected one channel (8- or 16-bit grey)",
                img.color()
            ),
        ));
    }
    let g = img.into_luma16();
    let scale = if g.as_raw().is_empty() {
        1.0
    } else {
        enc.mm_per_unit
    };
    let mm = g
        .as_raw()
        .iter()
        .map(|&v| {
            if enc.invalid_value == Some(v) {
                0.0
            } else {
                (v as f64 * scale) as f32
            }
        })
        .collect();
    Ok((g.width(), g.height(), mm))
}

fn write_frame(
    seq: &SequenceWriter,
    i: usize,
    frame: &ImportedFrame,
    camera: &Camera,
    depth_enc: Option<DepthEncoding>,
    map: Option<&UndistortMap>,
) -> Result<(), DataError> {
    let img = decode_image(&frame.image)?;
    let (w, h) = (img.width(), img.height());
    if (w, h) != (camera.width, camera.height) {
        return Err(DataError::image(
            &frame.image,
            format!(
                "image is {w}x{h}; expected the camera's size {}x{} (give the intrinsics of this size)",
                camera.width, camera.height
            ),
        ));
    }
    let grey = img.color().channel_count() <= 2;
    if grey {
        let g = img.into_luma8();
        let data = map.map_or_else(|| g.as_raw().clone(), |m| m.bilinear(g.as_raw(), 1));
        seq.write_gray(i, w, h, &data)?;
    } else {
        let rgb = img.into_rgb8();
        let data = map.map_or_else(|| rgb.as_raw().clone(), |m| m.bilinear(rgb.as_raw(), 3));
        seq.write_rgb(i, w, h, &data)?;
    }
    if let (Some(dp), Some(enc)) = (&frame.depth, depth_enc) {
        let (dw, dh, mm) = read_depth_mm(dp, enc)?;
        if (dw, dh) != (w, h) {
            return Err(DataError::image(
                dp,
                format!("depth map is {dw}x{dh}; expected the image size {w}x{h}"),
            ));
        }
        let mm = map.map_or(mm.clone(), |m| m.nearest(&mm));
        seq.write_depth(i, w, h, &mm)?;
    }
    Ok(())
}

/// Writes imported sequences as an endoloc dataset at `out` (images re-encoded as PNG, depth in
/// the format's 16-bit PNG, poses as TUM `poses.txt`, or the frame times as `frames.txt` for a
/// recording without poses), frames in parallel; with `config.add` into an existing dataset at
/// `out`, beside its sequences.
///
/// All sequences must share one camera. The dataset (an added sequence) appears at `out` only
/// when everything was written (staging folder, see [`DatasetWriter`]).
///
/// # Errors
/// [`DataError::AlreadyExists`] when `out` (an added sequence) exists and `config.overwrite`
/// is false; [`DataError::Invalid`] for an added pass whose frames are not the size of the
/// dataset's camera;
/// [`DataError::Invalid`] for no sequences, differing cameras or an empty sequence;
/// [`DataError::Image`] for an image of the wrong size or that cannot be decoded;
/// [`DataError::Io`].
pub fn write_import(
    out: &Path,
    sequences: &[(String, ImportedSequence)],
    config: &WriteImportConfig,
) -> Result<ImportSummary, DataError> {
    let Some((_, first)) = sequences.first() else {
        return Err(DataError::invalid(out, "nothing to import: no sequences"));
    };
    let source_camera = first.camera;
    for (name, s) in sequences {
        if s.camera != source_camera {
            return Err(DataError::invalid(
                &s.source,
                format!(
                    "sequence {name:?} has camera {:?}; expected the same camera as {:?} ({source_camera:?})",
                    s.camera, sequences[0].0
                ),
            ));
        }
        if s.frames.is_empty() {
            return Err(DataError::invalid(
                &s.source,
                format!("sequence {name:?} has no frames"),
            ));
        }
    }
    let undistort = config.undistort && !source_camera.distortion.is_none();
    let camera = if undistort {
        Camera {
            distortion: Distortion::None,
            ..source_camera
        }
    } else {
        source_camera
    };
    let map = undistort.then(|| UndistortMap::new(&source_camera));
    let adding = config.add && out.join(crate::dataset::META_FILE).is_file();
    if adding
        && !config.overwrite
        && let Some((name, _)) = sequences.iter().find(|(n, _)| out.join(n).exists())
    {
        return Err(DataError::AlreadyExists {
            path: out.join(name),
        });
    }
    let writer = if adding {
        let mut writer = DatasetWriter::add_to(out, config.overwrite)?;
        let have = writer.meta().camera;
        if (have.width, have.height) != (camera.width, camera.height) {
            return Err(DataError::invalid(
                &first.source,
                format!(
                    "frames of {}x{}; expected the size of the dataset's camera, {}x{} ({}): \
                     resize them (video: `size`)",
                    camera.width,
                    camera.height,
                    have.width,
                    have.height,
                    out.join(crate::dataset::META_FILE).display()
                ),
            ));
        }
        for (name, _) in sequences {
            writer
                .meta_mut()
                .source
                .insert(name.clone(), toml::Value::Table(config.source.clone()));
        }
        writer
    } else {
        let mut meta = DatasetMeta::new(config.name.clone(), camera);
        meta.source = config.source.clone();
        if undistort {
            meta.source.insert(
                "undistorted".into(),
                toml::Value::String(format!(
                    "images resampled (bilinear; depth nearest) from {:?} to the pinhole with the same fx fy cx cy",
                    source_camera.distortion
                )),
            );
        }
        DatasetWriter::create(out, &meta, config.overwrite)?
    };
    let mut written = Vec::new();
    for (name, s) in sequences {
        let seq = writer.sequence(name)?;
        // Frames are written in parallel; the error reported is the first frame's in order,
        // so the same bad input always names the same file.
        let results: Vec<Result<(), DataError>> = s
            .frames
            .par_iter()
            .enumerate()
            .map(|(i, f)| write_frame(&seq, i, f, &source_camera, s.depth_encoding, map.as_ref()))
            .collect();
        results.into_iter().collect::<Result<(), DataError>>()?;
        let has_depth = s.depth_encoding.is_some() && s.frames.iter().all(|f| f.depth.is_some());
        if adding && camera != writer.meta().camera {
            seq.write_camera(&camera)?;
        }
        if s.posed {
            seq.finish(&s.poses(), None)?;
        } else {
            let times: Vec<f64> = s.frames.iter().map(|f| f.pose.timestamp_s).collect();
            seq.finish_unposed(&times)?;
        }
        written.push((name.clone(), s.frames.len(), has_depth));
    }
    let dir = writer.finish()?;
    Ok(ImportSummary {
        dir,
        camera,
        sequences: written,
    })
}
