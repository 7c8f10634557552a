//! What the experiments share: trained models and maps made (or reused) through the same
//! code paths as `endoloc train` and `endoloc map`, test-frame SURF features extracted once,
//! zone predictions, our method run in-process on cached features, and one evaluated row per
//! method.

use std::path::{Path, PathBuf};
use std::time::Instant;

use endoloc_data::write_atomic;
use endoloc_data::{Dataset, Sequence, StampedPose};
use endoloc_eval::{
    Block, EvalConfig, EvalInputs, FrameRecord, MethodBar, Sources, WriteOptions, evaluate,
    write_frames_csv,
};
use endoloc_features::{Feature, SurfConfig};
use endoloc_geometry::{Pose, Status};
use endoloc_jobs::bail;
use endoloc_jobs::error::{Context, Result};
use endoloc_jobs::note;
use endoloc_jobs::progress::{Progress, bar};
use endoloc_localize::map_io::{
    SMOOTHED_LEVEL_DIR, load_map, load_smoothed_level, smoothed_level_px,
};
use endoloc_localize::{
    ConfirmConfig, FrameResult, Localizer, LocalizerConfig, RetryFeatures, StageTimes,
};
use endoloc_net::{ZoneClassifier, ZonePrediction, ZoneSpec, viterbi};

use endoloc_jobs::map::smoothed_level_sigma;
pub(super) use endoloc_jobs::predict::predict_zones;
use endoloc_jobs::{MapJob, TrainJob};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Where an experiment's data is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct DataArgs {
    /// Dataset with a training and a test sequence.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub data: PathBuf,
    /// Training sequence.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DataArgs::default().train))]
    pub train: String,
    /// Test sequence.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DataArgs::default().test))]
    pub test: String,
}

impl Default for DataArgs {
    fn default() -> Self {
        DataArgs {
            data: PathBuf::new(),
            train: "train".into(),
            test: "test".into(),
        }
    }
}

/// The dataset an experiment runs on: its training and test sequences.
pub(super) struct Data {
    /// Dataset folder.
    pub dir: PathBuf,
    /// The test sequence (images and ground-truth poses).
    pub test: Sequence,
    /// Name of the training sequence.
    pub train_name: String,
    /// Width of the dataset's images, pixels.
    pub width: u32,
}

impl Data {
    pub fn from_args(a: &DataArgs) -> Result<Self> {
        Self::open(&a.data, &a.train, &a.test)
    }

    pub fn open(dir: &Path, train: &str, test: &str) -> Result<Self> {
        let ds =
            Dataset::open(dir).with_context(|| format!("opening dataset {}", dir.display()))?;
        // Fail early, before any training, if either sequence is missing.
        ds.sequence(train)
            .with_context(|| format!("training sequence {train:?}"))?;
        let test = ds
            .sequence(test)
            .with_context(|| format!("test sequence {test:?}"))?;
        if test.is_empty() {
            bail!("the test sequence {} has no frame", test.dir.display());
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            test,
            train_name: train.to_string(),
            width: ds.meta.camera.width,
        })
    }
}

/// How a Siamese model is trained for an experiment.
#[derive(Debug, Clone)]
pub(super) struct TrainSpec {
    /// Zones of the training (the train job's `zones`).
    pub zones: ZoneSpec,
    /// Epochs (`None`: the `fast` schedule's default).
    pub epochs: Option<usize>,
    /// Training seed.
    pub seed: u64,
    /// Start weights (`--pretrained` of `endoloc train`); `None`: random initialisation.
    pub pretrained: Option<PathBuf>,
}

/// The zoom-blurred views an experiment asks of every zone index it trains (the train job's
/// `index_zoom_blur` and `index_view_penalty`; `None`: the train job's defaults).
#[derive(Debug, Clone, Copy)]
pub(super) struct IndexViews<'a> {
    /// Amplitudes, `A,..` or `none`.
    pub zoom_blur: Option<&'a str>,
    /// Descriptor distance added to a view's at look-up.
    pub penalty: Option<f64>,
}

