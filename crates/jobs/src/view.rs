//! `ViewJob`: one self-contained HTML page to explore a localization run.
//!
//! The page (`RUN/view.html` by default) holds everything it shows — script, style, poses, map
//! points and a thumbnail per test frame — and opens from disk with no network: a 3-D view of
//! the colon's wall when the dataset was simulated, the training pass, the per-zone
//! map points, the true and the estimated trajectories and the
//! scope at the current frame; a frame scrubber with the frame's thumbnail, its map points
//! reprojected with the estimated pose and its `frames.csv` row; the position error along the
//! pass (when the test sequence has `poses.txt`).

use std::fmt;
use std::path::{Path, PathBuf};

use endoloc_data::{Dataset, StampedPose, read_tum};
use endoloc_eval::{FrameRecord, read_frames_csv};
use endoloc_geometry::{
    Camera, Distortion, Pose, Status, canonical_quaternion, orientation_error_deg,
    position_error_mm,
};
use endoloc_localize::map_io::load_map;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::error::{Context, JobError, Result};
use crate::localize::{LOCALIZE_FILE, LocalizeJob};
use crate::progress::{Progress, bar};

mod wall;

/// The page's markup and style; `/*VIEWER_JS*/` and `/*VIEWER_DATA*/` are replaced.
const TEMPLATE: &str = include_str!("view/viewer.html");
/// The page's script.
const SCRIPT: &str = include_str!("view/viewer.js");

/// The file name of the page inside the run folder when no `out` is given.
pub const VIEW_FILE: &str = "view.html";

/// Writes one self-contained HTML page (`view.html` in the run folder, or `out`) that shows a
/// localization run: trajectories, map points, per-frame thumbnails with the reprojected map,
/// status and errors. The run folder is one written by `endoloc localize` (`trajectory.txt`,
/// `frames.csv`, `localize.toml`); the sequence and model it names are read for the images,
/// the ground truth, the camera, the training pass and the map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ViewJob {
    /// Run folder written by the localize job (its `out`).
    #[cfg_attr(feature = "cli", arg(value_name = "RUN_DIR"))]
    pub run: PathBuf,
    /// Output page. Default: RUN_DIR/view.html.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE.html"))]
    pub out: Option<PathBuf>,
    /// Replace an existing page.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
    /// Width of the frame thumbnails embedded in the page, pixels (height follows the
    /// camera's aspect ratio).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ViewJob::default().thumb_width))]
    pub thumb_width: u32,
    /// At most this many map points in the page, all zones together (subsampled evenly).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ViewJob::default().max_points))]
    pub max_points: usize,
    /// Show no errors even when the sequence has poses.txt.
    #[cfg_attr(feature = "cli", arg(long))]
    pub no_gt: bool,
    /// Test sequence folder. Default: the one in RUN_DIR/localize.toml.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub seq: Option<PathBuf>,
    /// Model folder (training pass, zones, map). Default: the one in RUN_DIR/localize.toml.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub model: Option<PathBuf>,
    /// JPEG quality of the thumbnails (1–100).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ViewJob::default().jpeg_quality))]
    pub jpeg_quality: u8,
}

impl Default for ViewJob {
    fn default() -> Self {
        ViewJob {
            run: PathBuf::new(),
            out: None,
            force: false,
            thumb_width: 160,
            max_points: 30_000,
            no_gt: false,
            seq: None,
            model: None,
            jpeg_quality: 75,
        }
    }
}

/// What `ViewJob` wrote.
#[derive(Debug, Clone)]
pub struct ViewReport {
    /// The page.
    pub out: PathBuf,
    /// Its size, bytes.
    pub bytes: u64,
    /// Test frames shown.
    pub frames: usize,
    /// Frames with an estimated pose.
    pub with_pose: usize,
    /// Map points in the page (after subsampling) and in the map.
    pub points: (usize, usize),
    /// Whether position and orientation errors are shown.
    pub ground_truth: bool,
    /// Inputs that were missing and left out of the page (e.g. no map).
    pub missing: Vec<String>,
}

