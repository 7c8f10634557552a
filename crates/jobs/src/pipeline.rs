//! `RunJob` and `DemoJob`: the whole chain — simulate (or an existing dataset), train, map,
//! localize, evaluate — composed from the stage jobs.

use std::fmt::Display;
use std::path::{Path, PathBuf};
use std::time::Instant;

use endoloc_net::ZoneSpec;
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::error::{Context, JobError, Result};
use crate::output::{create_dir, replace_folder};
use crate::progress::Progress;
use crate::{EvalJob, LocalizeJob, MapJob, SimulateJob, TrainJob, ViewJob};

/// The whole chain from one TOML file (`endoloc run --config experiment.toml`): every table is
/// the stage's own job, with the same fields and defaults as its command. Paths between the
/// stages (`data`, `out`, `model`, `seq`) are filled in by the run.
///
/// ```toml
/// out = "experiments/paper50"   # required
/// data = "data/paper"           # an existing dataset, or a [simulate] table
/// [simulate]
/// preset = "paper"
/// [train]
/// zones = 50
/// pretrained = "builtin-joint"
/// epochs = 0
/// [map]
/// threshold = 25.0
/// [localize]
/// live = true
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunJob {
    /// Output folder: `data/` (when simulated), `model/`, `run/`, `run/eval/`,
    /// `experiment.toml` (a copy of the configuration) and `timings.csv`.
    pub out: PathBuf,
    /// An existing dataset (exactly one of `data` and `simulate`).
    pub data: Option<PathBuf>,
    /// Simulate the dataset first.
    pub simulate: Option<SimulateJob>,
    /// The training stage.
    #[serde(default)]
    pub train: TrainJob,
    /// The map stage.
    #[serde(default)]
    pub map: MapJob,
    /// The localization stage (of the dataset's `test` sequence).
    #[serde(default)]
    pub localize: LocalizeJob,
    /// The evaluation stage.
    #[serde(default)]
    pub eval: EvalJob,
}

/// Wall time of each stage of a chain, seconds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Timings {
    /// `(stage, seconds)` in the order run.
    pub stages: Vec<(String, f64)>,
}

impl Timings {
    /// Runs `f` as stage `name`, noting its start (`== name: command`) and its report.
    fn stage<R: Display>(
        &mut self,
        progress: &dyn Progress,
        name: &str,
        command: String,
        f: impl FnOnce() -> Result<R>,
    ) -> Result<R> {
        progress.note(&format!("\n== {name}: endoloc {command}"));
        let t = Instant::now();
        let report = f()?;
        progress.note(&report.to_string());
        self.stages
            .push((name.to_string(), t.elapsed().as_secs_f64()));
        Ok(report)
    }

    /// Total seconds.
    pub fn total(&self) -> f64 {
        self.stages.iter().map(|s| s.1).sum()
    }

    /// `stage,seconds` lines with a header and a total.
    pub fn csv(&self) -> String {
        let mut csv = String::from("stage,seconds\n");
        for (name, secs) in &self.stages {
            csv.push_str(&format!("{name},{secs:.2}\n"));
        }
        csv.push_str(&format!("total,{:.2}\n", self.total()));
        csv
    }
}

impl std::fmt::Display for Timings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "stage       wall s")?;
        for (name, secs) in &self.stages {
            writeln!(f, "{name:<10} {secs:>7.1}")?;
        }
        write!(f, "{:<10} {:>7.1}", "total", self.total())
    }
}

fn show(p: &Path) -> String {
    p.display().to_string()
}

impl RunJob {
    /// Reads a run configuration.
    ///
    /// # Errors
    /// An unreadable file, or TOML that does not describe a run (unknown keys are named).
    pub fn from_toml(text: &str) -> Result<Self> {
        let job: RunJob = toml::from_str(text).map_err(|e| {
            let (line, message) = endoloc_data::toml_error_line(text, &e);
            JobError::Invalid(format!("line {line}: {message}"))
        })?;
        if job.data.is_some() == job.simulate.is_some() {
            bail!("give exactly one of `data = \"DATASET\"` or a [simulate] table");
        }
        // Settings that cannot work are refused before any stage runs.
        job.train.train_config()?;
        Ok(job)
    }

