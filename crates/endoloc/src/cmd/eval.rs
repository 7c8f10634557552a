//! `endoloc eval`: errors, plots and a report for an estimated trajectory.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::ValueEnum;
use endoloc_data::read_tum;
use endoloc_eval::align::AlignmentKind;
use endoloc_eval::association::AssociationConfig;
use endoloc_eval::rpe::RpeConfig;
use endoloc_eval::{
    EvalConfig, EvalInputs, Sources, WriteOptions, evaluate, read_frames_csv, read_zones_csv,
    write_results,
};

/// Evaluate an estimated trajectory against the ground truth: position / orientation errors
/// (evo-compatible APE, optional Umeyama alignment), relative pose error, localized fraction,
/// zone accuracy, per-zone and per-status tables, plots and a markdown report.
///
/// Trajectories are TUM files (timestamp tx ty tz qx qy qz qw; T_wc, mm) associated by
/// timestamp as evo does; a ground-truth pose's frame index is its line order. The numbers
/// equal `evo_ape tum GT EST` (-r trans_part / angle_deg) and `evo_rpe` to 1e-6.
///
/// Writes into --out: metrics.json, errors.csv (one row per test frame), report.md and
/// trajectory_xy.png, errors_along.png, error_cdf.png. Existing files are kept unless --force.
///
/// Examples:
///
///   endoloc eval --gt data/small/test/poses.txt --est runs/a/trajectory.txt
///
///   endoloc eval --gt poses.txt --est runs/a/trajectory.txt --frames runs/a/frames.csv \
///       --gt-zones runs/a/test_zones.csv --out runs/a/eval --force
///
///   endoloc eval --gt poses.txt --est slam.txt --align se3 --no-plots
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Ground-truth trajectory of the test sequence (TUM; e.g. the dataset's test/poses.txt).
    #[arg(long)]
    gt: PathBuf,

    /// Estimated trajectory (TUM; a localization run's trajectory.txt).
    #[arg(long)]
    est: PathBuf,

    /// The run's frames.csv (status, zone, ... per frame). Default: frames.csv next to --est,
    /// when it exists.
    #[arg(long)]
    frames: Option<PathBuf>,

    /// True zone of each test frame: CSV with header `frame,zone` (0-based frame and zone
    /// indices). Enables zone_accuracy.
    #[arg(long, value_name = "CSV")]
    gt_zones: Option<PathBuf>,

    /// Output folder. Default: `eval/` next to --est.
    #[arg(short, long)]
    out: Option<PathBuf>,

    /// Replace existing output files.
    #[arg(long)]
    force: bool,

    /// Align the estimate onto the ground truth before computing errors: `none`, `se3`
    /// (rigid Umeyama, evo -a) or `sim3` (with scale, evo -a -s).
    #[arg(long, value_enum, default_value = "none")]
    align: AlignArg,

    /// Largest timestamp difference for associating poses, seconds (evo --t_max_diff).
    #[arg(long, default_value_t = 0.01)]
    t_max_diff: f64,

    /// Offset added to the estimate's timestamps before associating, seconds (evo --t_offset).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    t_offset: f64,

    /// RPE pair distance, in associated poses (evo_rpe --delta N --delta_unit f).
    #[arg(long, default_value_t = 1)]
    rpe_delta: usize,

    /// RPE over every pair (i, i+delta) instead of consecutive pairs (evo_rpe --all_pairs).
    #[arg(long)]
    rpe_all_pairs: bool,

    /// Do not draw the PNG plots.
    #[arg(long)]
    no_plots: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum AlignArg {
    None,
    Se3,
    Sim3,
}

fn parent_or_dot(p: &Path) -> PathBuf {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Runs `endoloc eval`.
pub fn run(args: Args) -> Result<()> {
    let config = EvalConfig {
        association: AssociationConfig {
            max_diff_s: args.t_max_diff,
            offset_s: args.t_offset,
        },
        alignment: match args.align {
            AlignArg::None => AlignmentKind::None,
            AlignArg::Se3 => AlignmentKind::Se3,
            AlignArg::Sim3 => AlignmentKind::Sim3,
        },
        rpe: RpeConfig {
            delta_frames: args.rpe_delta,
            all_pairs: args.rpe_all_pairs,
        },
    };
    let gt = read_tum(&args.gt).context("reading the ground truth (--gt)")?;
    let est = read_tum(&args.est).context("reading the estimate (--est)")?;
    let frames_path = args.frames.clone().or_else(|| {
        let p = parent_or_dot(&args.est).join("frames.csv");
        p.is_file().then(|| {
            tracing::info!("using {}", p.display());
            p
        })
    });
    let frames = frames_path
        .as_deref()
        .map(read_frames_csv)
        .transpose()
        .context("reading frames.csv")?;
    let zones = args
        .gt_zones
        .as_deref()
        .map(read_zones_csv)
        .transpose()
        .context("reading the ground-truth zones (--gt-zones)")?;
    let evaluation = evaluate(
        &EvalInputs {
            gt: &gt,
            est: &est,
            frames: frames.as_deref(),
            gt_zones: zones.as_deref(),
        },
        &config,
    )
    .with_context(|| {
        format!(
            "evaluating {} against {}",
            args.est.display(),
            args.gt.display()
        )
    })?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| parent_or_dot(&args.est).join("eval"));
    let shown = |p: &Path| p.display().to_string();
    let written = write_results(
        &evaluation,
        &out,
        &WriteOptions {
            force: args.force,
            no_plots: args.no_plots,
            plot: Default::default(),
            sources: Sources {
                gt: shown(&args.gt),
                est: shown(&args.est),
                frames: frames_path.as_deref().map(shown),
                gt_zones: args.gt_zones.as_deref().map(shown),
            },
        },
    )?;
    if !args.no_plots && !written.plot_text {
        tracing::warn!("no usable system font (fontconfig): plots drawn without text");
    }
    let m = &evaluation.metrics;
    println!(
        "frames {}  localized {} ({:.1} %)",
        m.frames,
        m.localized,
        100.0 * m.localized_fraction
    );
    for (name, s) in [
        ("position mm", &m.position_mm),
        ("orientation °", &m.orientation_deg),
    ] {
        println!(
            "{name:>14}: mean {:.3}  median {:.3}  rmse {:.3}  p90 {:.3}  max {:.3}",
            s.mean, s.median, s.rmse, s.p90, s.max
        );
    }
    if let Some(r) = &m.rpe {
        println!(
            "{:>14}: {:.3} mm  {:.3}° (rmse, delta {} frames)",
            "RPE", r.translation_mm.rmse, r.rotation_deg.rmse, r.delta_frames
        );
    }
    if let Some(acc) = m.zone_accuracy {
        println!("{:>14}: {:.1} %", "zone accuracy", 100.0 * acc);
    }
    println!("wrote {} files to {}", written.files.len(), out.display());
    Ok(())
}
