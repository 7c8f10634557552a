//! A video file (MP4/H.264, MKV, AVI/MJPEG, MOV — whatever FFmpeg decodes) with a tracker's
//! pose log, as an imported recording.
//!
//! Decoding goes through the `ffmpeg` and `ffprobe` programs (Debian: `apt install ffmpeg`):
//! `ffprobe` lists every video frame's presentation time (the container's, so a variable frame
//! rate is respected), `ffmpeg` writes the frames kept by `every` / `fps` (its `select` filter;
//! all of them when neither is set) as PNG into a scratch folder, in the same order
//! (`-fps_mode passthrough`: no frame dropped or duplicated). The frame times
//! are the video's clock; the pose log ([`super::tracker`]) is on its own, and the offset
//! between the two is given or found from the images ([`VideoTime::Auto`]). Frames that get no
//! pose (a dropout of the sensor, outside the log) are left out of the sequence — a posed
//! sequence holds one pose per image — and listed in the notes with their time. A pass
//! without a log keeps every frame with its time only (`frames.txt`): it can be localized,
//! not evaluated.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

use endoloc_geometry::{Camera, Pose};

use super::tracker::{
    OffsetSearch, PoseLog, ResampleConfig, estimate_time_offset, frame_motion, poses_at,
};
use super::{ImportedFrame, ImportedSequence};
use crate::{DataError, StampedPose};

/// How the video's clock maps to the pose log's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VideoTime {
    /// Log time of a frame = its time + this, seconds.
    Offset(f64),
    /// Found by correlating the image motion with the tracker's speed
    /// ([`estimate_time_offset`]) within this many seconds either way.
    Auto {
        /// Largest offset searched, seconds.
        max_s: f64,
    },
}

/// Options of [`read_video`].
#[derive(Debug, Clone, PartialEq)]
pub struct VideoConfig {
    /// The camera of the video's frames (a video carries no intrinsics); its size must be the
    /// frames'.
    pub camera: Camera,
    /// The pose log of the pass; `None` for a pass recorded without one: every frame is kept
    /// (after `every` and `fps`) with its time only, to be localized, not evaluated.
    pub log: Option<PoseLog>,
    /// The clock offset, or how to find it.
    pub time: VideoTime,
    /// A frame gets a pose only when valid log samples lie within this on both sides, seconds.
    pub max_gap_s: f64,
    /// The hand-eye transform `T_sc` (camera in the sensor's frame, mm), when the log is the
    /// sensor's.
    pub sensor_to_camera: Option<Pose>,
    /// Keep every `every`-th frame (1 = all).
    pub every: usize,
    /// Keep at most this many frames per second of video (the first frame, then each one at
    /// least `1 / fps` after the last kept); `None`: all (after `every`).
    pub fps: Option<f64>,
    /// Resize the frames to this size `(width, height)` (area filter); the camera, given for
    /// the video's own size, is scaled with them, so the aspect ratio must stay. `None`: the
    /// video's size.
    pub size: Option<(u32, u32)>,
}

/// A decoded video with its poses; the frames stay on disk as long as this value lives.
#[derive(Debug, Clone)]
pub struct VideoImport {
    /// The recording, its frames as PNG files in a scratch folder that lives as long as this
    /// value.
    pub sequence: ImportedSequence,
    /// The clock offset used: log time = video time + this, seconds.
    pub offset_s: f64,
    /// The estimate, when [`VideoTime::Auto`].
    pub estimate: Option<super::tracker::OffsetEstimate>,
    /// Frames (0-based, of the decoded video, before `every`) left without a pose, with their
    /// times (seconds, the video's clock).
    pub unposed: Vec<(usize, f64)>,
    scratch: Arc<tempfile::TempDir>,
}

impl VideoImport {
    /// The scratch folder holding the decoded frames.
    pub fn scratch_dir(&self) -> &Path {
        self.scratch.path()
    }
}

