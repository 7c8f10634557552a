//! `LocalizeJob`: every frame of a sequence localized, by endoloc or a baseline.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use endoloc_data::stream::{FrameStream, PixelFormat};
use endoloc_data::{Dataset, Sequence, StampedPose};
use endoloc_features::Mask;
use endoloc_geometry::RobustKernel;
use endoloc_localize::colon_scale::ColonScaleConfig;
use endoloc_localize::map_io::{load_map, load_smoothed_level};
use endoloc_localize::{ConfirmConfig, FrameResult, Localizer, LocalizerConfig, MotionConfig};
use endoloc_net::ZoneClassifier;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

mod results;
mod stream;
mod summary;

pub use results::{
    FRAMES_FILE, INLIERS_FILE, ResultWriter, TRAJECTORY_FILE, frame_record, frame_records,
    inliers_csv, parse_inliers_csv, read_inliers_csv,
};
pub use stream::{STREAM_FILE, StreamSummary, StreamedFrame};
pub use summary::{LatencyHistogram, RunSummary};

use crate::bail;
use crate::baselines::{self, Estimates};
use crate::choice::Device;
use crate::error::{Context, JobError, Result};
use crate::predict::predict_zones;
use crate::progress::{Progress, bar};

/// A localization method: endoloc's, or a baseline of the paper's Table I.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum LocalizeMethod {
    /// The paper's two-step method (zone, then SURF map matching and Gauss-Newton).
    #[default]
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

impl LocalizeMethod {
    /// Lower-case name, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LocalizeMethod::Endoloc => "endoloc",
            LocalizeMethod::Classify => "classify",
            LocalizeMethod::Retrieval => "retrieval",
            LocalizeMethod::Posenet => "posenet",
            LocalizeMethod::Offsetnet => "offsetnet",
            LocalizeMethod::Vo => "vo",
        }
    }
}

