//! How a job reports what it is doing: progress of long loops and notes for the user.
//!
//! Jobs never print. They call a [`Progress`] sink, which the command line turns into progress
//! bars and lines on stderr, and which a library user may ignore ([`Silent`]) or forward.

use std::sync::atomic::{AtomicU64, Ordering};

/// Receives a job's progress. Calls come from worker threads too, hence `Sync`.
pub trait Progress: Sync {
    /// A loop of `total` steps starts (e.g. frames to localize), labelled `label`.
    fn start(&self, label: &str, total: u64);
    /// `n` more steps of the current loop are done.
    fn inc(&self, n: u64);
    /// The current loop has done `done` of `total` steps (for loops whose length changes).
    fn position(&self, done: u64, total: u64) {
        let _ = (done, total);
    }
    /// A short status of the current loop (e.g. the training loss).
    fn message(&self, msg: &str) {
        let _ = msg;
    }
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

/// One loop of a job on a [`Progress`] sink; finished when dropped.
pub struct Bar<'a> {
    sink: &'a dyn Progress,
    total: AtomicU64,
}

impl<'a> Bar<'a> {
    /// Starts a loop of `total` steps on `sink`.
    pub fn new(sink: &'a dyn Progress, total: u64, label: &str) -> Self {
        sink.start(label, total);
        Bar {
            sink,
            total: AtomicU64::new(total),
        }
    }
    /// `n` more steps done.
    pub fn inc(&self, n: u64) {
        self.sink.inc(n);
    }
    /// A new length of the loop.
    pub fn set_length(&self, total: u64) {
        self.total.store(total, Ordering::Relaxed);
    }
    /// `done` steps done so far.
    pub fn set_position(&self, done: u64) {
        self.sink.position(done, self.total.load(Ordering::Relaxed));
    }
    /// A short status line.
    pub fn set_message(&self, msg: impl AsRef<str>) {
        self.sink.message(msg.as_ref());
    }
    /// Ends the loop now.
    pub fn finish_and_clear(self) {}
}

impl Drop for Bar<'_> {
    fn drop(&mut self) {
        self.sink.finish();
    }
}

/// Starts a loop of `total` steps labelled `label` on `sink`.
pub fn bar<'a>(sink: &'a dyn Progress, total: u64, label: &str) -> Bar<'a> {
    Bar::new(sink, total, label)
}