impl fmt::Display for ViewReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "frames    {} ({} with a pose); map points {} of {}; ground truth {}",
            self.frames,
            self.with_pose,
            self.points.0,
            self.points.1,
            if self.ground_truth { "yes" } else { "no" }
        )?;
        for m in &self.missing {
            writeln!(f, "left out  {m}")?;
        }
        write!(
            f,
            "wrote     {} ({:.1} MB)",
            self.out.display(),
            self.bytes as f64 / 1e6
        )
    }
}

/// The data embedded in the page as one JSON object (lengths in mm, world frame, `T_wc`).
#[derive(Debug, Serialize)]
struct PageData {
    /// A live page: no frames yet, each comes as an event of the server's stream
    /// ([`LiveFrame`]).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    live: bool,
    /// What `along` is measured from (`the anus`, or the training pass's start).
    #[serde(skip_serializing_if = "Option::is_none")]
    along_from: Option<String>,
    title: String,
    frames: usize,
    zones: usize,
    camera: CameraData,
    thumb: ThumbData,
    /// Training pass positions, flat `x y z …`.
    train: Vec<f64>,
    /// Rings of the colon's wall ([`wall::colon_wall`]), each flat `x y z …`; none when the
    /// dataset was not simulated.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    wall: Vec<Vec<f64>>,
    /// Map points, flat `x y z …`, sorted by zone.
    points: Vec<f64>,
    /// `[first, end)` indices into the points of each zone.
    zone_points: Vec<[usize; 2]>,
    /// Ground-truth poses `x y z qx qy qz qw` per frame, or none.
    gt: Option<Vec<[f64; 7]>>,
    /// Estimated poses per frame (`None`: rejected).
    est: Vec<Option<[f64; 7]>>,
    zone: Vec<Option<usize>>,
    zone_score: Vec<Option<f64>>,
    /// 0 refined, 1 init_only, 2 rejected.
    status: Vec<u8>,
    reason: Vec<String>,
    inliers: Vec<Option<usize>>,
    rms: Vec<Option<f64>>,
    time_ms: Vec<f64>,
    pos_err: Option<Vec<Option<f64>>>,
    rot_err: Option<Vec<Option<f64>>>,
    /// Inlier keypoints per frame, flat `x y …` in image pixels, when the run recorded them.
    keypoints: Option<Vec<Vec<f64>>>,
    /// Base64 thumbnails, one per frame (`image_mime`).
    images: Vec<String>,
    image_mime: &'static str,
}

#[derive(Debug, Serialize)]
struct CameraData {
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    /// `radial-tangential` (`k1 k2 p1 p2 k3`) or `fisheye` (`k1 k2 k3 k4`); `None`: pinhole.
    distortion: Option<(&'static str, [f64; 5])>,
}

impl CameraData {
    fn of(camera: &Camera) -> Self {
        CameraData {
            width: camera.width,
            height: camera.height,
            fx: camera.fx,
            fy: camera.fy,
            cx: camera.cx,
            cy: camera.cy,
            distortion: distortion_of(camera),
        }
    }
}

fn distortion_of(camera: &Camera) -> Option<(&'static str, [f64; 5])> {
    match camera.distortion {
        Distortion::None => None,
        Distortion::RadialTangential { k1, k2, p1, p2, k3 } => {
            Some(("radial-tangential", [k1, k2, p1, p2, k3]))
        }
        Distortion::Fisheye { k1, k2, k3, k4 } => Some(("fisheye", [k1, k2, k3, k4, 0.0])),
    }
}

#[derive(Debug, Serialize)]
struct ThumbData {
    width: u32,
    height: u32,
}

fn round(x: f64, digits: i32) -> f64 {
    let s = 10f64.powi(digits);
    (x * s).round() / s
}

fn pose7(p: &Pose) -> [f64; 7] {
    let t = p.translation.vector;
    let q = canonical_quaternion(p.rotation);
    [
        round(t.x, 2),
        round(t.y, 2),
        round(t.z, 2),
        round(q.i, 5),
        round(q.j, 5),
        round(q.k, 5),
        round(q.w, 5),
    ]
}

/// A path stored in `localize.toml` "as given": as it is when it exists from here, else
/// relative to the run folder or one of its parents.
fn resolve(path: &Path, run: &Path) -> PathBuf {
    if path.is_absolute() || path.exists() {
        return path.to_path_buf();
    }
    run.ancestors()
        .map(|a| a.join(path))
        .find(|p| p.exists())
        .unwrap_or_else(|| path.to_path_buf())
}

/// The PNG images of a sequence's `images/` folder, in file order.
fn list_images(seq: &Path) -> Result<Vec<PathBuf>> {
    let dir = seq.join("images");
    let rd = std::fs::read_dir(&dir).map_err(|e| JobError::io(&dir, e))?;
    let mut paths = Vec::new();
    for entry in rd {
        let p = entry.map_err(|e| JobError::io(&dir, e))?.path();
        if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            paths.push(p);
        }
    }
    paths.sort();
    Ok(paths)
}