/// Localizes every frame of a sequence and writes `trajectory.txt` (TUM, `T_wc`, mm; one line
/// per frame with a pose) and, for endoloc, `frames.csv` (one row per frame: zone, status,
/// reason, inliers, reprojection RMS, time) into `out`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct LocalizeJob {
    /// Method: `endoloc` (the two-step method) or a baseline of the paper's Table I:
    /// `classify` (zone median pose), `retrieval` (pose of the nearest training image),
    /// `posenet` (`model` is a PoseNet folder trained with the train job's `method` posenet),
    /// `offsetnet` (`model` the Siamese model for retrieval, `regressor` the OffsetNet folder,
    /// `reference_seq` the training sequence) or `vo` (monocular visual odometry; the first
    /// pose and the scale come from the sequence's poses.txt). Baselines write trajectory.txt
    /// only.
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value_t = LocalizeMethod::default()))]
    pub method: LocalizeMethod,
    /// Model folder (trained, with its map; for `posenet` the PoseNet folder).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub model: Option<PathBuf>,
    /// Ensemble: join this zone model to `model` (same training pass and zones; repeatable).
    /// The map is `model`'s.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub also_model: Vec<PathBuf>,
    /// OffsetNet model folder (method `offsetnet`).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub regressor: Option<PathBuf>,
    /// Training sequence folder holding the reference images (method `offsetnet`).
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub reference_seq: Option<PathBuf>,
    /// Sequence folder to localize (images/ and, for evaluation, poses.txt), e.g.
    /// data/small/test; or `video`.
    #[cfg_attr(
        feature = "cli",
        arg(
            long,
            value_name = "DIR",
            // Empty when `video` is given: a parser that takes the empty default.
            default_value = "",
            value_parser = |s: &str| Ok::<_, std::convert::Infallible>(PathBuf::from(s)),
            hide_default_value = true,
            required_unless_present = "video",
            conflicts_with = "video"
        )
    )]
    pub seq: PathBuf,
    /// Instead of `seq`: localize frames as they come, live, from a video file (decoded by
    /// FFmpeg while it is read, each frame resized to the model's camera; the frames must come
    /// from that camera) or, with `-`, raw frames on standard input (`size`, `pix_fmt`).
    /// trajectory.txt then holds the video's times (raw frames: seconds since the first), and
    /// stream.csv lists every frame of the source with its latency from arrival to pose.
    /// Needs `live`.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE|-", requires = "live"))]
    pub video: Option<PathBuf>,
    /// With `video`: frames arrive as a camera delivers them — a file paced at its frame
    /// times, raw frames on standard input as they come — and a frame that arrives before the
    /// last one was taken wins: the older one is dropped (listed in stream.csv), never queued.
    /// Without it every frame is localized, the source waiting for the localizer.
    #[cfg_attr(feature = "cli", arg(long, requires = "video"))]
    pub realtime: bool,
    /// Raw frames on standard input (`video` -): their size, WxH in pixels (resized to the
    /// model's camera; the aspect ratio must be the same).
    #[cfg_attr(feature = "cli", arg(long, value_name = "WxH", requires = "video"))]
    pub size: Option<String>,
    /// Raw frames on standard input: `gray8` (one byte per pixel) or `rgb24` (three: R G B).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "FORMAT", default_value_t = PixelFormat::default(), requires = "video")
    )]
    pub pix_fmt: PixelFormat,
    /// With `video`: the image mask of the frames — a dataset folder (its mask) or a mask PNG
    /// of the model's camera size, non-zero = valid (default: none).
    #[cfg_attr(feature = "cli", arg(long, value_name = "PATH", requires = "video"))]
    pub mask: Option<PathBuf>,
    /// The camera the frames come from when it is not the model's (another scope: another
    /// field of view, principal point or distortion): a TOML file with a `[camera]` table as
    /// in dataset.toml (width, height, fx, fy, cx, cy in pixels, optional
    /// `[camera.distortion]`). A camera of another size than the model's is scaled to it, as
    /// the frames are (the aspect ratio must be the same). Default: the sequence's own
    /// camera.toml when it has one, else the model's camera.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE"))]
    pub camera: Option<PathBuf>,
    /// Output folder.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub out: PathBuf,
    /// Live mode: frames one at a time, in order, as a scope delivers them (causal zone
    /// filter, no look-ahead). After a refined frame the next one is first registered from
    /// that pose (see `track_frames`).
    #[cfg_attr(feature = "cli", arg(long))]
    pub live: bool,
    /// Live mode: frames a refined pose stays usable as the next frames' prior (0: every frame
    /// starts from its zone's median pose, as in the paper).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().track_frames))]
    pub track_frames: usize,
    /// Live mode: for this many frames after a refined one, frames that register nowhere else
    /// also try the zones around it (one behind, two ahead); 0: off.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().recover_frames))]
    pub recover_frames: usize,
    /// Live mode: the motion model (damped constant velocity) predicts the pose for at most
    /// this many frames after the last refined one; an init_only frame reports that
    /// prediction instead of its zone's median, and weak registrations must agree with it;
    /// 0: always the zone median, no gate.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().hold_frames))]
    pub hold_frames: usize,
    /// Live mode: run the zone classifier on every frame. By default a frame registered from
    /// the motion model's prediction is not classified (its zone is the one its pose lies in,
    /// its zone score empty in frames.csv): the classifier runs only when tracking fails.
    #[cfg_attr(feature = "cli", arg(long))]
    pub classify_every_frame: bool,
    /// Live mode: a registration with at least this many inliers is trusted without the
    /// motion model's agreement (fewer: it must agree with the prediction, or be confirmed by
    /// the next frame's registration).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().trusted_inliers))]
    pub trusted_inliers: usize,
    /// Live mode: base radius of the motion gate around the predicted camera centre, mm
    /// (grows by 1 mm per frame since the last refined one).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().gate_mm))]
    pub gate_mm: f64,
    /// Map points also come from this many zones on each side of the classified one.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().neighbours))]
    pub neighbours: usize,
    /// SURF threshold on the test frames (default: 0.4 × the map's; the keypoint budget keeps
    /// a sharp frame to its strongest keypoints).
    #[cfg_attr(feature = "cli", arg(long))]
    pub threshold: Option<f32>,
    /// A frame that registers nowhere is described again with every keypoint above this SURF
    /// threshold (no budget) and tried once more (default: twice the map's, per frame only;
    /// given, live too; 0: off).
    #[cfg_attr(feature = "cli", arg(long))]
    pub retry_threshold: Option<f32>,
    /// Keypoint budget of a test frame: at most this × √(width × height) SURF keypoints, the
    /// strongest (2: 554 at 320×240, 1109 at 640×480; 0: no budget, every keypoint above the
    /// threshold).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().keypoint_budget))]
    pub keypoint_budget: f32,
    /// Keep at most this many SURF keypoints per test frame, the strongest (0: no fixed cap;
    /// with the keypoint budget the smaller cap wins).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().max_keypoints))]
    pub max_keypoints: usize,
    /// Zones tried (best classifier score first) until one registers; 1 = trust the top zone
    /// as the paper does.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().candidate_zones))]
    pub candidate_zones: usize,
    /// Validity: largest predicted position uncertainty (1σ, mm) of a refined pose; frames
    /// above it keep the zone's median pose as `init_only` (degenerate_geometry).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().max_sigma_mm))]
    pub max_sigma_mm: f64,
    /// Per frame: largest stated position uncertainty (the frames.csv standard deviation,
    /// mm) of a refined frame; above it the frame is `init_only` (uncertain) and keeps its
    /// registered pose (source `registered`). Default: no limit; 1.5 with `weak_max_std_mm`
    /// 0.75 suits 640×480 frames.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().max_std_mm))]
    pub max_std_mm: f64,
    /// Per frame: as `max_std_mm`, for registrations with fewer than `trusted_inliers`
    /// inliers.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().weak_max_std_mm))]
    pub weak_max_std_mm: f64,
    /// Confirm registrations against the map (on by default; `no_confirm` turns it off).
    /// Every registration (live: every one not tracked from the prediction with 50 inliers or
    /// more) is checked against all map points near its pose, matched in shrinking windows
    /// around their projections, and refined again from them: sharper poses, and one that few
    /// of them support is `init_only` (unsupported) with its registered pose (source
    /// `registered`); live, the motion model keeps the translation undamped through frames
    /// that register nowhere. Without confirmation a frame takes about 10 % less time live and
    /// 30 % less per frame, and wrong `refined` poses are far more common.
    #[cfg_attr(feature = "cli", arg(long = "no-confirm", action = clap::ArgAction::SetFalse))]
    pub confirm: bool,
    /// Validity: largest RMS reprojection error of the inliers, pixels.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().max_rms_px))]
    pub max_rms_px: f64,
    /// Validity: largest jump from the prior (the zone's median pose, or in live mode the last
    /// refined pose), mm.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().max_jump_mm))]
    pub max_jump_mm: f64,
    /// Scale of the Cauchy kernel of the final polish on the inliers, pixels: map points are
    /// now and then a pixel or two off where a new view sees them, and the kernel all but
    /// ignores those. 0: least squares on the inliers.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().polish_px))]
    pub polish_px: f64,
    /// How far the colon wall may have moved since the mapping pass (standard deviation, mm):
    /// deformation, a shifted segment, another insufflation. Such a move shifts a map point's
    /// image by about f·σ/z pixels at depth z, so each point's reprojection tolerance in
    /// RANSAC, the refinement and the confirming windows widens by √(1 + (f·σ/z)²): near
    /// points may lie farther from their projection than far ones. Tried only on a frame that
    /// does not register as a rigid wall (0.25 for a deformed pass; off by default, as it
    /// also rescues a few wrong poses on an unchanged one). 0: a rigid colon.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().wall_motion_mm))]
    pub wall_motion_mm: f64,
    /// Keypoint noise of a registration to a wall that did not move, pixels per image axis
    /// (1σ). The stated uncertainty (`position_std_mm`, `orientation_std_deg`) reads what the
    /// inliers' reprojection residuals show beyond it as the colon wall having moved since
    /// the mapping pass — neighbouring map points alike, correlated over 50 mm — and adds the
    /// pose error such a motion causes, most of which leaves no residual. On an unchanged
    /// colon it adds (nearly) nothing; set too low for the images it overstates the
    /// uncertainty, never understates it. 0: the residuals are independent noise only.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().keypoint_noise_px))]
    pub keypoint_noise_px: f64,
    /// Refine each `refined` pose once more with the colon's scale about its mid-line (the
    /// training pass's camera path): a colon insufflated more or less than when it was mapped
    /// is the mapped colon scaled about its mid-line, and a rigid pose fitted to it lands
    /// millimetres off along the lumen. The value is the standard deviation of the scale's
    /// prior around 1 (0.15: about ±15 %); the pose reported is the camera carried back into
    /// the mapped colon. 0: rigid poses, as in the paper.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = LocalizeJob::default().colon_scale))]
    pub colon_scale: f64,
    /// Stop at the first image that cannot be read (for batch checks) instead of
    /// reporting the frame as `rejected` (reason `unreadable_image`) and going on.
    #[cfg_attr(feature = "cli", arg(long))]
    pub strict: bool,
    /// Replace existing results in `out`.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for LocalizeJob {
    fn default() -> Self {
        let cfg = LocalizerConfig::default();
        let validity = &cfg.localize.validity;
        LocalizeJob {
            method: LocalizeMethod::Endoloc,
            model: None,
            also_model: Vec::new(),
            regressor: None,
            reference_seq: None,
            seq: PathBuf::new(),
            video: None,
            realtime: false,
            size: None,
            pix_fmt: PixelFormat::default(),
            mask: None,
            camera: None,
            out: PathBuf::new(),
            live: false,
            track_frames: cfg.track_frames,
            recover_frames: cfg.recover_frames,
            hold_frames: cfg.hold_frames,
            classify_every_frame: cfg.classify_tracked,
            trusted_inliers: cfg.motion.trusted_inliers,
            gate_mm: cfg.motion.gate_mm,
            neighbours: cfg.neighbour_zones,
            threshold: cfg.surf.as_ref().map(|s| s.threshold),
            retry_threshold: cfg.retry_threshold,
            keypoint_budget: endoloc_localize::TEST_KEYPOINT_BUDGET,
            max_keypoints: 0,
            candidate_zones: cfg.candidate_zones,
            max_sigma_mm: validity.max_position_sigma_mm,
            max_std_mm: cfg.max_std_mm,
            weak_max_std_mm: cfg.weak_max_std_mm,
            // Unlike the library's configuration, whose default is the paper's pipeline.
            confirm: true,
            max_rms_px: validity.max_rms_px,
            max_jump_mm: validity.max_jump_mm,
            polish_px: match cfg.localize.refine.polish_kernel {
                RobustKernel::Cauchy { scale_px } | RobustKernel::Huber { scale_px } => scale_px,
                RobustKernel::None => 0.0,
            },
            wall_motion_mm: cfg.localize.refine.wall_motion_mm,
            keypoint_noise_px: cfg.wall_covariance.keypoint_noise_px,
            colon_scale: cfg.colon_scale.map_or(0.0, |c| c.fit.prior_sigma),
            strict: false,
            force: false,
        }
    }
}