impl IndexViews<'_> {
    /// The amplitudes and penalty as the train job reads them.
    ///
    /// # Errors
    /// A bad list or penalty, named as the train job names it.
    pub fn parsed(&self) -> Result<(Vec<f64>, f64)> {
        let cfg = TrainJob {
            index_zoom_blur: self.zoom_blur.map(str::to_string),
            index_view_penalty: self.penalty,
            ..TrainJob::default()
        }
        .train_config()?;
        Ok((cfg.index_zoom_blur, cfg.index_view_penalty))
    }

    /// Passes them on to a train job.
    pub fn apply(&self, job: TrainJob) -> TrainJob {
        TrainJob {
            index_zoom_blur: self.zoom_blur.map(str::to_string),
            index_view_penalty: self.penalty,
            ..job
        }
    }

    /// Their options on a command line (`print_jobs`), each with a leading space.
    pub fn options(&self) -> String {
        let mut c = String::new();
        if let Some(a) = self.zoom_blur {
            c.push_str(&format!(" --index-zoom-blur {}", shell_quote(a)));
        }
        if let Some(d) = self.penalty {
            c.push_str(&format!(" --index-view-penalty {d}"));
        }
        c
    }

    /// Checks each of `dirs` that holds a model already (a colon's model made earlier, used
    /// as it is): when views are asked for, it must have them (what is not asked for is not
    /// checked). Called before an experiment writes anything; the others are trained with
    /// the views.
    ///
    /// # Errors
    /// The first model whose index has other views or another penalty, with the command that
    /// trains it again; an unreadable `model.toml`.
    pub fn check_models(&self, dirs: impl IntoIterator<Item = PathBuf>) -> Result<()> {
        if self.zoom_blur.is_none() && self.penalty.is_none() {
            return Ok(());
        }
        let (views, penalty) = self.parsed()?;
        for dir in dirs {
            if !dir.join("model.toml").is_file() {
                continue;
            }
            let have = endoloc_net::ModelConfig::load(&dir)
                .with_context(|| format!("reading the model of {}", dir.display()))?
                .train;
            if (self.zoom_blur.is_some() && have.index_zoom_blur != views)
                || (self.penalty.is_some() && have.index_view_penalty != penalty)
            {
                bail!(
                    "the zone index of {} has zoom-blurred views {:?} (penalty {}), but \
                     {views:?} (penalty {penalty}) were asked for: train it again (`endoloc \
                     train … --out {} --force` with the views), or use another output folder",
                    dir.display(),
                    have.index_zoom_blur,
                    have.index_view_penalty,
                    dir.display()
                );
            }
        }
        Ok(())
    }
}

/// Trains a model into `dir` unless a finished one is already there (`model.toml` present).
/// Returns whether it trained.
pub(super) fn ensure_model(
    dir: &Path,
    data: &Data,
    spec: &TrainSpec,
    progress: &dyn Progress,
) -> Result<bool> {
    if dir.join("model.toml").is_file() {
        note!(progress, "reusing   model {}", dir.display());
        return Ok(false);
    }
    let job = TrainJob {
        data: data.dir.clone(),
        seq: data.train_name.clone(),
        zones: spec.zones,
        out: dir.to_path_buf(),
        seed: spec.seed,
        epochs: spec.epochs,
        pretrained: spec.pretrained.clone(),
        // A half-written model folder from an interrupted run is resumed by the training.
        resume: dir.with_extension("partial").exists(),
        ..TrainJob::default()
    };
    note!(progress, "\n== train: {}", job.out.display());
    job.run(progress)?;
    Ok(true)
}

