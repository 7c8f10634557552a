//! `endoloc demo`: the whole method on the built-in colon, from nothing to a report.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Parser;

use crate::cmd;

/// Run the whole pipeline on the built-in procedural colon, with no input files: simulate the
/// `small` dataset, train the Siamese zone classifier, build the per-zone SURF maps, localize
/// every test frame as a live video (frames in order, causal track filter, tracking from the
/// last refined pose) and evaluate against the ground truth. Each stage is the same command a
/// user would run (printed as it starts), so the demo doubles as a tutorial.
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
    #[arg(long, default_value = "endoloc-demo")]
    out: PathBuf,
    /// Uniform zones along the training pass.
    #[arg(long, default_value_t = 20)]
    zones: usize,
    /// Training epochs (the demo's short schedule; `endoloc train` defaults to more).
    #[arg(long, default_value_t = 40)]
    epochs: usize,
    /// SURF threshold of the map; test frames are described at twice it and retried at it
    /// (the paper's 200 is meant for larger, richer images).
    #[arg(long, default_value_t = cmd::localize::DEFAULT_MAP_THRESHOLD)]
    threshold: f64,
    /// Master seed of the simulation and the training.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Replace an existing output folder.
    #[arg(long)]
    force: bool,
}

/// Parses one stage's arguments exactly as the command line would.
pub(crate) fn parse<T: clap::Args>(argv: &[String]) -> Result<T> {
    #[derive(Parser)]
    struct Wrap<A: clap::Args> {
        #[command(flatten)]
        args: A,
    }
    Ok(Wrap::<T>::try_parse_from(argv)
        .with_context(|| format!("internal demo arguments {argv:?}"))?
        .args)
}

pub(crate) fn stage(title: &str, argv: &[String]) {
    eprintln!("\n== {title}: endoloc {}", argv.join(" "));
}

/// Runs `endoloc demo`.
pub fn run(args: Args) -> Result<()> {
    if args.out.exists() {
        if !args.force {
            bail!(
                "{} exists; pass --force to replace it (or --out another folder)",
                args.out.display()
            );
        }
        std::fs::remove_dir_all(&args.out)
            .with_context(|| format!("removing {}", args.out.display()))?;
    }
    std::fs::create_dir_all(&args.out)?;
    let t = std::time::Instant::now();
    let p = |rel: &str| args.out.join(rel).display().to_string();
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<String>>();

    let sim = s(&[
        "simulate",
        "--preset",
        "small",
        "--seed",
        &args.seed.to_string(),
        "--out",
        &p("data"),
    ]);
    stage("1/5 simulate", &sim);
    cmd::simulate::run(parse(&sim)?)?;

    let train = s(&[
        "train",
        "--data",
        &p("data"),
        "--zones",
        &args.zones.to_string(),
        "--out",
        &p("model"),
        "--schedule",
        "fast",
        "--epochs",
        &args.epochs.to_string(),
        "--seed",
        &args.seed.to_string(),
    ]);
    stage("2/5 train", &train);
    cmd::train::run(parse(&train)?)?;

    let map = s(&[
        "map",
        "--model",
        &p("model"),
        "--data",
        &p("data"),
        "--threshold",
        &args.threshold.to_string(),
    ]);
    stage("3/5 map", &map);
    cmd::localize::run_map(parse(&map)?)?;

    let loc = s(&[
        "localize",
        "--model",
        &p("model"),
        "--seq",
        &p("data/test"),
        "--out",
        &p("run"),
        "--live",
    ]);
    stage("4/5 localize", &loc);
    cmd::localize::run_localize(parse(&loc)?)?;

    let eval = s(&[
        "eval",
        "--gt",
        &p("data/test/poses.txt"),
        "--est",
        &p("run/trajectory.txt"),
        "--frames",
        &p("run/frames.csv"),
        "--out",
        &p("run/eval"),
    ]);
    stage("5/5 eval", &eval);
    cmd::eval::run(parse(&eval)?)?;

    eprintln!(
        "\ndemo done in {:.0} s: report {}",
        t.elapsed().as_secs_f64(),
        p("run/eval/report.md")
    );
    Ok(())
}