/// The camera of the dataset that holds `seq` (`dataset.toml` in its parent folder).
fn camera_of(seq: &Path) -> Result<Camera> {
    let parent = seq
        .canonicalize()
        .map_err(|e| JobError::io(seq, e))?
        .parent()
        .map(Path::to_path_buf)
        .with_context(|| format!("{} has no parent dataset folder", seq.display()))?;
    let ds = Dataset::open(&parent).with_context(|| {
        format!(
            "{} should be a sequence folder inside a dataset (with dataset.toml)",
            seq.display()
        )
    })?;
    Ok(ds.meta.camera)
}

fn encode_thumb(img: &image::GrayImage, width: u32, height: u32, quality: u8) -> Result<Vec<u8>> {
    let small = image::imageops::resize(img, width, height, image::imageops::FilterType::Triangle);
    let mut bytes = Vec::new();
    let enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality.clamp(1, 100));
    small
        .write_with_encoder(enc)
        .map_err(|e| JobError::Invalid(format!("encoding a thumbnail: {e}")))?;
    Ok(bytes)
}

/// Estimated poses per frame: the lines of `trajectory.txt` belong, in order, to the frames
/// whose status is not `rejected`; failing that, they are matched by timestamp to `gt`.
fn estimates_per_frame(
    rows: &[FrameRecord],
    est: &[StampedPose],
    gt: Option<&[StampedPose]>,
    traj_path: &Path,
) -> Result<Vec<Option<Pose>>> {
    let with_pose: Vec<usize> = rows
        .iter()
        .filter(|r| r.status != Status::Rejected)
        .map(|r| r.frame)
        .collect();
    let mut out = vec![None; rows.len()];
    if with_pose.len() == est.len() {
        for (&f, p) in with_pose.iter().zip(est) {
            out[f] = Some(p.pose);
        }
        return Ok(out);
    }
    let Some(gt) = gt else {
        bail!(
            "{}: {} poses but {} frames of frames.csv have one, and without the sequence's poses.txt the poses cannot be matched to frames by timestamp",
            traj_path.display(),
            est.len(),
            with_pose.len()
        );
    };
    for p in est {
        let i = gt
            .iter()
            .position(|g| (g.timestamp_s - p.timestamp_s).abs() < 1e-3)
            .with_context(|| {
                format!(
                    "{}: timestamp {} is no frame of the test sequence",
                    traj_path.display(),
                    p.timestamp_s
                )
            })?;
        if i < out.len() {
            out[i] = Some(p.pose);
        }
    }
    Ok(out)
}

/// What every page shows of the model: the training pass and the map points by zone.
struct Scene {
    /// Training pass positions, flat `x y z …`.
    train: Vec<f64>,
    /// Map points, flat `x y z …`, sorted by zone (at most `max_points`).
    points: Vec<f64>,
    /// `[first, end)` indices into the points of each zone.
    zone_points: Vec<[usize; 2]>,
    zones: usize,
    /// Points in the map before subsampling.
    map_points_total: usize,
}

impl Scene {
    fn empty(zones: usize) -> Self {
        Scene {
            train: Vec::new(),
            points: Vec::new(),
            zone_points: vec![[0, 0]; zones],
            zones,
            map_points_total: 0,
        }
    }