    /// Runs every stage; `force` replaces an existing output folder. `config_text` is copied
    /// to `OUT/experiment.toml`.
    ///
    /// # Errors
    /// An existing output folder without `force`, or the first stage that fails.
    pub fn run(&self, config_text: &str, force: bool, progress: &dyn Progress) -> Result<Timings> {
        crate::output::refuse_existing(&self.out, force, " (the results of this run)")?;
        create_dir(&self.out)?;
        let copy = self.out.join("experiment.toml");
        endoloc_data::write_atomic(&copy, config_text.as_bytes())
            .with_context(|| format!("writing {}", copy.display()))?;
        let mut t = Timings::default();
        let data = match (&self.data, &self.simulate) {
            (Some(d), _) => d.clone(),
            (None, Some(sim)) => {
                let job = SimulateJob {
                    out: self.out.join("data"),
                    force,
                    ..sim.clone()
                };
                t.stage(progress, "simulate", job.command_line(), || {
                    job.run(progress)
                })?;
                job.out
            }
            (None, None) => bail!("give exactly one of `data` or a [simulate] table"),
        };
        let model = self.out.join("model");
        let train = TrainJob {
            data: data.clone(),
            out: model.clone(),
            force,
            ..self.train.clone()
        };
        t.stage(progress, "train", train.command_line(), || {
            train.run(progress)
        })?;
        let map = MapJob {
            model: model.clone(),
            data: data.clone(),
            force,
            ..self.map.clone()
        };
        t.stage(progress, "map", map.command_line(), || map.run(progress))?;
        let test = data.join("test");
        let localize = LocalizeJob {
            model: Some(model),
            seq: test.clone(),
            out: self.out.join("run"),
            force,
            ..self.localize.clone()
        };
        t.stage(progress, "localize", localize.command_line(), || {
            localize.run(progress)
        })?;
        let eval = EvalJob {
            gt: test.join("poses.txt"),
            est: self.out.join("run/trajectory.txt"),
            frames: Some(self.out.join("run/frames.csv")),
            out: self.out.join("run/eval"),
            force,
            ..self.eval.clone()
        };
        t.stage(progress, "eval", eval.command_line(), || eval.run(progress))?;
        let path = self.out.join("timings.csv");
        endoloc_data::write_atomic(&path, t.csv().as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        Ok(t)
    }
}

/// The whole method on the built-in colon, from nothing to a report: a small simulated
/// dataset, the zone classifier (by default the shipped `builtin-joint` network indexing the
/// training pass, no training; with `train`, the paper's classifier trained from scratch), the
/// per-zone maps, live localization of the test pass, its evaluation and a viewer page.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct DemoJob {
    /// Output folder: data/, model/, run/ (with view.html), run/eval/.
    #[cfg_attr(feature = "cli", arg(long, default_value_os_t = DemoJob::default().out))]
    pub out: PathBuf,
    /// Uniform zones along the training pass.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DemoJob::default().zones))]
    pub zones: usize,
    /// Train the paper's Siamese classifier from scratch (a short schedule of `epochs`)
    /// instead of indexing the pass with the shipped network.
    #[cfg_attr(feature = "cli", arg(long))]
    pub train: bool,
    /// Training epochs with `train` (the train job defaults to more).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DemoJob::default().epochs))]
    pub epochs: usize,
    /// Image size of the simulated frames, WIDTHxHEIGHT (in a TOML table `[width, height]`).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "WxH", default_value = "640x480", value_parser = parse_size)
    )]
    pub size: (u32, u32),
    /// SURF threshold of the map; test frames keep their strongest keypoints above 0.4 times it
    /// (a budget per frame, as `localize` does by default).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DemoJob::default().threshold))]
    pub threshold: f32,
    /// Master seed of the simulation and the training.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DemoJob::default().seed))]
    pub seed: u64,
    /// Replace an existing output folder.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

