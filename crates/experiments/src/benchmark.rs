//! `endoloc experiment benchmark`: the whole chain over several colons, so that a figure
//! says what to expect on a colon it was not tuned on.
//!
//! Each colon (a procedural seed, or a CT colon in the Gut Cell Atlas format) is one
//! independent job with its own folder `colons/<name>/`: simulate → index or train → map →
//! the methods of [`CompareJob`] → evaluate. A colon is done when its `row.json` exists; a
//! later call (or `--merge`) reads the finished folders and writes the tables: each method's
//! figures per colon and their mean ± 95 % confidence interval across colons (Student's t).

use std::path::{Path, PathBuf};

use endoloc_net::ZoneSpec;
use serde::{Deserialize, Serialize};

use super::common::{self, DataArgs, MethodRow, shell_quote};
use super::compare::{CompareJob, Method};
use endoloc_eval::{BoxColumn, HtmlReport, PlotConfig, plot_error_boxes};
use endoloc_jobs::bail;
use endoloc_jobs::error::{Context, Result};
use endoloc_jobs::note;
use endoloc_jobs::progress::Progress;
use endoloc_jobs::{SimulateJob, TrainJob};
use endoloc_sim::{Preset, Severity};

/// The chain over several colons, resumable per colon.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct BenchmarkJob {
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, default_value_os_t = BenchmarkJob::default().out))]
    pub out: PathBuf,
    /// Simulator preset of every colon (see the simulate job's `preset`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = BenchmarkJob::default().preset))]
    pub preset: Preset,
    /// Procedural colons: simulator seeds, e.g. 1-8, 1,3,5 or none.
    #[cfg_attr(feature = "cli", arg(long, default_value = "1-8", value_parser = parse_seeds))]
    pub seeds: Seeds,
    /// Development colons: seeds on which settings were chosen (the `paper` preset's is 0).
    /// Run and reported as their own rows, left out of the mean ± interval, which speaks for
    /// colons nothing was tuned on.
    #[cfg_attr(feature = "cli", arg(long, default_value = "none", value_parser = parse_seeds))]
    pub dev_seeds: Seeds,
    /// A CT colon: GCA model folder (repeatable; see the simulate job's `gca`).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub gca: Vec<PathBuf>,
    /// Lumen inflation of the CT colons (see the simulate job's `inflation`).
    #[cfg_attr(feature = "cli", arg(long))]
    pub inflation: Option<f64>,
    /// How each colon changes between its training and test pass (see the simulate job's
    /// `changes`; default `none`): the figures are then against the anatomical truth.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "SEVERITY", value_parser = endoloc_jobs::severity_parser())
    )]
    pub changes: Option<Severity>,
    /// Frames of each training pass (default: the preset's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub train_frames: Option<usize>,
    /// Frames of each test pass (default: the preset's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub test_frames: Option<usize>,
    /// Zones (a count, or `expert`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = BenchmarkJob::default().zones))]
    pub zones: ZoneSpec,
    /// Start weights of the zone network: `builtin-joint` (the shipped network, indexed
    /// without training), a weights file, or `none` (or empty) to train from scratch on each
    /// colon as in the paper.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = BenchmarkJob::default().pretrained))]
    pub pretrained: String,
    /// Training epochs (default: 0 with `pretrained`, else the schedule's own).
    #[cfg_attr(feature = "cli", arg(long))]
    pub epochs: Option<usize>,
    /// Seed of every training.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = BenchmarkJob::default().seed))]
    pub seed: u64,
    /// σ of each map's smoothed level, pixels (the map job's `smoothed_level_px`; default: 1.5
    /// per 320 pixels of image width; 0: none).
    #[cfg_attr(feature = "cli", arg(long = "smoothed-level", value_name = "SIGMA_PX"))]
    pub smoothed_level_px: Option<f64>,
    /// Zoom-blurred views of every training frame in each zone index (the train job's
    /// `index_zoom_blur`, e.g. 0.03,0.06,0.12; default: none). A colon's model made earlier is
    /// used only when it has them.
    #[cfg_attr(feature = "cli", arg(long, value_name = "A,..|none"))]
    pub index_zoom_blur: Option<String>,
    /// With `index_zoom_blur`: the train job's `index_view_penalty` (default 0).
    #[cfg_attr(feature = "cli", arg(long, value_name = "D"))]
    pub index_view_penalty: Option<f64>,
    /// Methods (default: endoloc-paper, endoloc, endoloc-confirm, endoloc-live,
    /// endoloc-live-confirm, classify; see the compare experiment).
    #[cfg_attr(feature = "cli", arg(long, value_delimiter = ','))]
    pub methods: Vec<Method>,
    /// Run only this colon (`seed-N`, `dev-seed-N` or `ct-<folder>`, as printed with
    /// `print_jobs`); the tables are not written.
    #[cfg_attr(feature = "cli", arg(long))]
    pub colon: Option<String>,
    /// Print one command per colon (for GNU parallel or a Slurm array) and the merge command,
    /// and stop.
    #[cfg_attr(feature = "cli", arg(long))]
    pub print_jobs: bool,
    /// Run nothing: write the tables from the colons already finished.
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "colon"))]
    pub merge: bool,
    /// Use an output folder that holds something else.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

