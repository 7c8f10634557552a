//! Writing a dataset: a hidden staging folder renamed into place only when every sequence is
//! finished.

use crate::fsutil::{hidden_sibling, parent_dir, sync_dir, write_atomic};
use crate::png_io::{check_len, depth_code_from_mm, write_png};
use crate::sections_csv::write_sections;
use crate::trajectory::{StampedPose, write_frame_times, write_tum};
use crate::{DataError, Section};
use endoloc_geometry::Camera;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use super::layout::{
    DEPTH_DIR, FRAME_TIMES_FILE, IMAGES_DIR, MASK_FILE, META_FILE, MIDLINE_FILE, POSES_FILE,
    SECTIONS_FILE,
};
use super::mask::{check_mask, write_mask_png};
use super::meta::DatasetMeta;

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

/// Writes a dataset; see the [module docs](crate::dataset).
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
    /// Adding sequences to the existing dataset at `dir` ([`DatasetWriter::add_to`]).
    adding: bool,
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
            adding: false,
            shared: Arc::new(WriterShared {
                staging,
                camera: meta.camera,
                sequences: Mutex::new(BTreeMap::new()),
            }),
            finished: false,
        })
    }

    /// Adds sequences to the existing dataset at `dir`: they are written into a hidden staging
    /// folder beside it and moved in by [`DatasetWriter::finish`], each whole, then
    /// `dataset.toml` is replaced (with any change made through [`DatasetWriter::meta_mut`]).
    /// The dataset's other sequences are not touched; a sequence of the same name is replaced
    /// only when `overwrite`.
    ///
    /// # Errors
    /// Errors reading `dir/dataset.toml` (none there: [`DataError::Io`]);
    /// [`DataError::Io`] if the staging folder cannot be created.
    pub fn add_to(dir: &Path, overwrite: bool) -> Result<Self, DataError> {
        let meta = DatasetMeta::read(&dir.join(META_FILE))?;
        crate::fsutil::remove_stale_siblings(dir, "staging");
        let staging = hidden_sibling(dir, "staging");
        std::fs::create_dir(&staging).map_err(|e| DataError::io(&staging, e))?;
        Ok(DatasetWriter {
            dir: dir.to_path_buf(),
            overwrite,
            adding: true,
            shared: Arc::new(WriterShared {
                staging,
                camera: meta.camera,
                sequences: Mutex::new(BTreeMap::new()),
            }),
            meta,
            finished: false,
        })
    }

    /// The metadata that will be written, to change before [`DatasetWriter::finish`] (e.g.
    /// the provenance of an added sequence).
    pub fn meta_mut(&mut self) -> &mut DatasetMeta {
        &mut self.meta
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

    /// Writes the colon's mid-line as [`MIDLINE_FILE`]: `points` in the world frame, mm, from
    /// the anus to the caecum.
    ///
    /// # Errors
    /// [`DataError::Invalid`] for fewer than two points or a non-finite one; [`DataError::Io`].
    pub fn write_midline(&mut self, points: &[nalgebra::Point3<f64>]) -> Result<(), DataError> {
        let path = self.shared.staging.join(MIDLINE_FILE);
        if points.len() < 2 {
            return Err(DataError::invalid(
                self.dir.join(MIDLINE_FILE),
                format!("{} mid-line points; expected at least 2", points.len()),
            ));
        }
        let mut text = String::from(
            "# endoloc mid-line, anus to caecum: x y z in mm (world frame), one point per line\n",
        );
        for (i, p) in points.iter().enumerate() {
            if !p.coords.iter().all(|v| v.is_finite()) {
                return Err(DataError::invalid(
                    self.dir.join(MIDLINE_FILE),
                    format!("mid-line point {i} is not finite: {p:?}"),
                ));
            }
            text.push_str(&format!("{:.4} {:.4} {:.4}\n", p.x, p.y, p.z));
        }
        write_atomic(&path, text.as_bytes())
            .map_err(|e| e.relocated(&self.shared.staging, &self.dir))
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
        if self.adding {
            return self.finish_adding();
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

impl DatasetWriter {
    /// [`DatasetWriter::finish`] of [`DatasetWriter::add_to`]: each staged sequence renamed
    /// into the dataset (one it replaces moved aside first and removed after), then
    /// `dataset.toml` replaced atomically.
    fn finish_adding(self) -> Result<PathBuf, DataError> {
        let names: Vec<String> = lock(&self.shared.sequences).keys().cloned().collect();
        let existing: Vec<&String> = names
            .iter()
            .filter(|n| self.dir.join(n).symlink_metadata().is_ok())
            .collect();
        if let Some(name) = existing.first()
            && !self.overwrite
        {
            return Err(DataError::AlreadyExists {
                path: self.dir.join(name),
            });
        }
        let text = self
            .meta
            .to_toml_string()
            .map_err(|m| DataError::invalid(self.dir.join(META_FILE), m))?;
        let mut replaced = Vec::new();
        for name in &names {
            let target = self.dir.join(name);
            if target.symlink_metadata().is_ok() {
                let old = hidden_sibling(&target, "old");
                std::fs::rename(&target, &old).map_err(|e| DataError::io(&target, e))?;
                replaced.push(old);
            }
            std::fs::rename(self.shared.staging.join(name), &target)
                .map_err(|e| DataError::io(&target, e))?;
        }
        write_atomic(&self.dir.join(META_FILE), text.as_bytes())?;
        sync_dir(&self.dir);
        for old in replaced {
            std::fs::remove_dir_all(&old).map_err(|e| DataError::io(&old, e))?;
        }
        // The staging folder is empty now; Drop removes it.
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

    /// Writes a further trajectory of the sequence as TUM file `file` (a plain file name such
    /// as [`CHANGED_POSES_FILE`](crate::CHANGED_POSES_FILE)); `poses.txt` is written by
    /// [`SequenceWriter::finish`].
    ///
    /// # Errors
    /// [`DataError::Invalid`] for a path-like name, `poses.txt`, or a non-finite pose;
    /// [`DataError::Io`].
    pub fn write_trajectory(&self, file: &str, poses: &[StampedPose]) -> Result<(), DataError> {
        if file.is_empty() || file.contains(['/', '\\', ':']) || file == POSES_FILE {
            return Err(DataError::invalid(
                self.final_dir.join(file),
                format!(
                    "trajectory file {file:?}: expected a plain file name other than {POSES_FILE}"
                ),
            ));
        }
        write_tum(&self.dir.join(file), poses).map_err(|e| e.relocated(&self.dir, &self.final_dir))
    }

    /// Writes this sequence's own camera ([`crate::SEQUENCE_CAMERA_FILE`]: a pass taken with
    /// another scope than the dataset's, at the same image size).
    ///
    /// # Errors
    /// [`DataError::Invalid`] for another image size than the dataset camera's; I/O errors.
    pub fn write_camera(&self, camera: &endoloc_geometry::Camera) -> Result<(), DataError> {
        let c = &self.shared.camera;
        let ds = (c.width, c.height);
        if (camera.width, camera.height) != ds {
            return Err(DataError::invalid(
                self.final_dir.join(crate::SEQUENCE_CAMERA_FILE),
                format!(
                    "a {}x{} camera; expected the dataset's image size, {}x{}",
                    camera.width, camera.height, ds.0, ds.1
                ),
            ));
        }
        super::meta::write_sequence_camera(&self.dir, camera)
            .map_err(|e| e.relocated(&self.dir, &self.final_dir))
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
        let n = poses.len();
        self.check_frames(n, "poses")?;
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

    /// Completes a pass recorded without poses: writes [`FRAME_TIMES_FILE`] (each image's time,
    /// seconds, same order) in place of `poses.txt`. Such a pass can be localized, not trained
    /// on, mapped or evaluated.
    ///
    /// # Errors
    /// As [`SequenceWriter::finish`], with `times` for the poses; [`DataError::Invalid`] when
    /// the times are not finite and strictly increasing.
    pub fn finish_unposed(self, times: &[f64]) -> Result<(), DataError> {
        self.check_frames(times.len(), "frame times")?;
        write_frame_times(&self.dir.join(FRAME_TIMES_FILE), times)
            .map_err(|e| e.relocated(&self.dir, &self.final_dir))?;
        sync_dir(&self.dir);
        lock(&self.shared.sequences).insert(self.name.clone(), true);
        Ok(())
    }

    /// Checks that the images written are exactly frames `0..n` (`what` names what gave `n`),
    /// with depth for all of them or none.
    fn check_frames(&self, n: usize, what: &str) -> Result<(), DataError> {
        let frames = std::mem::take(&mut *lock(&self.frames));
        let images_dir = self.final_dir.join(IMAGES_DIR);
        if frames.images.len() != n {
            return Err(DataError::invalid(
                &images_dir,
                format!(
                    "{} images written but {n} {what} given; expected one image per frame",
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
        Ok(())
    }
}
