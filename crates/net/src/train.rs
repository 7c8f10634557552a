//! Training the Siamese network: twins sharing one backbone, the contrastive loss, balanced
//! pairs, Adam; checkpoints and resume; validation zone accuracy; the model folder.
//!
//! The loop (written out here rather than burn's TUI learner) per step: draw a [`PairBatch`],
//! augment and standardise its images, run them through the backbone as one batch (so the
//! twins share weights by construction), pick the two rows of every pair, take the
//! contrastive loss, back-propagate, Adam step. An *epoch* is `pairs_per_epoch` pairs.
//!
//! Schedules: [`Schedule::paper`] is the paper's (128 + 128 pairs per epoch, 500 epochs,
//! Adam, lr 0.001, batch 128 pairs, every pair with its own two images);
//! [`Schedule::fast`] is the CPU default (see its doc for the numbers).

use crate::NetError;
use crate::augment::{AugmentConfig, augment};
use crate::backbone::{BackboneConfig, EmbeddingNet};
use crate::database::{DescriptorDatabase, ScoreRule, smooth_along_pass};
use crate::loss::{DEFAULT_MARGIN, contrastive_loss};
use crate::model::{self, ModelConfig};
use crate::optimise::{cosine_learning_rate, descend};
use crate::pairs::{PairBatch, PairRule, PairSampler};
use crate::preprocess::{InputSize, resize_area, standardize};
use crate::regress::view::ViewIntrinsics;
use crate::temporal::TemporalConfig;
use crate::whiten::{WHITENING_FILE, Whitening};
use crate::zones::{TRUTH_ANGLE_WEIGHT_MM_PER_DEG, ZoneTable, cumulative_path_mm, nearest_frame};
use burn::module::Module;
use burn::optim::AdamConfig;
use burn::tensor::{Device, Int, Tensor, TensorData};
use endoloc_data::Sequence;
use endoloc_geometry::Camera;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

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
    /// its poses ([`ZoneTable::truth_zone`]). For monitoring only: nothing is selected by it.
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
    /// nearest training pose ([`ZoneTable::truth_zone`]), so that positive pairs also join
    /// views of one place from different passes — the variation a test pass brings. Zones,
    /// the descriptor database and maps stay those of the training sequence.
    pub extra_sequences: Vec<PathBuf>,
    /// Power of the partial PCA whitening learnt from the database at the end
    /// ([`crate::whiten`]; 0: none, the network's descriptors as they are). Default ¼.
    pub whitening: f32,
    /// Database rows smoothed along the training pass over ± this camera path length, mm,
    /// after the whitening ([`crate::database::smooth_along_pass`]; 0: none). Default 2.2.
    pub database_smoothing_mm: f64,
}

/// Default [`TrainConfig::database_smoothing_mm`], about ±4 frames of the `paper` preset:
/// chosen on a second pass of its colon among 1.0, 1.6, 2.2 and 3.0 mm.
pub const DEFAULT_DATABASE_SMOOTHING_MM: f64 = 2.2;

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

/// What the training loop is doing, for progress display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Decoding and resizing the training images.
    LoadingImages,
    /// Optimising.
    Training,
    /// Computing descriptors of all training frames.
    Describing,
    /// Writing the model folder.
    Saving,
}

/// A progress report from [`train`].
#[derive(Debug, Clone, PartialEq)]
pub struct TrainProgress {
    /// Current phase.
    pub phase: Phase,
    /// Units done in this phase (images, or steps when training).
    pub done: usize,
    /// Units in this phase.
    pub total: usize,
    /// Current epoch (1-based; 0 outside training).
    pub epoch: usize,
    /// Mean loss of the last finished epoch.
    pub loss: Option<f32>,
    /// Last validation zone accuracy (fraction).
    pub val_accuracy: Option<f32>,
}

impl TrainProgress {
    /// Progress of a phase outside the optimisation (no epoch, loss or accuracy).
    pub fn outside_training(phase: Phase, done: usize, total: usize) -> Self {
        TrainProgress {
            phase,
            done,
            total,
            epoch: 0,
            loss: None,
            val_accuracy: None,
        }
    }
}

