//! Training the Siamese network: twins sharing one backbone, the contrastive loss, balanced
//! pairs, Adam; checkpoints and resume; validation zone accuracy; the model folder.
//!
//! [`train`] runs the whole of it from a training sequence to a published model folder,
//! step by step:
//!
//! 1. load and resize the training images and any further passes (`data`);
//! 2. fit the network on them ([`fit`], the training loop), validating as configured and
//!    checkpointing into the staging folder (`checkpoint`);
//! 3. describe every training frame, whiten and smooth the rows into the descriptor
//!    database, and write the model folder with its loss curve (`output`);
//! 4. rename the staging folder into place ([`crate::model::publish`]).
//!
//! The settings are [`TrainConfig`]; schedules: [`Schedule::paper`] is the paper's (128 + 128
//! pairs per epoch, 500 epochs, Adam, lr 0.001, batch 128 pairs, every pair with its own two
//! images); [`Schedule::fast`] is the CPU default (see its doc for the numbers).

mod checkpoint;
mod data;
mod fit;
mod output;
mod progress;
mod validation;

pub use crate::history::EpochRecord;
pub use crate::train_config::{
    DEFAULT_DATABASE_SMOOTHING_MM, DEFAULT_INDEX_VIEW_PENALTY, DEFAULT_WHITENING, Schedule,
    TrainConfig, ValidationConfig, ZOOM_BLUR_AMPLITUDES,
};
pub use checkpoint::TrainTarget;
pub(crate) use checkpoint::{checkpoint_dir, discard as discard_checkpoint};
pub use data::{ImageCache, ValidationSet, describe_cached};
pub(crate) use data::{add_passes, forward_values};
pub use fit::{Fitted, fit};
pub use progress::{Phase, TrainProgress};

use crate::NetError;
use crate::database::DescriptorDatabase;
use crate::model;
use crate::zones::ZoneTable;
use burn::module::Module;
use endoloc_data::Sequence;
use endoloc_geometry::Camera;
use output::ModelSource;
use std::path::PathBuf;
use std::time::Instant;

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
    target.run(|staging| {
        let ckpt = checkpoint_dir(staging);

        let t_load = Instant::now();
        let (cache, pass_zones, pass_frames) =
            data::load_training(cfg, seq, zones, camera, progress)?;
        let load_s = t_load.elapsed().as_secs_f64();

        let val_set = data::validation_set(cfg, seq, zones)?;
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
        let net = fitted.net.valid();
        let (rows, whitening) = output::database_rows(cfg, &net, &cache, seq, staging, progress)?;
        let describe_s = t_desc.elapsed().as_secs_f64();
        let dim = cfg.backbone.descriptor_dim();
        // The sharp rows, then each zoom-blurred view of every frame: row i is frame i mod n.
        let views = 1 + cfg.index_zoom_blur.len();
        let db = DescriptorDatabase::from_rows(
            dim,
            zones.len(),
            rows,
            zones.zone_of_frame.repeat(views),
            (0..views).flat_map(|_| 0..seq.len()).collect(),
        )?;
        progress(&TrainProgress::outside_training(Phase::Saving, 0, 1));
        let source = ModelSource {
            cfg,
            seq,
            zones,
            camera,
            dataset,
            whitening,
            history: &fitted.history,
        };
        output::write_model(staging, &source, &net, &db)?;
        discard_checkpoint(&ckpt)?;
        model::publish(staging, &target.dir, target.force)?;
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
    })
}
