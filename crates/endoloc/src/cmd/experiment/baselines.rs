//! The baselines of `experiment compare` that need more than the zone classifier: PoseNet and
//! OffsetNet (trained here, on the same training pass and backbone, kept under
//! `OUT/models/`) and monocular visual odometry.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use endoloc_data::{Dataset, Sequence};
use endoloc_geometry::Pose;
use endoloc_net::ZonePrediction;
use endoloc_net::regress::{
    OffsetNetModel, PoseNetModel, RegressConfig, RegressPhase, TrainingSet, train_offsetnet,
    train_posenet,
};
use endoloc_vo::{VisualOdometry, VoConfig};
use rayon::prelude::*;

use super::common::{Data, MethodOutput};
use crate::ui;

/// What the baselines need.
pub(super) struct Inputs<'a> {
    pub data: &'a Data,
    /// The Siamese classifier's predictions for the test frames (OffsetNet's retrieval).
    pub preds: &'a [ZonePrediction],
    /// Time per frame of those predictions, ms.
    pub zone_ms: f64,
    /// Folder of the experiment's models.
    pub models: &'a Path,
    /// Training epochs (`None`: each schedule's default).
    pub epochs: Option<usize>,
    /// Training seed.
    pub seed: u64,
}

fn train_sequence(data: &Data) -> Result<(Sequence, endoloc_geometry::Camera)> {
    let ds = Dataset::open(&data.dir)?;
    let camera = ds.meta.camera;
    Ok((ds.sequence(&data.train_name)?, camera))
}

fn regress_config(inputs: &Inputs<'_>) -> RegressConfig {
    let mut cfg = RegressConfig {
        seed: inputs.seed,
        ..RegressConfig::default()
    };
    if let Some(e) = inputs.epochs {
        cfg.schedule.epochs = e;
    }
    cfg
}

fn training_set(inputs: &Inputs<'_>, cfg: &RegressConfig) -> Result<TrainingSet> {
    let (train, camera) = train_sequence(inputs.data)?;
    let bar = ui::progress_bar(train.len() as u64, "load");
    let set =
        TrainingSet::from_sequence(&train, &camera, cfg.backbone.input(), &mut |_| bar.inc(1))?;
    bar.finish_and_clear();
    Ok(set)
}

fn progress_bar(what: &str) -> indicatif::ProgressBar {
    ui::progress_bar(1, what)
}

/// Shows training progress (steps done of the total, the loss) on `bar`.
fn on_progress(
    bar: &indicatif::ProgressBar,
) -> impl FnMut(&endoloc_net::regress::RegressProgress) + '_ {
    move |p| {
        if p.phase == RegressPhase::Training {
            bar.set_length(p.total as u64);
            bar.set_position(p.done as u64);
            if let Some(l) = p.loss {
                bar.set_message(format!("loss {l:.3}"));
            }
        }
    }
}

/// PoseNet: trains (or reuses) `models/posenet`, then regresses every test pose.
pub(super) fn posenet(inputs: &Inputs<'_>) -> Result<MethodOutput> {
    let dir = inputs.models.join("posenet");
    let model = if dir.join("regress.toml").is_file() {
        eprintln!("reusing   model {}", dir.display());
        PoseNetModel::load(&dir)?
    } else {
        let cfg = regress_config(inputs);
        let set = training_set(inputs, &cfg)?;
        let bar = progress_bar("posenet");
        let t = Instant::now();
        let model = train_posenet(&cfg, &set, &mut on_progress(&bar))?;
        bar.finish_and_clear();
        eprintln!("trained   posenet in {:.0} s", t.elapsed().as_secs_f64());
        model.save(&dir, false)?;
        model
    };
    let test = &inputs.data.test;
    let t = Instant::now();
    let poses = predict_batched(test, "posenet", |imgs| Ok(model.predict_batch(imgs)?))?;
    Ok(MethodOutput {
        name: "posenet".into(),
        description: "PoseNet pose regression (Kendall et al. 2015)".into(),
        poses: poses.into_iter().map(Some).collect(),
        results: None,
        ms_per_frame: t.elapsed().as_secs_f64() * 1e3 / test.len().max(1) as f64,
    })
}

