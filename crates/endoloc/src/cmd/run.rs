//! `endoloc run --config experiment.toml`: the whole chain from one config file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::Deserialize;

use crate::cmd;
use crate::cmd::demo::{parse, stage};

/// Run simulate (or use an existing dataset), train, map, localize and eval from one TOML file.
/// The file is copied to OUT/experiment.toml so the run can be repeated from its own outputs;
/// the wall time of every stage is printed at the end and written to OUT/timings.csv.
///
/// Example experiment.toml (every table but `out` is optional; values shown are defaults
/// unless marked):
///
///   out = "experiments/paper50"        # required
///   data = "data/paper"                # an existing dataset; or a [simulate] table:
///   [simulate]
///   preset = "paper"                   # small | paper
///   seed = 0
///   [train]
///   zones = "50"                       # a number, or "expert" / "expert:N"
///   schedule = "fast"                  # fast | paper
///   # epochs = 150                     # default: the schedule's; 0 with pretrained: index only
///   seed = 0
///   pretrained = "builtin"             # optional start weights: a file, builtin, builtin-track, builtin-joint
///   pairs = "zone"                     # zone (the paper's) | track (`endoloc train --pairs`)
///   [map]
///   images_per_zone = 8
///   threshold = 25.0                   # map; test frames at twice it, retried at it
///   [localize]
///   live = false
///   candidate_zones = 3
///   neighbours = 1
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Experiment file (TOML).
    #[arg(long, value_name = "TOML")]
    config: PathBuf,
    /// Replace an existing output folder.
    #[arg(long)]
    force: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Experiment {
    out: PathBuf,
    data: Option<PathBuf>,
    simulate: Option<SimulateStage>,
    #[serde(default)]
    train: TrainStage,
    #[serde(default)]
    map: MapStage,
    #[serde(default)]
    localize: LocalizeStage,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct SimulateStage {
    preset: String,
    seed: u64,
}

impl Default for SimulateStage {
    fn default() -> Self {
        SimulateStage {
            preset: "small".into(),
            seed: 0,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct TrainStage {
    zones: String,
    schedule: String,
    /// `--epochs`: absent for the schedule's; 0 (with `pretrained`) indexes the pass with the
    /// start weights and trains nothing.
    epochs: Option<usize>,
    seed: u64,
    /// Start from these weights (`--pretrained`; a path like `out` and `data`).
    pretrained: Option<PathBuf>,
    /// Training pairs (`--pairs`).
    pairs: PairsChoice,
}

/// `[train] pairs`: the value of `endoloc train --pairs`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
enum PairsChoice {
    Zone,
    Track,
}

impl PairsChoice {
    fn flag(self) -> &'static str {
        match self {
            PairsChoice::Zone => "zone",
            PairsChoice::Track => "track",
        }
    }
}

impl TrainStage {
    /// The `endoloc train` arguments of this stage (without `--force`).
    fn argv(&self, data: &str, model: &str) -> Vec<String> {
        let mut argv: Vec<String> = [
            "train",
            "--data",
            data,
            "--zones",
            &self.zones,
            "--out",
            model,
            "--schedule",
            &self.schedule,
            "--seed",
            &self.seed.to_string(),
            "--pairs",
            self.pairs.flag(),
        ]
        .iter()
        .map(|x| x.to_string())
        .collect();
        if let Some(epochs) = self.epochs {
            argv.extend(["--epochs".to_string(), epochs.to_string()]);
        }
        if let Some(w) = &self.pretrained {
            argv.extend(["--pretrained".to_string(), w.display().to_string()]);
        }
        argv
    }
}

impl Default for TrainStage {
    fn default() -> Self {
        TrainStage {
            zones: "50".into(),
            schedule: "fast".into(),
            epochs: None,
            seed: 0,
            pretrained: None,
            pairs: PairsChoice::Zone,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct MapStage {
    images_per_zone: usize,
    threshold: f64,
}

impl Default for MapStage {
    fn default() -> Self {
        MapStage {
            images_per_zone: 8,
            threshold: cmd::localize::DEFAULT_MAP_THRESHOLD,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct LocalizeStage {
    live: bool,
    candidate_zones: usize,
    neighbours: usize,
}

impl Default for LocalizeStage {
    fn default() -> Self {
        LocalizeStage {
            live: false,
            candidate_zones: 3,
            neighbours: 1,
        }
    }
}

/// Runs `endoloc run`.
pub fn run(args: Args) -> Result<()> {
    let text = std::fs::read_to_string(&args.config)
        .with_context(|| format!("reading {}", args.config.display()))?;
    let exp: Experiment =
        toml::from_str(&text).with_context(|| format!("parsing {}", args.config.display()))?;
    if exp.data.is_some() == exp.simulate.is_some() {
        bail!(
            "{}: give exactly one of `data = \"DATASET\"` or a [simulate] table",
            args.config.display()
        );
    }
    if exp.out.exists() && !args.force {
        bail!(
            "{} exists; pass --force to replace its results",
            exp.out.display()
        );
    }
    std::fs::create_dir_all(&exp.out).with_context(|| format!("creating {}", exp.out.display()))?;
    let copy = exp.out.join("experiment.toml");
    endoloc_eval::write_atomic(&copy, text.as_bytes())
        .with_context(|| format!("writing {}", copy.display()))?;
    let p = |rel: &str| exp.out.join(rel).display().to_string();
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<String>>();
    let force: &[&str] = if args.force { &["--force"] } else { &[] };
    let mut timings: Vec<(&str, f64)> = Vec::new();
    let mut timed = |name: &'static str, f: &mut dyn FnMut() -> Result<()>| -> Result<()> {
        let t = std::time::Instant::now();
        f()?;
        timings.push((name, t.elapsed().as_secs_f64()));
        Ok(())
    };

    let data: PathBuf = match (&exp.data, &exp.simulate) {
        (Some(d), _) => d.clone(),
        (None, Some(sim)) => {
            let mut argv = s(&[
                "simulate",
                "--preset",
                &sim.preset,
                "--seed",
                &sim.seed.to_string(),
                "--out",
                &p("data"),
            ]);
            argv.extend(s(force));
            stage("simulate", &argv);
            timed("simulate", &mut || cmd::simulate::run(parse(&argv)?))?;
            exp.out.join("data")
        }
        (None, None) => unreachable!("checked above"),
    };
    let data_s = data.display().to_string();

    let mut train = exp.train.argv(&data_s, &p("model"));
    train.extend(s(force));
    stage("train", &train);
    timed("train", &mut || cmd::train::run(parse(&train)?))?;

    let mut map = s(&[
        "map",
        "--model",
        &p("model"),
        "--data",
        &data_s,
        "--images-per-zone",
        &exp.map.images_per_zone.to_string(),
        "--threshold",
        &exp.map.threshold.to_string(),
    ]);
    map.extend(s(force));
    stage("map", &map);
    timed("map", &mut || cmd::localize::run_map(parse(&map)?))?;

    let test = Path::new(&data_s).join("test").display().to_string();
    let mut loc = s(&[
        "localize",
        "--model",
        &p("model"),
        "--seq",
        &test,
        "--out",
        &p("run"),
        "--candidate-zones",
        &exp.localize.candidate_zones.to_string(),
        "--neighbours",
        &exp.localize.neighbours.to_string(),
    ]);
    if exp.localize.live {
        loc.push("--live".into());
    }
    loc.extend(s(force));
    stage("localize", &loc);
    timed("localize", &mut || {
        cmd::localize::run_localize(parse(&loc)?)
    })?;

    let gt = Path::new(&test).join("poses.txt").display().to_string();
    let mut eval = s(&[
        "eval",
        "--gt",
        &gt,
        "--est",
        &p("run/trajectory.txt"),
        "--frames",
        &p("run/frames.csv"),
        "--out",
        &p("run/eval"),
    ]);
    eval.extend(s(force));
    stage("eval", &eval);
    timed("eval", &mut || cmd::eval::run(parse(&eval)?))?;

    let total: f64 = timings.iter().map(|t| t.1).sum();
    let mut csv = String::from("stage,seconds\n");
    eprintln!("\nstage       wall s");
    for (name, secs) in timings.iter().chain([&("total", total)]) {
        eprintln!("{name:<10} {secs:>7.1}");
        csv.push_str(&format!("{name},{secs:.2}\n"));
    }
    let path = exp.out.join("timings.csv");
    endoloc_eval::write_atomic(&path, csv.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn train_pairs_parse_and_a_bad_rule_is_named() {
        let exp: Experiment =
            toml::from_str("out = \"o\"\ndata = \"d\"\n[train]\npairs = \"track\"\n").unwrap();
        assert_eq!(exp.train.pairs.flag(), "track");
        let exp: Experiment = toml::from_str("out = \"o\"\ndata = \"d\"\n").unwrap();
        assert_eq!(exp.train.pairs.flag(), "zone");
        let e = toml::from_str::<Experiment>("out = \"o\"\n[train]\npairs = \"frames\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("frames") && e.contains("track"), "{e}");
    }

    #[test]
    fn train_epochs_absent_take_the_schedule_and_zero_indexes_only() {
        let parse = |t: &str| toml::from_str::<Experiment>(t).unwrap();
        let argv = parse("out = \"o\"\ndata = \"d\"\n")
            .train
            .argv("d", "o/model");
        assert!(!argv.contains(&"--epochs".to_string()), "{argv:?}");
        assert!(!argv.contains(&"--pretrained".to_string()), "{argv:?}");
        let argv = parse(
            "out = \"o\"\ndata = \"d\"\n[train]\nepochs = 0\npretrained = \"builtin-joint\"\n",
        )
        .train
        .argv("d", "o/model");
        let text = argv.join(" ");
        assert!(
            text.contains("--epochs 0") && text.contains("--pretrained builtin-joint"),
            "{text}"
        );
        // The arguments parse as `endoloc train`'s own.
        crate::cmd::demo::parse::<crate::cmd::train::Args>(&argv).unwrap();
    }
}
