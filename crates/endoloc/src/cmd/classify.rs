//! `endoloc classify`: the zone of every frame of a sequence, raw and temporally filtered.

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
    #[command(flatten)]
    job: ClassifyJob,
}

/// Runs `endoloc classify`: the CSV (without --out) on stdout, the summary on stderr.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let report = args.job.run(ui)?;
    if let Some(csv) = &report.csv {
        crate::ui::print(&csv.trim_end_matches('\n'))?;
    }
    eprintln!("{report}");
    Ok(())
}