/// Simulator seeds (a type of its own so that the command line parses the whole list, e.g.
/// `1-8`, as one value).
pub type Seeds = Vec<u64>;

impl Default for BenchmarkJob {
    fn default() -> Self {
        BenchmarkJob {
            out: "experiments/benchmark".into(),
            preset: Preset::Paper,
            seeds: (1..=8).collect(),
            dev_seeds: Vec::new(),
            gca: Vec::new(),
            inflation: None,
            changes: None,
            train_frames: None,
            test_frames: None,
            zones: ZoneSpec::default(),
            pretrained: "builtin-joint".into(),
            epochs: None,
            seed: 0,
            smoothed_level_px: None,
            index_zoom_blur: None,
            index_view_penalty: None,
            methods: Vec::new(),
            colon: None,
            print_jobs: false,
            merge: false,
            force: false,
        }
    }
}

/// One colon of the benchmark.
#[derive(Debug, Clone, PartialEq)]
pub struct Colon {
    /// Folder name: `seed-N`, `dev-seed-N` or `ct-<model folder>`.
    pub name: String,
    pub(super) seed: u64,
    pub(super) gca: Option<PathBuf>,
    pub(super) development: bool,
}

/// One colon's figures: every method's row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColonRow {
    /// The colon's name.
    pub colon: String,
    /// What it is (`procedural, seed 3`, `CT colon EdinGCA_…`).
    pub kind: String,
    /// A development colon (settings were chosen on it): reported, not in the summary.
    #[serde(default)]
    pub development: bool,
    /// One row per method.
    pub methods: Vec<MethodRow>,
}

/// Mean and 95 % confidence half-width of one figure across colons.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Mean over the colons.
    pub mean: f64,
    /// Half-width of the 95 % confidence interval of the mean (Student's t, n − 1 degrees of
    /// freedom); 0 for one colon.
    pub half_width: f64,
    /// Colons with the figure.
    pub colons: usize,
}

/// One method's figures across colons.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MethodSummary {
    /// Method name.
    pub method: String,
    /// Localized fraction of the test frames, %.
    pub localized_pct: Option<Interval>,
    /// Refined fraction, % (ours).
    pub refined_pct: Option<Interval>,
    /// Mean position error, mm.
    pub mean_position_mm: Option<Interval>,
    /// Median position error, mm.
    pub median_position_mm: Option<Interval>,
    /// Mean orientation error, degrees.
    pub mean_orientation_deg: Option<Interval>,
    /// Median orientation error, degrees.
    pub median_orientation_deg: Option<Interval>,
}

/// What `BenchmarkJob` wrote.
#[derive(Debug, Clone)]
pub struct BenchmarkReport {
    /// Finished colons.
    pub colons: Vec<ColonRow>,
    /// Per method, across colons.
    pub summary: Vec<MethodSummary>,
    /// Colons not finished yet.
    pub missing: Vec<String>,
    /// The summary as a markdown table.
    pub table: String,
    /// The output folder.
    pub out: PathBuf,
    /// Commands printed with `print_jobs`.
    pub jobs: Vec<String>,
}

