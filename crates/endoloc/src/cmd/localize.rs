//! `endoloc map` and `endoloc localize`: the geometric half of the method.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::{Context, Result, bail};
use endoloc_data::{Dataset, Sequence, StampedPose};
use endoloc_eval::{FrameRecord, write_frames_csv};
use endoloc_localize::export::{write_colmap_text, write_zone_ply};
use endoloc_localize::map_io::{load_map, save_map};
use endoloc_localize::{FrameResult, Localizer, LocalizerConfig, MapConfig, build_map};
use endoloc_net::ZoneClassifier;
use rayon::prelude::*;

use crate::cmd::baselines;
use crate::ui;

/// Build the per-zone 3-D maps of a trained model: SURF tracks over `m` images of each zone,
/// triangulated with the known training poses; points reprojecting farther than δr are
/// dropped. Writes map.toml and map.bin into the model folder, one PLY per zone
/// (map_ply/zone_NNN.ply) and a COLMAP text model (map_colmap/).
///
/// Example:
///
///   endoloc map --model models/small --data data/small
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct MapArgs {
    /// Model folder written by `endoloc train`.
    #[arg(long, value_name = "DIR")]
    pub model: PathBuf,
    /// Dataset the model was trained on.
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// Training sequence inside the dataset.
    #[arg(long, default_value = "train")]
    pub seq: String,
    /// Images per zone (the paper's m ≥ 3).
    #[arg(long, default_value_t = 8)]
    pub images_per_zone: usize,
    /// SURF threshold (units of MATLAB's MetricThreshold). The paper used 200. On the
    /// simulator's 640×480 frames (`paper` preset, live localization) a lower threshold gives
    /// denser maps and more registered frames: 200 → 42 map points per zone (median) and 22 %
    /// refined; 50 → 446 and 94.4 %; 25 → 962 and 95.4 % (test frames at 50, retried at 25),
    /// so 25 is the default.
    #[arg(long, default_value_t = DEFAULT_MAP_THRESHOLD)]
    pub threshold: f64,
    /// δr: drop map points reprojecting farther than this, pixels.
    #[arg(long, default_value_t = 10.0)]
    pub delta_r: f64,
    /// Replace an existing map.
    #[arg(long)]
    pub force: bool,
}

/// Default SURF threshold of `endoloc map` (and of the experiments' maps).
pub const DEFAULT_MAP_THRESHOLD: f64 = 25.0;

/// The localizer's SURF settings for test frames, from the map's: `threshold` (default twice
/// the map's) and `retry` (default the map's; 0 = off). Everything else in the returned config
/// is the default.
pub fn test_frame_surf(
    map_surf: &endoloc_features::SurfConfig,
    threshold: Option<f64>,
    retry: Option<f64>,
) -> LocalizerConfig {
    let mut surf = map_surf.clone();
    surf.threshold = threshold.map_or(2.0 * map_surf.threshold, |t| t as f32);
    LocalizerConfig {
        surf,
        retry_threshold: retry.map_or(map_surf.threshold, |t| t as f32),
        ..LocalizerConfig::default()
    }
}

