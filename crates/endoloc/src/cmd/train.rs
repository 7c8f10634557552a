//! `endoloc train`: zone the training sequence, train the Siamese network, write the model.

use anyhow::{Context, Result};
use endoloc_jobs::{Progress, TrainJob};

/// Train the zone classifier (a Siamese network with the paper's contrastive loss) on the
/// training sequence of a dataset and write a model folder: model.toml, weights.safetensors,
/// zones.csv, database.bin (descriptors of every training frame, whitened and smoothed along
/// the pass), whitening.bin, train_poses.txt, history.csv and loss.png.
///
/// Zones: `--zones 50` cuts the training trajectory into 50 zones of equal arc length
/// (`--uniform-by frames` for equal frame counts); `--zones expert` makes one zone per
/// anatomical section of sections.csv and splits long sections to 50 zones in all
/// (`expert:N` for N zones).
///
/// Schedules: `fast` (default; 150 epochs of 128+128 pairs, batch 64 pairs sharing images,
/// Adam 1e-3 → 1e-4) or `paper` (500 epochs of 128+128 pairs, batch 128, Adam 1e-3).
///
/// Examples:
///
///   endoloc train --data data/paper --zones 50 --out models/paper50
///
///   endoloc train --data data/paper --zones expert --out models/expert --schedule paper
///
///   endoloc train --data data/paper --zones 50 --out models/paper50 --resume
///
/// The shipped network pretrained on simulated colons, used as it is (the pass is only
/// described, in seconds):
///
///   endoloc train --data data/paper --zones 50 --out models/bj --pretrained builtin-joint --epochs 0
///
/// Pretraining on another simulated colon seen in two passes, then starting from it:
///
///   endoloc simulate --preset paper --seed 101 --out data/pretrain
///   endoloc train --data data/pretrain --also-seq test --out models/pretrain
///   endoloc train --data data/paper --pretrained models/pretrain/weights.safetensors --out models/paper50
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: TrainJob,

    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Runs `endoloc train`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .context("setting the thread count")?;
    }
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
