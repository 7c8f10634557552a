//! The learning baselines of the paper's Table I: absolute pose regression ([`posenet`],
//! Kendall et al. 2015) and relative pose regression from a retrieved reference image
//! ([`offsetnet`], Sganga et al. 2018), on the same backbone as the Siamese zone classifier
//! ([`crate::backbone`]) and the same preprocessing ([`crate::preprocess`]).
//!
//! Both networks put a small head on the backbone's descriptor: the unit-length descriptor
//! of [`crate::backbone::EmbeddingNet`] is multiplied by `√dim` (entries of order 1), then
//! `Linear(·, hidden) → ReLU → {Linear(hidden, 3) position, Linear(hidden, 4) quaternion}`.
//!
//! Targets are normalised ([`normalize::PoseNormalizer`]): positions have the training mean
//! subtracted and are divided by the RMS distance of the training positions from that mean;
//! rotations are expressed relative to a reference rotation (the chordal mean of the training
//! rotations) and their quaternions canonicalised to `w ≥ 0` — the q/−q ambiguity is resolved
//! by putting every training target in the hemisphere of the reference, so the hemisphere's
//! edge lies as far as possible from the training orientations.
//!
//! Geometric augmentation changes the pose an image shows, so only the photometric part of
//! [`crate::augment`] is used, plus a *view* augmentation with the label corrected exactly
//! ([`view`]): the camera turned about its own centre by `ΔR` (a roll about the optical axis,
//! and with known intrinsics a small pitch and yaw) sees the image warped by the homography
//! `K ΔRᵀ K⁻¹`, and its rotation label becomes `R_wc · ΔR`. The test pass through a colon
//! differs from the training pass by such turns (gaze, roll) and a small lateral offset.
//!
//! A trained model is one folder ([`io`]): `regress.toml` (what it is, its config, the
//! normaliser, the training image size) and `weights.safetensors`, written to `DIR.partial`
//! and renamed into place.

mod batch;
mod fit;
pub mod io;
pub mod loss;
pub mod normalize;
pub mod offsetnet;
pub mod posenet;
pub mod view;

pub use fit::RegressNetwork;
pub use io::{RegressMethod, RegressModelFile};
pub use loss::{posenet_loss, posenet_loss_sample};
pub use normalize::PoseNormalizer;
pub use offsetnet::{OffsetNetModel, compose, offset_between, train_offsetnet};
pub use posenet::{PoseNetModel, train_posenet};

use crate::NetError;
use crate::augment::AugmentConfig;
use crate::backbone::BackboneConfig;
use crate::optimise::cosine_learning_rate;
use crate::preprocess::InputSize;
use crate::train::ImageCache;
use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use endoloc_data::Sequence;
use endoloc_geometry::{Camera, Pose};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Optimisation schedule of a regression network.
///
/// A *sample* is one image for PoseNet and one (reference, query) pair for OffsetNet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RegressSchedule {
    /// Number of epochs.
    pub epochs: usize,
    /// Samples per epoch.
    pub samples_per_epoch: usize,
    /// Samples per optimisation step.
    pub batch: usize,
    /// Adam learning rate at the start.
    pub learning_rate: f64,
    /// Learning rate at the end (cosine decay); equal to `learning_rate` for a constant rate.
    pub final_learning_rate: f64,
}

impl Default for RegressSchedule {
    fn default() -> Self {
        RegressSchedule::fast()
    }
}

impl RegressSchedule {
    /// The CPU default: 40 epochs of 1024 samples, batch 32 (32 steps per epoch, 1280 steps),
    /// Adam 0.001 decaying to 0.00002 (cosine). About 41 k images through the backbone for
    /// PoseNet, twice that for OffsetNet (two images per sample).
    pub fn fast() -> Self {
        RegressSchedule {
            epochs: 40,
            samples_per_epoch: 1024,
            batch: 32,
            learning_rate: 1e-3,
            final_learning_rate: 2e-5,
        }
    }

    /// The Siamese network's paper schedule applied to regression (the paper does not give
    /// its baselines' schedules): 500 epochs of 256 samples, batch 128, Adam with a constant
    /// learning rate of 0.001.
    pub fn paper() -> Self {
        RegressSchedule {
            epochs: 500,
            samples_per_epoch: 256,
            batch: 128,
            learning_rate: 1e-3,
            final_learning_rate: 1e-3,
        }
    }

