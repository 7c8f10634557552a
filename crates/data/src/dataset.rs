//! The endoloc dataset, format version 1 (docs/CONVENTIONS.md):
//!
//! ```text
//! DATASET/
//!   dataset.toml            name, format_version, units = "mm", [source], [camera], [simulation]
//!   mask.png                optional ([camera] mask = "mask.png"): 8-bit, non-zero = valid pixel
//!   SEQUENCE/               one folder per trajectory (train/, test/, …)
//!     images/000000.png …   8-bit grey or RGB PNG; frame index = file order
//!     poses.txt             TUM trajectory, T_wc, mm — one line per image, same order
//!     sections.csv          optional: `frame,section`, one anatomical label per frame
//!     depth/000000.png …    optional: 16-bit depth along z, value = mm × 100 (0 = none)
//! ```
//!
//! [`DatasetWriter`] builds a dataset in a hidden staging folder next to its destination and
//! renames it into place only in [`DatasetWriter::finish`], so a crash or an error never
//! leaves a half-written dataset at the destination. [`Dataset`] and [`Sequence`] read one.

use crate::fsutil::{hidden_sibling, parent_dir, read_text, sync_dir, write_atomic};
use crate::png_io::{
    check_len, decode, decode_depth_mm, decode_png, depth_code_from_mm, write_png,
};
use crate::sections_csv::{read_sections, write_sections};
use crate::trajectory::{StampedPose, read_tum, write_tum};
use crate::{DataError, Section};
use endoloc_geometry::Camera;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

/// The dataset format version this crate reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// The only length unit of the format.
pub const UNITS: &str = "mm";

/// File name of the dataset description.
pub const META_FILE: &str = "dataset.toml";
/// File name of a sequence's trajectory.
pub const POSES_FILE: &str = "poses.txt";
/// File name of a sequence's per-frame anatomical labels.
pub const SECTIONS_FILE: &str = "sections.csv";
/// Folder of a sequence's images.
pub const IMAGES_DIR: &str = "images";
/// Folder of a sequence's depth maps.
pub const DEPTH_DIR: &str = "depth";

/// The usual file name of a dataset's image mask.
pub const MASK_FILE: &str = "mask.png";

/// The contents of `dataset.toml`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "meta_toml::MetaRepr", into = "meta_toml::MetaRepr")]
pub struct DatasetMeta {
    /// Human-readable dataset name.
    pub name: String,
    /// Format version; [`FORMAT_VERSION`] for datasets written by this crate.
    pub format_version: u32,
    /// Length unit of every file: always `"mm"`.
    pub units: String,
    /// Provenance, free form (tool, version, command line, original source and licence, …).
    #[serde(default)]
    pub source: toml::Table,
    /// The camera all images of all sequences were taken with. Stored as a `[camera]` table
    /// with `model = "pinhole"`, size, intrinsics in pixels and an optional
    /// `[camera.distortion]` table (`model = "radial-tangential"` or `"fisheye"`).
    pub camera: Camera,
    /// The image mask, a file name relative to the dataset folder (`[camera] mask`, usually
    /// [`MASK_FILE`]): an 8-bit image of the frames' size, non-zero where the image is valid
    /// (inside the field stop, off the black border). `None`: every pixel is valid.
    pub mask: Option<String>,
    /// The simulator's full configuration when the dataset was simulated (opaque here), so
    /// the dataset can be regenerated from its own files.
    pub simulation: Option<toml::Table>,
}

impl DatasetMeta {
    /// Metadata for a new dataset: current format version, units mm, empty provenance, no
    /// simulation config.
    pub fn new(name: impl Into<String>, camera: Camera) -> Self {
        DatasetMeta {
            name: name.into(),
            format_version: FORMAT_VERSION,
            units: UNITS.to_string(),
            source: toml::Table::new(),
            camera,
            mask: None,
            simulation: None,
        }
    }

    /// Checks version, units and camera; the message says what was expected.
    ///
    /// # Errors
    /// A message for the first problem found.
    pub fn validate(&self) -> Result<(), String> {
        self.problems().into_iter().next().map_or(Ok(()), Err)
    }

    /// Every problem with version, units and camera.
    pub(crate) fn problems(&self) -> Vec<String> {
        let mut p = Vec::new();
        if self.format_version != FORMAT_VERSION {
            p.push(format!(
                "format_version = {}; expected {FORMAT_VERSION}",
                self.format_version
            ));
        }
        if self.units != UNITS {
            p.push(format!("units = {:?}; expected \"{UNITS}\"", self.units));
        }
        if let Err(e) = self.camera.validate() {
            p.push(format!("[camera]: {e}"));
        }
        if let Some(m) = &self.mask {
            let path = Path::new(m);
            if m.is_empty()
                || path.is_absolute()
                || path.components().any(|c| c.as_os_str() == "..")
            {
                p.push(format!(
                    "[camera] mask = {m:?}; expected a file name inside the dataset folder, e.g. \"{MASK_FILE}\""
                ));
            }
        }
        p
    }

