//! `PretrainJob`: start weights for the zone classifier from simulated colons.

use std::fmt;
use std::path::PathBuf;

use endoloc_data::Dataset;
use endoloc_net::pretrain::{PretrainColon, PretrainReport as JointReport, pretrain};
use endoloc_net::train::{TrainConfig, TrainTarget};
use endoloc_net::{InputSize, UniformBy, ZoneConfig, ZoneSpec};
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::choice::{Device, Pairs};
use crate::error::{Context, JobError, Result};
use crate::progress::Progress;
use crate::simulate::{SimulateJob, SimulateReport};
use crate::train::{TrainBars, TrainJob, TrainReport, pair_rule_from};
use endoloc_sim::{ChangeConfig, Preset, Severity};

/// Pretrains the zone classifier's network on `colons` simulated colons, each rendered with a
/// training and a test pass (seeds `seed + 101·i`), and writes start weights for
/// `TrainJob::pretrained` to `out/weights.safetensors`. Colon after colon, each starting
/// from the previous one's weights, the network is trained with the test pass's frames in
/// the zone of their nearest training pose; with `joint`, one network is trained on every
/// colon at once instead. With `changes`, each test pass goes through its colon changed at
/// random ([`ChangeConfig::draw`]): the pairs across the passes then span the change. Writes
/// `out/colon-SEED/` (datasets), `out/model-SEED/` (models; with `joint` one `out/joint/`); a
/// colon or model already in `out` is reused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct PretrainJob {
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub out: PathBuf,
    /// Number of simulated colons, trained on one after the other.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PretrainJob::default().colons))]
    pub colons: usize,
    /// Seed of the first colon; colon i has seed `seed + 101·i`.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PretrainJob::default().seed))]
    pub seed: u64,
    /// Simulator preset of the colons (`paper`, or `small` for a quick try).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PretrainJob::default().preset))]
    pub preset: Preset,
    /// Uniform zones of each colon's training pass.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PretrainJob::default().zones))]
    pub zones: usize,
    /// Training epochs per colon (default: the `fast` schedule's); with `joint`, the whole
    /// training's (default: 60 per colon).
    #[cfg_attr(feature = "cli", arg(long))]
    pub epochs: Option<usize>,
    /// Training pairs of each colon: `zone` (default) or `track` (see the train job's
    /// `pairs`; the test pass's frames then pair by their place along the training pass).
    #[cfg_attr(feature = "cli", arg(long, value_enum, value_name = "RULE"))]
    pub pairs: Option<Pairs>,
    /// Track pairs: fraction of negatives near the positive (see the train job's
    /// `near_fraction`), e.g. 0.1.
    #[cfg_attr(feature = "cli", arg(long, value_name = "F"))]
    pub near_fraction: Option<f32>,
    /// Start weights of the first colon (a `.safetensors` or `.pt` file, or `builtin`):
    /// continue from an earlier pretraining, e.g. with other pairs. Default: random weights.
    #[cfg_attr(feature = "cli", arg(long, value_name = "WEIGHTS"))]
    pub pretrained: Option<String>,
    /// Train one network on every colon at once (batches drawn from all of them, each
    /// negative from its partner's colon) instead of colon after colon. `epochs` is then
    /// the whole training's (default 60 per colon).
    #[cfg_attr(feature = "cli", arg(long))]
    pub joint: bool,
    /// Track pairs: largest positive and smallest negative frame gap, `P,N` (default 3,10;
    /// halve them with `fps` 15).
    #[cfg_attr(feature = "cli", arg(long, value_name = "P,N"))]
    pub pair_frames: Option<String>,
    /// Frames of each pass (default: the preset's).
    #[cfg_attr(feature = "cli", arg(long, value_name = "N"))]
    pub frames: Option<usize>,
    /// Frame rate of the simulated passes (default: the preset's, 30); with half the frames,
    /// 15 renders every second frame of the same passes.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FPS"))]
    pub fps: Option<f64>,
    /// Image width and height WIDTHxHEIGHT (default: the preset's).
    #[cfg_attr(feature = "cli", arg(long, value_name = "WxH"))]
    pub size: Option<String>,
    /// Each colon's test pass through its colon changed at random up to this severity (`mild`,
    /// `moderate` or `severe`): every factor of the change model (shape, look, scope; see
    /// `simulate --changes`) drawn between none and the severity's value, seeded by the
    /// colon's seed, so that the network learns to find a zone in a colon that changed since
    /// its map pass. Default: both passes through the same colon.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "SEVERITY", value_parser = crate::severity_parser())
    )]
    pub changes: Option<Severity>,
    /// Replace an existing OUT/weights.safetensors.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto (BURN_DEVICE, else cpu).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value_t = PretrainJob::default().device)
    )]
    pub device: Device,
}

