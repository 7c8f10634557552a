//! `endoloc bench`: timing endoloc's stages on a dataset.

use anyhow::Result;
use endoloc_jobs::{LiveBenchJob, Progress};

/// Time endoloc's stages on your own data.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    Live(LiveArgs),
}

/// Replay a sequence as a live stream (frames in order, each decoded before its clock
/// starts) through `localize --live` and print the median time per stage, the p95 per frame
/// and the fraction refined. By default every frame is also localized by the plain path —
/// SURF's reference loop (filter responses sample by sample at every level), the zone
/// classifier on every frame (the current path classifies only the frames it cannot track)
/// and brute-force matching of tracked frames (the current path matches them guided by the
/// predicted pose) — the two alternating which runs first, so the speed-up is a ratio
/// measured in one run on one machine. The number of frames whose result differs is
/// printed. With --against, a second sequence (the same pass through the unchanged colon
/// beside a changed one, say) goes through the current localizer instead, frame by frame
/// alternating with the first: the ratio of their latencies, from one run. With --video, a
/// video file goes through `localize --live --video` (--realtime: paced at its frame times,
/// the newest frame winning): decoding, resizing, localization and the latency from a
/// frame's arrival to its pose, median and p95, with the frames dropped. Nothing is
/// written.
///
/// Examples:
///
///   endoloc bench live --model models/bj --seq data/paper/test
///
///   endoloc bench live --model models/bj --seq data/paper/test --frames 500 --no-compare
///
///   endoloc bench live --model models/bj --seq data/moderate/test --against data/paper/test
///
///   endoloc bench live --model models/bj --video pass-1080p.mp4 --realtime
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
struct LiveArgs {
    #[command(flatten)]
    job: LiveBenchJob,
    #[command(flatten)]
    confirm: super::localize::ConfirmArgs,
}

pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    match args.what {
        What::Live(a) => {
            let mut job = a.job;
            a.confirm.apply(&mut job.confirm);
            crate::ui::print(&job.run(ui)?)?;
        }
    }
    Ok(())
}