/// The file in a localization run's folder that holds the job that made it.
pub const LOCALIZE_FILE: &str = "localize.toml";

/// What `LocalizeJob` did.
#[derive(Debug, Clone)]
pub struct LocalizeReport {
    /// Counts and latencies (endoloc only; `None` for baselines).
    pub summary: Option<RunSummary>,
    /// Arrivals, drops and latency from arrival to pose (`video` only).
    pub stream: Option<StreamSummary>,
    /// Frames of the sequence.
    pub frame_count: usize,
    /// Frames with a pose.
    pub with_pose: usize,
    /// Mean time per frame, ms (baselines).
    pub ms_per_frame: f64,
    /// Wall time, seconds.
    pub wall_s: f64,
    /// A line from the method (e.g. where VO lost track).
    pub note: Option<String>,
    /// Whether `along.csv` (each pose's distance along the colon) was written.
    pub along: bool,
    /// Output folder.
    pub out: PathBuf,
}

impl LocalizeJob {
    /// The localizer's configuration for a map built with `map_surf`-independent settings:
    /// test-frame SURF stays `None` (derived from the map) unless a threshold or keypoint cap
    /// is given.
    pub fn localizer_config(&self, map_surf: &endoloc_features::SurfConfig) -> LocalizerConfig {
        let base = LocalizerConfig::default();
        let surf = if self.threshold.is_some()
            || self.max_keypoints > 0
            || self.keypoint_budget != endoloc_localize::TEST_KEYPOINT_BUDGET
        {
            let mut s = base.test_surf(map_surf);
            if let Some(t) = self.threshold {
                s.threshold = t;
            }
            s.max_keypoints = self.max_keypoints;
            s.keypoint_budget = self.keypoint_budget;
            Some(s)
        } else {
            None
        };
        let mut cfg = LocalizerConfig {
            surf,
            retry_threshold: self.retry_threshold,
            neighbour_zones: self.neighbours,
            max_std_mm: self.max_std_mm,
            weak_max_std_mm: self.weak_max_std_mm,
            confirm: if self.confirm {
                ConfirmConfig::standard()
            } else {
                ConfirmConfig::default()
            },
            candidate_zones: self.candidate_zones,
            track_frames: self.track_frames,
            recover_frames: self.recover_frames,
            hold_frames: self.hold_frames,
            classify_tracked: self.classify_every_frame,
            motion: MotionConfig {
                trusted_inliers: self.trusted_inliers,
                gate_mm: self.gate_mm,
                ..base.motion
            },
            ..base
        };
        let validity = &mut cfg.localize.validity;
        validity.max_position_sigma_mm = self.max_sigma_mm;
        validity.max_rms_px = self.max_rms_px;
        validity.max_jump_mm = self.max_jump_mm;
        cfg.colon_scale = (self.colon_scale != 0.0).then(|| {
            let mut c = ColonScaleConfig::default();
            c.fit.prior_sigma = self.colon_scale;
            c
        });
        cfg.localize.refine.wall_motion_mm = self.wall_motion_mm;
        cfg.wall_covariance.keypoint_noise_px = self.keypoint_noise_px;
        cfg.localize.refine.polish_kernel = if self.polish_px == 0.0 {
            RobustKernel::None
        } else {
            RobustKernel::Cauchy {
                scale_px: self.polish_px,
            }
        };
        cfg
    }

