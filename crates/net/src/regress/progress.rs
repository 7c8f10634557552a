//! Progress reports and per-epoch history of a regression training run.

use serde::{Deserialize, Serialize};

/// What a regression training run is doing, for progress display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegressPhase {
    /// Optimising.
    Training,
    /// Computing held-out errors.
    Validating,
}

/// A progress report from [`train_posenet`](super::train_posenet) /
/// [`train_offsetnet`](super::train_offsetnet).
#[derive(Debug, Clone, PartialEq)]
pub struct RegressProgress {
    /// Current phase.
    pub phase: RegressPhase,
    /// Steps done.
    pub done: usize,
    /// Steps in the run.
    pub total: usize,
    /// Current epoch (1-based).
    pub epoch: usize,
    /// Mean loss of the last finished epoch.
    pub loss: Option<f32>,
}

/// One epoch of a regression training history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RegressEpoch {
    /// 1-based epoch.
    pub epoch: usize,
    /// Mean loss over the epoch's steps (normalised units, see [`posenet_loss`](super::posenet_loss)).
    pub loss: f32,
    /// Mean position error of the held-out frames, mm (when validated this epoch).
    pub val_position_mm: Option<f64>,
    /// Mean orientation error of the held-out frames, degrees.
    pub val_orientation_deg: Option<f64>,
    /// Wall-clock seconds since the start of training.
    pub elapsed_s: f64,
}