impl std::fmt::Display for BenchmarkReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if !self.jobs.is_empty() {
            return write!(f, "{}", self.jobs.join("\n"));
        }
        if !self.table.is_empty() {
            writeln!(f, "\n{}", self.table.trim_end())?;
        }
        if !self.missing.is_empty() {
            writeln!(f, "not finished: {}", self.missing.join(", "))?;
        }
        write!(
            f,
            "wrote     {}/benchmark.md, benchmark.json, benchmark.png, report.html",
            self.out.display()
        )
    }
}

/// Parses a seed list: `1,2,5`, a range `1-8`, a mix (`0,3-5`), or `none`.
///
/// # Errors
/// A message naming the part that is not a seed or a range.
pub fn parse_seeds(s: &str) -> std::result::Result<Vec<u64>, String> {
    if s.trim() == "none" || s.trim().is_empty() {
        return Ok(Vec::new());
    }
    let mut v = Vec::new();
    for part in s.split(',').map(str::trim) {
        let num = |x: &str| {
            x.trim().parse::<u64>().map_err(|_| {
                format!("{part:?} is not a seed or a range of seeds (e.g. 1-8); expected e.g. 1,2,5 or 1-8 or none")
            })
        };
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (num(a)?, num(b)?);
                if b < a {
                    return Err(format!("{part:?}: the range ends before it starts"));
                }
                v.extend(a..=b);
            }
            None => v.push(num(part)?),
        }
    }
    Ok(v)
}

/// Two-sided 95 % quantile of Student's t with `df` degrees of freedom (tables; above 30 the
/// next smaller tabulated value, which errs on the wide side).
pub fn t95(df: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::NAN,
        1..=30 => T[df - 1],
        31..=40 => 2.042,
        41..=60 => 2.021,
        61..=120 => 2.000,
        _ => 1.980,
    }
}

/// Mean and 95 % confidence half-width of `values` (`None` when empty).
pub fn interval(values: &[f64]) -> Option<Interval> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let half_width = if n < 2 {
        0.0
    } else {
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        t95(n - 1) * (var / n as f64).sqrt()
    };
    Some(Interval {
        mean,
        half_width,
        colons: n,
    })
}

const DEFAULT_METHODS: [Method; 6] = [
    Method::EndolocPaper,
    Method::Endoloc,
    Method::EndolocConfirm,
    Method::EndolocLive,
    Method::EndolocLiveConfirm,
    Method::Classify,
];

