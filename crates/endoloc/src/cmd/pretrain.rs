//! `endoloc pretrain`: start weights for the zone classifier from simulated colons.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::cmd;
use crate::cmd::demo::{parse, stage};
use endoloc_data::Dataset;
use endoloc_net::pretrain::{PretrainColon, pretrain};
use endoloc_net::train::{TrainConfig, TrainTarget};
use endoloc_net::{UniformBy, ZoneConfig};

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
/// Measured on the `paper` preset (50 zones, test pass; exact / within ±1 zone per frame) with
/// tilt augmentation ±12°: no pretraining 66.2 / 84.8 %, one colon 71.5 / 89.9 %, two
/// 74.9 / 90.5 %, three 77.5 / 93.3 %, four (the default) 80.4 / 96.5 %, eight 78.8 / 96.4 %
/// (the gain stops at four). At today's ±28° it adds 2.5 points to zone pairs and 16 to track
/// pairs with `--near-fraction 0.1` (62.5 → 78.6 %). Each colon costs about 9–15 minutes on 2
/// cores (simulation 2–3, training 7–12). The result of the default run ships with endoloc:
/// `endoloc train --pretrained builtin`. Continued from it with track pairs over eight colons
/// (`--colons 8 --pretrained builtin --pairs track --near-fraction 0.1`; the first four are
/// the same colons), it ships as `builtin-track`: track pairs fine-tuned from it reach
/// 83.6 / 95.2 % (82.5 / 94.5 % after four colons).
///
/// `--joint` trains one network on every colon's two passes at once instead (the places of
/// each colon kept apart, negatives drawn from the partner's colon, where the look-alikes
/// are). From `builtin-track` over sixteen colons at 15 fps and then sixteen more (below),
/// it ships as `builtin-joint`, which needs no training on your pass at all: `endoloc train
/// --pretrained builtin-joint --epochs 0` gives 90.1 % exact per frame on the `paper` preset.
/// A joint run holds every colon's images in memory (16 colons of 2610 images: about 8 GB)
/// and takes about 2 s per epoch of 256 pairs here.
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
///   endoloc pretrain --out models/pj32 --colons 16 --seed 1717 --frames 1305 --fps 15 --joint --pairs track --pair-frames 2,5 --near-fraction 0.1 --pretrained models/pj16/weights.safetensors
///
///   endoloc train --data data/paper --pretrained models/pretrain/weights.safetensors --out models/paper50
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Number of simulated colons, trained on one after the other.
    #[arg(long, default_value_t = 4)]
    colons: usize,
    /// Seed of the first colon; colon i has seed `seed + 101·i`.
    #[arg(long, default_value_t = 101)]
    seed: u64,
    /// Simulator preset of the colons (`paper`, or `small` for a quick try).
    #[arg(long, default_value = "paper")]
    preset: String,
    /// Uniform zones of each colon's training pass.
    #[arg(long, default_value_t = 50)]
    zones: usize,
    /// Training epochs per colon (default: the `fast` schedule's).
    #[arg(long)]
    epochs: Option<usize>,
    /// Training pairs of each colon: `zone` (default) or `track` (see `endoloc train
    /// --pairs`; the test pass's frames then pair by their place along the training pass).
    #[arg(long, value_name = "RULE")]
    pairs: Option<String>,
    /// Track pairs: fraction of negatives near the positive (see `endoloc train
    /// --near-fraction`; 0.1 gives the best track-pair models).
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
}

