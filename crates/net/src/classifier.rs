//! Inference: a loaded model folder that turns grey frames into descriptors and zones.
//!
//! ```no_run
//! # fn main() -> Result<(), endoloc_net::NetError> {
//! use endoloc_net::{TemporalFilter, ZoneClassifier};
//! let clf = ZoneClassifier::load(std::path::Path::new("model"))?;
//! let img = image::open("frame.png").map_err(|e| endoloc_net::NetError::Config(e.to_string()))?.into_luma8();
//! let p = clf.classify(&img)?;              // p.zone, p.zone_scores (distances: lower = better)
//! let mut f = TemporalFilter::new(clf.zone_count(), clf.config().temporal);
//! let smoothed = f.update(&p);
//! # let _ = smoothed; Ok(()) }
//! ```
//!
//! **Ensembles.** [`ZoneClassifier::join`] adds models trained on the same pass with the same
//! zones (say one with zone pairs, best per frame, and one with track pairs, best filtered): a
//! frame's descriptor becomes the concatenation of every model's unit descriptor, each scaled
//! by `1/√n`. It stays unit length, the squared distance to a training frame is the mean of the
//! models' squared distances, and every look-up, filter and the localizer work unchanged.

use crate::NetError;
use crate::backbone::{BackboneConfig, EmbeddingNet};
use crate::database::{DATABASE_FILE, DescriptorDatabase, ZonePrediction};
use crate::model::{self, ModelConfig};
use crate::preprocess::network_input;
use crate::whiten::{WHITENING_FILE, Whitening};
use crate::zones::{ZONES_FILE, ZoneTable};
use burn::module::Module;
use burn::tensor::Device;
use endoloc_geometry::{Camera, Pose};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// A trained zone classifier (validation mode, on the CPU unless asked otherwise): one model
/// folder, or several joined into an ensemble ([`ZoneClassifier::join`]).
pub struct ZoneClassifier {
    dir: PathBuf,
    config: ModelConfig,
    /// The networks whose descriptors are joined; one for a model folder.
    nets: Vec<Branch>,
    device: Device,
    zones: ZoneTable,
    database: DescriptorDatabase,
    train_poses: Vec<Pose>,
}

/// One network of a classifier, with what it needs to describe a frame.
struct Branch {
    dir: PathBuf,
    backbone: BackboneConfig,
    net: EmbeddingNet,
    /// Applied to the network's descriptors ([`crate::whiten`]), when the model has one.
    whitening: Option<Whitening>,
    batch: usize,
}

impl Branch {
    fn new(
        dir: PathBuf,
        config: &ModelConfig,
        net: EmbeddingNet,
        whitening: Option<Whitening>,
    ) -> Self {
        Branch {
            dir,
            backbone: config.backbone.clone(),
            net,
            whitening,
            batch: config.train.inference_batch.max(1),
        }
    }
}

impl std::fmt::Debug for ZoneClassifier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let nets: Vec<String> = self
            .nets
            .iter()
            .map(|b| format!("{} ({})", b.dir.display(), b.backbone.name()))
            .collect();
        f.debug_struct("ZoneClassifier")
            .field("nets", &nets)
            .field("zones", &self.zones.len())
            .field("frames", &self.database.frame_count())
            .finish()
    }
}

impl ZoneClassifier {
    /// Loads a model folder on the CPU.
    ///
    /// # Errors
    /// [`NetError::Io`] / [`NetError::Parse`] naming the missing or bad file,
    /// [`NetError::Weights`], and [`NetError::Incompatible`] when the files disagree (zone
    /// count, frame count, descriptor length).
    pub fn load(dir: &Path) -> Result<Self, NetError> {
        Self::load_on(dir, "cpu")
    }