/// Builds the per-zone maps of `model`, with the smoothed level `smoothed_level_px` asks for
/// (the map job's option: σ in pixels, `None` the default for the images' width, 0 none),
/// unless it has a map; a map already there is used as it is, and refused (not rebuilt) when
/// `smoothed_level_px` names another level. Maps depend on the zone table and the training
/// data, not on the training seed: when `share_from` holds a map with the same level built
/// for an identical zone table (same `zones.csv`), it is copied instead of rebuilt.
pub(super) fn ensure_map(
    model: &Path,
    data: &Data,
    threshold: f32,
    smoothed_level_px: Option<f64>,
    share_from: &[PathBuf],
    progress: &dyn Progress,
) -> Result<()> {
    let asked = smoothed_level_px;
    let smoothed_level_px = smoothed_level_sigma(asked, data.width);
    if model.join("map.bin").is_file() {
        // A map already there is used as it is unless another level was asked for by name.
        let found = smoothed_level_px_of(model)?;
        if asked.is_some() && found != smoothed_level_px {
            let has = |s: f64| {
                if s > 0.0 {
                    format!("a smoothed level of σ {s} px")
                } else {
                    "no smoothed level".to_string()
                }
            };
            bail!(
                "the map of {} has {}, but {} was asked for: build it again with `endoloc map \
                 --model {} --smoothed-level {} --force`, or use another model",
                model.display(),
                has(found),
                has(smoothed_level_px),
                shell_quote(&model.display().to_string()),
                smoothed_level_px
            );
        }
        return Ok(());
    }
    let zones = std::fs::read(model.join("zones.csv"))
        .with_context(|| format!("reading {}/zones.csv", model.display()))?;
    for other in share_from {
        if other == model
            || !other.join("map.bin").is_file()
            || smoothed_level_px_of(other)? != smoothed_level_px
        {
            continue;
        }
        if std::fs::read(other.join("zones.csv")).ok().as_deref() == Some(&zones[..]) {
            let level = Path::new(SMOOTHED_LEVEL_DIR);
            let mut files = vec![PathBuf::from("map.toml"), PathBuf::from("map.bin")];
            if smoothed_level_px > 0.0 {
                std::fs::create_dir_all(model.join(level))
                    .with_context(|| format!("creating {}", model.join(level).display()))?;
                files.extend([level.join("map.toml"), level.join("map.bin")]);
            }
            for f in files {
                let bytes = std::fs::read(other.join(&f))
                    .with_context(|| format!("reading {}", other.join(&f).display()))?;
                write_atomic(&model.join(&f), &bytes)?;
            }
            note!(
                progress,
                "reusing   map of {} (same zones) for {}",
                other.display(),
                model.display()
            );
            return Ok(());
        }
    }
    let job = MapJob {
        model: model.to_path_buf(),
        data: data.dir.clone(),
        seq: data.train_name.clone(),
        threshold,
        smoothed_level_px: asked,
        ..MapJob::default()
    };
    note!(progress, "\n== map: {}", model.display());
    let report = job.run(progress)?;
    note!(progress, "{report}");
    Ok(())
}

/// [`smoothed_level_px`] of a model folder, as an experiment error.
fn smoothed_level_px_of(model: &Path) -> Result<f64> {
    smoothed_level_px(model).with_context(|| format!("reading the map of {}", model.display()))
}

/// SURF features of every test frame, extracted once: with the localizer's test-frame
/// settings and, when the retry is on, its retry's
/// ([`endoloc_localize::LocalizerConfig::retry_surf`]).
pub(super) struct FeatureCache {
    /// The SURF settings of the test frames.
    pub surf: SurfConfig,
    /// The retry's SURF settings (`None`: no retry features).
    pub retry_surf: Option<SurfConfig>,
    /// Features per frame.
    pub features: Vec<Vec<Feature>>,
    /// Extraction time per frame, ms (one thread per frame).
    pub surf_ms: Vec<f64>,
    /// Features per frame with the retry's settings (empty when the retry is off).
    pub retry: Vec<Vec<Feature>>,
    /// Their extraction time, ms.
    pub retry_ms: Vec<f64>,
    /// The sequence's own camera (`camera.toml`: a pass from another scope), when it has one.
    pub camera: Option<endoloc_geometry::Camera>,
}