impl BenchmarkJob {
    /// The zone indexes' views this experiment asks for.
    fn index_views(&self) -> common::IndexViews<'_> {
        common::IndexViews {
            zoom_blur: self.index_zoom_blur.as_deref(),
            penalty: self.index_view_penalty,
        }
    }

    /// The start weights of the zone network; `None` (`pretrained` empty or `none`): the
    /// paper's training from scratch.
    fn pretrained_weights(&self) -> Option<PathBuf> {
        let p = self.pretrained.trim();
        (!p.is_empty() && p != "none").then(|| PathBuf::from(p))
    }

    /// Every colon of the benchmark, in order: seeds, CT colons, then development seeds.
    pub fn colons(&self) -> Vec<Colon> {
        let mut v: Vec<Colon> = self
            .seeds
            .iter()
            .map(|&s| Colon {
                name: format!("seed-{s}"),
                seed: s,
                gca: None,
                development: false,
            })
            .collect();
        for g in &self.gca {
            let stem = g
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "ct".into());
            v.push(Colon {
                name: format!("ct-{stem}"),
                seed: 0,
                gca: Some(g.clone()),
                development: false,
            });
        }
        v.extend(self.dev_seeds.iter().map(|&s| Colon {
            name: format!("dev-seed-{s}"),
            seed: s,
            gca: None,
            development: true,
        }));
        v
    }

    fn methods(&self) -> Vec<Method> {
        if self.methods.is_empty() {
            DEFAULT_METHODS.to_vec()
        } else {
            self.methods.clone()
        }
    }

    /// The command line that runs one colon (or, with `None`, merges the finished ones).
    pub fn command(&self, colon: Option<&str>) -> String {
        let q = |p: &Path| shell_quote(&p.display().to_string());
        let mut c = format!(
            "endoloc experiment benchmark --out {} --preset {} --zones {} --seed {}",
            q(&self.out),
            self.preset,
            self.zones,
            self.seed
        );
        c.push_str(&colon_options(
            &self.seeds,
            &self.gca,
            self.inflation,
            self.train_frames,
            self.test_frames,
        ));
        if !self.dev_seeds.is_empty() {
            let s: Vec<String> = self.dev_seeds.iter().map(u64::to_string).collect();
            c.push_str(&format!(" --dev-seeds {}", s.join(",")));
        }
        if let Some(s) = self.changes {
            c.push_str(&format!(" --changes {}", s.name()));
        }
        c.push_str(&format!(" --pretrained {}", shell_quote(&self.pretrained)));
        if let Some(s) = self.smoothed_level_px {
            c.push_str(&format!(" --smoothed-level {s}"));
        }
        c.push_str(&self.index_views().options());
        if let Some(e) = self.epochs {
            c.push_str(&format!(" --epochs {e}"));
        }
        if !self.methods.is_empty() {
            let m: Vec<String> = self.methods.iter().map(|m| m.name()).collect();
            c.push_str(&format!(" --methods {}", m.join(",")));
        }
        match colon {
            Some(name) => c.push_str(&format!(" --colon {}", shell_quote(name))),
            None => c.push_str(" --merge"),
        }
        c
    }

    /// Runs the benchmark (or one colon of it, or only the merge).
    ///
    /// # Errors
    /// A failed stage of a colon, an unknown `colon`, or an output folder that holds
    /// something else.
    pub fn run(&self, progress: &dyn Progress) -> Result<BenchmarkReport> {
        let colons = self.colons();
        if colons.is_empty() {
            bail!("no colons: give `seeds` and/or `gca`");
        }
        if let Some(s) = self.dev_seeds.iter().find(|s| self.seeds.contains(s)) {
            bail!(
                "seed {s} is in both `seeds` and `dev_seeds`; a development colon cannot also \
                 speak for unseen ones"
            );
        }
        endoloc_jobs::map::check_smoothed_level(self.smoothed_level_px)?;
        self.index_views().parsed()?;
        if self.print_jobs {
            return Ok(BenchmarkReport {
                colons: Vec::new(),
                summary: Vec::new(),
                missing: Vec::new(),
                table: String::new(),
                out: self.out.clone(),
                jobs: job_lines(&colons, &|c| self.command(c)),
            });
        }
        let selected = select_colons(&colons, self.colon.as_deref(), self.merge, "benchmark")?;
        // A colon's model made earlier (and its figures) is used as it is.
        self.index_views().check_models(
            selected
                .iter()
                .map(|c| self.out.join("colons").join(&c.name).join("model")),
        )?;
        common::prepare_out(&self.out, "benchmark.toml", self.force)?;
        common::create_out(&self.out, "benchmark.toml")?;
        common::write_text(
            &self.out.join("benchmark.toml"),
            &toml::to_string_pretty(&self.saved()).context("serializing the configuration")?,
        )?;
        for (k, c) in selected.iter().enumerate() {
            if row_path(&self.out, &c.name).is_file() {
                note!(progress, "reusing   {} (done)", c.name);
                continue;
            }
            note!(
                progress,
                "\n=== colon {} ({} of {})",
                c.name,
                k + 1,
                selected.len()
            );
            self.run_colon(c, progress)?;
        }
        let (rows, missing) = self.finished(&colons)?;
        if self.colon.is_some() {
            return Ok(BenchmarkReport {
                colons: rows,
                summary: Vec::new(),
                missing,
                table: String::new(),
                out: self.out.clone(),
                jobs: Vec::new(),
            });
        }
        if rows.is_empty() {
            bail!(
                "no colon of {} is finished; run the colons first (see `print_jobs`)",
                self.out.display()
            );
        }
        let unseen: Vec<ColonRow> = rows.iter().filter(|r| !r.development).cloned().collect();
        let summary = summarise(&unseen, &self.methods());
        let table = self.write_outputs(&rows, &summary, &missing, progress)?;
        Ok(BenchmarkReport {
            colons: rows,
            summary,
            missing,
            table,
            out: self.out.clone(),
            jobs: Vec::new(),
        })
    }

    fn saved(&self) -> BenchmarkJob {
        BenchmarkJob {
            colon: None,
            print_jobs: false,
            merge: false,
            force: false,
            ..self.clone()
        }
    }

    fn run_colon(&self, c: &Colon, progress: &dyn Progress) -> Result<()> {
        let dir = self.out.join("colons").join(&c.name);
        let data = dir.join("data");
        if !data.join("dataset.toml").is_file() {
            note!(progress, "simulating {}", c.name);
            let sim = SimulateJob {
                preset: self.preset,
                seed: Some(c.seed),
                gca: c.gca.clone(),
                inflation: c.gca.as_ref().and(self.inflation),
                changes: self.changes,
                train_frames: self.train_frames,
                test_frames: self.test_frames,
                out: data.clone(),
                force: data.exists(),
                ..Default::default()
            };
            let report = sim.run(progress)?;
            note!(progress, "{report}");
        }
        let model = dir.join("model");
        if !model.join("model.toml").is_file() {
            let pretrained = self.pretrained_weights();
            let train = self.index_views().apply(TrainJob {
                data: data.clone(),
                zones: self.zones,
                out: model.clone(),
                force: model.exists(),
                epochs: self.epochs.or(pretrained.as_ref().map(|_| 0)),
                pretrained,
                seed: self.seed,
                ..Default::default()
            });
            note!(progress, "zone network for {}", c.name);
            let report = train.run(progress)?;
            note!(progress, "{report}");
        }
        let compare = CompareJob {
            data: DataArgs {
                data: data.clone(),
                ..Default::default()
            },
            out: dir.join("compare"),
            zones: self.zones,
            epochs: self.epochs,
            seed: self.seed,
            model: Some(model),
            methods: self.methods(),
            smoothed_level_px: self.smoothed_level_px,
            ..Default::default()
        };
        let report = compare.run(progress)?;
        let kind = match &c.gca {
            Some(g) => format!("CT colon {}", g.display()),
            None if c.development => format!(
                "development colon: procedural, `{}` preset, seed {} (settings were chosen on it)",
                self.preset, c.seed
            ),
            None => format!("procedural, `{}` preset, seed {}", self.preset, c.seed),
        };
        let row = ColonRow {
            colon: c.name.clone(),
            kind,
            development: c.development,
            methods: report.rows,
        };
        common::write_text(
            &row_path(&self.out, &c.name),
            &serde_json::to_string_pretty(&row)?,
        )?;
        Ok(())
    }

    /// The rows of the finished colons, and the names of the others.
    fn finished(&self, colons: &[Colon]) -> Result<(Vec<ColonRow>, Vec<String>)> {
        let mut rows = Vec::new();
        let mut missing = Vec::new();
        for c in colons {
            let p = row_path(&self.out, &c.name);
            match std::fs::read_to_string(&p) {
                Ok(text) => rows.push(
                    serde_json::from_str::<ColonRow>(&text)
                        .with_context(|| format!("reading {}", p.display()))?,
                ),
                Err(_) => missing.push(c.name.clone()),
            }
        }
        Ok((rows, missing))
    }

    fn write_outputs(
        &self,
        rows: &[ColonRow],
        summary: &[MethodSummary],
        missing: &[String],
        progress: &dyn Progress,
    ) -> Result<String> {
        let (dev, unseen): (Vec<&ColonRow>, Vec<&ColonRow>) =
            rows.iter().partition(|r| r.development);
        let unseen: Vec<ColonRow> = unseen.into_iter().cloned().collect();
        let table = summary_table(summary);
        let mut md = String::from("# Benchmark across colons\n\n");
        md.push_str(&format!(
            "{} colons ({}), `{}` preset{}, {} zones, zone network {}. Each figure is the mean over \
             the colons ± the half-width of its 95 % confidence interval (Student's t); errors are \
             over the frames each method localizes.{}\n\n",
            unseen.len(),
            unseen
                .iter()
                .map(|r| r.colon.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            self.preset,
            frames_note(self.train_frames, self.test_frames),
            self.zones,
            if self.pretrained_weights().is_none() {
                "trained on each colon".to_string()
            } else {
                format!("`{}` indexed without training", self.pretrained)
            },
            match self.changes {
                Some(s) if s != Severity::None => format!(
                    " Each test pass goes through its colon changed `{}` (simulate --changes); \
                     errors are against the anatomical truth.",
                    s.name()
                ),
                _ => String::new(),
            }
        ));
        md.push_str(&table);
        if !dev.is_empty() {
            md.push_str(&format!(
                "\nDevelopment colon{} (settings were chosen on {}; not in the figures above):\n\n",
                if dev.len() > 1 { "s" } else { "" },
                if dev.len() > 1 { "them" } else { "it" }
            ));
            let dev: Vec<ColonRow> = dev.iter().map(|r| (*r).clone()).collect();
            md.push_str(&colon_table(&dev));
        }
        if !missing.is_empty() {
            md.push_str(&format!("\nNot finished: {}.\n", missing.join(", ")));
        }
        md.push_str("\n## Per colon\n\n");
        md.push_str(&colon_table(&unseen));
        md.push_str("\n![mean errors of each colon, by method](benchmark.png)\n\nReproduce: `");
        md.push_str(&self.command(None).replace(" --merge", ""));
        md.push_str("`\n");
        common::write_text(&self.out.join("benchmark.md"), &md)?;
        #[derive(Serialize)]
        struct Json<'a> {
            config: BenchmarkJob,
            summary: &'a [MethodSummary],
            colons: &'a [ColonRow],
            missing: &'a [String],
        }
        common::write_text(
            &self.out.join("benchmark.json"),
            &serde_json::to_string_pretty(&Json {
                config: self.saved(),
                summary,
                colons: rows,
                missing,
            })?,
        )?;
        let png = self.out.join("benchmark.png");
        let methods = self.methods();
        let columns: Vec<BoxColumn> = methods
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let name = m.name();
                BoxColumn {
                    x: (k + 1) as f64,
                    position_mm: per_colon(&unseen, &name, &|r| r.mean_position_mm),
                    orientation_deg: per_colon(&unseen, &name, &|r| r.mean_orientation_deg),
                }
            })
            .collect();
        let legend: Vec<String> = methods
            .iter()
            .enumerate()
            .map(|(k, m)| format!("{} = {}", k + 1, m.name()))
            .collect();
        plot_error_boxes(
            &columns,
            &format!("method ({})", legend.join(", ")),
            &png,
            &PlotConfig::default(),
        )?;
        let mut html = HtmlReport::new("endoloc — benchmark across colons");
        html.push(endoloc_eval::Block::Paragraph(format!(
            "{} colons; mean ± 95 % confidence half-width across colons{}.",
            unseen.len(),
            if dev.is_empty() {
                String::new()
            } else {
                format!(
                    " (development colon{} {} not included)",
                    if dev.len() > 1 { "s" } else { "" },
                    dev.iter()
                        .map(|r| r.colon.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        )))
        .push(endoloc_eval::Block::Table {
            header: SUMMARY_HEADER.iter().map(|s| s.to_string()).collect(),
            rows: summary.iter().map(summary_cells).collect(),
        });
        if let Some(b) = common::image_block(
            &png,
            &format!(
                "Mean errors of each colon, by method ({})",
                legend.join(", ")
            ),
            progress,
        ) {
            html.push(b);
        }
        html.push(endoloc_eval::Block::Heading("Configuration".into()))
            .push(endoloc_eval::Block::Code(toml::to_string_pretty(
                &self.saved(),
            )?));
        common::write_text(&self.out.join("report.html"), &html.render())?;
        Ok(table)
    }
}

/// The lines `print_jobs` prints: one command per colon, then the merge command.
pub(super) fn job_lines(colons: &[Colon], command: &dyn Fn(Option<&str>) -> String) -> Vec<String> {
    let mut jobs: Vec<String> = colons.iter().map(|c| command(Some(&c.name))).collect();
    jobs.push(format!("# when every colon is done: {}", command(None)));
    jobs
}

/// The colons a run works on: the one named by `colon`, none for a merge, else all; `what`
/// names the run in the error (`benchmark`, `study`).
///
/// # Errors
/// A `colon` that is not one of `colons`.
pub(super) fn select_colons<'a>(
    colons: &'a [Colon],
    colon: Option<&str>,
    merge: bool,
    what: &str,
) -> Result<Vec<&'a Colon>> {
    Ok(match colon {
        Some(name) => {
            let c = colons.iter().find(|c| c.name == name).with_context(|| {
                let names: Vec<&str> = colons.iter().map(|c| c.name.as_str()).collect();
                format!(
                    "`colon` {name}: not a colon of this {what}; expected one of {}",
                    names.join(", ")
                )
            })?;
            vec![c]
        }
        None if merge => Vec::new(),
        None => colons.iter().collect(),
    })
}

