//! The trained-model wrapper both regression methods share ([`RegressModel`]): the
//! `regress.toml` record, the network in validation mode and its device, with loading and
//! saving of the model folder ([`super::io`]). Each method adds its own `predict` methods.

use super::fit::{RegressNetwork, load_model};
use super::io::{self, RegressMethod, RegressModelFile};
use super::progress::RegressEpoch;
use crate::NetError;
use burn::tensor::Device;
use std::path::Path;

/// A trained regression model of network `N` (validation mode):
/// [`PoseNetModel`](super::PoseNetModel) or [`OffsetNetModel`](super::OffsetNetModel).
pub struct RegressModel<N> {
    /// What the model is and how it was trained.
    pub(super) file: RegressModelFile,
    /// The network (validation mode).
    pub(super) net: N,
    /// Where `net` runs.
    pub(super) device: Device,
}

impl<N: RegressNetwork> std::fmt::Debug for RegressModel<N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match N::METHOD {
            RegressMethod::Posenet => "PoseNetModel",
            RegressMethod::Offsetnet => "OffsetNetModel",
        };
        f.debug_struct(name)
            .field("backbone", &self.file.config.backbone.name())
            .field("frames", &self.file.frames)
            .finish()
    }
}

impl<N: RegressNetwork> RegressModel<N> {
    /// Writes the model folder `dir` atomically ([`io`]); an existing `dir` is an error
    /// unless `overwrite`.
    ///
    /// # Errors
    /// [`NetError::AlreadyExists`], [`NetError::Io`], [`NetError::Weights`].
    pub fn save(&self, dir: &Path, overwrite: bool) -> Result<(), NetError> {
        io::save_model(dir, &self.file, &self.net, overwrite)
    }

    /// Loads a model folder on the CPU.
    ///
    /// # Errors
    /// [`NetError::Io`] / [`NetError::Parse`] naming the missing or bad file (or a folder of
    /// the other method), [`NetError::Weights`] for weights that do not fit `regress.toml`.
    pub fn load(dir: &Path) -> Result<Self, NetError> {
        Self::load_on(dir, "cpu")
    }

    /// Loads a model folder on the named device ([`crate::device::from_name`]).
    ///
    /// # Errors
    /// As [`RegressModel::load`], and [`NetError::Device`].
    pub fn load_on(dir: &Path, device: &str) -> Result<Self, NetError> {
        let (file, net, device) = load_model(dir, device)?;
        Ok(RegressModel { file, net, device })
    }

    /// What the model is and how it was trained (`regress.toml`).
    pub fn info(&self) -> &RegressModelFile {
        &self.file
    }

    /// Loss and held-out errors per epoch.
    pub fn history(&self) -> &[RegressEpoch] {
        &self.file.history
    }
}
