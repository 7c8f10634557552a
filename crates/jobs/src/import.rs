//! `ImportJob`: a C3VD, SimCol3D or EndoSLAM recording as an endoloc dataset.

use std::fmt;
use std::path::{Path, PathBuf};

use endoloc_data::DataError;
use endoloc_data::import::c3vd::{C3vdConfig, read_c3vd};
use endoloc_data::import::endoslam::{EndoSlamConfig, Units, read_endoslam};
use endoloc_data::import::simcol3d::{SimCol3dConfig, read_simcol3d};
use endoloc_data::import::split::{parse_split, split_sequence};
use endoloc_data::import::tracker::{OffsetEstimate, TrackerLogConfig, read_pose_log};
use endoloc_data::import::video::{VideoConfig, VideoImport, VideoTime, read_video};
use endoloc_data::import::{ImportSummary, ImportedSequence, WriteImportConfig, write_import};
use endoloc_geometry::{Camera, Distortion, Pose, pose_from_matrix};
use nalgebra::Matrix4;
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::error::{Context, JobError, Result};
use crate::progress::Progress;

/// A source format of [`ImportJob`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum ImportFormat {
    /// C3VD recording folder: pose.txt (16 values per line, column-major T_wc in mm),
    /// {n}_color.png, optional {NNNN}_depth.tiff (mm = v / 65535 × 100). Camera: the common
    /// pinhole + OpenCV-fisheye fit of C3VD's omnidirectional model (1350×1080) unless
    /// `camera`.
    #[default]
    C3vd,
    /// SimCol3D colon folder (SavedPosition_S*.txt in cm, SavedRotationQuaternion_S*.txt,
    /// Frames_S*/FrameBuffer_NNNN.png, optional Frames_S*/Depth_NNNN.png) or one Frames_S*
    /// folder. Unity's left-handed y-up poses are converted with R = S·R·S, t = 10·S·t,
    /// S = diag(1,-1,1). Depth (16-bit, z-depth) is imported when every frame has a
    /// Depth_NNNN.png, with the organisers' scale mm = v / (255 × 256) × 200 (65280 = 20 cm).
    /// Camera: 475×475, fx = fy = 227.60416, cx = cy = 237.5 unless `camera` (cam.txt is
    /// ambiguous).
    Simcol3d,
    /// EndoSLAM recording: UnityCam (Poses/*.csv `tX,tY,tZ,rX,rY,rZ,rW,time(s)`, paired with
    /// Frames/ by row, Unity axes converted) or ex-vivo (an .xlsx pose workbook, or a CSV
    /// export of its sheet, with columns `ImageFrame,Pose_Index,trans_x..z,quot_x..w`, joined
    /// to the frames on ImageFrame; the sheet is `sheet`, else the first whose header has
    /// ImageFrame). The length unit and the camera are not documented: give both (`units`,
    /// `camera`).
    Endoslam,
    /// A video file (MP4/H.264, MKV, AVI/MJPEG, MOV: whatever FFmpeg decodes; `ffmpeg` and
    /// `ffprobe` must be installed) with the pass's pose log (`poses`: a tracker CSV with a
    /// header, TUM, or C3VD's pose.txt at `log_rate_hz`; `units`, default mm), on the log's own clock (`time_offset`, or
    /// `auto`: found from the images), resampled at each frame's time from the container;
    /// frames without a pose within `max_gap_ms` are left out and listed. The camera
    /// (`camera`) is required: a video carries no intrinsics.
    Video,
}

impl ImportFormat {
    /// Lower-case name, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ImportFormat::C3vd => "c3vd",
            ImportFormat::Simcol3d => "simcol3d",
            ImportFormat::Endoslam => "endoslam",
            ImportFormat::Video => "video",
        }
    }
}