/// Runs a program, its standard output returned; errors name the video and carry the
/// program's own message.
fn run(video: &Path, program: &str, args: &[&std::ffi::OsStr]) -> Result<Vec<u8>, DataError> {
    let out = Command::new(program).args(args).output().map_err(|e| {
        DataError::invalid(
            video,
            if e.kind() == std::io::ErrorKind::NotFound {
                format!("`{program}` not found: a video is decoded with FFmpeg (Debian: apt install ffmpeg)")
            } else {
                format!("running `{program}`: {e}")
            },
        )
    })?;
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    if !out.status.success() {
        return Err(DataError::invalid(
            video,
            format!(
                "cannot decode the video ({program}: {})",
                lines.last().unwrap_or(&"no message")
            ),
        ));
    }
    // At `-v error` FFmpeg reports only errors: a damaged packet it concealed is still a
    // damaged frame, not one to take a pose for.
    if let Some(first) = lines.first() {
        return Err(DataError::invalid(
            video,
            format!(
                "the video is damaged: {program} reports {} decoding error{}, the first: {first}",
                lines.len(),
                if lines.len() == 1 { "" } else { "s" }
            ),
        ));
    }
    Ok(out.stdout)
}

/// `ffprobe`'s answer (CSV, no keys) for the `entries` of the first video stream.
fn probe(video: &Path, entries: &str) -> Result<String, DataError> {
    let args: Vec<&std::ffi::OsStr> = ["-v", "error", "-select_streams", "v:0", "-show_entries"]
        .iter()
        .map(std::ffi::OsStr::new)
        .chain([
            std::ffi::OsStr::new(entries),
            "-of".as_ref(),
            "csv=p=0".as_ref(),
            video.as_os_str(),
        ])
        .collect();
    let out = run(video, "ffprobe", &args)?;
    Ok(String::from_utf8_lossy(&out).into_owned())
}

/// The presentation time of every frame of the first video stream, seconds, in decoding order.
///
/// # Errors
/// [`DataError::Invalid`] naming the video when `ffprobe` is missing, fails, or lists a frame
/// without a time.
pub fn frame_times(video: &Path) -> Result<Vec<f64>, DataError> {
    let text = probe(video, "frame=best_effort_timestamp_time")?;
    let mut times = Vec::new();
    for (i, l) in text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .enumerate()
    {
        let t: f64 = l.trim_end_matches(',').parse().map_err(|_| {
            DataError::invalid(
                video,
                format!(
                    "frame {i} has no time stamp ({l:?}); expected the container's frame times"
                ),
            )
        })?;
        times.push(t);
    }
    if times.is_empty() {
        return Err(DataError::invalid(video, "no video frames"));
    }
    for (i, w) in times.windows(2).enumerate() {
        if w[1] <= w[0] {
            return Err(DataError::invalid(
                video,
                format!(
                    "frame {} at {} s is not after frame {i} at {} s; expected increasing frame times",
                    i + 1,
                    w[1],
                    w[0]
                ),
            ));
        }
    }
    Ok(times)
}

/// The number of frames of the first video stream as its container states it (read from
/// the header, no decoding); `None` when the container does not say (or `ffprobe` fails).
pub fn frame_count_hint(video: &Path) -> Option<usize> {
    probe(video, "stream=nb_frames")
        .ok()?
        .trim()
        .trim_end_matches(',')
        .parse()
        .ok()
}

/// The mean frame rate of the first video stream as its container states it (`avg_frame_rate`,
/// frames per second); `None` when the container does not say (or `ffprobe` fails).
pub fn frame_rate(video: &Path) -> Option<f64> {
    let text = probe(video, "stream=avg_frame_rate").ok()?;
    let text = text.trim().trim_end_matches(',');
    let rate = match text.split_once('/') {
        Some((n, d)) => n.trim().parse::<f64>().ok()? / d.trim().parse::<f64>().ok()?,
        None => text.parse().ok()?,
    };
    (rate.is_finite() && rate > 0.0).then_some(rate)
}