/// The command-line options that name the colons and their passes (`seeds`, `gca`,
/// `inflation`, `train_frames`, `test_frames`), each with a leading space.
pub(super) fn colon_options(
    seeds: &[u64],
    gca: &[PathBuf],
    inflation: Option<f64>,
    train_frames: Option<usize>,
    test_frames: Option<usize>,
) -> String {
    let mut c = String::new();
    if seeds.is_empty() {
        c.push_str(" --seeds none");
    } else {
        let s: Vec<String> = seeds.iter().map(u64::to_string).collect();
        c.push_str(&format!(" --seeds {}", s.join(",")));
    }
    for g in gca {
        c.push_str(&format!(" --gca {}", shell_quote(&g.display().to_string())));
    }
    if let Some(i) = inflation {
        c.push_str(&format!(" --inflation {i}"));
    }
    if let Some(n) = train_frames {
        c.push_str(&format!(" --train-frames {n}"));
    }
    if let Some(n) = test_frames {
        c.push_str(&format!(" --test-frames {n}"));
    }
    c
}

fn frames_note(train: Option<usize>, test: Option<usize>) -> String {
    match (train, test) {
        (None, None) => String::new(),
        (a, b) => format!(
            " ({} training, {} test frames per colon)",
            a.map_or("preset's".into(), |n| n.to_string()),
            b.map_or("preset's".into(), |n| n.to_string())
        ),
    }
}