/// An image size `WIDTHxHEIGHT`, at least 16×16 pixels.
#[cfg(feature = "cli")]
fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let parsed = s
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    parsed
        .filter(|&(w, h): &(u32, u32)| w >= 16 && h >= 16)
        .ok_or_else(|| format!("{s}: expected WIDTHxHEIGHT, e.g. 640x480"))
}

impl Default for DemoJob {
    fn default() -> Self {
        DemoJob {
            out: "endoloc-demo".into(),
            zones: 50,
            train: false,
            epochs: 40,
            size: (640, 480),
            threshold: MapJob::default().threshold,
            seed: 0,
            force: false,
        }
    }
}

/// What the demo did: each stage's time, the figures that matter and where to look next.
#[derive(Debug, Clone)]
pub struct DemoReport {
    /// Wall time per stage.
    pub timings: Timings,
    /// Fractions of test frames `refined`, in [0, 1].
    pub refined: f64,
    /// Mean and median position error over all test frames, mm.
    pub position_mm: (f64, f64),
    /// Mean and median orientation error over all test frames, degrees.
    pub orientation_deg: (f64, f64),
    /// Median time per frame of live localization, ms.
    pub median_ms: f64,
    /// The evaluation report (`run/eval/report.md`) and its `metrics.json`.
    pub report: PathBuf,
    /// The viewer page (`run/view.html`).
    pub view: PathBuf,
}

impl std::fmt::Display for DemoReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "demo done in {:.0} s", self.timings.total())?;
        writeln!(
            f,
            "refined   {:.1} % of the test frames",
            100.0 * self.refined
        )?;
        writeln!(
            f,
            "error     mean {:.2} mm / {:.2}°, median {:.2} mm / {:.2}°",
            self.position_mm.0, self.orientation_deg.0, self.position_mm.1, self.orientation_deg.1
        )?;
        writeln!(
            f,
            "latency   median {:.1} ms per frame (live)",
            self.median_ms
        )?;
        write!(
            f,
            "next      open {} (colon, map, scope, every frame); report {}",
            self.view.display(),
            self.report.display()
        )
    }
}

impl DemoJob {
    /// Runs the demo.
    ///
    /// # Errors
    /// An existing output folder without `force`, or the first stage that fails.
    pub fn run(&self, progress: &dyn Progress) -> Result<DemoReport> {
        replace_folder(&self.out, self.force, " (or choose another output folder)")?;
        create_dir(&self.out)?;
        let p = |rel: &str| self.out.join(rel);
        let mut t = Timings::default();
        let sim = SimulateJob {
            preset: endoloc_sim::Preset::Small,
            seed: Some(self.seed),
            width: Some(self.size.0),
            height: Some(self.size.1),
            depth: Some(false),
            out: p("data"),
            ..SimulateJob::default()
        };
        t.stage(progress, "1/6 simulate", sim.command_line(), || {
            sim.run(progress)
        })?;
        let train = if self.train {
            TrainJob {
                data: p("data"),
                zones: ZoneSpec::Uniform(self.zones),
                out: p("model"),
                schedule: crate::choice::SchedulePreset::Fast,
                epochs: Some(self.epochs),
                seed: self.seed,
                ..TrainJob::default()
            }
        } else {
            TrainJob {
                data: p("data"),
                zones: ZoneSpec::Uniform(self.zones),
                out: p("model"),
                pretrained: Some("builtin-joint".into()),
                epochs: Some(0),
                seed: self.seed,
                ..TrainJob::default()
            }
        };
        t.stage(progress, "2/6 train", train.command_line(), || {
            train.run(progress)
        })?;
        let map = MapJob {
            model: p("model"),
            data: p("data"),
            threshold: self.threshold,
            ..MapJob::default()
        };
        t.stage(progress, "3/6 map", map.command_line(), || {
            map.run(progress)
        })?;
        let localize = LocalizeJob {
            model: Some(p("model")),
            seq: p("data/test"),
            out: p("run"),
            live: true,
            ..LocalizeJob::default()
        };
        let run = t.stage(progress, "4/6 localize", localize.command_line(), || {
            localize.run(progress)
        })?;
        let eval = EvalJob {
            gt: p("data/test/poses.txt"),
            est: p("run/trajectory.txt"),
            frames: Some(p("run/frames.csv")),
            out: p("run/eval"),
            ..EvalJob::default()
        };
        let evaluated = t.stage(progress, "5/6 eval", eval.command_line(), || {
            eval.run(progress)
        })?;
        let view = ViewJob {
            run: p("run"),
            ..ViewJob::default()
        };
        let page = t.stage(progress, "6/6 view", view.command_line(), || {
            view.run(progress)
        })?;
        let summary = run.summary.unwrap_or_default();
        let m = &evaluated.metrics;
        Ok(DemoReport {
            timings: t,
            refined: summary.refined(),
            position_mm: (m.position_mm.mean, m.position_mm.median),
            orientation_deg: (m.orientation_deg.mean, m.orientation_deg.median),
            median_ms: summary.median_ms(),
            report: p("run/eval/report.md"),
            view: page.out,
        })
    }
}

