//! `endoloc train`: zone the training sequence, train the Siamese network, write the model.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use endoloc_data::Dataset;

use crate::cmd::baselines::{Regressor, train_regressor};
use endoloc_net::backbone::{BackboneConfig, Pooling};
use endoloc_net::train::{Phase, Schedule, TrainConfig, TrainProgress, TrainTarget, train};
use endoloc_net::{AugmentConfig, PairRule, UniformBy, ZoneConfig, ZoneTable};

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
/// The best classifier on simulated data, in seconds: the shipped network pretrained on 32
/// simulated colons, used as it is (the pass is only described; on the `paper` preset 90.1 %
/// exact per frame against 74 % for the default training; on real images measure both):
///
///   endoloc train --data data/paper --zones 50 --out models/bj --pretrained builtin-joint --epochs 0
///
/// Pretraining on another simulated colon seen in two passes (once; about 10 minutes), then
/// starting from it (on the `paper` preset: 71.5 % exact per frame instead of 66.2 %):
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
    method: TrainMethod,
    /// Dataset folder (with dataset.toml).
    #[arg(long, value_name = "DIR")]
    data: PathBuf,

    /// Training sequence inside the dataset.
    #[arg(long, default_value = "train")]
    seq: String,

    /// A further pass through the same colon (a sequence of this dataset; repeatable). Its
    /// frames join the zone of their nearest training pose, so that positive pairs also join
    /// views of one place from different passes; zones, database and maps stay those of
    /// --seq.
    #[arg(long, value_name = "SEQ")]
    also_seq: Vec<String>,

    /// Zones: a number (uniform) or `expert` / `expert:N` (anatomical, N zones, default 50).
    #[arg(long, default_value = "50")]
    zones: String,

    /// Uniform zones of equal `arc-length` (default) or equal `frames`.
    #[arg(long, default_value = "arc-length")]
    uniform_by: String,

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
    #[arg(long, default_value = "compact")]
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
    /// On the `paper` preset it adds 2–4 points of exact zone accuracy per frame.
    #[arg(long, value_name = "P")]
    whitening: Option<f32>,

    /// Smooth the database along the training pass: each training frame's descriptor becomes
    /// the mean of those within ±MM of camera path (default 2.2; 0: none). Test frames are
    /// still looked up one by one. On the `paper` preset it adds 1–1.5 points per frame.
    #[arg(long, value_name = "MM")]
    database_smoothing: Option<f64>,

    /// Schedule preset: `fast` or `paper`.
    #[arg(long, default_value = "fast")]
    schedule: String,

    /// Training settings from a TOML file (fields of TrainConfig); the flags below override it.
    #[arg(long, value_name = "TOML")]
    config: Option<PathBuf>,

    /// Number of epochs (overrides the schedule). 0, with --pretrained: no optimisation,
    /// only the database of the training pass from the start weights as they are (seconds).
    /// With `--pretrained builtin-joint` that is the best single model on the `paper` preset.
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
    #[arg(long, default_value_t = 0)]
    seed: u64,

    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto (BURN_DEVICE, else cpu).
    #[arg(long, default_value = "cpu")]
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
    /// colons, best used as they are with `--epochs 0`: on the `paper` preset 90.1 % exact
    /// per frame and 97.1 % smoothed in 14 s, against 83.5 % after a 7-minute fine-tune from
    /// `builtin-track` and 74 % for the default training from random weights.
    #[arg(long, value_name = "FILE|builtin|builtin-track|builtin-joint")]
    pretrained: Option<PathBuf>,

    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Parses `--zones`.
fn zone_config(spec: &str, by: &str) -> Result<ZoneConfig> {
    let s = spec.trim().to_ascii_lowercase();
    if let Some(rest) = s.strip_prefix("expert") {
        let count = match rest.strip_prefix(':') {
            Some(n) => n
                .parse()
                .with_context(|| format!("--zones {spec}: expected expert:N with N a number"))?,
            None if rest.is_empty() => 50,
            None => bail!("--zones {spec}: expected a number, `expert` or `expert:N`"),
        };
        return Ok(ZoneConfig::Expert { count });
    }
    let count: usize = s
        .parse()
        .with_context(|| format!("--zones {spec}: expected a number, `expert` or `expert:N`"))?;
    Ok(ZoneConfig::Uniform {
        count,
        by: by.parse::<UniformBy>()?,
    })
}

