//! Training images: decoded and resized once ([`ImageCache`]), further passes through the
//! same colon joined to them (`add_passes`), validation frames of another sequence
//! ([`ValidationSet`]), and descriptors of cached images ([`describe_cached`]).

use super::progress::{Phase, TrainProgress};
use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::preprocess::{InputSize, resize_area, standardize};
use crate::train_config::TrainConfig;
use crate::view::ViewIntrinsics;
use crate::zones::{TRUTH_ANGLE_WEIGHT_MM_PER_DEG, ZoneTable, nearest_frame};
use burn::tensor::{Device, Tensor, TensorData};
use endoloc_data::Sequence;
use endoloc_geometry::Camera;
use rayon::prelude::*;
use std::path::PathBuf;

/// Training images, resized once to the network input (values in `[0, 1]`, not standardised).
#[derive(Debug, Clone, PartialEq)]
pub struct ImageCache {
    /// Size of every image.
    pub size: InputSize,
    /// `count × width × height` values, row-major images one after the other.
    pub pixels: Vec<f32>,
    /// Pinhole model of the images at this size (for view augmentation), when known.
    pub view: Option<ViewIntrinsics>,
    /// Place of each image along the training pass (the training frame nearest to its pose),
    /// for [`PairRule::Track`](crate::pairs::PairRule::Track); empty when image `i` is
    /// training frame `i`.
    pub along: Vec<usize>,
}

impl ImageCache {
    /// Decodes and resizes every image of `seq` (in parallel).
    ///
    /// # Errors
    /// The first image that cannot be read ([`NetError::Data`]).
    pub fn from_sequence(
        seq: &Sequence,
        size: InputSize,
        progress: &mut dyn FnMut(usize),
    ) -> Result<Self, NetError> {
        let mut images = Vec::with_capacity(seq.len());
        let frames: Vec<usize> = (0..seq.len()).collect();
        for chunk in frames.chunks(64) {
            let part: Result<Vec<Vec<f32>>, NetError> = chunk
                .par_iter()
                .map(|&i| load_resized(seq, i, size))
                .collect();
            images.extend(part?);
            progress(images.len());
        }
        Ok(ImageCache::from_images(size, images))
    }

    /// A cache of already resized images (each `width × height` values in `[0, 1]`).
    pub fn from_images(size: InputSize, images: Vec<Vec<f32>>) -> Self {
        let mut pixels = Vec::with_capacity(images.len() * size.pixels());
        for im in images {
            pixels.extend(im);
        }
        ImageCache {
            size,
            pixels,
            view: None,
            along: Vec::new(),
        }
    }

    /// Number of images.
    pub fn len(&self) -> usize {
        self.pixels.len() / self.size.pixels().max(1)
    }

    /// Whether there are no images.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Place of image `i` along the training pass ([`ImageCache::along`]).
    pub fn along_of(&self, i: usize) -> usize {
        self.along.get(i).copied().unwrap_or(i)
    }

    /// Image `i`.
    pub fn image(&self, i: usize) -> &[f32] {
        let n = self.size.pixels();
        &self.pixels[i * n..(i + 1) * n]
    }
}

/// Descriptors (`frames.len() × dim`, row-major) of cached images through `net` (validation
/// mode, no augmentation).
pub fn describe_cached(
    net: &EmbeddingNet,
    device: &Device,
    cache: &ImageCache,
    frames: &[usize],
    batch: usize,
    progress: &mut dyn FnMut(usize),
) -> Vec<f32> {
    describe_cached_with(net, device, cache, frames, batch, <[f32]>::to_vec, progress)
}

/// [`describe_cached`] of the cached images changed by `change` (before standardisation).
pub(crate) fn describe_cached_with(
    net: &EmbeddingNet,
    device: &Device,
    cache: &ImageCache,
    frames: &[usize],
    batch: usize,
    change: impl Fn(&[f32]) -> Vec<f32> + Sync,
    progress: &mut dyn FnMut(usize),
) -> Vec<f32> {
    let size = cache.size;
    let mut out = Vec::new();
    for (k, chunk) in frames.chunks(batch.max(1)).enumerate() {
        let buf: Vec<f32> = chunk
            .par_iter()
            .flat_map_iter(|&f| {
                let mut v = change(cache.image(f));
                standardize(&mut v);
                v
            })
            .collect();
        out.extend(forward_values(net, device, buf, chunk.len(), size));
        progress((k * batch.max(1) + chunk.len()).min(frames.len()));
    }
    out
}

/// Runs a batch of standardised images through `net` and reads the descriptors back.
pub(crate) fn forward_values(
    net: &EmbeddingNet,
    device: &Device,
    buf: Vec<f32>,
    n: usize,
    size: InputSize,
) -> Vec<f32> {
    let x = Tensor::<4>::from_data(
        TensorData::new(buf, [n, 1, size.height as usize, size.width as usize]),
        device,
    );
    net.forward(x)
        .into_data()
        .try_into_vec::<f32>()
        .unwrap_or_default()
}

/// Validation frames from another sequence: resized images and their truth zones.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationSet {
    /// The images, resized to the network input.
    pub images: ImageCache,
    /// Truth zone of each image.
    pub truth: Vec<usize>,
}