/// Runs `endoloc pretrain`.
pub fn run(args: Args) -> Result<()> {
    if args.colons == 0 {
        bail!("--colons 0: at least one colon is needed");
    }
    let weights = args.out.join("weights.safetensors");
    if weights.exists() && !args.force {
        bail!("{} exists; pass --force to replace it", weights.display());
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let size = match &args.size {
        Some(text) => {
            let s: endoloc_net::InputSize = text
                .parse()
                .with_context(|| format!("--size {text}: expected WIDTHxHEIGHT"))?;
            Some((s.width, s.height))
        }
        None => None,
    };
    let mut previous: Option<String> = args.pretrained.clone();
    for i in 0..args.colons {
        let seed = args.seed + 101 * i as u64;
        let data = colon_dir(&args, i);
        let model = args.out.join(format!("model-{seed}"));
        let title = format!("colon {} of {}", i + 1, args.colons);
        if data.join("dataset.toml").is_file() {
            eprintln!("\n== {title}: reusing {}", data.display());
        } else {
            let mut sim = strings(&[
                "simulate",
                "--preset",
                &args.preset,
                "--seed",
                &seed.to_string(),
                "--out",
                &path(&data),
                "--force",
            ]);
            if let Some(n) = args.frames {
                let n = n.to_string();
                sim.extend(strings(&["--train-frames", &n, "--test-frames", &n]));
            }
            if let Some(f) = args.fps {
                sim.extend(strings(&["--fps", &f.to_string()]));
            }
            if let Some((w, h)) = size {
                sim.extend(strings(&[
                    "--width",
                    &w.to_string(),
                    "--height",
                    &h.to_string(),
                ]));
            }
            stage(&format!("{title}: simulate"), &sim);
            cmd::simulate::run(parse(&sim)?)?;
        }
        if args.joint {
            continue;
        }
        if model.join("weights.safetensors").is_file() {
            eprintln!("== {title}: reusing {}", model.display());
        } else {
            let mut train = strings(&[
                "train",
                "--data",
                &path(&data),
                "--zones",
                &args.zones.to_string(),
                "--also-seq",
                "test",
                "--out",
                &path(&model),
                "--force",
            ]);
            if let Some(w) = &previous {
                train.extend(strings(&["--pretrained", w]));
            }
            if let Some(e) = args.epochs {
                train.extend(strings(&["--epochs", &e.to_string()]));
            }
            if let Some(rule) = &args.pairs {
                train.extend(strings(&["--pairs", rule]));
            }
            if let Some(f) = args.near_fraction {
                train.extend(strings(&["--near-fraction", &f.to_string()]));
            }
            if let Some(f) = &args.pair_frames {
                train.extend(strings(&["--pair-frames", f]));
            }
            stage(&format!("{title}: train"), &train);
            cmd::train::run(parse(&train)?)?;
        }
        previous = Some(path(&model.join("weights.safetensors")));
    }
    if args.joint {
        previous = Some(path(&train_joint(&args)?));
    }
    let last = PathBuf::from(previous.context("no colon was trained")?);
    let tmp = args.out.join("weights.safetensors.partial");
    std::fs::copy(&last, &tmp)
        .with_context(|| format!("copying {} to {}", last.display(), tmp.display()))?;
    std::fs::rename(&tmp, &weights)
        .with_context(|| format!("renaming {} to {}", tmp.display(), weights.display()))?;
    println!("wrote     {}", weights.display());
    println!(
        "next      endoloc train --data DATA --pretrained {} --out MODEL",
        weights.display()
    );
    Ok(())
}

/// Folder of colon `i` (simulated) in OUT.
fn colon_dir(args: &Args, i: usize) -> PathBuf {
    args.out
        .join(format!("colon-{}", args.seed + 101 * i as u64))
}

/// The joint training of `--joint` (OUT/joint, resumed when interrupted); returns its weights.
fn train_joint(args: &Args) -> Result<PathBuf> {
    let dir = args.out.join("joint");
    let weights = dir.join(endoloc_net::model::WEIGHTS_FILE);
    if weights.is_file() {
        eprintln!("\n== joint training: reusing {}", dir.display());
        return Ok(weights);
    }
    let colons = (0..args.colons)
        .map(|i| {
            let data = colon_dir(args, i);
            let ds = Dataset::open(&data)?;
            Ok(PretrainColon {
                train: ds.sequence("train")?,
                passes: vec![ds.sequence("test")?.dir],
                camera: ds.meta.camera,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let mut cfg = TrainConfig {
        pretrained: args.pretrained.as_ref().map(PathBuf::from),
        ..TrainConfig::default()
    };
    cfg.pairs = cmd::train::pair_rule_from(
        args.pairs.as_deref(),
        args.pair_frames.as_deref(),
        args.near_fraction,
        None,
        cfg.pairs,
    )?;
    cfg.schedule.epochs = args.epochs.unwrap_or(60 * args.colons);
    // Held-out frames against a database spread over every colon say little (the database
    // must be sparse to be quick); what a pretraining is worth shows on a colon it never saw
    // (`endoloc train --epochs 0 --pretrained OUT/weights.safetensors`, then `classify`).
    cfg.validation.holdout_every = 0;
    cfg.validate()?;
    let zones = ZoneConfig::Uniform {
        count: args.zones,
        by: UniformBy::ArcLength,
    };
    eprintln!(
        "\n== joint training: {} colons at once, {} epochs of {} pairs → {}",
        colons.len(),
        cfg.schedule.epochs,
        cfg.schedule.pairs_per_epoch,
        dir.display()
    );
    let target = TrainTarget {
        dir: dir.clone(),
        force: args.force,
        resume: true,
    };
    let mut bars = cmd::train::TrainBars::default();
    let report = pretrain(&cfg, &zones, &colons, &target, &mut |p| bars.show(p))?;
    bars.clear();
    println!(
        "joint     {} images from {} colons, {} steps in {:.0} s (loading {:.0} s), final loss {}",
        report.images.iter().sum::<usize>(),
        report.images.len(),
        report.steps,
        report.train_s,
        report.load_s,
        report
            .history
            .last()
            .map_or("-".into(), |r| format!("{:.4}", r.loss))
    );
    Ok(weights)
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn path(p: &Path) -> String {
    p.display().to_string()
}