/// `--pairs`, `--pair-frames`, `--near-fraction` applied to `rule` (from the config or the
/// default).
fn pair_rule(args: &Args, rule: PairRule) -> Result<PairRule> {
    pair_rule_from(
        args.pairs.as_deref(),
        args.pair_frames.as_deref(),
        args.near_fraction,
        args.zone_fraction,
        rule,
    )
}

/// `--pairs RULE`, `--pair-frames P,N`, `--near-fraction F` and `--zone-fraction F` applied
/// to `rule`.
pub(crate) fn pair_rule_from(
    pairs: Option<&str>,
    pair_frames: Option<&str>,
    near: Option<f32>,
    zone: Option<f32>,
    rule: PairRule,
) -> Result<PairRule> {
    let mut rule = match pairs.map(|s| s.trim().to_ascii_lowercase()) {
        None => rule,
        Some(s) if s == "zone" => PairRule::Zone,
        Some(s) if s == "track" => match rule {
            PairRule::Track { .. } => rule,
            PairRule::Zone => PairRule::track(),
        },
        Some(other) => bail!("--pairs {other}: expected `zone` or `track`"),
    };
    let tuning = pair_frames.is_some() || near.is_some() || zone.is_some();
    match &mut rule {
        PairRule::Track {
            positive_frames,
            negative_frames,
            near_fraction,
            zone_fraction,
        } => {
            if let Some(spec) = pair_frames {
                let parsed = spec
                    .split_once(',')
                    .and_then(|(p, n)| Some((p.trim().parse().ok()?, n.trim().parse().ok()?)));
                let Some((p, n)) = parsed else {
                    bail!("--pair-frames {spec}: expected P,N (two frame counts, e.g. 3,10)");
                };
                (*positive_frames, *negative_frames) = (p, n);
            }
            if let Some(f) = near {
                *near_fraction = f;
            }
            if let Some(f) = zone {
                *zone_fraction = f;
            }
        }
        PairRule::Zone if tuning => {
            bail!(
                "--pair-frames, --near-fraction and --zone-fraction apply to track pairs (--pairs track)"
            )
        }
        PairRule::Zone => {}
    }
    rule.validate()?;
    Ok(rule)
}

/// Turns the arguments into a training config.
fn train_config(args: &Args) -> Result<TrainConfig> {
    let mut cfg = match &args.config {
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            toml::from_str::<TrainConfig>(&text).with_context(|| format!("{}", p.display()))?
        }
        None => TrainConfig {
            backbone: BackboneConfig::from_name(&args.backbone)?,
            schedule: Schedule::from_name(&args.schedule)?,
            ..TrainConfig::default()
        },
    };
    if let Some(size) = &args.input {
        cfg.backbone = cfg.backbone.clone().with_input(size.parse()?);
    }
    if let Some(n) = args.stem_stride {
        match &mut cfg.backbone {
            BackboneConfig::Compact { stem_stride, .. } => *stem_stride = n,
            other => anyhow::bail!(
                "--stem-stride applies to the compact backbone, not {}",
                other.name()
            ),
        }
    }
    if let Some(kind) = &args.pooling {
        let kind: Pooling = match kind.trim().to_ascii_lowercase().as_str() {
            "average" | "avg" => Pooling::Average,
            "gem" => Pooling::Gem,
            other => bail!("--pooling {other}: expected `average` or `gem`"),
        };
        match &mut cfg.backbone {
            BackboneConfig::Compact { pooling, .. } => *pooling = kind,
            other => bail!(
                "--pooling applies to the compact backbone, not {}",
                other.name()
            ),
        }
    }
    if let Some(e) = args.epochs {
        cfg.schedule.epochs = e;
    }
    if let Some(lr) = args.lr {
        cfg.schedule.learning_rate = lr;
        cfg.schedule.final_learning_rate = cfg.schedule.final_learning_rate.min(lr);
    }
    if let Some(b) = args.batch_pairs {
        cfg.schedule.batch_pairs = b;
    }
    if let Some(t) = args.tilt_deg {
        if !(0.0..=45.0).contains(&t) {
            bail!("--tilt-deg {t}: expected 0 to 45 degrees");
        }
        cfg.augment.tilt_deg = t;
    }
    if args.no_augment {
        cfg.augment = AugmentConfig::off();
    }
    cfg.pairs = pair_rule(args, cfg.pairs)?;
    if let Some(p) = args.whitening {
        cfg.whitening = p;
    }
    if let Some(mm) = args.database_smoothing {
        cfg.database_smoothing_mm = mm;
    }
    cfg.seed = args.seed;
    cfg.device = args.device.clone();
    if args.val_seq.is_some() {
        cfg.validation.sequence = args.val_seq.clone();
    }
    if args.pretrained.is_some() {
        cfg.pretrained = args.pretrained.clone();
    }
    cfg.validate()?;
    Ok(cfg)
}