/// OffsetNet: trains (or reuses) `models/offsetnet`; the reference of a test frame is the
/// training frame the Siamese classifier retrieved (its nearest descriptor), and the pose is
/// `T_ref ∘ offset`.
pub(super) fn offsetnet(inputs: &Inputs<'_>) -> Result<MethodOutput> {
    let dir = inputs.models.join("offsetnet");
    let model = if dir.join("regress.toml").is_file() {
        eprintln!("reusing   model {}", dir.display());
        OffsetNetModel::load(&dir)?
    } else {
        let cfg = regress_config(inputs);
        let set = training_set(inputs, &cfg)?;
        let bar = progress_bar("offsetnet");
        let t = Instant::now();
        let model = train_offsetnet(&cfg, &set, &mut on_progress(&bar))?;
        bar.finish_and_clear();
        eprintln!("trained   offsetnet in {:.0} s", t.elapsed().as_secs_f64());
        model.save(&dir, false)?;
        model
    };
    let (train, _) = train_sequence(inputs.data)?;
    let test = &inputs.data.test;
    let bar = ui::progress_bar(test.len() as u64, "offsetnet");
    let t = Instant::now();
    let poses: Result<Vec<Option<Pose>>> = (0..test.len())
        .into_par_iter()
        .map(|i| {
            let pred = &inputs.preds[i];
            let r = pred.nearest_frame;
            let (Some(t_ref), Ok(reference)) =
                (train.poses.get(r).map(|p| p.pose), train.load_gray(r))
            else {
                return Ok(None);
            };
            let img = test.load_gray(i)?;
            let p = model
                .predict(&img, &reference, &t_ref)
                .with_context(|| format!("offsetnet on test frame {i}"))?;
            bar.inc(1);
            Ok(Some(p))
        })
        .collect();
    bar.finish_and_clear();
    Ok(MethodOutput {
        name: "offsetnet".into(),
        description: "OffsetNet relative pose to the retrieved image (Sganga et al. 2018)".into(),
        poses: poses?,
        results: None,
        ms_per_frame: inputs.zone_ms + t.elapsed().as_secs_f64() * 1e3 / test.len().max(1) as f64,
    })
}

/// Monocular visual odometry over the test pass, frames in order; each tracked segment is
/// aligned to the ground truth by its first pose, with the scale from the ground truth (as
/// the paper did for ORB-SLAM and DSO). Returns the output and a line on where it lost track.
pub(super) fn vo(inputs: &Inputs<'_>) -> Result<(MethodOutput, String)> {
    let ds = Dataset::open(&inputs.data.dir)?;
    let test = &inputs.data.test;
    let mut vo = VisualOdometry::new(ds.meta.camera, VoConfig::default())?;
    let bar = ui::progress_bar(test.len() as u64, "vo");
    let t = Instant::now();
    for i in 0..test.len() {
        let img = test.load_gray(i)?;
        vo.track(&img)
            .with_context(|| format!("VO on {}", test.image_paths[i].display()))?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let ms = t.elapsed().as_secs_f64() * 1e3 / test.len().max(1) as f64;
    let gt: Vec<Pose> = test.poses.iter().map(|p| p.pose).collect();
    let report = endoloc_vo::report(vo.frames(), &gt)?;
    let lost: Vec<String> = report.lost_at.iter().map(|i| i.to_string()).collect();
    let note = format!(
        "VO tracked {:.1} % of the frames in {} segment(s); lost track at frame(s) {}.",
        100.0 * report.tracked_fraction,
        report.segments.len(),
        if lost.is_empty() {
            "none".to_string()
        } else {
            lost.join(", ")
        }
    );
    Ok((
        MethodOutput {
            name: "vo".into(),
            description: "monocular SURF visual odometry, first pose and scale from the truth"
                .into(),
            poses: report.t_wc,
            results: None,
            ms_per_frame: ms,
        },
        note,
    ))
}

/// Runs `predict` over the test frames in batches of 64 (images decoded on all cores).
fn predict_batched(
    seq: &Sequence,
    what: &str,
    predict: impl Fn(&[image::GrayImage]) -> Result<Vec<Pose>>,
) -> Result<Vec<Pose>> {
    let bar = ui::progress_bar(seq.len() as u64, what);
    let mut out = Vec::with_capacity(seq.len());
    for start in (0..seq.len()).step_by(64) {
        let end = (start + 64).min(seq.len());
        let imgs: Result<Vec<_>> = (start..end)
            .into_par_iter()
            .map(|i| Ok(seq.load_gray(i)?))
            .collect();
        out.extend(predict(&imgs?)?);
        bar.inc((end - start) as u64);
    }
    bar.finish_and_clear();
    Ok(out)
}