    /// The localizer this job runs (method `endoloc`): the model joined with `also_model`, the
    /// model's map and this job's settings — what [`LocalizeJob::run`] localizes every frame
    /// with, for callers that feed frames one at a time (live: [`Localizer::live_state`] and
    /// [`Localizer::localize_live`]; otherwise [`Localizer::localize`]).
    ///
    /// # Errors
    /// No model folder, a model or map that cannot be loaded, or a map built for another
    /// model.
    pub fn localizer(&self) -> Result<Localizer> {
        self.localizer_with(|_, _| {})
    }

    /// [`LocalizeJob::localizer`] with its settings changed by `adjust` (which also gets the
    /// map's SURF settings) before it is built.
    ///
    /// # Errors
    /// As [`LocalizeJob::localizer`].
    pub fn localizer_with(
        &self,
        adjust: impl FnOnce(&mut LocalizerConfig, &endoloc_features::SurfConfig),
    ) -> Result<Localizer> {
        let model = self
            .model
            .as_deref()
            .context("a model folder is required (`model`)")?;
        let classifier = load_classifier(model, &self.also_model, Device::Cpu)?;
        let map = load_map(model)?;
        let mut cfg = self.localizer_config(&map.config.surf);
        adjust(&mut cfg, &map.config.surf);
        let localizer = Localizer::new(classifier, map, cfg)?
            .with_smoothed_level(load_smoothed_level(model)?)?;
        match self.frames_camera(localizer.camera())? {
            Some(camera) => Ok(localizer.with_camera(camera)?),
            None => Ok(localizer),
        }
    }

    /// The camera of the frames, when it is not the model's (`model_camera`): `camera`, scaled
    /// to the model's image size, else the sequence's own camera.toml.
    ///
    /// # Errors
    /// A camera file that cannot be read, or of another aspect ratio than the model's camera.
    pub fn frames_camera(
        &self,
        model_camera: &endoloc_geometry::Camera,
    ) -> Result<Option<endoloc_geometry::Camera>> {
        if let Some(path) = &self.camera {
            let c = endoloc_data::read_camera_file(path)?;
            return Ok(Some(fit_camera(path, c, model_camera)?));
        }
        if self.seq.as_os_str().is_empty() || !self.seq.is_dir() {
            return Ok(None);
        }
        let Some(root) = self
            .seq
            .parent()
            .filter(|r| r.join(endoloc_data::dataset::META_FILE).is_file())
        else {
            return Ok(None);
        };
        let ds = endoloc_data::DatasetMeta::read(&root.join(endoloc_data::dataset::META_FILE))?;
        Ok(endoloc_data::sequence_camera(&self.seq, &ds.camera)?)
    }

    /// Localizes the sequence and writes the results.
    ///
    /// # Errors
    /// Existing results without `force`, a missing model or map, a model for another camera,
    /// an unreadable image, or a failed write.
    pub fn run(&self, progress: &dyn Progress) -> Result<LocalizeReport> {
        self.run_with(progress, &mut |_| {})
    }

