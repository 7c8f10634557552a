//! OffsetNet (Sganga, Eng, Graetzel & Camarillo 2018): the relative pose from a reference
//! image, whose pose is known, to the test image; the test pose is `T_ref ∘ offset`.
//!
//! Network: two branches sharing the zone classifier's backbone; the scaled descriptors of
//! the reference `f_r` and of the query `f_q` are concatenated as `[f_r, f_q, f_q − f_r]` and a
//! pose head ([`super::PoseHead`]) regresses the offset `T_ref⁻¹ · T_query` — its translation
//! in the reference camera's frame (mm, normalised by the training offsets' mean and RMS) and
//! its rotation quaternion (relative to the training offsets' mean rotation, `w ≥ 0`) — with
//! the PoseNet loss ([`super::posenet_loss`]).
//!
//! Training pairs: a training frame `i` as the reference (not augmented, as a retrieved
//! training image is at test time) and a frame `j` with `|i − j| ≤ pair_reach_frames` as the
//! query (photometric and view augmentation, its label turned too).
//!
//! Inference: the caller retrieves the reference. The intended reference is the training frame
//! whose Siamese descriptor is nearest to the test image's,
//! [`crate::ZonePrediction::nearest_frame`]: it is the training view that looks most like the
//! test image, hence the smallest offset and the closest to the training pairs; a fixed zone
//! reference (e.g. the zone's middle frame) can be up to half a zone away.

