//! `endoloc features`: SURF keypoints of one image — count, keypoint file, overlay picture.

use anyhow::Result;
use endoloc_jobs::{FeaturesJob, Progress};

/// Detect SURF keypoints in an image: print the count, optionally write the keypoints (CSV or
/// JSON, by extension) and an overlay picture (circles of radius 2.5σ with an orientation line;
/// green = dark blob, magenta = bright blob). Existing output files are kept unless --force.
///
/// Defaults are the paper's MATLAB settings: MetricThreshold 200, NumOctaves 4,
/// NumScaleLevels 6 (same units as MATLAB/OpenCV on 8-bit images).
///
/// Examples:
///
///   endoloc features frame.png --overlay frame_surf.png
///
///   endoloc features frame.png --keypoints kp.csv --threshold 400 --upright
///
///   endoloc features frame.png --keypoints kp.json --descriptors --extended
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: FeaturesJob,
}

/// Runs `endoloc features`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