/// Runs `endoloc map`.
pub fn run_map(args: MapArgs) -> Result<()> {
    if args.model.join("map.bin").exists() && !args.force {
        bail!(
            "{} already has a map (map.bin); pass --force to rebuild it",
            args.model.display()
        );
    }
    let classifier = ZoneClassifier::load(&args.model)
        .with_context(|| format!("loading model {}", args.model.display()))?;
    let dataset = Dataset::open(&args.data)?;
    classifier.check_compatible(&dataset.meta.camera)?;
    let train = dataset.sequence(&args.seq)?;
    let mut cfg = MapConfig {
        images_per_zone: args.images_per_zone,
        ..MapConfig::default()
    };
    cfg.surf.threshold = args.threshold as f32;
    cfg.triangulation.delta_r_px = args.delta_r;
    let bar = ui::progress_bar(classifier.zone_count() as u64, "map");
    let t = std::time::Instant::now();
    let map = build_map(
        &train,
        classifier.zones(),
        &dataset.meta.camera,
        &cfg,
        &|_| bar.inc(1),
    )?;
    bar.finish_and_clear();
    let summary = map.summary();
    save_map(&map, &args.model)?;
    let ply_dir = args.model.join("map_ply");
    std::fs::create_dir_all(&ply_dir).with_context(|| format!("creating {}", ply_dir.display()))?;
    for z in &map.zones {
        write_zone_ply(z, &ply_dir.join(format!("zone_{:03}.ply", z.zone)))?;
    }
    write_colmap_text(&map, &train, &args.model.join("map_colmap"))?;
    for z in &summary.empty_zones {
        eprintln!(
            "warning: zone {z} has no map point (textureless?): its frames will be init_only"
        );
    }
    println!(
        "map       {} zones, {} points (median {} per zone), mean reprojection RMS {:.2} px, {:.1} s",
        summary.zones,
        summary.points,
        summary.median_points_per_zone,
        summary.mean_reprojection_rms_px,
        t.elapsed().as_secs_f64()
    );
    println!(
        "wrote     {}/map.bin, map_ply/, map_colmap/",
        args.model.display()
    );
    Ok(())
}

/// Localize every frame of a sequence: zone (Siamese classifier) → initial pose = zone median
/// → SURF matched to the zone's map points → Gauss-Newton on SE(3) → validity check.
/// Writes trajectory.txt (TUM, T_wc, mm; one line per frame that has a pose) and frames.csv
/// (frame, zone, zone score, status refined|init_only|rejected, reason, inliers,
/// reprojection RMS, time) into --out. Then `endoloc eval --gt SEQ/poses.txt --est
/// OUT/trajectory.txt` gives the errors.
///
/// Example:
///
///   endoloc localize --model models/small --seq data/small/test --out runs/small
///
///   endoloc localize --model models/small --seq data/small/test --out runs/live --live
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct LocalizeArgs {
    /// Method: `endoloc` (the paper's two-step method, default) or a baseline of the paper's
    /// Table I: `classify` (zone median pose), `retrieval` (pose of the nearest training
    /// image), `posenet` (--model is a PoseNet folder from `endoloc train --method posenet`),
    /// `offsetnet` (--model the Siamese model for retrieval, --regressor the OffsetNet folder,
    /// --reference-seq the training sequence) or `vo` (monocular visual odometry; needs the
    /// sequence's poses.txt for the first pose and the scale, as the paper did for ORB-SLAM).
    /// Baselines write trajectory.txt only.
    #[arg(long, value_enum, default_value = "endoloc")]
    pub method: LocalizeMethod,
    /// Model folder (trained, with its map).
    #[arg(long, value_name = "DIR")]
    pub model: Option<PathBuf>,
    /// Ensemble: join this zone model to --model (same training pass and zones; repeat for
    /// more; `endoloc classify --also-model` shows what it gains). The map is --model's.
    #[arg(long, value_name = "DIR")]
    pub also_model: Vec<PathBuf>,
    /// OffsetNet model folder (--method offsetnet).
    #[arg(long, value_name = "DIR")]
    pub regressor: Option<PathBuf>,
    /// Training sequence folder holding the reference images (--method offsetnet).
    #[arg(long, value_name = "DIR")]
    pub reference_seq: Option<PathBuf>,
    /// Sequence folder to localize (images/ and, for evaluation, poses.txt), e.g. data/small/test.
    #[arg(long, value_name = "DIR")]
    pub seq: PathBuf,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Live mode: frames one at a time, in order, with causal temporal zone filtering, as a
    /// scope would deliver them (no look-ahead; one frame in flight). After a refined frame
    /// the next one is first registered from that pose (see --track-frames).
    #[arg(long)]
    pub live: bool,
    /// Live mode: frames a refined pose stays usable as the next frames' prior (0: every frame
    /// starts from its zone's median pose, as in the paper).
    #[arg(long, default_value_t = 5)]
    pub track_frames: usize,
    /// Live mode: for this many frames after a refined one, frames that register nowhere else
    /// also try the zones around it (one behind, two ahead); 0: off.
    #[arg(long, default_value_t = 300)]
    pub recover_frames: usize,
    /// Live mode: an init_only frame reports the last refined pose (instead of its zone's
    /// median) when that is at most this many frames old; 0: always the zone median.
    #[arg(long, default_value_t = 60)]
    pub hold_frames: usize,
    /// Map points also come from this many zones on each side of the classified one.
    #[arg(long, default_value_t = 1)]
    pub neighbours: usize,
    /// SURF threshold on the test frames (default: twice the map's: the stronger features,
    /// cheaper to detect and match).
    #[arg(long)]
    pub threshold: Option<f64>,
    /// A frame that registers nowhere is described again at this lower SURF threshold and
    /// tried once more (default: the map's threshold; 0: off). Weakly textured frames get the
    /// features they need; only they pay the second detection.
    #[arg(long)]
    pub retry_threshold: Option<f64>,
    /// Keep at most this many SURF keypoints per test frame, the strongest (0: all); bounds
    /// the time per frame on richly textured frames.
    #[arg(long, default_value_t = 0)]
    pub max_keypoints: usize,
    /// Zones tried (best classifier score first) until one registers; 1 = trust the top zone
    /// as the paper does.
    #[arg(long, default_value_t = 3)]
    pub candidate_zones: usize,
    /// Validity: largest predicted position uncertainty (1σ, mm) of a refined pose; frames
    /// above it keep the zone's median pose as `init_only` (degenerate_geometry).
    #[arg(long, default_value_t = 5.0)]
    pub max_sigma_mm: f64,
    /// Validity: largest RMS reprojection error of the inliers, pixels.
    #[arg(long, default_value_t = 3.0)]
    pub max_rms_px: f64,
    /// Validity: largest jump from the prior (the zone's median pose, or in live mode the last
    /// refined pose), mm.
    #[arg(long, default_value_t = 50.0)]
    pub max_jump_mm: f64,
    /// Replace existing results in --out.
    #[arg(long)]
    pub force: bool,
}

