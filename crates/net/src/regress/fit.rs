//! What PoseNet and OffsetNet share: the network's construction and loading
//! ([`RegressNetwork`], [`load_model`]) and the training loop ([`fit`]) — Adam on the
//! schedule's cosine learning rate, one loss per batch, held-out errors every few epochs,
//! progress reports and the per-epoch history. Each method supplies only how a batch is drawn
//! and scored and how its held-out frames are predicted.

use super::config::RegressConfig;
use super::io::{self, RegressMethod, RegressModelFile};
use super::progress::{RegressEpoch, RegressPhase, RegressProgress};
use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::optimise::descend;
use burn::module::Module;
use burn::optim::AdamConfig;
use burn::tensor::{Device, Tensor};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::time::Instant;

/// A regression network: a backbone and a head, built from a [`RegressConfig`].
pub trait RegressNetwork: Module + Sized {
    /// The method whose model folders hold this network.
    const METHOD: RegressMethod;

    /// A fresh network for `cfg` on `device` (seed the device first for reproducible weights;
    /// the backbone comes from `cfg.init_backbone` when set).
    ///
    /// # Errors
    /// [`NetError::Weights`] when `cfg.init_backbone` cannot be loaded.
    fn new(cfg: &RegressConfig, device: &Device) -> Result<Self, NetError>;
}

/// The backbone of a fresh network: from `cfg.init_backbone` when set, else newly initialised.
///
/// # Errors
/// [`NetError::Weights`] when `cfg.init_backbone` cannot be loaded.
pub(crate) fn init_backbone(
    cfg: &RegressConfig,
    device: &Device,
) -> Result<EmbeddingNet, NetError> {
    match &cfg.init_backbone {
        Some(p) => crate::model::load_weights(&cfg.backbone, p, device),
        None => Ok(cfg.backbone.init(device)),
    }
}

/// Loads the model folder `dir` of network `N` on the named device: its `regress.toml` (which
/// must name `N`'s method) and every weight.
///
/// # Errors
/// [`NetError::Io`] / [`NetError::Parse`] naming the missing or bad file (or a folder of the
/// other method), [`NetError::Weights`] for weights that do not fit `regress.toml`,
/// [`NetError::Device`].
pub(crate) fn load_model<N: RegressNetwork>(
    dir: &Path,
    device: &str,
) -> Result<(RegressModelFile, N, Device), NetError> {
    let file = RegressModelFile::load(dir, N::METHOD)?;
    let device = crate::device::from_name(device)?;
    let cfg = RegressConfig {
        init_backbone: None,
        ..file.config.clone()
    };
    let mut net = N::new(&cfg, &device)?;
    io::load_weights(dir, &mut net)?;
    Ok((file, net, device))
}

/// Trains `net` (on an autodiff device) for `cfg.schedule`.
///
/// Epoch `e` draws its batches from a generator seeded with `cfg.seed ^ seed_salt` on stream
/// `e + 1`, so a run is reproducible and each method draws its own numbers. `batch_loss(net, b,
/// rng)` draws `b` samples and returns their loss (a one-element tensor); `held_errors(net)`
/// returns the mean position (mm) and orientation (°) errors of the held-out frames for the
/// validation-mode network, asked every `cfg.validate_every_epochs` epochs and after the last
/// one when `has_held`.
///
/// Returns the validation-mode network and the history.
///
/// # Errors
/// [`NetError::Diverged`] for a non-finite loss.
pub(crate) fn fit<N: RegressNetwork>(
    cfg: &RegressConfig,
    seed_salt: u64,
    mut net: N,
    has_held: bool,
    mut batch_loss: impl FnMut(&N, usize, &mut ChaCha8Rng) -> Tensor<1>,
    mut held_errors: impl FnMut(&N) -> (f64, f64),
    progress: &mut dyn FnMut(&RegressProgress),
) -> Result<(N, Vec<RegressEpoch>), NetError> {
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    let sched = &cfg.schedule;
    let steps_per_epoch = sched.steps_per_epoch();
    let total_steps = steps_per_epoch * sched.epochs;
    let t0 = Instant::now();
    let mut history = Vec::with_capacity(sched.epochs);
    let mut last_loss = None;
    for epoch in 0..sched.epochs {
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ seed_salt);
        rng.set_stream(epoch as u64 + 1);
        let mut loss_sum = 0.0f64;
        let mut remaining = sched.samples_per_epoch;
        let mut k = 0;
        while remaining > 0 {
            let b = remaining.min(sched.batch).max(2);
            remaining = remaining.saturating_sub(b);
            let loss = batch_loss(&net, b, &mut rng);
            let lr = sched.learning_rate_at(epoch * steps_per_epoch + k, total_steps);
            let (stepped, lv) = descend(&mut optim, net, loss, lr, epoch + 1)?;
            net = stepped;
            loss_sum += lv as f64;
            k += 1;
            progress(&RegressProgress {
                phase: RegressPhase::Training,
                done: epoch * steps_per_epoch + k,
                total: total_steps,
                epoch: epoch + 1,
                loss: last_loss,
            });
        }
        let loss = (loss_sum / k.max(1) as f64) as f32;
        last_loss = Some(loss);
        let last = epoch + 1 == sched.epochs;
        let validate = has_held
            && cfg.validate_every_epochs > 0
            && ((epoch + 1) % cfg.validate_every_epochs == 0 || last);
        let (vp, vo) = if validate {
            progress(&RegressProgress {
                phase: RegressPhase::Validating,
                done: (epoch + 1) * steps_per_epoch,
                total: total_steps,
                epoch: epoch + 1,
                loss: last_loss,
            });
            let (p, o) = held_errors(&net.valid());
            tracing::info!(
                "{} epoch {}: held-out {p:.1} mm, {o:.2}°",
                N::METHOD.name(),
                epoch + 1
            );
            (Some(p), Some(o))
        } else {
            (None, None)
        };
        history.push(RegressEpoch {
            epoch: epoch + 1,
            loss,
            val_position_mm: vp,
            val_orientation_deg: vo,
            elapsed_s: t0.elapsed().as_secs_f64(),
        });
    }
    Ok((net.valid(), history))
}