/// Builds the command line a user would type for a job (for display only: nothing parses it).
#[derive(Debug, Clone)]
pub struct CommandLine(String);

impl CommandLine {
    /// `endoloc <command>`, without the `endoloc`.
    pub fn new(command: &str) -> Self {
        CommandLine(command.to_string())
    }
    /// `--name value`, or the bare `value` when `name` is empty (a positional argument).
    pub fn arg(mut self, name: &str, value: impl Display) -> Self {
        if name.is_empty() {
            self.0.push_str(&format!(" {value}"));
        } else {
            self.0.push_str(&format!(" --{name} {value}"));
        }
        self
    }
    /// `--name PATH`.
    pub fn path(self, name: &str, value: &Path) -> Self {
        self.arg(name, show(value))
    }
    /// `--name value` when `value` differs from `default`.
    pub fn arg_if<T: Display + PartialEq>(self, name: &str, value: &T, default: &T) -> Self {
        if value != default {
            self.arg(name, value)
        } else {
            self
        }
    }
    /// `--name value` when present.
    pub fn opt<T: Display>(self, name: &str, value: Option<T>) -> Self {
        match value {
            Some(v) => self.arg(name, v),
            None => self,
        }
    }
    /// `--name` when `on`.
    pub fn flag(mut self, name: &str, on: bool) -> Self {
        if on {
            self.0.push_str(&format!(" --{name}"));
        }
        self
    }
    /// The command line.
    pub fn finish(self) -> String {
        self.0
    }
}

impl TrainJob {
    /// The `endoloc train` command line of this job (the settings that differ from the
    /// defaults).
    pub fn command_line(&self) -> String {
        let d = TrainJob::default();
        CommandLine::new("train")
            .path("data", &self.data)
            .arg_if("seq", &self.seq, &d.seq)
            .arg_if("zones", &self.zones, &d.zones)
            .path("out", &self.out)
            .arg_if("schedule", &self.schedule, &d.schedule)
            .opt("epochs", self.epochs)
            .arg_if("seed", &self.seed, &d.seed)
            .opt("pairs", self.pairs)
            .opt("pretrained", self.pretrained.as_deref().map(show))
            .flag("resume", self.resume)
            .flag("force", self.force)
            .finish()
    }
}

