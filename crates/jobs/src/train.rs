//! `TrainJob`: zone the training sequence, train the Siamese network (or a regression
//! baseline), write the model folder.

use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

use endoloc_data::Dataset;
use endoloc_net::backbone::{BackboneConfig, Pooling};
use endoloc_net::train::{Phase, TrainConfig, TrainProgress, TrainTarget, train};
use endoloc_net::{AugmentConfig, PairRule, UniformBy, ZoneConfig, ZoneSpec, ZoneTable};
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::baselines::{Regressor, RegressorSettings, train_regressor};
use crate::choice::{Backbone, Device, Pairs, SchedulePreset};
use crate::error::{Context, JobError, Result};
use crate::progress::Progress;

/// What a `TrainJob` trains.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum TrainMethod {
    /// The Siamese zone classifier.
    #[default]
    Siamese,
    /// PoseNet pose regression (baseline).
    Posenet,
    /// OffsetNet relative pose regression (baseline).
    Offsetnet,
}

/// Trains the zone classifier (a Siamese network with the paper's contrastive loss) on the
/// training sequence of a dataset and writes a model folder: `model.toml`,
/// `weights.safetensors`, `zones.csv`, `database.bin`, `whitening.bin`, `train_poses.txt`,
/// `history.csv` and `loss.png`. `Option` fields override the schedule, backbone or `config`
/// file when set; `None` keeps theirs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct TrainJob {
    /// What to train: the Siamese zone classifier (the paper's method) or a learning
    /// baseline on the same backbone (`posenet`, `offsetnet`; for the localize job's `method`
    /// and the compare experiment). The baselines use `data`, `seq`, `out`, `epochs`, `seed`
    /// and `force`.
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value_t = TrainMethod::default()))]
    pub method: TrainMethod,
    /// Dataset folder (with dataset.toml).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub data: PathBuf,
    /// Training sequence inside the dataset.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = TrainJob::default().seq))]
    pub seq: String,
    /// A further pass through the same colon (a sequence of this dataset; repeatable). Its
    /// frames join the zone of their nearest training pose, so that positive pairs also join
    /// views of one place from different passes; zones, database and maps stay those of
    /// `seq`.
    #[cfg_attr(feature = "cli", arg(long, value_name = "SEQ"))]
    pub also_seq: Vec<String>,
    /// Zones: a number (uniform) or `expert` / `expert:N` (anatomical, N zones, default 50).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = TrainJob::default().zones))]
    pub zones: ZoneSpec,
    /// Uniform zones of equal `arc-length` (default) or equal `frames`.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = TrainJob::default().uniform_by))]
    pub uniform_by: UniformBy,
    /// Fewest training frames a uniform zone holds: a zone over a fast stretch of the pass is
    /// widened into its neighbours until it has this many (its map needs several views).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "N", default_value_t = TrainJob::default().min_zone_frames)
    )]
    pub min_zone_frames: usize,
    /// Model folder to write.
    #[cfg_attr(feature = "cli", arg(long, value_name = "MODEL"))]
    pub out: PathBuf,
    /// Replace an existing model folder (or discard an interrupted run).
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
    /// Continue an interrupted run from its checkpoint (MODEL.partial/checkpoint).
    #[cfg_attr(feature = "cli", arg(long))]
    pub resume: bool,
    /// Backbone: `compact` (CPU default, 256x192 input, stride-4 first layer) or `googlenet`
    /// (the paper's, 224x224x1; for a GPU).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value_t = TrainJob::default().backbone)
    )]
    pub backbone: Backbone,
    /// Network input size WIDTHxHEIGHT (default: the backbone's, 256x192 for compact).
    #[cfg_attr(feature = "cli", arg(long, value_name = "WxH"))]
    pub input: Option<String>,
    /// Stride of the compact backbone's first convolution (default 4; 2 with `input`
    /// 128x96 is the former, coarser default).
    #[cfg_attr(feature = "cli", arg(long, value_name = "N"))]
    pub stem_stride: Option<usize>,
    /// Global pooling of the compact backbone: `average` (default) or `gem` (generalised mean,
    /// p = 3).
    #[cfg_attr(feature = "cli", arg(long, value_name = "KIND"))]
    pub pooling: Option<Pooling>,
    /// Augment with the view of the scope turned by up to ±DEG about its x and y axes (an
    /// exact homography; default from the augmentation settings).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DEG"))]
    pub tilt_deg: Option<f32>,
    /// Training pairs: `zone` (the paper's: positives share a zone, negatives do not) or
    /// `track` (by distance along the training pass: positives within 3 frames, negatives 10
    /// or more apart, half of them within 20; see `pair_frames`). Track pairs never give
    /// opposite labels to neighbouring frames across a zone border.
    #[cfg_attr(feature = "cli", arg(long, value_enum, value_name = "RULE"))]
    pub pairs: Option<Pairs>,
    /// Track pairs: largest positive and smallest negative frame gap, `P,N` (default 3,10).
    #[cfg_attr(feature = "cli", arg(long, value_name = "P,N"))]
    pub pair_frames: Option<String>,
    /// Track pairs: fraction of negatives within 2·N frames (default 0.5).
    #[cfg_attr(feature = "cli", arg(long, value_name = "F"))]
    pub near_fraction: Option<f32>,
    /// Track pairs: fraction of each batch drawn as zone pairs instead (default 0).
    #[cfg_attr(feature = "cli", arg(long, value_name = "F"))]
    pub zone_fraction: Option<f32>,
    /// Power of the partial PCA whitening learnt from the database of the training pass and
    /// applied to every descriptor (default 0.25; 0: the network's descriptors as they are).
    #[cfg_attr(feature = "cli", arg(long, value_name = "P"))]
    pub whitening: Option<f32>,
    /// Smooth the database along the training pass: each training frame's descriptor becomes
    /// the mean of those within ±MM of camera path (default 2.2; 0: none). Test frames are
    /// still looked up one by one.
    #[cfg_attr(feature = "cli", arg(long, value_name = "MM"))]
    pub database_smoothing: Option<f64>,
    /// Zoom-blurred views of every training frame added to the database, amplitudes of the
    /// magnification `1 ± A` (a scope moving along its axis during the exposure), comma
    /// separated, e.g. 0.03,0.06,0.12; `none` (the default): the sharp rows alone. A
    /// motion-blurred test frame then finds its zone among views that look like it.
    #[cfg_attr(feature = "cli", arg(long, value_name = "A,..|none"))]
    pub index_zoom_blur: Option<String>,
    /// With `index_zoom_blur`: descriptor distance added to a view's when a test frame's zone
    /// is looked up, so that a view wins only when clearly nearer than the sharp rows (default
    /// 0: a view counts as its frame; 0.07 loses less on sharp passes, gains less on blurred
    /// ones).
    #[cfg_attr(feature = "cli", arg(long, value_name = "D"))]
    pub index_view_penalty: Option<f64>,
    /// Schedule preset: `fast` (150 epochs of 128+128 pairs, batch 64 pairs sharing images,
    /// Adam 1e-3 → 1e-4) or `paper` (500 epochs of 128+128 pairs, batch 128, Adam 1e-3).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value_t = TrainJob::default().schedule)
    )]
    pub schedule: SchedulePreset,
    /// Training settings from a TOML file (fields of TrainConfig); the options below override
    /// it.
    #[cfg_attr(feature = "cli", arg(long, value_name = "TOML"))]
    pub config: Option<PathBuf>,
    /// Number of epochs (overrides the schedule). 0, with `pretrained`: no optimisation,
    /// only the database of the training pass from the start weights as they are (seconds).
    #[cfg_attr(feature = "cli", arg(long))]
    pub epochs: Option<usize>,
    /// Adam learning rate at the start (overrides the schedule).
    #[cfg_attr(feature = "cli", arg(long))]
    pub lr: Option<f64>,
    /// Pairs per step (overrides the schedule).
    #[cfg_attr(feature = "cli", arg(long))]
    pub batch_pairs: Option<usize>,
    /// Turn augmentation off.
    #[cfg_attr(feature = "cli", arg(long))]
    pub no_augment: bool,
    /// Seed of every random step.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = TrainJob::default().seed))]
    pub seed: u64,
    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto (BURN_DEVICE, else cpu).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value_t = TrainJob::default().device)
    )]
    pub device: Device,
    /// Monitor validation accuracy on this sequence folder (e.g. a second pass through the
    /// same colon; truth zones from its poses) instead of held-out training frames.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub val_seq: Option<PathBuf>,
    /// Start from these weights: a safetensors file or a PyTorch state dict (.pt/.pth);
    /// GoogLeNet takes torchvision's names (use branch3_kernel = 3 in a `config` file for
    /// torchvision's weights). Shipped with endoloc, for the default compact backbone
    /// (pretrained on simulated colons, never yours): `builtin`, zone pairs on four colons;
    /// `builtin-track`, those continued with track pairs on eight colons, the start for track
    /// `pairs` with `near_fraction` 0.1; `builtin-joint`, those continued on 32 colons at
    /// once, best used as they are with 0 `epochs`; `builtin-changes`, those continued on
    /// eight colons changed at random between their passes, for a colon that changed since
    /// its map pass (0 `epochs`).
    #[cfg_attr(
        feature = "cli",
        arg(
            long,
            value_name = "FILE|builtin|builtin-track|builtin-joint|builtin-changes"
        )
    )]
    pub pretrained: Option<PathBuf>,
}

