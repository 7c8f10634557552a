//! `endoloc demo`: the whole method on the built-in colon, from nothing to a report.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::{DemoJob, Progress};

/// Run the whole pipeline on the built-in procedural colon, with no input files: simulate the
/// `small` dataset, train the Siamese zone classifier, build the per-zone SURF maps, localize
/// every test frame as a live video (frames in order, causal track filter, tracking from the
/// last refined pose) and evaluate against the ground truth. Each stage is printed as the
/// command a user would type, so the demo doubles as a tutorial.
///
/// Output folder layout: data/ (dataset), model/ (classifier, zones, maps), run/
/// (trajectory.txt, frames.csv) and run/eval/ (metrics.json, report.md, plots).
///
/// Example:
///
///   endoloc demo --out endoloc-demo
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value_os_t = DemoJob::default().out)]
    out: PathBuf,
    /// Uniform zones along the training pass.
    #[arg(long, default_value_t = DemoJob::default().zones)]
    zones: usize,
    /// Training epochs (the demo's short schedule; `endoloc train` defaults to more).
    #[arg(long, default_value_t = DemoJob::default().epochs)]
    epochs: usize,
    /// SURF threshold of the map; test frames are described at twice it and retried at it.
    #[arg(long, default_value_t = DemoJob::default().threshold)]
    threshold: f32,
    /// Master seed of the simulation and the training.
    #[arg(long, default_value_t = DemoJob::default().seed)]
    seed: u64,
    /// Replace an existing output folder.
    #[arg(long)]
    force: bool,
}

/// Runs `endoloc demo`.
pub fn run(a: Args, ui: &dyn Progress) -> Result<()> {
    let job = DemoJob {
        out: a.out,
        zones: a.zones,
        epochs: a.epochs,
        threshold: a.threshold,
        seed: a.seed,
        force: a.force,
    };
    eprintln!("\n{}", job.run(ui)?);
    Ok(())
}
