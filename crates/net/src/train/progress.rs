//! Progress reports of a training run, for display.

/// What the training loop is doing, for progress display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Decoding and resizing the training images.
    LoadingImages,
    /// Optimising.
    Training,
    /// Computing descriptors of all training frames.
    Describing,
    /// Writing the model folder.
    Saving,
}

/// A progress report from [`train`](super::train) and [`fit`](super::fit).
#[derive(Debug, Clone, PartialEq)]
pub struct TrainProgress {
    /// Current phase.
    pub phase: Phase,
    /// Units done in this phase (images, or steps when training).
    pub done: usize,
    /// Units in this phase.
    pub total: usize,
    /// Current epoch (1-based; 0 outside training).
    pub epoch: usize,
    /// Mean loss of the last finished epoch.
    pub loss: Option<f32>,
    /// Last validation zone accuracy (fraction).
    pub val_accuracy: Option<f32>,
}

impl TrainProgress {
    /// Progress of a phase outside the optimisation (no epoch, loss or accuracy).
    pub fn outside_training(phase: Phase, done: usize, total: usize) -> Self {
        TrainProgress {
            phase,
            done,
            total,
            epoch: 0,
            loss: None,
            val_accuracy: None,
        }
    }
}
