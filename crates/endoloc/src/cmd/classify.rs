//! `endoloc classify`: the zone of every frame of a sequence, raw and temporally filtered.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::{ClassifyJob, Progress};

/// Classify every frame of a sequence into the model's zones and compare with the truth.
///
/// Each frame goes to the zone of its nearest training descriptor (zone score = distance in
/// descriptor space, lower is better). Beyond the paper, the zones are filtered over the
/// video, two ways:
///
///   - an HMM over zones: `forward` is the causal filter (live use), `viterbi` the offline
///     best path;
///   - an HMM over (training frame, speed) that tracks the video along the training pass and
///     takes the zone holding most of the belief: `track` is the causal filter, `smooth`
///     forward–backward over the whole video (offline).
///
/// The truth zone of a frame is the zone of the nearest training pose (position, with 10° of
/// orientation counting as 1 mm); that training frame is the `truth_frame` column.
///
/// With --verify K (and the model's maps, from `endoloc map`), each frame is also checked
/// geometrically: its SURF features are registered in its K best zones, best first, and the
/// frame goes to the zone of the first registered pose (`verified`, per frame); the live
/// localizer does the same with the track filter and tracking (`live`). A frame that
/// registers nowhere keeps its raw (or tracked) zone.
///
/// Output: a CSV with one row per frame (frame, chosen zone, raw zone, its distance, nearest
/// training frame, forward and Viterbi zones, track and smoothed zones and training frames,
/// truth frame and zone; then verified and live zones with --verify) to --out or stdout, all
/// zone scores with --scores, every frame's descriptor with --descriptors (a NumPy `.npy`
/// array), and a summary of accuracies and timing on stderr. Existing --out, --scores and
/// --descriptors files are kept unless --force; files are written whole or not at all.
///
/// Examples:
///
///   endoloc classify --model models/paper50 --seq data/paper/test --out zones.csv
///
///   endoloc classify --model models/paper50 --seq data/paper/test --filter viterbi > zones.csv
///
///   endoloc classify --model models/paper50 --seq data/paper/test --verify 5 --out zones.csv
///
///   endoloc classify --model models/zone50 --also-model models/track50 --seq data/paper/test
///
///   endoloc classify --model models/paper50 --seq data/paper/train --descriptors train.npy --out train.csv
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Model folder written by `endoloc train`.
    #[arg(long, value_name = "MODEL")]
    model: PathBuf,

    /// Ensemble: join this model too (trained on the same pass with the same zones; repeat the
    /// flag for more). Each frame's descriptor joins every model's; the squared distance to a
    /// training frame is the mean of the models'. Maps, camera and filter parameters are
    /// --model's.
    #[arg(long, value_name = "MODEL")]
    also_model: Vec<PathBuf>,

    /// Sequence folder (images/ and poses.txt), e.g. DATASET/test.
    #[arg(long, value_name = "DIR")]
    seq: PathBuf,

    /// Which zone the `zone` column holds: none (raw), forward, viterbi, track (causal, as
    /// live) or smooth. All are always in the CSV.
    #[arg(long, default_value_t = ClassifyJob::default().filter)]
    filter: String,

    /// Write the per-frame CSV here (default: stdout).
    #[arg(long, value_name = "CSV")]
    out: Option<PathBuf>,

    /// Write every zone's score per frame (CSV: frame, then one column per zone).
    #[arg(long, value_name = "CSV")]
    scores: Option<PathBuf>,

    /// Write every frame's descriptor here as a NumPy array (`.npy`, float32, frames ×
    /// descriptor length, row i = frame i; an ensemble's joined descriptor): for study in
    /// Python (`numpy.load`). Run on the training pass for the database's descriptors.
    #[arg(long, value_name = "NPY")]
    descriptors: Option<PathBuf>,

    /// Only the first N frames.
    #[arg(long)]
    limit: Option<usize>,

    /// HMM: probability of staying in a zone per frame (default: the model's).
    #[arg(long)]
    stay: Option<f64>,

    /// HMM: emission temperature in descriptor-distance units (default: the model's).
    #[arg(long)]
    temperature: Option<f32>,

    /// Track filter: emission temperature (descriptor-distance units).
    #[arg(long)]
    track_temperature: Option<f32>,

    /// Track filter: scale of the move per frame, in training frames.
    #[arg(long)]
    track_scale: Option<f64>,

    /// Track filter: largest move per frame, in training frames.
    #[arg(long)]
    track_step: Option<usize>,

    /// Track filter: largest speed, training frames per test frame (0: no speed state).
    #[arg(long)]
    track_speed: Option<usize>,

    /// Track filter: probability per frame of the speed changing by one.
    #[arg(long)]
    track_speed_change: Option<f64>,

    /// Track filter: report each frame's zone given the next L frames too (fixed-lag
    /// smoothing; live, the zone L frames late). 0 = causal.
    #[arg(long, value_name = "L", default_value_t = ClassifyJob::default().track_lag)]
    track_lag: usize,

    /// Track filter: jump probability per frame.
    #[arg(long)]
    track_jump: Option<f64>,

    /// Verify every frame against the model's SURF maps in its K best zones (0 = off; needs
    /// `endoloc map` first). Adds the verified (per frame) and live zones.
    #[arg(long, value_name = "K", default_value_t = ClassifyJob::default().verify)]
    verify: usize,

    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto.
    #[arg(long, default_value_t = ClassifyJob::default().device)]
    device: String,

    /// Replace --out, --scores and --descriptors files that already exist.
    #[arg(long)]
    force: bool,
}

impl From<Args> for ClassifyJob {
    fn from(a: Args) -> Self {
        ClassifyJob {
            model: a.model,
            also_model: a.also_model,
            seq: a.seq,
            filter: a.filter,
            out: a.out,
            scores: a.scores,
            descriptors: a.descriptors,
            limit: a.limit,
            stay: a.stay,
            temperature: a.temperature,
            track_temperature: a.track_temperature,
            track_scale: a.track_scale,
            track_step: a.track_step,
            track_speed: a.track_speed,
            track_speed_change: a.track_speed_change,
            track_lag: a.track_lag,
            track_jump: a.track_jump,
            verify: a.verify,
            device: a.device,
            force: a.force,
        }
    }
}

/// Runs `endoloc classify`: the CSV (without --out) on stdout, the summary on stderr.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let report = ClassifyJob::from(args).run(ui)?;
    if let Some(csv) = &report.csv {
        crate::ui::print(&csv.trim_end_matches('\n'))?;
    }
    eprintln!("{report}");
    Ok(())
}
