//! `endoloc experiment perturb`.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::Progress;
use endoloc_jobs::experiment::*;

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
    data: super::DataArgs,
    /// Output folder.
    #[arg(long, default_value_os_t = PerturbJob::default().out)]
    out: PathBuf,
    /// Largest zone offset e.
    #[arg(long, default_value_t = PerturbJob::default().max)]
    max: usize,
    /// Use every n-th test frame.
    #[arg(long, default_value_t = PerturbJob::default().every)]
    every: usize,
    /// Map points also come from this many zones on each side of the forced one (0: the
    /// forced zone's points only, as in the paper).
    #[arg(long, default_value_t = PerturbJob::default().neighbours)]
    neighbours: usize,
    /// Trained model to use (trained into OUT/models/siamese when absent).
    #[arg(long, value_name = "DIR")]
    model: Option<PathBuf>,
    /// Zones when training a model.
    #[arg(long, default_value_t = PerturbJob::default().zones)]
    zones: String,
    /// Training epochs when training a model.
    #[arg(long)]
    epochs: Option<usize>,
    /// Training seed.
    #[arg(long, default_value_t = PerturbJob::default().seed)]
    seed: u64,
    /// SURF threshold of a map built here and of the test frames.
    #[arg(long, default_value_t = PerturbJob::default().threshold)]
    threshold: f32,
    /// Use an output folder that holds something else.
    #[arg(long)]
    force: bool,
}

impl From<Args> for PerturbJob {
    fn from(a: Args) -> Self {
        PerturbJob {
            data: a.data.into(),
            out: a.out,
            max: a.max,
            every: a.every,
            neighbours: a.neighbours,
            model: a.model,
            zones: a.zones,
            epochs: a.epochs,
            seed: a.seed,
            threshold: a.threshold,
            force: a.force,
        }
    }
}

/// Runs `endoloc experiment perturb`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&PerturbJob::from(args).run(ui)?)?;
    Ok(())
}