impl Default for TrainJob {
    fn default() -> Self {
        let cfg = TrainConfig::default();
        TrainJob {
            method: TrainMethod::Siamese,
            data: PathBuf::new(),
            seq: "train".into(),
            also_seq: Vec::new(),
            zones: ZoneSpec::default(),
            uniform_by: UniformBy::ArcLength,
            min_zone_frames: endoloc_net::DEFAULT_MIN_ZONE_FRAMES,
            out: PathBuf::new(),
            force: false,
            resume: false,
            backbone: Backbone::default(),
            input: None,
            stem_stride: None,
            pooling: None,
            tilt_deg: None,
            pairs: None,
            pair_frames: None,
            near_fraction: None,
            zone_fraction: None,
            whitening: None,
            database_smoothing: None,
            index_zoom_blur: None,
            index_view_penalty: None,
            schedule: SchedulePreset::default(),
            config: None,
            epochs: None,
            lr: None,
            batch_pairs: None,
            no_augment: false,
            seed: cfg.seed,
            device: Device::default(),
            val_seq: None,
            pretrained: None,
        }
    }
}

/// What a `TrainJob` trained.
#[derive(Debug)]
pub enum TrainReport {
    /// The Siamese classifier.
    Siamese(Box<SiameseReport>),
    /// A regression baseline.
    Regressor {
        /// Which one.
        which: Regressor,
        /// Training time, seconds.
        seconds: f64,
        /// Its model folder.
        out: PathBuf,
    },
}