    /// Parses `dataset.toml` text (without validating values).
    ///
    /// # Errors
    /// [`DataError::Parse`] naming the line and what was expected.
    pub fn from_toml_str(path: &Path, text: &str) -> Result<Self, DataError> {
        toml::from_str::<DatasetMeta>(text).map_err(|e| {
            let (line, message) = crate::toml_error_line(text, &e);
            DataError::parse(path, line, message)
        })
    }

    /// Reads and validates `dataset.toml`.
    ///
    /// # Errors
    /// [`DataError::Io`], [`DataError::Parse`], or [`DataError::Invalid`] for a wrong
    /// version, units or camera.
    pub fn read(path: &Path) -> Result<Self, DataError> {
        let text = read_text(path)?;
        let meta = Self::from_toml_str(path, &text)?;
        meta.validate().map_err(|m| DataError::invalid(path, m))?;
        Ok(meta)
    }

    /// The TOML text of `dataset.toml`, with a header comment.
    ///
    /// # Errors
    /// A message when the provenance or simulation tables cannot be written as TOML.
    pub fn to_toml_string(&self) -> Result<String, String> {
        let body = toml::to_string(self).map_err(|e| e.to_string())?;
        Ok(format!(
            "# endoloc dataset, format version {FORMAT_VERSION}: lengths in mm, poses T_wc (camera-to-world)\n{body}"
        ))
    }
}

/// `dataset.toml` as stored: `[camera]` holds the [`Camera`], `model = "pinhole"` and the mask.
mod meta_toml {
    use super::DatasetMeta;
    use endoloc_geometry::{Camera, Distortion};
    use serde::{Deserialize, Serialize};

    fn pinhole() -> String {
        "pinhole".to_string()
    }

    /// The camera model, refused here (so the error points at its line) unless `pinhole`.
    fn pinhole_model<'de, D: serde::Deserializer<'de>>(d: D) -> Result<String, D::Error> {
        let model = String::deserialize(d)?;
        if model != "pinhole" {
            return Err(serde::de::Error::custom(format!(
                "camera model {model:?} is not supported; expected \"pinhole\" (lens distortion goes in [camera.distortion])"
            )));
        }
        Ok(model)
    }

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(super) struct CameraRepr {
        #[serde(default = "pinhole", deserialize_with = "pinhole_model")]
        model: String,
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        mask: Option<String>,
        #[serde(default, skip_serializing_if = "Distortion::is_none")]
        distortion: Distortion,
    }

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(super) struct MetaRepr {
        name: String,
        format_version: u32,
        units: String,
        #[serde(default)]
        source: toml::Table,
        camera: CameraRepr,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        simulation: Option<toml::Table>,
    }

    impl TryFrom<MetaRepr> for DatasetMeta {
        type Error = String;
        fn try_from(r: MetaRepr) -> Result<Self, String> {
            let c = r.camera;
            Ok(DatasetMeta {
                name: r.name,
                format_version: r.format_version,
                units: r.units,
                source: r.source,
                camera: Camera {
                    width: c.width,
                    height: c.height,
                    fx: c.fx,
                    fy: c.fy,
                    cx: c.cx,
                    cy: c.cy,
                    distortion: c.distortion,
                },
                mask: c.mask,
                simulation: r.simulation,
            })
        }
    }

    impl From<DatasetMeta> for MetaRepr {
        fn from(m: DatasetMeta) -> Self {
            let c = m.camera;
            MetaRepr {
                name: m.name,
                format_version: m.format_version,
                units: m.units,
                source: m.source,
                camera: CameraRepr {
                    model: pinhole(),
                    width: c.width,
                    height: c.height,
                    fx: c.fx,
                    fy: c.fy,
                    cx: c.cx,
                    cy: c.cy,
                    mask: m.mask,
                    distortion: c.distortion,
                },
                simulation: m.simulation,
            }
        }
    }
}

/// Checks a mask against the camera: its size, and at least one valid pixel.
fn check_mask(path: &Path, mask: &image::GrayImage, camera: &Camera) -> Result<(), DataError> {
    if (mask.width(), mask.height()) != (camera.width, camera.height) {
        return Err(DataError::invalid(
            path,
            format!(
                "mask is {}×{} pixels; expected the camera's {}×{}",
                mask.width(),
                mask.height(),
                camera.width,
                camera.height
            ),
        ));
    }
    if mask.as_raw().iter().all(|&v| v == 0) {
        return Err(DataError::invalid(
            path,
            "no valid pixel (every value is 0); expected non-zero inside the field of view",
        ));
    }
    Ok(())
}

