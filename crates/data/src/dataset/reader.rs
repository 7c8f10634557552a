//! Reading a dataset: its sequences, poses and labels in memory, images on demand.

use crate::png_io::{decode, decode_depth_mm};
use crate::sections_csv::read_sections;
use crate::trajectory::{StampedPose, read_frame_times, read_tum};
use crate::{DataError, Section};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::layout::{
    DEPTH_DIR, FRAME_TIMES_FILE, IMAGES_DIR, META_FILE, POSES_FILE, SECTIONS_FILE,
};
use super::mask::{black_outside, read_dataset_mask};
use super::meta::DatasetMeta;

/// A dataset opened for reading.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The dataset folder.
    pub root: PathBuf,
    /// The contents of `dataset.toml`.
    pub meta: DatasetMeta,
    /// Names of the sub-folders that hold a `poses.txt`, sorted.
    pub sequences: Vec<String>,
    /// Names of the passes without poses — sub-folders with a `frames.txt` and no
    /// `poses.txt` (a video imported without a pose log) — sorted. They can be localized
    /// ([`Sequence::open_frames`]), not trained on, mapped or evaluated.
    pub unposed: Vec<String>,
}

/// Sorted names of the visible sub-folders of `root` that contain `poses.txt`.
pub(crate) fn list_sequences(root: &Path) -> Result<Vec<String>, DataError> {
    list_subfolders_with(root, POSES_FILE)
}

/// Sorted names of the visible sub-folders of `root` that contain `frames.txt` and no
/// `poses.txt`: the passes without poses.
pub(crate) fn list_unposed(root: &Path) -> Result<Vec<String>, DataError> {
    let mut names = list_subfolders_with(root, FRAME_TIMES_FILE)?;
    names.retain(|n| !root.join(n).join(POSES_FILE).is_file());
    Ok(names)
}

/// Sorted names of the visible sub-folders of `root` that contain the file `file`.
fn list_subfolders_with(root: &Path, file: &str) -> Result<Vec<String>, DataError> {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(root).map_err(|e| DataError::io(root, e))? {
        let entry = entry.map_err(|e| DataError::io(root, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue;
        }
        let p = entry.path();
        if p.is_dir() && p.join(file).is_file() {
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
        let unposed = list_unposed(dir)?;
        Ok(Dataset {
            root: dir.to_path_buf(),
            meta,
            sequences,
            unposed,
        })
    }

    /// The mask file named by `[camera] mask`, when there is one.
    pub fn mask_path(&self) -> Option<PathBuf> {
        self.meta.mask.as_ref().map(|m| self.root.join(m))
    }

    /// The colon's mid-line file ([`MIDLINE_FILE`](crate::MIDLINE_FILE)), when the dataset
    /// has one (simulated datasets do).
    pub fn midline_path(&self) -> Option<PathBuf> {
        Some(self.root.join(crate::MIDLINE_FILE)).filter(|p| p.is_file())
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
        if self.unposed.iter().any(|s| s == name) {
            return Err(unposed_error(&self.root.join(name)));
        }
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
        Sequence::open_in(
            &self.root.join(name),
            Some((c.width, c.height)),
            mask,
            false,
        )
    }
}

/// The error for a pass without poses opened where poses are needed.
fn unposed_error(dir: &Path) -> DataError {
    DataError::invalid(
        dir,
        format!(
            "a pass without poses ({FRAME_TIMES_FILE}, no {POSES_FILE}: recorded without a pose log); \
             it can be localized, not trained on, mapped or evaluated"
        ),
    )
}

/// One sequence of a dataset, loaded lazily: poses and labels in memory, images on demand.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// Sequence (folder) name.
    pub name: String,
    /// Sequence folder.
    pub dir: PathBuf,
    /// Camera-to-world poses `T_wc` (mm), one per image; empty for a pass without poses
    /// (opened with [`Sequence::open_frames`]; its times are in `frame_times`).
    pub poses: Vec<StampedPose>,
    /// The frames' times (seconds) of a pass without poses (`frames.txt`); `None` for a
    /// posed sequence, whose times are its poses'.
    pub frame_times: Option<Vec<f64>>,
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
    /// See [`Dataset::sequence`]; [`DataError::Invalid`] for a pass without poses.
    pub fn open(dir: &Path) -> Result<Self, DataError> {
        Self::open_with(dir, false)
    }

    /// Loads the frames stored in folder `dir`, with or without poses: for what needs only
    /// the images and their times (localizing a pass). A pass without poses has an empty
    /// `poses` and its times in `frame_times`.
    ///
    /// # Errors
    /// See [`Dataset::sequence`]; errors from reading `frames.txt`.
    pub fn open_frames(dir: &Path) -> Result<Self, DataError> {
        Self::open_with(dir, true)
    }

    fn open_with(dir: &Path, unposed_ok: bool) -> Result<Self, DataError> {
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
        Self::open_in(dir, image_size, mask, unposed_ok)
    }

    /// [`Sequence::open`] with the camera's image size (`None`: unchecked) and the dataset's
    /// mask already known; a pass without poses is opened only when `unposed_ok`.
    fn open_in(
        dir: &Path,
        image_size: Option<(u32, u32)>,
        mask: Option<Arc<image::GrayImage>>,
        unposed_ok: bool,
    ) -> Result<Self, DataError> {
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let unposed = !dir.join(POSES_FILE).is_file() && dir.join(FRAME_TIMES_FILE).is_file();
        if unposed && !unposed_ok {
            return Err(unposed_error(dir));
        }
        let (poses, frame_times, listed) = if unposed {
            let times = read_frame_times(&dir.join(FRAME_TIMES_FILE))?;
            (Vec::new(), Some(times), ("times", FRAME_TIMES_FILE, "time"))
        } else {
            (
                read_tum(&dir.join(POSES_FILE))?,
                None,
                ("poses", POSES_FILE, "pose"),
            )
        };
        let images_dir = dir.join(IMAGES_DIR);
        let image_paths = list_pngs(&images_dir)?;
        let n = frame_times.as_ref().map_or(poses.len(), Vec::len);
        if image_paths.len() != n {
            return Err(DataError::invalid(
                &images_dir,
                format!(
                    "{} images but {n} {} in {}; expected one image per {} (run `endoloc dataset check`)",
                    image_paths.len(),
                    listed.0,
                    listed.1,
                    listed.2
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
            frame_times,
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
        self.frame_times.as_ref().map_or(self.poses.len(), Vec::len)
    }

    /// Whether the sequence has no frames.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether each frame has a pose (false for a pass opened with
    /// [`Sequence::open_frames`] that has none).
    pub fn is_posed(&self) -> bool {
        self.frame_times.is_none()
    }

    /// The frames' times, seconds, in frame order (the poses' time stamps, or `frames.txt`).
    pub fn timestamps(&self) -> Vec<f64> {
        match &self.frame_times {
            Some(t) => t.clone(),
            None => self.poses.iter().map(|p| p.timestamp_s).collect(),
        }
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
