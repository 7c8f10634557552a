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

use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::database::{DATABASE_FILE, DescriptorDatabase, ZonePrediction};
use crate::model::{self, ModelConfig};
use crate::preprocess::network_input;
use crate::zones::{ZONES_FILE, ZoneTable};
use burn::module::Module;
use burn::tensor::Device;
use endoloc_geometry::{Camera, Pose};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// A trained zone classifier (validation mode, on the CPU unless asked otherwise).
pub struct ZoneClassifier {
    dir: PathBuf,
    config: ModelConfig,
    net: EmbeddingNet,
    device: Device,
    zones: ZoneTable,
    database: DescriptorDatabase,
    train_poses: Vec<Pose>,
    batch: usize,
}

impl std::fmt::Debug for ZoneClassifier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZoneClassifier")
            .field("dir", &self.dir)
            .field("backbone", &self.config.backbone.name())
            .field("zones", &self.zones.len())
            .field("frames", &self.database.len())
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
        let database = DescriptorDatabase::load(&dir.join(DATABASE_FILE), zones.len())?;
        let incompatible = |m: String| NetError::Incompatible {
            model: dir.to_path_buf(),
            message: m,
        };
        if database.dim != config.backbone.descriptor_dim() {
            return Err(incompatible(format!(
                "{DATABASE_FILE} holds descriptors of length {} but the backbone makes {}",
                database.dim,
                config.backbone.descriptor_dim()
            )));
        }
        if database.len() != zones.frame_count() || database.len() != config.frames {
            return Err(incompatible(format!(
                "{DATABASE_FILE} has {} rows, {ZONES_FILE} covers {} frames, model.toml says {}",
                database.len(),
                zones.frame_count(),
                config.frames
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
        let batch = config.train.inference_batch.max(1);
        Ok(ZoneClassifier {
            dir: dir.to_path_buf(),
            config,
            net,
            device,
            zones,
            database,
            train_poses,
            batch,
        })
    }

    /// A classifier from its parts (a model not read from disk: tests, benchmarks, a network
    /// trained in memory). `net` should be in validation mode (`net.valid()`).
    ///
    /// # Errors
    /// [`NetError::Incompatible`] when the parts disagree (descriptor length, frame or zone
    /// counts).
    pub fn from_parts(
        dir: PathBuf,
        config: ModelConfig,
        net: EmbeddingNet,
        device: Device,
        zones: ZoneTable,
        database: DescriptorDatabase,
        train_poses: Vec<Pose>,
    ) -> Result<Self, NetError> {
        if database.dim != config.backbone.descriptor_dim()
            || database.len() != zones.frame_count()
            || train_poses.len() != zones.frame_count()
            || database.zones != zones.len()
        {
            return Err(NetError::Incompatible {
                model: dir,
                message: format!(
                    "parts disagree: database {} rows of {} ({} zones), {} zones over {} frames, {} poses, descriptor length {}",
                    database.len(),
                    database.dim,
                    database.zones,
                    zones.len(),
                    zones.frame_count(),
                    train_poses.len(),
                    config.backbone.descriptor_dim()
                ),
            });
        }
        let batch = config.train.inference_batch.max(1);
        Ok(ZoneClassifier {
            dir,
            config,
            net,
            device,
            zones,
            database,
            train_poses,
            batch,
        })
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

    fn check_image(&self, img: &image::GrayImage) -> Result<(), NetError> {
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

    /// Descriptors of many frames: preprocessing on all cores, the network in batches.
    ///
    /// # Errors
    /// As [`ZoneClassifier::describe`], for the first bad image.
    pub fn describe_batch(&self, imgs: &[image::GrayImage]) -> Result<Vec<Vec<f32>>, NetError> {
        for im in imgs {
            self.check_image(im)?;
        }
        let size = self.config.backbone.input();
        let dim = self.config.backbone.descriptor_dim();
        let mut out = Vec::with_capacity(imgs.len());
        for chunk in imgs.chunks(self.batch) {
            let buf: Vec<f32> = chunk
                .par_iter()
                .flat_map_iter(|im| network_input(im, size))
                .collect();
            let v = crate::train::forward_values(&self.net, &self.device, buf, chunk.len(), size);
            out.extend(v.chunks_exact(dim).map(<[f32]>::to_vec));
        }
        Ok(out)
    }

    /// Descriptors of network inputs already prepared at the model's input size (resized,
    /// standardised, e.g. by [`crate::preprocess::network_input`] and then warped), in batches.
    ///
    /// # Errors
    /// [`NetError::Incompatible`] for an input of another length than the model's input.
    pub fn describe_inputs(&self, inputs: &[Vec<f32>]) -> Result<Vec<Vec<f32>>, NetError> {
        let size = self.config.backbone.input();
        if let Some(bad) = inputs.iter().find(|v| v.len() != size.pixels()) {
            return Err(NetError::Incompatible {
                model: self.dir.clone(),
                message: format!(
                    "network input of {} values; the model takes {size} = {} values",
                    bad.len(),
                    size.pixels()
                ),
            });
        }
        let dim = self.config.backbone.descriptor_dim();
        let mut out = Vec::with_capacity(inputs.len());
        for chunk in inputs.chunks(self.batch) {
            let buf: Vec<f32> = chunk.iter().flatten().copied().collect();
            let v = crate::train::forward_values(&self.net, &self.device, buf, chunk.len(), size);
            out.extend(v.chunks_exact(dim).map(<[f32]>::to_vec));
        }
        Ok(out)
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