impl FeatureCache {
    /// Extracts the features of `seq` with `surf`, and with `retry_surf` when there is one.
    pub fn extract(
        seq: &Sequence,
        surf: &SurfConfig,
        retry_surf: Option<&SurfConfig>,
        progress: &dyn Progress,
    ) -> Result<Self> {
        let mask = endoloc_jobs::localize::dataset_mask(&seq.dir)?;
        let extractor = surf
            .clone()
            .init()
            .context("SURF settings")?
            .with_mask(mask.clone());
        let retry = retry_surf
            .map(|s| s.clone().init())
            .transpose()
            .context("SURF retry settings")?
            .map(|s| s.with_mask(mask));
        let bar = bar(progress, seq.len() as u64, "SURF");
        type Timed = (Vec<Feature>, f64);
        let out: Result<Vec<(Timed, Timed)>> = (0..seq.len())
            .into_par_iter()
            .map(|i| {
                let img = seq.load_gray(i)?;
                let timed = |s: &endoloc_features::Surf| -> Result<Timed> {
                    let t = Instant::now();
                    let f = s
                        .detect_and_describe(&img)
                        .with_context(|| format!("SURF on {}", seq.image_paths[i].display()))?;
                    Ok((f, t.elapsed().as_secs_f64() * 1e3))
                };
                let primary = timed(&extractor)?;
                let dense = match &retry {
                    Some(s) => timed(s)?,
                    None => (Vec::new(), 0.0),
                };
                bar.inc(1);
                Ok((primary, dense))
            })
            .collect();
        bar.finish_and_clear();
        let (primary, dense): (Vec<Timed>, Vec<Timed>) = out?.into_iter().unzip();
        let (features, surf_ms) = primary.into_iter().unzip();
        let (retry, retry_ms) = if retry_surf.is_some() {
            dense.into_iter().unzip()
        } else {
            (Vec::new(), Vec::new())
        };
        let camera = endoloc_data::sequence_camera(
            &seq.dir,
            &endoloc_jobs::localize::dataset_camera(&seq.dir)?,
        )?;
        Ok(Self {
            surf: surf.clone(),
            retry_surf: retry_surf.cloned(),
            features,
            surf_ms,
            retry,
            retry_ms,
            camera,
        })
    }

    /// Reuses `cache` when it was extracted for the test-frame settings that go with a map
    /// built with `map_surf` (the localizer's defaults), else extracts anew into it.
    pub fn get<'a>(
        cache: &'a mut Option<FeatureCache>,
        seq: &Sequence,
        map_surf: &SurfConfig,
        progress: &dyn Progress,
    ) -> Result<&'a FeatureCache> {
        let cfg = LocalizerConfig::default();
        let surf = cfg.test_surf(map_surf);
        let retry = cfg.retry_surf(map_surf);
        if cache
            .as_ref()
            .is_none_or(|c| c.surf != surf || c.retry_surf != retry)
        {
            *cache = Some(Self::extract(seq, &surf, retry.as_ref(), progress)?);
        }
        cache.as_ref().context("feature cache")
    }

    /// The retry features of frame `i`, if any.
    pub fn retry_of(&self, i: usize) -> Option<RetryFeatures<'_>> {
        self.retry.get(i).map(|f| RetryFeatures {
            features: f,
            surf_ms: self.retry_ms[i],
        })
    }
}

/// How our method picks the zone of each frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ZoneChoice {
    /// Each frame alone: the classifier's top zone (the paper).
    PerFrame,
    /// Frames in order (`--live`): causal track filter, and registration from the last
    /// refined pose first.
    Live,
    /// Offline Viterbi over the whole test pass.
    Viterbi,
    /// Offline forward–backward of the track filter over the whole test pass.
    Smooth,
}

/// How [`run_endoloc`] localizes: the zone choice, the candidate zones per frame and whether
/// registrations are confirmed against the map ([`endoloc_localize::confirm`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct EndolocRun {
    pub choice: ZoneChoice,
    pub candidate_zones: usize,
    pub confirm: bool,
    /// [`endoloc_geometry::RefineConfig::wall_motion_mm`].
    pub wall_motion_mm: f64,
}

