//! `endoloc features`: SURF keypoints of one image — count, keypoint file, overlay picture.

use std::path::PathBuf;

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
    /// Input image (any format the `image` crate reads; colour is converted to grey).
    image: PathBuf,

    /// Write the image with the keypoints drawn (PNG).
    #[arg(long, value_name = "PNG")]
    overlay: Option<PathBuf>,

    /// Write the keypoints: `.csv` (x,y,scale,orientation_rad,response,laplacian,octave; pixels,
    /// origin at the top-left pixel's centre) or `.json`.
    #[arg(long, value_name = "FILE")]
    keypoints: Option<PathBuf>,

    /// Include the descriptors in the JSON keypoint file.
    #[arg(long, requires = "keypoints")]
    descriptors: bool,

    /// Detector settings from a TOML file (fields of SurfConfig); flags below override it.
    #[arg(long, value_name = "TOML")]
    config: Option<PathBuf>,

    /// Hessian threshold (MATLAB MetricThreshold).
    #[arg(long)]
    threshold: Option<f32>,

    /// Number of octaves (MATLAB NumOctaves).
    #[arg(long)]
    octaves: Option<usize>,

    /// Filter sizes per octave (MATLAB NumScaleLevels).
    #[arg(long)]
    scale_levels: Option<usize>,

    /// Sampling step of the first octave in pixels.
    #[arg(long)]
    initial_step: Option<usize>,

    /// U-SURF: no orientation (0 = along +x).
    #[arg(long)]
    upright: bool,

    /// 128-d descriptors instead of 64-d.
    #[arg(long)]
    extended: bool,

    /// Use one thread.
    #[arg(long)]
    single_thread: bool,

    /// Replace --overlay and --keypoints files that already exist.
    #[arg(long)]
    force: bool,
}

impl From<Args> for FeaturesJob {
    fn from(a: Args) -> Self {
        FeaturesJob {
            image: a.image,
            overlay: a.overlay,
            keypoints: a.keypoints,
            descriptors: a.descriptors,
            config: a.config,
            threshold: a.threshold,
            octaves: a.octaves,
            scale_levels: a.scale_levels,
            initial_step: a.initial_step,
            upright: a.upright,
            extended: a.extended,
            single_thread: a.single_thread,
            force: a.force,
        }
    }
}

/// Runs `endoloc features`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&FeaturesJob::from(args).run(ui)?)?;
    Ok(())
}
