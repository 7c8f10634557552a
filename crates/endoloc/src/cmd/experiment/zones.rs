//! `endoloc experiment zones`.

use anyhow::Result;
use endoloc_experiments::ZoneSweepJob;
use endoloc_jobs::Progress;

/// Sweep the number of uniform zones: for every count from --from to --to (step --step),
/// train --runs models with different seeds, map, localize the test pass with our method and
/// record the mean errors of each run; box-and-whisker plots of the run means against the
/// zone count (the paper's Fig. 4). Resumable: finished runs are kept in results.csv and
/// skipped; interrupt it at any time and run the same command again. Maps depend on the
/// zone table, not on the seed: each count maps once, and the test frames' SURF features are
/// extracted once for the whole sweep.
///
/// Every (count, run) cell is an independent job with its own folder
/// (OUT/models/zNNN/runRR/row.csv): --print-jobs prints one command per cell for GNU
/// parallel or a Slurm job array, and --merge writes the tables from the finished cells.
///
/// Time: each run is one training (`--epochs`, the dominant cost) plus about a minute of
/// look-up and localization; docs/RESULTS.md gives the measured wall time of the defaults.
///
/// Examples:
///
///   endoloc experiment zones --data data/paper --from 10 --to 170 --step 10 --runs 10
///   endoloc experiment zones --data data/paper --pretrained builtin-joint --epochs 0 --runs 1
///   endoloc experiment zones --data data/paper --print-jobs | grep -v '^#' | parallel -j 2
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: ZoneSweepJob,
}

/// Runs `endoloc experiment zones`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