/// The size `(width, height)` of the first video stream's frames, pixels.
///
/// # Errors
/// [`DataError::Invalid`] naming the video when `ffprobe` is missing or fails.
pub fn frame_size(video: &Path) -> Result<(u32, u32), DataError> {
    let text = probe(video, "stream=width,height")?;
    let mut fields = text.trim().split(',').map(|v| v.trim().parse::<u32>());
    match (fields.next(), fields.next()) {
        (Some(Ok(w)), Some(Ok(h))) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(DataError::invalid(
            video,
            format!("no frame size in ffprobe's answer {:?}", text.trim()),
        )),
    }
}

/// Decodes the frames of the first video stream into `dir` as `000000.png`, `000001.png`, …
/// (RGB; the video's size, or `size` with FFmpeg's area filter), in decoding order — every
/// frame, or only those at the 0-based indices `keep` (sorted; FFmpeg's `select` filter, so
/// that a subsampled long video writes only what is kept) — and returns their paths. Every
/// frame is decoded either way: a damaged one anywhere is an error.
///
/// # Errors
/// [`DataError::Invalid`] naming the video when `ffmpeg` is missing or fails;
/// [`DataError::Io`] when the filter script cannot be written.
pub fn decode_frames(
    video: &Path,
    dir: &Path,
    size: Option<(u32, u32)>,
    keep: Option<&[usize]>,
) -> Result<Vec<PathBuf>, DataError> {
    let pattern = dir.join("%06d.png");
    let mut filters = Vec::new();
    if let Some(keep) = keep {
        filters.push(format!("select='{}'", select_expression(keep)));
    }
    if let Some((w, h)) = size {
        filters.push(format!("scale={w}:{h}:flags=area"));
    }
    // The filter graph as a script file: a long selection does not fit on a command line.
    let script = dir.join("filters.txt");
    if !filters.is_empty() {
        std::fs::write(&script, filters.join(",")).map_err(|e| DataError::io(&script, e))?;
    }
    let mut args: Vec<&std::ffi::OsStr> = [
        std::ffi::OsStr::new("-v"),
        "error".as_ref(),
        "-nostdin".as_ref(),
        "-i".as_ref(),
        video.as_os_str(),
        "-map".as_ref(),
        "0:v:0".as_ref(),
        "-fps_mode".as_ref(),
        "passthrough".as_ref(),
        "-pix_fmt".as_ref(),
        "rgb24".as_ref(),
        "-start_number".as_ref(),
        "0".as_ref(),
    ]
    .to_vec();
    if !filters.is_empty() {
        args.extend([std::ffi::OsStr::new("-filter_script:v"), script.as_os_str()]);
    }
    args.push(pattern.as_os_str());
    run(video, "ffmpeg", &args)?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| DataError::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    Ok(files)
}

/// An FFmpeg expression true for the frames numbered `keep` (sorted, not empty): a binary
/// search of nested `if`s, evaluated one branch at a time — `O(log n)` a frame, and nested
/// only `log2 n` deep (FFmpeg refuses a flat sum of more than about a hundred terms).
fn select_expression(keep: &[usize]) -> String {
    match keep {
        [] => "0".to_string(),
        [i] => format!("eq(n,{i})"),
        _ => {
            let (lo, hi) = keep.split_at(keep.len() / 2);
            format!(
                "if(lt(n,{}),{},{})",
                hi[0],
                select_expression(lo),
                select_expression(hi)
            )
        }
    }
}

