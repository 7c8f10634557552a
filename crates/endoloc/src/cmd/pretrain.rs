//! `endoloc pretrain`: start weights for the zone classifier from simulated colons.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::{PretrainJob, Progress};

/// Pretrain the zone classifier's network on simulated colons, each seen in two passes, and
/// write start weights for `endoloc train --pretrained`.
///
/// One pass through a colon cannot show how a second pass sees the same place from elsewhere
/// (other gaze, lateral offset, roll); the paper starts from Places weights for that. Here
/// each pretraining colon is simulated with a training and a test pass, and the network is
/// trained with the test pass's frames in the zone of their nearest training pose
/// (`endoloc train --also-seq test`), colon after colon, each starting from the previous
/// one's weights. The colons share nothing with your data but the simulator.
///
/// `--joint` trains one network on every colon's two passes at once instead (the places of
/// each colon kept apart, negatives drawn from the partner's colon, where the look-alikes
/// are). A joint run holds every colon's images in memory.
///
/// The weights shipped with endoloc (`endoloc train --pretrained builtin`, `builtin-track`,
/// `builtin-joint`) were made with this command; see `endoloc train --help`.
///
/// Output: OUT/colon-SEED/ (each dataset), OUT/model-SEED/ (each model; with `--joint` one
/// OUT/joint/ with its checkpoint, history and loss curve) and OUT/weights.safetensors (the
/// last model's weights). A colon or model already in OUT is reused, so an interrupted run
/// continues where it stopped; delete one to redo it.
///
/// Examples:
///
///   endoloc pretrain --out models/pretrain
///
///   endoloc pretrain --out models/pretrain-track --colons 8 --pretrained builtin --pairs track --near-fraction 0.1
///
///   endoloc pretrain --out models/pj16 --colons 16 --seed 101 --frames 1305 --fps 15 --joint --pairs track --pair-frames 2,5 --near-fraction 0.1 --pretrained builtin-track
///
///   endoloc train --data data/paper --pretrained models/pretrain/weights.safetensors --out models/paper50
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Number of simulated colons, trained on one after the other.
    #[arg(long, default_value_t = PretrainJob::default().colons)]
    colons: usize,
    /// Seed of the first colon; colon i has seed `seed + 101·i`.
    #[arg(long, default_value_t = PretrainJob::default().seed)]
    seed: u64,
    /// Simulator preset of the colons (`paper`, or `small` for a quick try).
    #[arg(long, default_value_t = PretrainJob::default().preset)]
    preset: String,
    /// Uniform zones of each colon's training pass.
    #[arg(long, default_value_t = PretrainJob::default().zones)]
    zones: usize,
    /// Training epochs per colon (default: the `fast` schedule's).
    #[arg(long)]
    epochs: Option<usize>,
    /// Training pairs of each colon: `zone` (default) or `track` (see `endoloc train
    /// --pairs`; the test pass's frames then pair by their place along the training pass).
    #[arg(long, value_name = "RULE")]
    pairs: Option<String>,
    /// Track pairs: fraction of negatives near the positive (see `endoloc train
    /// --near-fraction`), e.g. 0.1.
    #[arg(long, value_name = "F")]
    near_fraction: Option<f32>,
    /// Start weights of the first colon (a `.safetensors` or `.pt` file, or `builtin`):
    /// continue from an earlier pretraining, e.g. with other pairs. Default: random weights.
    #[arg(long, value_name = "WEIGHTS")]
    pretrained: Option<String>,
    /// Train one network on every colon at once (batches drawn from all of them, each
    /// negative from its partner's colon) instead of colon after colon. `--epochs` is then
    /// the whole training's (default 60 per colon).
    #[arg(long)]
    joint: bool,
    /// Track pairs: largest positive and smallest negative frame gap, `P,N` (default 3,10;
    /// halve them with `--fps 15`).
    #[arg(long, value_name = "P,N")]
    pair_frames: Option<String>,
    /// Frames of each pass (default: the preset's).
    #[arg(long, value_name = "N")]
    frames: Option<usize>,
    /// Frame rate of the simulated passes (default: the preset's, 30); with half the frames,
    /// 15 renders every second frame of the same passes.
    #[arg(long, value_name = "FPS")]
    fps: Option<f64>,
    /// Image width and height WIDTHxHEIGHT (default: the preset's).
    #[arg(long, value_name = "WxH")]
    size: Option<String>,
    /// Replace an existing OUT/weights.safetensors.
    #[arg(long)]
    force: bool,
    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto (BURN_DEVICE, else cpu).
    #[arg(long, default_value_t = PretrainJob::default().device)]
    device: String,
}

impl From<Args> for PretrainJob {
    fn from(a: Args) -> Self {
        PretrainJob {
            out: a.out,
            colons: a.colons,
            seed: a.seed,
            preset: a.preset,
            zones: a.zones,
            epochs: a.epochs,
            pairs: a.pairs,
            near_fraction: a.near_fraction,
            pretrained: a.pretrained,
            joint: a.joint,
            pair_frames: a.pair_frames,
            frames: a.frames,
            fps: a.fps,
            size: a.size,
            force: a.force,
            device: a.device,
        }
    }
}

/// Runs `endoloc pretrain`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&PretrainJob::from(args).run(ui)?)?;
    Ok(())
}
