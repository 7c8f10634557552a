//! `endoloc demo`: the whole method on the built-in colon, from nothing to a report.

use anyhow::Result;
use endoloc_jobs::{DemoJob, Progress};

/// Run the whole method on the built-in procedural colon, with no input files: simulate a
/// small dataset (300 + 300 frames at 640×480), index its training pass with the shipped
/// zone classifier (`builtin-joint`, no training), build the per-zone SURF maps, localize every
/// test frame as a live video (frames in order, causal track filter, tracking from the last
/// refined pose), evaluate against the ground truth and write a viewer page. Each stage is
/// printed as the command a user would type, so the demo doubles as a tutorial.
///
/// Output folder layout: data/ (dataset), model/ (classifier, zones, maps), run/
/// (trajectory.txt, frames.csv, view.html) and run/eval/ (metrics.json, report.md, plots).
///
/// Examples:
///
///   endoloc demo
///
///   endoloc demo --train --out endoloc-demo-trained     # the paper's classifier, trained here
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: DemoJob,
}

/// Runs `endoloc demo`.
pub fn run(a: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&format!("\n{}", a.job.run(ui)?))?;
    Ok(())
}