    /// The preset named `fast` (or `default`) or `paper`.
    ///
    /// # Errors
    /// [`NetError::Config`] for another name.
    pub fn from_name(name: &str) -> Result<Self, NetError> {
        match name.trim().to_ascii_lowercase().as_str() {
            "fast" | "default" => Ok(RegressSchedule::fast()),
            "paper" => Ok(RegressSchedule::paper()),
            other => Err(NetError::Config(format!(
                "unknown schedule {other:?}; expected fast or paper"
            ))),
        }
    }

    /// Optimisation steps per epoch.
    pub fn steps_per_epoch(&self) -> usize {
        self.samples_per_epoch.div_ceil(self.batch.max(1)).max(1)
    }

    /// Learning rate at `step` of `total` (cosine from `learning_rate` to
    /// `final_learning_rate`).
    pub fn learning_rate_at(&self, step: usize, total: usize) -> f64 {
        cosine_learning_rate(self.learning_rate, self.final_learning_rate, step, total)
    }
}

/// Everything that determines a PoseNet or OffsetNet training run (saved in `regress.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RegressConfig {
    /// Backbone (the same as the zone classifier's by default).
    pub backbone: BackboneConfig,
    /// Optimisation schedule.
    pub schedule: RegressSchedule,
    /// Kendall's β: weight of the quaternion term against the position term. Positions are
    /// normalised (see the module documentation), so both terms are of order 1 and β = 1
    /// weighs an error of one position scale (the RMS radius of the training positions,
    /// ~hundreds of mm) like a quaternion error of 1 (~60°); larger β favours orientation.
    pub beta: f32,
    /// Hidden units of the regression head.
    pub hidden: usize,
    /// Photometric augmentation of the query images; its geometric fields (`rotation_deg`,
    /// `scale`, `translate`) are ignored because they would change the pose the image shows.
    pub augment: AugmentConfig,
    /// View augmentation, roll: the query camera turns about its optical axis by an angle
    /// uniform in `±roll_deg` degrees, image and label alike ([`view`]). 0 disables it.
    pub roll_deg: f32,
    /// View augmentation, tilt: pitch and yaw each uniform in `±tilt_deg` degrees. Needs the
    /// training camera ([`TrainingSet::camera`]); skipped with a warning without one.
    pub tilt_deg: f32,
    /// OffsetNet: training pairs are (frame i, frame j) with `|i − j| ≤ pair_reach_frames`
    /// along the training trajectory.
    pub pair_reach_frames: usize,
    /// Hold out every `holdout_every`-th training frame (0: none) and report its pose errors
    /// every `validate_every_epochs` epochs (OffsetNet: the reference is the nearest
    /// non-held-out frame along the trajectory).
    pub holdout_every: usize,
    /// Validate every this many epochs (and after the last), when frames are held out.
    pub validate_every_epochs: usize,
    /// Seed of every random step (weights, batches, augmentation).
    pub seed: u64,
    /// Images per forward pass at inference and validation.
    pub inference_batch: usize,
    /// Compute device: `cpu`, `cuda`, `wgpu` or `auto` ([`crate::device::from_name`]).
    pub device: String,
    /// Start the backbone from these weights (a zone model's `weights.safetensors`, written by
    /// [`crate::model::save_weights`]) instead of a random initialisation.
    pub init_backbone: Option<PathBuf>,
}

impl Default for RegressConfig {
    fn default() -> Self {
        RegressConfig {
            backbone: BackboneConfig::compact_low_res(),
            schedule: RegressSchedule::fast(),
            beta: 1.0,
            hidden: 256,
            augment: AugmentConfig {
                rotation_deg: 0.0,
                scale: 0.0,
                translate: 0.0,
                ..AugmentConfig::default()
            },
            roll_deg: 20.0,
            tilt_deg: 8.0,
            pair_reach_frames: 40,
            holdout_every: 0,
            validate_every_epochs: 10,
            seed: 0,
            inference_batch: 64,
            device: "cpu".into(),
            init_backbone: None,
        }
    }
}

impl RegressConfig {
    /// The default with the [`RegressSchedule::paper`] schedule.
    pub fn paper() -> Self {
        RegressConfig {
            schedule: RegressSchedule::paper(),
            ..RegressConfig::default()
        }
    }