/// Imports the recording `src` as an endoloc dataset in `out` (format v1: mm, `T_wc`, OpenCV
/// camera axes, TUM `poses.txt`, PNG images, 16-bit depth PNG). One recording becomes the
/// sequence `seq`; `split` cuts it into sequences, or `test` adds a second recording of the
/// same colon as `test` (then `src` is `train`). An existing `out` is kept unless `force`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ImportJob {
    /// Source format.
    #[cfg_attr(feature = "cli", arg(value_enum, value_name = "FORMAT"))]
    pub format: ImportFormat,
    /// The recording folder (C3VD: holding pose.txt; SimCol3D: the colon folder or a
    /// Frames_S* folder; EndoSLAM: holding Frames/ and Poses/).
    #[cfg_attr(feature = "cli", arg(value_name = "SRC"))]
    pub src: PathBuf,
    /// Output dataset folder.
    #[cfg_attr(feature = "cli", arg(short, long))]
    pub out: PathBuf,
    /// Replace an existing dataset at `out`.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
    /// Dataset name in dataset.toml (default: the output folder's name).
    #[cfg_attr(feature = "cli", arg(long))]
    pub name: Option<String>,
    /// Cut the recording into sequences by 0-based, end-exclusive frame ranges, e.g.
    /// `train:0..1500,test:1500..` (ranges must not overlap).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "NAME:START..END,…", conflicts_with = "test")
    )]
    pub split: Option<String>,
    /// A second recording of the same colon (same format and options), written as `test`;
    /// SRC is then written as `train`.
    #[cfg_attr(feature = "cli", arg(long, value_name = "SRC2"))]
    pub test: Option<PathBuf>,
    /// Sequence name for SRC when neither `split` nor `test` is given; when `out` is an
    /// existing dataset, SRC is added to it under this name.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ImportJob::default().seq))]
    pub seq: String,
    /// Frame rate for the time stamps (frame i at i / fps s) where the source has none.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ImportJob::default().fps))]
    pub fps: f64,
    /// Import the depth maps (C3VD, SimCol3D; on by default, `no_depth` turns it off).
    #[cfg_attr(feature = "cli", arg(long = "no-depth", action = clap::ArgAction::SetFalse))]
    pub depth: bool,
    /// Camera: W,H,FX,FY,CX,CY (pinhole), or for C3VD also W,H,FX,FY,CX,CY,K1,K2,K3,K4
    /// (OpenCV fisheye). Default: the format's camera; EndoSLAM needs it: it ships its
    /// calibrations only as MATLAB cameraParameters objects
    /// (Calibration/Camera/*/*_cameraParams_pinhole.mat), which only MATLAB decodes: read
    /// ImageSize, FocalLength and PrincipalPoint there.
    #[cfg_attr(feature = "cli", arg(long, value_name = "W,H,FX,FY,CX,CY[,K1..K4]"))]
    pub camera: Option<String>,
    /// C3VD: resample images (bilinear) and depth (nearest) through the fisheye model into a
    /// pinhole with the same size, fx, fy, cx, cy; the dataset's camera is that pinhole.
    #[cfg_attr(feature = "cli", arg(long))]
    pub undistort: bool,
    /// SimCol3D: trajectory suffix when the folder holds several (S1 for
    /// SavedPosition_S1.txt).
    #[cfg_attr(feature = "cli", arg(long))]
    pub sequence: Option<String>,
    /// EndoSLAM (required) and video (default mm): length unit of the pose file.
    #[cfg_attr(feature = "cli", arg(long, value_parser = ["mm", "cm", "m"]))]
    pub units: Option<String>,
    /// EndoSLAM: pose file, .csv or .xlsx (default: the only .csv or .xlsx in SRC/Poses,
    /// else in SRC). Video: the pass's pose log; without one the frames are kept with their
    /// times only (`frames.txt`): the pass can be localized, not evaluated.
    #[cfg_attr(feature = "cli", arg(long))]
    pub poses: Option<PathBuf>,
    /// Video: the rate of a pose log without time stamps (C3VD's pose.txt, one camera pose
    /// per frame), Hz; line k is taken at k / rate. Default: the video's frame rate.
    #[cfg_attr(feature = "cli", arg(long, value_name = "HZ"))]
    pub log_rate_hz: Option<f64>,
    /// Video: the pose log of the `test` video.
    #[cfg_attr(feature = "cli", arg(long, requires = "test"))]
    pub test_poses: Option<PathBuf>,
    /// Video: log time of a frame = its time in the video + this many seconds, or `auto`
    /// (found by matching the image motion to the tracker's speed, within ±5 s; the report
    /// gives the offset and how clearly it stood out).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ImportJob::default().time_offset))]
    pub time_offset: String,
    /// Video: a frame gets a pose only when valid log samples lie within this on both sides,
    /// milliseconds.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ImportJob::default().max_gap_ms))]
    pub max_gap_ms: f64,
    /// Video: the hand-eye transform, a text file with the 4×4 matrix `T_sc` (the camera in
    /// the tracked sensor's frame; four rows of four numbers, translation in the log's
    /// `units`), when the log is the sensor's and not the camera's.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE"))]
    pub sensor_to_camera: Option<PathBuf>,
    /// Video: keep every N-th frame.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ImportJob::default().every))]
    pub every: usize,
    /// Video: keep at most this many frames per second (after `every`).
    #[cfg_attr(feature = "cli", arg(long))]
    pub max_fps: Option<f64>,
    /// Video: resize the frames to WxH (the same aspect ratio; `camera` is given for the
    /// video's own size and scaled with them).
    #[cfg_attr(feature = "cli", arg(long, value_name = "WxH"))]
    pub size: Option<String>,
    /// EndoSLAM: worksheet of an .xlsx pose file (default: the first sheet whose header row
    /// has an ImageFrame column, else the first sheet).
    #[cfg_attr(feature = "cli", arg(long))]
    pub sheet: Option<String>,
    /// EndoSLAM: frames folder (default: SRC/Frames, else SRC).
    #[cfg_attr(feature = "cli", arg(long))]
    pub frames: Option<PathBuf>,
    /// The command line recorded in dataset.toml (`None`: not recorded). Set by the caller,
    /// not an option of the import.
    #[cfg_attr(feature = "cli", arg(skip))]
    pub command: Option<String>,
}

