//! The settings of a Siamese training run ([`TrainConfig`], saved in `model.toml` and
//! `pretrain.toml`): the optimisation [`Schedule`], the [`ValidationConfig`] and the defaults.
//!
//! Schedules: [`Schedule::paper`] is the paper's (128 + 128 pairs per epoch, 500 epochs,
//! Adam, lr 0.001, batch 128 pairs, every pair with its own two images);
//! [`Schedule::fast`] is the CPU default (see its doc for the numbers).

use crate::NetError;
use crate::augment::AugmentConfig;
use crate::backbone::BackboneConfig;
use crate::database::ScoreRule;
use crate::loss::DEFAULT_MARGIN;
use crate::optimise::cosine_learning_rate;
use crate::pairs::PairRule;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Optimisation schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Schedule {
    /// Number of epochs.
    pub epochs: usize,
    /// Pairs per epoch (half positive, half negative).
    pub pairs_per_epoch: usize,
    /// Pairs per optimisation step.
    pub batch_pairs: usize,
    /// Adam learning rate at the start.
    pub learning_rate: f64,
    /// Learning rate at the end (cosine decay); equal to `learning_rate` for a constant rate.
    pub final_learning_rate: f64,
    /// Share images between pairs ([`crate::pairs`]): half the images per pair.
    pub share_images: bool,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule::fast()
    }
}

impl Schedule {
    /// The paper's schedule: 500 epochs of 128 positive + 128 negative pairs, batch 128
    /// pairs (2 steps per epoch), Adam with a constant learning rate of 0.001, independent
    /// pairs (256 images per step).
    pub fn paper() -> Self {
        Schedule {
            epochs: 500,
            pairs_per_epoch: 256,
            batch_pairs: 128,
            learning_rate: 1e-3,
            final_learning_rate: 1e-3,
            share_images: false,
        }
    }

    /// The CPU default: 150 epochs of 128 + 128 pairs, batch 64 pairs over 66 shared images
    /// (4 steps per epoch, 600 steps, ~40 k images through the network), Adam 0.001 decaying
    /// to 0.0001 (cosine).
    pub fn fast() -> Self {
        Schedule {
            epochs: 150,
            pairs_per_epoch: 256,
            batch_pairs: 64,
            learning_rate: 1e-3,
            final_learning_rate: 1e-4,
            share_images: true,
        }
    }

    /// The preset named `fast` or `paper`.
    ///
    /// # Errors
    /// [`NetError::Config`] for another name.
    pub fn from_name(name: &str) -> Result<Self, NetError> {
        match name.trim().to_ascii_lowercase().as_str() {
            "fast" | "default" => Ok(Schedule::fast()),
            "paper" => Ok(Schedule::paper()),
            other => Err(NetError::Config(format!(
                "unknown schedule {other:?}; expected fast or paper"
            ))),
        }
    }

    /// Optimisation steps per epoch.
    pub fn steps_per_epoch(&self) -> usize {
        self.pairs_per_epoch
            .div_ceil(self.batch_pairs.max(1))
            .max(1)
    }

    /// Learning rate at `step` of `total` (cosine from `learning_rate` to
    /// `final_learning_rate`).
    pub fn learning_rate_at(&self, step: usize, total: usize) -> f64 {
        cosine_learning_rate(self.learning_rate, self.final_learning_rate, step, total)
    }
}

/// Validation during training: held-out training frames classified against the others.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ValidationConfig {
    /// Hold out every `holdout_every`-th training frame from the pairs (0: none, and no
    /// validation). The final database still holds every frame.
    pub holdout_every: usize,
    /// Validate every this many epochs (and after the last).
    pub every_epochs: usize,
    /// At most this many database frames (evenly spaced) during validation, for speed.
    pub max_database_frames: usize,
    /// Validate on this other sequence (a folder with images/ and poses.txt, e.g. a second
    /// pass through the same colon) instead of held-out training frames; truth zones come from
    /// its poses ([`ZoneTable::truth_zone`](crate::zones::ZoneTable::truth_zone)). For
    /// monitoring only: nothing is selected by it.
    pub sequence: Option<PathBuf>,
    /// At most this many frames of `sequence` (evenly spaced).
    pub max_queries: usize,
}

impl Default for ValidationConfig {
    fn default() -> Self {
        ValidationConfig {
            holdout_every: 10,
            every_epochs: 25,
            max_database_frames: 1200,
            sequence: None,
            max_queries: 400,
        }
    }
}

