//! The training loop ([`fit`]), written out here rather than burn's TUI learner.
//!
//! Per step: draw a [`PairBatch`], augment and standardise its images, run them through the
//! backbone as one batch (so the twins share weights by construction), pick the two rows of
//! every pair, take the contrastive loss, back-propagate, Adam step. An *epoch* is
//! `pairs_per_epoch` pairs; after it the network may be validated and checkpointed
//! ([`super::checkpoint`]).

use super::checkpoint::{self, Learner};
use super::data::{ImageCache, ValidationSet};
use super::progress::{Phase, TrainProgress};
use super::validation::{Holdout, Validation};
use crate::NetError;
use crate::augment::augment;
use crate::backbone::EmbeddingNet;
use crate::history::EpochRecord;
use crate::loss::contrastive_loss;
use crate::optimise::descend;
use crate::pairs::{PairBatch, PairRule, PairSampler};
use crate::preprocess::standardize;
use crate::train_config::TrainConfig;
use crate::zones::ZoneTable;
use burn::module::Module;
use burn::optim::AdamConfig;
use burn::tensor::{Device, Int, Tensor, TensorData};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// The fitted network and its history (in-memory core of [`train`](super::train)).
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
    check_inputs(cfg, cache, zones)?;
    let base = crate::device::from_name(&cfg.device)?;
    let device = base.clone().autodiff();
    let n = zones.frame_count();
    let holdout = Holdout::new(cfg, validation.is_some());
    let sampler = pair_sampler(cfg, cache, zones, holdout)?;
    let val = Validation::new(cfg, cache, zones, validation, holdout);

    // Fresh start or resume.
    let learner = init_learner(cfg, &device)?;
    let (mut learner, start) = match checkpoint_dir {
        Some(dir) if resume => checkpoint::resume(dir, cfg, n, zones.len(), learner)?,
        _ => (learner, None),
    };
    let resumed = start.as_ref().map(|s| s.epoch);
    let (start_epoch, mut history) = start.map_or((0, Vec::new()), |s| (s.epoch, s.history));

    let sched = &cfg.schedule;
    let steps_per_epoch = sched.steps_per_epoch();
    let total_steps = steps_per_epoch * sched.epochs;
    let t0 = Instant::now();
    let mut steps = 0;
    let mut last_loss = history.last().map(|r| r.loss);
    let mut last_val = history.iter().rev().find_map(|r| r.val_accuracy);
    for epoch in start_epoch..sched.epochs {
        let report = |done: usize, loss: Option<f32>, val_accuracy: Option<f32>| TrainProgress {
            phase: Phase::Training,
            done,
            total: total_steps,
            epoch: epoch + 1,
            loss,
            val_accuracy,
        };
        let (trained, loss, k) =
            run_epoch(learner, cfg, cache, &sampler, &device, epoch, &mut |done| {
                progress(&report(done, last_loss, last_val))
            })?;
        learner = trained;
        steps += k;
        last_loss = Some(loss);
        let last = epoch + 1 == sched.epochs;
        let (val_accuracy, val_within1) = if val.due(cfg, epoch + 1, last) {
            let (a, b) = val.accuracy(&learner.net.valid(), &base, cache, zones, cfg)?;
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
        progress(&report((epoch + 1) * steps_per_epoch, last_loss, last_val));
        if let Some(dir) = checkpoint_dir
            && checkpoint::due(cfg.checkpoint_every_epochs, epoch + 1, last)
        {
            checkpoint::save(dir, &learner, epoch + 1, &history, cfg, (n, zones.len()))?;
        }
    }
    Ok(Fitted {
        net: learner.net,
        history,
        resumed_after_epoch: resumed,
        steps,
        train_s: t0.elapsed().as_secs_f64(),
    })
}

/// Checks that `cache` holds one image per frame of `zones` at the backbone's input size.
fn check_inputs(cfg: &TrainConfig, cache: &ImageCache, zones: &ZoneTable) -> Result<(), NetError> {
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
    Ok(())
}