impl Default for ImportJob {
    fn default() -> Self {
        let c3vd = C3vdConfig::default();
        ImportJob {
            format: ImportFormat::C3vd,
            src: PathBuf::new(),
            out: PathBuf::new(),
            force: false,
            name: None,
            split: None,
            test: None,
            seq: "train".into(),
            fps: c3vd.fps,
            depth: c3vd.depth,
            camera: None,
            undistort: false,
            sequence: None,
            units: None,
            poses: None,
            log_rate_hz: None,
            test_poses: None,
            time_offset: "0".into(),
            max_gap_ms: 50.0,
            sensor_to_camera: None,
            every: 1,
            max_fps: None,
            size: None,
            sheet: None,
            frames: None,
            command: None,
        }
    }
}

/// What `ImportJob` wrote.
#[derive(Debug, Clone)]
pub struct ImportReport {
    /// Source format.
    pub format: ImportFormat,
    /// Folder, camera and sequences written.
    pub summary: ImportSummary,
    /// Video: each pass's clock offset and the frames left without a pose.
    pub videos: Vec<VideoPass>,
}

/// One imported video pass.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoPass {
    /// Sequence name.
    pub name: String,
    /// Log time = video time + this, seconds.
    pub offset_s: f64,
    /// How it was found, with `time_offset` auto.
    pub estimate: Option<OffsetEstimate>,
    /// Frames of the video (0-based, before `every`) left without a pose, with their times in
    /// the video, seconds.
    pub unposed: Vec<(usize, f64)>,
    /// Whether the pass came with a pose log (false: its frames have times only,
    /// `frames.txt`).
    pub posed: bool,
}

/// Reads a 4×4 rigid transform from a text file (four rows of four numbers), translation in
/// `units`, as a pose in mm.
fn read_transform(path: &Path, units: Units) -> Result<Pose> {
    let text = std::fs::read_to_string(path).map_err(|e| JobError::Data(DataError::io(path, e)))?;
    let mut values = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let row: Vec<&str> = l
            .split([' ', ',', '\t'])
            .filter(|c| !c.is_empty())
            .collect();
        if row.len() != 4 {
            return Err(DataError::parse(
                path,
                i + 1,
                format!(
                    "{} numbers; expected 4 (a row of the 4×4 matrix)",
                    row.len()
                ),
            )
            .into());
        }
        for c in row {
            values.push(c.parse::<f64>().map_err(|_| {
                JobError::from(DataError::parse(
                    path,
                    i + 1,
                    format!("{c:?} is not a number"),
                ))
            })?);
        }
    }
    if values.len() != 16 {
        return Err(DataError::invalid(
            path,
            format!("{} rows; expected 4 (a 4×4 matrix)", values.len() / 4),
        )
        .into());
    }
    let mut m = Matrix4::from_row_slice(&values);
    for r in 0..3 {
        m[(r, 3)] *= units.mm_per_unit();
    }
    pose_from_matrix(&m, 1e-3).map_err(|e| DataError::invalid(path, e).into())
}

