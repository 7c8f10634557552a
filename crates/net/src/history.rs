//! The training history shared by the training loop, the model folder and the loss plot:
//! one [`EpochRecord`] per epoch, written as `history.csv` ([`write_history`]).

use crate::NetError;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// One epoch of the training history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EpochRecord {
    /// 1-based epoch.
    pub epoch: usize,
    /// Mean contrastive loss over the epoch's steps.
    pub loss: f32,
    /// Validation exact zone accuracy (fraction), when validated this epoch.
    pub val_accuracy: Option<f32>,
    /// Validation accuracy within ±1 zone.
    pub val_within1: Option<f32>,
    /// Wall-clock seconds since the start of training (this run).
    pub elapsed_s: f64,
}

/// Writes `history.csv`: `epoch,loss,val_accuracy,val_within1,elapsed_s`.
///
/// # Errors
/// [`NetError::Io`].
pub fn write_history(path: &Path, history: &[EpochRecord]) -> Result<(), NetError> {
    let mut s = String::from("epoch,loss,val_accuracy,val_within1,elapsed_s\n");
    let opt = |v: Option<f32>| v.map_or(String::new(), |v| format!("{v:.4}"));
    for r in history {
        let _ = writeln!(
            s,
            "{},{:.6},{},{},{:.1}",
            r.epoch,
            r.loss,
            opt(r.val_accuracy),
            opt(r.val_within1),
            r.elapsed_s
        );
    }
    std::fs::write(path, s).map_err(|e| NetError::io(path, e))
}