    /// Like [`LocalizeJob::run`], and hands each frame's result (method `endoloc`), in frame
    /// order, to `on_frame` once its rows are written; the run itself keeps none of them.
    ///
    /// # Errors
    /// As [`LocalizeJob::run`].
    pub fn run_with(
        &self,
        progress: &dyn Progress,
        on_frame: &mut dyn FnMut(FrameResult),
    ) -> Result<LocalizeReport> {
        for f in [TRAJECTORY_FILE, FRAMES_FILE] {
            crate::output::refuse_existing(
                &self.out.join(f),
                self.force,
                &format!(" (the results in {})", self.out.display()),
            )?;
        }
        if self.video.is_some() {
            return self.run_video(progress, on_frame);
        }
        if self.seq.as_os_str().is_empty() {
            bail!("a sequence folder (`seq`) or a video (`video`) to localize is required");
        }
        if self.method != LocalizeMethod::Endoloc {
            if !self.also_model.is_empty() {
                bail!("`also_model` joins zone models for the endoloc method only");
            }
            return self.run_baseline(progress);
        }
        let localizer = self.localizer()?.with_mask(dataset_mask(&self.seq)?);
        // A pass without poses (frames.txt) is localized as any other.
        let seq = Sequence::open_frames(&self.seq)?;
        let dataset = dataset_of(&self.seq)?;
        let classifier = localizer.classifier();
        classifier
            .check_compatible(&dataset.meta.camera)
            .and_then(|()| classifier.check_dataset(&dataset))
            .with_context(|| {
                format!(
                    "model {} vs sequence {}",
                    localizer.classifier().dir().display(),
                    self.seq.display()
                )
            })?;
        let n = seq.len();
        let t = Instant::now();
        // Rows are written as frames finish, in frame order; nothing of a frame is kept.
        let staged = crate::output::StagedFiles::new(&self.out)?;
        // Each pose's distance along the colon, when the sequence's dataset has a mid-line.
        let midline = match dataset.midline_path() {
            Some(p) => Some(
                endoloc_eval::Midline::from_file(&p)
                    .with_context(|| format!("reading the mid-line of {}", self.seq.display()))?,
            ),
            None => None,
        };
        let along = midline.is_some();
        let mut writer = ResultWriter::create(&staged, &self.out, &seq, midline)?;
        let mut summary = RunSummary::default();
        let mut with_pose = 0;
        let mut emit = |r: FrameResult| -> Result<()> {
            writer.push(&r)?;
            summary.add(&r);
            with_pose += usize::from(r.t_wc.is_some());
            on_frame(r);
            Ok(())
        };
        let bar = bar(
            progress,
            n as u64,
            if self.live { "live" } else { "localize" },
        );
        // An unreadable frame is reported and skipped, unless `strict`.
        let load = |i: usize| -> Result<std::result::Result<image::GrayImage, FrameResult>> {
            match seq.load_gray(i) {
                Ok(img) => Ok(Ok(img)),
                Err(e) if !self.strict => {
                    progress.note(&format!(
                        "warning: frame {i} rejected (unreadable_image): {e}"
                    ));
                    Ok(Err(FrameResult::unreadable(e.to_string())))
                }
                Err(e) => Err(e.into()),
            }
        };
        if self.live {
            // Frame k+1 is decoded on its own thread while frame k is localized (a scope
            // delivers decoded frames; here the files must be read), at most two ahead.
            let mut state = localizer.live_state();
            std::thread::scope(|scope| -> Result<()> {
                let (tx, rx) = std::sync::mpsc::sync_channel(2);
                scope.spawn(move || {
                    for i in 0..n {
                        // A closed channel: the localization stopped at an error.
                        if tx.send(load(i)).is_err() {
                            break;
                        }
                    }
                });
                for loaded in rx {
                    emit(match loaded? {
                        Ok(img) => localizer.localize_live(&mut state, &img)?,
                        Err(unreadable) => unreadable,
                    })?;
                    bar.inc(1);
                }
                Ok(())
            })?;
        } else {
            // Frames are independent: localized in parallel a block at a time, so that at
            // most one block of results waits to be written.
            let block = 16 * rayon::current_num_threads().max(1);
            for start in (0..n).step_by(block) {
                let results = (start..(start + block).min(n))
                    .into_par_iter()
                    .map(|i| {
                        let r = match load(i)? {
                            Ok(img) => localizer.localize(&img)?,
                            Err(unreadable) => unreadable,
                        };
                        bar.inc(1);
                        Ok(r)
                    })
                    .collect::<Result<Vec<FrameResult>>>()?;
                for r in results {
                    emit(r)?;
                }
            }
        }
        drop(bar);
        let wall_s = t.elapsed().as_secs_f64();
        writer.finish()?;
        self.save_to(&staged.path(LOCALIZE_FILE))?;
        staged.publish()?;
        Ok(LocalizeReport {
            frame_count: n,
            with_pose,
            ms_per_frame: 1e3 * wall_s / n.max(1) as f64,
            summary: Some(summary),
            stream: None,
            wall_s,
            note: None,
            along,
            out: self.out.clone(),
        })
    }

    /// Localizes the frames of `video` (a file, or `-`: raw frames on standard input) as they
    /// come (see [`LocalizeJob::video`]).
    fn run_video(
        &self,
        progress: &dyn Progress,
        on_frame: &mut dyn FnMut(FrameResult),
    ) -> Result<LocalizeReport> {
        let never = std::sync::atomic::AtomicBool::new(false);
        self.run_video_watched(progress, &never, &mut |f| on_frame(f.result))
    }