fn row_path(out: &Path, colon: &str) -> PathBuf {
    out.join("colons").join(colon).join("row.json")
}

/// One figure of method `name` in every colon that has it.
fn per_colon(rows: &[ColonRow], name: &str, f: &dyn Fn(&MethodRow) -> Option<f64>) -> Vec<f64> {
    rows.iter()
        .filter_map(|r| r.methods.iter().find(|x| x.method == name))
        .filter_map(f)
        .collect()
}

/// Each method's figures across the colons that ran it.
pub fn summarise(rows: &[ColonRow], methods: &[Method]) -> Vec<MethodSummary> {
    methods
        .iter()
        .map(|m| {
            let name = m.name();
            let of = |f: &dyn Fn(&MethodRow) -> Option<f64>| interval(&per_colon(rows, &name, f));
            let pct = |part: usize, whole: usize| 100.0 * part as f64 / whole.max(1) as f64;
            MethodSummary {
                method: name.clone(),
                localized_pct: of(&|r| Some(pct(r.localized, r.frames))),
                refined_pct: of(&|r| r.refined.map(|k| pct(k, r.frames))),
                mean_position_mm: of(&|r| r.mean_position_mm),
                median_position_mm: of(&|r| r.median_position_mm),
                mean_orientation_deg: of(&|r| r.mean_orientation_deg),
                median_orientation_deg: of(&|r| r.median_orientation_deg),
            }
        })
        .collect()
}

