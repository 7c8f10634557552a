//! `endoloc experiment benchmark`.

use anyhow::Result;
use endoloc_experiments::BenchmarkJob;
use endoloc_jobs::Progress;

/// Run the whole chain — simulate, index (or train), map, localize with each method,
/// evaluate — on several colons: procedural ones (one per --seeds value; none of them was
/// used to choose a setting) and CT colons (--gca). Writes benchmark.md, benchmark.json,
/// benchmark.png and report.html: each method's figures per colon and their mean ± 95 %
/// confidence interval across colons. Every colon is an independent job in colons/<name>/;
/// finished colons are kept, so running again continues. --print-jobs prints one command per
/// colon, for GNU parallel or a Slurm array; --merge then writes the tables.
///
/// Examples:
///
///   endoloc experiment benchmark --seeds 1-8 --gca ../shared/data/gca-edin-00090 --inflation 1.5
///
///   endoloc experiment benchmark --seeds 1-8 --print-jobs | grep -v '^#' | parallel -j 4
///   endoloc experiment benchmark --seeds 1-8 --merge
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: BenchmarkJob,
}

/// Runs `endoloc experiment benchmark`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