    /// Localizes the frames of `video` as they come (see [`LocalizeJob::video`]), handing each
    /// frame — its image, result and latency — to `watch` once its rows are written (a live
    /// view); stops after the frame in hand when `stop` is set (Ctrl-C), the files complete.
    ///
    /// # Errors
    /// No `video` or `live`, a model or map that cannot be loaded, a video that cannot be
    /// opened or fails while read (FFmpeg's message), or a failed write.
    pub fn run_video_watched(
        &self,
        progress: &dyn Progress,
        stop: &std::sync::atomic::AtomicBool,
        watch: &mut dyn FnMut(StreamedFrame<'_>),
    ) -> Result<LocalizeReport> {
        let Some(video) = &self.video else {
            bail!("no video to localize (`video`)");
        };
        if self.method != LocalizeMethod::Endoloc || !self.live {
            bail!("`video` is localized live by endoloc: it needs `live` and the method endoloc");
        }
        if !self.seq.as_os_str().is_empty() {
            bail!("give a sequence folder (`seq`) or a video (`video`), not both");
        }
        let (localizer, black) = self.stream_localizer()?;
        let camera = localizer.camera();
        let size = (camera.width, camera.height);
        let stream = if video.as_os_str() == "-" {
            let Some(native) = self.size.as_deref().map(parse_size).transpose()? else {
                bail!("standard input: raw frames need their size (`size` WxH, e.g. 640x480)");
            };
            FrameStream::raw(
                "standard input",
                Box::new(std::io::stdin()),
                native,
                self.pix_fmt,
                size,
            )?
        } else {
            if self.size.is_some() {
                bail!(
                    "`size` is the size of raw frames on standard input; a video file states its own"
                );
            }
            FrameStream::open_video(video, size)?
        };
        self.run_stream(&localizer, stream, black, progress, stop, watch)
    }

    /// Localizes the frames of `stream` live, as they come, into `out` (this job's settings;
    /// `seq` and `video` unused): what `video` does, for frames from any source — a camera's
    /// driver, a test's reader. The stream's size must be the model's camera's. With
    /// `realtime`, a raw stream's frames are taken as they arrive (newest wins) and a video
    /// file's are paced at their times; without it every frame is localized.
    ///
    /// # Errors
    /// A model or map that cannot be loaded, a stream of another size than the model's
    /// camera, a source that fails (its own error), or a failed write.
    pub fn run_frames(
        &self,
        stream: FrameStream,
        progress: &dyn Progress,
        on_frame: &mut dyn FnMut(FrameResult),
    ) -> Result<LocalizeReport> {
        let (localizer, black) = self.stream_localizer()?;
        let camera = localizer.camera();
        if stream.size() != (camera.width, camera.height) {
            bail!(
                "{}: frames of {}x{}; the model's camera is {}x{}",
                stream.name().display(),
                stream.size().0,
                stream.size().1,
                camera.width,
                camera.height
            );
        }
        let never = std::sync::atomic::AtomicBool::new(false);
        self.run_stream(&localizer, stream, black, progress, &never, &mut |f| {
            on_frame(f.result)
        })
    }

    /// Localizes `stream` live into `out` with this job's settings (see `stream.rs`).
    fn run_stream(
        &self,
        localizer: &Localizer,
        stream: FrameStream,
        black: Option<image::GrayImage>,
        progress: &dyn Progress,
        stop: &std::sync::atomic::AtomicBool,
        watch: &mut dyn FnMut(StreamedFrame<'_>),
    ) -> Result<LocalizeReport> {
        let run = stream::StreamRun {
            out: &self.out,
            realtime: self.realtime,
            pix_fmt: self.pix_fmt,
            job_file: LOCALIZE_FILE,
            save_job: &|dir| self.save(dir),
        };
        let done = run.localize(localizer, stream, black, progress, stop, watch)?;
        let localized = done.summary.frames;
        Ok(LocalizeReport {
            frame_count: localized,
            with_pose: done.with_pose,
            ms_per_frame: 1e3 * done.wall_s / localized.max(1) as f64,
            summary: Some(done.summary),
            stream: Some(done.stream),
            wall_s: done.wall_s,
            note: None,
            along: false,
            out: self.out.clone(),
        })
    }

    /// The camera of `model` as its `model.toml` states it (what the localizer's frames must
    /// be), without loading the network or the map.
    ///
    /// # Errors
    /// No model folder, or a `model.toml` that cannot be read.
    pub fn camera(&self) -> Result<endoloc_geometry::Camera> {
        let model = self
            .model
            .as_deref()
            .context("a model folder is required (`model`)")?;
        Ok(endoloc_net::model::ModelConfig::load(model)?.camera)
    }

    /// The localizer of a stream, with `mask` (and the mask as an image, to black the frames
    /// outside it).
    fn stream_localizer(&self) -> Result<(Localizer, Option<image::GrayImage>)> {
        let localizer = self.localizer()?;
        let mask = match &self.mask {
            Some(p) => read_mask(p, localizer.camera())?,
            None => None,
        };
        let black = mask.as_ref().map(|m| m.to_gray());
        Ok((localizer.with_mask(mask), black))
    }

    /// Writes this job as `localize.toml` into `dir`, so that the run can be repeated (and
    /// viewed) from its own files. Paths are stored as given.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn save(&self, dir: &Path) -> Result<()> {
        self.save_to(&dir.join(LOCALIZE_FILE))
    }

    fn save_to(&self, path: &Path) -> Result<()> {
        let text = toml::to_string_pretty(self)?;
        endoloc_data::write_atomic(path, text.as_bytes())?;
        Ok(())
    }

    /// Reads the `localize.toml` that a run wrote into `dir`.
    ///
    /// # Errors
    /// A missing or unreadable file.
    pub fn load(dir: &Path) -> Result<Self> {
        let path = dir.join(LOCALIZE_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| JobError::io(&path, e))?;
        toml::from_str(&text).with_context(|| format!("reading {}", path.display()))
    }

    /// A baseline: its estimates and `trajectory.txt`.
    fn run_baseline(&self, progress: &dyn Progress) -> Result<LocalizeReport> {
        // Geometric VO is aligned to the pass's true poses; the others need only its frames.
        let seq = if self.method == LocalizeMethod::Vo {
            Sequence::open(&self.seq)?
        } else {
            Sequence::open_frames(&self.seq)?
        };
        let camera = dataset_camera(&self.seq)?;
        let name = self.method.name();
        let model = || {
            self.model
                .as_deref()
                .with_context(|| format!("method {name} needs a model folder (`model`)"))
        };
        let classify =
            |dir: &Path| -> Result<(ZoneClassifier, Vec<endoloc_net::ZonePrediction>, f64)> {
                let clf = ZoneClassifier::load(dir)
                    .with_context(|| format!("loading model {}", dir.display()))?;
                clf.check_compatible(&camera)?;
                clf.check_dataset(&dataset_of(&self.seq)?)?;
                let (preds, ms) = predict_zones(&clf, &seq, progress)?;
                Ok((clf, preds, ms))
            };
        let t = Instant::now();
        let est = match self.method {
            LocalizeMethod::Classify | LocalizeMethod::Retrieval => {
                let (clf, preds, ms) = classify(model()?)?;
                let poses = preds
                    .iter()
                    .map(|p| {
                        if self.method == LocalizeMethod::Classify {
                            clf.zones().zones.get(p.zone).map(|z| z.median_pose)
                        } else {
                            clf.train_poses().get(p.nearest_frame).copied()
                        }
                    })
                    .collect();
                Estimates {
                    poses,
                    ms_per_frame: ms,
                    note: None,
                }
            }
            LocalizeMethod::Posenet => baselines::posenet(model()?, &seq, progress)?,
            LocalizeMethod::Offsetnet => {
                let reg = self
                    .regressor
                    .as_deref()
                    .context("method offsetnet needs the OffsetNet model folder (`regressor`)")?;
                let refs = self.reference_seq.as_deref().context(
                    "method offsetnet needs the training sequence folder (`reference_seq`)",
                )?;
                let train = Sequence::open(refs)?;
                let (_, preds, ms) = classify(model()?)?;
                baselines::offsetnet(reg, &train, &seq, &preds, ms, progress)?
            }
            LocalizeMethod::Vo => baselines::vo(&camera, dataset_mask(&self.seq)?, &seq, progress)?,
            LocalizeMethod::Endoloc => unreachable!("endoloc is not a baseline"),
        };
        let staged = crate::output::StagedFiles::new(&self.out)?;
        let trajectory = stamped(&seq, est.poses.iter().copied());
        endoloc_data::write_tum(&staged.path(TRAJECTORY_FILE), &trajectory)?;
        self.save_to(&staged.path(LOCALIZE_FILE))?;
        staged.publish()?;
        Ok(LocalizeReport {
            summary: None,
            stream: None,
            frame_count: seq.len(),
            with_pose: trajectory.len(),
            ms_per_frame: est.ms_per_frame,
            wall_s: t.elapsed().as_secs_f64(),
            note: est.note,
            along: false,
            out: self.out.clone(),
        })
    }
}

/// Loads a zone model on `device`, joined with `also` into an ensemble
/// ([`ZoneClassifier::join`]) when that is not empty.
///
/// # Errors
/// A model that cannot be loaded, or models that cannot be joined.
pub fn load_classifier(model: &Path, also: &[PathBuf], device: Device) -> Result<ZoneClassifier> {
    let load = |dir: &Path| {
        ZoneClassifier::load_on(dir, device.name())
            .with_context(|| format!("loading model {}", dir.display()))
    };
    let first = load(model)?;
    if also.is_empty() {
        return Ok(first);
    }
    let others = also.iter().map(|d| load(d)).collect::<Result<Vec<_>>>()?;
    Ok(first.join(others)?)
}

/// An image size `WxH`, pixels, both above 0.
///
/// # Errors
/// [`JobError::Invalid`] quoting `text`.
pub(crate) fn parse_size(text: &str) -> Result<(u32, u32)> {
    let parsed = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => bail!("`size` {text:?}; expected WxH in pixels, e.g. 640x480"),
    }
}