impl Default for PretrainJob {
    fn default() -> Self {
        PretrainJob {
            out: PathBuf::new(),
            colons: 4,
            seed: 101,
            preset: Preset::Paper,
            zones: 50,
            epochs: None,
            pairs: None,
            near_fraction: None,
            pretrained: None,
            joint: false,
            pair_frames: None,
            frames: None,
            fps: None,
            size: None,
            changes: None,
            force: false,
            device: Device::Cpu,
        }
    }
}

/// One colon of a pretraining: what was simulated and trained (`None`: reused).
#[derive(Debug)]
pub struct ColonReport {
    /// The colon's seed.
    pub seed: u64,
    /// The simulation, when the colon was not reused.
    pub simulated: Option<SimulateReport>,
    /// The training, when the model was not reused (never with `joint`).
    pub trained: Option<TrainReport>,
}

/// What `PretrainJob` did.
#[derive(Debug)]
pub struct PretrainReport {
    /// Per colon, in order.
    pub colons: Vec<ColonReport>,
    /// The joint training, with `joint` (when not reused).
    pub joint: Option<JointReport>,
    /// The start weights written.
    pub weights: PathBuf,
}

impl PretrainJob {
    fn seed_of(&self, i: usize) -> u64 {
        self.seed + 101 * i as u64
    }

    /// Folder of colon `i` (simulated) in `out`.
    fn colon_dir(&self, i: usize) -> PathBuf {
        self.out.join(format!("colon-{}", self.seed_of(i)))
    }

    /// Refuses a colon simulated earlier with another change than the one asked for.
    fn check_reused(&self, data: &std::path::Path) -> Result<()> {
        let ds = Dataset::open(data)?;
        let had = ds
            .meta
            .simulation
            .as_ref()
            .and_then(|s| {
                s.get("changes")?
                    .get("severity")?
                    .as_str()
                    .map(str::to_owned)
            })
            .unwrap_or_else(|| Severity::None.name().to_owned());
        let asked = self.changes.unwrap_or_default();
        if had != asked.name() {
            bail!(
                "{} was simulated with changes `{had}`, this pretraining asks for `{asked}`: \
                 use another `out`, or remove the folder to simulate it again",
                data.display()
            );
        }
        Ok(())
    }

