//! `endoloc experiment compare`.

use anyhow::Result;
use endoloc_experiments::CompareJob;
use endoloc_jobs::Progress;

/// Compare every method on one dataset: our two-step method (per frame as in the paper,
/// with candidate zones, live and offline temporal filtering) against the baselines —
/// `classify` (zone median pose), `retrieval` (pose of the nearest training image),
/// `posenet`, `offsetnet` and `vo` (monocular visual odometry, first pose aligned, scale
/// from the ground truth). Writes compare.md, compare.json, compare.png and report.html;
/// each method's trajectory, frames.csv and evaluation go to runs/<method>/. Models and
/// finished runs are kept: running again continues (delete runs/<method> to redo one).
///
/// Example:
///
///   endoloc experiment compare --data data/paper --out experiments/compare
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: CompareJob,
}

/// Runs `endoloc experiment compare`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
