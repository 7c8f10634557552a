//! `endoloc dataset`: inspect datasets in endoloc's format v1 (`check`, `info`) and find their
//! image mask (`mask`).

use anyhow::{Result, bail};
use endoloc_jobs::{DatasetJob, Progress};

/// Inspect a dataset: check it for problems (`check`; exits non-zero when any is found),
/// summarize it (`info`), or find its image mask (`mask`).
///
/// Examples:
///
///   endoloc dataset check data/small
///
///   endoloc dataset info data/small
///
///   endoloc dataset mask data/c3vd-like
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: DatasetJob,
}

/// Runs `endoloc dataset`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let report = args.job.run(ui)?;
    crate::ui::print(&report)?;
    if report.problems() > 0 {
        bail!(
            "{} problem(s) in {}",
            report.problems(),
            args.job.dir.display()
        );
    }
    Ok(())
}
