//! The baselines of the paper's Table I that need more than the zone classifier: PoseNet and
//! OffsetNet (trained on the same training pass and backbone) and monocular visual
//! odometry. Used by `TrainJob` (`method`), `LocalizeJob` (`method`) and the `compare`
//! experiment.

use std::path::Path;
use std::time::Instant;

use crate::bail;
use crate::error::{Context, Result};
use endoloc_data::Sequence;
use endoloc_geometry::{Camera, Pose};
use endoloc_net::ZonePrediction;
use endoloc_net::regress::{
    OffsetNetModel, PoseNetModel, RegressConfig, RegressPhase, TrainingSet, train_offsetnet,
    train_posenet,
};
use endoloc_vo::{VisualOdometry, VoConfig};
use rayon::prelude::*;

use crate::progress::{Progress, bar};

/// A learned regression baseline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Regressor {
    /// PoseNet: absolute pose regression.
    PoseNet,
    /// OffsetNet: relative pose from a reference image.
    OffsetNet,
}

impl Regressor {
    /// Lower-case name (`posenet`, `offsetnet`).
    pub fn name(self) -> &'static str {
        match self {
            Regressor::PoseNet => "posenet",
            Regressor::OffsetNet => "offsetnet",
        }
    }
}

/// How a regression baseline is trained.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RegressorSettings {
    /// Epochs (`None`: the schedule's).
    pub epochs: Option<usize>,
    /// Seed of every random step.
    pub seed: u64,
    /// Replace an existing model folder.
    pub force: bool,
}

/// Poses estimated by a baseline for every test frame (`None`: no pose) and the time per
/// frame, ms.
#[derive(Debug, Clone)]
pub struct Estimates {
    /// `T_wc` per test frame, mm.
    pub poses: Vec<Option<Pose>>,
    /// Mean time per frame, ms.
    pub ms_per_frame: f64,
    /// A line for the user (e.g. where VO lost track).
    pub note: Option<String>,
}

/// Trains PoseNet or OffsetNet on `train` and writes the model folder `out` (refused when it
/// exists, unless `force`). `epochs`: `None` for the schedule's default. Returns the training
/// time, seconds.
pub fn train_regressor(
    which: Regressor,
    train: &Sequence,
    camera: &Camera,
    out: &Path,
    settings: RegressorSettings,
    progress: &dyn Progress,
) -> Result<f64> {
    let RegressorSettings {
        epochs,
        seed,
        force,
    } = settings;
    crate::output::refuse_existing(out, force, "")?;
    let mut cfg = RegressConfig {
        seed,
        ..RegressConfig::default()
    };
    if let Some(e) = epochs {
        cfg.schedule.epochs = e;
    }
    let loading = bar(progress, train.len() as u64, "load");
    let set =
        TrainingSet::from_sequence(train, camera, cfg.backbone.input(), &mut |_| loading.inc(1))?;
    loading.finish_and_clear();
    let bar = bar(progress, 1, which.name());
    let t = Instant::now();
    match which {
        Regressor::PoseNet => {
            train_posenet(&cfg, &set, &mut on_progress(&bar))?.save(out, force)?;
        }
        Regressor::OffsetNet => {
            train_offsetnet(&cfg, &set, &mut on_progress(&bar))?.save(out, force)?;
        }
    }
    bar.finish_and_clear();
    Ok(t.elapsed().as_secs_f64())
}

/// Shows training progress (steps done of the total, the loss) on `bar`.
fn on_progress<'a>(
    bar: &'a crate::progress::Bar<'_>,
) -> impl FnMut(&endoloc_net::regress::RegressProgress) + 'a {
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

/// PoseNet's pose for every frame of `test`.
pub fn posenet(model: &Path, test: &Sequence, progress: &dyn Progress) -> Result<Estimates> {
    let model = PoseNetModel::load(model)
        .with_context(|| format!("loading PoseNet model {}", model.display()))?;
    let t = Instant::now();
    let poses = predict_batched(test, "posenet", progress, |imgs| {
        Ok(model.predict_batch(imgs)?)
    })?;
    Ok(Estimates {
        poses: poses.into_iter().map(Some).collect(),
        ms_per_frame: t.elapsed().as_secs_f64() * 1e3 / test.len().max(1) as f64,
        note: None,
    })
}

/// OffsetNet's pose for every frame of `test`: the reference is the training frame the
/// Siamese classifier retrieved for it (`preds[i].nearest_frame`, its nearest descriptor),
/// and the pose is `T_ref ∘ offset`. `zone_ms`: the retrieval's time per frame, added.
pub fn offsetnet(
    model: &Path,
    train: &Sequence,
    test: &Sequence,
    preds: &[ZonePrediction],
    zone_ms: f64,
    progress: &dyn Progress,
) -> Result<Estimates> {
    let model = OffsetNetModel::load(model)
        .with_context(|| format!("loading OffsetNet model {}", model.display()))?;
    if preds.len() != test.len() {
        bail!(
            "{} zone predictions for {} test frames",
            preds.len(),
            test.len()
        );
    }
    let bar = bar(progress, test.len() as u64, "offsetnet");
    let t = Instant::now();
    let poses: Result<Vec<Option<Pose>>> = (0..test.len())
        .into_par_iter()
        .map(|i| {
            let r = preds[i].nearest_frame;
            let Some(t_ref) = train.poses.get(r).map(|p| p.pose) else {
                return Ok(None);
            };
            let reference = train.load_gray(r)?;
            let img = test.load_gray(i)?;
            let p = model
                .predict(&img, &reference, &t_ref)
                .with_context(|| format!("offsetnet on test frame {i}"))?;
            bar.inc(1);
            Ok(Some(p))
        })
        .collect();
    bar.finish_and_clear();
    Ok(Estimates {
        poses: poses?,
        ms_per_frame: zone_ms + t.elapsed().as_secs_f64() * 1e3 / test.len().max(1) as f64,
        note: None,
    })
}

/// Monocular visual odometry over `test`, frames in order; each tracked segment is aligned
/// to the ground truth by its first pose, with the scale from the ground truth (as the paper
/// did for ORB-SLAM and DSO). The note says where it lost track. With `mask`, SURF stays
/// inside the image's valid area.
pub fn vo(
    camera: &Camera,
    mask: Option<std::sync::Arc<endoloc_features::Mask>>,
    test: &Sequence,
    progress: &dyn Progress,
) -> Result<Estimates> {
    let mut vo = VisualOdometry::new(*camera, VoConfig::default())?.with_mask(mask);
    let bar = bar(progress, test.len() as u64, "vo");
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
    Ok(Estimates {
        poses: report.t_wc,
        ms_per_frame: ms,
        note: Some(note),
    })
}

/// Runs `predict` over the test frames in batches of 64 (images decoded on all cores).
fn predict_batched(
    seq: &Sequence,
    what: &str,
    progress: &dyn Progress,
    predict: impl Fn(&[image::GrayImage]) -> Result<Vec<Pose>>,
) -> Result<Vec<Pose>> {
    let bar = bar(progress, seq.len() as u64, what);
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