/// Parses `W,H,FX,FY,CX,CY` (and, when `allow_fisheye`, 4 more fisheye coefficients).
///
/// # Errors
/// A malformed list or a camera that does not validate.
pub fn parse_camera(text: &str, allow_fisheye: bool) -> Result<Camera> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .map_err(|e| JobError::Invalid(format!("`camera`: {s:?} is not a number: {e}")))
        })
        .collect::<Result<_>>()?;
    let distortion = match (v.len(), allow_fisheye) {
        (6, _) => Distortion::None,
        (10, true) => Distortion::Fisheye {
            k1: v[6],
            k2: v[7],
            k3: v[8],
            k4: v[9],
        },
        (n, true) => {
            bail!("`camera`: {n} values; expected W,H,FX,FY,CX,CY or W,H,FX,FY,CX,CY,K1,K2,K3,K4")
        }
        (n, false) => bail!("`camera`: {n} values; expected W,H,FX,FY,CX,CY"),
    };
    let size = |x: f64, what: &str| -> Result<u32> {
        if x.fract() != 0.0 || !(1.0..=100_000.0).contains(&x) {
            bail!("`camera`: {what} = {x}; expected a positive whole number of pixels");
        }
        Ok(x as u32)
    };
    let cam = Camera {
        width: size(v[0], "W")?,
        height: size(v[1], "H")?,
        fx: v[2],
        fy: v[3],
        cx: v[4],
        cy: v[5],
        distortion,
    };
    cam.validate()
        .map_err(|e| JobError::Invalid(format!("`camera`: {e}")))?;
    Ok(cam)
}

type Reader = Box<dyn Fn(&Path) -> Result<ImportedSequence, DataError>>;

impl ImportJob {
    /// The reader of this job's format, for `src` and `test`.
    fn reader(&self) -> Result<Reader> {
        let camera = |fisheye| self.camera.as_deref().map(|c| parse_camera(c, fisheye));
        let first = self.src.clone();
        Ok(match self.format {
            ImportFormat::C3vd => {
                let mut cfg = C3vdConfig {
                    fps: self.fps,
                    depth: self.depth,
                    ..C3vdConfig::default()
                };
                if let Some(c) = camera(true) {
                    cfg.camera = c?;
                }
                Box::new(move |p| read_c3vd(p, &cfg))
            }
            ImportFormat::Simcol3d => {
                let mut cfg = SimCol3dConfig {
                    fps: self.fps,
                    sequence: self.sequence.clone(),
                    depth: self.depth,
                    cam_txt: self.camera.is_none(),
                    ..SimCol3dConfig::default()
                };
                if let Some(c) = camera(false) {
                    cfg.camera = c?;
                }
                // A test recording is usually another Frames_S* folder: its suffix comes
                // from its own folder name, not from `sequence`.
                let test_cfg = SimCol3dConfig {
                    sequence: None,
                    ..cfg.clone()
                };
                Box::new(move |p| read_simcol3d(p, if p == first { &cfg } else { &test_cfg }))
            }
            ImportFormat::Endoslam => {
                let units = self.units_or(None)?;
                let cfg = EndoSlamConfig {
                    camera: camera(false)
                        .context("endoslam: the camera (`camera` W,H,FX,FY,CX,CY) is required")??,
                    units,
                    poses: self.poses.clone(),
                    sheet: self.sheet.clone(),
                    frames: self.frames.clone(),
                    fps: self.fps,
                };
                let test_cfg = EndoSlamConfig {
                    poses: None,
                    sheet: None,
                    frames: None,
                    ..cfg.clone()
                };
                Box::new(move |p| read_endoslam(p, if p == first { &cfg } else { &test_cfg }))
            }
            ImportFormat::Video => bail!("video: read with `ImportJob::read_videos`"),
        })
    }

    /// The length unit of the pose file: `units`, or `default` when not given.
    fn units_or(&self, default: Option<Units>) -> Result<Units> {
        Ok(match self.units.as_deref() {
            Some("mm") => Units::Mm,
            Some("cm") => Units::Cm,
            Some("m") => Units::M,
            None if let Some(d) = default => d,
            other => bail!(
                "{}: `units` {other:?}; expected mm, cm or m",
                self.format.name()
            ),
        })
    }