    /// The training pass (`train_poses.txt`), zones and map of `model`, its points subsampled
    /// evenly to at most `max_points`; what is missing is noted in `missing`.
    fn of_model(
        model: &Path,
        max_points: usize,
        zones_hint: usize,
        missing: &mut Vec<String>,
    ) -> Result<Self> {
        let mut scene = Scene::empty(0);
        scene.zones = zones_hint;
        scene.zone_points.clear();
        let tp = model.join(endoloc_net::model::POSES_FILE);
        if tp.is_file() {
            for p in read_tum(&tp)? {
                let t = p.pose.translation.vector;
                scene
                    .train
                    .extend([round(t.x, 2), round(t.y, 2), round(t.z, 2)]);
            }
        } else {
            missing.push(format!("training pass: no {}", tp.display()));
        }
        let zp = model.join(endoloc_net::zones::ZONES_FILE);
        if zp.is_file() {
            let table = endoloc_net::ZoneTable::load(&zp)?;
            scene.zones = scene.zones.max(table.len());
        }
        if model.join("map.bin").is_file() {
            let map = load_map(model)?;
            scene.map_points_total = map.zones.iter().map(|z| z.points.len()).sum::<usize>();
            let keep = if scene.map_points_total > max_points {
                max_points as f64 / scene.map_points_total as f64
            } else {
                1.0
            };
            let zones_in_map = map.zones.iter().map(|z| z.zone + 1).max().unwrap_or(0);
            scene.zones = scene.zones.max(zones_in_map);
            scene.zone_points = vec![[0usize, 0usize]; scene.zones];
            let mut zm: Vec<_> = map.zones.iter().collect();
            zm.sort_by_key(|z| z.zone);
            let mut acc = 0.0;
            for z in zm {
                let first = scene.points.len() / 3;
                for p in &z.points {
                    acc += keep;
                    if acc >= 1.0 {
                        acc -= 1.0;
                        let w = p.p_world;
                        scene
                            .points
                            .extend([round(w.x, 2), round(w.y, 2), round(w.z, 2)]);
                    }
                }
                scene.zone_points[z.zone] = [first, scene.points.len() / 3];
            }
        } else {
            missing.push(format!(
                "map points: no {}",
                model.join("map.bin").display()
            ));
        }
        if scene.zone_points.len() < scene.zones {
            let end = scene.points.len() / 3;
            scene.zone_points.resize(scene.zones, [end, end]);
        }
        Ok(scene)
    }
}

impl ViewJob {
    /// The page this job writes.
    pub fn out_path(&self) -> PathBuf {
        self.out.clone().unwrap_or_else(|| self.run.join(VIEW_FILE))
    }