/// A trained Siamese classifier.
#[derive(Debug)]
pub struct SiameseReport {
    /// The library's training report.
    pub report: endoloc_net::train::TrainReport,
    /// Zones.
    pub zones: usize,
    /// Frames zoned.
    pub zone_frames: usize,
    /// Zones widened over fast stretches, or too short for `min_zone_frames`
    /// ([`ZoneTable::frames_note`]).
    pub zone_note: Option<String>,
    /// Validation sequence (`None`: held-out training frames).
    pub validation_sequence: Option<PathBuf>,
    /// Further passes joined to the pairs.
    pub extra_sequences: Vec<PathBuf>,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// The amplitudes of `--index-zoom-blur`: `A,B,…` or `none`; their range, (0, 0.5], is
/// [`TrainConfig::validate`]'s to check.
///
/// # Errors
/// A value that is not a number, named with the option.
fn parse_zoom_blur(list: &str) -> Result<Vec<f64>> {
    if list.trim() == "none" {
        return Ok(Vec::new());
    }
    list.split(',')
        .map(|a| {
            a.trim().parse::<f64>().map_err(|_| {
                JobError::Invalid(format!(
                    "`index_zoom_blur` {list:?}: expected amplitudes in (0, 0.5] separated by \
                     commas (e.g. 0.03,0.06,0.12), or none"
                ))
            })
        })
        .collect()
}

/// `pairs`, `pair_frames` (`P,N`), `near_fraction` and `zone_fraction` applied to `rule`.
///
/// # Errors
/// Malformed frame gaps, tuning of zone pairs, or a rule that does not validate.
pub fn pair_rule_from(
    pairs: Option<Pairs>,
    pair_frames: Option<&str>,
    near: Option<f32>,
    zone: Option<f32>,
    rule: PairRule,
) -> Result<PairRule> {
    let mut rule = match pairs {
        None => rule,
        Some(Pairs::Zone) => PairRule::Zone,
        Some(Pairs::Track) => match rule {
            PairRule::Track { .. } => rule,
            PairRule::Zone => PairRule::track(),
        },
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
                    bail!("`pair_frames` {spec}: expected P,N (two frame counts, e.g. 3,10)");
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
                "`pair_frames`, `near_fraction` and `zone_fraction` apply to track pairs (`pairs` track)"
            )
        }
        PairRule::Zone => {}
    }
    rule.validate()?;
    Ok(rule)
}