/// Reads a video and its pose log as a recording (see the module docs).
///
/// # Errors
/// [`DataError::Invalid`] naming the video when it cannot be decoded, when its frame count
/// differs from its frame times' (a damaged file), when its frames are not the camera's size,
/// when the clock offset cannot be found, or when no frame gets a pose.
pub fn read_video(video: &Path, cfg: &VideoConfig) -> Result<VideoImport, DataError> {
    if cfg.every == 0 {
        return Err(DataError::invalid(video, "every = 0; expected 1 or more"));
    }
    if let Some(fps) = cfg.fps
        && !(fps.is_finite() && fps > 0.0)
    {
        return Err(DataError::invalid(
            video,
            format!("fps = {fps}; expected a value > 0"),
        ));
    }
    let native = frame_size(video)?;
    let c = &cfg.camera;
    if native != (c.width, c.height) {
        return Err(DataError::invalid(
            video,
            format!(
                "frames are {}x{}; expected the camera's {}x{} (the camera is that of the video's own frames)",
                native.0, native.1, c.width, c.height
            ),
        ));
    }
    let camera = match cfg.size {
        None => cfg.camera,
        Some((w, h)) => {
            // The same aspect ratio, to a pixel.
            let scale = f64::from(w) / f64::from(c.width);
            let scaled = c.scaled(scale);
            if (scaled.width, scaled.height) != (w, h) {
                return Err(DataError::invalid(
                    video,
                    format!(
                        "size {w}x{h} has another aspect ratio than the video's {}x{}; expected {}x{} for that width",
                        c.width, c.height, scaled.width, scaled.height
                    ),
                ));
            }
            scaled
        }
    };
    let all_times = frame_times(video)?;
    let scratch = Arc::new(
        tempfile::Builder::new()
            .prefix("endoloc-video-")
            .tempdir()
            .map_err(|e| DataError::io(std::env::temp_dir(), e))?,
    );
    // Only the frames kept by `every` and `fps` are written out, each with its index in the
    // video and its time.
    let kept = kept_frames(&all_times, cfg);
    let select = (kept.len() < all_times.len()).then_some(kept.as_slice());
    let files = decode_frames(video, scratch.path(), cfg.size, select)?;
    if files.len() != kept.len() {
        return Err(DataError::invalid(
            video,
            format!(
                "ffprobe lists {} frames ({} kept) but ffmpeg wrote {}; expected the same frames (a damaged file?)",
                all_times.len(),
                kept.len(),
                files.len()
            ),
        ));
    }
    let times: Vec<f64> = kept.iter().map(|&i| all_times[i]).collect();
    let Some(log) = &cfg.log else {
        return Ok(unposed_import(video, camera, files, &times, scratch));
    };
    // The camera's own path: its speed is what moves the image (a sensor a few millimetres
    // away moves differently whenever the scope turns).
    let log = match &cfg.sensor_to_camera {
        Some(t_sc) => log.to_camera(t_sc),
        None => log.clone(),
    };
    let (offset_s, estimate) = match cfg.time {
        VideoTime::Offset(s) => (s, None),
        VideoTime::Auto { max_s } => {
            let motion = image_motion(&files)?;
            let search = OffsetSearch {
                max_s,
                ..OffsetSearch::default()
            };
            let e = estimate_time_offset(&log, &times, &motion, &search).ok_or_else(|| {
                DataError::invalid(
                    video,
                    format!(
                        "cannot find the clock offset: the video ({:.2}–{:.2} s) and the log {} \
                         overlap by fewer than {} frames at every offset within ±{max_s} s",
                        times[0],
                        times[times.len() - 1],
                        log.source.display(),
                        search.min_frames
                    ),
                )
            })?;
            (e.offset_s, Some(e))
        }
    };
    let resample = ResampleConfig {
        time_offset_s: offset_s,
        max_gap_s: cfg.max_gap_s,
        sensor_to_camera: None,
    };
    let poses = poses_at(&log, &times, &resample);
    let mut frames = Vec::new();
    let mut unposed = Vec::new();
    for (((&i, file), &t), pose) in kept.iter().zip(&files).zip(&times).zip(&poses) {
        match pose {
            Some(p) => frames.push(ImportedFrame {
                image: file.clone(),
                depth: None,
                pose: StampedPose {
                    timestamp_s: t,
                    pose: *p,
                },
            }),
            None => unposed.push((i, t)),
        }
    }
    if frames.is_empty() {
        return Err(DataError::invalid(
            video,
            format!(
                "no frame has a pose: the log {} covers {:.2}–{:.2} s, the video {:.2}–{:.2} s \
                 plus the offset {offset_s:.3} s",
                log.source.display(),
                log.samples[0].time_s,
                log.samples[log.samples.len() - 1].time_s,
                times[0] + offset_s,
                times[times.len() - 1] + offset_s
            ),
        ));
    }
    let mut notes = log.notes.clone();
    if let Some(e) = &estimate {
        notes.push(format!(
            "clock offset found from the images: log time = video time + {:.3} s (fit R {:.2}, \
             {:.2} better than any offset ≥ 0.25 s away, {} frames)",
            e.offset_s, e.correlation, e.margin, e.frames
        ));
    }
    if !unposed.is_empty() {
        let list: Vec<String> = unposed
            .iter()
            .map(|(i, t)| format!("{i} ({t:.3} s)"))
            .collect();
        notes.push(format!(
            "{} frames have no pose within {} ms of a valid log sample and are left out: {}",
            unposed.len(),
            cfg.max_gap_s * 1000.0,
            list.join(", ")
        ));
    }
    Ok(VideoImport {
        sequence: ImportedSequence {
            source: video.to_path_buf(),
            frames,
            depth_encoding: None,
            camera,
            notes,
            posed: true,
        },
        offset_s,
        estimate,
        unposed,
        scratch,
    })
}