const SUMMARY_HEADER: [&str; 7] = [
    "method",
    "localized %",
    "refined %",
    "mean pos. mm",
    "median pos. mm",
    "mean orient. °",
    "median orient. °",
];

/// `mean ± half-width`; a figure from one colon has no interval and is shown alone.
fn pm(i: Option<Interval>, digits: usize) -> String {
    match i {
        None => "—".into(),
        Some(i) if i.colons < 2 => format!("{:.digits$}", i.mean),
        Some(i) => format!("{:.digits$} ± {:.digits$}", i.mean, i.half_width),
    }
}

fn summary_cells(s: &MethodSummary) -> Vec<String> {
    vec![
        s.method.clone(),
        pm(s.localized_pct, 1),
        pm(s.refined_pct, 1),
        pm(s.mean_position_mm, 2),
        pm(s.median_position_mm, 2),
        pm(s.mean_orientation_deg, 2),
        pm(s.median_orientation_deg, 2),
    ]
}

fn summary_table(summary: &[MethodSummary]) -> String {
    let mut s = format!("| {} |\n", SUMMARY_HEADER.join(" | "));
    s.push_str(&format!("|{}\n", "---|".repeat(SUMMARY_HEADER.len())));
    for m in summary {
        s.push_str(&format!("| {} |\n", summary_cells(m).join(" | ")));
    }
    s
}

