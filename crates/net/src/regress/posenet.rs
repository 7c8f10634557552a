//! PoseNet (Kendall, Grimes & Cipolla 2015): a test image's pose regressed directly.
//!
//! The network is the zone classifier's backbone with a pose head ([`super::PoseHead`]);
//! it predicts the normalised position and the quaternion relative to the training set's
//! reference rotation ([`super::PoseNormalizer`]), trained with [`super::posenet_loss`].
//!
//! ```no_run
//! # fn main() -> Result<(), endoloc_net::NetError> {
//! use endoloc_net::regress::{PoseNetModel, RegressConfig, TrainingSet, train_posenet};
//! let ds = endoloc_data::Dataset::open(std::path::Path::new("data"))?;
//! let (seq, camera) = (ds.sequence("train")?, ds.meta.camera);
//! let cfg = RegressConfig::default();
//! let data = TrainingSet::from_sequence(&seq, &camera, cfg.backbone.input(), &mut |_| {})?;
//! let model = train_posenet(&cfg, &data, &mut |_| {})?;
//! model.save(std::path::Path::new("posenet"), false)?;
//! let pose = PoseNetModel::load(std::path::Path::new("posenet"))?.predict(&seq.load_gray(0)?)?;
//! # let _ = pose; Ok(()) }
//! ```

use super::batch::{
    clean_batch, draw_frames, images_tensor, query_batch, rows_tensor, split_holdout,
};
use super::config::RegressConfig;
use super::data::{TrainingSet, check_frame};
use super::fit::{RegressNetwork, fit, init_backbone};
use super::head::{PoseHead, scaled_features, tensor_rows};
use super::io::{RegressMethod, RegressModelFile};
use super::loss::posenet_loss;
use super::model::RegressModel;
use super::normalize::PoseNormalizer;
use super::progress::RegressProgress;
use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::preprocess::network_input;
use crate::train::ImageCache;
use crate::view::rotated_rotation;
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use endoloc_geometry::pose::pose_from_parts;
use endoloc_geometry::{Pose, orientation_error_deg, position_error_mm};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The PoseNet network: backbone → scaled descriptor → pose head.
#[derive(Module, Debug)]
pub struct PoseNetNet {
    /// The zone classifier's backbone.
    pub backbone: EmbeddingNet,
    /// Position + quaternion head.
    pub head: PoseHead,
}

impl RegressNetwork for PoseNetNet {
    const METHOD: RegressMethod = RegressMethod::Posenet;

    fn new(cfg: &RegressConfig, device: &Device) -> Result<Self, NetError> {
        Ok(PoseNetNet {
            backbone: init_backbone(cfg, device)?,
            head: PoseHead::new(cfg.backbone.descriptor_dim(), cfg.hidden, device),
        })
    }
}

impl PoseNetNet {
    /// Normalised positions and raw relative quaternions of a batch.
    ///
    /// # Shapes
    /// `[b, 1, h, w]` standardised images → (`[b, 3]`, `[b, 4]`)
    pub fn forward(&self, x: Tensor<4>) -> (Tensor<2>, Tensor<2>) {
        self.head.forward(scaled_features(self.backbone.forward(x)))
    }
}

/// A trained PoseNet (validation mode): loading and saving as every
/// [`RegressModel`], prediction below.
pub type PoseNetModel = RegressModel<PoseNetNet>;

impl PoseNetModel {
    /// The pose `T_wc` (mm) of one grey frame.
    ///
    /// # Errors
    /// [`NetError::Image`] for a frame of another size than the training frames.
    pub fn predict(&self, img: &image::GrayImage) -> Result<Pose, NetError> {
        self.predict_batch(std::slice::from_ref(img))?
            .pop()
            .ok_or_else(|| NetError::Config("no prediction".into()))
    }

    /// Poses `T_wc` (mm) of many frames (preprocessing on all cores, the network in batches).
    ///
    /// # Errors
    /// As [`PoseNetModel::predict`], for the first bad frame.
    pub fn predict_batch(&self, imgs: &[image::GrayImage]) -> Result<Vec<Pose>, NetError> {
        for (i, im) in imgs.iter().enumerate() {
            check_frame(
                im,
                self.file.frame_width,
                self.file.frame_height,
                &format!("query frame {i}"),
            )?;
        }
        let size = self.file.config.backbone.input();
        let mut out = Vec::with_capacity(imgs.len());
        for chunk in imgs.chunks(self.file.config.inference_batch.max(1)) {
            let px: Vec<f32> = chunk
                .par_iter()
                .flat_map_iter(|im| network_input(im, size))
                .collect();
            out.extend(predict_px(
                &self.net,
                &self.device,
                &self.file.normalizer,
                px,
                chunk.len(),
                size,
            ));
        }
        Ok(out)
    }
}