impl TrainJob {
    /// The training configuration of this job: `config` (a TOML file) or the schedule and
    /// backbone, with every override applied.
    ///
    /// # Errors
    /// An unreadable config file or a bad value, named as its command-line option.
    pub fn train_config(&self) -> Result<TrainConfig> {
        let args = self;
        let mut cfg = match &args.config {
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .with_context(|| format!("reading {}", p.display()))?;
                toml::from_str::<TrainConfig>(&text).map_err(|e| {
                    let (line, message) = endoloc_data::toml_error_line(&text, &e);
                    JobError::Invalid(format!("{}:{line}: {message}", p.display()))
                })?
            }
            None => TrainConfig {
                backbone: args.backbone.config(),
                schedule: args.schedule.schedule(),
                ..TrainConfig::default()
            },
        };
        if let Some(size) = &args.input {
            cfg.backbone = cfg.backbone.clone().with_input(size.parse()?);
        }
        if let Some(n) = args.stem_stride {
            match &mut cfg.backbone {
                BackboneConfig::Compact { stem_stride, .. } => *stem_stride = n,
                other => bail!(
                    "`stem_stride` applies to the compact backbone, not {}",
                    other.name()
                ),
            }
        }
        if let Some(kind) = args.pooling {
            match &mut cfg.backbone {
                BackboneConfig::Compact { pooling, .. } => *pooling = kind,
                other => bail!(
                    "`pooling` applies to the compact backbone, not {}",
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
                bail!("`tilt_deg` {t}: expected 0 to 45 degrees");
            }
            cfg.augment.tilt_deg = t;
        }
        if args.no_augment {
            cfg.augment = AugmentConfig::off();
        }
        cfg.pairs = pair_rule_from(
            args.pairs,
            args.pair_frames.as_deref(),
            args.near_fraction,
            args.zone_fraction,
            cfg.pairs,
        )?;
        if let Some(p) = args.whitening {
            cfg.whitening = p;
        }
        if let Some(mm) = args.database_smoothing {
            cfg.database_smoothing_mm = mm;
        }
        if let Some(list) = &args.index_zoom_blur {
            cfg.index_zoom_blur = parse_zoom_blur(list)?;
        }
        if let Some(d) = args.index_view_penalty {
            cfg.index_view_penalty = d;
        }
        cfg.seed = args.seed;
        cfg.device = args.device.name().to_string();
        if args.val_seq.is_some() {
            cfg.validation.sequence = args.val_seq.clone();
        }
        if args.pretrained.is_some() {
            cfg.pretrained = args.pretrained.clone();
        }
        cfg.validate()?;
        Ok(cfg)
    }

    /// Trains and writes the model folder.
    ///
    /// # Errors
    /// An existing model folder without `force`, an unreadable dataset, a bad setting, or a
    /// failed training or write.
    pub fn run(&self, progress: &dyn Progress) -> Result<TrainReport> {
        let args = self;
        if args.method != TrainMethod::Siamese {
            let which = if args.method == TrainMethod::Posenet {
                Regressor::PoseNet
            } else {
                Regressor::OffsetNet
            };
            let dataset = Dataset::open(&args.data)?;
            let seq = dataset.sequence(&args.seq)?;
            let seconds = train_regressor(
                which,
                &seq,
                &dataset.meta.camera,
                &args.out,
                RegressorSettings {
                    epochs: args.epochs,
                    seed: args.seed,
                    force: args.force,
                },
                progress,
            )?;
            return Ok(TrainReport::Regressor {
                which,
                seconds,
                out: args.out.clone(),
            });
        }
        let cfg = self.train_config()?;
        let zcfg = args.zones.config(args.uniform_by, args.min_zone_frames);
        let dataset = Dataset::open(&args.data)?;
        let seq = dataset.sequence(&args.seq)?;
        let zones = ZoneTable::from_sequence(&seq, &zcfg)?;
        let zone_note = zones.frames_note();
        if let Some(note) = &zone_note {
            progress.note(&format!("zones: {note}"));
        }
        let mut cfg = cfg;
        for name in &args.also_seq {
            if *name == args.seq {
                bail!("`also_seq` {name}: that is the training sequence itself");
            }
            cfg.extra_sequences.push(dataset.sequence(name)?.dir);
        }
        progress.note(&format!(
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
        ));
        let target = TrainTarget {
            dir: args.out.clone(),
            force: args.force,
            resume: args.resume,
        };
        let t0 = Instant::now();
        let mut bars = TrainBars::new(progress);
        let report = train(
            &cfg,
            &seq,
            &zones,
            &dataset.meta.camera,
            &dataset.meta.name,
            &target,
            &mut |p| bars.show(p),
        )?;
        drop(bars);
        Ok(TrainReport::Siamese(Box::new(SiameseReport {
            zones: zones.len(),
            zone_frames: zones.frame_count(),
            zone_note,
            validation_sequence: cfg.validation.sequence.clone(),
            extra_sequences: cfg.extra_sequences.clone(),
            seconds: t0.elapsed().as_secs_f64(),
            report,
        })))
    }
}

