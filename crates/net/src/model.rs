//! The model folder: one directory holds everything a trained zone classifier needs.
//!
//! ```text
//! MODEL/
//!   model.toml            ModelConfig: format version, backbone, score rule, temporal
//!                         defaults, training camera, dataset/sequence, zoning, train config
//!   weights.safetensors   backbone weights (burn-store; safetensors, readable from Python)
//!   zones.csv             the zone table (ZoneTable::save)
//!   database.bin          descriptors of every training frame (DescriptorDatabase::save)
//!   train_poses.txt       the training poses, TUM, T_wc, mm (zone median poses, truth zones)
//!   history.csv           epoch, loss, validation accuracy
//!   loss.png              the loss curve (skipped with a warning if no font is usable)
//! ```
//!
//! A model is written to `MODEL.partial/` and renamed into place ([`publish`]).

use crate::NetError;
use crate::backbone::{BackboneConfig, EmbeddingNet};
use crate::database::{DescriptorDatabase, ScoreRule};
use crate::history::EpochRecord;
pub use crate::history::write_history;
use crate::temporal::TemporalConfig;
use crate::track::TrackConfig;
use crate::train_config::TrainConfig;
use crate::zones::{ZONES_FILE, ZoneConfig, ZoneTable};
use burn::tensor::Device;
use burn_store::{ModuleSnapshot, SafetensorsStore};
use endoloc_data::{Fingerprint, Sequence};
use endoloc_geometry::Camera;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Version of the model folder layout.
pub const FORMAT_VERSION: u32 = 1;
/// Config file name.
pub const CONFIG_FILE: &str = "model.toml";
/// Weights file name.
pub const WEIGHTS_FILE: &str = "weights.safetensors";
/// Training poses file name.
pub const POSES_FILE: &str = "train_poses.txt";
/// Training history file name.
pub const HISTORY_FILE: &str = "history.csv";
/// Loss curve file name.
pub const LOSS_PNG: &str = "loss.png";

/// `model.toml`: what the model is and what it was trained on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelConfig {
    /// Layout version ([`FORMAT_VERSION`]).
    pub format_version: u32,
    /// Name of the training dataset.
    pub dataset: String,
    /// Name of the training sequence.
    pub sequence: String,
    /// Number of training frames (rows of the database).
    pub frames: usize,
    /// Zone look-up rule.
    pub score: ScoreRule,
    /// The camera of the training images: test images must come from the same camera.
    pub camera: Camera,
    /// The backbone (input size, descriptor length).
    pub backbone: BackboneConfig,
    /// How the zones were made.
    pub zones: ZoneConfig,
    /// Default temporal-filter parameters.
    pub temporal: TemporalConfig,
    /// Default parameters of the frame-level track filter ([`crate::track`]); models written
    /// before it existed get the defaults.
    #[serde(default)]
    pub track: TrackConfig,
    /// Power of the whitening in `whitening.bin` ([`crate::whiten`]) applied to every
    /// descriptor, database rows included; none for raw network descriptors (and for models
    /// written before whitening existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub whitening: Option<f32>,
    /// The training run.
    pub train: TrainConfig,
    /// What the folder was made from (fingerprints); written by every model since they
    /// existed, absent in older folders (which are then not checked).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

/// What a model folder was made from: `localize` and `classify` compare it with the dataset
/// they are given, `map` records it in the map, so that a model, a map and a dataset from
/// different runs are never mixed silently.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// Fingerprint of the training sequence's poses as read from the dataset
    /// ([`endoloc_data::poses_fingerprint`]).
    pub train_poses: Fingerprint,
    /// Fingerprint of the folder's `zones.csv` (its bytes).
    pub zones: Fingerprint,
}

impl ModelConfig {
    /// Reads `MODEL/model.toml`.
    ///
    /// # Errors
    /// [`NetError::Io`] if missing; [`NetError::Parse`] (with the line) for bad TOML or a
    /// format version this build does not read.
    pub fn load(dir: &Path) -> Result<Self, NetError> {
        let path = dir.join(CONFIG_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| NetError::io(&path, e))?;
        Self::parse(&path, &text)
    }

    /// Parses the text of a `model.toml` (see [`ModelConfig::load`]); `path` names the file
    /// in errors.
    ///
    /// # Errors
    /// [`NetError::Parse`] (with the line) for bad TOML, a format version this build does not
    /// read, or filter parameters out of range.
    pub fn parse(path: &Path, text: &str) -> Result<Self, NetError> {
        let cfg: ModelConfig = toml::from_str(text).map_err(|e| {
            let (line, message) = endoloc_data::toml_error_line(text, &e);
            NetError::parse(path, line, message)
        })?;
        if cfg.format_version != FORMAT_VERSION {
            return Err(NetError::parse(
                path,
                0,
                format!(
                    "model format version {}; this build reads version {FORMAT_VERSION}",
                    cfg.format_version
                ),
            ));
        }
        // Filter parameters a user may have edited: refused here, not at the first frame.
        for check in [cfg.temporal.validate(), cfg.track.validate()] {
            check.map_err(|e| NetError::parse(path, 0, e.to_string()))?;
        }
        Ok(cfg)
    }

    /// Writes `DIR/model.toml`.
    ///
    /// # Errors
    /// [`NetError::Io`] / [`NetError::Config`].
    pub fn save(&self, dir: &Path) -> Result<(), NetError> {
        let path = dir.join(CONFIG_FILE);
        let body = toml::to_string_pretty(self).map_err(|e| NetError::Config(e.to_string()))?;
        let text = format!(
            "# endoloc zone-classifier model (format {FORMAT_VERSION}); see crates/net/src/model.rs\n{body}"
        );
        std::fs::write(&path, text).map_err(|e| NetError::io(&path, e))
    }
}