/// Decodes the bytes of a dataset's mask PNG (see [`Dataset::load_mask`]) and checks it
/// against `camera`; `path` names the file in errors.
///
/// # Errors
/// [`DataError::Image`] for bytes that are not a PNG; [`DataError::Invalid`] when its size is
/// not the camera's or no pixel is valid.
pub fn mask_from_png(
    path: &Path,
    bytes: &[u8],
    camera: &Camera,
) -> Result<image::GrayImage, DataError> {
    let img = decode_png(path, bytes)?.into_luma8();
    check_mask(path, &img, camera)?;
    Ok(img)
}

/// Writes a mask as an 8-bit grey PNG.
fn write_mask_png(path: &Path, mask: &image::GrayImage) -> Result<(), DataError> {
    write_png(
        path,
        mask.width(),
        mask.height(),
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        mask.as_raw(),
    )
}

/// Adds (or replaces, with `force`) the image mask of the dataset in `dir`: writes
/// [`MASK_FILE`] and names it in `dataset.toml`, each atomically.
///
/// # Errors
/// [`DataError::AlreadyExists`] when the dataset already has a mask and `force` is off;
/// [`DataError::Invalid`] for a mask of another size or without a valid pixel; read and
/// write errors naming the file.
pub fn write_dataset_mask(
    dir: &Path,
    mask: &image::GrayImage,
    force: bool,
) -> Result<PathBuf, DataError> {
    let meta_path = dir.join(META_FILE);
    let mut meta = DatasetMeta::read(&meta_path)?;
    let path = dir.join(MASK_FILE);
    if !force && (meta.mask.is_some() || path.exists()) {
        return Err(DataError::AlreadyExists { path });
    }
    check_mask(&path, mask, &meta.camera)?;
    let tmp = hidden_sibling(&path, "tmp");
    write_mask_png(&tmp, mask)?;
    std::fs::rename(&tmp, &path).map_err(|e| DataError::io(&path, e))?;
    meta.mask = Some(MASK_FILE.to_string());
    let text = meta
        .to_toml_string()
        .map_err(|m| DataError::invalid(&meta_path, m))?;
    write_atomic(&meta_path, text.as_bytes())?;
    Ok(path)
}

/// Locks a mutex, recovering the data if another thread panicked while holding it (the state
/// guarded here stays consistent after any single update).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// State shared by a [`DatasetWriter`] and its [`SequenceWriter`]s.
#[derive(Debug)]
struct WriterShared {
    staging: PathBuf,
    camera: Camera,
    /// Sequence name → finished.
    sequences: Mutex<BTreeMap<String, bool>>,
}

/// Writes a dataset; see the [module docs](self).
///
/// ```no_run
/// # use endoloc_data::{DatasetMeta, DatasetWriter, StampedPose};
/// # fn demo(meta: DatasetMeta, poses: Vec<StampedPose>, img: Vec<u8>) -> Result<(), endoloc_data::DataError> {
/// let writer = DatasetWriter::create("out/sim".as_ref(), &meta, false)?;
/// let train = writer.sequence("train")?;
/// train.write_rgb(0, meta.camera.width, meta.camera.height, &img)?; // from any thread
/// train.finish(&poses, None)?;
/// let dir = writer.finish()?; // only now does out/sim appear
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct DatasetWriter {
    dir: PathBuf,
    meta: DatasetMeta,
    overwrite: bool,
    shared: Arc<WriterShared>,
    finished: bool,
}

impl DatasetWriter {
    /// Starts a dataset that will appear at `dir` when [`DatasetWriter::finish`] succeeds.
    ///
    /// Creates `dir`'s parent folders if needed and a hidden staging folder next to `dir`.
    ///
    /// # Errors
    /// [`DataError::AlreadyExists`] if `dir` exists and `overwrite` is false (checked before
    /// any work); [`DataError::Invalid`] if the metadata is invalid (version, units, camera);
    /// [`DataError::Io`] if the staging folder cannot be created.
    pub fn create(dir: &Path, meta: &DatasetMeta, overwrite: bool) -> Result<Self, DataError> {
        if !overwrite && dir.symlink_metadata().is_ok() {
            return Err(DataError::AlreadyExists {
                path: dir.to_path_buf(),
            });
        }
        if dir.file_name().is_none() {
            return Err(DataError::invalid(
                dir,
                "expected a dataset folder path ending in a folder name",
            ));
        }
        meta.validate()
            .map_err(|m| DataError::invalid(dir.join(META_FILE), m))?;
        let parent = parent_dir(dir);
        std::fs::create_dir_all(&parent).map_err(|e| DataError::io(&parent, e))?;
        // Staging folders of killed runs are tidied away before a new one is made.
        crate::fsutil::remove_stale_siblings(dir, "staging");
        let staging = hidden_sibling(dir, "staging");
        std::fs::create_dir(&staging).map_err(|e| DataError::io(&staging, e))?;
        Ok(DatasetWriter {
            dir: dir.to_path_buf(),
            meta: meta.clone(),
            overwrite,
            shared: Arc::new(WriterShared {
                staging,
                camera: meta.camera,
                sequences: Mutex::new(BTreeMap::new()),
            }),
            finished: false,
        })
    }

