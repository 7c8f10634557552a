//! `endoloc experiment compare`: every method on the same data, the paper's Table I.

use std::path::{Path, PathBuf};

use endoloc_eval::{HtmlReport, PlotConfig, plot_method_bars};
use endoloc_jobs::error::{Context, Result};
use endoloc_localize::map_io::load_map;
use endoloc_net::ZoneClassifier;
use endoloc_net::ZoneSpec;
use serde::{Deserialize, Serialize};

use super::common::{
    self, Data, DataArgs, EndolocRun, ExperimentReport, FeatureCache, MethodOutput, MethodRow,
    TrainSpec, Truth, ZoneChoice, ensure_map, ensure_model, predict_zones, run_endoloc,
    write_and_evaluate,
};
use endoloc_jobs::baselines::{self, Regressor};
use endoloc_jobs::note;
use endoloc_jobs::progress::Progress;

/// Compare every method on one dataset: our two-step method (per frame as in the paper,
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct CompareJob {
    /// Where the data is.
    #[cfg_attr(feature = "cli", command(flatten))]
    pub data: DataArgs,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, default_value_os_t = CompareJob::default().out))]
    pub out: PathBuf,
    /// Zones (a count, or `expert`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CompareJob::default().zones))]
    pub zones: ZoneSpec,
    /// Training epochs of the learned models (default: each schedule's own).
    #[cfg_attr(feature = "cli", arg(long))]
    pub epochs: Option<usize>,
    /// Seed of every training.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CompareJob::default().seed))]
    pub seed: u64,
    /// SURF threshold of the maps; test frames keep their strongest keypoints above 0.4 times
    /// it (a budget per frame, as the localize job does by default).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CompareJob::default().threshold))]
    pub threshold: f32,
    /// σ of the map's smoothed level, pixels (the map job's `smoothed_level_px`; default: 1.5
    /// per 320 pixels of image width; 0: none). The map of a given `model` is used as it is,
    /// and refused when this names another level.
    #[cfg_attr(feature = "cli", arg(long = "smoothed-level", value_name = "SIGMA_PX"))]
    pub smoothed_level_px: Option<f64>,
    /// Use this trained Siamese model (with or without a map) instead of training one.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub model: Option<PathBuf>,
    /// Methods to run (default: all). endoloc-confirm and endoloc-live-confirm are the
    /// localize job's defaults; endoloc and endoloc-live localize without confirmation.
    #[cfg_attr(feature = "cli", arg(long, value_delimiter = ','))]
    pub methods: Vec<Method>,
    /// How far the colon wall may have moved since the mapping pass, mm (the localize job's
    /// `wall_motion_mm`; 0: a rigid colon).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CompareJob::default().wall_motion_mm))]
    pub wall_motion_mm: f64,
    /// Use an output folder that holds something else.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for CompareJob {
    fn default() -> Self {
        CompareJob {
            data: Default::default(),
            out: "experiments/compare".into(),
            zones: ZoneSpec::default(),
            epochs: None,
            seed: 0,
            threshold: endoloc_localize::DEFAULT_MAP_THRESHOLD,
            smoothed_level_px: None,
            model: None,
            methods: Vec::new(),
            wall_motion_mm: 0.0,
            force: false,
        }
    }
}

/// A localization method of the comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// The paper's rule: top zone → median pose → SURF matching → Gauss-Newton.
    EndolocPaper,
    /// Ours, trying the 3 best-scoring zones until one registers; registrations not confirmed
    /// against the map (the localize job with `confirm` off).
    Endoloc,
    /// Ours live: frames in order, the causal track filter, registration from the last pose;
    /// registrations not confirmed against the map (the localize job, `live`, `confirm` off).
    EndolocLive,
    /// Ours per frame, every registration confirmed against the map, as `endoloc localize`
    /// runs by default.
    EndolocConfirm,
    /// Ours live, weak registrations confirmed against the map, as `endoloc localize --live`
    /// runs by default.
    EndolocLiveConfirm,
    /// Ours with offline Viterbi zone smoothing.
    EndolocViterbi,
    /// Ours with offline track smoothing (forward–backward over training frames and speed).
    EndolocSmooth,
    /// PoseNet: absolute pose regression.
    Posenet,
    /// OffsetNet: relative pose from the retrieved reference image.
    Offsetnet,
    /// Monocular visual odometry (first pose aligned, scale from the ground truth).
    Vo,
    /// The classified zone's median pose (the first step alone).
    Classify,
    /// The pose of the nearest training image in descriptor space.
    Retrieval,
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| {
                let names: Vec<String> = Self::ALL.iter().map(|m| m.name()).collect();
                format!("unknown method {s:?}; expected one of {}", names.join(", "))
            })
    }
}

