//! endoloc's experiments: the paper's comparisons and studies, composed from the stages of
//! `endoloc-jobs`, each in one output folder with its tables (markdown, JSON), plots and a
//! self-contained HTML report. Like the stages, each is a serialisable job whose options are
//! its fields (clap's derive with the `cli` feature), run with an
//! [`endoloc_jobs::Progress`] sink.
//!
//! - [`BenchmarkJob`] — the whole chain over several colons, mean ± 95 % confidence interval;
//! - [`ChangesJob`] — every factor of a colon that changes between the passes, alone at each
//!   severity, over several colons: where endoloc stops holding;
//! - [`CompareJob`] — every method on the same data (the paper's Table I);
//! - [`ZoneSweepJob`] — the Monte-Carlo zone-count sweep (the paper's Fig. 4), resumable;
//! - [`ExpertJob`] — anatomical zones against uniform ones;
//! - [`PerturbJob`] — the error when the zone is forced wrong by ±e (the paper's Fig. 7).
//!
//! Experiments reuse what they already computed: a folder's models, maps and runs are kept,
//! and a second run continues where the first stopped. SURF features of the test frames are
//! extracted once per run and shared by every method that needs them.

#![warn(missing_docs)]

mod benchmark;
mod changes;
mod common;
mod compare;
mod expert;
mod perturb;
mod zones;

pub use benchmark::{
    BenchmarkJob, BenchmarkReport, ColonRow, Interval, MethodSummary, Seeds, interval, parse_seeds,
    t95,
};
pub use changes::{
    ChangesJob, ChangesReport, Condition, ConditionRow, ConditionSummary, Factor, Factors,
};
pub use common::{DataArgs as ExperimentData, ExperimentReport, MethodRow};
pub use compare::{CompareJob, Method as CompareMethod};
pub use expert::ExpertJob;
pub use perturb::{PerturbJob, Row as PerturbRow};
pub use zones::{RunRow as SweepRun, ZoneSweepJob};
