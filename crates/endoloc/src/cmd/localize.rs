//! `endoloc map` and `endoloc localize`: the geometric half of the method.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::{LocalizeJob, LocalizeMethod, MapJob, Progress};

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
    model: PathBuf,
    /// Dataset the model was trained on.
    #[arg(long, value_name = "DIR")]
    data: PathBuf,
    /// Training sequence inside the dataset.
    #[arg(long, default_value_t = MapJob::default().seq)]
    seq: String,
    /// Images per zone (the paper's m ≥ 3).
    #[arg(long, default_value_t = MapJob::default().images_per_zone)]
    images_per_zone: usize,
    /// SURF threshold of the map (units of MATLAB's MetricThreshold; the paper's 200 suits
    /// larger, richer images). Test frames are described at twice it and retried at it.
    #[arg(long, default_value_t = MapJob::default().threshold)]
    threshold: f32,
    /// δr: drop map points reprojecting farther than this, pixels.
    #[arg(long, default_value_t = MapJob::default().delta_r_px)]
    delta_r: f64,
    /// Every other training frame of a zone also looks for the zone's map points (projected
    /// with its known pose, matched within this many pixels, e.g. 3), and each point is
    /// triangulated again from all its observations: sharper points, a longer build (SURF on
    /// every training frame). 0 (default) = only the --images-per-zone images.
    #[arg(long, default_value_t = MapJob::default().observation_radius_px)]
    observation_radius: f64,
    /// Replace an existing map.
    #[arg(long)]
    force: bool,
}

impl From<MapArgs> for MapJob {
    fn from(a: MapArgs) -> Self {
        MapJob {
            model: a.model,
            data: a.data,
            seq: a.seq,
            images_per_zone: a.images_per_zone,
            threshold: a.threshold,
            delta_r_px: a.delta_r,
            observation_radius_px: a.observation_radius,
            force: a.force,
        }
    }
}

/// Runs `endoloc map`.
pub fn run_map(args: MapArgs, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&MapJob::from(args).run(ui)?)?;
    Ok(())
}