/// Loads a zone model on `device`, joined with `also` into an ensemble
/// ([`ZoneClassifier::join`]) when that is not empty.
pub fn load_classifier(model: &Path, also: &[PathBuf], device: &str) -> Result<ZoneClassifier> {
    let load = |dir: &Path| {
        ZoneClassifier::load_on(dir, device)
            .with_context(|| format!("loading model {}", dir.display()))
    };
    let first = load(model)?;
    if also.is_empty() {
        return Ok(first);
    }
    let others = also.iter().map(|d| load(d)).collect::<Result<Vec<_>>>()?;
    Ok(first.join(others)?)
}

/// Runs `endoloc localize`.
pub fn run_localize(args: LocalizeArgs) -> Result<()> {
    let outputs = ["trajectory.txt", "frames.csv"];
    if !args.force
        && let Some(existing) = outputs
            .iter()
            .map(|f| args.out.join(f))
            .find(|p| p.exists())
    {
        bail!(
            "{} exists; pass --force to replace the results in {}",
            existing.display(),
            args.out.display()
        );
    }
    if args.method != LocalizeMethod::Endoloc {
        if !args.also_model.is_empty() {
            bail!("--also-model joins zone models for --method endoloc only");
        }
        return run_baseline(&args);
    }
    let model = args.model.as_deref().context("--model is required")?;
    let classifier = load_classifier(model, &args.also_model, "cpu")?;
    let map = load_map(model)?;
    let seq = Sequence::open(&args.seq)?;
    let camera = dataset_camera(&args.seq)?;
    classifier.check_compatible(&camera).with_context(|| {
        format!(
            "model {} vs sequence {}",
            model.display(),
            args.seq.display()
        )
    })?;
    let mut cfg = LocalizerConfig {
        neighbour_zones: args.neighbours,
        candidate_zones: args.candidate_zones,
        track_frames: args.track_frames,
        recover_frames: args.recover_frames,
        hold_frames: args.hold_frames,
        ..test_frame_surf(&map.config.surf, args.threshold, args.retry_threshold)
    };
    cfg.surf.max_keypoints = args.max_keypoints;
    let validity = &mut cfg.localize.validity;
    validity.max_position_sigma_mm = args.max_sigma_mm;
    validity.max_rms_px = args.max_rms_px;
    validity.max_jump_mm = args.max_jump_mm;
    let localizer = Localizer::new(classifier, map, cfg)?;
    let n = seq.len();
    let bar = ui::progress_bar(n as u64, if args.live { "live" } else { "localize" });
    let t = std::time::Instant::now();
    let results: Vec<FrameResult> = if args.live {
        let mut state = localizer.live_state();
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let img = seq.load_gray(i)?;
            out.push(localizer.localize_live(&mut state, &img)?);
            bar.inc(1);
        }
        out
    } else {
        let done = AtomicUsize::new(0);
        let r: Result<Vec<FrameResult>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let img = seq.load_gray(i)?;
                let r = localizer.localize(&img)?;
                done.fetch_add(1, Ordering::Relaxed);
                bar.inc(1);
                Ok(r)
            })
            .collect();
        r?
    };
    bar.finish_and_clear();
    let wall = t.elapsed().as_secs_f64();
    write_results(&args.out, &seq, &results)?;
    print_summary(&results, wall);
    println!(
        "wrote     {}/trajectory.txt, frames.csv",
        args.out.display()
    );
    Ok(())
}