    /// The destination folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The metadata that will be written.
    pub fn meta(&self) -> &DatasetMeta {
        &self.meta
    }

    /// Starts sequence `name` (a plain folder name such as `train` or `test`).
    ///
    /// # Errors
    /// [`DataError::Invalid`] for an empty, hidden or path-like name or one already started;
    /// [`DataError::Io`] if its folders cannot be created.
    pub fn sequence(&self, name: &str) -> Result<SequenceWriter, DataError> {
        let bad = name.is_empty()
            || name.starts_with('.')
            || name.contains(['/', '\\', ':'])
            || name.chars().any(char::is_control);
        if bad {
            return Err(DataError::invalid(
                self.dir.join(name),
                format!(
                    "sequence name {name:?}: expected a plain folder name (no '/', '\\', ':' or leading '.')"
                ),
            ));
        }
        {
            let mut seqs = lock(&self.shared.sequences);
            if seqs.contains_key(name) {
                return Err(DataError::invalid(
                    self.dir.join(name),
                    format!("sequence {name:?} was already started in this dataset"),
                ));
            }
            seqs.insert(name.to_string(), false);
        }
        let dir = self.shared.staging.join(name);
        let images = dir.join(IMAGES_DIR);
        std::fs::create_dir_all(&images)
            .map_err(|e| DataError::io(self.dir.join(name).join(IMAGES_DIR), e))?;
        Ok(SequenceWriter {
            name: name.to_string(),
            final_dir: self.dir.join(name),
            dir,
            shared: Arc::clone(&self.shared),
            frames: Mutex::new(FrameLog::default()),
        })
    }

    /// Writes the image mask (8-bit, the camera's size, non-zero = valid) as [`MASK_FILE`] and
    /// names it in `dataset.toml` (`[camera] mask`).
    ///
    /// # Errors
    /// [`DataError::Invalid`] for a mask of another size or without a valid pixel;
    /// [`DataError::Io`] if writing fails.
    pub fn write_mask(&mut self, mask: &image::GrayImage) -> Result<(), DataError> {
        let path = self.shared.staging.join(MASK_FILE);
        check_mask(&path, mask, &self.meta.camera)
            .and_then(|()| write_mask_png(&path, mask))
            .map_err(|e| e.relocated(&self.shared.staging, &self.dir))?;
        self.meta.mask = Some(MASK_FILE.to_string());
        Ok(())
    }

    /// Writes `dataset.toml` and moves the dataset into place at its destination (replacing
    /// an existing folder only now, when `overwrite` was given). Returns the destination.
    ///
    /// # Errors
    /// [`DataError::Invalid`] if a started sequence was not finished;
    /// [`DataError::AlreadyExists`] if the destination appeared meanwhile and overwriting was
    /// not asked for; [`DataError::Io`] if writing or renaming fails. On error nothing is left
    /// at the destination that was not there before, and the staging folder is removed.
    pub fn finish(mut self) -> Result<PathBuf, DataError> {
        let unfinished: Vec<String> = lock(&self.shared.sequences)
            .iter()
            .filter(|(_, done)| !**done)
            .map(|(n, _)| n.clone())
            .collect();
        if !unfinished.is_empty() {
            return Err(DataError::invalid(
                &self.dir,
                format!(
                    "sequence(s) {} were started but not finished; call SequenceWriter::finish for each",
                    unfinished.join(", ")
                ),
            ));
        }
        let staging = self.shared.staging.clone();
        let meta_path = staging.join(META_FILE);
        let text = self
            .meta
            .to_toml_string()
            .map_err(|m| DataError::invalid(self.dir.join(META_FILE), m))?;
        write_atomic(&meta_path, text.as_bytes()).map_err(|e| e.relocated(&staging, &self.dir))?;
        sync_dir(&staging);

        let exists = self.dir.symlink_metadata().is_ok();
        if exists && !self.overwrite {
            return Err(DataError::AlreadyExists {
                path: self.dir.clone(),
            });
        }
        if exists {
            let old = hidden_sibling(&self.dir, "old");
            std::fs::rename(&self.dir, &old).map_err(|e| DataError::io(&self.dir, e))?;
            if let Err(e) = std::fs::rename(&staging, &self.dir) {
                // Put the old dataset back; the staging folder is removed by Drop.
                let _ = std::fs::rename(&old, &self.dir);
                return Err(DataError::io(&self.dir, e));
            }
            self.finished = true;
            sync_dir(&parent_dir(&self.dir));
            let removed = if old.is_dir() {
                std::fs::remove_dir_all(&old)
            } else {
                std::fs::remove_file(&old)
            };
            removed.map_err(|e| DataError::io(&old, e))?;
        } else {
            std::fs::rename(&staging, &self.dir).map_err(|e| DataError::io(&self.dir, e))?;
            self.finished = true;
            sync_dir(&parent_dir(&self.dir));
        }
        Ok(self.dir.clone())
    }
}

