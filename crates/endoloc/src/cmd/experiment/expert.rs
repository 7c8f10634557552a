//! `endoloc experiment expert`.

use anyhow::Result;
use endoloc_experiments::ExpertJob;
use endoloc_jobs::Progress;

/// Anatomical ("expert") zones against uniform ones: train one model on the sections of
/// sections.csv subdivided to --count zones and one on --uniform equal-length zones (by
/// default the best count of a finished `experiment zones` folder given with --sweep, else
/// 50), map, localize and evaluate both with our method. Writes expert.md, expert.json,
/// expert.png and report.html.
///
/// Example:
///
///   endoloc experiment expert --data data/paper --sweep experiments/zones
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: ExpertJob,
}

/// Runs `endoloc experiment expert`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