/// Runs our method on cached features and predictions: zone → median pose → matching →
/// Gauss-Newton → validity, trying `run.candidate_zones` zones.
pub(super) fn run_endoloc(
    model: &Path,
    features: &FeatureCache,
    preds: &[ZonePrediction],
    zone_ms: f64,
    run: EndolocRun,
    progress: &dyn Progress,
) -> Result<Vec<FrameResult>> {
    let EndolocRun {
        choice,
        candidate_zones,
        confirm,
        wall_motion_mm,
    } = run;
    let classifier = ZoneClassifier::load(model)
        .with_context(|| format!("loading model {}", model.display()))?;
    let map = load_map(model)?;
    let cfg = LocalizerConfig {
        candidate_zones,
        confirm: if confirm {
            ConfirmConfig::standard()
        } else {
            ConfirmConfig::default()
        },
        surf: Some(features.surf.clone()),
        retry_threshold: Some(features.retry_surf.as_ref().map_or(0.0, |s| s.threshold)),
        ..LocalizerConfig::default()
    };
    let mut cfg = cfg;
    cfg.localize.refine.wall_motion_mm = wall_motion_mm;
    let localizer =
        Localizer::new(classifier, map, cfg)?.with_smoothed_level(load_smoothed_level(model)?)?;
    let localizer = match features.camera {
        Some(camera) => localizer.with_camera(camera)?,
        None => localizer,
    };
    let n = preds.len();
    let times = |i: usize| StageTimes {
        zone_ms,
        surf_ms: features.surf_ms[i],
        ..Default::default()
    };
    if choice == ZoneChoice::Live {
        // One frame at a time, in order: the state carries the zone filter and the last pose.
        let bar = bar(progress, n as u64, "live");
        let mut state = localizer.live_state();
        let mut out = Vec::with_capacity(n);
        for (i, pred) in preds.iter().enumerate() {
            out.push(localizer.localize_live_features(
                &mut state,
                &features.features[i],
                features.retry_of(i),
                pred,
                times(i),
            )?);
            bar.inc(1);
        }
        bar.finish_and_clear();
        return Ok(out);
    }
    let chosen: Vec<usize> = match choice {
        ZoneChoice::PerFrame | ZoneChoice::Live => preds.iter().map(|p| p.zone).collect(),
        ZoneChoice::Viterbi => viterbi(
            preds,
            localizer.classifier().zone_count(),
            &localizer.config().temporal,
        ),
        ZoneChoice::Smooth => {
            let clf = localizer.classifier();
            let distances: Vec<Vec<f32>> = preds
                .par_iter()
                .map(|p| clf.frame_distances(&p.descriptor))
                .collect::<Result<_, _>>()?;
            endoloc_net::track::smooth(&distances, &clf.zones().zone_of_frame, &clf.config().track)?
                .iter()
                .map(|e| e.zone)
                .collect()
        }
    };
    let bar = bar(progress, n as u64, "localize");
    let results: Result<Vec<FrameResult>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let r = localizer.localize_features(
                &features.features[i],
                features.retry_of(i),
                &preds[i],
                chosen[i],
                times(i),
            );
            bar.inc(1);
            Ok(r?)
        })
        .collect();
    bar.finish_and_clear();
    results
}

/// The output of one method on the test sequence.
pub(super) struct MethodOutput {
    /// Short name (folder name and table row).
    pub name: String,
    /// One line on what it is.
    pub description: String,
    /// Estimated pose per test frame (`None`: not localized).
    pub poses: Vec<Option<Pose>>,
    /// Our method's per-frame results (status, zone, inliers, times), when it is ours.
    pub results: Option<Vec<FrameResult>>,
    /// Median time per frame, ms.
    pub ms_per_frame: f64,
}

impl MethodOutput {
    pub fn from_results(name: &str, description: &str, results: Vec<FrameResult>) -> Self {
        let mut t: Vec<f64> = results.iter().map(|r| r.times.total_ms()).collect();
        t.sort_by(f64::total_cmp);
        Self {
            name: name.into(),
            description: description.into(),
            poses: results.iter().map(|r| r.t_wc).collect(),
            ms_per_frame: t.get(t.len() / 2).copied().unwrap_or(f64::NAN),
            results: Some(results),
        }
    }
}

/// What an experiment wrote: its rows (the figures), the table shown to the user and the
/// files in its output folder.
#[derive(Debug, Clone)]
pub struct ExperimentReport<R> {
    /// One row per method, run or offset.
    pub rows: Vec<R>,
    /// The rows as a markdown table.
    pub table: String,
    /// The output folder.
    pub out: PathBuf,
    /// The files written into it (tables, plots, report).
    pub files: Vec<&'static str>,
}