fn predict_px(
    net: &PoseNetNet,
    device: &Device,
    nz: &PoseNormalizer,
    px: Vec<f32>,
    n: usize,
    size: crate::preprocess::InputSize,
) -> Vec<Pose> {
    let (p, q) = net.forward(images_tensor(px, n, size, device));
    let (p, q) = (tensor_rows(p), tensor_rows(q));
    p.chunks_exact(3)
        .zip(q.chunks_exact(4))
        .map(|(x, q)| nz.pose_from_output(x, q))
        .collect()
}

/// Poses of cached frames (no augmentation).
fn predict_cached(
    net: &PoseNetNet,
    device: &Device,
    nz: &PoseNormalizer,
    cache: &ImageCache,
    frames: &[usize],
    batch: usize,
) -> Vec<Pose> {
    let mut out = Vec::with_capacity(frames.len());
    for chunk in frames.chunks(batch.max(1)) {
        let px = clean_batch(cache, chunk);
        out.extend(predict_px(net, device, nz, px, chunk.len(), cache.size));
    }
    out
}

/// Mean position (mm) and orientation (°) errors of `est` against `truth`.
pub(crate) fn mean_errors(est: &[Pose], truth: &[Pose]) -> (f64, f64) {
    let n = est.len().min(truth.len()).max(1) as f64;
    let p = est
        .iter()
        .zip(truth)
        .map(|(e, t)| position_error_mm(e, t))
        .sum::<f64>();
    let o = est
        .iter()
        .zip(truth)
        .map(|(e, t)| orientation_error_deg(e, t))
        .sum::<f64>();
    (p / n, o / n)
}

/// Trains PoseNet on `data` (every frame, or all but the held-out ones when
/// `cfg.holdout_every > 1`).
///
/// Each step draws `cfg.schedule.batch` training frames (without replacement within the
/// step), augments them ([`RegressConfig::augment`] photometric part, view turns with the label
/// turned too), and takes an Adam step on [`posenet_loss`]. Same seed and data → same weights.
///
/// # Errors
/// [`NetError::Config`] for a bad config or data (fewer than 2 frames, a cache at another
/// size than the backbone's input, non-finite poses); [`NetError::Weights`] for a bad
/// `init_backbone`; [`NetError::Diverged`] for a non-finite loss; [`NetError::Device`].
pub fn train_posenet(
    cfg: &RegressConfig,
    data: &TrainingSet,
    progress: &mut dyn FnMut(&RegressProgress),
) -> Result<PoseNetModel, NetError> {
    cfg.validate()?;
    data.check(cfg, 2)?;
    let base = crate::device::from_name(&cfg.device)?;
    let device = base.clone().autodiff();
    let (train_frames, held) = split_holdout(data.len(), cfg.holdout_every);
    let train_poses: Vec<Pose> = train_frames.iter().map(|&f| data.poses[f]).collect();
    let nz = PoseNormalizer::fit(&train_poses)?;
    let net = crate::device::seeded_init(&device, cfg.seed, |d| PoseNetNet::new(cfg, d))?;
    let size = data.images.size;
    let intrinsics = data.view_intrinsics();
    let batch_loss = |net: &PoseNetNet, b: usize, rng: &mut ChaCha8Rng| {
        let frames = draw_frames(&train_frames, b, rng);
        let (px, turns) = query_batch(&data.images, &frames, cfg, intrinsics.as_ref(), rng);
        let (xs, qs): (Vec<[f32; 3]>, Vec<[f32; 4]>) = frames
            .iter()
            .zip(&turns)
            .map(|(&f, turn)| {
                let p = &data.poses[f];
                nz.target(&pose_from_parts(
                    p.translation.vector,
                    rotated_rotation(&p.rotation, turn),
                ))
            })
            .unzip();
        let (x_hat, q_hat) = net.forward(images_tensor(px, frames.len(), size, &device));
        posenet_loss(
            x_hat,
            q_hat,
            rows_tensor(&xs, &device),
            rows_tensor(&qs, &device),
            cfg.beta,
        )
    };
    let held_errors = |net: &PoseNetNet| {
        let est = predict_cached(net, &base, &nz, &data.images, &held, cfg.inference_batch);
        let truth: Vec<Pose> = held.iter().map(|&f| data.poses[f]).collect();
        mean_errors(&est, &truth)
    };
    let (net, history) = fit(
        cfg,
        0x9E37_79B9_7F4A_7C15,
        net,
        !held.is_empty(),
        batch_loss,
        held_errors,
        progress,
    )?;
    let file = RegressModelFile::trained(RegressMethod::Posenet, data, nz, cfg, history);
    Ok(PoseNetModel {
        file,
        net,
        device: base,
    })
}