/// Everything that determines a training run (saved in `model.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// Backbone.
    pub backbone: BackboneConfig,
    /// Optimisation schedule.
    pub schedule: Schedule,
    /// Contrastive-loss margin (unit descriptors: distances in `[0, 2]`).
    pub margin: f32,
    /// Fraction of negative pairs drawn from nearby zones (default 0: zones drawn uniformly,
    /// as in the paper). Measured on the simulator's `paper` preset (50 zones, test pass):
    /// 0.5 gives 50.9 % exact / 65.8 % within ±1 zone per frame and 53.4 / 72.1 % with the
    /// forward filter; 0 gives 53.4 / 74.0 % and 59.2 / 85.5 %. Pushing neighbouring zones
    /// apart teaches cues of the training pass that a second pass does not share.
    pub hard_negative_fraction: f32,
    /// "Nearby" for hard negatives: at most this many zones apart.
    pub hard_negative_reach: usize,
    /// Which pairs to draw: the paper's zone pairs (default) or pairs by distance along the
    /// training pass ([`PairRule::Track`]; the hard-negative settings then do not apply).
    pub pairs: PairRule,
    /// Augmentation.
    pub augment: AugmentConfig,
    /// Seed of every random step (weights, pairs, augmentation).
    pub seed: u64,
    /// Validation.
    pub validation: ValidationConfig,
    /// Write a checkpoint every this many epochs (0: only at the end).
    pub checkpoint_every_epochs: usize,
    /// Zone look-up rule stored with the model.
    pub score: ScoreRule,
    /// Images per forward pass when computing descriptors.
    pub inference_batch: usize,
    /// Compute device: `cpu`, `cuda`, `wgpu` or `auto` ([`crate::device::from_name`]).
    pub device: String,
    /// Start from these weights (safetensors or a PyTorch state dict, [`crate::pretrained`])
    /// instead of a random initialisation.
    pub pretrained: Option<PathBuf>,
    /// Further passes through the same colon (sequence folders with poses in the training
    /// sequence's world frame, same camera). Each of their frames joins the zone of its
    /// nearest training pose
    /// ([`ZoneTable::truth_zone`](crate::zones::ZoneTable::truth_zone)), so that positive
    /// pairs also join views of one place from different passes — the variation a test pass
    /// brings. Zones, the descriptor database and maps stay those of the training sequence.
    pub extra_sequences: Vec<PathBuf>,
    /// Power of the partial PCA whitening learnt from the database at the end
    /// ([`crate::whiten`]; 0: none, the network's descriptors as they are). Default ¼.
    pub whitening: f32,
    /// Database rows smoothed along the training pass over ± this camera path length, mm,
    /// after the whitening ([`crate::database::smooth_along_pass`]; 0: none). Default 2.2.
    pub database_smoothing_mm: f64,
    /// Zoom-blurred views of every training frame added to the database, one row per
    /// amplitude: the frame averaged over magnifications in `1 ± a` about the principal point
    /// ([`crate::zoom_blur`]), the motion blur of a scope moving along its axis, so that a
    /// blurred test frame finds its place among views that look like it. Whitened with the
    /// sharp rows' whitening and smoothed along the pass as they are; a row's frame is its
    /// training frame. Empty (the default): the sharp rows alone.
    /// [`ZOOM_BLUR_AMPLITUDES`] are the amplitudes measured.
    pub index_zoom_blur: Vec<f64>,
    /// Added to a zoom-blurred view's distance when the zone of a test descriptor is looked
    /// up, descriptor units ([`DescriptorDatabase::view_penalty`](crate::DescriptorDatabase::view_penalty)):
    /// a view wins over the sharp rows only when it is that much nearer, so that a sharp
    /// frame seldom lands on a blurred view of a far zone. Without views it does nothing.
    /// Default [`DEFAULT_INDEX_VIEW_PENALTY`] (0: none; what 0.07 trades is said there).
    pub index_view_penalty: f64,
}

/// Default [`TrainConfig::database_smoothing_mm`], about ±4 frames of the `paper` preset:
/// chosen on a second pass of its colon among 1.0, 1.6, 2.2 and 3.0 mm.
pub const DEFAULT_DATABASE_SMOOTHING_MM: f64 = 2.2;

/// Default [`TrainConfig::index_view_penalty`]: none, a view counts as its frame. A penalty
/// trades what the views gain under a blurring scope for what they cost on a sharp one: with
/// views at 0.03, 0.06 and 0.12, 0.07 brings the `paper` preset's nine benchmark colons
/// (unchanged passes, per frame) from 22,582 to 22,615 refined frames (22,625 without views)
/// and their mean error from 1.93 to 1.61 mm (1.51), while on the six `small` colons of the
/// change study the median along-the-colon error of every frame under all of `moderate` grows
/// from 23.8 to 28.6 mm (50.9 without views); refined frames stay within a few of each other.
pub const DEFAULT_INDEX_VIEW_PENALTY: f64 = 0.0;

