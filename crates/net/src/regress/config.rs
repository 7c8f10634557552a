//! Settings of a regression training run: the optimisation schedule ([`RegressSchedule`])
//! and everything else that determines it ([`RegressConfig`], saved in `regress.toml`).

use crate::NetError;
use crate::augment::AugmentConfig;
use crate::backbone::BackboneConfig;
use crate::optimise::cosine_learning_rate;
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
    /// uniform in `±roll_deg` degrees, image and label alike ([`crate::view`]). 0 disables it.
    pub roll_deg: f32,
    /// View augmentation, tilt: pitch and yaw each uniform in `±tilt_deg` degrees. Needs the
    /// training camera ([`TrainingSet::camera`](super::TrainingSet::camera)); skipped with a
    /// warning without one.
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