/// Saves backbone weights as safetensors, atomically, replacing a file at `path`: models are
/// written into their own staging folder, where a file can only be a killed run's.
///
/// # Errors
/// [`NetError::Weights`].
pub fn save_weights(net: &EmbeddingNet, path: &Path) -> Result<(), NetError> {
    // Names without the enum variant (`conv1.conv.weight`, as PyTorch would write them).
    let mut store = SafetensorsStore::from_file(path)
        .skip_enum_variants(true)
        .overwrite(true);
    net.save_into(&mut store)
        .map_err(|e| NetError::weights(path, e))
}

/// Builds the backbone of `cfg` on `device` and loads its weights from `path`; every tensor
/// must be present with the right shape.
///
/// # Errors
/// [`NetError::Weights`] naming the file and what is missing or mismatched.
pub fn load_weights(
    cfg: &BackboneConfig,
    path: &Path,
    device: &Device,
) -> Result<EmbeddingNet, NetError> {
    if !path.is_file() {
        return Err(NetError::weights(path, "file not found"));
    }
    load_into(cfg, path, SafetensorsStore::from_file(path), device)
}

/// [`load_weights`] from the bytes of a safetensors file; `path` names the file in errors.
///
/// # Errors
/// [`NetError::Weights`] naming the file and what is missing, mismatched or malformed.
pub fn load_weights_from_bytes(
    cfg: &BackboneConfig,
    path: &Path,
    bytes: Vec<u8>,
    device: &Device,
) -> Result<EmbeddingNet, NetError> {
    load_into(cfg, path, SafetensorsStore::from_bytes(Some(bytes)), device)
}

/// The backbone of `cfg` with the weights of `store` (the file `path`).
fn load_into(
    cfg: &BackboneConfig,
    path: &Path,
    store: SafetensorsStore,
    device: &Device,
) -> Result<EmbeddingNet, NetError> {
    let mut net = cfg.init(device);
    let mut store = store.skip_enum_variants(true).allow_partial(false);
    let result = net
        .load_from(&mut store)
        .map_err(|e| NetError::weights(path, e))?;
    if !result.errors.is_empty() || !result.missing.is_empty() {
        return Err(NetError::weights(
            path,
            format!(
                "does not match the {} backbone of model.toml: missing {:?}, errors {:?}",
                cfg.name(),
                result.missing,
                result.errors
            ),
        ));
    }
    Ok(net)
}

/// Writes every file of a model folder into `dir` (which must exist) except the loss curve
/// `loss.png`, which the writer of the folder draws with [`crate::plot::loss_curve_or_warn`].
///
/// # Errors
/// [`NetError::Io`], [`NetError::Weights`], [`NetError::Data`] (poses).
pub fn write_model_files(
    dir: &Path,
    cfg: &ModelConfig,
    net: &EmbeddingNet,
    zones: &ZoneTable,
    db: &DescriptorDatabase,
    seq: &Sequence,
    history: &[EpochRecord],
) -> Result<(), NetError> {
    save_weights(net, &dir.join(WEIGHTS_FILE))?;
    let zones_path = dir.join(ZONES_FILE);
    zones.save(&zones_path)?;
    db.save(&dir.join(crate::database::DATABASE_FILE))?;
    endoloc_data::write_tum(&dir.join(POSES_FILE), &seq.poses)?;
    write_history(&dir.join(HISTORY_FILE), history)?;
    let provenance = Provenance {
        train_poses: endoloc_data::poses_fingerprint(&seq.poses),
        zones: file_fingerprint(&zones_path)?,
    };
    ModelConfig {
        provenance: Some(provenance),
        ..cfg.clone()
    }
    .save(dir)
}

/// The fingerprint of a file's bytes.
///
/// # Errors
/// [`NetError::Io`] naming the file.
pub fn file_fingerprint(path: &Path) -> Result<Fingerprint, NetError> {
    let bytes = std::fs::read(path).map_err(|e| NetError::io(path, e))?;
    Ok(Fingerprint::of_bytes(&bytes))
}

/// Moves the finished staging folder to `dest`. With `force`, an existing `dest` is first
/// renamed aside and removed only after the new model is in place.
///
/// # Errors
/// [`NetError::AlreadyExists`] without `force`; [`NetError::Io`].
pub fn publish(staging: &Path, dest: &Path, force: bool) -> Result<(), NetError> {
    if dest.exists() {
        if !force {
            return Err(NetError::AlreadyExists {
                path: dest.to_path_buf(),
            });
        }
        let old = dest.with_file_name(format!(
            "{}.old-{}",
            dest.file_name()
                .map_or("model".into(), |n| n.to_string_lossy()),
            std::process::id()
        ));
        std::fs::rename(dest, &old).map_err(|e| NetError::io(dest, e))?;
        std::fs::rename(staging, dest).map_err(|e| NetError::io(dest, e))?;
        let _ = std::fs::remove_dir_all(&old);
        return Ok(());
    }
    if let Some(parent) = dest.parent()
        && !parent.as_os_str().is_empty()
    {
        std::fs::create_dir_all(parent).map_err(|e| NetError::io(parent, e))?;
    }
    std::fs::rename(staging, dest).map_err(|e| NetError::io(dest, e))
}

/// Path of a file in a model folder.
pub fn file(dir: &Path, name: &str) -> PathBuf {
    dir.join(name)
}