impl<R> std::fmt::Display for ExperimentReport<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "\n{}", self.table.trim_end())?;
        if self.files.is_empty() {
            return Ok(());
        }
        write!(
            f,
            "\nwrote     {}/{}",
            self.out.display(),
            self.files.join(", ")
        )
    }
}

/// One method's figures on the test sequence (errors over the frames it localizes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MethodRow {
    /// Short name (folder name and table row).
    pub method: String,
    /// One line on what it is.
    pub description: String,
    /// Test frames.
    pub frames: usize,
    /// Frames with a pose.
    pub localized: usize,
    /// Frames `refined` (our method only).
    pub refined: Option<usize>,
    /// Mean position error, mm.
    pub mean_position_mm: Option<f64>,
    /// Median position error, mm.
    pub median_position_mm: Option<f64>,
    /// Mean orientation error, degrees.
    pub mean_orientation_deg: Option<f64>,
    /// Median orientation error, degrees.
    pub median_orientation_deg: Option<f64>,
    /// Mean position error over the `refined` frames only (our method), mm.
    pub refined_mean_position_mm: Option<f64>,
    /// Mean orientation error over the `refined` frames only (our method), degrees.
    pub refined_mean_orientation_deg: Option<f64>,
    /// Median time per frame, ms.
    pub ms_per_frame: f64,
    /// Median position error over the `refined` frames only (our method), mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_median_position_mm: Option<f64>,
    /// `refined` frames more than 5 mm from the truth (our method): wrong poses flagged as
    /// right.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_over_5mm: Option<usize>,
    /// `refined` frames whose position error is within their stated 95 % bound,
    /// [`BOUND95_PER_STD`](endoloc_geometry::BOUND95_PER_STD) × `position_std_mm` (our
    /// method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_within_bound: Option<usize>,
    /// Median error along the colon over the localized frames, mm of mid-line (when the
    /// dataset has a mid-line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub median_along_mm: Option<f64>,
    /// Fraction of frames whose zone (`frames.csv`) is within one of the true zone (our
    /// method, when the true zones are known).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zone_within_one: Option<f64>,
}

/// What is known of the test pass beyond its poses, for [`write_and_evaluate`]: the colon's
/// mid-line (the error along the colon) and each frame's true zone (zone accuracy).
#[derive(Default)]
pub(super) struct Truth {
    pub midline: Option<endoloc_eval::Midline>,
    pub zones: Option<Vec<endoloc_eval::ZoneLabel>>,
}

impl Truth {
    /// The mid-line of the dataset in `dir` (when it has one) and the true zone of every test
    /// frame under `classifier`'s zones (the zone its anatomical pose lies in).
    pub fn of(dir: &Path, test: &Sequence, classifier: &ZoneClassifier) -> Result<Self> {
        let midline = match Dataset::open(dir)?.midline_path() {
            Some(p) => Some(
                endoloc_eval::Midline::from_file(&p)
                    .with_context(|| format!("reading the mid-line of {}", dir.display()))?,
            ),
            None => None,
        };
        let zones = test
            .poses
            .iter()
            .enumerate()
            .filter_map(|(frame, p)| {
                classifier
                    .truth_zone(&p.pose)
                    .map(|zone| endoloc_eval::ZoneLabel { frame, zone })
            })
            .collect();
        Ok(Truth {
            midline,
            zones: Some(zones),
        })
    }
}

