//! `endoloc experiment perturb`.

use anyhow::Result;
use endoloc_experiments::PerturbJob;
use endoloc_jobs::Progress;

/// Force the zone of each test frame to k ± e (k: its true zone, from the ground-truth pose)
/// for e = −max … max and run the refinement from that zone's median pose with that zone's
/// map points; plot the errors against e (the paper's Fig. 7). Writes perturb.csv,
/// perturb.md, perturb.png and report.html.
///
/// Example:
///
///   endoloc experiment perturb --data data/paper --model models/paper50 --max 5
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: PerturbJob,
}

/// Runs `endoloc experiment perturb`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
