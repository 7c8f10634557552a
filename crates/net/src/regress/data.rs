//! Training data of the regression networks ([`TrainingSet`]: resized images and their
//! poses) and the size check of test frames.

use super::config::RegressConfig;
use crate::NetError;
use crate::preprocess::InputSize;
use crate::train::ImageCache;
use crate::view;
use endoloc_data::Sequence;
use endoloc_geometry::{Camera, Pose};
use std::path::PathBuf;

/// Training images (resized once to the network input) with their poses.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingSet {
    /// The images at the backbone's input size, values in `[0, 1]`.
    pub images: ImageCache,
    /// `T_wc` of each image, mm.
    pub poses: Vec<Pose>,
    /// Size of the original frames, pixels (test frames must have it).
    pub frame_width: u32,
    /// Height of the original frames, pixels.
    pub frame_height: u32,
    /// The camera of the frames (needed for tilt augmentation).
    pub camera: Option<Camera>,
}

impl TrainingSet {
    /// Loads every frame of `seq` (taken with `camera`) at `size` (in parallel), with its
    /// pose.
    ///
    /// # Errors
    /// [`NetError::Data`] for the first unreadable image; [`NetError::Config`] for an empty
    /// sequence; [`NetError::Image`] when the frames are not of the camera's size.
    pub fn from_sequence(
        seq: &Sequence,
        camera: &Camera,
        size: InputSize,
        progress: &mut dyn FnMut(usize),
    ) -> Result<Self, NetError> {
        if seq.is_empty() {
            return Err(NetError::Config(format!(
                "{}: the sequence has no frames",
                seq.dir.display()
            )));
        }
        let first = seq.load_gray(0)?;
        if first.dimensions() != (camera.width, camera.height) {
            return Err(NetError::Image {
                path: seq.image_paths.first().cloned().unwrap_or_default(),
                message: format!(
                    "{}x{} pixels but the camera is {}x{}",
                    first.width(),
                    first.height(),
                    camera.width,
                    camera.height
                ),
            });
        }
        let images = ImageCache::from_sequence(seq, size, progress)?;
        Ok(TrainingSet {
            images,
            poses: seq.poses.iter().map(|p| p.pose).collect(),
            frame_width: first.width(),
            frame_height: first.height(),
            camera: Some(*camera),
        })
    }

    /// A training set of in-memory grey frames (all of one size) and their poses, with the
    /// camera when known.
    ///
    /// # Errors
    /// [`NetError::Config`] when the counts differ or there are no frames;
    /// [`NetError::Image`] for a frame of another size than the first.
    pub fn from_images(
        frames: &[image::GrayImage],
        poses: &[Pose],
        camera: Option<&Camera>,
        size: InputSize,
    ) -> Result<Self, NetError> {
        let Some(first) = frames.first() else {
            return Err(NetError::Config("no training frames".into()));
        };
        if frames.len() != poses.len() {
            return Err(NetError::Config(format!(
                "{} frames but {} poses",
                frames.len(),
                poses.len()
            )));
        }
        let (w, h) = first.dimensions();
        let mut resized = Vec::with_capacity(frames.len());
        for (i, f) in frames.iter().enumerate() {
            if f.dimensions() != (w, h) || w == 0 || h == 0 {
                return Err(NetError::Image {
                    path: PathBuf::from(format!("training frame {i}")),
                    message: format!(
                        "{}x{} pixels, expected {w}x{h} like the first frame",
                        f.width(),
                        f.height()
                    ),
                });
            }
            resized.push(crate::preprocess::resize_area(
                f.as_raw(),
                w as usize,
                h as usize,
                size,
            ));
        }
        Ok(TrainingSet {
            images: ImageCache::from_images(size, resized),
            poses: poses.to_vec(),
            frame_width: w,
            frame_height: h,
            camera: camera.copied(),
        })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether there are no frames.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// Intrinsics of the cached images for view augmentation (`None` without a camera or for
    /// a camera of another size than the frames).
    pub(crate) fn view_intrinsics(&self) -> Option<view::ViewIntrinsics> {
        let c = self.camera.as_ref()?;
        if (c.width, c.height) != (self.frame_width, self.frame_height) {
            return None;
        }
        Some(view::ViewIntrinsics::resized(
            c,
            self.images.size.width,
            self.images.size.height,
        ))
    }

    pub(crate) fn check(&self, cfg: &RegressConfig, min_frames: usize) -> Result<(), NetError> {
        if cfg.tilt_deg > 0.0 && self.view_intrinsics().is_none() {
            tracing::warn!(
                "no camera of the training frames' size: tilt augmentation (tilt_deg {}) skipped",
                cfg.tilt_deg
            );
        }
        if self.images.len() != self.poses.len() {
            return Err(NetError::Config(format!(
                "{} cached images but {} poses",
                self.images.len(),
                self.poses.len()
            )));
        }
        if self.len() < min_frames {
            return Err(NetError::Config(format!(
                "{} training frames; at least {min_frames} needed",
                self.len()
            )));
        }
        if self.images.size != cfg.backbone.input() {
            return Err(NetError::Config(format!(
                "images cached at {} but the backbone takes {}",
                self.images.size,
                cfg.backbone.input()
            )));
        }
        if let Some((i, _)) = self.poses.iter().enumerate().find(|(_, p)| {
            !(p.translation.vector.iter().all(|v| v.is_finite())
                && p.rotation.coords.iter().all(|v| v.is_finite()))
        }) {
            return Err(NetError::Config(format!("training pose {i} is not finite")));
        }
        Ok(())
    }
}

/// Checks that a test frame has the training frames' size.
pub(crate) fn check_frame(
    img: &image::GrayImage,
    width: u32,
    height: u32,
    what: &str,
) -> Result<(), NetError> {
    if img.width() != width || img.height() != height {
        return Err(NetError::Image {
            path: PathBuf::from(what),
            message: format!(
                "{}x{} pixels but the model was trained on {width}x{height} frames",
                img.width(),
                img.height()
            ),
        });
    }
    Ok(())
}