/// Writes `dir/trajectory.txt` (and `frames.csv` for our method), evaluates against the
/// ground truth into `dir/eval/` (metrics.json, report, plots) and returns the row.
pub(super) fn write_and_evaluate(
    dir: &Path,
    seq: &Sequence,
    out: &MethodOutput,
    truth: &Truth,
) -> Result<MethodRow> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let est: Vec<StampedPose> = out
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
    endoloc_data::write_tum(&dir.join("trajectory.txt"), &est)?;
    let frames: Option<Vec<FrameRecord>> = out
        .results
        .as_deref()
        .map(endoloc_jobs::localize::frame_records);
    if let Some(f) = &frames {
        write_frames_csv(&dir.join("frames.csv"), f)?;
    }
    let mut row = MethodRow {
        method: out.name.clone(),
        description: out.description.clone(),
        frames: seq.len(),
        localized: est.len(),
        refined: out
            .results
            .as_ref()
            .map(|rs| rs.iter().filter(|r| r.status == Status::Refined).count()),
        mean_position_mm: None,
        median_position_mm: None,
        mean_orientation_deg: None,
        median_orientation_deg: None,
        refined_mean_position_mm: None,
        refined_mean_orientation_deg: None,
        ms_per_frame: out.ms_per_frame,
        refined_median_position_mm: None,
        refined_over_5mm: None,
        refined_within_bound: None,
        median_along_mm: None,
        zone_within_one: None,
    };
    if est.is_empty() {
        return Ok(row);
    }
    let evaluation = evaluate(
        &EvalInputs {
            gt: &seq.poses,
            est: &est,
            frames: frames.as_deref(),
            gt_zones: truth.zones.as_deref().filter(|_| frames.is_some()),
            midline: truth.midline.as_ref(),
        },
        &EvalConfig::default(),
    )
    .with_context(|| format!("evaluating {}", out.name))?;
    let m = &evaluation.metrics;
    row.median_along_mm = m.along_colon_mm.as_ref().map(|a| a.median);
    row.zone_within_one = m.zone_within_one;
    if let Some(records) = &frames {
        let std_mm: std::collections::HashMap<usize, f64> = records
            .iter()
            .filter_map(|r| Some((r.frame, r.position_std_mm?)))
            .collect();
        let (mut over, mut within) = (0, 0);
        evaluation.for_each_frame(|f| {
            if f.status != Some(Status::Refined) {
                return Ok(());
            }
            let Some(e) = f.position_mm else {
                return Ok(());
            };
            over += usize::from(e > 5.0);
            within += usize::from(
                std_mm
                    .get(&f.frame)
                    .is_some_and(|s| e <= endoloc_geometry::BOUND95_PER_STD * s),
            );
            Ok(())
        })?;
        row.refined_over_5mm = Some(over);
        row.refined_within_bound = Some(within);
    }
    row.mean_position_mm = Some(m.position_mm.mean);
    row.median_position_mm = Some(m.position_mm.median);
    row.mean_orientation_deg = Some(m.orientation_deg.mean);
    row.median_orientation_deg = Some(m.orientation_deg.median);
    if let Some(r) = m.by_status.get("refined") {
        row.refined_mean_position_mm = Some(r.position_mm.mean);
        row.refined_mean_orientation_deg = Some(r.orientation_deg.mean);
        row.refined_median_position_mm = Some(r.position_mm.median);
    }
    endoloc_eval::write_results(
        &evaluation,
        &dir.join("eval"),
        &WriteOptions {
            force: true,
            no_plots: false,
            plot: Default::default(),
            sources: Sources {
                gt: seq.dir.join("poses.txt").display().to_string(),
                est: dir.join("trajectory.txt").display().to_string(),
                frames: frames
                    .as_ref()
                    .map(|_| dir.join("frames.csv").display().to_string()),
                gt_zones: None,
            },
        },
    )?;
    Ok(row)
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".into(), |x| format!("{x:.digits$}"))
}

fn pct(part: usize, whole: usize) -> String {
    format!("{:.1}", 100.0 * part as f64 / whole.max(1) as f64)
}

const HEADER: [&str; 9] = [
    "method",
    "mean pos (mm)",
    "median pos (mm)",
    "mean rot (°)",
    "median rot (°)",
    "localized (%)",
    "refined (%)",
    "refined: mean pos (mm) / rot (°)",
    "ms / frame",
];

