//! The learning baselines of the paper's Table I: absolute pose regression ([`posenet`],
//! Kendall et al. 2015) and relative pose regression from a retrieved reference image
//! ([`offsetnet`], Sganga et al. 2018), on the same backbone as the Siamese zone classifier
//! ([`crate::backbone`]) and the same preprocessing ([`crate::preprocess`]).
//!
//! Both networks put a small head on the backbone's descriptor: the unit-length descriptor
//! of [`crate::backbone::EmbeddingNet`] is multiplied by `√dim` (entries of order 1), then
//! `Linear(·, hidden) → ReLU → {Linear(hidden, 3) position, Linear(hidden, 4) quaternion}`.
//!
//! Targets are normalised ([`normalize::PoseNormalizer`]): positions have the training mean
//! subtracted and are divided by the RMS distance of the training positions from that mean;
//! rotations are expressed relative to a reference rotation (the chordal mean of the training
//! rotations) and their quaternions canonicalised to `w ≥ 0` — the q/−q ambiguity is resolved
//! by putting every training target in the hemisphere of the reference, so the hemisphere's
//! edge lies as far as possible from the training orientations.
//!
//! Geometric augmentation changes the pose an image shows, so only the photometric part of
//! [`crate::augment`] is used, plus a *view* augmentation with the label corrected exactly
//! ([`view`]): the camera turned about its own centre by `ΔR` (a roll about the optical axis,
//! and with known intrinsics a small pitch and yaw) sees the image warped by the homography
//! `K ΔRᵀ K⁻¹`, and its rotation label becomes `R_wc · ΔR`. The test pass through a colon
//! differs from the training pass by such turns (gaze, roll) and a small lateral offset.
//!
//! A trained model is one folder ([`io`]): `regress.toml` (what it is, its config, the
//! normaliser, the training image size) and `weights.safetensors`, written to `DIR.partial`
//! and renamed into place.

mod batch;
mod config;
mod data;
mod fit;
mod head;
pub mod io;
pub mod loss;
mod model;
pub mod normalize;
pub mod offsetnet;
pub mod posenet;
mod progress;

/// View turns and their homographies, shared with the zone classifier's augmentation.
pub use crate::view;
pub use config::{RegressConfig, RegressSchedule};
pub use data::TrainingSet;
pub use fit::RegressNetwork;
pub use head::PoseHead;
pub use io::{RegressMethod, RegressModelFile};
pub use loss::{posenet_loss, posenet_loss_sample};
pub use model::RegressModel;
pub use normalize::PoseNormalizer;
pub use offsetnet::{OffsetNetModel, compose, offset_between, train_offsetnet};
pub use posenet::{PoseNetModel, train_posenet};
pub use progress::{RegressEpoch, RegressPhase, RegressProgress};