impl ValidationSet {
    /// Loads up to `max` evenly spaced frames of `seq` with truth zones from their poses.
    ///
    /// # Errors
    /// [`NetError::Data`] for unreadable images.
    pub fn from_sequence(
        seq: &Sequence,
        zones: &ZoneTable,
        train_poses: &[endoloc_geometry::Pose],
        size: InputSize,
        max: usize,
    ) -> Result<Self, NetError> {
        let n = seq.len();
        let m = max.max(1).min(n);
        let frames: Vec<usize> = (0..m).map(|i| i * n / m).collect();
        let imgs: Result<Vec<Vec<f32>>, NetError> = frames
            .par_iter()
            .map(|&i| load_resized(seq, i, size))
            .collect();
        let poses: Vec<_> = frames.iter().map(|&i| seq.poses[i].pose).collect();
        let truth = zones
            .truth_zones(train_poses, &poses)
            .into_iter()
            .map(|t| t.unwrap_or(0))
            .collect();
        Ok(ValidationSet {
            images: ImageCache::from_images(size, imgs?),
            truth,
        })
    }
}

/// Appends the frames of further passes to `cache` and returns the zone table extended to
/// them (each extra frame takes the zone of its nearest pose of `seq`, and that pose's
/// frame as its place along the pass, [`ImageCache::along`]) and the number of frames taken
/// from each pass.
///
/// # Errors
/// [`NetError::Data`] for an unreadable sequence or image; [`NetError::Config`] for a pass
/// whose images do not have the camera's size.
pub(crate) fn add_passes(
    cache: &mut ImageCache,
    zones: &ZoneTable,
    seq: &Sequence,
    extra: &[PathBuf],
    camera: &Camera,
    progress: &mut dyn FnMut(&TrainProgress),
) -> Result<(ZoneTable, Vec<usize>), NetError> {
    let mut table = zones.clone();
    let mut counts = Vec::with_capacity(extra.len());
    let train_poses: Vec<endoloc_geometry::Pose> = seq.poses.iter().map(|p| p.pose).collect();
    for dir in extra {
        let pass = Sequence::open(dir)?;
        if pass.is_empty() {
            return Err(NetError::Config(format!(
                "extra pass {}: no frames",
                dir.display()
            )));
        }
        let first = pass.load_gray(0)?;
        if (first.width(), first.height()) != (camera.width, camera.height) {
            return Err(NetError::Config(format!(
                "extra pass {}: {} is {}x{}; the training camera is {}x{}",
                dir.display(),
                pass.image_paths[0].display(),
                first.width(),
                first.height(),
                camera.width,
                camera.height
            )));
        }
        let poses: Vec<endoloc_geometry::Pose> = pass.poses.iter().map(|p| p.pose).collect();
        let nearest: Vec<Option<usize>> = poses
            .par_iter()
            .map(|p| nearest_frame(&train_poses, p, TRUTH_ANGLE_WEIGHT_MM_PER_DEG))
            .collect();
        let total = pass.len();
        let images = ImageCache::from_sequence(&pass, cache.size, &mut |done| {
            progress(&TrainProgress::outside_training(
                Phase::LoadingImages,
                done,
                total,
            ))
        })?;
        let before = table.zone_of_frame.len();
        if cache.along.is_empty() {
            cache.along = (0..before).collect();
        }
        for (i, frame) in nearest.into_iter().enumerate() {
            if let Some(z) = frame.and_then(|f| zones.zone_of_frame.get(f).copied()) {
                cache.pixels.extend_from_slice(images.image(i));
                table.zone_of_frame.push(z);
                cache.along.extend(frame);
            }
        }
        counts.push(table.zone_of_frame.len() - before);
    }
    Ok((table, counts))
}

/// The images [`train`](super::train) fits on: every frame of `seq` (with the view model of
/// `camera` at the network input), then the frames of `cfg.extra_sequences` (`add_passes`).
/// Returns the cache, the zone table extended to the extra frames and the frames taken from
/// each extra pass.
///
/// # Errors
/// As [`ImageCache::from_sequence`] and `add_passes`.
pub(crate) fn load_training(
    cfg: &TrainConfig,
    seq: &Sequence,
    zones: &ZoneTable,
    camera: &Camera,
    progress: &mut dyn FnMut(&TrainProgress),
) -> Result<(ImageCache, ZoneTable, Vec<usize>), NetError> {
    let size = cfg.backbone.input();
    let total = seq.len();
    let mut cache = ImageCache::from_sequence(seq, size, &mut |done| {
        progress(&TrainProgress::outside_training(
            Phase::LoadingImages,
            done,
            total,
        ))
    })?;
    cache.view = Some(ViewIntrinsics::resized(camera, size.width, size.height));
    let (pass_zones, pass_frames) = add_passes(
        &mut cache,
        zones,
        seq,
        &cfg.extra_sequences,
        camera,
        progress,
    )?;
    Ok((cache, pass_zones, pass_frames))
}

/// The validation set of `cfg.validation.sequence`, if one is named: up to `max_queries` of
/// its frames, truth zones from the poses of the training sequence `seq`.
///
/// # Errors
/// [`NetError::Data`] for an unreadable sequence or image.
pub(crate) fn validation_set(
    cfg: &TrainConfig,
    seq: &Sequence,
    zones: &ZoneTable,
) -> Result<Option<ValidationSet>, NetError> {
    let Some(p) = &cfg.validation.sequence else {
        return Ok(None);
    };
    let vseq = Sequence::open(p)?;
    let train_poses: Vec<_> = seq.poses.iter().map(|p| p.pose).collect();
    Ok(Some(ValidationSet::from_sequence(
        &vseq,
        zones,
        &train_poses,
        cfg.backbone.input(),
        cfg.validation.max_queries,
    )?))
}

/// Frame `i` of `seq` as grey values resized (area average) to the network's input.
fn load_resized(seq: &Sequence, i: usize, size: InputSize) -> Result<Vec<f32>, NetError> {
    let g = seq.load_gray(i)?;
    Ok(resize_area(
        g.as_raw(),
        g.width() as usize,
        g.height() as usize,
        size,
    ))
}