/// One epoch of the training history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EpochRecord {
    /// 1-based epoch.
    pub epoch: usize,
    /// Mean contrastive loss over the epoch's steps.
    pub loss: f32,
    /// Validation exact zone accuracy (fraction), when validated this epoch.
    pub val_accuracy: Option<f32>,
    /// Validation accuracy within ±1 zone.
    pub val_within1: Option<f32>,
    /// Wall-clock seconds since the start of training (this run).
    pub elapsed_s: f64,
}

/// The outcome of [`train`].
#[derive(Debug, Clone, PartialEq)]
pub struct TrainReport {
    /// The model folder written.
    pub model_dir: PathBuf,
    /// Loss and validation per epoch (including epochs of a resumed run).
    pub history: Vec<EpochRecord>,
    /// Epoch the run resumed after (`None`: a fresh start).
    pub resumed_after_epoch: Option<usize>,
    /// Frames of each extra pass that joined the training images
    /// ([`TrainConfig::extra_sequences`], in order).
    pub pass_frames: Vec<usize>,
    /// Wall-clock seconds: loading images.
    pub load_s: f64,
    /// Wall-clock seconds: optimisation steps and validation (this run).
    pub train_s: f64,
    /// Wall-clock seconds: descriptors of all training frames.
    pub describe_s: f64,
    /// Steps taken in this run.
    pub steps: usize,
}

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
    /// for [`PairRule::Track`]; empty when image `i` is training frame `i`.
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
                .map(|&i| {
                    let g = seq.load_gray(i)?;
                    Ok(resize_area(
                        g.as_raw(),
                        g.width() as usize,
                        g.height() as usize,
                        size,
                    ))
                })
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
    let size = cache.size;
    let mut out = Vec::new();
    for (k, chunk) in frames.chunks(batch.max(1)).enumerate() {
        let buf: Vec<f32> = chunk
            .par_iter()
            .flat_map_iter(|&f| {
                let mut v = cache.image(f).to_vec();
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
            .map(|&i| {
                let g = seq.load_gray(i)?;
                Ok(resize_area(
                    g.as_raw(),
                    g.width() as usize,
                    g.height() as usize,
                    size,
                ))
            })
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

/// Saved training state between runs (`checkpoint/state.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CheckpointState {
    epoch: usize,
    history: Vec<EpochRecord>,
    config: TrainConfig,
    frames: usize,
    zones: usize,
}

const CKPT_NET: &str = "net.bpk";
const CKPT_OPTIM: &str = "optim.bpk";
const CKPT_STATE: &str = "state.json";

/// The fitted network and its history (in-memory core of [`train`]).
pub struct Fitted {
    /// The trained backbone (autodiff device; call `.valid()` for inference).
    pub net: EmbeddingNet,
    /// Loss and validation per epoch.
    pub history: Vec<EpochRecord>,
    /// Epoch resumed after, if any.
    pub resumed_after_epoch: Option<usize>,
    /// Steps taken in this run.
    pub steps: usize,
    /// Wall-clock seconds of this run.
    pub train_s: f64,
}

/// Fits the network on cached images: the training loop without any file output except
/// optional checkpoints in `checkpoint_dir` (resumed from when `resume` and a checkpoint
/// exists there).
///
/// # Errors
/// [`NetError::Config`] for a bad config or a cache/zoning size mismatch; [`NetError::Zoning`]
/// when no balanced pairs can be formed; [`NetError::Diverged`]; [`NetError::Weights`] /
/// [`NetError::Io`] for checkpoint files.
pub fn fit(
    cfg: &TrainConfig,
    cache: &ImageCache,
    zones: &ZoneTable,
    validation: Option<&ValidationSet>,
    checkpoint_dir: Option<&Path>,
    resume: bool,
    progress: &mut dyn FnMut(&TrainProgress),
) -> Result<Fitted, NetError> {
    cfg.validate()?;
    if cache.len() != zones.frame_count() {
        return Err(NetError::Config(format!(
            "{} cached images but the zone table covers {} frames",
            cache.len(),
            zones.frame_count()
        )));
    }
    if cache.size != cfg.backbone.input() {
        return Err(NetError::Config(format!(
            "images cached at {} but the backbone takes {}",
            cache.size,
            cfg.backbone.input()
        )));
    }
    let base = crate::device::from_name(&cfg.device)?;
    let device = base.clone().autodiff();
    let n = zones.frame_count();
    let holdout = if validation.is_some() {
        0
    } else {
        cfg.validation.holdout_every
    };
    let is_held = |f: usize| holdout > 1 && f % holdout == holdout / 2;
    let mut zone_frames: Vec<Vec<usize>> = vec![Vec::new(); zones.len()];
    for f in 0..n {
        if !is_held(f) {
            zone_frames[zones.zone_of_frame[f]].push(f);
        }
    }
    let sampler = match cfg.pairs {
        PairRule::Zone => PairSampler::new(
            zone_frames,
            cfg.hard_negative_fraction,
            cfg.hard_negative_reach,
        )?,
        rule @ PairRule::Track { zone_fraction, .. } => {
            let track = PairSampler::along_track(
                (0..n)
                    .filter(|&f| !is_held(f))
                    .map(|f| (cache.along_of(f), f))
                    .collect(),
                rule,
            )?;
            if zone_fraction > 0.0 {
                track.with_zone_pairs(zone_frames)?
            } else {
                track
            }
        }
    };
    // Validation queries: (image cache, frames in it, truth zones).
    let held: Vec<usize> = (0..n).filter(|&f| is_held(f)).collect();
    let held_truth: Vec<usize> = held.iter().map(|&f| zones.zone_of_frame[f]).collect();
    let ext_frames: Vec<usize> = validation.map_or(Vec::new(), |v| (0..v.images.len()).collect());
    let (val_cache, val_queries, val_truth): (&ImageCache, &[usize], &[usize]) = match validation {
        Some(v) => (&v.images, &ext_frames, &v.truth),
        None => (cache, &held, &held_truth),
    };
    let val_db: Vec<usize> = {
        let pool: Vec<usize> = (0..n).filter(|&f| !is_held(f)).collect();
        let m = cfg.validation.max_database_frames.max(1);
        if pool.len() <= m {
            pool
        } else {
            (0..m).map(|i| pool[i * pool.len() / m]).collect()
        }
    };

    // Fresh start or resume.
    let mut net = crate::device::seeded(&device, cfg.seed, || cfg.backbone.init(&device));
    if let Some(p) = &cfg.pretrained {
        let r = crate::pretrained::load_pretrained(&mut net, p)?;
        tracing::info!(
            "pretrained weights {}: {} tensors loaded, {} skipped, {} kept at their initial values{}",
            p.display(),
            r.applied,
            r.skipped.len(),
            r.missing.len(),
            if r.conv1_from_rgb {
                ", conv1 summed from RGB"
            } else {
                ""
            }
        );
    }
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    let mut history: Vec<EpochRecord> = Vec::new();
    let mut start_epoch = 0;
    let mut resumed = None;
    if let Some(dir) = checkpoint_dir {
        let state_path = dir.join(CKPT_STATE);
        if resume && state_path.is_file() {
            let text =
                std::fs::read_to_string(&state_path).map_err(|e| NetError::io(&state_path, e))?;
            let st: CheckpointState = serde_json::from_str(&text)
                .map_err(|e| NetError::parse(&state_path, e.line(), e.to_string()))?;
            if st.config.backbone != cfg.backbone || st.frames != n || st.zones != zones.len() {
                return Err(NetError::Config(format!(
                    "{}: the checkpoint was made with another backbone, frame count or zoning ({} frames, {} zones); start over with --force",
                    dir.display(),
                    st.frames,
                    st.zones
                )));
            }
            let p = dir.join(CKPT_NET);
            net = net
                .try_load_file(&p)
                .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
            let p = dir.join(CKPT_OPTIM);
            optim = optim
                .load(&p)
                .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
            start_epoch = st.epoch;
            history = st.history;
            resumed = Some(st.epoch);
        }
    }

    let sched = &cfg.schedule;
    let steps_per_epoch = sched.steps_per_epoch();
    let total_steps = steps_per_epoch * sched.epochs;
    let size = cache.size;
    let (w, h) = (size.width as usize, size.height as usize);
    let t0 = Instant::now();
    let mut steps = 0;
    let mut last_loss = history.last().map(|r| r.loss);
    let mut last_val = history.iter().rev().find_map(|r| r.val_accuracy);
    for epoch in start_epoch..sched.epochs {
        // One RNG stream per epoch: a resumed run draws the same pairs as an uninterrupted one.
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x5EED_0000_0000);
        rng.set_stream(epoch as u64 + 1);
        let mut loss_sum = 0.0f64;
        let mut remaining = sched.pairs_per_epoch;
        let mut k = 0;
        while remaining > 0 {
            let pairs = remaining.min(sched.batch_pairs).max(2);
            remaining = remaining.saturating_sub(pairs);
            let batch: PairBatch = sampler.batch(pairs, sched.share_images, &mut rng);
            // Per-image seeds drawn sequentially, augmentation in parallel.
            let seeds: Vec<u64> = batch
                .images
                .iter()
                .map(|_| rand::Rng::random(&mut rng))
                .collect();
            let buf: Vec<f32> = batch
                .images
                .par_iter()
                .zip(seeds.par_iter())
                .flat_map_iter(|(&f, &s)| {
                    let mut r = ChaCha8Rng::seed_from_u64(s);
                    let mut v = augment(
                        cache.image(f),
                        w,
                        h,
                        cache.view.as_ref(),
                        &cfg.augment,
                        &mut r,
                    );
                    standardize(&mut v);
                    v
                })
                .collect();
            let nb = batch.images.len();
            let x = Tensor::<4>::from_data(TensorData::new(buf, [nb, 1, h, w]), &device);
            let desc = net.forward(x);
            let idx = |v: &[usize]| {
                let d: Vec<i32> = v.iter().map(|&i| i as i32).collect();
                Tensor::<1, Int>::from_ints(TensorData::new(d, [v.len()]), &device)
            };
            let da = desc.clone().select(0, idx(&batch.a));
            let db = desc.select(0, idx(&batch.b));
            let y = Tensor::<1>::from_data(
                TensorData::new(batch.dissimilar.clone(), [batch.a.len()]),
                &device,
            );
            let loss = contrastive_loss(da, db, y, cfg.margin);
            let lr = sched.learning_rate_at(epoch * steps_per_epoch + k, total_steps);
            let (stepped, lv) = descend(&mut optim, net, loss, lr, epoch + 1)?;
            net = stepped;
            loss_sum += lv as f64;
            k += 1;
            steps += 1;
            progress(&TrainProgress {
                phase: Phase::Training,
                done: epoch * steps_per_epoch + k,
                total: total_steps,
                epoch: epoch + 1,
                loss: last_loss,
                val_accuracy: last_val,
            });
        }
        let loss = (loss_sum / k.max(1) as f64) as f32;
        last_loss = Some(loss);
        let last = epoch + 1 == sched.epochs;
        let validate = !val_queries.is_empty()
            && cfg.validation.every_epochs > 0
            && ((epoch + 1) % cfg.validation.every_epochs == 0 || last);
        let (val_accuracy, val_within1) = if validate {
            let (a, b) = validation_accuracy(
                &net.valid(),
                &base,
                cache,
                zones,
                &val_db,
                (val_cache, val_queries, val_truth),
                cfg,
            )?;
            last_val = Some(a);
            (Some(a), Some(b))
        } else {
            (None, None)
        };
        history.push(EpochRecord {
            epoch: epoch + 1,
            loss,
            val_accuracy,
            val_within1,
            elapsed_s: t0.elapsed().as_secs_f64(),
        });
        progress(&TrainProgress {
            phase: Phase::Training,
            done: (epoch + 1) * steps_per_epoch,
            total: total_steps,
            epoch: epoch + 1,
            loss: last_loss,
            val_accuracy: last_val,
        });
        let every = cfg.checkpoint_every_epochs;
        if let Some(dir) = checkpoint_dir
            && (last || (every > 0 && (epoch + 1) % every == 0))
        {
            save_checkpoint(
                dir,
                &net,
                &optim,
                &CheckpointState {
                    epoch: epoch + 1,
                    history: history.clone(),
                    config: cfg.clone(),
                    frames: n,
                    zones: zones.len(),
                },
            )?;
        }
    }
    Ok(Fitted {
        net,
        history,
        resumed_after_epoch: resumed,
        steps,
        train_s: t0.elapsed().as_secs_f64(),
    })
}

fn save_checkpoint(
    dir: &Path,
    net: &EmbeddingNet,
    optim: &burn::optim::ModuleOptimizer,
    state: &CheckpointState,
) -> Result<(), NetError> {
    std::fs::create_dir_all(dir).map_err(|e| NetError::io(dir, e))?;
    // Write to temporary names, then rename: a crash mid-write leaves the old checkpoint.
    let tmp = |name: &str| dir.join(format!(".{name}.tmp"));
    let p = tmp(CKPT_NET);
    net.clone()
        .save_file(&p)
        .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
    let p = tmp(CKPT_OPTIM);
    optim
        .save(&p)
        .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
    let p = tmp(CKPT_STATE);
    let text = serde_json::to_string_pretty(state).map_err(|e| NetError::Config(e.to_string()))?;
    std::fs::write(&p, text).map_err(|e| NetError::io(&p, e))?;
    for name in [CKPT_NET, CKPT_OPTIM, CKPT_STATE] {
        let (from, to) = (tmp(name), dir.join(name));
        // burn may add an extension to the file name it is given.
        let from = if from.is_file() {
            from
        } else {
            from.with_extension("tmp.bpk")
        };
        std::fs::rename(&from, &to).map_err(|e| NetError::io(&to, e))?;
    }
    Ok(())
}

/// Exact and ±1 zone accuracy of held-out frames against a database of other frames.
fn validation_accuracy(
    net: &EmbeddingNet,
    device: &Device,
    cache: &ImageCache,
    zones: &ZoneTable,
    db_frames: &[usize],
    queries: (&ImageCache, &[usize], &[usize]),
    cfg: &TrainConfig,
) -> Result<(f32, f32), NetError> {
    let (qcache, queries, truth) = queries;
    let dim = cfg.backbone.descriptor_dim();
    let d = describe_cached(
        net,
        device,
        cache,
        db_frames,
        cfg.inference_batch,
        &mut |_| {},
    );
    let db = DescriptorDatabase::from_rows(
        dim,
        zones.len(),
        d,
        db_frames.iter().map(|&f| zones.zone_of_frame[f]).collect(),
        db_frames.to_vec(),
    )?;
    let q = describe_cached(
        net,
        device,
        qcache,
        queries,
        cfg.inference_batch,
        &mut |_| {},
    );
    let mut exact = 0;
    let mut near = 0;
    for (i, &truth) in truth.iter().enumerate().take(queries.len()) {
        let p = db.lookup(&q[i * dim..(i + 1) * dim], cfg.score)?;
        exact += usize::from(p.zone == truth);
        near += usize::from(p.zone.abs_diff(truth) <= 1);
    }
    let n = queries.len().max(1) as f32;
    Ok((exact as f32 / n, near as f32 / n))
}

/// Where and how [`train`] writes the model folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TrainTarget {
    /// The model folder to create.
    pub dir: PathBuf,
    /// Replace an existing model folder.
    pub force: bool,
    /// Continue from the checkpoint of an interrupted run (`DIR.partial/checkpoint`).
    pub resume: bool,
}