/// Amplitudes for [`TrainConfig::index_zoom_blur`] (`train --index-zoom-blur 0.03,0.06,0.12`;
/// not the default). Over five procedural colons and the CT colon (`small` preset,
/// `builtin-joint`, 50 zones), the network's own zone per frame within ±1 of the truth's: a
/// test pass through a `moderate` motion-blurred scope 68.3 → 77.8 %, every `moderate` look
/// and scope change 38.9 → 52.2 %, the unchanged pass 86.4 → 86.3 %. On the `paper` preset's
/// unchanged passes a sharp frame now and then finds a blurred view of a far zone nearest
/// (per frame over the benchmark's nine colons 43 fewer of 23,427 frames refined; live the
/// same frames), which is why the views are not on by default (docs/RESULTS.md).
pub const ZOOM_BLUR_AMPLITUDES: [f64; 3] = [0.03, 0.06, 0.12];

/// Default [`TrainConfig::whitening`]: chosen on a second pass of the simulator's `paper`
/// colon (¼ and ⅕ within 1 point; ½ loses 20).
pub const DEFAULT_WHITENING: f32 = 0.25;

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            backbone: BackboneConfig::default(),
            schedule: Schedule::fast(),
            margin: DEFAULT_MARGIN,
            hard_negative_fraction: 0.0,
            hard_negative_reach: 2,
            pairs: PairRule::Zone,
            augment: AugmentConfig::default(),
            seed: 0,
            validation: ValidationConfig::default(),
            checkpoint_every_epochs: 10,
            score: ScoreRule::Nearest,
            inference_batch: 64,
            device: "cpu".into(),
            pretrained: None,
            extra_sequences: Vec::new(),
            whitening: DEFAULT_WHITENING,
            database_smoothing_mm: DEFAULT_DATABASE_SMOOTHING_MM,
            index_zoom_blur: Vec::new(),
            index_view_penalty: DEFAULT_INDEX_VIEW_PENALTY,
        }
    }
}

impl TrainConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`NetError::Config`] naming the first bad value.
    pub fn validate(&self) -> Result<(), NetError> {
        self.backbone.validate()?;
        let s = &self.schedule;
        if s.pairs_per_epoch < 2 || s.batch_pairs < 2 {
            return Err(NetError::Config(format!(
                "schedule: pairs_per_epoch {} ≥ 2 and batch_pairs {} ≥ 2 expected",
                s.pairs_per_epoch, s.batch_pairs
            )));
        }
        if s.epochs == 0 && self.pretrained.is_none() {
            return Err(NetError::Config(
                "schedule: 0 epochs (no optimisation, only the database) needs start weights \
                 (pretrained); from random weights train at least one epoch"
                    .into(),
            ));
        }
        if !(s.learning_rate > 0.0 && s.final_learning_rate > 0.0) {
            return Err(NetError::Config("learning rates must be positive".into()));
        }
        if self.margin.is_nan() || self.margin <= 0.0 {
            return Err(NetError::Config(format!(
                "margin {} must be positive",
                self.margin
            )));
        }
        if self.inference_batch == 0 {
            return Err(NetError::Config(
                "inference_batch must be at least 1".into(),
            ));
        }
        self.pairs.validate()?;
        if !(self.database_smoothing_mm >= 0.0 && self.database_smoothing_mm.is_finite()) {
            return Err(NetError::Config(format!(
                "database_smoothing_mm {} must be 0 (none) or a positive length",
                self.database_smoothing_mm
            )));
        }
        if let Some(a) = self
            .index_zoom_blur
            .iter()
            .find(|a| !(**a > 0.0 && **a <= 0.5))
        {
            return Err(NetError::Config(format!(
                "index_zoom_blur: amplitude {a} must be in (0, 0.5] (a magnification of 1 ± a)"
            )));
        }
        if !(self.index_view_penalty >= 0.0 && self.index_view_penalty.is_finite()) {
            return Err(NetError::Config(format!(
                "index_view_penalty {} must be 0 or a positive distance",
                self.index_view_penalty
            )));
        }
        if !(self.whitening == 0.0 || (self.whitening > 0.0 && self.whitening <= 0.5)) {
            return Err(NetError::Config(format!(
                "whitening {} must be 0 (none) or in (0, 0.5]",
                self.whitening
            )));
        }
        if !(0.0..=45.0).contains(&self.augment.tilt_deg) {
            return Err(NetError::Config(format!(
                "augment.tilt_deg {} must be in [0, 45] degrees",
                self.augment.tilt_deg
            )));
        }
        Ok(())
    }
}