impl Method {
    /// Every method, in the table's order.
    pub const ALL: [Method; 12] = [
        Method::EndolocPaper,
        Method::Endoloc,
        Method::EndolocLive,
        Method::EndolocConfirm,
        Method::EndolocLiveConfirm,
        Method::EndolocViterbi,
        Method::EndolocSmooth,
        Method::Posenet,
        Method::Offsetnet,
        Method::Vo,
        Method::Classify,
        Method::Retrieval,
    ];

    /// The methods run when none are named: all of them.
    fn all() -> Vec<Method> {
        Self::ALL.to_vec()
    }

    /// The method's name (folder name and table row), e.g. `endoloc-live`.
    pub fn name(self) -> String {
        match self {
            Method::EndolocPaper => "endoloc-paper",
            Method::Endoloc => "endoloc",
            Method::EndolocLive => "endoloc-live",
            Method::EndolocConfirm => "endoloc-confirm",
            Method::EndolocLiveConfirm => "endoloc-live-confirm",
            Method::EndolocViterbi => "endoloc-viterbi",
            Method::EndolocSmooth => "endoloc-smooth",
            Method::Posenet => "posenet",
            Method::Offsetnet => "offsetnet",
            Method::Vo => "vo",
            Method::Classify => "classify",
            Method::Retrieval => "retrieval",
        }
        .to_string()
    }

    fn description(self) -> &'static str {
        match self {
            Method::EndolocPaper => "two-step, top zone only (the paper's rule)",
            Method::Endoloc => "two-step, up to 3 candidate zones, unconfirmed (`confirm` off)",
            Method::EndolocLive => {
                "two-step, live: track filter, motion model, unconfirmed (`confirm` off)"
            }
            Method::EndolocConfirm => {
                "two-step, 3 candidates, registrations confirmed by the map (the default)"
            }
            Method::EndolocLiveConfirm => {
                "two-step, live, weak registrations confirmed by the map (the default)"
            }
            Method::EndolocViterbi => "two-step, offline Viterbi zones, 3 candidates",
            Method::EndolocSmooth => "two-step, offline track-smoothed zones, 3 candidates",
            Method::Posenet => "PoseNet pose regression (Kendall et al. 2015)",
            Method::Offsetnet => {
                "OffsetNet relative pose to the retrieved image (Sganga et al. 2018)"
            }
            Method::Vo => "monocular SURF visual odometry, first pose and scale from the truth",
            Method::Classify => "zone median pose (classification only)",
            Method::Retrieval => "pose of the nearest training image",
        }
    }
}

/// The configuration saved next to the results.
#[derive(Serialize)]
struct Saved<'a> {
    experiment: &'static str,
    data: String,
    train: &'a str,
    test: &'a str,
    zones: String,
    epochs: Option<usize>,
    seed: u64,
    threshold: f32,
    #[serde(skip_serializing_if = "Option::is_none")]
    smoothed_level_px: Option<f64>,
    model: String,
    methods: Vec<String>,
}