    /// Reads the run, its sequence and model, and writes the page.
    ///
    /// # Errors
    /// An existing page without `force`; a folder that is not a localization run; a missing
    /// sequence or unreadable image; a trajectory that does not fit `frames.csv`; a failed
    /// write.
    pub fn run(&self, progress: &dyn Progress) -> Result<ViewReport> {
        let out = self.out_path();
        crate::output::refuse_existing(&out, self.force, "")?;
        if self.thumb_width < 8 || self.thumb_width > 2048 {
            bail!(
                "`thumb_width` must be 8 to 2048 pixels, not {}",
                self.thumb_width
            );
        }
        let run = &self.run;
        let frames_path = run.join("frames.csv");
        let traj_path = run.join("trajectory.txt");
        if !run.is_dir() || !frames_path.is_file() || !traj_path.is_file() {
            bail!(
                "{} is not a localization run folder: it should contain frames.csv and trajectory.txt (and localize.toml), as the localize job writes them",
                run.display()
            );
        }
        let localize = if run.join(LOCALIZE_FILE).is_file() {
            Some(LocalizeJob::load(run)?)
        } else {
            None
        };
        let seq = match (&self.seq, &localize) {
            (Some(s), _) => s.clone(),
            (None, Some(l)) => resolve(&l.seq, run),
            (None, None) => bail!(
                "{} has no {LOCALIZE_FILE} naming the test sequence; give it (`seq`)",
                run.display()
            ),
        };
        let model = match (&self.model, &localize) {
            (Some(m), _) => Some(m.clone()),
            (None, Some(l)) => l.model.as_deref().map(|m| resolve(m, run)),
            (None, None) => None,
        };
        let mut missing = Vec::new();

        let rows = read_frames_csv(&frames_path)?;
        for (i, r) in rows.iter().enumerate() {
            if r.frame != i {
                bail!(
                    "{}: row {} is frame {}; expected one row per frame in order",
                    frames_path.display(),
                    i + 1,
                    r.frame
                );
            }
        }
        let n = rows.len();
        let inliers_path = run.join(crate::localize::INLIERS_FILE);
        let keypoints = if inliers_path.is_file() {
            let per_frame = crate::localize::read_inliers_csv(&inliers_path, n)?;
            Some(
                per_frame
                    .iter()
                    .map(|f| {
                        f.iter()
                            .flat_map(|p| [round(p[0] as f64, 1), round(p[1] as f64, 1)])
                            .collect()
                    })
                    .collect(),
            )
        } else {
            missing.push(format!(
                "matched keypoints: no {}",
                crate::localize::INLIERS_FILE
            ));
            None
        };
        let images = list_images(&seq)?;
        if images.len() != n {
            bail!(
                "{} has {} frames but {} holds {} images; is this the sequence the run localized?",
                frames_path.display(),
                n,
                seq.join("images").display(),
                images.len()
            );
        }
        let gt_path = seq.join("poses.txt");
        let gt = if self.no_gt {
            None
        } else if gt_path.is_file() {
            let gt = read_tum(&gt_path)?;
            if gt.len() != n {
                bail!(
                    "{} has {} poses for {n} frames; expected one per frame",
                    gt_path.display(),
                    gt.len()
                );
            }
            Some(gt)
        } else if seq.join(endoloc_data::FRAME_TIMES_FILE).is_file() {
            missing.push(format!(
                "errors: {} is a pass without poses ({})",
                seq.display(),
                endoloc_data::FRAME_TIMES_FILE
            ));
            None
        } else {
            missing.push(format!("errors: no {}", gt_path.display()));
            None
        };
        let est_stamped = read_tum(&traj_path)?;
        let est = estimates_per_frame(&rows, &est_stamped, gt.as_deref(), &traj_path)?;
        let camera = camera_of(&seq)?;

        // The training pass and the map.
        let zones_in_rows = rows
            .iter()
            .filter_map(|r| r.zone)
            .max()
            .map_or(0, |z| z + 1);
        let scene = match &model {
            Some(model) => Scene::of_model(model, self.max_points, zones_in_rows, &mut missing)?,
            None => {
                missing.push("training pass and map: the run names no model (`model`)".into());
                Scene::empty(zones_in_rows)
            }
        };

        // Thumbnails.
        let tw = self.thumb_width;
        let th = ((tw as f64 * camera.height as f64 / camera.width as f64).round() as u32).max(1);
        let thumbs = {
            let bar = bar(progress, n as u64, "thumbnails");
            images
                .par_iter()
                .map(|path| {
                    let img = image::open(path)
                        .map_err(|e| JobError::Invalid(format!("{}: {e}", path.display())))?
                        .into_luma8();
                    let bytes = encode_thumb(&img, tw, th, self.jpeg_quality)?;
                    bar.inc(1);
                    Ok(endoloc_eval::html::base64(&bytes))
                })
                .collect::<Result<Vec<String>>>()?
        };

        let (pos_err, rot_err) = match &gt {
            Some(gt) => {
                let pe = est
                    .iter()
                    .zip(gt)
                    .map(|(e, g)| e.map(|e| round(position_error_mm(&e, &g.pose), 3)))
                    .collect();
                let re = est
                    .iter()
                    .zip(gt)
                    .map(|(e, g)| e.map(|e| round(orientation_error_deg(&e, &g.pose), 3)))
                    .collect();
                (Some(pe), Some(re))
            }
            None => (None, None),
        };
        let with_pose = est.iter().filter(|e| e.is_some()).count();
        // The colon the test sequence's dataset was simulated through, when it was.
        let wall = seq
            .parent()
            .map(|dataset| wall::colon_wall(dataset, &mut missing))
            .unwrap_or_default();
        let data = PageData {
            title: run
                .canonicalize()
                .ok()
                .and_then(|p| p.file_name().map(|s| s.to_string_lossy().into_owned()))
                .unwrap_or_else(|| run.display().to_string()),
            live: false,
            along_from: None,
            frames: n,
            zones: scene.zones,
            camera: CameraData::of(&camera),
            thumb: ThumbData {
                width: tw,
                height: th,
            },
            train: scene.train,
            wall,
            zone_points: scene.zone_points,
            gt: gt
                .as_ref()
                .map(|g| g.iter().map(|p| pose7(&p.pose)).collect()),
            est: est.iter().map(|e| e.as_ref().map(pose7)).collect(),
            zone: rows.iter().map(|r| r.zone).collect(),
            zone_score: rows
                .iter()
                .map(|r| r.zone_score.map(|s| round(s, 4)))
                .collect(),
            status: rows
                .iter()
                .map(|r| match r.status {
                    Status::Refined => 0,
                    Status::InitOnly => 1,
                    Status::Rejected => 2,
                })
                .collect(),
            reason: rows.iter().map(|r| r.reason.clone()).collect(),
            inliers: rows.iter().map(|r| r.inliers).collect(),
            rms: rows
                .iter()
                .map(|r| r.reprojection_rms_px.map(|x| round(x, 3)))
                .collect(),
            time_ms: rows.iter().map(|r| round(r.time_ms, 2)).collect(),
            pos_err,
            rot_err,
            keypoints,
            images: thumbs,
            image_mime: "image/jpeg",
            points: scene.points,
        };
        let html = render(&data)?;
        if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
            crate::output::create_dir(parent)?;
        }
        endoloc_data::write_atomic(&out, html.as_bytes())?;
        Ok(ViewReport {
            bytes: html.len() as u64,
            out,
            frames: n,
            with_pose,
            points: (data.points.len() / 3, scene.map_points_total),
            ground_truth: data.gt.is_some(),
            missing,
        })
    }
}