    /// Simulates, trains and writes the start weights.
    ///
    /// # Errors
    /// No colon, an existing `out/weights.safetensors` without `force`, bad settings, or a
    /// failed simulation, training or write.
    pub fn run(&self, progress: &dyn Progress) -> Result<PretrainReport> {
        if self.colons == 0 {
            bail!("`colons` 0: at least one colon is needed");
        }
        let weights = self.out.join("weights.safetensors");
        crate::output::refuse_existing(&weights, self.force, "")?;
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("creating {}", self.out.display()))?;
        let size = match &self.size {
            Some(text) => {
                let s: InputSize = text.parse().map_err(|e| {
                    JobError::Invalid(format!("`size` {text}: expected WIDTHxHEIGHT: {e}"))
                })?;
                Some((s.width, s.height))
            }
            None => None,
        };
        let mut previous: Option<PathBuf> = self.pretrained.as_ref().map(PathBuf::from);
        let mut colons = Vec::with_capacity(self.colons);
        for i in 0..self.colons {
            let seed = self.seed_of(i);
            let data = self.colon_dir(i);
            let model = self.out.join(format!("model-{seed}"));
            let title = format!("colon {} of {}", i + 1, self.colons);
            let mut colon = ColonReport {
                seed,
                simulated: None,
                trained: None,
            };
            if data.join("dataset.toml").is_file() {
                self.check_reused(&data)?;
                progress.note(&format!("\n== {title}: reusing {}", data.display()));
            } else {
                progress.note(&format!("\n== {title}: simulate"));
                let sim = SimulateJob {
                    preset: self.preset,
                    seed: Some(seed),
                    out: data.clone(),
                    force: true,
                    train_frames: self.frames,
                    test_frames: self.frames,
                    fps: self.fps,
                    width: size.map(|s| s.0),
                    height: size.map(|s| s.1),
                    ..SimulateJob::default()
                };
                let mut cfg = sim.sim_config()?;
                if let Some(up_to) = self.changes {
                    cfg.changes = ChangeConfig::draw(up_to, cfg.changes.seed);
                }
                colon.simulated = Some(sim.run_config(&cfg, progress)?);
            }
            if !self.joint {
                if model.join("weights.safetensors").is_file() {
                    progress.note(&format!("== {title}: reusing {}", model.display()));
                } else {
                    progress.note(&format!("\n== {title}: train"));
                    let train = TrainJob {
                        data: data.clone(),
                        zones: ZoneSpec::Uniform(self.zones),
                        also_seq: vec!["test".into()],
                        out: model.clone(),
                        force: true,
                        pretrained: previous.clone(),
                        epochs: self.epochs,
                        pairs: self.pairs,
                        near_fraction: self.near_fraction,
                        pair_frames: self.pair_frames.clone(),
                        device: self.device,
                        ..TrainJob::default()
                    };
                    colon.trained = Some(train.run(progress)?);
                }
                previous = Some(model.join("weights.safetensors"));
            }
            colons.push(colon);
        }
        let mut joint = None;
        if self.joint {
            let (w, report) = self.train_joint(progress)?;
            previous = Some(w);
            joint = report;
        }
        let last = previous.context("no colon was trained")?;
        let tmp = self.out.join("weights.safetensors.partial");
        std::fs::copy(&last, &tmp)
            .with_context(|| format!("copying {} to {}", last.display(), tmp.display()))?;
        std::fs::rename(&tmp, &weights)
            .with_context(|| format!("renaming {} to {}", tmp.display(), weights.display()))?;
        Ok(PretrainReport {
            colons,
            joint,
            weights,
        })
    }

    /// The joint training (`out/joint`, resumed when interrupted): its weights, and its report
    /// unless reused.
    fn train_joint(&self, progress: &dyn Progress) -> Result<(PathBuf, Option<JointReport>)> {
        let dir = self.out.join("joint");
        let weights = dir.join(endoloc_net::model::WEIGHTS_FILE);
        if weights.is_file() {
            progress.note(&format!("\n== joint training: reusing {}", dir.display()));
            return Ok((weights, None));
        }
        let colons = (0..self.colons)
            .map(|i| {
                let ds = Dataset::open(&self.colon_dir(i))?;
                Ok(PretrainColon {
                    train: ds.sequence("train")?,
                    passes: vec![ds.sequence("test")?.dir],
                    camera: ds.meta.camera,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let mut cfg = TrainConfig {
            pretrained: self.pretrained.as_ref().map(PathBuf::from),
            device: self.device.name().to_string(),
            ..TrainConfig::default()
        };
        cfg.pairs = pair_rule_from(
            self.pairs,
            self.pair_frames.as_deref(),
            self.near_fraction,
            None,
            cfg.pairs,
        )?;
        cfg.schedule.epochs = self.epochs.unwrap_or(60 * self.colons);
        // Held-out frames against a database spread over every colon say little (the database
        // must be sparse to be quick); what a pretraining is worth shows on a colon it never
        // saw (train with 0 epochs from the weights, then classify).
        cfg.validation.holdout_every = 0;
        cfg.validate()?;
        let zones = ZoneConfig::uniform(self.zones, UniformBy::ArcLength);
        progress.note(&format!(
            "\n== joint training: {} colons at once, {} epochs of {} pairs → {}",
            colons.len(),
            cfg.schedule.epochs,
            cfg.schedule.pairs_per_epoch,
            dir.display()
        ));
        let target = TrainTarget {
            dir: dir.clone(),
            force: self.force,
            resume: true,
        };
        let report = {
            let mut bars = TrainBars::new(progress);
            pretrain(&cfg, &zones, &colons, &target, &mut |p| bars.show(p))?
        };
        Ok((weights, Some(report)))
    }
}

impl fmt::Display for PretrainReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in &self.colons {
            if let Some(s) = &c.simulated {
                writeln!(f, "{s}")?;
            }
            if let Some(t) = &c.trained {
                writeln!(f, "{t}")?;
            }
        }
        if let Some(r) = &self.joint {
            writeln!(
                f,
                "joint     {} images from {} colons, {} steps in {:.0} s (loading {:.0} s), final loss {}",
                r.images.iter().sum::<usize>(),
                r.images.len(),
                r.steps,
                r.train_s,
                r.load_s,
                r.history
                    .last()
                    .map_or("-".into(), |e| format!("{:.4}", e.loss))
            )?;
        }
        writeln!(f, "wrote     {}", self.weights.display())?;
        write!(
            f,
            "next      train with `pretrained` {}",
            self.weights.display()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_from_an_empty_file() {
        let from_toml: PretrainJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, PretrainJob::default());
        let job = PretrainJob {
            out: "p".into(),
            ..PretrainJob::default()
        };
        assert_eq!(job.colon_dir(1), std::path::Path::new("p/colon-202"));
        assert_eq!(
            TrainJob::default().zones,
            ZoneSpec::Uniform(PretrainJob::default().zones),
            "a colon's zones default to the training default"
        );
    }
}