/// `camera` (read from `path`) for frames resized to `model`'s image size: scaled by the ratio
/// of the widths; the heights must then agree (the same aspect ratio).
fn fit_camera(
    path: &Path,
    camera: endoloc_geometry::Camera,
    model: &endoloc_geometry::Camera,
) -> Result<endoloc_geometry::Camera> {
    if (camera.width, camera.height) == (model.width, model.height) {
        return Ok(camera);
    }
    let scale = f64::from(model.width) / f64::from(camera.width);
    let scaled = camera.scaled(scale);
    if scaled.height != model.height {
        bail!(
            "{}: a {}x{} camera cannot be scaled to the model's {}x{} (another aspect ratio)",
            path.display(),
            camera.width,
            camera.height,
            model.width,
            model.height
        );
    }
    Ok(endoloc_geometry::Camera {
        width: model.width,
        ..scaled
    })
}

/// The camera of the dataset a sequence folder belongs to (its parent's `dataset.toml`).
///
/// # Errors
/// A sequence folder that is not inside a dataset.
pub fn dataset_camera(seq_dir: &Path) -> Result<endoloc_geometry::Camera> {
    Ok(dataset_of(seq_dir)?.meta.camera)
}

/// The dataset that holds sequence folder `seq_dir`.
fn dataset_of(seq_dir: &Path) -> Result<Dataset> {
    let parent = seq_dir
        .canonicalize()
        .map_err(|e| JobError::io(seq_dir, e))?
        .parent()
        .map(Path::to_path_buf)
        .context("the sequence folder has no parent dataset folder")?;
    Dataset::open(&parent).with_context(|| {
        format!(
            "{} should be a sequence folder inside a dataset (with dataset.toml)",
            seq_dir.display()
        )
    })
}