impl fmt::Display for TrainReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = match self {
            TrainReport::Regressor {
                which,
                seconds,
                out,
            } => {
                return write!(
                    f,
                    "trained   {} in {seconds:.0} s → {}",
                    which.name(),
                    out.display()
                );
            }
            TrainReport::Siamese(r) => r,
        };
        let report = &r.report;
        if let Some(n) = report.resumed_after_epoch {
            writeln!(f, "resumed      after epoch {n}")?;
        }
        writeln!(f, "model        {}", report.model_dir.display())?;
        writeln!(f, "zones        {} ({} frames)", r.zones, r.zone_frames)?;
        if let Some(note) = &r.zone_note {
            writeln!(f, "zone note    {note}")?;
        }
        for (dir, n) in r.extra_sequences.iter().zip(&report.pass_frames) {
            writeln!(
                f,
                "extra pass   {} ({n} frames joined the pairs)",
                dir.display()
            )?;
        }
        if let Some(last) = report.history.last() {
            writeln!(f, "final loss   {:.4} (epoch {})", last.loss, last.epoch)?;
        }
        if let Some(v) = report
            .history
            .iter()
            .rev()
            .find(|h| h.val_accuracy.is_some())
        {
            writeln!(
                f,
                "validation   {:.1} % exact, {:.1} % within ±1 zone ({}, epoch {})",
                100.0 * v.val_accuracy.unwrap_or(0.0),
                100.0 * v.val_within1.unwrap_or(0.0),
                r.validation_sequence
                    .as_ref()
                    .map_or("held-out training frames".to_string(), |p| p
                        .display()
                        .to_string()),
                v.epoch
            )?;
        }
        write!(
            f,
            "time         {:.1} s total: load {:.1} s, train {:.1} s ({} steps), describe {:.1} s",
            r.seconds, report.load_s, report.train_s, report.steps, report.describe_s
        )
    }
}

/// Shows a training's phases on a progress sink: one loop per phase, the loss and validation
/// accuracy as the training loop's message.
pub struct TrainBars<'a> {
    sink: &'a dyn Progress,
    phase: Option<Phase>,
}

impl<'a> TrainBars<'a> {
    /// Bars on `sink`.
    pub fn new(sink: &'a dyn Progress) -> Self {
        TrainBars { sink, phase: None }
    }

    /// Shows `p`, starting a new loop when the phase changes.
    pub fn show(&mut self, p: &TrainProgress) {
        if self.phase != Some(p.phase) {
            if self.phase.is_some() {
                self.sink.finish();
            }
            let label = match p.phase {
                Phase::LoadingImages => "loading",
                Phase::Training => "training",
                Phase::Describing => "describing",
                Phase::Saving => "saving",
            };
            self.sink.start(label, p.total as u64);
            self.phase = Some(p.phase);
        }
        self.sink.position(p.done as u64, p.total as u64);
        if p.phase == Phase::Training {
            let loss = p.loss.map_or("-".into(), |l| format!("{l:.4}"));
            let val = p
                .val_accuracy
                .map_or(String::new(), |a| format!(" val {:.1}%", 100.0 * a));
            self.sink
                .message(&format!("ep {} loss {loss}{val}", p.epoch));
        }
    }
}