/// A localization method of `endoloc localize`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LocalizeMethod {
    /// The paper's two-step method (zone, then SURF map matching and Gauss-Newton).
    Endoloc,
    /// Zone median pose (classification only).
    Classify,
    /// Pose of the nearest training image in descriptor space.
    Retrieval,
    /// PoseNet pose regression.
    Posenet,
    /// OffsetNet relative pose to the retrieved training image.
    Offsetnet,
    /// Monocular visual odometry, first pose and scale from the ground truth.
    Vo,
}

/// `endoloc localize --method <baseline>`: estimates and trajectory.txt.
fn run_baseline(args: &LocalizeArgs) -> Result<()> {
    let seq = Sequence::open(&args.seq)?;
    let camera = dataset_camera(&args.seq)?;
    let name = format!("{:?}", args.method).to_lowercase();
    let model = || {
        args.model
            .as_deref()
            .with_context(|| format!("--method {name} needs --model"))
    };
    let classify = |dir: &Path| -> Result<(ZoneClassifier, Vec<endoloc_net::ZonePrediction>, f64)> {
        let clf = ZoneClassifier::load(dir)
            .with_context(|| format!("loading model {}", dir.display()))?;
        clf.check_compatible(&camera)?;
        let (preds, ms) = crate::cmd::experiment::predict_zones(&clf, &seq)?;
        Ok((clf, preds, ms))
    };
    let est = match args.method {
        LocalizeMethod::Classify | LocalizeMethod::Retrieval => {
            let (clf, preds, ms) = classify(model()?)?;
            let poses = preds
                .iter()
                .map(|p| {
                    if args.method == LocalizeMethod::Classify {
                        clf.zones().zones.get(p.zone).map(|z| z.median_pose)
                    } else {
                        clf.train_poses().get(p.nearest_frame).copied()
                    }
                })
                .collect();
            baselines::Estimates {
                poses,
                ms_per_frame: ms,
                note: None,
            }
        }
        LocalizeMethod::Posenet => baselines::posenet(model()?, &seq)?,
        LocalizeMethod::Offsetnet => {
            let reg = args
                .regressor
                .as_deref()
                .context("--method offsetnet needs --regressor (the OffsetNet model folder)")?;
            let refs = args.reference_seq.as_deref().context(
                "--method offsetnet needs --reference-seq (the training sequence folder)",
            )?;
            let train = Sequence::open(refs)?;
            let (_, preds, ms) = classify(model()?)?;
            baselines::offsetnet(reg, &train, &seq, &preds, ms)?
        }
        LocalizeMethod::Vo => baselines::vo(&camera, &seq)?,
        LocalizeMethod::Endoloc => unreachable!("handled by run_localize"),
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let trajectory: Vec<StampedPose> = est
        .poses
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            p.map(|pose| StampedPose {
                timestamp_s: seq.poses[i].timestamp_s,
                pose,
            })
        })
        .collect();
    endoloc_data::write_tum(&args.out.join("trajectory.txt"), &trajectory)?;
    if let Some(note) = &est.note {
        println!("{note}");
    }
    println!(
        "frames    {} — {} with a pose ({:.1} %), {:.1} ms per frame",
        seq.len(),
        trajectory.len(),
        100.0 * trajectory.len() as f64 / seq.len().max(1) as f64,
        est.ms_per_frame
    );
    println!("wrote     {}/trajectory.txt", args.out.display());
    Ok(())
}

