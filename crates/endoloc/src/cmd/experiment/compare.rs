//! `endoloc experiment compare`.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::Progress;
use endoloc_jobs::experiment::*;

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
    data: super::DataArgs,
    /// Output folder.
    #[arg(long, default_value_os_t = CompareJob::default().out)]
    out: PathBuf,
    /// Zones (a count, or `expert`).
    #[arg(long, default_value_t = CompareJob::default().zones)]
    zones: String,
    /// Training epochs of the learned models (default: each schedule's own).
    #[arg(long)]
    epochs: Option<usize>,
    /// Seed of every training.
    #[arg(long, default_value_t = CompareJob::default().seed)]
    seed: u64,
    /// SURF threshold of the maps; test frames are described at twice it and retried at it
    /// (as `endoloc localize` does by default; see `endoloc map --help`).
    #[arg(long, default_value_t = CompareJob::default().threshold)]
    threshold: f32,
    /// Use this trained Siamese model (with or without a map) instead of training one.
    #[arg(long, value_name = "DIR")]
    model: Option<PathBuf>,
    /// Methods to run (default: all). endoloc-confirm and endoloc-live-confirm are `endoloc
    /// localize`'s defaults; endoloc and endoloc-live localize with --no-confirm.
    #[arg(long, value_delimiter = ',')]
    methods: Vec<CompareMethod>,
    /// Use an output folder that holds something else.
    #[arg(long)]
    force: bool,
}

impl From<Args> for CompareJob {
    fn from(a: Args) -> Self {
        CompareJob {
            data: a.data.into(),
            out: a.out,
            zones: a.zones,
            epochs: a.epochs,
            seed: a.seed,
            threshold: a.threshold,
            model: a.model,
            methods: a.methods,
            force: a.force,
        }
    }
}

/// Runs `endoloc experiment compare`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&CompareJob::from(args).run(ui)?)?;
    Ok(())
}
