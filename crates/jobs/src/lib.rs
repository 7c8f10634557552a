//! endoloc's stages as typed jobs: the library behind the `endoloc` command line.
//!
//! Each stage is a plain, serialisable struct (`SimulateJob`, `TrainJob`, `MapJob`,
//! `LocalizeJob`, `EvalJob`, …) whose `Default` is the method the documentation measures. Its
//! `run` takes a [`Progress`] sink and returns a typed report; nothing here prints.
//!
//! Each option is defined once, on its job's field: its name, type, default (the job's
//! `Default`) and help (the field's doc comment). With the `cli` feature every job also
//! derives clap's `Args` from those fields, so the command line parses its arguments straight
//! into the job (`#[command(flatten)]`), runs it and prints the report; the Python module
//! reads its keyword arguments from the same derive; `endoloc run` reads the same jobs from a
//! TOML file; the demo composes them, and so do the experiments (`endoloc-experiments`, the
//! crate above this one).
//!
//! ```no_run
//! use endoloc_jobs::{Silent, MapJob};
//! let job = MapJob { model: "models/small".into(), data: "data/small".into(), ..MapJob::default() };
//! let report = job.run(&Silent)?;
//! println!("{report}");
//! # Ok::<(), endoloc_jobs::JobError>(())
//! ```

#![warn(missing_docs)]

pub mod error;
pub mod output;
pub mod progress;

pub mod baselines;
pub mod bench;
pub mod choice;
pub mod classify;
pub mod dataset;
pub mod eval;
pub mod features;
pub mod import;
pub mod localize;
pub mod map;
pub mod pipeline;
pub mod predict;
pub mod pretrain;
pub mod simulate;
pub mod train;
pub mod view;

pub use bench::{LiveBenchJob, LiveBenchReport, VideoBench};
pub use classify::{ClassifyJob, ClassifyReport, ZoneAccuracy};
pub use dataset::{DatasetAction, DatasetJob, DatasetReport};
pub use endoloc_features::MaskDetectConfig;
pub use error::{Context, JobError, Result};
pub use eval::{EvalJob, EvalReport};
pub use features::{FeaturesJob, FeaturesReport};
pub use import::{ImportFormat, ImportJob, ImportReport};
pub use localize::{LocalizeJob, LocalizeMethod, LocalizeReport, STREAM_FILE, StreamSummary};
pub use map::{MapJob, MapReport};
pub use pipeline::{DemoJob, DemoReport, RunJob, Timings};
pub use pretrain::{PretrainJob, PretrainReport};
pub use progress::{Bar, Progress, Silent};
pub use simulate::{SimulateJob, SimulateReport};
pub use train::{TrainJob, TrainMethod, TrainReport};
pub use view::{LiveView, ViewJob, ViewReport};

/// The value parser of a change severity (`none`, `mild`, `moderate`, `severe`).
#[cfg(feature = "cli")]
pub fn severity_parser() -> impl clap::builder::TypedValueParser<Value = endoloc_sim::Severity> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(endoloc_sim::Severity::ALL.map(|p| p.name())).map(
        |s| {
            s.parse::<endoloc_sim::Severity>()
                .expect("a listed severity")
        },
    )
}

/// The value parser of a path option whose default is empty (the job then picks the path, or
/// asks for one): clap's own path parser refuses an empty value, its default included.
#[cfg(feature = "cli")]
pub(crate) fn path_or_empty() -> impl clap::builder::TypedValueParser<Value = std::path::PathBuf> {
    use clap::builder::TypedValueParser as _;
    clap::builder::OsStringValueParser::new().map(std::path::PathBuf::from)
}