fn colon_table(rows: &[ColonRow]) -> String {
    let mut s = String::from(
        "| colon | method | localized % | refined % | mean pos. mm | median pos. mm | mean orient. ° | median orient. ° |\n|---|---|---|---|---|---|---|---|\n",
    );
    let o = |v: Option<f64>| v.map_or("—".into(), |x| format!("{x:.2}"));
    for r in rows {
        for m in &r.methods {
            let pct = |k: usize| format!("{:.1}", 100.0 * k as f64 / m.frames.max(1) as f64);
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.colon,
                m.method,
                pct(m.localized),
                m.refined.map_or("—".into(), pct),
                o(m.mean_position_mm),
                o(m.median_position_mm),
                o(m.mean_orientation_deg),
                o(m.median_orientation_deg)
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confidence_interval_uses_students_t() {
        // 4 values: mean 2.5, sample sd sqrt(5/3), t(3) = 3.182.
        let i = interval(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert!((i.mean - 2.5).abs() < 1e-12);
        let want = 3.182 * (5.0f64 / 3.0 / 4.0).sqrt();
        assert!((i.half_width - want).abs() < 1e-9, "{}", i.half_width);
        assert_eq!(interval(&[7.0]).unwrap().half_width, 0.0);
        assert!(interval(&[]).is_none());
        assert!(t95(8) > t95(30) && t95(30) > t95(1000));
    }

    #[test]
    fn every_colon_is_one_command_and_the_merge_is_the_last() {
        let job = BenchmarkJob {
            out: "exp/bench mark".into(),
            seeds: vec![1, 2],
            dev_seeds: vec![0],
            gca: vec!["../shared/data/gca-edin-00090".into()],
            inflation: Some(1.5),
            changes: Some(Severity::Moderate),
            test_frames: Some(650),
            ..Default::default()
        };
        let names: Vec<String> = job.colons().into_iter().map(|c| c.name).collect();
        assert_eq!(
            names,
            ["seed-1", "seed-2", "ct-gca-edin-00090", "dev-seed-0"]
        );
        let c = job.command(Some("seed-2"));
        assert!(
            c.starts_with("endoloc experiment benchmark --out 'exp/bench mark'"),
            "{c}"
        );
        for option in [
            "--seeds 1,2",
            "--dev-seeds 0",
            "--gca ../shared/data/gca-edin-00090",
            "--inflation 1.5",
            "--changes moderate",
            "--test-frames 650",
        ] {
            assert!(c.contains(option), "{option}: {c}");
        }
        assert!(c.ends_with("--colon seed-2"), "{c}");
        assert!(job.command(None).ends_with("--merge"));
    }

    #[test]
    fn seed_lists_and_ranges() {
        assert_eq!(parse_seeds("1-3,7").unwrap(), [1, 2, 3, 7]);
        assert_eq!(parse_seeds("none").unwrap(), Vec::<u64>::new());
        assert!(parse_seeds("3-1").unwrap_err().contains("ends before"));
        assert!(parse_seeds("1,x").unwrap_err().contains("\"x\""));
    }
}