impl Drop for TrainBars<'_> {
    fn drop(&mut self) {
        if self.phase.is_some() {
            self.sink.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use endoloc_net::train::Schedule;

    fn config(job: TrainJob) -> Result<TrainConfig> {
        TrainJob {
            data: "d".into(),
            out: "m".into(),
            ..job
        }
        .train_config()
    }

    fn job() -> TrainJob {
        TrainJob::default()
    }

    #[test]
    fn defaults_agree() {
        let from_toml: TrainJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, TrainJob::default());
        let cfg = config(job()).unwrap();
        assert_eq!(cfg.backbone, BackboneConfig::compact());
        assert_eq!(cfg.pairs, PairRule::Zone);
        assert_eq!(cfg.schedule, Schedule::fast());
    }

    #[test]
    fn pooling_and_tilt_reach_the_config_and_bad_values_are_named() {
        let cfg = config(TrainJob {
            pooling: Some(Pooling::Gem),
            tilt_deg: Some(12.0),
            ..job()
        })
        .unwrap();
        let BackboneConfig::Compact { pooling, .. } = cfg.backbone else {
            panic!("compact expected");
        };
        assert_eq!(pooling, Pooling::Gem);
        assert_eq!(cfg.augment.tilt_deg, 12.0);
        let e = toml::from_str::<TrainJob>("pooling = \"max\"")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`max`") && e.contains("`gem`"), "{e}");
        let e = config(TrainJob {
            tilt_deg: Some(90.0),
            ..job()
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("`tilt_deg` 90"), "{e}");
        let e = config(TrainJob {
            backbone: Backbone::GoogLeNet,
            pooling: Some(Pooling::Gem),
            ..job()
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("compact backbone"), "{e}");
        // Zoom-blurred index views: off by default, a list, `none`, bad values named.
        assert!(config(job()).unwrap().index_zoom_blur.is_empty());
        let views = |list: &str| {
            config(TrainJob {
                index_zoom_blur: Some(list.into()),
                ..job()
            })
        };
        assert_eq!(
            views("0.03, 0.06,0.12").unwrap().index_zoom_blur,
            [0.03, 0.06, 0.12]
        );
        assert!(views("none").unwrap().index_zoom_blur.is_empty());
        let penalty = |d: f64| {
            config(TrainJob {
                index_view_penalty: Some(d),
                ..job()
            })
        };
        assert_eq!(config(job()).unwrap().index_view_penalty, 0.0);
        assert_eq!(penalty(0.07).unwrap().index_view_penalty, 0.07);
        let e = penalty(-0.1).unwrap_err().to_string();
        assert!(e.contains("index_view_penalty -0.1"), "{e}");
        for bad in ["0.7", "0", "a", "0.1,"] {
            let e = views(bad).unwrap_err().to_string();
            assert!(
                e.contains("index_zoom_blur") && e.contains("(0, 0.5]"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn pair_settings_reach_the_config_and_bad_values_are_named() {
        let track = |frames: Option<&str>, near: Option<f32>| TrainJob {
            pairs: Some(Pairs::Track),
            pair_frames: frames.map(str::to_string),
            near_fraction: near,
            ..job()
        };
        assert_eq!(config(track(None, None)).unwrap().pairs, PairRule::track());
        assert_eq!(
            config(track(Some("2,8"), Some(0.3))).unwrap().pairs,
            PairRule::Track {
                positive_frames: 2,
                negative_frames: 8,
                near_fraction: 0.3,
                zone_fraction: 0.0
            }
        );
        let e = toml::from_str::<TrainJob>("pairs = \"frames\"")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`frames`") && e.contains("`track`"), "{e}");
        let e = config(TrainJob {
            pair_frames: Some("2,8".into()),
            ..job()
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("`pairs` track"), "{e}");
        let e = config(track(Some("8"), None)).unwrap_err().to_string();
        assert!(e.contains("`pair_frames` 8"), "{e}");
        let e = config(track(Some("8,4"), None)).unwrap_err().to_string();
        assert!(e.contains("negative_frames 4 > positive_frames"), "{e}");
    }

    #[test]
    fn zone_specs_parse_and_bad_ones_are_named() {
        let spec: ZoneSpec = "expert:30".parse().unwrap();
        assert_eq!(
            spec.config(UniformBy::ArcLength, 3),
            ZoneConfig::Expert { count: 30 }
        );
        for (text, by) in [
            ("arc-length", UniformBy::ArcLength),
            ("frames", UniformBy::Frames),
        ] {
            let job: TrainJob = toml::from_str(&format!("uniform_by = \"{text}\"")).unwrap();
            assert_eq!(job.uniform_by, by);
        }
        let e = "many".parse::<ZoneSpec>().unwrap_err().to_string();
        assert!(e.contains("zones \"many\""), "{e}");
        let job: TrainJob = toml::from_str("zones = \"expert:9\"").unwrap();
        assert_eq!(job.zones, ZoneSpec::Expert(Some(9)));
        let job: TrainJob = toml::from_str("zones = 70").unwrap();
        assert_eq!(job.zones, ZoneSpec::Uniform(70));
        assert!(toml::from_str::<TrainJob>("zones = \"many\"").is_err());
    }
}
