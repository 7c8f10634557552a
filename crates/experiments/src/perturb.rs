//! `endoloc experiment perturb`: force the zone of every test frame to `k + e`, `k` its true
//! zone, and measure the error against `e` (the paper's Fig. 7): how wrong may the
//! classifier be before the refinement stops recovering?

use std::path::PathBuf;

use endoloc_eval::stats::mean_median;
use endoloc_eval::{CurvePoint, HtmlReport, PlotConfig, plot_error_curve};
use endoloc_geometry::Status;
use endoloc_jobs::error::{Context, Result};
use endoloc_localize::map_io::load_map;
use endoloc_localize::{Localizer, LocalizerConfig, StageTimes};
use endoloc_net::ZoneClassifier;
use endoloc_net::ZoneSpec;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::common::{
    self, Data, DataArgs, ExperimentReport, FeatureCache, TrainSpec, ensure_map, ensure_model,
    pose_error,
};
use endoloc_jobs::progress::{Progress, bar};

/// Force the zone of each test frame to k ± e (k: its true zone, from the ground-truth pose)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct PerturbJob {
    /// Where the data is.
    #[cfg_attr(feature = "cli", command(flatten))]
    pub data: DataArgs,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, default_value_os_t = PerturbJob::default().out))]
    pub out: PathBuf,
    /// Largest zone offset e.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PerturbJob::default().max))]
    pub max: usize,
    /// Use every n-th test frame.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PerturbJob::default().every))]
    pub every: usize,
    /// Map points also come from this many zones on each side of the forced one (0: the
    /// forced zone's points only, as in the paper).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PerturbJob::default().neighbours))]
    pub neighbours: usize,
    /// Trained model to use (trained into OUT/models/siamese when absent).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub model: Option<PathBuf>,
    /// Zones when training a model.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PerturbJob::default().zones))]
    pub zones: ZoneSpec,
    /// Training epochs when training a model.
    #[cfg_attr(feature = "cli", arg(long))]
    pub epochs: Option<usize>,
    /// Training seed.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PerturbJob::default().seed))]
    pub seed: u64,
    /// SURF threshold of a map built here and of the test frames.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = PerturbJob::default().threshold))]
    pub threshold: f32,
    /// Use an output folder that holds something else.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for PerturbJob {
    fn default() -> Self {
        PerturbJob {
            data: Default::default(),
            out: "experiments/perturb".into(),
            max: 5,
            every: 1,
            neighbours: 0,
            model: None,
            zones: ZoneSpec::default(),
            epochs: None,
            seed: 0,
            threshold: endoloc_localize::DEFAULT_MAP_THRESHOLD,
            force: false,
        }
    }
}

/// Errors at one forced zone offset.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Row {
    /// The offset e: frames are localized from zone k + e, k their true zone.
    pub offset: i64,
    /// Test frames used.
    pub frames: usize,
    /// Frames `refined`.
    pub refined: usize,
    /// Frames with a pose.
    pub localized: usize,
    /// Mean position error, mm.
    pub mean_position_mm: Option<f64>,
    /// Median position error, mm.
    pub median_position_mm: Option<f64>,
    /// Mean orientation error, degrees.
    pub mean_orientation_deg: Option<f64>,
    /// Median orientation error, degrees.
    pub median_orientation_deg: Option<f64>,
    /// Mean position error over the `refined` frames, mm.
    pub refined_mean_position_mm: Option<f64>,
}

/// One frame at one offset: its status and, with a pose, its position (mm) and orientation
/// (°) errors.
type FrameOutcome = Option<(Status, Option<(f64, f64)>)>;