    /// Video: decodes `src` (and `test`) with their pose logs.
    fn read_videos(&self) -> Result<Vec<(String, VideoImport)>> {
        let camera = parse_camera(
            self.camera
                .as_deref()
                .context("video: the camera (`camera` W,H,FX,FY,CX,CY) is required: a video carries no intrinsics")?,
            true,
        )?;
        let units = self.units_or(Some(Units::Mm))?;
        let time = match self.time_offset.trim() {
            "auto" => VideoTime::Auto { max_s: 5.0 },
            t => VideoTime::Offset(t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(
                || {
                    JobError::Invalid(format!(
                        "`time_offset` {t:?}; expected seconds (e.g. 0.35) or auto"
                    ))
                },
            )?),
        };
        if !(self.max_gap_ms.is_finite() && self.max_gap_ms > 0.0) {
            bail!(
                "`max_gap_ms` = {}; expected a finite value > 0",
                self.max_gap_ms
            );
        }
        let size = self
            .size
            .as_deref()
            .map(crate::localize::parse_size)
            .transpose()?;
        let sensor_to_camera = match &self.sensor_to_camera {
            Some(p) => Some(read_transform(p, units)?),
            None => None,
        };
        let mut passes = vec![("train", &self.src, self.poses.as_ref())];
        if let Some(t) = &self.test {
            passes.push(("test", t, self.test_poses.as_ref()));
        } else {
            passes[0].0 = self.seq.as_str();
        }
        let mut out = Vec::new();
        for (name, video, poses) in passes {
            let log = match poses {
                Some(poses) => {
                    let rate_hz = self
                        .log_rate_hz
                        .or_else(|| endoloc_data::import::video::frame_rate(video));
                    Some(read_pose_log(poses, &TrackerLogConfig { units, rate_hz })?)
                }
                None if time != VideoTime::Offset(0.0) || sensor_to_camera.is_some() => bail!(
                    "video {}: `time_offset` and `sensor_to_camera` apply to a pose log; none \
                     is given (`{}`)",
                    video.display(),
                    if name == "test" && self.test.is_some() {
                        "test_poses"
                    } else {
                        "poses"
                    }
                ),
                None => None,
            };
            let cfg = VideoConfig {
                camera,
                log,
                time,
                max_gap_s: self.max_gap_ms / 1000.0,
                sensor_to_camera,
                every: self.every,
                fps: self.max_fps,
                size,
            };
            let v = read_video(video, &cfg)
                .with_context(|| format!("reading video {}", video.display()))?;
            out.push((name.to_string(), v));
        }
        Ok(out)
    }

    /// Reads the recording(s) and writes the dataset.
    ///
    /// # Errors
    /// Invalid settings, an unreadable recording, an existing `out` without `force`, or a
    /// failed write.
    pub fn run(&self, _progress: &dyn Progress) -> Result<ImportReport> {
        // Decoded videos keep their frames on disk while they live: until the dataset is
        // written.
        let videos = if self.format == ImportFormat::Video {
            if self.split.is_some() {
                bail!("video: `split` is not supported; import each pass as its own video");
            }
            self.read_videos()?
        } else {
            Vec::new()
        };
        let sequences = if !videos.is_empty() {
            videos
                .iter()
                .map(|(name, v)| (name.clone(), v.sequence.clone()))
                .collect()
        } else {
            self.read_sequences()?
        };
        self.write(&sequences, &videos)
    }

    /// Reads the recording(s) of a format other than video.
    fn read_sequences(&self) -> Result<Vec<(String, ImportedSequence)>> {
        let format = self.format.name();
        let read = self.reader()?;
        let src = &self.src;
        let main =
            read(src).with_context(|| format!("reading {format} recording {}", src.display()))?;
        Ok(if let Some(spec) = &self.split {
            let parts =
                parse_split(spec).map_err(|e| JobError::Invalid(format!("`split`: {e}")))?;
            split_sequence(&main, &parts)?
        } else if let Some(test) = &self.test {
            let t = read(test)
                .with_context(|| format!("reading {format} test recording {}", test.display()))?;
            vec![("train".to_string(), main), ("test".to_string(), t)]
        } else {
            vec![(self.seq.clone(), main)]
        })
    }

