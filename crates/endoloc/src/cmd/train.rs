//! `endoloc train`: zone the training sequence, train the Siamese network, write the model.

use std::path::PathBuf;

use anyhow::{Context, Result};
use endoloc_jobs::{Progress, TrainJob, TrainMethod};

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
    /// What to train: the Siamese zone classifier (the paper's method) or a learning
    /// baseline on the same backbone (`posenet`, `offsetnet`; for `endoloc localize --method`
    /// and `endoloc experiment compare`). The baselines use --data, --seq, --out, --epochs,
    /// --seed and --force.
    #[arg(long, value_enum, default_value = "siamese")]
    method: Method,
    /// Dataset folder (with dataset.toml).
    #[arg(long, value_name = "DIR")]
    data: PathBuf,

    /// Training sequence inside the dataset.
    #[arg(long, default_value_t = TrainJob::default().seq)]
    seq: String,

    /// A further pass through the same colon (a sequence of this dataset; repeatable). Its
    /// frames join the zone of their nearest training pose, so that positive pairs also join
    /// views of one place from different passes; zones, database and maps stay those of
    /// --seq.
    #[arg(long, value_name = "SEQ")]
    also_seq: Vec<String>,

    /// Zones: a number (uniform) or `expert` / `expert:N` (anatomical, N zones, default 50).
    #[arg(long, default_value_t = TrainJob::default().zones)]
    zones: String,

    /// Uniform zones of equal `arc-length` (default) or equal `frames`.
    #[arg(long, default_value_t = TrainJob::default().uniform_by)]
    uniform_by: String,

    /// Fewest training frames a uniform zone holds: a zone over a fast stretch of the pass is
    /// widened into its neighbours until it has this many (its map needs several views).
    #[arg(long, value_name = "N", default_value_t = TrainJob::default().min_zone_frames)]
    min_zone_frames: usize,

    /// Model folder to write.
    #[arg(long, value_name = "MODEL")]
    out: PathBuf,

    /// Replace an existing model folder (or discard an interrupted run).
    #[arg(long)]
    force: bool,

    /// Continue an interrupted run from its checkpoint (MODEL.partial/checkpoint).
    #[arg(long)]
    resume: bool,

    /// Backbone: `compact` (CPU default, 256x192 input, stride-4 first layer) or `googlenet` (the paper's,
    /// 224x224x1; for a GPU).
    #[arg(long, default_value_t = TrainJob::default().backbone)]
    backbone: String,

    /// Network input size WIDTHxHEIGHT (default: the backbone's, 256x192 for compact).
    #[arg(long, value_name = "WxH")]
    input: Option<String>,

    /// Stride of the compact backbone's first convolution (default 4; 2 with `--input 128x96`
    /// is the former, coarser default).
    #[arg(long, value_name = "N")]
    stem_stride: Option<usize>,

    /// Global pooling of the compact backbone: `average` (default) or `gem` (generalised mean,
    /// p = 3).
    #[arg(long, value_name = "KIND")]
    pooling: Option<String>,

    /// Augment with the view of the scope turned by up to ±DEG about its x and y axes (an
    /// exact homography; default from the augmentation settings).
    #[arg(long, value_name = "DEG")]
    tilt_deg: Option<f32>,

    /// Training pairs: `zone` (the paper's: positives share a zone, negatives do not) or
    /// `track` (by distance along the training pass: positives within 3 frames, negatives 10
    /// or more apart, half of them within 20; see --pair-frames). Track pairs never give
    /// opposite labels to neighbouring frames across a zone border.
    #[arg(long, value_name = "RULE")]
    pairs: Option<String>,

    /// Track pairs: largest positive and smallest negative frame gap, `P,N` (default 3,10).
    #[arg(long, value_name = "P,N")]
    pair_frames: Option<String>,

    /// Track pairs: fraction of negatives within 2·N frames (default 0.5).
    #[arg(long, value_name = "F")]
    near_fraction: Option<f32>,

    /// Track pairs: fraction of each batch drawn as zone pairs instead (default 0).
    #[arg(long, value_name = "F")]
    zone_fraction: Option<f32>,

    /// Power of the partial PCA whitening learnt from the database of the training pass and
    /// applied to every descriptor (default 0.25; 0: the network's descriptors as they are).
    #[arg(long, value_name = "P")]
    whitening: Option<f32>,

    /// Smooth the database along the training pass: each training frame's descriptor becomes
    /// the mean of those within ±MM of camera path (default 2.2; 0: none). Test frames are
    /// still looked up one by one.
    #[arg(long, value_name = "MM")]
    database_smoothing: Option<f64>,

    /// Schedule preset: `fast` or `paper`.
    #[arg(long, default_value_t = TrainJob::default().schedule)]
    schedule: String,

    /// Training settings from a TOML file (fields of TrainConfig); the flags below override it.
    #[arg(long, value_name = "TOML")]
    config: Option<PathBuf>,

    /// Number of epochs (overrides the schedule). 0, with --pretrained: no optimisation,
    /// only the database of the training pass from the start weights as they are (seconds).
    #[arg(long)]
    epochs: Option<usize>,

    /// Adam learning rate at the start (overrides the schedule).
    #[arg(long)]
    lr: Option<f64>,

    /// Pairs per step (overrides the schedule).
    #[arg(long)]
    batch_pairs: Option<usize>,

    /// Turn augmentation off.
    #[arg(long)]
    no_augment: bool,

    /// Seed of every random step.
    #[arg(long, default_value_t = TrainJob::default().seed)]
    seed: u64,

    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto (BURN_DEVICE, else cpu).
    #[arg(long, default_value_t = TrainJob::default().device)]
    device: String,

    /// Monitor validation accuracy on this sequence folder (e.g. a second pass through the
    /// same colon; truth zones from its poses) instead of held-out training frames.
    #[arg(long, value_name = "DIR")]
    val_seq: Option<PathBuf>,

    /// Start from these weights: a safetensors file or a PyTorch state dict (.pt/.pth);
    /// GoogLeNet takes torchvision's names (use branch3_kernel = 3 in a --config file for
    /// torchvision's weights). Shipped with endoloc, for the default compact backbone
    /// (`endoloc pretrain` on simulated colons, never yours): `builtin`, zone pairs on four
    /// colons; `builtin-track`, those continued with track pairs on eight colons, the start
    /// for `--pairs track --near-fraction 0.1`; `builtin-joint`, those continued on 32
    /// colons at once, best used as they are with `--epochs 0`.
    #[arg(long, value_name = "FILE|builtin|builtin-track|builtin-joint")]
    pretrained: Option<PathBuf>,

    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// `--method` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Method {
    /// The Siamese zone classifier.
    Siamese,
    /// PoseNet pose regression (baseline).
    Posenet,
    /// OffsetNet relative pose regression (baseline).
    Offsetnet,
}