    /// Loads a model folder on the named device ([`crate::device::from_name`]).
    ///
    /// # Errors
    /// As [`ZoneClassifier::load`], and [`NetError::Device`].
    pub fn load_on(dir: &Path, device: &str) -> Result<Self, NetError> {
        let config = ModelConfig::load(dir)?;
        config.backbone.validate()?;
        let device = crate::device::from_name(device)?;
        let zones = ZoneTable::load(&dir.join(ZONES_FILE))?;
        let database = DescriptorDatabase::load(&dir.join(DATABASE_FILE), zones.len())?
            .with_view_penalty(config.train.index_view_penalty as f32);
        let incompatible = |m: String| NetError::Incompatible {
            model: dir.to_path_buf(),
            message: m,
        };
        if let Some(recorded) = config.provenance.as_ref().map(|p| &p.zones) {
            let found = model::file_fingerprint(&dir.join(ZONES_FILE))?;
            if &found != recorded {
                return Err(incompatible(format!(
                    "{ZONES_FILE} has fingerprint {found} but model.toml records {recorded}: \
                     the zone table was replaced or edited after training; put the model's own \
                     {ZONES_FILE} back or train again"
                )));
            }
        }
        if database.dim != config.backbone.descriptor_dim() {
            return Err(incompatible(format!(
                "{DATABASE_FILE} holds descriptors of length {} but the backbone makes {}",
                database.dim,
                config.backbone.descriptor_dim()
            )));
        }
        if database.frame_count() != zones.frame_count() || database.frame_count() != config.frames
        {
            return Err(incompatible(format!(
                "{DATABASE_FILE} has rows of {} frames, {ZONES_FILE} covers {} frames, model.toml says {}",
                database.frame_count(),
                zones.frame_count(),
                config.frames
            )));
        }
        if let Some((r, f)) = database
            .frame_of_row
            .iter()
            .enumerate()
            .find(|&(r, &f)| database.zone_of_row[r] != zones.zone_of_frame[f])
        {
            return Err(incompatible(format!(
                "{DATABASE_FILE}: row {r} (training frame {f}) is in zone {}, {ZONES_FILE} puts the frame in zone {}",
                database.zone_of_row[r], zones.zone_of_frame[*f]
            )));
        }
        let poses_path = dir.join(model::POSES_FILE);
        let train_poses: Vec<Pose> = endoloc_data::read_tum(&poses_path)?
            .into_iter()
            .map(|p| p.pose)
            .collect();
        if train_poses.len() != config.frames {
            return Err(incompatible(format!(
                "{} has {} poses; model.toml says {} frames",
                model::POSES_FILE,
                train_poses.len(),
                config.frames
            )));
        }
        let net =
            model::load_weights(&config.backbone, &dir.join(model::WEIGHTS_FILE), &device)?.valid();
        let whitening = match config.whitening {
            Some(_) => Some(Whitening::load(
                &dir.join(WHITENING_FILE),
                config.backbone.descriptor_dim(),
            )?),
            None => None,
        };
        Ok(ZoneClassifier {
            dir: dir.to_path_buf(),
            nets: vec![Branch::new(dir.to_path_buf(), &config, net, whitening)],
            config,
            device,
            zones,
            database,
            train_poses,
        })
    }