    /// Writes the dataset.
    fn write(
        &self,
        sequences: &[(String, ImportedSequence)],
        videos: &[(String, VideoImport)],
    ) -> Result<ImportReport> {
        let format = self.format.name();
        let src = &self.src;
        let mut source = toml::Table::new();
        source.insert("tool".into(), format!("endoloc import {format}").into());
        source.insert("version".into(), env!("CARGO_PKG_VERSION").into());
        source.insert("format".into(), format.into());
        if let Some(command) = &self.command {
            source.insert("command".into(), command.clone().into());
        }
        let mut recordings = vec![toml::Value::from(src.display().to_string())];
        if let Some(t) = &self.test {
            recordings.push(t.display().to_string().into());
        }
        source.insert("recordings".into(), toml::Value::Array(recordings));
        for (name, v) in videos.iter().filter(|(_, v)| v.sequence.posed) {
            source.insert(
                format!("{name}_time_offset_s"),
                toml::Value::Float(v.offset_s),
            );
        }
        let name = self.name.clone().unwrap_or_else(|| {
            self.out.file_name().map_or_else(
                || format!("{format} import"),
                |n| n.to_string_lossy().into_owned(),
            )
        });
        let summary = write_import(
            &self.out,
            sequences,
            &WriteImportConfig {
                name,
                undistort: self.undistort && self.format == ImportFormat::C3vd,
                overwrite: self.force,
                add: self.split.is_none() && self.test.is_none(),
                source,
            },
        )
        .map_err(|e| JobError::Context {
            context: match e {
                DataError::AlreadyExists { .. } => {
                    "not replacing it: `force` overwrites it".to_string()
                }
                _ => format!("writing {}", self.out.display()),
            },
            source: Box::new(e.into()),
        })?;
        for (_, s) in sequences {
            for n in &s.notes {
                tracing::info!("{}: {n}", s.source.display());
            }
        }
        Ok(ImportReport {
            format: self.format,
            summary,
            videos: videos
                .iter()
                .map(|(name, v)| VideoPass {
                    name: name.clone(),
                    offset_s: v.offset_s,
                    estimate: v.estimate,
                    unposed: v.unposed.clone(),
                    posed: v.sequence.posed,
                })
                .collect(),
        })
    }
}

impl fmt::Display for ImportReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.summary;
        let c = &s.camera;
        write!(
            f,
            "imported {} into {}: camera {}x{} fx {} fy {} cx {} cy {}{}",
            self.format.name(),
            s.dir.display(),
            c.width,
            c.height,
            c.fx,
            c.fy,
            c.cx,
            c.cy,
            if c.distortion.is_none() {
                String::new()
            } else {
                format!(" {:?}", c.distortion)
            }
        )?;
        for (name, frames, depth) in &s.sequences {
            write!(
                f,
                "\n  {name}: {frames} frames{}",
                if *depth { ", depth" } else { "" }
            )?;
            if let Some(v) = self.videos.iter().find(|v| &v.name == name) {
                if !v.posed {
                    write!(
                        f,
                        "; no pose log: frame times only (frames.txt), to be localized"
                    )?;
                    continue;
                }
                match &v.estimate {
                    Some(e) => write!(
                        f,
                        "; clock offset found: log = video + {:.3} s (fit R {:.2}, margin {:.2})",
                        e.offset_s, e.correlation, e.margin
                    )?,
                    None => write!(f, "; clock offset {} s", v.offset_s)?,
                }
                if !v.unposed.is_empty() {
                    let shown: Vec<String> = v
                        .unposed
                        .iter()
                        .take(8)
                        .map(|(i, t)| format!("{i} ({t:.2} s)"))
                        .collect();
                    write!(
                        f,
                        "; {} frames without a pose left out: {}{}",
                        v.unposed.len(),
                        shown.join(", "),
                        if v.unposed.len() > 8 { ", …" } else { "" }
                    )?;
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_library_defaults() {
        let from_toml: ImportJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, ImportJob::default());
        let (c3vd, simcol) = (C3vdConfig::default(), SimCol3dConfig::default());
        assert_eq!((simcol.fps, simcol.depth), (c3vd.fps, c3vd.depth));
        assert_eq!(ImportJob::default().fps, c3vd.fps);
        assert!(parse_camera("320,240,200,200,160,120", false).is_ok());
        assert!(parse_camera("320,240,200,200,160,120,0,0,0,0", false).is_err());
    }
}