    /// Checks the values.
    ///
    /// # Errors
    /// [`NetError::Config`] naming the first bad value.
    pub fn validate(&self) -> Result<(), NetError> {
        self.backbone.validate()?;
        let s = &self.schedule;
        if s.epochs == 0 || s.samples_per_epoch == 0 || s.batch < 2 {
            return Err(NetError::Config(format!(
                "schedule: epochs {} ≥ 1, samples_per_epoch {} ≥ 1 and batch {} ≥ 2 expected",
                s.epochs, s.samples_per_epoch, s.batch
            )));
        }
        let positive = |v: f64| v > 0.0 && v.is_finite();
        if !positive(s.learning_rate) || !positive(s.final_learning_rate) {
            return Err(NetError::Config("learning rates must be positive".into()));
        }
        if !(self.beta >= 0.0 && self.beta.is_finite()) {
            return Err(NetError::Config(format!(
                "beta {} must be finite and ≥ 0",
                self.beta
            )));
        }
        if self.hidden == 0 || self.hidden > 65536 {
            return Err(NetError::Config(format!(
                "hidden {} must be in 1..=65536",
                self.hidden
            )));
        }
        if !(0.0..=180.0).contains(&self.roll_deg) {
            return Err(NetError::Config(format!(
                "roll_deg {} must be in [0, 180]",
                self.roll_deg
            )));
        }
        if !(0.0..=45.0).contains(&self.tilt_deg) {
            return Err(NetError::Config(format!(
                "tilt_deg {} must be in [0, 45]",
                self.tilt_deg
            )));
        }
        if self.inference_batch == 0 {
            return Err(NetError::Config(
                "inference_batch must be at least 1".into(),
            ));
        }
        Ok(())
    }

    /// The photometric part of [`RegressConfig::augment`] (geometric fields zeroed).
    pub(crate) fn photometric(&self) -> AugmentConfig {
        AugmentConfig {
            rotation_deg: 0.0,
            tilt_deg: 0.0,
            scale: 0.0,
            translate: 0.0,
            ..self.augment.clone()
        }
    }
}

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

/// What a regression training run is doing, for progress display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegressPhase {
    /// Optimising.
    Training,
    /// Computing held-out errors.
    Validating,
}

/// A progress report from [`train_posenet`] / [`train_offsetnet`].
#[derive(Debug, Clone, PartialEq)]
pub struct RegressProgress {
    /// Current phase.
    pub phase: RegressPhase,
    /// Steps done.
    pub done: usize,
    /// Steps in the run.
    pub total: usize,
    /// Current epoch (1-based).
    pub epoch: usize,
    /// Mean loss of the last finished epoch.
    pub loss: Option<f32>,
}

/// One epoch of a regression training history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RegressEpoch {
    /// 1-based epoch.
    pub epoch: usize,
    /// Mean loss over the epoch's steps (normalised units, see [`posenet_loss`]).
    pub loss: f32,
    /// Mean position error of the held-out frames, mm (when validated this epoch).
    pub val_position_mm: Option<f64>,
    /// Mean orientation error of the held-out frames, degrees.
    pub val_orientation_deg: Option<f64>,
    /// Wall-clock seconds since the start of training.
    pub elapsed_s: f64,
}

/// The regression head on a backbone descriptor (see the module documentation).
#[derive(Module, Debug)]
pub struct PoseHead {
    /// Features → hidden.
    pub fc: Linear,
    /// Hidden → 3 (normalised position or translation).
    pub position: Linear,
    /// Hidden → 4 (quaternion `x y z w`, before normalisation; identity added).
    pub rotation: Linear,
}

impl PoseHead {
    pub(crate) fn new(features: usize, hidden: usize, device: &Device) -> Self {
        PoseHead {
            fc: LinearConfig::new(features, hidden).init(device),
            position: LinearConfig::new(hidden, 3).init(device),
            rotation: LinearConfig::new(hidden, 4).init(device),
        }
    }

    /// Position and raw quaternion of a batch of features; the quaternion output is the
    /// layer's output plus the identity `(0, 0, 0, 1)`, so an untrained head predicts rotations
    /// near the reference.
    ///
    /// # Shapes
    /// `[b, features]` → (`[b, 3]`, `[b, 4]`)
    pub fn forward(&self, features: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
        let b = features.dims()[0];
        let device = features.device();
        let h = relu(self.fc.forward(features));
        let p = self.position.forward(h.clone());
        let mut id = vec![0f32; b * 4];
        for row in id.chunks_exact_mut(4) {
            row[3] = 1.0;
        }
        let id = Tensor::<2>::from_data(TensorData::new(id, [b, 4]), &device);
        (p, self.rotation.forward(h) + id)
    }
}

/// Descriptor scaled to entries of order 1: `descriptor · √dim`.
pub(crate) fn scaled_features(desc: Tensor<2>) -> Tensor<2> {
    let d = desc.dims()[1].max(1) as f32;
    desc.mul_scalar(d.sqrt())
}

/// Reads a `[rows, cols]` tensor back as `f32` rows.
pub(crate) fn tensor_rows(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_into_vec::<f32>().unwrap_or_default()
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