impl Drop for DatasetWriter {
    /// An unfinished dataset (error, panic, early return) leaves nothing behind.
    fn drop(&mut self) {
        if !self.finished {
            let _ = std::fs::remove_dir_all(&self.shared.staging);
        }
    }
}

#[derive(Debug, Default)]
struct FrameLog {
    images: BTreeSet<usize>,
    depth: BTreeSet<usize>,
}

/// Writes one sequence of a dataset. It is `Sync`: `write_*` may be called from many threads
/// at once (e.g. a rayon loop over frames), in any frame order.
#[derive(Debug)]
pub struct SequenceWriter {
    name: String,
    dir: PathBuf,
    final_dir: PathBuf,
    shared: Arc<WriterShared>,
    frames: Mutex<FrameLog>,
}

impl SequenceWriter {
    /// The sequence name.
    pub fn name(&self) -> &str {
        &self.name
    }

    fn check_size(&self, path: &Path, width: u32, height: u32) -> Result<(), DataError> {
        let cam = &self.shared.camera;
        if (width, height) != (cam.width, cam.height) {
            return Err(DataError::image(
                path,
                format!(
                    "image is {width}x{height}; expected the camera's size {}x{}",
                    cam.width, cam.height
                ),
            ));
        }
        Ok(())
    }

    fn image_path(&self, frame: usize) -> PathBuf {
        self.dir.join(IMAGES_DIR).join(format!("{frame:06}.png"))
    }

    fn write_image(
        &self,
        frame: usize,
        width: u32,
        height: u32,
        data: &[u8],
        color: png::ColorType,
        channels: usize,
    ) -> Result<(), DataError> {
        let path = self.image_path(frame);
        self.check_size(&path, width, height)
            .and_then(|()| check_len(&path, width, height, channels, data.len()))
            .and_then(|()| write_png(&path, width, height, color, png::BitDepth::Eight, data))
            .map_err(|e| e.relocated(&self.dir, &self.final_dir))?;
        lock(&self.frames).images.insert(frame);
        Ok(())
    }

    /// Writes frame `frame` as an 8-bit RGB PNG `images/{frame:06}.png`; `rgb` is row-major,
    /// 3 bytes per pixel, `width × height` the camera's size.
    ///
    /// # Errors
    /// [`DataError::Image`] for a wrong size or buffer length; [`DataError::Io`].
    pub fn write_rgb(
        &self,
        frame: usize,
        width: u32,
        height: u32,
        rgb: &[u8],
    ) -> Result<(), DataError> {
        self.write_image(frame, width, height, rgb, png::ColorType::Rgb, 3)
    }

    /// Writes frame `frame` as an 8-bit grey PNG `images/{frame:06}.png`.
    ///
    /// # Errors
    /// [`DataError::Image`] for a wrong size or buffer length; [`DataError::Io`].
    pub fn write_gray(
        &self,
        frame: usize,
        width: u32,
        height: u32,
        gray: &[u8],
    ) -> Result<(), DataError> {
        self.write_image(frame, width, height, gray, png::ColorType::Grayscale, 1)
    }

    /// Writes the depth map of frame `frame` (depth along the optical axis z, mm) as a 16-bit
    /// grey PNG `depth/{frame:06}.png` with value `round(mm × 100)`; 0 (no depth) for
    /// non-finite, non-positive or > 655.35 mm depths.
    ///
    /// # Errors
    /// [`DataError::Image`] for a wrong size or buffer length; [`DataError::Io`].
    pub fn write_depth(
        &self,
        frame: usize,
        width: u32,
        height: u32,
        depth_mm: &[f32],
    ) -> Result<(), DataError> {
        let dir = self.dir.join(DEPTH_DIR);
        let path = dir.join(format!("{frame:06}.png"));
        let write = || {
            self.check_size(&path, width, height)?;
            check_len(&path, width, height, 1, depth_mm.len())?;
            let mut bytes = Vec::with_capacity(depth_mm.len() * 2);
            for &d in depth_mm {
                bytes.extend_from_slice(&depth_code_from_mm(d).to_be_bytes());
            }
            std::fs::create_dir_all(&dir).map_err(|e| DataError::io(&dir, e))?;
            write_png(
                &path,
                width,
                height,
                png::ColorType::Grayscale,
                png::BitDepth::Sixteen,
                &bytes,
            )
        };
        write().map_err(|e| e.relocated(&self.dir, &self.final_dir))?;
        lock(&self.frames).depth.insert(frame);
        Ok(())
    }