impl PerturbJob {
    /// Runs the experiment.
    ///
    /// # Errors
    /// Bad inputs, a failed stage, or an output folder that holds something else.
    pub fn run(&self, progress: &dyn Progress) -> Result<ExperimentReport<Row>> {
        let args = self;
        common::prepare_out(&args.out, "perturb.md", args.force)?;
        let data = Data::from_args(&args.data)?;
        common::create_out(&args.out, "perturb.md")?;
        let model = args
            .model
            .clone()
            .unwrap_or_else(|| args.out.join("models/siamese"));
        ensure_model(
            &model,
            &data,
            &TrainSpec {
                zones: args.zones,
                epochs: args.epochs,
                seed: args.seed,
                pretrained: None,
            },
            progress,
        )?;
        ensure_map(&model, &data, args.threshold, None, &[], progress)?;
        let classifier = ZoneClassifier::load(&model)?;
        let map = load_map(&model)?;
        let mut surf = map.config.surf.clone();
        surf.threshold = args.threshold;
        let truth: Vec<Option<usize>> = data
            .test
            .poses
            .iter()
            .map(|p| classifier.truth_zone(&p.pose))
            .collect();
        let n_zones = classifier.zone_count() as i64;
        let localizer = Localizer::new(
            classifier,
            map,
            LocalizerConfig {
                neighbour_zones: args.neighbours,
                surf: Some(surf.clone()),
                retry_threshold: Some(0.0),
                ..LocalizerConfig::default()
            },
        )?;
        let features = FeatureCache::extract(&data.test, &surf, None, progress)?;
        let frames: Vec<usize> = (0..data.test.len()).step_by(args.every.max(1)).collect();
        let max = args.max as i64;
        let bar = bar(
            progress,
            ((2 * max + 1) as usize * frames.len()) as u64,
            "perturb",
        );
        let mut rows = Vec::new();
        for e in -max..=max {
            let per_frame: Result<Vec<FrameOutcome>> = frames
                .par_iter()
                .map(|&i| {
                    bar.inc(1);
                    let Some(k) = truth[i] else { return Ok(None) };
                    let z = k as i64 + e;
                    if z < 0 || z >= n_zones {
                        return Ok(None);
                    }
                    let r = localizer.register_in_zone(
                        &features.features[i],
                        z as usize,
                        StageTimes::default(),
                    )?;
                    let err = r.t_wc.map(|p| pose_error(&p, &data.test.poses[i].pose));
                    Ok(Some((r.status, err)))
                })
                .collect();
            let per_frame: Vec<_> = per_frame?.into_iter().flatten().collect();
            let pos: Vec<f64> = per_frame.iter().filter_map(|x| x.1.map(|e| e.0)).collect();
            let rot: Vec<f64> = per_frame.iter().filter_map(|x| x.1.map(|e| e.1)).collect();
            let refined_pos: Vec<f64> = per_frame
                .iter()
                .filter(|x| x.0 == Status::Refined)
                .filter_map(|x| x.1.map(|e| e.0))
                .collect();
            let (mp, dp) = mean_median(&pos);
            let (mr, dr) = mean_median(&rot);
            rows.push(Row {
                offset: e,
                frames: per_frame.len(),
                refined: per_frame.iter().filter(|x| x.0 == Status::Refined).count(),
                localized: pos.len(),
                mean_position_mm: mp,
                median_position_mm: dp,
                mean_orientation_deg: mr,
                median_orientation_deg: dr,
                refined_mean_position_mm: mean_median(&refined_pos).0,
            });
        }
        bar.finish_and_clear();

        let f = |v: Option<f64>| v.map_or("—".to_string(), |x| format!("{x:.2}"));
        let mut csv = String::from(
            "offset,frames,refined,localized,mean_position_mm,median_position_mm,mean_orientation_deg,median_orientation_deg,refined_mean_position_mm\n",
        );
        let header = [
            "e",
            "frames",
            "refined (%)",
            "mean pos (mm)",
            "median pos (mm)",
            "mean rot (°)",
            "median rot (°)",
            "refined: mean pos (mm)",
        ];
        let mut md = format!(
            "# Zone perturbation (the paper's Fig. 7)\n\nModel `{}`, test `{}`, every {} frame(s), \
             map points of the forced zone ± {} neighbour(s). Errors over frames with a pose (the \
             forced zone's median pose when the refinement fails).\n\n| {} |\n|{}\n",
            model.display(),
            data.test.dir.display(),
            args.every.max(1),
            args.neighbours,
            header.join(" | "),
            "---|".repeat(header.len())
        );
        let mut table_rows = Vec::new();
        for r in &rows {
            let opt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.4}"));
            csv.push_str(&format!(
                "{},{},{},{},{},{},{},{},{}\n",
                r.offset,
                r.frames,
                r.refined,
                r.localized,
                opt(r.mean_position_mm),
                opt(r.median_position_mm),
                opt(r.mean_orientation_deg),
                opt(r.median_orientation_deg),
                opt(r.refined_mean_position_mm)
            ));
            let cells = vec![
                format!("{:+}", r.offset),
                r.frames.to_string(),
                format!("{:.1}", 100.0 * r.refined as f64 / r.frames.max(1) as f64),
                f(r.mean_position_mm),
                f(r.median_position_mm),
                f(r.mean_orientation_deg),
                f(r.median_orientation_deg),
                f(r.refined_mean_position_mm),
            ];
            md.push_str(&format!("| {} |\n", cells.join(" | ")));
            table_rows.push(cells);
        }
        md.push_str("\n![error against the zone offset](perturb.png)\n");
        common::write_text(&args.out.join("perturb.csv"), &csv)?;
        common::write_text(&args.out.join("perturb.md"), &md)?;
        let png = args.out.join("perturb.png");
        let points: Vec<CurvePoint> = rows
            .iter()
            .map(|r| CurvePoint {
                x: r.offset as f64,
                mean_position_mm: r.mean_position_mm,
                median_position_mm: r.median_position_mm,
                mean_orientation_deg: r.mean_orientation_deg,
                median_orientation_deg: r.median_orientation_deg,
            })
            .collect();
        plot_error_curve(
            &points,
            "forced zone offset e (zones)",
            &png,
            &PlotConfig::default(),
        )?;
        let mut html = HtmlReport::new("endoloc — zone perturbation");
        html.push(endoloc_eval::Block::Paragraph(format!(
            "Each test frame is localized from zone k + e, k its true zone. Model {}, data {}.",
            model.display(),
            args.data.data.display()
        )))
        .push(endoloc_eval::Block::Table {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: table_rows,
        });
        if let Some(b) =
            common::image_block(&png, "Errors against the forced zone offset", progress)
        {
            html.push(b);
        }
        common::write_text(&args.out.join("report.html"), &html.render())
            .context("writing report.html")?;
        Ok(ExperimentReport {
            rows,
            table: md.lines().skip(4).collect::<Vec<_>>().join("\n"),
            out: args.out.clone(),
            files: vec!["perturb.csv", "perturb.md", "perturb.png", "report.html"],
        })
    }
}