/// The live page of a stream being localized (`localize --live --video … --serve`): the same
/// page and drawing code as [`ViewJob`]'s, started without frames; each frame reaches it as a
/// [`LiveView::frame_event`] on the server's event stream. Where the scope is along the colon
/// is measured on the mid-line of the dataset the model was trained on (`data`: its
/// `midline.txt`, from the anus, and its training sequence's `sections.csv` for the
/// anatomical section of the nearest training frame); without it, along the training pass
/// from its first frame.
#[derive(Debug)]
pub struct LiveView {
    page: String,
    midline: Option<endoloc_eval::Midline>,
    /// Training positions and their sections, for the section of the nearest one.
    sections: Option<(Vec<nalgebra::Point3<f64>>, Vec<endoloc_data::Section>)>,
    thumb: (u32, u32),
    /// What could not be shown (e.g. no map), one line each.
    pub missing: Vec<String>,
}

/// One frame as the live page receives it (JSON; lengths in mm, `est` as `x y z qx qy qz qw`).
#[derive(Debug, Serialize)]
struct LiveFrame<'a> {
    frame: usize,
    t: f64,
    est: Option<[f64; 7]>,
    zone: Option<usize>,
    zone_score: Option<f64>,
    status: u8,
    reason: &'a str,
    inliers: Option<usize>,
    rms: Option<f64>,
    time_ms: f64,
    keypoints: Vec<f64>,
    along: Option<f64>,
    section: Option<&'static str>,
    std_mm: Option<f64>,
    latency_ms: f64,
    image: Option<String>,
    /// When the event left the server, ms since the Unix epoch: the page measures its delay.
    sent: f64,
}

