//! `endoloc experiment expert`: anatomical zones (the sections, subdivided to N) against
//! uniform zones, through the same method.

use std::path::PathBuf;

use endoloc_eval::{HtmlReport, PlotConfig, plot_method_bars};
use endoloc_jobs::bail;
use endoloc_jobs::error::{Context, Result};
use endoloc_localize::map_io::load_map;
use endoloc_net::{ZoneClassifier, ZoneSpec};

use serde::{Deserialize, Serialize};

use super::common::{
    self, Data, DataArgs, EndolocRun, ExperimentReport, FeatureCache, MethodOutput, MethodRow,
    TrainSpec, Truth, ZoneChoice, ensure_map, ensure_model, predict_zones, run_endoloc,
    write_and_evaluate,
};
use endoloc_jobs::progress::Progress;

/// Anatomical ("expert") zones against uniform ones: train one model on the sections of
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ExpertJob {
    /// Where the data is (the training sequence needs sections.csv).
    #[cfg_attr(feature = "cli", command(flatten))]
    pub data: DataArgs,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, default_value_os_t = ExpertJob::default().out))]
    pub out: PathBuf,
    /// Anatomical zones in all (the sections, long ones subdivided).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ExpertJob::default().count))]
    pub count: usize,
    /// Uniform zone count to compare with.
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "sweep"))]
    pub uniform: Option<usize>,
    /// Take the uniform count from a finished zone sweep (its best median).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub sweep: Option<PathBuf>,
    /// Training epochs (default: the `fast` schedule's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub epochs: Option<usize>,
    /// Training seed.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ExpertJob::default().seed))]
    pub seed: u64,
    /// SURF threshold of the maps; test frames keep their strongest keypoints above 0.4 times
    /// it (a budget per frame, as the localize job does by default).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ExpertJob::default().threshold))]
    pub threshold: f32,
    /// Use an output folder that holds something else.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for ExpertJob {
    fn default() -> Self {
        ExpertJob {
            data: Default::default(),
            out: "experiments/expert".into(),
            count: 50,
            uniform: None,
            sweep: None,
            epochs: None,
            seed: 0,
            threshold: endoloc_localize::DEFAULT_MAP_THRESHOLD,
            force: false,
        }
    }
}

/// The best zone count of a sweep folder's results.csv (lowest median of run means).
fn best_of_sweep(dir: &std::path::Path) -> Result<usize> {
    let path = dir.join("results.csv");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut by: std::collections::BTreeMap<usize, Vec<f64>> = Default::default();
    for (i, line) in text.lines().enumerate().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let parsed = (|| {
            Some((
                v.first()?.parse::<usize>().ok()?,
                v.get(6)?.parse::<f64>().ok()?,
            ))
        })();
        let Some((n, e)) = parsed else {
            bail!(
                "{} line {}: expected `zones,run,…,mean_position_mm,…`",
                path.display(),
                i + 1
            );
        };
        by.entry(n).or_default().push(e);
    }
    by.into_iter()
        .filter_map(|(n, mut v)| {
            v.retain(|x| x.is_finite());
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).map(|&m| (n, m))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|x| x.0)
        .with_context(|| format!("{} has no finished run", path.display()))
}

impl ExpertJob {
    /// Runs the experiment.
    ///
    /// # Errors
    /// Bad inputs, a failed stage, or an output folder that holds something else.
    pub fn run(&self, progress: &dyn Progress) -> Result<ExperimentReport<MethodRow>> {
        let args = self;
        common::prepare_out(&args.out, "expert.md", args.force)?;
        let data = Data::from_args(&args.data)?;
        common::create_out(&args.out, "expert.md")?;
        if data.test.is_empty() {
            bail!("empty test sequence");
        }
        let uniform = match (&args.sweep, args.uniform) {
            (Some(d), _) => best_of_sweep(d)?,
            (None, Some(n)) => n,
            (None, None) => 50,
        };
        let variants = [
            (
                format!("expert-{}", args.count),
                ZoneSpec::Expert(Some(args.count)),
                format!("anatomical sections subdivided to {} zones", args.count),
            ),
            (
                format!("uniform-{uniform}"),
                ZoneSpec::Uniform(uniform),
                format!("{uniform} zones of equal arc length"),
            ),
        ];
        let mut features: Option<FeatureCache> = None;
        let mut rows: Vec<MethodRow> = Vec::new();
        for (name, zones, description) in &variants {
            let model = args.out.join("models").join(name);
            ensure_model(
                &model,
                &data,
                &TrainSpec {
                    zones: *zones,
                    epochs: args.epochs,
                    seed: args.seed,
                    pretrained: None,
                },
                progress,
            )?;
            ensure_map(&model, &data, args.threshold, None, &[], progress)?;
            let classifier = ZoneClassifier::load(&model)?;
            let surf = load_map(&model)?.config.surf.clone();
            let cache = FeatureCache::get(&mut features, &data.test, &surf, progress)?;
            let (preds, zone_ms) = predict_zones(&classifier, &data.test, progress)?;
            let results = run_endoloc(
                &model,
                cache,
                &preds,
                zone_ms,
                EndolocRun {
                    choice: ZoneChoice::PerFrame,
                    candidate_zones: 3,
                    confirm: false,
                    wall_motion_mm: 0.0,
                },
                progress,
            )?;
            let out = MethodOutput::from_results(name, description, results);
            let row = write_and_evaluate(
                &args.out.join("runs").join(name),
                &data.test,
                &out,
                &Truth::default(),
            )?;
            rows.push(row);
        }
        let table = common::markdown_table(&rows);
        let md = format!(
            "# Anatomical against uniform zones\n\nDataset `{}`, our method with 3 candidate zones.\n\n{table}\n![errors](expert.png)\n",
            args.data.data.display()
        );
        common::write_text(&args.out.join("expert.md"), &md)?;
        common::write_text(
            &args.out.join("expert.json"),
            &serde_json::to_string_pretty(&rows)?,
        )?;
        let png = args.out.join("expert.png");
        plot_method_bars(&common::bars(&rows), &png, &PlotConfig::default())?;
        let mut html = HtmlReport::new("endoloc — anatomical against uniform zones");
        html.push(endoloc_eval::Block::Paragraph(format!(
            "Dataset {}; both models trained with seed {}.",
            args.data.data.display(),
            args.seed
        )))
        .push(common::html_table(&rows));
        if let Some(b) = common::image_block(&png, "Errors by zoning", progress) {
            html.push(b);
        }
        common::write_text(&args.out.join("report.html"), &html.render())?;
        Ok(ExperimentReport {
            rows,
            table,
            out: args.out.clone(),
            files: vec!["expert.md", "expert.json", "expert.png", "report.html"],
        })
    }
}