impl CompareJob {
    /// Runs the experiment.
    ///
    /// # Errors
    /// Bad inputs, a failed stage, or an output folder that holds something else.
    pub fn run(&self, progress: &dyn Progress) -> Result<ExperimentReport<MethodRow>> {
        let args = self;
        endoloc_jobs::map::check_smoothed_level(args.smoothed_level_px)?;
        common::prepare_out(&args.out, "compare.toml", args.force)?;
        let data = Data::from_args(&args.data)?;
        common::create_out(&args.out, "compare.toml")?;
        let methods = if args.methods.is_empty() {
            Method::all()
        } else {
            args.methods.clone()
        };
        let model = args
            .model
            .clone()
            .unwrap_or_else(|| args.out.join("models/siamese"));
        let saved = Saved {
            experiment: "compare",
            data: args.data.data.display().to_string(),
            train: &args.data.train,
            test: &args.data.test,
            zones: args.zones.to_string(),
            epochs: args.epochs,
            seed: args.seed,
            threshold: args.threshold,
            smoothed_level_px: args.smoothed_level_px,
            model: model.display().to_string(),
            methods: methods.iter().map(|m| m.name()).collect(),
        };
        common::write_text(
            &args.out.join("compare.toml"),
            &toml::to_string_pretty(&saved).context("serializing the configuration")?,
        )?;

        let spec = TrainSpec {
            zones: args.zones,
            epochs: args.epochs,
            seed: args.seed,
            pretrained: None,
        };
        ensure_model(&model, &data, &spec, progress)?;
        ensure_map(
            &model,
            &data,
            args.threshold,
            args.smoothed_level_px,
            &[],
            progress,
        )?;
        let classifier = ZoneClassifier::load(&model)?;
        classifier.check_compatible(&data_camera(&data)?)?;
        let truth = Truth::of(&data.dir, &data.test, &classifier)?;

        let mut ctx = Ctx {
            data: &data,
            model: &model,
            out: &args.out,
            classifier: &classifier,
            preds: None,
            features: None,
            epochs: args.epochs,
            seed: args.seed,
            wall_motion_mm: args.wall_motion_mm,
            progress,
        };
        let mut rows = Vec::new();
        for m in methods {
            let dir = args.out.join("runs").join(m.name());
            let row_file = dir.join("row.json");
            if let Some(row) = std::fs::read_to_string(&row_file)
                .ok()
                .and_then(|s| serde_json::from_str::<MethodRow>(&s).ok())
            {
                note!(progress, "reusing   {} ({})", m.name(), row_file.display());
                rows.push(row);
                continue;
            }
            note!(progress, "\n== {}: {}", m.name(), m.description());
            let output = ctx.run(m)?;
            let row = write_and_evaluate(&dir, &data.test, &output, &truth)?;
            common::write_text(&row_file, &serde_json::to_string_pretty(&row)?)?;
            print_row(&row, progress);
            rows.push(row);
        }
        let table = write_outputs(&args.out, &rows, &saved, progress)?;
        Ok(ExperimentReport {
            rows,
            table,
            out: args.out.clone(),
            files: vec!["compare.md", "compare.json", "compare.png", "report.html"],
        })
    }
}

fn data_camera(data: &Data) -> Result<endoloc_geometry::Camera> {
    Ok(endoloc_data::Dataset::open(&data.dir)?.meta.camera)
}

struct Ctx<'a> {
    data: &'a Data,
    model: &'a Path,
    out: &'a Path,
    classifier: &'a ZoneClassifier,
    preds: Option<(Vec<endoloc_net::ZonePrediction>, f64)>,
    features: Option<FeatureCache>,
    epochs: Option<usize>,
    seed: u64,
    wall_motion_mm: f64,
    progress: &'a dyn Progress,
}

