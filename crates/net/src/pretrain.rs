//! Pretraining on several colons at once: one network trained on the passes of every colon
//! together, its batches drawn from all of them.
//!
//! Training colon after colon, each from the previous one's weights, would let the last
//! colon's stage undo what the first ones taught. Instead every colon's training pass and
//! further passes (each frame at the place of its nearest training pose) go into one image
//! cache; colon `c`'s places are offset by `c ·` [`crate::pairs::COLON_PLACE_STRIDE`], so
//! track pairs never join frames of two colons as alike and draw each negative from its
//! partner's own colon, where the look-alikes are. Zones are each colon's own (offset
//! likewise), for zone pairs and for the held-out validation.
//!
//! The output is a folder like a model's, less what only a model of one pass has:
//! `weights.safetensors` (the start weights for [`crate::train::TrainConfig::pretrained`]),
//! `pretrain.toml` (the config and the colons), `history.csv` and `loss.png`.

use crate::NetError;
use crate::model;
use crate::pairs::COLON_PLACE_STRIDE;
use crate::plot;
use crate::train::{
    EpochRecord, ImageCache, Phase, TrainConfig, TrainProgress, TrainTarget, add_passes,
    checkpoint_dir, discard_checkpoint, fit,
};
use crate::view::ViewIntrinsics;
use crate::zones::{Zone, ZoneConfig, ZoneTable};
use burn::module::Module;
use endoloc_data::Sequence;
use endoloc_geometry::Camera;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// One colon of a joint pretraining: its training pass, further passes through it, and the
/// camera of all of them.
#[derive(Debug, Clone)]
pub struct PretrainColon {
    /// The training pass (places and zones come from its poses).
    pub train: Sequence,
    /// Further passes through the same colon (sequence folders), paired with the training
    /// pass by place.
    pub passes: Vec<PathBuf>,
    /// The camera of every pass of this colon.
    pub camera: Camera,
}

/// What a joint pretraining was, saved as `pretrain.toml` next to its weights.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PretrainRecord {
    /// The training settings (pairs, schedule, augmentation, start weights).
    pub train: TrainConfig,
    /// Zones of each colon's training pass.
    pub zones: ZoneConfig,
    /// Training pass of each colon, in order.
    pub colons: Vec<PathBuf>,
    /// Images of each colon (training pass and further passes).
    pub images: Vec<usize>,
}

/// The outcome of [`pretrain`].
#[derive(Debug, Clone, PartialEq)]
pub struct PretrainReport {
    /// The folder written.
    pub dir: PathBuf,
    /// Images of each colon that joined the training (training pass and further passes).
    pub images: Vec<usize>,
    /// Loss and validation per epoch.
    pub history: Vec<EpochRecord>,
    /// Wall-clock seconds: loading images.
    pub load_s: f64,
    /// Wall-clock seconds: optimisation (this run).
    pub train_s: f64,
    /// Steps taken in this run.
    pub steps: usize,
}

