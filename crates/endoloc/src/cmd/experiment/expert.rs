//! `endoloc experiment expert`: anatomical zones (the sections, subdivided to N) against
//! uniform zones, through the same method.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use endoloc_eval::{HtmlReport, PlotConfig, plot_method_bars};
use endoloc_localize::map_io::load_map;
use endoloc_net::ZoneClassifier;

use super::common::{
    self, Data, DataArgs, FeatureCache, MethodOutput, MethodRow, TrainSpec, ZoneChoice, ensure_map,
    ensure_model, predict_zones, run_endoloc, write_and_evaluate,
};

/// Anatomical ("expert") zones against uniform ones: train one model on the sections of
/// sections.csv subdivided to --count zones and one on --uniform equal-length zones (by
/// default the best count of a finished `experiment zones` folder given with --sweep, else
/// 50), map, localize and evaluate both with our method. Writes expert.md, expert.json,
/// expert.png and report.html.
///
/// Example:
///
///   endoloc experiment expert --data data/paper --sweep experiments/zones
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// The training sequence needs sections.csv.
    #[command(flatten)]
    data: DataArgs,
    /// Output folder.
    #[arg(long, default_value = "experiments/expert")]
    out: PathBuf,
    /// Anatomical zones in all (the sections, long ones subdivided).
    #[arg(long, default_value_t = 50)]
    count: usize,
    /// Uniform zone count to compare with.
    #[arg(long, conflicts_with = "sweep")]
    uniform: Option<usize>,
    /// Take the uniform count from a finished zone sweep (its best median).
    #[arg(long, value_name = "DIR")]
    sweep: Option<PathBuf>,
    /// Training epochs (default: the `fast` schedule's).
    #[arg(long)]
    epochs: Option<usize>,
    /// Training seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// SURF threshold of the maps; test frames are described at twice it and retried at it
    /// (as `endoloc localize` does by default; see `endoloc map --help`).
    #[arg(long, default_value_t = crate::cmd::localize::DEFAULT_MAP_THRESHOLD)]
    threshold: f64,
    /// Use an output folder that holds something else.
    #[arg(long)]
    force: bool,
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

/// Runs `endoloc experiment expert`.
pub fn run(args: Args) -> Result<()> {
    common::prepare_out(&args.out, "expert.md", args.force)?;
    let data = Data::from_args(&args.data)?;
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
            format!("expert:{}", args.count),
            format!("anatomical sections subdivided to {} zones", args.count),
        ),
        (
            format!("uniform-{uniform}"),
            uniform.to_string(),
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
                zones: zones.clone(),
                epochs: args.epochs,
                seed: args.seed,
            },
        )?;
        ensure_map(&model, &data, args.threshold, &[])?;
        let classifier = ZoneClassifier::load(&model)?;
        let surf = load_map(&model)?.config.surf.clone();
        let cache = FeatureCache::get(&mut features, &data.test, &surf)?;
        let (preds, zone_ms) = predict_zones(&classifier, &data.test)?;
        let results = run_endoloc(&model, cache, &preds, zone_ms, ZoneChoice::PerFrame, 3)?;
        let out = MethodOutput::from_results(name, description, results);
        let row = write_and_evaluate(&args.out.join("runs").join(name), &data.test, &out)?;
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
    if let Some(b) = common::image_block(&png, "Errors by zoning") {
        html.push(b);
    }
    common::write_text(&args.out.join("report.html"), &html.render())?;
    println!("\n{table}");
    println!(
        "wrote     {}/expert.md, expert.json, expert.png, report.html",
        args.out.display()
    );
    Ok(())
}
