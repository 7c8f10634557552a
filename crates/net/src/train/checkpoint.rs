//! What a training run keeps on disk besides the finished model: the staging folder
//! `DIR.partial/` the model is written into ([`TrainTarget`]), and the checkpoint in its
//! `checkpoint/` subfolder that an interrupted run resumes from.
//!
//! A checkpoint is three files: `net-EPOCH.bpk` (the network's weights, as burn saves a
//! module), `optim-EPOCH.bpk` (Adam's state) and `state.json` (the epoch reached, the history,
//! the config and the data's frame and zone counts, checked on resume). Each is written under
//! a temporary name and renamed into place, `state.json` last: it names the epoch whose weights
//! and optimiser state a resumed run loads, so a run killed anywhere inside a save resumes from
//! one whole checkpoint (the new one or the one before), never from weights of one epoch with
//! the optimiser of another. The files of earlier epochs are removed once `state.json` names
//! the new one.

use crate::NetError;
use crate::backbone::EmbeddingNet;
use crate::history::EpochRecord;
use crate::train_config::TrainConfig;
use burn::module::Module;
use burn::optim::ModuleOptimizer;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Saved training state between runs (`checkpoint/state.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CheckpointState {
    epoch: usize,
    history: Vec<EpochRecord>,
    config: TrainConfig,
    frames: usize,
    zones: usize,
}

/// Prefix of the network's file: `net-EPOCH.bpk`.
const CKPT_NET: &str = "net";
/// Prefix of the optimiser's file: `optim-EPOCH.bpk`.
const CKPT_OPTIM: &str = "optim";
const CKPT_STATE: &str = "state.json";

/// Name of the checkpoint folder inside the staging folder.
const CHECKPOINT_DIR: &str = "checkpoint";

/// The file of `what` ([`CKPT_NET`] or [`CKPT_OPTIM`]) after `epoch` (1-based).
fn epoch_file(what: &str, epoch: usize) -> String {
    format!("{what}-{epoch:04}.bpk")
}

/// The network being trained with its optimiser: what a checkpoint holds besides its state.
pub(crate) struct Learner {
    /// The backbone (autodiff device).
    pub net: EmbeddingNet,
    /// Adam and its moments.
    pub optim: ModuleOptimizer,
}

/// Where a resumed run continues: the last epoch saved and the history up to it.
pub(crate) struct ResumePoint {
    /// Epochs done (1-based number of the last one).
    pub epoch: usize,
    /// Loss and validation of those epochs.
    pub history: Vec<EpochRecord>,
}

/// The checkpoint folder of staging folder `staging`: `staging/checkpoint`.
pub(crate) fn checkpoint_dir(staging: &Path) -> PathBuf {
    staging.join(CHECKPOINT_DIR)
}

/// Loads the checkpoint in `dir` into `learner` when there is one (`state.json` present);
/// `None` leaves `learner` as it was.
///
/// # Errors
/// [`NetError::Io`] / [`NetError::Parse`] for `state.json`; [`NetError::Config`] for a
/// checkpoint of another backbone, frame count or zone count; [`NetError::Weights`] for
/// unreadable network or optimiser files.
pub(crate) fn resume(
    dir: &Path,
    cfg: &TrainConfig,
    frames: usize,
    zones: usize,
    learner: Learner,
) -> Result<(Learner, Option<ResumePoint>), NetError> {
    let state_path = dir.join(CKPT_STATE);
    if !state_path.is_file() {
        return Ok((learner, None));
    }
    let text = std::fs::read_to_string(&state_path).map_err(|e| NetError::io(&state_path, e))?;
    let st: CheckpointState = serde_json::from_str(&text)
        .map_err(|e| NetError::parse(&state_path, e.line(), e.to_string()))?;
    if st.config.backbone != cfg.backbone || st.frames != frames || st.zones != zones {
        return Err(NetError::Config(format!(
            "{}: the checkpoint was made with another backbone, frame count or zoning ({} frames, {} zones); start over with `force`",
            dir.display(),
            st.frames,
            st.zones
        )));
    }
    let p = dir.join(epoch_file(CKPT_NET, st.epoch));
    let net = learner
        .net
        .try_load_file(&p)
        .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
    let p = dir.join(epoch_file(CKPT_OPTIM, st.epoch));
    let optim = learner
        .optim
        .load(&p)
        .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
    Ok((
        Learner { net, optim },
        Some(ResumePoint {
            epoch: st.epoch,
            history: st.history,
        }),
    ))
}

/// Whether epoch `epoch` (1-based) ends with a checkpoint: every `every` epochs (0: never)
/// and after the last one.
pub(crate) fn due(every: usize, epoch: usize, last: bool) -> bool {
    last || (every > 0 && epoch.is_multiple_of(every))
}

/// Writes the checkpoint of `learner` after `epoch` (1-based) into `dir`, replacing the
/// previous one only once every file is complete.
///
/// # Errors
/// [`NetError::Io`]; [`NetError::Weights`] when burn cannot write the network or optimiser.
pub(crate) fn save(
    dir: &Path,
    learner: &Learner,
    epoch: usize,
    history: &[EpochRecord],
    cfg: &TrainConfig,
    (frames, zones): (usize, usize),
) -> Result<(), NetError> {
    let state = CheckpointState {
        epoch,
        history: history.to_vec(),
        config: cfg.clone(),
        frames,
        zones,
    };
    // Batch-norm running statistics hold their latest update per thread until synchronised,
    // and saving reads the synchronised value only: synchronise first (`valid()` does, on the
    // shared state), or a resumed run starts from stale statistics and ends elsewhere.
    let _ = learner.net.valid();
    write_files(dir, &learner.net, &learner.optim, &state)
}

/// Removes the checkpoint folder `dir` (a finished run's), if it exists.
///
/// # Errors
/// [`NetError::Io`].
pub(crate) fn discard(dir: &Path) -> Result<(), NetError> {
    if dir.exists() {
        std::fs::remove_dir_all(dir).map_err(|e| NetError::io(dir, e))?;
    }
    Ok(())
}

fn write_files(
    dir: &Path,
    net: &EmbeddingNet,
    optim: &ModuleOptimizer,
    state: &CheckpointState,
) -> Result<(), NetError> {
    std::fs::create_dir_all(dir).map_err(|e| NetError::io(dir, e))?;
    // Each file under a temporary name, then renamed; the weights and optimiser state carry
    // their epoch in their names, so renaming them leaves the previous checkpoint whole until
    // `state.json` is replaced.
    let (net_name, optim_name) = (
        epoch_file(CKPT_NET, state.epoch),
        epoch_file(CKPT_OPTIM, state.epoch),
    );
    let tmp = |name: &str| dir.join(format!(".{name}.tmp"));
    // burn may add its extension to the file name it is given.
    let written = |p: PathBuf| {
        if p.is_file() {
            p
        } else {
            p.with_extension("tmp.bpk")
        }
    };
    let publish = |from: PathBuf, name: &str| {
        let to = dir.join(name);
        std::fs::rename(&from, &to).map_err(|e| NetError::io(&to, e))
    };
    let p = tmp(&net_name);
    net.clone()
        .save_file(&p)
        .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
    publish(written(p), &net_name)?;
    let p = tmp(&optim_name);
    optim
        .save(&p)
        .map_err(|e| NetError::weights(&p, format!("{e:?}")))?;
    publish(written(p), &optim_name)?;
    let p = tmp(CKPT_STATE);
    let text = serde_json::to_string_pretty(state).map_err(|e| NetError::Config(e.to_string()))?;
    std::fs::write(&p, text).map_err(|e| NetError::io(&p, e))?;
    publish(p, CKPT_STATE)?;
    // Only now are the earlier epochs' files (and temporary files of a killed save) unused.
    for entry in std::fs::read_dir(dir).map_err(|e| NetError::io(dir, e))? {
        let path = entry.map_err(|e| NetError::io(dir, e))?.path();
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        if name != CKPT_STATE && name != net_name && name != optim_name {
            std::fs::remove_file(&path).map_err(|e| NetError::io(&path, e))?;
        }
    }
    Ok(())
}

/// Where and how [`train`](super::train) and [`pretrain`](crate::pretrain::pretrain) write
/// their output folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TrainTarget {
    /// The model folder to create.
    pub dir: PathBuf,
    /// Replace an existing model folder.
    pub force: bool,
    /// Continue from the checkpoint of an interrupted run (`DIR.partial/checkpoint`).
    pub resume: bool,
}

impl TrainTarget {
    /// Checks that the output may be written and makes its staging folder
    /// ([`TrainTarget::staging_dir`]), kept as it is when resuming, emptied with `force`.
    ///
    /// # Errors
    /// [`NetError::AlreadyExists`] for an existing output without `force`;
    /// [`NetError::Config`] for an interrupted run without `resume` or `force`;
    /// [`NetError::Io`].
    pub fn prepare(&self) -> Result<PathBuf, NetError> {
        if self.dir.exists() && !self.force {
            return Err(NetError::AlreadyExists {
                path: self.dir.clone(),
            });
        }
        let staging = self.staging_dir();
        if staging.exists() && !self.resume {
            if self.force {
                std::fs::remove_dir_all(&staging).map_err(|e| NetError::io(&staging, e))?;
            } else {
                return Err(NetError::Config(format!(
                    "{} holds an interrupted training run: `resume` continues it, `force` starts over",
                    staging.display()
                )));
            }
        }
        std::fs::create_dir_all(&staging).map_err(|e| NetError::io(&staging, e))?;
        Ok(staging)
    }

    /// Runs `body` with the staging folder of [`TrainTarget::prepare`]. When it fails before
    /// any checkpoint was written (a bad image, a bad setting), the staging folder is removed,
    /// so that an error leaves no partial output; with a checkpoint it is kept for `--resume`.
    ///
    /// # Errors
    /// Those of [`TrainTarget::prepare`] and of `body`.
    pub fn run<T>(&self, body: impl FnOnce(&Path) -> Result<T, NetError>) -> Result<T, NetError> {
        let staging = self.prepare()?;
        let result = body(&staging);
        if result.is_err() && !has_checkpoint(&staging) {
            let _ = std::fs::remove_dir_all(&staging);
        }
        result
    }

    /// The staging folder next to the model folder: `DIR.partial`.
    pub fn staging_dir(&self) -> PathBuf {
        let name = self
            .dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".into());
        self.dir.with_file_name(format!("{name}.partial"))
    }
}

/// Whether a staging folder holds a checkpoint to resume from.
fn has_checkpoint(staging: &Path) -> bool {
    std::fs::read_dir(checkpoint_dir(staging)).is_ok_and(|mut d| d.next().is_some())
}