/// The camera of the dataset a sequence folder belongs to (its parent's dataset.toml).
fn dataset_camera(seq_dir: &Path) -> Result<endoloc_geometry::Camera> {
    let parent = seq_dir
        .canonicalize()
        .with_context(|| format!("{}", seq_dir.display()))?
        .parent()
        .map(Path::to_path_buf)
        .context("the sequence folder has no parent dataset folder")?;
    let ds = Dataset::open(&parent).with_context(|| {
        format!(
            "{} should be a sequence folder inside a dataset (with dataset.toml)",
            seq_dir.display()
        )
    })?;
    Ok(ds.meta.camera)
}

/// Writes trajectory.txt and frames.csv.
pub fn write_results(out: &Path, seq: &Sequence, results: &[FrameResult]) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let trajectory: Vec<StampedPose> = results
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            r.t_wc.map(|pose| StampedPose {
                timestamp_s: seq.poses[i].timestamp_s,
                pose,
            })
        })
        .collect();
    endoloc_data::write_tum(&out.join("trajectory.txt"), &trajectory)?;
    let rows = frame_records(results);
    write_frames_csv(&out.join("frames.csv"), &rows)?;
    Ok(())
}

/// The frames.csv rows of a run, one per frame in order.
pub fn frame_records(results: &[FrameResult]) -> Vec<FrameRecord> {
    results
        .iter()
        .enumerate()
        .map(|(i, r)| FrameRecord {
            frame: i,
            zone: Some(r.zone),
            zone_score: Some(r.zone_score as f64),
            status: r.status,
            reason: r
                .reason
                .as_ref()
                .map_or(String::new(), |x| x.code().to_string()),
            inliers: Some(r.inliers),
            reprojection_rms_px: r
                .reprojection_rms_px
                .is_finite()
                .then_some(r.reprojection_rms_px),
            time_ms: r.times.total_ms(),
        })
        .collect()
}

/// Prints counts per status and per-stage median latency.
pub fn print_summary(results: &[FrameResult], wall_s: f64) {
    let count = |s: endoloc_geometry::Status| results.iter().filter(|r| r.status == s).count();
    let n = results.len().max(1);
    let median = |f: &dyn Fn(&FrameResult) -> f64| {
        let mut v: Vec<f64> = results.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    println!(
        "frames    {} — refined {:.1} %, init_only {:.1} %, rejected {:.1} %",
        results.len(),
        100.0 * count(endoloc_geometry::Status::Refined) as f64 / n as f64,
        100.0 * count(endoloc_geometry::Status::InitOnly) as f64 / n as f64,
        100.0 * count(endoloc_geometry::Status::Rejected) as f64 / n as f64,
    );
    println!(
        "latency   median per frame {:.1} ms (zone {:.1}, SURF {:.1}, matching {:.1}, refine {:.2}); {:.1} s wall",
        median(&|r| r.times.total_ms()),
        median(&|r| r.times.zone_ms),
        median(&|r| r.times.surf_ms),
        median(&|r| r.times.matching_ms),
        median(&|r| r.times.refine_ms),
        wall_s
    );
}