fn cells(r: &MethodRow) -> Vec<String> {
    vec![
        r.method.clone(),
        opt(r.mean_position_mm, 2),
        opt(r.median_position_mm, 2),
        opt(r.mean_orientation_deg, 2),
        opt(r.median_orientation_deg, 2),
        pct(r.localized, r.frames),
        r.refined.map_or("—".into(), |k| pct(k, r.frames)),
        match (r.refined_mean_position_mm, r.refined_mean_orientation_deg) {
            (Some(p), Some(o)) => format!("{p:.2} / {o:.2}"),
            _ => "—".into(),
        },
        format!("{:.1}", r.ms_per_frame),
    ]
}

/// The rows as a markdown table.
pub(super) fn markdown_table(rows: &[MethodRow]) -> String {
    let mut s = format!("| {} |\n", HEADER.join(" | "));
    s.push_str(&format!("|{}\n", "---|".repeat(HEADER.len())));
    for r in rows {
        s.push_str(&format!("| {} |\n", cells(r).join(" | ")));
    }
    s
}

/// The rows as an HTML table block.
pub(super) fn html_table(rows: &[MethodRow]) -> Block {
    Block::Table {
        header: HEADER.iter().map(|s| s.to_string()).collect(),
        rows: rows.iter().map(cells).collect(),
    }
}

/// The rows as bars for [`endoloc_eval::plot_method_bars`].
pub(super) fn bars(rows: &[MethodRow]) -> Vec<MethodBar> {
    rows.iter()
        .map(|r| MethodBar {
            name: r.method.clone(),
            mean_position_mm: r.mean_position_mm,
            median_position_mm: r.median_position_mm,
            mean_orientation_deg: r.mean_orientation_deg,
            median_orientation_deg: r.median_orientation_deg,
        })
        .collect()
}

/// Writes text to `path` atomically.
pub(super) fn write_text(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    write_atomic(path, text.as_bytes())?;
    Ok(())
}

/// Reads a PNG for embedding (a missing plot is reported, not fatal).
pub(super) fn image_block(path: &Path, caption: &str, progress: &dyn Progress) -> Option<Block> {
    match std::fs::read(path) {
        Ok(png) => Some(Block::Image {
            caption: caption.into(),
            png,
        }),
        Err(e) => {
            note!(progress, "warning: {} not embedded: {e}", path.display());
            None
        }
    }
}

/// Refuses to work in a folder that holds another experiment's results unless `--force`,
/// before any input is read ([`create_out`] makes it once the inputs open).
pub(super) fn prepare_out(out: &Path, marker: &str, force: bool) -> Result<()> {
    if out.exists() && !force {
        // The marker file, or the tag `create_out` leaves at once (a run killed before its
        // first result is resumed too).
        let tagged =
            std::fs::read_to_string(out.join(EXPERIMENT_TAG)).is_ok_and(|t| t.trim() == marker);
        let is_same = out.join(marker).is_file() || tagged;
        let empty = std::fs::read_dir(out)
            .map(|mut d| d.next().is_none())
            .unwrap_or(false);
        if !is_same && !empty {
            bail!(
                "{} exists and is not a `{}` experiment folder; choose another `out` or set `force`",
                out.display(),
                marker.trim_end_matches(".toml")
            );
        }
    }
    Ok(())
}

/// Hidden file that says which experiment a folder belongs to (its marker's name).
const EXPERIMENT_TAG: &str = ".endoloc-experiment";

/// Creates the output folder that [`prepare_out`] allowed, once the inputs have been opened
/// (bad input leaves no folder behind), tagged with the experiment's `marker` so that a run
/// killed before its first result can be resumed.
pub(super) fn create_out(out: &Path, marker: &str) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    endoloc_data::write_atomic(&out.join(EXPERIMENT_TAG), format!("{marker}\n").as_bytes())?;
    Ok(())
}

/// `s` as one shell word: unchanged when it is plain, single-quoted otherwise.
pub(super) fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=,:+".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// Position error (mm) and orientation error (degrees, geodesic angle of `R_estᵀ R_gt`) of
/// one estimate, as `endoloc eval` computes them.
pub(super) fn pose_error(est: &Pose, gt: &Pose) -> (f64, f64) {
    (
        endoloc_geometry::position_error_mm(est, gt),
        endoloc_geometry::orientation_error_deg(est, gt),
    )
}