/// The images of several colons as one cache, with the places along each colon's training
/// pass offset by colon ([`COLON_PLACE_STRIDE`]), and their zones offset likewise.
///
/// # Errors
/// [`NetError::Config`] for no colon, colons of different cameras or a colon with more
/// frames than a stride holds; [`NetError::Data`] for unreadable images;
/// [`NetError::Zoning`] for a pass that cannot be zoned.
pub fn joint_cache(
    colons: &[PretrainColon],
    zones: &ZoneConfig,
    cfg: &TrainConfig,
    progress: &mut dyn FnMut(&TrainProgress),
) -> Result<(ImageCache, ZoneTable, Vec<usize>), NetError> {
    let Some(first) = colons.first() else {
        return Err(NetError::Config(
            "a pretraining needs at least one colon".into(),
        ));
    };
    let size = cfg.backbone.input();
    let mut joint = ImageCache::from_images(size, Vec::new());
    joint.view = Some(ViewIntrinsics::resized(
        &first.camera,
        size.width,
        size.height,
    ));
    let mut table = ZoneTable {
        config: *zones,
        zones: Vec::new(),
        zone_of_frame: Vec::new(),
        widened: Vec::new(),
    };
    let mut counts = Vec::with_capacity(colons.len());
    for (c, colon) in colons.iter().enumerate() {
        if colon.camera != first.camera {
            return Err(NetError::Config(format!(
                "colon {}: its camera differs from that of {} (one network input, one view \
                 augmentation: simulate every colon with the same camera)",
                colon.train.dir.display(),
                first.train.dir.display()
            )));
        }
        if colon.train.len() >= COLON_PLACE_STRIDE {
            return Err(NetError::Config(format!(
                "colon {}: {} frames, more than a colon's places hold",
                colon.train.dir.display(),
                colon.train.len()
            )));
        }
        let own_zones = ZoneTable::from_sequence(&colon.train, zones)?;
        let total = colon.train.len();
        let mut cache = ImageCache::from_sequence(&colon.train, size, &mut |done| {
            progress(&TrainProgress::outside_training(
                Phase::LoadingImages,
                done,
                total,
            ))
        })?;
        let (pass_zones, _) = add_passes(
            &mut cache,
            &own_zones,
            &colon.train,
            &colon.passes,
            &colon.camera,
            progress,
        )?;
        let place0 = c * COLON_PLACE_STRIDE;
        let zone0 = table.zones.len();
        let frame0 = table.zone_of_frame.len();
        joint.pixels.extend_from_slice(&cache.pixels);
        joint
            .along
            .extend((0..cache.len()).map(|i| place0 + cache.along_of(i)));
        table
            .zone_of_frame
            .extend(pass_zones.zone_of_frame.iter().map(|z| zone0 + z));
        table.zones.extend(own_zones.zones.iter().map(|z| Zone {
            index: zone0 + z.index,
            first_frame: frame0 + z.first_frame,
            last_frame: frame0 + z.last_frame,
            ..z.clone()
        }));
        counts.push(cache.len());
    }
    Ok((joint, table, counts))
}

/// Trains one network on every colon at once ([`joint_cache`]) and writes the start-weights
/// folder (module doc) atomically: everything goes to `DIR.partial/` (checkpoints in
/// `DIR.partial/checkpoint/`), renamed to `DIR` at the end; an interrupted run continues
/// with `target.resume`.
///
/// # Errors
/// [`NetError::AlreadyExists`] for an existing folder without `target.force`, or an
/// interrupted run without `resume`/`force`; everything [`joint_cache`] and [`fit`] return;
/// [`NetError::Io`] while writing.
pub fn pretrain(
    cfg: &TrainConfig,
    zones: &ZoneConfig,
    colons: &[PretrainColon],
    target: &TrainTarget,
    progress: &mut dyn FnMut(&TrainProgress),
) -> Result<PretrainReport, NetError> {
    cfg.validate()?;
    target.run(|staging| {
        let t_load = Instant::now();
        let (cache, table, images) = joint_cache(colons, zones, cfg, progress)?;
        let load_s = t_load.elapsed().as_secs_f64();
        let ckpt = checkpoint_dir(staging);
        let fitted = fit(
            cfg,
            &cache,
            &table,
            None,
            Some(&ckpt),
            target.resume,
            progress,
        )?;
        progress(&TrainProgress::outside_training(Phase::Saving, 0, 1));
        model::save_weights(&fitted.net.valid(), &staging.join(model::WEIGHTS_FILE))?;
        model::write_history(&staging.join(model::HISTORY_FILE), &fitted.history)?;
        plot::loss_curve_or_warn(&staging.join(model::LOSS_PNG), &fitted.history);
        let record = PretrainRecord {
            train: cfg.clone(),
            zones: *zones,
            colons: colons.iter().map(|c| c.train.dir.clone()).collect(),
            images: images.clone(),
        };
        let path = staging.join(PRETRAIN_FILE);
        let text = toml::to_string(&record).map_err(|e| NetError::Config(e.to_string()))?;
        std::fs::write(&path, text).map_err(|e| NetError::io(&path, e))?;
        discard_checkpoint(&ckpt)?;
        model::publish(staging, &target.dir, target.force)?;
        Ok(PretrainReport {
            dir: target.dir.clone(),
            images,
            history: fitted.history,
            load_s,
            train_s: fitted.train_s,
            steps: fitted.steps,
        })
    })
}

/// The record of a joint pretraining in its folder.
pub const PRETRAIN_FILE: &str = "pretrain.toml";