/// The pair sampler of `cfg.pairs` over the frames not held out.
///
/// # Errors
/// [`NetError::Zoning`] when no balanced pairs can be formed; [`NetError::Config`] for bad
/// pair settings.
fn pair_sampler(
    cfg: &TrainConfig,
    cache: &ImageCache,
    zones: &ZoneTable,
    holdout: Holdout,
) -> Result<PairSampler, NetError> {
    let n = zones.frame_count();
    let mut zone_frames: Vec<Vec<usize>> = vec![Vec::new(); zones.len()];
    for f in 0..n {
        if !holdout.is_held(f) {
            zone_frames[zones.zone_of_frame[f]].push(f);
        }
    }
    Ok(match cfg.pairs {
        PairRule::Zone => PairSampler::new(
            zone_frames,
            cfg.hard_negative_fraction,
            cfg.hard_negative_reach,
        )?,
        rule @ PairRule::Track { zone_fraction, .. } => {
            let track = PairSampler::along_track(
                (0..n)
                    .filter(|&f| !holdout.is_held(f))
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
    })
}

/// A fresh network (seeded with `cfg.seed`, from `cfg.pretrained` when set) and Adam.
///
/// # Errors
/// [`NetError::Weights`] for unreadable start weights.
fn init_learner(cfg: &TrainConfig, device: &Device) -> Result<Learner, NetError> {
    let mut net = crate::device::seeded_init(device, cfg.seed, |d| {
        Ok::<_, NetError>(cfg.backbone.init(d))
    })?;
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
    let optim = AdamConfig::new().with_epsilon(1e-8).init();
    Ok(Learner { net, optim })
}

/// One epoch (0-based `epoch`): `pairs_per_epoch` pairs in batches of at most `batch_pairs`,
/// an Adam step on each. `on_step` gets the number of steps done in the whole run after each
/// step. Returns the stepped learner, the epoch's mean loss and its number of steps.
///
/// # Errors
/// [`NetError::Diverged`] for a non-finite loss.
fn run_epoch(
    learner: Learner,
    cfg: &TrainConfig,
    cache: &ImageCache,
    sampler: &PairSampler,
    device: &Device,
    epoch: usize,
    on_step: &mut dyn FnMut(usize),
) -> Result<(Learner, f32, usize), NetError> {
    let sched = &cfg.schedule;
    let steps_per_epoch = sched.steps_per_epoch();
    let total_steps = steps_per_epoch * sched.epochs;
    let Learner { mut net, mut optim } = learner;
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
        let loss = batch_loss(&net, cfg, cache, &batch, device, &mut rng);
        let lr = sched.learning_rate_at(epoch * steps_per_epoch + k, total_steps);
        let (stepped, lv) = descend(&mut optim, net, loss, lr, epoch + 1)?;
        net = stepped;
        loss_sum += lv as f64;
        k += 1;
        on_step(epoch * steps_per_epoch + k);
    }
    let loss = (loss_sum / k.max(1) as f64) as f32;
    Ok((Learner { net, optim }, loss, k))
}

/// The contrastive loss of one batch of pairs: its images augmented (one seed per image drawn
/// from `rng` in order, the augmentation itself in parallel) and standardised, run through
/// `net` as one batch.
fn batch_loss(
    net: &EmbeddingNet,
    cfg: &TrainConfig,
    cache: &ImageCache,
    batch: &PairBatch,
    device: &Device,
    rng: &mut ChaCha8Rng,
) -> Tensor<1> {
    let (w, h) = (cache.size.width as usize, cache.size.height as usize);
    // Per-image seeds drawn sequentially, augmentation in parallel.
    let seeds: Vec<u64> = batch
        .images
        .iter()
        .map(|_| rand::Rng::random(&mut *rng))
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
    let x = Tensor::<4>::from_data(TensorData::new(buf, [nb, 1, h, w]), device);
    let desc = net.forward(x);
    let idx = |v: &[usize]| {
        let d: Vec<i32> = v.iter().map(|&i| i as i32).collect();
        Tensor::<1, Int>::from_ints(TensorData::new(d, [v.len()]), device)
    };
    let da = desc.clone().select(0, idx(&batch.a));
    let db = desc.select(0, idx(&batch.b));
    let y = Tensor::<1>::from_data(
        TensorData::new(batch.dissimilar.clone(), [batch.a.len()]),
        device,
    );
    contrastive_loss(da, db, y, cfg.margin)
}