/// Progress bars of a training: one per phase, the loss and validation accuracy on the
/// training bar.
#[derive(Default)]
pub(crate) struct TrainBars {
    bar: Option<(Phase, indicatif::ProgressBar)>,
}

impl TrainBars {
    /// Shows `p`, starting a new bar when the phase changes.
    pub(crate) fn show(&mut self, p: &TrainProgress) {
        if self.bar.as_ref().is_none_or(|(ph, _)| *ph != p.phase) {
            if let Some((_, b)) = self.bar.take() {
                b.finish();
            }
            let label = match p.phase {
                Phase::LoadingImages => "loading",
                Phase::Training => "training",
                Phase::Describing => "describing",
                Phase::Saving => "saving",
            };
            self.bar = Some((p.phase, crate::ui::progress_bar(p.total as u64, label)));
        }
        if let Some((_, b)) = &self.bar {
            b.set_position(p.done as u64);
            if p.phase == Phase::Training {
                let loss = p.loss.map_or("-".into(), |l| format!("{l:.4}"));
                let val = p
                    .val_accuracy
                    .map_or(String::new(), |a| format!(" val {:.1}%", 100.0 * a));
                b.set_message(format!("ep {} loss {loss}{val}", p.epoch));
            }
        }
    }

    /// Removes the last bar.
    pub(crate) fn clear(&mut self) {
        if let Some((_, b)) = self.bar.take() {
            b.finish_and_clear();
        }
    }
}

/// What `endoloc train` trains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TrainMethod {
    /// The Siamese zone classifier.
    Siamese,
    /// PoseNet pose regression (baseline).
    Posenet,
    /// OffsetNet relative pose regression (baseline).
    Offsetnet,
}