/// Localize every frame of a sequence: zone (Siamese classifier) → initial pose = zone median
/// → SURF matched to the zone's map points → Gauss-Newton on SE(3) → validity check.
/// Writes trajectory.txt (TUM, T_wc, mm; one line per frame that has a pose) and frames.csv
/// (frame, zone, zone score, status refined|init_only|rejected, reason, inliers,
/// reprojection RMS, time) into --out. Then `endoloc eval --gt SEQ/poses.txt --est
/// OUT/trajectory.txt` gives the errors.
///
/// Examples:
///
///   endoloc localize --model models/small --seq data/small/test --out runs/small
///
///   endoloc localize --model models/small --seq data/small/test --out runs/live --live
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct LocalizeArgs {
    /// Method: `endoloc` (the two-step method) or a baseline of the paper's Table I:
    /// `classify` (zone median pose), `retrieval` (pose of the nearest training image),
    /// `posenet` (--model is a PoseNet folder from `endoloc train --method posenet`),
    /// `offsetnet` (--model the Siamese model for retrieval, --regressor the OffsetNet folder,
    /// --reference-seq the training sequence) or `vo` (monocular visual odometry; the first
    /// pose and the scale come from the sequence's poses.txt). Baselines write trajectory.txt
    /// only.
    #[arg(long, value_enum, default_value = "endoloc")]
    method: Method,
    /// Model folder (trained, with its map).
    #[arg(long, value_name = "DIR")]
    model: Option<PathBuf>,
    /// Ensemble: join this zone model to --model (same training pass and zones; repeat for
    /// more). The map is --model's.
    #[arg(long, value_name = "DIR")]
    also_model: Vec<PathBuf>,
    /// OffsetNet model folder (--method offsetnet).
    #[arg(long, value_name = "DIR")]
    regressor: Option<PathBuf>,
    /// Training sequence folder holding the reference images (--method offsetnet).
    #[arg(long, value_name = "DIR")]
    reference_seq: Option<PathBuf>,
    /// Sequence folder to localize (images/ and, for evaluation, poses.txt), e.g. data/small/test.
    #[arg(long, value_name = "DIR")]
    seq: PathBuf,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Live mode: frames one at a time, in order, as a scope delivers them (causal zone
    /// filter, no look-ahead). After a refined frame the next one is first registered from
    /// that pose (see --track-frames).
    #[arg(long)]
    live: bool,
    /// Live mode: frames a refined pose stays usable as the next frames' prior (0: every frame
    /// starts from its zone's median pose, as in the paper).
    #[arg(long, default_value_t = LocalizeJob::default().track_frames)]
    track_frames: usize,
    /// Live mode: for this many frames after a refined one, frames that register nowhere else
    /// also try the zones around it (one behind, two ahead); 0: off.
    #[arg(long, default_value_t = LocalizeJob::default().recover_frames)]
    recover_frames: usize,
    /// Live mode: the motion model (damped constant velocity) predicts the pose for at most
    /// this many frames after the last refined one; an init_only frame reports that
    /// prediction instead of its zone's median, and weak registrations must agree with it;
    /// 0: always the zone median, no gate.
    #[arg(long, default_value_t = LocalizeJob::default().hold_frames)]
    hold_frames: usize,
    /// Live mode: run the zone classifier on every frame. By default a frame registered from
    /// the motion model's prediction is not classified (its zone is the one its pose lies in,
    /// its zone score empty in frames.csv): the classifier runs only when tracking fails.
    #[arg(long)]
    classify_every_frame: bool,
    /// Live mode: a registration with at least this many inliers is trusted without the
    /// motion model's agreement (fewer: it must agree with the prediction, or be confirmed by
    /// the next frame's registration).
    #[arg(long, default_value_t = LocalizeJob::default().trusted_inliers)]
    trusted_inliers: usize,
    /// Live mode: base radius of the motion gate around the predicted camera centre, mm
    /// (grows by 1 mm per frame since the last refined one).
    #[arg(long, default_value_t = LocalizeJob::default().gate_mm)]
    gate_mm: f64,
    /// Map points also come from this many zones on each side of the classified one.
    #[arg(long, default_value_t = LocalizeJob::default().neighbours)]
    neighbours: usize,
    /// SURF threshold on the test frames (default: twice the map's).
    #[arg(long)]
    threshold: Option<f32>,
    /// A frame that registers nowhere is described again at this lower SURF threshold and
    /// tried once more (default: the map's threshold; 0: off).
    #[arg(long)]
    retry_threshold: Option<f32>,
    /// Keep at most this many SURF keypoints per test frame, the strongest (0: all).
    #[arg(long, default_value_t = 0)]
    max_keypoints: usize,
    /// Zones tried (best classifier score first) until one registers; 1 = trust the top zone
    /// as the paper does.
    #[arg(long, default_value_t = LocalizeJob::default().candidate_zones)]
    candidate_zones: usize,
    /// Validity: largest predicted position uncertainty (1σ, mm) of a refined pose; frames
    /// above it keep the zone's median pose as `init_only` (degenerate_geometry).
    #[arg(long, default_value_t = LocalizeJob::default().max_sigma_mm)]
    max_sigma_mm: f64,
    /// Per frame: largest stated position uncertainty (the frames.csv standard deviation,
    /// mm) of a refined frame; above it the frame is `init_only` (uncertain) and keeps its
    /// registered pose (source `registered`). Default: no limit; 1.5 with
    /// --weak-max-std-mm 0.75 suits 640×480 frames.
    #[arg(long, default_value_t = LocalizeJob::default().max_std_mm)]
    max_std_mm: f64,
    /// Per frame: as --max-std-mm, for registrations with fewer than --trusted-inliers
    /// inliers.
    #[arg(long, default_value_t = LocalizeJob::default().weak_max_std_mm)]
    weak_max_std_mm: f64,
    #[command(flatten)]
    confirm: ConfirmArgs,
    /// Validity: largest RMS reprojection error of the inliers, pixels.
    #[arg(long, default_value_t = LocalizeJob::default().max_rms_px)]
    max_rms_px: f64,
    /// Validity: largest jump from the prior (the zone's median pose, or in live mode the last
    /// refined pose), mm.
    #[arg(long, default_value_t = LocalizeJob::default().max_jump_mm)]
    max_jump_mm: f64,
    /// Scale of the Cauchy kernel of the final polish on the inliers, pixels: map points are
    /// now and then a pixel or two off where a new view sees them, and the kernel all but
    /// ignores those. 0: least squares on the inliers.
    #[arg(long, default_value_t = LocalizeJob::default().polish_px)]
    polish_px: f64,
    /// Stop at the first image that cannot be read (for batch checks) instead of
    /// reporting the frame as `rejected` (reason `unreadable_image`) and going on.
    #[arg(long)]
    strict: bool,
    /// Replace existing results in --out.
    #[arg(long)]
    force: bool,
}

/// `--method` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// The two-step method (zone, then SURF map matching and Gauss-Newton).
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

impl From<Method> for LocalizeMethod {
    fn from(m: Method) -> Self {
        match m {
            Method::Endoloc => LocalizeMethod::Endoloc,
            Method::Classify => LocalizeMethod::Classify,
            Method::Retrieval => LocalizeMethod::Retrieval,
            Method::Posenet => LocalizeMethod::Posenet,
            Method::Offsetnet => LocalizeMethod::Offsetnet,
            Method::Vo => LocalizeMethod::Vo,
        }
    }
}

impl From<LocalizeArgs> for LocalizeJob {
    fn from(a: LocalizeArgs) -> Self {
        LocalizeJob {
            method: a.method.into(),
            model: a.model,
            also_model: a.also_model,
            regressor: a.regressor,
            reference_seq: a.reference_seq,
            seq: a.seq,
            out: a.out,
            live: a.live,
            track_frames: a.track_frames,
            recover_frames: a.recover_frames,
            hold_frames: a.hold_frames,
            classify_every_frame: a.classify_every_frame,
            trusted_inliers: a.trusted_inliers,
            gate_mm: a.gate_mm,
            neighbours: a.neighbours,
            threshold: a.threshold,
            retry_threshold: a.retry_threshold,
            max_keypoints: a.max_keypoints,
            candidate_zones: a.candidate_zones,
            max_sigma_mm: a.max_sigma_mm,
            max_std_mm: a.max_std_mm,
            weak_max_std_mm: a.weak_max_std_mm,
            confirm: a.confirm.on(),
            max_rms_px: a.max_rms_px,
            max_jump_mm: a.max_jump_mm,
            polish_px: a.polish_px,
            strict: a.strict,
            force: a.force,
        }
    }
}

/// Runs `endoloc localize`.
pub fn run_localize(args: LocalizeArgs, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&LocalizeJob::from(args).run(ui)?)?;
    Ok(())
}

/// Whether registrations are confirmed against the map: `--no-confirm` and its pair
/// `--confirm` (the default), shared by `localize` and `bench live`.
#[derive(Debug, clap::Args)]
pub struct ConfirmArgs {
    /// Do not confirm registrations against the map. By default every registration (live:
    /// every one not tracked from the prediction with 50 inliers or more) is checked against
    /// all map points near its pose, matched in shrinking windows around their projections,
    /// and refined again from them: sharper poses, and one that few of them support is
    /// `init_only` (unsupported) with its registered pose (source `registered`); live, the
    /// motion model keeps the translation undamped through frames that register nowhere.
    /// With --no-confirm a frame takes about 10 % less time live and 30 % less per frame, and
    /// wrong `refined` poses are far more common.
    #[arg(long, overrides_with = "confirm")]
    no_confirm: bool,
    /// Confirm registrations against the map (the default; see --no-confirm).
    #[arg(long, overrides_with = "no_confirm")]
    confirm: bool,
}

impl ConfirmArgs {
    /// Whether confirmation is on (the default; `--no-confirm` turns it off).
    pub fn on(&self) -> bool {
        !self.no_confirm
    }
}