    /// A classifier from its parts (a model not read from disk: tests, benchmarks, a network
    /// trained in memory). `net` should be in validation mode (`net.valid()`); `whitening`,
    /// when given, is applied to its descriptors (the database rows are taken as they are:
    /// whitened already).
    ///
    /// # Errors
    /// [`NetError::Incompatible`] when the parts disagree (descriptor length, frame or zone
    /// counts, a whitening of another length).
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        dir: PathBuf,
        config: ModelConfig,
        net: EmbeddingNet,
        whitening: Option<Whitening>,
        device: Device,
        zones: ZoneTable,
        database: DescriptorDatabase,
        train_poses: Vec<Pose>,
    ) -> Result<Self, NetError> {
        if whitening
            .as_ref()
            .is_some_and(|w| w.dim != config.backbone.descriptor_dim())
            || database.dim != config.backbone.descriptor_dim()
            || database.frame_count() != zones.frame_count()
            || train_poses.len() != zones.frame_count()
            || database.zones != zones.len()
        {
            return Err(NetError::Incompatible {
                model: dir,
                message: format!(
                    "parts disagree: database rows of {} frames of {} ({} zones), {} zones over {} frames, {} poses, descriptor length {}, whitening length {}",
                    database.frame_count(),
                    database.dim,
                    database.zones,
                    zones.len(),
                    zones.frame_count(),
                    train_poses.len(),
                    config.backbone.descriptor_dim(),
                    whitening
                        .as_ref()
                        .map_or("none".to_string(), |w| w.dim.to_string())
                ),
            });
        }
        Ok(ZoneClassifier {
            nets: vec![Branch::new(dir.clone(), &config, net, whitening)],
            dir,
            config,
            device,
            zones,
            database,
            train_poses,
        })
    }

    /// An ensemble of this classifier and `others`, trained on the same pass with the same
    /// zones: descriptors and database rows are the concatenation of every network's unit
    /// descriptor scaled by `1/√n` (see the module docs). This classifier's configuration
    /// (camera, score rule, filter parameters), folder and maps are the ensemble's.
    ///
    /// # Errors
    /// [`NetError::Incompatible`] naming the model that differs: another zone table, other
    /// training poses, other database rows, another image size or device.
    pub fn join(mut self, others: Vec<ZoneClassifier>) -> Result<Self, NetError> {
        if others.is_empty() {
            return Ok(self);
        }
        for other in &others {
            self.check_joinable(other)?;
        }
        let n_old = self.nets.len() as f32;
        let n_new = n_old + others.iter().map(|o| o.nets.len() as f32).sum::<f32>();
        // Rows of each part are already scaled by 1/√(its nets); rescale to 1/√(all nets).
        let parts: Vec<(&DescriptorDatabase, f32)> = std::iter::once(&self.database)
            .map(|d| (d, (n_old / n_new).sqrt()))
            .chain(
                others
                    .iter()
                    .map(|o| (&o.database, (o.nets.len() as f32 / n_new).sqrt())),
            )
            .collect();
        let dim: usize = parts.iter().map(|(d, _)| d.dim).sum();
        let mut rows = Vec::with_capacity(dim * self.database.len());
        for r in 0..self.database.len() {
            for (db, scale) in &parts {
                let row = &db.descriptors[r * db.dim..(r + 1) * db.dim];
                rows.extend(row.iter().map(|v| v * scale));
            }
        }
        self.database = DescriptorDatabase::from_rows(
            dim,
            self.database.zones,
            rows,
            self.database.zone_of_row.clone(),
            self.database.frame_of_row.clone(),
        )?
        .with_view_penalty(self.database.view_penalty);
        for other in others {
            self.nets.extend(other.nets);
        }
        Ok(self)
    }

    fn check_joinable(&self, other: &ZoneClassifier) -> Result<(), NetError> {
        let differs = |what: &str| NetError::Incompatible {
            model: other.dir.clone(),
            message: format!(
                "cannot join it to {}: {what} differ (an ensemble needs models trained on the same pass with the same zones)",
                self.dir.display()
            ),
        };
        if other.zones.zone_of_frame != self.zones.zone_of_frame {
            return Err(differs("the zone tables"));
        }
        let same_pose = |a: &Pose, b: &Pose| {
            endoloc_geometry::position_error_mm(a, b) < 1e-6
                && endoloc_geometry::orientation_error_deg(a, b) < 1e-6
        };
        if other.train_poses.len() != self.train_poses.len()
            || !other
                .train_poses
                .iter()
                .zip(&self.train_poses)
                .all(|(a, b)| same_pose(a, b))
        {
            return Err(differs("the training poses"));
        }
        if other.database.frame_of_row != self.database.frame_of_row {
            return Err(differs(
                "the rows of the descriptor databases (their training frames, or zoom-blurred views of them in one only)",
            ));
        }
        let (a, b) = (&self.config.camera, &other.config.camera);
        if (a.width, a.height) != (b.width, b.height) {
            return Err(differs("the image sizes"));
        }
        if other.device != self.device {
            return Err(differs("the devices"));
        }
        Ok(())
    }

    /// Number of networks: 1 for a model folder, more for an ensemble.
    pub fn net_count(&self) -> usize {
        self.nets.len()
    }

    /// The model's `model.toml`.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }

    /// The zone table.
    pub fn zones(&self) -> &ZoneTable {
        &self.zones
    }

    /// Number of zones.
    pub fn zone_count(&self) -> usize {
        self.zones.len()
    }

    /// The descriptor database (one row per training frame).
    pub fn database(&self) -> &DescriptorDatabase {
        &self.database
    }

    /// The training poses (`T_wc`, mm), in frame order.
    pub fn train_poses(&self) -> &[Pose] {
        &self.train_poses
    }

    /// The model folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Checks that images from `camera` fit this model: same image size, and focal lengths
    /// and principal point within 2 %.
    ///
    /// # Errors
    /// [`NetError::Incompatible`] naming both values.
    pub fn check_compatible(&self, camera: &Camera) -> Result<(), NetError> {
        let m = &self.config.camera;
        let err = |msg: String| NetError::Incompatible {
            model: self.dir.clone(),
            message: msg,
        };
        if camera.width != m.width || camera.height != m.height {
            return Err(err(format!(
                "images are {}x{} but the model was trained on {}x{} images",
                camera.width, camera.height, m.width, m.height
            )));
        }
        let close = |a: f64, b: f64| (a - b).abs() <= 0.02 * b.abs().max(1.0);
        if !(close(camera.fx, m.fx)
            && close(camera.fy, m.fy)
            && close(camera.cx, m.cx)
            && close(camera.cy, m.cy))
        {
            return Err(err(format!(
                "another camera: fx {:.1} fy {:.1} cx {:.1} cy {:.1}, the model's is fx {:.1} fy {:.1} cx {:.1} cy {:.1}",
                camera.fx, camera.fy, camera.cx, camera.cy, m.fx, m.fy, m.cx, m.cy
            )));
        }
        Ok(())
    }

    /// Checks that `dataset` is the one this model was trained on, when the dataset holds the
    /// model's training sequence: its poses must have the fingerprint recorded in
    /// `model.toml`. A dataset without that sequence (a test pass recorded on its own), and a
    /// model written before fingerprints existed, are not checked.
    ///
    /// # Errors
    /// [`NetError::Incompatible`] saying what differs (frame counts and fingerprints) and
    /// what to do; [`NetError::Data`] when the training sequence's poses cannot be read.
    pub fn check_dataset(&self, dataset: &endoloc_data::Dataset) -> Result<(), NetError> {
        let Some(provenance) = &self.config.provenance else {
            return Ok(());
        };
        let name = &self.config.sequence;
        if !dataset.sequences.iter().any(|s| s == name) {
            return Ok(());
        }
        let poses_path = dataset.root.join(name).join("poses.txt");
        let poses = endoloc_data::read_tum(&poses_path)?;
        let found = endoloc_data::poses_fingerprint(&poses);
        if found == provenance.train_poses {
            return Ok(());
        }
        Err(NetError::Incompatible {
            model: self.dir.clone(),
            message: format!(
                "the model was trained on dataset '{}' ({} '{name}' frames, poses fingerprint {}), \
                 but {} holds '{}' with {} '{name}' frames, poses fingerprint {found}: \
                 train a model on this dataset, or give the matching model",
                self.config.dataset,
                self.config.frames,
                provenance.train_poses,
                poses_path.display(),
                dataset.meta.name,
                poses.len(),
            ),
        })
    }

    /// Checks that `img` has the size of the training images.
    ///
    /// # Errors
    /// [`NetError::Incompatible`] naming both sizes.
    pub fn check_image(&self, img: &image::GrayImage) -> Result<(), NetError> {
        let m = &self.config.camera;
        if img.width() != m.width || img.height() != m.height {
            return Err(NetError::Incompatible {
                model: self.dir.clone(),
                message: format!(
                    "image is {}x{} but the model was trained on {}x{} images",
                    img.width(),
                    img.height(),
                    m.width,
                    m.height
                ),
            });
        }
        Ok(())
    }

    /// The descriptor of one grey frame (resized and standardised inside; unit length).
    ///
    /// # Errors
    /// [`NetError::Incompatible`] for an image of another size than the training images.
    pub fn describe(&self, img: &image::GrayImage) -> Result<Vec<f32>, NetError> {
        Ok(self
            .describe_batch(std::slice::from_ref(img))?
            .pop()
            .unwrap_or_default())
    }

    /// Descriptors of many frames: preprocessing on all cores, the network in batches (every
    /// network of an ensemble, joined).
    ///
    /// # Errors
    /// As [`ZoneClassifier::describe`], for the first bad image.
    pub fn describe_batch(&self, imgs: &[image::GrayImage]) -> Result<Vec<Vec<f32>>, NetError> {
        for im in imgs {
            self.check_image(im)?;
        }
        Ok(self.describe_with(imgs.len(), |branch, range| {
            let size = branch.backbone.input();
            imgs[range]
                .par_iter()
                .flat_map_iter(|im| network_input(im, size))
                .collect()
        }))
    }

    /// Descriptors of network inputs already prepared at the model's input size (resized,
    /// standardised, e.g. by [`crate::preprocess::network_input`] and then warped), in batches.
    ///
    /// # Errors
    /// [`NetError::Incompatible`] for an input of another length than the model's input, or
    /// an ensemble whose networks take inputs of different sizes.
    pub fn describe_inputs(&self, inputs: &[Vec<f32>]) -> Result<Vec<Vec<f32>>, NetError> {
        let incompatible = |message: String| NetError::Incompatible {
            model: self.dir.clone(),
            message,
        };
        let size = self.config.backbone.input();
        if let Some(b) = self.nets.iter().find(|b| b.backbone.input() != size) {
            return Err(incompatible(format!(
                "the ensemble's networks take inputs of {size} and {} ({}): prepare images with describe_batch",
                b.backbone.input(),
                b.dir.display()
            )));
        }
        if let Some(bad) = inputs.iter().find(|v| v.len() != size.pixels()) {
            return Err(incompatible(format!(
                "network input of {} values; the model takes {size} = {} values",
                bad.len(),
                size.pixels()
            )));
        }
        Ok(self.describe_with(inputs.len(), |_, range| {
            inputs[range].iter().flatten().copied().collect()
        }))
    }

    /// Runs every network over `n` items in batches; `input(branch, range)` gives the
    /// network input of items `range`. Joins the descriptors, each scaled by `1/√nets`.
    fn describe_with(
        &self,
        n: usize,
        input: impl Fn(&Branch, std::ops::Range<usize>) -> Vec<f32>,
    ) -> Vec<Vec<f32>> {
        let scale = 1.0 / (self.nets.len() as f32).sqrt();
        let mut out = vec![Vec::with_capacity(self.database.dim); n];
        for branch in &self.nets {
            let size = branch.backbone.input();
            let dim = branch.backbone.descriptor_dim();
            for start in (0..n).step_by(branch.batch) {
                let range = start..(start + branch.batch).min(n);
                let len = range.len();
                let buf = input(branch, range);
                let mut v = crate::train::forward_values(&branch.net, &self.device, buf, len, size);
                if let Some(w) = &branch.whitening {
                    v = w.apply_rows(&v);
                }
                for (row, d) in out[start..].iter_mut().zip(v.chunks_exact(dim)) {
                    if self.nets.len() == 1 {
                        row.extend_from_slice(d);
                    } else {
                        row.extend(d.iter().map(|x| x * scale));
                    }
                }
            }
        }
        out
    }

    /// The zone of a descriptor (the model's score rule).
    ///
    /// # Errors
    /// [`NetError::Config`] for a descriptor of the wrong length.
    pub fn lookup(&self, descriptor: &[f32]) -> Result<ZonePrediction, NetError> {
        self.database.lookup(descriptor, self.config.score)
    }

    /// Distance from a descriptor to every training frame of the zone table (`∞` for frames
    /// without a descriptor): the evidence of the track filter ([`crate::track`]).
    ///
    /// # Errors
    /// [`NetError::Config`] for a descriptor of the wrong length.
    pub fn frame_distances(&self, descriptor: &[f32]) -> Result<Vec<f32>, NetError> {
        let mut d = self.database.frame_distances(descriptor)?;
        d.resize(self.zones.frame_count(), f32::INFINITY);
        Ok(d)
    }

    /// A track filter over the training frames with the model's parameters.
    ///
    /// # Errors
    /// [`NetError::Config`] for bad parameters.
    pub fn track_filter(&self) -> Result<crate::TrackFilter, NetError> {
        crate::TrackFilter::new(self.zones.zone_of_frame.clone(), self.config.track)
    }

    /// The zone of one frame.
    ///
    /// # Errors
    /// As [`ZoneClassifier::describe`].
    pub fn classify(&self, img: &image::GrayImage) -> Result<ZonePrediction, NetError> {
        self.lookup(&self.describe(img)?)
    }

    /// Zones of many frames (descriptors in batches, look-ups in parallel).
    ///
    /// # Errors
    /// As [`ZoneClassifier::describe_batch`].
    pub fn classify_batch(
        &self,
        imgs: &[image::GrayImage],
    ) -> Result<Vec<ZonePrediction>, NetError> {
        let d = self.describe_batch(imgs)?;
        d.par_iter().map(|q| self.lookup(q)).collect()
    }

    /// The training frame nearest to a pose ([`crate::zones::nearest_frame`], default
    /// weighting): where the track filter is anchored when a pose is known.
    pub fn nearest_train_frame(&self, pose: &Pose) -> Option<usize> {
        crate::zones::nearest_frame(
            &self.train_poses,
            pose,
            crate::zones::TRUTH_ANGLE_WEIGHT_MM_PER_DEG,
        )
    }

    /// The ground-truth zone of a pose from another pass ([`ZoneTable::truth_zone`] against
    /// the training poses, default weighting).
    pub fn truth_zone(&self, pose: &Pose) -> Option<usize> {
        self.zones.truth_zone(
            &self.train_poses,
            pose,
            crate::zones::TRUTH_ANGLE_WEIGHT_MM_PER_DEG,
        )
    }
}