impl Ctx<'_> {
    fn preds(&mut self) -> Result<&(Vec<endoloc_net::ZonePrediction>, f64)> {
        let progress = self.progress;
        if self.preds.is_none() {
            self.preds = Some(predict_zones(self.classifier, &self.data.test, progress)?);
        }
        self.preds.as_ref().context("zone predictions")
    }

    fn run(&mut self, m: Method) -> Result<MethodOutput> {
        let progress = self.progress;
        let wall_motion_mm = self.wall_motion_mm;
        let ours = |choice, candidate_zones, confirm| EndolocRun {
            choice,
            candidate_zones,
            confirm,
            wall_motion_mm,
        };
        let setting = match m {
            Method::EndolocPaper => Some(ours(ZoneChoice::PerFrame, 1, false)),
            Method::Endoloc => Some(ours(ZoneChoice::PerFrame, 3, false)),
            Method::EndolocLive => Some(ours(ZoneChoice::Live, 3, false)),
            Method::EndolocConfirm => Some(ours(ZoneChoice::PerFrame, 3, true)),
            Method::EndolocLiveConfirm => Some(ours(ZoneChoice::Live, 3, true)),
            Method::EndolocViterbi => Some(ours(ZoneChoice::Viterbi, 3, false)),
            Method::EndolocSmooth => Some(ours(ZoneChoice::Smooth, 3, false)),
            _ => None,
        };
        if let Some(setting) = setting {
            let surf = load_map(self.model)?.config.surf.clone();
            self.preds()?;
            let features = FeatureCache::get(&mut self.features, &self.data.test, &surf, progress)?;
            let (preds, zone_ms) = self.preds.as_ref().context("zone predictions")?;
            let results = run_endoloc(self.model, features, preds, *zone_ms, setting, progress)?;
            return Ok(MethodOutput::from_results(
                &m.name(),
                m.description(),
                results,
            ));
        }
        let (preds, zone_ms) = self.preds()?.clone();
        let train_poses = self.classifier.train_poses();
        let zones = &self.classifier.zones().zones;
        let simple = |poses: Vec<Option<endoloc_geometry::Pose>>| MethodOutput {
            name: m.name(),
            description: m.description().into(),
            poses,
            results: None,
            ms_per_frame: zone_ms,
        };
        match m {
            Method::Classify => Ok(simple(
                preds
                    .iter()
                    .map(|p| zones.get(p.zone).map(|z| z.median_pose))
                    .collect(),
            )),
            Method::Retrieval => Ok(simple(
                preds
                    .iter()
                    .map(|p| train_poses.get(p.nearest_frame).copied())
                    .collect(),
            )),
            Method::Posenet | Method::Offsetnet | Method::Vo => {
                let ds = endoloc_data::Dataset::open(&self.data.dir)?;
                let train = ds.sequence(&self.data.train_name)?;
                let test = &self.data.test;
                let models = self.out.join("models");
                let est = match m {
                    Method::Posenet | Method::Offsetnet => {
                        let which = if m == Method::Posenet {
                            Regressor::PoseNet
                        } else {
                            Regressor::OffsetNet
                        };
                        let dir = models.join(which.name());
                        if dir.join("regress.toml").is_file() {
                            note!(progress, "reusing   model {}", dir.display());
                        } else {
                            baselines::train_regressor(
                                which,
                                &train,
                                &ds.meta.camera,
                                &dir,
                                baselines::RegressorSettings {
                                    epochs: self.epochs,
                                    seed: self.seed,
                                    force: false,
                                },
                                progress,
                            )?;
                        }
                        if which == Regressor::PoseNet {
                            baselines::posenet(&dir, test, progress)?
                        } else {
                            baselines::offsetnet(&dir, &train, test, &preds, zone_ms, progress)?
                        }
                    }
                    _ => baselines::vo(
                        &ds.meta.camera,
                        endoloc_jobs::localize::mask_of(&ds)?,
                        test,
                        progress,
                    )?,
                };
                if let Some(note) = &est.note {
                    note!(progress, "{note}");
                    common::write_text(
                        &self.out.join("runs").join(m.name()).join("note.txt"),
                        note,
                    )?;
                }
                Ok(MethodOutput {
                    name: m.name(),
                    description: m.description().into(),
                    poses: est.poses,
                    results: None,
                    ms_per_frame: est.ms_per_frame,
                })
            }
            _ => unreachable!("our method is handled above"),
        }
    }
}

