//! `endoloc experiment zones`.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::Progress;
use endoloc_jobs::experiment::*;

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
    data: super::DataArgs,
    /// Output folder.
    #[arg(long, default_value_os_t = ZoneSweepJob::default().out)]
    out: PathBuf,
    /// Smallest zone count.
    #[arg(long, default_value_t = ZoneSweepJob::default().from)]
    from: usize,
    /// Largest zone count.
    #[arg(long, default_value_t = ZoneSweepJob::default().to)]
    to: usize,
    /// Step between zone counts.
    #[arg(long, default_value_t = ZoneSweepJob::default().step)]
    step: usize,
    /// Runs (training seeds 0, 1, …) per zone count.
    #[arg(long, default_value_t = ZoneSweepJob::default().runs)]
    runs: usize,
    /// Training epochs per run (the `fast` schedule with fewer epochs, to fit a night).
    #[arg(long, default_value_t = ZoneSweepJob::default().epochs)]
    epochs: usize,
    /// SURF threshold of the maps; test frames are described at twice it and retried at it
    /// (as `endoloc localize` does by default; see `endoloc map --help`).
    #[arg(long, default_value_t = ZoneSweepJob::default().threshold)]
    threshold: f32,
    /// Zones tried per frame (1 = the paper's rule).
    #[arg(long, default_value_t = ZoneSweepJob::default().candidate_zones)]
    candidate_zones: usize,
    /// Keep each run's model folder (weights, descriptors) instead of deleting it once the
    /// run is recorded (its map is kept for the next runs either way).
    #[arg(long)]
    keep_models: bool,
    /// Start weights of every run's zone network: a file, or `builtin`, `builtin-track`,
    /// `builtin-joint` (the shipped networks). With --epochs 0 a run only indexes the training
    /// pass with them (the shipped network without training; one run per count).
    #[arg(long)]
    pretrained: Option<PathBuf>,
    /// Run only this cell of the grid, COUNT:RUN (e.g. 50:3), as printed by --print-jobs;
    /// the tables are not written.
    #[arg(long, value_name = "COUNT:RUN", conflicts_with_all = ["print_jobs", "merge"])]
    cell: Option<String>,
    /// Print one command per cell (for GNU parallel or a Slurm job array) and the merge
    /// command, and stop.
    #[arg(long, conflicts_with = "merge")]
    print_jobs: bool,
    /// Run nothing: write the tables from the cells already finished (and list the others).
    #[arg(long)]
    merge: bool,
    /// Use an output folder that holds something else.
    #[arg(long)]
    force: bool,
}

impl From<Args> for ZoneSweepJob {
    fn from(a: Args) -> Self {
        ZoneSweepJob {
            data: a.data.into(),
            out: a.out,
            from: a.from,
            to: a.to,
            step: a.step,
            runs: a.runs,
            epochs: a.epochs,
            threshold: a.threshold,
            candidate_zones: a.candidate_zones,
            keep_models: a.keep_models,
            pretrained: a.pretrained,
            cell: a.cell,
            print_jobs: a.print_jobs,
            merge: a.merge,
            force: a.force,
        }
    }
}

/// Runs `endoloc experiment zones`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&ZoneSweepJob::from(args).run(ui)?)?;
    Ok(())
}
