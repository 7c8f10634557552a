//! `endoloc demo`: the whole method on the built-in colon, from nothing to a report.

use std::path::PathBuf;

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
    /// Output folder.
    #[arg(long, default_value_os_t = DemoJob::default().out)]
    out: PathBuf,
    /// Uniform zones along the training pass.
    #[arg(long, default_value_t = DemoJob::default().zones)]
    zones: usize,
    /// Train the paper's Siamese classifier from scratch (a short schedule) instead of
    /// indexing the pass with the shipped network.
    #[arg(long)]
    train: bool,
    /// Training epochs with --train (`endoloc train` defaults to more).
    #[arg(long, default_value_t = DemoJob::default().epochs)]
    epochs: usize,
    /// Image size of the simulated frames, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
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
        train: a.train,
        epochs: a.epochs,
        size: a.size,
        threshold: a.threshold,
        seed: a.seed,
        force: a.force,
    };
    crate::ui::print(&format!("\n{}", job.run(ui)?))?;
    Ok(())
}

/// Parses `WIDTHxHEIGHT`.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let parsed = s
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    parsed
        .filter(|&(w, h): &(u32, u32)| w >= 16 && h >= 16)
        .ok_or_else(|| format!("{s}: expected WIDTHxHEIGHT, e.g. 640x480"))
}