impl LiveView {
    /// The page for `model` (its training pass and map, at most `max_points` of them) and
    /// frames of `camera`; `data`: the dataset the model was trained on, for distances from
    /// the anus and sections.
    ///
    /// # Errors
    /// A model, map or dataset that cannot be read.
    pub fn new(
        model: &Path,
        camera: &Camera,
        data: Option<&Path>,
        title: &str,
        max_points: usize,
    ) -> Result<Self> {
        let mut missing = Vec::new();
        let scene = Scene::of_model(model, max_points, 0, &mut missing)?;
        let (midline, sections, along_from) = match data {
            Some(dir) => {
                let ds = Dataset::open(dir)?;
                let midline = match ds.midline_path() {
                    Some(p) => Some(endoloc_eval::Midline::from_file(&p)?),
                    None => {
                        missing.push(format!(
                            "distance from the anus: {} has no mid-line",
                            dir.display()
                        ));
                        None
                    }
                };
                let train = ds.sequence("train")?;
                let sections = train.sections.clone().map(|s| {
                    let points = train
                        .poses
                        .iter()
                        .map(|p| nalgebra::Point3::from(p.pose.translation.vector))
                        .collect();
                    (points, s)
                });
                if sections.is_none() {
                    missing.push(format!(
                        "sections: {} has no train/sections.csv",
                        dir.display()
                    ));
                }
                (midline, sections, "the anus")
            }
            None => (None, None, "the start of the training pass"),
        };
        let midline = match midline {
            Some(m) => Some(m),
            None => {
                let points: Vec<nalgebra::Point3<f64>> = scene
                    .train
                    .chunks_exact(3)
                    .map(|c| nalgebra::Point3::new(c[0], c[1], c[2]))
                    .collect();
                endoloc_eval::Midline::new(&points, "the training pass").ok()
            }
        };
        let wall = data
            .map(|dir| wall::colon_wall(dir, &mut missing))
            .unwrap_or_default();
        let tw = 320.min(camera.width);
        let th = ((f64::from(tw) * f64::from(camera.height) / f64::from(camera.width)).round()
            as u32)
            .max(1);
        let data = PageData {
            live: true,
            along_from: Some(along_from.to_string()),
            title: title.to_string(),
            frames: 0,
            zones: scene.zones,
            camera: CameraData::of(camera),
            thumb: ThumbData {
                width: tw,
                height: th,
            },
            train: scene.train,
            wall,
            points: scene.points,
            zone_points: scene.zone_points,
            gt: None,
            est: Vec::new(),
            zone: Vec::new(),
            zone_score: Vec::new(),
            status: Vec::new(),
            reason: Vec::new(),
            inliers: Vec::new(),
            rms: Vec::new(),
            time_ms: Vec::new(),
            pos_err: None,
            rot_err: None,
            keypoints: Some(Vec::new()),
            images: Vec::new(),
            image_mime: "image/jpeg",
        };
        Ok(LiveView {
            page: render(&data)?,
            midline,
            sections,
            thumb: (tw, th),
            missing,
        })
    }

    /// The page (HTML, self-contained but for its event stream at `events`, relative).
    pub fn page(&self) -> &str {
        &self.page
    }

    /// The event of one localized frame (JSON, one line) — its pose, status, zone, where it is
    /// along the colon and in which section — twice: with a JPEG thumbnail of the frame (for
    /// the viewers now), and without (for the snapshot of viewers that connect later).
    ///
    /// # Errors
    /// A thumbnail that cannot be encoded, or a value JSON cannot hold.
    pub fn frame_event(&self, f: &crate::localize::StreamedFrame<'_>) -> Result<(String, String)> {
        let r = &f.result;
        let est = r.t_wc.as_ref().map(pose7);
        let centre = r.t_wc.map(|p| nalgebra::Point3::from(p.translation.vector));
        let along = match (&self.midline, centre) {
            (Some(m), Some(c)) => Some(round(m.arc_length_at(&c), 1)),
            _ => None,
        };
        let section = match (&self.sections, centre) {
            (Some((points, sections)), Some(c)) => points
                .iter()
                .map(|p| (p - c).norm_squared())
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .and_then(|(i, _)| sections.get(i))
                .map(|s| s.as_str()),
            _ => None,
        };
        let finite = |x: f64| x.is_finite().then_some(x);
        let record = crate::localize::frame_record(f.index, r);
        let mut event = LiveFrame {
            frame: f.index,
            t: round(f.time_s, 4),
            est,
            zone: record.zone,
            zone_score: record.zone_score.map(|s| round(s, 4)),
            status: match r.status {
                Status::Refined => 0,
                Status::InitOnly => 1,
                Status::Rejected => 2,
            },
            reason: &record.reason,
            inliers: record.inliers,
            rms: record.reprojection_rms_px.map(|x| round(x, 3)),
            time_ms: round(record.time_ms, 2),
            keypoints: r
                .inlier_px
                .iter()
                .flat_map(|p| [round(f64::from(p[0]), 1), round(f64::from(p[1]), 1)])
                .collect(),
            along,
            section,
            std_mm: finite(r.position_std_mm).map(|x| round(x, 3)),
            latency_ms: round(f.latency_ms, 2),
            image: None,
            sent: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0.0, |d| round(d.as_secs_f64() * 1e3, 1)),
        };
        let light = serde_json::to_string(&event)?;
        let bytes = encode_thumb(f.image, self.thumb.0, self.thumb.1, 70)?;
        event.image = Some(endoloc_eval::html::base64(&bytes));
        Ok((serde_json::to_string(&event)?, light))
    }
}