impl From<Args> for TrainJob {
    fn from(a: Args) -> Self {
        TrainJob {
            method: match a.method {
                Method::Siamese => TrainMethod::Siamese,
                Method::Posenet => TrainMethod::Posenet,
                Method::Offsetnet => TrainMethod::Offsetnet,
            },
            data: a.data,
            seq: a.seq,
            also_seq: a.also_seq,
            zones: a.zones,
            uniform_by: a.uniform_by,
            min_zone_frames: a.min_zone_frames,
            out: a.out,
            force: a.force,
            resume: a.resume,
            backbone: a.backbone,
            input: a.input,
            stem_stride: a.stem_stride,
            pooling: a.pooling,
            tilt_deg: a.tilt_deg,
            pairs: a.pairs,
            pair_frames: a.pair_frames,
            near_fraction: a.near_fraction,
            zone_fraction: a.zone_fraction,
            whitening: a.whitening,
            database_smoothing: a.database_smoothing,
            schedule: a.schedule,
            config: a.config,
            epochs: a.epochs,
            lr: a.lr,
            batch_pairs: a.batch_pairs,
            no_augment: a.no_augment,
            seed: a.seed,
            device: a.device,
            val_seq: a.val_seq,
            pretrained: a.pretrained,
        }
    }
}

/// Runs `endoloc train`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .context("setting the thread count")?;
    }
    crate::ui::print(&TrainJob::from(args).run(ui)?)?;
    Ok(())
}