    /// Number of distinct frames whose image has been written so far.
    pub fn frames_written(&self) -> usize {
        lock(&self.frames).images.len()
    }

    /// Completes the sequence: writes `poses.txt` (one TUM line per image, same order) and,
    /// when given, `sections.csv`.
    ///
    /// # Errors
    /// [`DataError::Invalid`] when the images written are not exactly frames
    /// `0..poses.len()`, when depth maps were written for some frames but not all, when
    /// `sections` has a different length, or when a pose is not finite; [`DataError::Io`].
    pub fn finish(
        self,
        poses: &[StampedPose],
        sections: Option<&[Section]>,
    ) -> Result<(), DataError> {
        let frames = std::mem::take(&mut *lock(&self.frames));
        let n = poses.len();
        let images_dir = self.final_dir.join(IMAGES_DIR);
        if frames.images.len() != n {
            return Err(DataError::invalid(
                &images_dir,
                format!(
                    "{} images written but {n} poses given; expected one image per pose",
                    frames.images.len()
                ),
            ));
        }
        if let Some(missing) = (0..n).find(|f| !frames.images.contains(f)) {
            return Err(DataError::invalid(
                &images_dir,
                format!("frame {missing} has no image; expected images for frames 0..{n}"),
            ));
        }
        if !frames.depth.is_empty() && frames.depth != frames.images {
            let missing = (0..n).find(|f| !frames.depth.contains(f));
            return Err(DataError::invalid(
                self.final_dir.join(DEPTH_DIR),
                format!(
                    "{} depth maps written for {n} images{}; expected depth for every frame or none",
                    frames.depth.len(),
                    missing.map_or(String::new(), |m| format!(" (frame {m} has none)"))
                ),
            ));
        }
        if let Some(s) = sections
            && s.len() != n
        {
            return Err(DataError::invalid(
                self.final_dir.join(SECTIONS_FILE),
                format!(
                    "{} section labels for {n} frames; expected one per frame",
                    s.len()
                ),
            ));
        }
        write_tum(&self.dir.join(POSES_FILE), poses)
            .and_then(|()| match sections {
                Some(s) => write_sections(&self.dir.join(SECTIONS_FILE), s),
                None => Ok(()),
            })
            .map_err(|e| e.relocated(&self.dir, &self.final_dir))?;
        sync_dir(&self.dir);
        lock(&self.shared.sequences).insert(self.name.clone(), true);
        Ok(())
    }
}

/// A dataset opened for reading.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The dataset folder.
    pub root: PathBuf,
    /// The contents of `dataset.toml`.
    pub meta: DatasetMeta,
    /// Names of the sub-folders that hold a `poses.txt`, sorted.
    pub sequences: Vec<String>,
}

/// Sorted names of the visible sub-folders of `root` that contain `poses.txt`.
pub(crate) fn list_sequences(root: &Path) -> Result<Vec<String>, DataError> {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(root).map_err(|e| DataError::io(root, e))? {
        let entry = entry.map_err(|e| DataError::io(root, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue;
        }
        let p = entry.path();
        if p.is_dir() && p.join(POSES_FILE).is_file() {
            names.push(name);
        }
    }
    names.sort();
    Ok(names)
}

/// The `.png` files of a folder (hidden files skipped), sorted by name: the frame order.
pub(crate) fn list_pngs(dir: &Path) -> Result<Vec<PathBuf>, DataError> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))? {
        let entry = entry.map_err(|e| DataError::io(dir, e))?;
        let p = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        let is_png = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if is_png && !name.starts_with('.') && p.is_file() {
            files.push(p);
        }
    }
    files.sort();
    Ok(files)
}

impl Dataset {
    /// Opens the dataset at `dir`: reads and validates `dataset.toml` and lists the sequences.
    ///
    /// # Errors
    /// [`DataError::Io`] if `dataset.toml` or the folder cannot be read, [`DataError::Parse`]
    /// or [`DataError::Invalid`] for a bad `dataset.toml`.
    pub fn open(dir: &Path) -> Result<Self, DataError> {
        let meta_path = dir.join(META_FILE);
        if !meta_path.is_file() {
            let what = if !dir.is_dir() {
                "no such folder"
            } else if dir.join(POSES_FILE).is_file() {
                "a sequence folder, not a dataset: give the folder above it"
            } else {
                "not an endoloc dataset (no dataset.toml): make one with endoloc simulate or endoloc import"
            };
            return Err(DataError::invalid(dir, what));
        }
        let meta = DatasetMeta::read(&meta_path)?;
        let sequences = list_sequences(dir)?;
        Ok(Dataset {
            root: dir.to_path_buf(),
            meta,
            sequences,
        })
    }