/// Runs `endoloc train`.
pub fn run(args: Args) -> Result<()> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .context("setting the thread count")?;
    }
    if args.method != TrainMethod::Siamese {
        let which = if args.method == TrainMethod::Posenet {
            Regressor::PoseNet
        } else {
            Regressor::OffsetNet
        };
        let dataset = Dataset::open(&args.data)?;
        let seq = dataset.sequence(&args.seq)?;
        return train_regressor(
            which,
            &seq,
            &dataset.meta.camera,
            &args.out,
            args.epochs,
            args.seed,
            args.force,
        );
    }
    let cfg = train_config(&args)?;
    let zcfg = zone_config(&args.zones, &args.uniform_by)?;
    let dataset = Dataset::open(&args.data)?;
    let seq = dataset.sequence(&args.seq)?;
    let zones = ZoneTable::from_sequence(&seq, &zcfg)?;
    let mut cfg = cfg;
    for name in &args.also_seq {
        if *name == args.seq {
            bail!("--also-seq {name}: that is the training sequence itself");
        }
        cfg.extra_sequences.push(dataset.sequence(name)?.dir);
    }
    eprintln!(
        "training {} on {} ({} frames, {} zones, {}), {} epochs of {} pairs, device {}",
        cfg.backbone.name(),
        seq.dir.display(),
        seq.len(),
        zones.len(),
        match zcfg {
            ZoneConfig::Uniform {
                by: UniformBy::ArcLength,
                ..
            } => "uniform by arc length",
            ZoneConfig::Uniform {
                by: UniformBy::Frames,
                ..
            } => "uniform by frames",
            ZoneConfig::Expert { .. } => "anatomical",
        },
        cfg.schedule.epochs,
        cfg.schedule.pairs_per_epoch,
        cfg.device
    );
    let target = TrainTarget {
        dir: args.out.clone(),
        force: args.force,
        resume: args.resume,
    };
    let t0 = Instant::now();
    let mut bars = TrainBars::default();
    let report = train(
        &cfg,
        &seq,
        &zones,
        &dataset.meta.camera,
        &dataset.meta.name,
        &target,
        &mut |p| bars.show(p),
    )?;
    bars.clear();
    let last = report.history.last();
    if let Some(n) = report.resumed_after_epoch {
        println!("resumed      after epoch {n}");
    }
    println!("model        {}", report.model_dir.display());
    println!(
        "zones        {} ({} frames)",
        zones.len(),
        zones.frame_count()
    );
    for (dir, n) in cfg.extra_sequences.iter().zip(&report.pass_frames) {
        println!(
            "extra pass   {} ({n} frames joined the pairs)",
            dir.display()
        );
    }
    if let Some(r) = last {
        println!("final loss   {:.4} (epoch {})", r.loss, r.epoch);
    }
    if let Some(r) = report
        .history
        .iter()
        .rev()
        .find(|r| r.val_accuracy.is_some())
    {
        println!(
            "validation   {:.1} % exact, {:.1} % within ±1 zone ({}, epoch {})",
            100.0 * r.val_accuracy.unwrap_or(0.0),
            100.0 * r.val_within1.unwrap_or(0.0),
            cfg.validation
                .sequence
                .as_ref()
                .map_or("held-out training frames".to_string(), |p| p
                    .display()
                    .to_string()),
            r.epoch
        );
    }
    println!(
        "time         {:.1} s total: load {:.1} s, train {:.1} s ({} steps), describe {:.1} s",
        t0.elapsed().as_secs_f64(),
        report.load_s,
        report.train_s,
        report.steps,
        report.describe_s
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn config(extra: &[&str]) -> Result<TrainConfig> {
        let mut argv = vec!["train", "--data", "d", "--out", "m"];
        argv.extend(extra);
        train_config(&Cli::try_parse_from(argv)?.args)
    }

    #[test]
    fn pooling_and_tilt_flags_reach_the_config_and_bad_values_are_named() {
        let cfg = config(&["--pooling", "gem", "--tilt-deg", "12"]).unwrap();
        let BackboneConfig::Compact { pooling, .. } = cfg.backbone else {
            panic!("compact expected");
        };
        assert_eq!(pooling, Pooling::Gem);
        assert_eq!(cfg.augment.tilt_deg, 12.0);
        let plain = config(&[]).unwrap();
        assert_eq!(plain.backbone, BackboneConfig::compact());
        let e = config(&["--pooling", "max"]).unwrap_err().to_string();
        assert!(e.contains("--pooling max") && e.contains("gem"), "{e}");
        let e = config(&["--tilt-deg", "90"]).unwrap_err().to_string();
        assert!(e.contains("--tilt-deg 90"), "{e}");
        let e = config(&["--backbone", "googlenet", "--pooling", "gem"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("compact backbone"), "{e}");
    }

    #[test]
    fn pair_flags_reach_the_config_and_bad_values_are_named() {
        assert_eq!(config(&[]).unwrap().pairs, PairRule::Zone);
        assert_eq!(
            config(&["--pairs", "track"]).unwrap().pairs,
            PairRule::track()
        );
        assert_eq!(
            config(&[
                "--pairs",
                "track",
                "--pair-frames",
                "2,8",
                "--near-fraction",
                "0.3"
            ])
            .unwrap()
            .pairs,
            PairRule::Track {
                positive_frames: 2,
                negative_frames: 8,
                near_fraction: 0.3,
                zone_fraction: 0.0
            }
        );
        let e = config(&["--pairs", "frames"]).unwrap_err().to_string();
        assert!(e.contains("--pairs frames"), "{e}");
        let e = config(&["--pair-frames", "2,8"]).unwrap_err().to_string();
        assert!(e.contains("--pairs track"), "{e}");
        let e = config(&["--pairs", "track", "--pair-frames", "8"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--pair-frames 8"), "{e}");
        let e = config(&["--pairs", "track", "--pair-frames", "8,4"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("negative_frames 4 > positive_frames"), "{e}");
    }
}
