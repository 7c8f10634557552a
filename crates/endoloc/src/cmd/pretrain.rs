//! `endoloc pretrain`: start weights for the zone classifier from simulated colons.

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
/// `--changes moderate` renders each colon's test pass through its colon changed at random
/// (every factor of `simulate --changes` drawn up to that severity): the network learns to
/// find a zone in a colon that changed since its map pass.
///
/// The weights shipped with endoloc (`endoloc train --pretrained builtin`, `builtin-track`,
/// `builtin-joint`, `builtin-changes`) were made with this command; see `endoloc train
/// --help`.
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
///   endoloc pretrain --out models/pc8 --colons 8 --seed 4949 --frames 1305 --fps 15 --joint --pairs track --pair-frames 2,5 --near-fraction 0.1 --pretrained builtin-joint --changes moderate
///
///   endoloc train --data data/paper --pretrained models/pretrain/weights.safetensors --out models/paper50
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: PretrainJob,
}

/// Runs `endoloc pretrain`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