use super::batch::{
    clean_batch, draw_frames, images_tensor, is_held, query_batch, rows_tensor, split_holdout,
};
use super::config::RegressConfig;
use super::data::{TrainingSet, check_frame};
use super::fit::{RegressNetwork, fit, init_backbone};
use super::head::{PoseHead, scaled_features, tensor_rows};
use super::io::{RegressMethod, RegressModelFile};
use super::loss::posenet_loss;
use super::model::RegressModel;
use super::normalize::PoseNormalizer;
use super::posenet::mean_errors;
use super::progress::RegressProgress;
use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::preprocess::{InputSize, network_input};
use crate::view::rotated_rotation;
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use endoloc_geometry::Pose;
use endoloc_geometry::pose::pose_from_parts;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The relative pose `T_ref⁻¹ · T_query` (the query camera in the reference camera's frame,
/// mm).
pub fn offset_between(t_ref: &Pose, t_query: &Pose) -> Pose {
    t_ref.inverse() * t_query
}

/// The query pose from the reference pose and the offset: `T_ref ∘ offset` (`T_wc`, mm).
pub fn compose(t_ref: &Pose, offset: &Pose) -> Pose {
    t_ref * offset
}

/// The OffsetNet network: a shared backbone for both images and a pose head on the
/// concatenated features.
#[derive(Module, Debug)]
pub struct OffsetNetNet {
    /// The zone classifier's backbone (both branches).
    pub backbone: EmbeddingNet,
    /// Offset head on `[f_ref, f_query, f_query − f_ref]`.
    pub head: PoseHead,
}

impl RegressNetwork for OffsetNetNet {
    const METHOD: RegressMethod = RegressMethod::Offsetnet;

    fn new(cfg: &RegressConfig, device: &Device) -> Result<Self, NetError> {
        Ok(OffsetNetNet {
            backbone: init_backbone(cfg, device)?,
            head: PoseHead::new(3 * cfg.backbone.descriptor_dim(), cfg.hidden, device),
        })
    }
}

impl OffsetNetNet {
    /// Normalised offset translations and raw relative quaternions of a batch of pairs.
    ///
    /// # Shapes
    /// `reference`, `query`: `[b, 1, h, w]` standardised images → (`[b, 3]`, `[b, 4]`)
    pub fn forward(&self, reference: Tensor<4>, query: Tensor<4>) -> (Tensor<2>, Tensor<2>) {
        let b = reference.dims()[0];
        let f = scaled_features(
            self.backbone
                .forward(Tensor::cat(vec![reference, query], 0)),
        );
        let fr = f.clone().narrow(0, 0, b);
        let fq = f.narrow(0, b, b);
        let diff = fq.clone() - fr.clone();
        self.head.forward(Tensor::cat(vec![fr, fq, diff], 1))
    }
}

/// A trained OffsetNet (validation mode): loading and saving as every
/// [`RegressModel`], prediction below.
pub type OffsetNetModel = RegressModel<OffsetNetNet>;

impl OffsetNetModel {
    /// The pose `T_wc` (mm) of the test frame `img` from a reference frame and its pose:
    /// `t_ref ∘ offset(reference → img)`.
    ///
    /// # Errors
    /// [`NetError::Image`] for a frame of another size than the training frames.
    pub fn predict(
        &self,
        img: &image::GrayImage,
        reference: &image::GrayImage,
        t_ref: &Pose,
    ) -> Result<Pose, NetError> {
        Ok(compose(t_ref, &self.predict_offset(img, reference)?))
    }

    /// The offset `T_ref⁻¹ · T_img` (the test camera in the reference camera's frame, mm).
    ///
    /// # Errors
    /// As [`OffsetNetModel::predict`].
    pub fn predict_offset(
        &self,
        img: &image::GrayImage,
        reference: &image::GrayImage,
    ) -> Result<Pose, NetError> {
        self.predict_offsets(std::slice::from_ref(img), std::slice::from_ref(reference))?
            .pop()
            .ok_or_else(|| NetError::Config("no prediction".into()))
    }

    /// Poses of many test frames, each with its reference frame and pose.
    ///
    /// # Errors
    /// [`NetError::Config`] when the three slices differ in length; as
    /// [`OffsetNetModel::predict`] for the first bad frame.
    pub fn predict_batch(
        &self,
        imgs: &[image::GrayImage],
        references: &[image::GrayImage],
        t_refs: &[Pose],
    ) -> Result<Vec<Pose>, NetError> {
        if t_refs.len() != imgs.len() {
            return Err(NetError::Config(format!(
                "{} test frames but {} reference poses",
                imgs.len(),
                t_refs.len()
            )));
        }
        let offsets = self.predict_offsets(imgs, references)?;
        Ok(t_refs
            .iter()
            .zip(&offsets)
            .map(|(t, o)| compose(t, o))
            .collect())
    }

    /// Offsets of many (test, reference) frame pairs.
    ///
    /// # Errors
    /// As [`OffsetNetModel::predict_batch`].
    pub fn predict_offsets(
        &self,
        imgs: &[image::GrayImage],
        references: &[image::GrayImage],
    ) -> Result<Vec<Pose>, NetError> {
        if imgs.len() != references.len() {
            return Err(NetError::Config(format!(
                "{} test frames but {} reference frames",
                imgs.len(),
                references.len()
            )));
        }
        let (w, h) = (self.file.frame_width, self.file.frame_height);
        for (i, (a, b)) in imgs.iter().zip(references).enumerate() {
            check_frame(a, w, h, &format!("query frame {i}"))?;
            check_frame(b, w, h, &format!("reference frame {i}"))?;
        }
        let size = self.file.config.backbone.input();
        let batch = self.file.config.inference_batch.max(1);
        let mut out = Vec::with_capacity(imgs.len());
        for (q, r) in imgs.chunks(batch).zip(references.chunks(batch)) {
            let prep = |v: &[image::GrayImage]| -> Vec<f32> {
                v.par_iter()
                    .flat_map_iter(|im| network_input(im, size))
                    .collect()
            };
            out.extend(offsets_px(
                &self.net,
                &self.device,
                &self.file.normalizer,
                (prep(r), prep(q)),
                q.len(),
                size,
            ));
        }
        Ok(out)
    }
}

fn offsets_px(
    net: &OffsetNetNet,
    device: &Device,
    nz: &PoseNormalizer,
    (ref_px, query_px): (Vec<f32>, Vec<f32>),
    n: usize,
    size: InputSize,
) -> Vec<Pose> {
    let (p, q) = net.forward(
        images_tensor(ref_px, n, size, device),
        images_tensor(query_px, n, size, device),
    );
    let (p, q) = (tensor_rows(p), tensor_rows(q));
    p.chunks_exact(3)
        .zip(q.chunks_exact(4))
        .map(|(x, q)| nz.pose_from_output(x, q))
        .collect()
}

/// A training frame near `target` that is not held out.
fn nearest_training_frame(target: usize, n: usize, every: usize) -> usize {
    let t = target.min(n.saturating_sub(1));
    if !is_held(t, every) {
        t
    } else if t > 0 {
        t - 1
    } else {
        (t + 1).min(n.saturating_sub(1))
    }
}

/// The reference frame used to validate held-out frame `h`: the training frame half the pair
/// reach before it (after it near the start), a typical training offset.
fn validation_reference(h: usize, n: usize, cfg: &RegressConfig) -> usize {
    let half = (cfg.pair_reach_frames / 2).max(1);
    let target = if h >= half { h - half } else { h + half };
    nearest_training_frame(target, n, cfg.holdout_every)
}

/// Trains OffsetNet on pairs of nearby frames of `data` (see the module documentation).
///
/// Each step draws `cfg.schedule.batch` reference frames (without replacement within the
/// step) and for each a query frame at most `cfg.pair_reach_frames` away; held-out frames
/// (`cfg.holdout_every > 1`) are never used. Same seed and data → same weights.
///
/// # Errors
/// [`NetError::Config`] for a bad config or data (fewer than 2 frames, a cache at another
/// size than the backbone's input, non-finite poses); [`NetError::Weights`] for a bad
/// `init_backbone`; [`NetError::Diverged`] for a non-finite loss; [`NetError::Device`].
pub fn train_offsetnet(
    cfg: &RegressConfig,
    data: &TrainingSet,
    progress: &mut dyn FnMut(&RegressProgress),
) -> Result<OffsetNetModel, NetError> {
    cfg.validate()?;
    data.check(cfg, 2)?;
    let n = data.len();
    let base = crate::device::from_name(&cfg.device)?;
    let device = base.clone().autodiff();
    let (train_frames, held) = split_holdout(n, cfg.holdout_every);
    let reach = cfg.pair_reach_frames;
    let partner = |i: usize, delta: i64| -> usize {
        let j = (i as i64 + delta).clamp(0, n as i64 - 1) as usize;
        nearest_training_frame(j, n, cfg.holdout_every)
    };
    // Normaliser from a deterministic spread of training offsets.
    let stride = (train_frames.len() / 500).max(1);
    let r = reach as i64;
    let offsets: Vec<Pose> = train_frames
        .iter()
        .step_by(stride)
        .flat_map(|&i| {
            [-r, -r / 2, r / 2, r]
                .into_iter()
                .map(move |d| (i, d))
                .collect::<Vec<_>>()
        })
        .map(|(i, d)| offset_between(&data.poses[i], &data.poses[partner(i, d)]))
        .collect();
    let nz = PoseNormalizer::fit(&offsets)?;
    let net = crate::device::seeded_init(&device, cfg.seed, |d| OffsetNetNet::new(cfg, d))?;
    let size = data.images.size;
    let intrinsics = data.view_intrinsics();
    let batch_loss = |net: &OffsetNetNet, b: usize, rng: &mut ChaCha8Rng| {
        let refs = draw_frames(&train_frames, b, rng);
        let queries: Vec<usize> = refs
            .iter()
            .map(|&i| partner(i, rng.random_range(-r..=r)))
            .collect();
        let ref_px = clean_batch(&data.images, &refs);
        let (query_px, turns) = query_batch(&data.images, &queries, cfg, intrinsics.as_ref(), rng);
        let (xs, qs): (Vec<[f32; 3]>, Vec<[f32; 4]>) = refs
            .iter()
            .zip(&queries)
            .zip(&turns)
            .map(|((&i, &j), turn)| {
                let p = &data.poses[j];
                let turned =
                    pose_from_parts(p.translation.vector, rotated_rotation(&p.rotation, turn));
                nz.target(&offset_between(&data.poses[i], &turned))
            })
            .unzip();
        let (x_hat, q_hat) = net.forward(
            images_tensor(ref_px, refs.len(), size, &device),
            images_tensor(query_px, refs.len(), size, &device),
        );
        posenet_loss(
            x_hat,
            q_hat,
            rows_tensor(&xs, &device),
            rows_tensor(&qs, &device),
            cfg.beta,
        )
    };
    let held_errors = |net: &OffsetNetNet| {
        let mut est = Vec::with_capacity(held.len());
        for chunk in held.chunks(cfg.inference_batch.max(1)) {
            let refs: Vec<usize> = chunk
                .iter()
                .map(|&h| validation_reference(h, n, cfg))
                .collect();
            let offs = offsets_px(
                net,
                &base,
                &nz,
                (
                    clean_batch(&data.images, &refs),
                    clean_batch(&data.images, chunk),
                ),
                chunk.len(),
                size,
            );
            est.extend(
                refs.iter()
                    .zip(&offs)
                    .map(|(&r, o)| compose(&data.poses[r], o)),
            );
        }
        let truth: Vec<Pose> = held.iter().map(|&f| data.poses[f]).collect();
        mean_errors(&est, &truth)
    };
    let (net, history) = fit(
        cfg,
        0x0FF5_E7AE_7000_0000,
        net,
        !held.is_empty(),
        batch_loss,
        held_errors,
        progress,
    )?;
    let file = RegressModelFile::trained(RegressMethod::Offsetnet, data, nz, cfg, history);
    Ok(OffsetNetModel {
        file,
        net,
        device: base,
    })
}