/// The frames kept by `every` and `fps`, indices into the decoded video.
fn kept_frames(times: &[f64], cfg: &VideoConfig) -> Vec<usize> {
    let mut kept = Vec::new();
    let mut next_kept = f64::NEG_INFINITY;
    for (i, &t) in times.iter().enumerate() {
        if i % cfg.every != 0 || t < next_kept {
            continue;
        }
        if let Some(fps) = cfg.fps {
            // Half a millisecond of slack: container times are rounded.
            next_kept = t + 1.0 / fps - 5e-4;
        }
        kept.push(i);
    }
    kept
}

/// A pass without a pose log: each kept frame (`files`, at `times` on the video's clock) with
/// no pose.
fn unposed_import(
    video: &Path,
    camera: Camera,
    files: Vec<PathBuf>,
    times: &[f64],
    scratch: Arc<tempfile::TempDir>,
) -> VideoImport {
    let frames = files
        .into_iter()
        .zip(times)
        .map(|(image, &timestamp_s)| ImportedFrame {
            image,
            depth: None,
            pose: StampedPose {
                timestamp_s,
                pose: Pose::identity(),
            },
        })
        .collect();
    VideoImport {
        sequence: ImportedSequence {
            source: video.to_path_buf(),
            frames,
            depth_encoding: None,
            camera,
            notes: vec![
                "no pose log: the frames are kept with their times (frames.txt), to be \
                 localized, not evaluated"
                    .to_string(),
            ],
            posed: false,
        },
        offset_s: 0.0,
        estimate: None,
        unposed: Vec::new(),
        scratch,
    }
}

/// [`frame_motion`] between consecutive decoded frames (`NaN` for the first).
fn image_motion(files: &[PathBuf]) -> Result<Vec<f64>, DataError> {
    let load = |p: &PathBuf| -> Result<image::GrayImage, DataError> {
        Ok(image::open(p)
            .map_err(|e| DataError::image(p, e.to_string()))?
            .to_luma8())
    };
    let mut out = Vec::with_capacity(files.len());
    let mut prev: Option<image::GrayImage> = None;
    for f in files {
        let img = load(f)?;
        out.push(prev.as_ref().map_or(f64::NAN, |p| frame_motion(p, &img)));
        prev = Some(img);
    }
    Ok(out)
}
