//! The regression model folder.
//!
//! ```text
//! MODEL/
//!   regress.toml          RegressModelFile: format version, method (posenet | offsetnet),
//!                         training frame size, normaliser, training config, history
//!   weights.safetensors   backbone + head weights (burn-store; names like
//!                         `backbone.blocks.0.conv.weight`, `head.fc.weight`)
//! ```
//!
//! Written to `MODEL.partial/` and renamed into place ([`crate::model::publish`]).

use super::config::RegressConfig;
use super::data::TrainingSet;
use super::normalize::PoseNormalizer;
use super::progress::RegressEpoch;
use crate::NetError;
use burn::module::Module;
use burn_store::{ModuleSnapshot, SafetensorsStore};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Version of the regression model folder layout.
pub const FORMAT_VERSION: u32 = 1;
/// Config file name.
pub const REGRESS_FILE: &str = "regress.toml";
/// Weights file name.
pub const WEIGHTS_FILE: &str = "weights.safetensors";

/// Which baseline a model folder holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RegressMethod {
    /// Absolute pose regression.
    Posenet,
    /// Relative pose regression from a reference image.
    Offsetnet,
}

impl RegressMethod {
    /// `posenet` or `offsetnet`.
    pub fn name(self) -> &'static str {
        match self {
            RegressMethod::Posenet => "posenet",
            RegressMethod::Offsetnet => "offsetnet",
        }
    }
}

/// `regress.toml`: what the model is and what it was trained on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegressModelFile {
    /// Layout version ([`FORMAT_VERSION`]).
    pub format_version: u32,
    /// The baseline.
    pub method: RegressMethod,
    /// Width of the training frames, pixels (test frames must match).
    pub frame_width: u32,
    /// Height of the training frames, pixels.
    pub frame_height: u32,
    /// Number of training frames.
    pub frames: usize,
    /// Target normalisation (positions in mm).
    pub normalizer: PoseNormalizer,
    /// The training run.
    pub config: RegressConfig,
    /// Loss and validation errors per epoch.
    pub history: Vec<RegressEpoch>,
}

impl RegressModelFile {
    /// The file of a `method` model just trained on `data` with `cfg`.
    pub(crate) fn trained(
        method: RegressMethod,
        data: &TrainingSet,
        normalizer: PoseNormalizer,
        cfg: &RegressConfig,
        history: Vec<RegressEpoch>,
    ) -> Self {
        RegressModelFile {
            format_version: FORMAT_VERSION,
            method,
            frame_width: data.frame_width,
            frame_height: data.frame_height,
            frames: data.len(),
            normalizer,
            config: cfg.clone(),
            history,
        }
    }

    /// Reads `MODEL/regress.toml` and checks that it holds a `method` model.
    ///
    /// # Errors
    /// [`NetError::Io`] if missing; [`NetError::Parse`] (with the line) for bad TOML, another
    /// format version or another method; [`NetError::Config`] for bad values.
    pub fn load(dir: &Path, method: RegressMethod) -> Result<Self, NetError> {
        let path = dir.join(REGRESS_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| NetError::io(&path, e))?;
        let file: RegressModelFile = toml::from_str(&text).map_err(|e| {
            let (line, message) = endoloc_data::toml_error_line(&text, &e);
            NetError::parse(&path, line, message)
        })?;
        if file.format_version != FORMAT_VERSION {
            return Err(NetError::parse(
                &path,
                0,
                format!(
                    "format version {}; this build reads version {FORMAT_VERSION}",
                    file.format_version
                ),
            ));
        }
        if file.method != method {
            return Err(NetError::parse(
                &path,
                0,
                format!(
                    "holds a {} model, expected {}",
                    file.method.name(),
                    method.name()
                ),
            ));
        }
        file.config.validate()?;
        if !(file.normalizer.position_scale_mm > 0.0
            && file.normalizer.position_scale_mm.is_finite())
        {
            return Err(NetError::parse(
                &path,
                0,
                format!(
                    "normalizer.position_scale_mm {} must be positive",
                    file.normalizer.position_scale_mm
                ),
            ));
        }
        Ok(file)
    }

    fn save(&self, dir: &Path) -> Result<(), NetError> {
        let path = dir.join(REGRESS_FILE);
        let body = toml::to_string_pretty(self).map_err(|e| NetError::Config(e.to_string()))?;
        let text = format!(
            "# endoloc {} model (format {FORMAT_VERSION}); see crates/net/src/regress/io.rs\n{body}",
            self.method.name()
        );
        std::fs::write(&path, text).map_err(|e| NetError::io(&path, e))
    }
}

/// Writes a model folder atomically: `DIR.partial/` then a rename. An existing `DIR` is
/// refused unless `overwrite` (then replaced only once the new one is complete).
pub(crate) fn save_model<M: Module>(
    dir: &Path,
    file: &RegressModelFile,
    net: &M,
    overwrite: bool,
) -> Result<(), NetError> {
    if dir.exists() && !overwrite {
        return Err(NetError::AlreadyExists {
            path: dir.to_path_buf(),
        });
    }
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "model".into());
    let staging: PathBuf = dir.with_file_name(format!("{name}.partial"));
    if staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(|e| NetError::io(&staging, e))?;
    }
    std::fs::create_dir_all(&staging).map_err(|e| NetError::io(&staging, e))?;
    let weights = staging.join(WEIGHTS_FILE);
    let mut store = SafetensorsStore::from_file(&weights).skip_enum_variants(true);
    net.save_into(&mut store)
        .map_err(|e| NetError::weights(&weights, e))?;
    file.save(&staging)?;
    crate::model::publish(&staging, dir, overwrite)
}

/// Loads every weight of `net` from `MODEL/weights.safetensors`; all must be present with the
/// right shapes.
pub(crate) fn load_weights<M: Module>(dir: &Path, net: &mut M) -> Result<(), NetError> {
    let path = dir.join(WEIGHTS_FILE);
    if !path.is_file() {
        return Err(NetError::weights(&path, "file not found"));
    }
    let mut store = SafetensorsStore::from_file(&path)
        .skip_enum_variants(true)
        .allow_partial(false);
    let result = net
        .load_from(&mut store)
        .map_err(|e| NetError::weights(&path, e))?;
    if !result.errors.is_empty() || !result.missing.is_empty() {
        return Err(NetError::weights(
            &path,
            format!(
                "does not match regress.toml's network: missing {:?}, errors {:?}",
                result.missing, result.errors
            ),
        ));
    }
    Ok(())
}
