//! Validation during training: which training frames are held out of the pairs
//! ([`Holdout`]) and the zone accuracy of the validation queries against a database of the
//! other training frames ([`Validation`]).

use super::data::{ImageCache, ValidationSet, describe_cached};
use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::database::DescriptorDatabase;
use crate::train_config::TrainConfig;
use crate::zones::ZoneTable;
use burn::tensor::Device;

/// The training frames held out of the pairs for validation: every `every`-th one (none when
/// `every ≤ 1`, or when a validation sequence is given).
#[derive(Debug, Clone, Copy)]
pub(super) struct Holdout {
    every: usize,
}

impl Holdout {
    pub(super) fn new(cfg: &TrainConfig, external_validation: bool) -> Self {
        Holdout {
            every: if external_validation {
                0
            } else {
                cfg.validation.holdout_every
            },
        }
    }

    pub(super) fn is_held(self, f: usize) -> bool {
        self.every > 1 && f % self.every == self.every / 2
    }
}

/// The validation of a run: query frames with truth zones, classified against a database of
/// training frames not held out.
pub(super) struct Validation<'a> {
    /// Images of the queries: the training cache (held-out frames) or the validation set's.
    images: &'a ImageCache,
    /// Query frames in `images`.
    queries: Vec<usize>,
    /// Truth zone of each query.
    truth: Vec<usize>,
    /// Database frames of the training cache: at most `max_database_frames`, evenly spaced.
    database: Vec<usize>,
}

impl<'a> Validation<'a> {
    pub(super) fn new(
        cfg: &TrainConfig,
        cache: &'a ImageCache,
        zones: &ZoneTable,
        external: Option<&'a ValidationSet>,
        holdout: Holdout,
    ) -> Self {
        let n = zones.frame_count();
        let (images, queries, truth) = match external {
            Some(v) => (&v.images, (0..v.images.len()).collect(), v.truth.clone()),
            None => {
                let held: Vec<usize> = (0..n).filter(|&f| holdout.is_held(f)).collect();
                let truth = held.iter().map(|&f| zones.zone_of_frame[f]).collect();
                (cache, held, truth)
            }
        };
        let pool: Vec<usize> = (0..n).filter(|&f| !holdout.is_held(f)).collect();
        let m = cfg.validation.max_database_frames.max(1);
        let database = if pool.len() <= m {
            pool
        } else {
            (0..m).map(|i| pool[i * pool.len() / m]).collect()
        };
        Validation {
            images,
            queries,
            truth,
            database,
        }
    }

    /// Whether to validate after 1-based `epoch`: every `every_epochs` epochs and after the
    /// last, when there are queries.
    pub(super) fn due(&self, cfg: &TrainConfig, epoch: usize, last: bool) -> bool {
        let every = cfg.validation.every_epochs;
        !self.queries.is_empty() && every > 0 && (epoch.is_multiple_of(every) || last)
    }

    /// Exact and ±1 zone accuracy (fractions) of the queries against the database frames,
    /// through `net` (validation mode).
    pub(super) fn accuracy(
        &self,
        net: &EmbeddingNet,
        device: &Device,
        cache: &ImageCache,
        zones: &ZoneTable,
        cfg: &TrainConfig,
    ) -> Result<(f32, f32), NetError> {
        let dim = cfg.backbone.descriptor_dim();
        let db_frames = &self.database;
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
            self.images,
            &self.queries,
            cfg.inference_batch,
            &mut |_| {},
        );
        let mut exact = 0;
        let mut near = 0;
        for (i, &truth) in self.truth.iter().enumerate().take(self.queries.len()) {
            let p = db.lookup(&q[i * dim..(i + 1) * dim], cfg.score)?;
            exact += usize::from(p.zone == truth);
            near += usize::from(p.zone.abs_diff(truth) <= 1);
        }
        let n = self.queries.len().max(1) as f32;
        Ok((exact as f32 / n, near as f32 / n))
    }
}