impl MapJob {
    /// The `endoloc map` command line of this job.
    pub fn command_line(&self) -> String {
        let d = MapJob::default();
        CommandLine::new("map")
            .path("model", &self.model)
            .path("data", &self.data)
            .arg_if("seq", &self.seq, &d.seq)
            .arg_if("images-per-zone", &self.images_per_zone, &d.images_per_zone)
            .arg("threshold", self.threshold)
            .arg_if("intensity", &self.intensity, &d.intensity)
            .arg_if("delta-r", &self.delta_r_px, &d.delta_r_px)
            .arg_if(
                "observation-radius",
                &self.observation_radius_px,
                &d.observation_radius_px,
            )
            .opt("smoothed-level", self.smoothed_level_px)
            .flag("force", self.force)
            .finish()
    }
}

impl LocalizeJob {
    /// The `endoloc localize` command line of this job (the settings that differ from the
    /// defaults).
    pub fn command_line(&self) -> String {
        let d = LocalizeJob::default();
        CommandLine::new("localize")
            .opt("model", self.model.as_deref().map(show))
            .path("seq", &self.seq)
            .path("out", &self.out)
            .flag("live", self.live)
            .arg_if("candidate-zones", &self.candidate_zones, &d.candidate_zones)
            .arg_if("neighbours", &self.neighbours, &d.neighbours)
            .flag("force", self.force)
            .finish()
    }
}

impl SimulateJob {
    /// The `endoloc simulate` command line of this job.
    pub fn command_line(&self) -> String {
        CommandLine::new("simulate")
            .arg("preset", self.preset)
            .opt("seed", self.seed)
            .opt("width", self.width)
            .opt("height", self.height)
            .flag("depth", self.depth == Some(true))
            .flag("no-depth", self.depth == Some(false))
            .opt("gca", self.gca.as_deref().map(show))
            .path("out", &self.out)
            .flag("force", self.force)
            .finish()
    }
}

impl ViewJob {
    /// The `endoloc view` command line of this job.
    pub fn command_line(&self) -> String {
        CommandLine::new("view")
            .path("", &self.run)
            .opt("out", self.out.as_deref().map(show))
            .flag("force", self.force)
            .finish()
    }
}

impl EvalJob {
    /// The `endoloc eval` command line of this job.
    pub fn command_line(&self) -> String {
        let line = CommandLine::new("eval")
            .path("gt", &self.gt)
            .path("est", &self.est)
            .opt("frames", self.frames.as_deref().map(show));
        let line = if self.out.as_os_str().is_empty() {
            line
        } else {
            line.path("out", &self.out)
        };
        line.flag("force", self.force).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_tables_are_the_stage_jobs() {
        let job =
            RunJob::from_toml("out = \"o\"\ndata = \"d\"\n[train]\npairs = \"track\"\n").unwrap();
        assert_eq!(job.train.pairs, Some(crate::choice::Pairs::Track));
        let job = RunJob::from_toml("out = \"o\"\ndata = \"d\"\n").unwrap();
        assert_eq!(job.train, TrainJob::default());
        assert_eq!(job.map, MapJob::default());
        assert_eq!(job.localize, LocalizeJob::default());
    }

    #[test]
    fn bad_runs_are_refused_before_any_stage() {
        let e = RunJob::from_toml("out = \"o\"\ndata = \"d\"\n[train]\npairs = \"frames\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("frames") && e.contains("track"), "{e}");
        let e = RunJob::from_toml("out = \"o\"\n").unwrap_err().to_string();
        assert!(e.contains("exactly one"), "{e}");
        let e = RunJob::from_toml("out = \"o\"\ndata = \"d\"\n[map]\nthreshhold = 3.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("threshhold"), "{e}");
    }

    #[test]
    fn train_command_lines_show_epochs_only_when_set() {
        let job = RunJob::from_toml("out = \"o\"\ndata = \"d\"\n").unwrap();
        assert!(!job.train.command_line().contains("--epochs"));
        let job = RunJob::from_toml(
            "out = \"o\"\ndata = \"d\"\n[train]\nepochs = 0\npretrained = \"builtin-joint\"\n",
        )
        .unwrap();
        let line = job.train.command_line();
        assert!(
            line.contains("--epochs 0") && line.contains("--pretrained builtin-joint"),
            "{line}"
        );
    }
}
