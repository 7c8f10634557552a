//! Zone classification for endoloc: the first half of the paper's pipeline.
//!
//! A training sequence is cut into zones ([`zones`]); a Siamese network — two twins sharing
//! one backbone ([`backbone`]) — is trained with the contrastive loss ([`loss`]) on balanced
//! pairs of images from the same zone and from different zones ([`pairs`], [`mod@train`]); the
//! descriptors of all training images form a database ([`database`]); a test image goes to
//! the zone of its nearest descriptors ([`classifier`]), optionally smoothed over a video by
//! an HMM over zones ([`temporal`]) or, finer, over training frames ([`track`]).
//!
//! The network runs on burn 0.22 with its pure-Rust `flex` CPU backend; a GPU backend is an
//! optional crate feature (`cuda`, `wgpu`) chosen at run time ([`device`]).
//!
//! A trained model is one folder ([`model`]): `model.toml` (its config), `weights.safetensors`,
//! `zones.csv`, `database.bin` (descriptors of the training frames, and with
//! `--index-zoom-blur` of their zoom-blurred views, [`zoom_blur`]), `whitening.bin` (when the
//! descriptors are whitened, [`whiten`]) and `train_poses.txt`.
//!
//! Conventions (`docs/CONVENTIONS.md`): zone indices are 0-based along the training trajectory; poses
//! are `T_wc` in mm.

#![warn(missing_docs)]

pub mod augment;
pub mod backbone;
mod binfile;
pub mod classifier;
pub mod database;
pub mod device;
pub mod error;
mod history;
pub mod loss;
pub mod model;
mod optimise;
pub mod pairs;
pub mod plot;
pub mod preprocess;
pub mod pretrain;
pub mod pretrained;
pub mod regress;
pub mod temporal;
pub mod track;
pub mod train;
mod train_config;
pub mod view;
pub mod whiten;
pub mod zones;
pub mod zoom_blur;

#[cfg(test)]
mod config_tests;

pub use augment::AugmentConfig;
pub use backbone::{BackboneConfig, EmbeddingNet};
pub use classifier::ZoneClassifier;
pub use database::{DescriptorDatabase, ScoreRule, ZonePrediction};
pub use error::NetError;
pub use model::ModelConfig;
pub use pairs::PairRule;
pub use preprocess::InputSize;
pub use temporal::{TemporalConfig, TemporalFilter, viterbi};
pub use track::{TrackConfig, TrackEstimate, TrackFilter};
pub use train::{
    EpochRecord, ImageCache, Phase, Schedule, TrainConfig, TrainProgress, TrainReport, TrainTarget,
    ValidationConfig, fit, train,
};
pub use zones::{DEFAULT_MIN_ZONE_FRAMES, UniformBy, Zone, ZoneConfig, ZoneSpec, ZoneTable};