/// The page: the template with the script and the data (JSON; `<` escaped so that no string
/// can close the script element).
fn render(data: &PageData) -> Result<String> {
    let json = serde_json::to_string(data)?.replace('<', "\\u003c");
    let page = TEMPLATE
        .replacen("/*VIEWER_JS*/", SCRIPT, 1)
        .replacen("/*VIEWER_DATA*/", &json, 1);
    Ok(page)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_toml_is_the_default() {
        let job: ViewJob = toml::from_str("").unwrap();
        assert_eq!(job, ViewJob::default());
    }

    #[test]
    fn a_folder_without_frames_csv_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let job = ViewJob {
            run: dir.path().to_path_buf(),
            ..ViewJob::default()
        };
        let err = job.run(&crate::Silent).unwrap_err().to_string();
        assert!(err.contains("not a localization run folder"), "{err}");
        assert!(err.contains("frames.csv"), "{err}");
    }

    fn row(frame: usize, status: Status) -> FrameRecord {
        FrameRecord {
            frame,
            zone: Some(0),
            zone_score: None,
            status,
            reason: String::new(),
            inliers: None,
            reprojection_rms_px: None,
            source: "refined".into(),
            position_std_mm: None,
            orientation_std_deg: None,
            time_ms: 1.0,
        }
    }

    fn stamped(t: f64, x: f64) -> StampedPose {
        StampedPose {
            timestamp_s: t,
            pose: Pose::translation(x, 0.0, 0.0),
        }
    }

    #[test]
    fn poses_go_to_frames_in_order_or_by_timestamp() {
        let path = Path::new("run/trajectory.txt");
        let rows = [
            row(0, Status::Refined),
            row(1, Status::Rejected),
            row(2, Status::InitOnly),
        ];
        let est = [stamped(0.0, 1.0), stamped(0.0667, 3.0)];
        let got = estimates_per_frame(&rows, &est, None, path).unwrap();
        let x: Vec<Option<f64>> = got.iter().map(|p| p.map(|p| p.translation.x)).collect();
        assert_eq!(x, [Some(1.0), None, Some(3.0)]);

        // one pose fewer than the statuses say: matched by timestamp to the ground truth
        let gt = [
            stamped(0.0, 0.0),
            stamped(0.0333, 0.0),
            stamped(0.0667, 0.0),
        ];
        let got = estimates_per_frame(&rows, &est[1..], Some(&gt), path).unwrap();
        assert!(got[0].is_none() && got[1].is_none() && got[2].is_some());
        let err = estimates_per_frame(&rows, &est[1..], None, path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("run/trajectory.txt"), "{err}");
    }

    #[test]
    fn the_script_cannot_be_closed_by_data() {
        let page = TEMPLATE.replacen("/*VIEWER_DATA*/", "{}", 1);
        assert!(page.contains("application/json"));
        assert!(!SCRIPT.contains("</script"));
    }
}