/// The image mask of the dataset that holds sequence folder `seq_dir` (`[camera] mask`), when
/// it has one.
///
/// # Errors
/// A sequence folder outside a dataset; an unreadable or invalid mask.
pub fn dataset_mask(seq_dir: &Path) -> Result<Option<Arc<Mask>>> {
    mask_of(&dataset_of(seq_dir)?)
}

/// The image mask at `path`: a dataset folder (its `[camera] mask`, `None` when it has
/// none) or a mask PNG (8-bit, `camera`'s size, non-zero = valid).
///
/// # Errors
/// A dataset or file that cannot be read, or a mask of another size or without a valid
/// pixel.
pub fn read_mask(path: &Path, camera: &endoloc_geometry::Camera) -> Result<Option<Arc<Mask>>> {
    if path.is_dir() {
        return mask_of(&Dataset::open(path)?);
    }
    let bytes = std::fs::read(path).map_err(|e| JobError::io(path, e))?;
    let img = endoloc_data::mask_from_png(path, &bytes, camera)?;
    let mask = Mask::from_gray(&img).with_context(|| format!("mask {}", path.display()))?;
    Ok(Some(Arc::new(mask)))
}

/// The image mask of `dataset`, when it has one.
///
/// # Errors
/// An unreadable or invalid mask.
pub fn mask_of(dataset: &Dataset) -> Result<Option<Arc<Mask>>> {
    match dataset.load_mask()? {
        None => Ok(None),
        Some(img) => {
            let path = dataset.mask_path().unwrap_or_default();
            let mask = Mask::from_gray(&img).with_context(|| format!("mask {}", path.display()))?;
            Ok(Some(Arc::new(mask)))
        }
    }
}

/// The frames of `seq` that have a pose, with their timestamps.
fn stamped(
    seq: &Sequence,
    poses: impl Iterator<Item = Option<endoloc_geometry::Pose>>,
) -> Vec<StampedPose> {
    poses
        .zip(seq.timestamps())
        .filter_map(|(p, timestamp_s)| p.map(|pose| StampedPose { timestamp_s, pose }))
        .collect()
}

impl fmt::Display for LocalizeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Some(summary) = &self.summary else {
            if let Some(note) = &self.note {
                writeln!(f, "{note}")?;
            }
            writeln!(
                f,
                "frames    {} — {} with a pose ({:.1} %), {:.1} ms per frame",
                self.frame_count,
                self.with_pose,
                100.0 * self.with_pose as f64 / self.frame_count.max(1) as f64,
                self.ms_per_frame
            )?;
            return write!(f, "wrote     {}/trajectory.txt", self.out.display());
        };
        writeln!(f, "{summary}; {:.1} s wall", self.wall_s)?;
        if let Some(stream) = &self.stream {
            writeln!(f, "{stream}")?;
        }
        write!(
            f,
            "wrote     {}/trajectory.txt, frames.csv, inliers.csv{}{}",
            self.out.display(),
            if self.along { ", along.csv" } else { "" },
            if self.stream.is_some() {
                ", stream.csv"
            } else {
                ""
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_library_defaults_with_confirmation() {
        let map_surf = endoloc_localize::MapConfig::default().surf;
        assert_eq!(
            LocalizeJob::default().localizer_config(&map_surf),
            LocalizerConfig {
                confirm: ConfirmConfig::standard(),
                ..LocalizerConfig::default()
            }
        );
        let unconfirmed = LocalizeJob {
            confirm: false,
            ..LocalizeJob::default()
        };
        assert_eq!(
            unconfirmed.localizer_config(&map_surf),
            LocalizerConfig::default()
        );
        let from_toml: LocalizeJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, LocalizeJob::default());
    }

    #[test]
    fn inliers_round_trip_and_a_bad_line_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(INLIERS_FILE);
        std::fs::write(&p, "frame,x_px,y_px\n0,1.5,2.25\n2,10,20\n").unwrap();
        let back = read_inliers_csv(&p, 3).unwrap();
        assert_eq!(back, vec![vec![[1.5, 2.25]], vec![], vec![[10.0, 20.0]]]);
        std::fs::write(&p, "frame,x_px,y_px\n0,1.5\n").unwrap();
        let e = read_inliers_csv(&p, 3).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("frame,x_px,y_px"), "{e}");
        std::fs::write(&p, "frame,x_px,y_px\n7,1,1\n").unwrap();
        let e = read_inliers_csv(&p, 3).unwrap_err().to_string();
        assert!(e.contains("below 3"), "{e}");
    }

    #[test]
    fn a_saved_job_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let job = LocalizeJob {
            model: Some("models/m".into()),
            seq: "data/d/test".into(),
            live: true,
            threshold: Some(40.0),
            ..LocalizeJob::default()
        };
        job.save(dir.path()).unwrap();
        assert_eq!(LocalizeJob::load(dir.path()).unwrap(), job);
    }
}