fn print_row(r: &MethodRow, progress: &dyn Progress) {
    let f = |v: Option<f64>| v.map_or("—".to_string(), |x| format!("{x:.2}"));
    note!(
        progress,
        "{:<16} mean {} mm / {}°, median {} mm / {}°, localized {:.1} %{}, {:.1} ms/frame",
        r.method,
        f(r.mean_position_mm),
        f(r.mean_orientation_deg),
        f(r.median_position_mm),
        f(r.median_orientation_deg),
        100.0 * r.localized as f64 / r.frames.max(1) as f64,
        r.refined
            .map(|k| format!(
                ", refined {:.1} %",
                100.0 * k as f64 / r.frames.max(1) as f64
            ))
            .unwrap_or_default(),
        r.ms_per_frame
    );
}

/// The best of our variants against the best learning baseline (PoseNet, OffsetNet), as
/// relative improvements of the mean errors (the paper's 28.9 % and 10.97 %).
fn margins(rows: &[MethodRow]) -> Option<String> {
    let ours = rows
        .iter()
        .filter(|r| r.method.starts_with("endoloc"))
        .filter_map(|r| Some((r, r.mean_position_mm?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?
        .0;
    let learned = rows
        .iter()
        .filter(|r| r.method == "posenet" || r.method == "offsetnet")
        .filter_map(|r| Some((r, r.mean_position_mm?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?
        .0;
    let gain = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => format!("{:.1} %", 100.0 * (b - a) / b),
        _ => "—".into(),
    };
    Some(format!(
        "Best of ours ({}) against the best learning baseline ({}): mean position error {} lower \
         (paper: 28.9 %), mean orientation error {} lower (paper: 10.97 %).",
        ours.method,
        learned.method,
        gain(ours.mean_position_mm, learned.mean_position_mm),
        gain(ours.mean_orientation_deg, learned.mean_orientation_deg)
    ))
}

fn write_outputs(
    out: &Path,
    rows: &[MethodRow],
    saved: &Saved<'_>,
    progress: &dyn Progress,
) -> Result<String> {
    let table = common::markdown_table(rows);
    let margin = margins(rows);
    let mut md = String::from("# Method comparison (the paper's Table I)\n\n");
    md.push_str(&format!(
        "Dataset `{}` ({} → {}), {} zones. Errors over the frames each method localizes \
         (for ours: `refined` and `init_only`; `rejected` frames have no pose).\n\n",
        saved.data, saved.train, saved.test, saved.zones
    ));
    md.push_str(&table);
    if let Some(m) = &margin {
        md.push_str(&format!("\n{m}\n"));
    }
    md.push_str("\n![errors by method](compare.png)\n");
    common::write_text(&out.join("compare.md"), &md)?;
    common::write_text(
        &out.join("compare.json"),
        &serde_json::to_string_pretty(rows)?,
    )?;
    let png = out.join("compare.png");
    plot_method_bars(&common::bars(rows), &png, &PlotConfig::default())?;

    let mut html = HtmlReport::new("endoloc — method comparison");
    html.push(endoloc_eval::Block::Paragraph(format!(
        "Dataset {} (train {}, test {}), {} zones, seed {}, SURF threshold {}.",
        saved.data, saved.train, saved.test, saved.zones, saved.seed, saved.threshold
    )))
    .push(common::html_table(rows));
    if let Some(m) = margin {
        html.push(endoloc_eval::Block::Paragraph(m));
    }
    if let Some(b) = common::image_block(&png, "Mean and median errors by method", progress) {
        html.push(b);
    }
    for r in rows {
        let p = out
            .join("runs")
            .join(&r.method)
            .join("eval/trajectory_xy.png");
        if p.is_file()
            && let Some(b) = common::image_block(
                &p,
                &format!("{}: trajectory, X-Y plane", r.method),
                progress,
            )
        {
            html.push(b);
        }
    }
    html.push(endoloc_eval::Block::Heading("Configuration".into()))
        .push(endoloc_eval::Block::Code(toml::to_string_pretty(saved)?));
    common::write_text(&out.join("report.html"), &html.render())?;
    Ok(table)
}