    /// The mask file named by `[camera] mask`, when there is one.
    pub fn mask_path(&self) -> Option<PathBuf> {
        self.meta.mask.as_ref().map(|m| self.root.join(m))
    }

    /// The image mask (`[camera] mask`): 8-bit, the camera's size, non-zero = valid; `None`
    /// when the dataset has none.
    ///
    /// # Errors
    /// Errors naming the file when it cannot be read or decoded; [`DataError::Invalid`] when its size is not the camera's or no
    /// pixel is valid.
    pub fn load_mask(&self) -> Result<Option<image::GrayImage>, DataError> {
        read_dataset_mask(&self.root, &self.meta)
    }

    /// Loads sequence `name`: its poses, image list, sections and depth list.
    ///
    /// # Errors
    /// [`DataError::Invalid`] for an unknown sequence or counts that differ (images, poses,
    /// sections, depth maps: run `endoloc dataset check` for a full report); errors from
    /// reading `poses.txt` or `sections.csv`.
    pub fn sequence(&self, name: &str) -> Result<Sequence, DataError> {
        if !self.sequences.iter().any(|s| s == name) {
            return Err(DataError::invalid(
                self.root.join(name),
                format!(
                    "no sequence {name:?} in this dataset; it has: {}",
                    if self.sequences.is_empty() {
                        "none".to_string()
                    } else {
                        self.sequences.join(", ")
                    }
                ),
            ));
        }
        let c = &self.meta.camera;
        let mask = self.load_mask()?.map(Arc::new);
        Sequence::open_in(&self.root.join(name), Some((c.width, c.height)), mask)
    }
}

/// The mask named by `meta`'s `[camera] mask` in the dataset folder `root`, when there is one.
fn read_dataset_mask(
    root: &Path,
    meta: &DatasetMeta,
) -> Result<Option<image::GrayImage>, DataError> {
    let Some(name) = &meta.mask else {
        return Ok(None);
    };
    let path = root.join(name);
    let bytes = std::fs::read(&path).map_err(|e| DataError::io(&path, e))?;
    mask_from_png(&path, &bytes, &meta.camera).map(Some)
}

/// One sequence of a dataset, loaded lazily: poses and labels in memory, images on demand.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// Sequence (folder) name.
    pub name: String,
    /// Sequence folder.
    pub dir: PathBuf,
    /// Camera-to-world poses `T_wc` (mm), one per image.
    pub poses: Vec<StampedPose>,
    /// Image files in frame order (sorted file names).
    pub image_paths: Vec<PathBuf>,
    /// Anatomical label per frame, when `sections.csv` exists.
    pub sections: Option<Vec<Section>>,
    /// Depth maps in frame order, when the `depth/` folder exists.
    pub depth_paths: Option<Vec<PathBuf>>,
    /// The camera's image size `(width, height)` from the dataset's `dataset.toml`, when the
    /// sequence sits in a dataset folder: every image loaded is checked against it.
    pub image_size: Option<(u32, u32)>,
    /// The dataset's image mask (`[camera] mask`; non-zero = valid), when it has one: every
    /// image loaded is black outside it, so that each stage — the zone network in training
    /// and at test time, SURF, the viewer — sees a frame the same way, whatever a recorder
    /// left in its border (noise, overlays, a time stamp).
    pub mask: Option<Arc<image::GrayImage>>,
}

impl Sequence {
    /// Loads the sequence stored in folder `dir`.
    ///
    /// # Errors
    /// See [`Dataset::sequence`].
    pub fn open(dir: &Path) -> Result<Self, DataError> {
        // The dataset's camera and mask, when the sequence sits in a dataset folder.
        let (image_size, mask) = match dir.parent() {
            Some(root) if root.join(META_FILE).is_file() => {
                let meta = DatasetMeta::read(&root.join(META_FILE))?;
                let c = &meta.camera;
                let mask = read_dataset_mask(root, &meta)?.map(Arc::new);
                (Some((c.width, c.height)), mask)
            }
            _ => (None, None),
        };
        Self::open_in(dir, image_size, mask)
    }

