//! The model folder of a fitted network: the descriptors of every training frame (whitened
//! and smoothed along the pass when configured) as its database, its files written by
//! [`crate::model`] and its loss curve drawn by [`crate::plot`].

use super::data::{ImageCache, describe_cached_with};
use super::progress::{Phase, TrainProgress};
use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::database::{DescriptorDatabase, smooth_along_pass};
use crate::history::EpochRecord;
use crate::model::{self, ModelConfig};
use crate::plot;
use crate::temporal::TemporalConfig;
use crate::train_config::TrainConfig;
use crate::whiten::{WHITENING_FILE, Whitening};
use crate::zones::{ZoneTable, cumulative_path_mm};
use crate::zoom_blur::zoom_blur;
use endoloc_data::Sequence;
use endoloc_geometry::Camera;
use std::path::Path;

/// Database rows of the training frames of `seq` (the first `seq.len()` images of `cache`)
/// through `net` (validation mode): whitened with power `cfg.whitening` (the whitening
/// written to `staging/whitening.bin`) and smoothed along the pass over
/// `cfg.database_smoothing_mm`; then, for each amplitude of `cfg.index_zoom_blur`, the rows of
/// the frames zoom-blurred by it ([`crate::zoom_blur`]), whitened with the same whitening and
/// smoothed alike. Returns the rows (`(1 + amplitudes) × frames`, the sharp ones first) and
/// the whitening power, if any.
///
/// # Errors
/// [`NetError::Device`] for a bad device name; whitening errors; [`NetError::Io`].
pub(crate) fn database_rows(
    cfg: &TrainConfig,
    net: &EmbeddingNet,
    cache: &ImageCache,
    seq: &Sequence,
    staging: &Path,
    progress: &mut dyn FnMut(&TrainProgress),
) -> Result<(Vec<f32>, Option<f32>), NetError> {
    let base = crate::device::from_name(&cfg.device)?;
    let n = seq.len();
    let frames: Vec<usize> = (0..n).collect();
    let total = n * (1 + cfg.index_zoom_blur.len());
    let size = cache.size;
    // The principal point at the network's input size (the image centre without a camera).
    let centre = cache.view.as_ref().map_or(
        (
            (f64::from(size.width) - 1.0) / 2.0,
            (f64::from(size.height) - 1.0) / 2.0,
        ),
        |v| (v.cx, v.cy),
    );
    let mut describe = |amplitude: f64, view: usize| {
        describe_cached_with(
            net,
            &base,
            cache,
            &frames,
            cfg.inference_batch,
            |img| {
                zoom_blur(
                    img,
                    size.width as usize,
                    size.height as usize,
                    centre,
                    amplitude,
                )
            },
            &mut |done| {
                progress(&TrainProgress::outside_training(
                    Phase::Describing,
                    view * n + done,
                    total,
                ))
            },
        )
    };
    let sharp = describe(0.0, 0);
    let blurred: Vec<Vec<f32>> = cfg
        .index_zoom_blur
        .iter()
        .enumerate()
        .map(|(k, &a)| describe(a, k + 1))
        .collect();
    let dim = cfg.backbone.descriptor_dim();
    let whitening = if cfg.whitening > 0.0 {
        let w = Whitening::fit(&sharp, dim, cfg.whitening)?;
        w.save(&staging.join(WHITENING_FILE))?;
        Some(w)
    } else {
        None
    };
    let path_mm = cumulative_path_mm(&seq.poses.iter().map(|p| p.pose).collect::<Vec<_>>());
    let mut rows = Vec::with_capacity(total * dim);
    for view in std::iter::once(&sharp).chain(&blurred) {
        let whitened = whitening.as_ref().map(|w| w.apply_rows(view));
        rows.extend(smooth_along_pass(
            whitened.as_deref().unwrap_or(view),
            dim,
            &path_mm,
            cfg.database_smoothing_mm,
        ));
    }
    Ok((rows, whitening.map(|_| cfg.whitening)))
}

/// What a model folder holds besides its network and database.
pub(crate) struct ModelSource<'a> {
    /// The training run's settings.
    pub cfg: &'a TrainConfig,
    /// The training sequence.
    pub seq: &'a Sequence,
    /// Its zones.
    pub zones: &'a ZoneTable,
    /// Its camera.
    pub camera: &'a Camera,
    /// The dataset's name.
    pub dataset: &'a str,
    /// Power of the database's whitening, if whitened.
    pub whitening: Option<f32>,
    /// Loss and validation per epoch.
    pub history: &'a [EpochRecord],
}

/// Writes every file of the model folder `staging` ([`crate::model`]) and its loss curve.
///
/// # Errors
/// As [`model::write_model_files`].
pub(crate) fn write_model(
    staging: &Path,
    src: &ModelSource<'_>,
    net: &EmbeddingNet,
    db: &DescriptorDatabase,
) -> Result<(), NetError> {
    let cfg = src.cfg;
    let model_cfg = ModelConfig {
        format_version: model::FORMAT_VERSION,
        backbone: cfg.backbone.clone(),
        score: cfg.score,
        temporal: TemporalConfig::default(),
        track: Default::default(),
        whitening: src.whitening,
        camera: *src.camera,
        dataset: src.dataset.to_string(),
        sequence: src.seq.name.clone(),
        frames: src.seq.len(),
        zones: src.zones.config,
        train: cfg.clone(),
        provenance: None,
    };
    model::write_model_files(
        staging,
        &model_cfg,
        net,
        src.zones,
        db,
        src.seq,
        src.history,
    )?;
    plot::loss_curve_or_warn(&staging.join(model::LOSS_PNG), src.history);
    Ok(())
}
