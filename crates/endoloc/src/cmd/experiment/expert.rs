//! `endoloc experiment expert`.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::Progress;
use endoloc_jobs::experiment::*;

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
    /// The training sequence needs sections.csv.
    #[command(flatten)]
    data: super::DataArgs,
    /// Output folder.
    #[arg(long, default_value_os_t = ExpertJob::default().out)]
    out: PathBuf,
    /// Anatomical zones in all (the sections, long ones subdivided).
    #[arg(long, default_value_t = ExpertJob::default().count)]
    count: usize,
    /// Uniform zone count to compare with.
    #[arg(long, conflicts_with = "sweep")]
    uniform: Option<usize>,
    /// Take the uniform count from a finished zone sweep (its best median).
    #[arg(long, value_name = "DIR")]
    sweep: Option<PathBuf>,
    /// Training epochs (default: the `fast` schedule's).
    #[arg(long)]
    epochs: Option<usize>,
    /// Training seed.
    #[arg(long, default_value_t = ExpertJob::default().seed)]
    seed: u64,
    /// SURF threshold of the maps; test frames are described at twice it and retried at it
    /// (as `endoloc localize` does by default; see `endoloc map --help`).
    #[arg(long, default_value_t = ExpertJob::default().threshold)]
    threshold: f32,
    /// Use an output folder that holds something else.
    #[arg(long)]
    force: bool,
}

impl From<Args> for ExpertJob {
    fn from(a: Args) -> Self {
        ExpertJob {
            data: a.data.into(),
            out: a.out,
            count: a.count,
            uniform: a.uniform,
            sweep: a.sweep,
            epochs: a.epochs,
            seed: a.seed,
            threshold: a.threshold,
            force: a.force,
        }
    }
}

/// Runs `endoloc experiment expert`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&ExpertJob::from(args).run(ui)?)?;
    Ok(())
}