    /// [`Sequence::open`] with the camera's image size (`None`: unchecked) and the dataset's
    /// mask already known.
    fn open_in(
        dir: &Path,
        image_size: Option<(u32, u32)>,
        mask: Option<Arc<image::GrayImage>>,
    ) -> Result<Self, DataError> {
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let poses = read_tum(&dir.join(POSES_FILE))?;
        let images_dir = dir.join(IMAGES_DIR);
        let image_paths = list_pngs(&images_dir)?;
        let n = poses.len();
        if image_paths.len() != n {
            return Err(DataError::invalid(
                &images_dir,
                format!(
                    "{} images but {n} poses in {POSES_FILE}; expected one image per pose (run `endoloc dataset check`)",
                    image_paths.len()
                ),
            ));
        }
        let sections_path = dir.join(SECTIONS_FILE);
        let sections = if sections_path.is_file() {
            let s = read_sections(&sections_path)?;
            if s.len() != n {
                return Err(DataError::invalid(
                    &sections_path,
                    format!("{} rows but {n} poses; expected one row per frame", s.len()),
                ));
            }
            Some(s)
        } else {
            None
        };
        let depth_dir = dir.join(DEPTH_DIR);
        let depth_paths = if depth_dir.is_dir() {
            let d = list_pngs(&depth_dir)?;
            if d.len() != n {
                return Err(DataError::invalid(
                    &depth_dir,
                    format!(
                        "{} depth maps but {n} poses; expected one per frame",
                        d.len()
                    ),
                ));
            }
            Some(d)
        } else {
            None
        };
        Ok(Sequence {
            name,
            dir: dir.to_path_buf(),
            poses,
            image_paths,
            sections,
            depth_paths,
            image_size,
            mask,
        })
    }

    /// This sequence with its images loaded as recorded, not blacked out beyond the mask
    /// (e.g. to find the mask again).
    pub fn unmasked(mut self) -> Self {
        self.mask = None;
        self
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether the sequence has no frames.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    fn frame_path<'a>(&self, paths: &'a [PathBuf], i: usize) -> Result<&'a Path, DataError> {
        paths.get(i).map(PathBuf::as_path).ok_or_else(|| {
            DataError::invalid(
                &self.dir,
                format!(
                    "frame {i} out of range; sequence {:?} has {} frames",
                    self.name,
                    paths.len()
                ),
            )
        })
    }

    /// Loads image `i` as 8-bit grey (an RGB image is converted).
    ///
    /// # Errors
    /// [`DataError::Invalid`] for `i` out of range; [`DataError::Image`] for an image that
    /// cannot be decoded or whose size is not the camera's; [`DataError::Io`].
    pub fn load_gray(&self, i: usize) -> Result<image::GrayImage, DataError> {
        let mut img = self.load_image(i)?.into_luma8();
        if let Some(mask) = &self.mask {
            black_outside(&mut img, mask);
        }
        Ok(img)
    }

    /// Decodes image `i` and checks its size against the dataset's camera.
    fn load_image(&self, i: usize) -> Result<image::DynamicImage, DataError> {
        let path = self.frame_path(&self.image_paths, i)?;
        let img = decode(path)?;
        if let Some((w, h)) = self.image_size
            && (img.width(), img.height()) != (w, h)
        {
            return Err(DataError::image(
                path,
                format!(
                    "{}x{} pixels; expected the camera's {w}x{h} (dataset.toml)",
                    img.width(),
                    img.height()
                ),
            ));
        }
        Ok(img)
    }

    /// Loads image `i` as 8-bit RGB (a grey image is replicated).
    ///
    /// # Errors
    /// [`DataError::Invalid`] for `i` out of range; [`DataError::Image`] / [`DataError::Io`].
    pub fn load_rgb(&self, i: usize) -> Result<image::RgbImage, DataError> {
        let mut img = self.load_image(i)?.into_rgb8();
        if let Some(mask) = &self.mask {
            black_outside(&mut img, mask);
        }
        Ok(img)
    }

    /// Loads depth map `i`: `(width, height, depth_mm)` row-major, depth along the optical
    /// axis in mm, 0.0 where there is no depth.
    ///
    /// # Errors
    /// [`DataError::Invalid`] if the sequence has no depth or `i` is out of range;
    /// [`DataError::Image`] if the file is not a 16-bit grey PNG.
    pub fn load_depth_mm(&self, i: usize) -> Result<(u32, u32, Vec<f32>), DataError> {
        let paths = self.depth_paths.as_deref().ok_or_else(|| {
            DataError::invalid(
                self.dir.join(DEPTH_DIR),
                format!("sequence {:?} has no depth maps", self.name),
            )
        })?;
        decode_depth_mm(self.frame_path(paths, i)?)
    }
}

/// Sets every pixel of `img` where `mask` is 0 to black. `img` and `mask` have the camera's
/// size (checked when the image is loaded and when the mask is read).
pub fn black_outside<P: image::Pixel<Subpixel = u8>>(
    img: &mut image::ImageBuffer<P, Vec<u8>>,
    mask: &image::GrayImage,
) {
    let channels = usize::from(P::CHANNEL_COUNT);
    for (px, &m) in img.chunks_exact_mut(channels).zip(mask.as_raw()) {
        if m == 0 {
            px.fill(0);
        }
    }
}
