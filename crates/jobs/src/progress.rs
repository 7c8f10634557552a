//! How a job reports what it is doing: progress of long loops and notes for the user.
//!
//! Jobs never print. They call a [`Progress`] sink, which the command line turns into progress
//! bars and lines on stderr, and which a library user may ignore ([`Silent`]) or forward.

/// Receives a job's progress. Calls come from worker threads too, hence `Sync`.
pub trait Progress: Sync {
    /// A loop of `total` steps starts (e.g. frames to localize), labelled `label`.
    fn start(&self, label: &str, total: u64);
    /// `n` more steps of the current loop are done.
    fn inc(&self, n: u64);
    /// The current loop is over.
    fn finish(&self);
    /// A line for the user: a stage that starts, a warning, where the results are.
    fn note(&self, line: &str);
}

/// A [`Progress`] that discards everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {
    fn start(&self, _label: &str, _total: u64) {}
    fn inc(&self, _n: u64) {}
    fn finish(&self) {}
    fn note(&self, _line: &str) {}
}

/// Runs `f` inside a progress loop of `total` steps, finishing it however `f` ends.
pub fn with_progress<T>(
    progress: &dyn Progress,
    label: &str,
    total: u64,
    f: impl FnOnce() -> T,
) -> T {
    progress.start(label, total);
    let out = f();
    progress.finish();
    out
}