impl TrainTarget {
    /// Checks that the output may be written and makes its staging folder
    /// ([`TrainTarget::staging_dir`]), kept as it is when resuming, emptied with `force`.
    ///
    /// # Errors
    /// [`NetError::AlreadyExists`] for an existing output without `force`;
    /// [`NetError::Config`] for an interrupted run without `resume` or `force`;
    /// [`NetError::Io`].
    pub fn prepare(&self) -> Result<PathBuf, NetError> {
        if self.dir.exists() && !self.force {
            return Err(NetError::AlreadyExists {
                path: self.dir.clone(),
            });
        }
        let staging = self.staging_dir();
        if staging.exists() && !self.resume {
            if self.force {
                std::fs::remove_dir_all(&staging).map_err(|e| NetError::io(&staging, e))?;
            } else {
                return Err(NetError::Config(format!(
                    "{} holds an interrupted training run: pass --resume to continue it or --force to start over",
                    staging.display()
                )));
            }
        }
        std::fs::create_dir_all(&staging).map_err(|e| NetError::io(&staging, e))?;
        Ok(staging)
    }

    /// The staging folder next to the model folder: `DIR.partial`.
    pub fn staging_dir(&self) -> PathBuf {
        let name = self
            .dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".into());
        self.dir.with_file_name(format!("{name}.partial"))
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

/// Trains a model on a training sequence and writes the model folder atomically: everything
/// goes to `DIR.partial/` (checkpoints in `DIR.partial/checkpoint/`), which is renamed to
/// `DIR` at the end. An existing `DIR` is refused unless `target.force`; an interrupted run
/// is continued with `target.resume`.
///
/// `camera` is the training dataset's camera, stored so that a model refuses data from
/// another camera. `dataset` names the dataset in `model.toml`.
///
/// # Errors
/// [`NetError::AlreadyExists`] for an existing model (or an interrupted run without
/// `resume`/`force`); [`NetError::Data`] for unreadable images; everything [`fit`] returns;
/// [`NetError::Io`] while writing.
pub fn train(
    cfg: &TrainConfig,
    seq: &Sequence,
    zones: &ZoneTable,
    camera: &Camera,
    dataset: &str,
    target: &TrainTarget,
    progress: &mut dyn FnMut(&TrainProgress),
) -> Result<TrainReport, NetError> {
    cfg.validate()?;
    if zones.frame_count() != seq.len() {
        return Err(NetError::Config(format!(
            "the zone table covers {} frames but sequence {} has {}",
            zones.frame_count(),
            seq.dir.display(),
            seq.len()
        )));
    }
    let staging = target.prepare()?;
    let ckpt = staging.join("checkpoint");

    let t_load = Instant::now();
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
    let load_s = t_load.elapsed().as_secs_f64();

    let val_set = match &cfg.validation.sequence {
        Some(p) => {
            let vseq = Sequence::open(p)?;
            let train_poses: Vec<_> = seq.poses.iter().map(|p| p.pose).collect();
            Some(ValidationSet::from_sequence(
                &vseq,
                zones,
                &train_poses,
                size,
                cfg.validation.max_queries,
            )?)
        }
        None => None,
    };
    let fitted = fit(
        cfg,
        &cache,
        &pass_zones,
        val_set.as_ref(),
        Some(&ckpt),
        target.resume,
        progress,
    )?;

    let t_desc = Instant::now();
    let base = crate::device::from_name(&cfg.device)?;
    let net = fitted.net.valid();
    let frames: Vec<usize> = (0..total).collect();
    let descriptors = describe_cached(
        &net,
        &base,
        &cache,
        &frames,
        cfg.inference_batch,
        &mut |done| {
            progress(&TrainProgress::outside_training(
                Phase::Describing,
                done,
                total,
            ))
        },
    );
    let dim = cfg.backbone.descriptor_dim();
    let (descriptors, whitening) = if cfg.whitening > 0.0 {
        let w = Whitening::fit(&descriptors, dim, cfg.whitening)?;
        w.save(&staging.join(WHITENING_FILE))?;
        (w.apply_rows(&descriptors), Some(cfg.whitening))
    } else {
        (descriptors, None)
    };
    let path_mm = cumulative_path_mm(&seq.poses.iter().map(|p| p.pose).collect::<Vec<_>>());
    let descriptors = smooth_along_pass(&descriptors, dim, &path_mm, cfg.database_smoothing_mm);
    let describe_s = t_desc.elapsed().as_secs_f64();
    let db = DescriptorDatabase::new(dim, zones.len(), descriptors, zones.zone_of_frame.clone())?;
    progress(&TrainProgress::outside_training(Phase::Saving, 0, 1));
    let model_cfg = ModelConfig {
        format_version: model::FORMAT_VERSION,
        backbone: cfg.backbone.clone(),
        score: cfg.score,
        temporal: TemporalConfig::default(),
        track: Default::default(),
        whitening,
        camera: *camera,
        dataset: dataset.to_string(),
        sequence: seq.name.clone(),
        frames: total,
        zones: zones.config,
        train: cfg.clone(),
    };
    model::write_model_files(&staging, &model_cfg, &net, zones, &db, seq, &fitted.history)?;
    if ckpt.exists() {
        std::fs::remove_dir_all(&ckpt).map_err(|e| NetError::io(&ckpt, e))?;
    }
    model::publish(&staging, &target.dir, target.force)?;
    Ok(TrainReport {
        model_dir: target.dir.clone(),
        history: fitted.history,
        resumed_after_epoch: fitted.resumed_after_epoch,
        pass_frames,
        load_s,
        train_s: fitted.train_s,
        describe_s,
        steps: fitted.steps,
    })
}
