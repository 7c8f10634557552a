//! `LiveBenchJob`: a test pass replayed as a live stream, timed stage by stage.
//!
//! Frames are decoded before each frame's clock starts (a scope's frames arrive decoded) and
//! fed one by one to [`Localizer::localize_live`]. With `compare`, every frame is also
//! localized by the plain path: SURF's reference loop
//! ([`endoloc_features::SurfConfig::reference_filters`]), the zone classifier on every frame
//! ([`endoloc_localize::LocalizerConfig::classify_tracked`]) and brute-force matching of
//! tracked frames ([`endoloc_localize::MotionConfig::search_px`] 0). The two alternate which
//! goes first from frame to frame, so both see the same machine load, and the speed-up is a
//! ratio measured in one run. With `against`, the current localizer replays a second sequence
//! instead (the same pass through the unchanged colon, say), frame by frame alternating with
//! the first, each with its own live state: the slow-down of a changed colon, again a ratio
//! from one run. With `video`, a video file goes through `localize --live --video` as it would
//! for a user (decoded by FFmpeg while it is read, paced at its frame times with `realtime`),
//! after a pass that only decodes it, to time decoding and resizing apart. Nothing is written
//! (the run's files go to a scratch folder).

use std::fmt;
use std::path::{Path, PathBuf};

use endoloc_data::Sequence;
use endoloc_features::SurfConfig;
use endoloc_localize::{FrameResult, Localizer};
use serde::{Deserialize, Serialize};

use std::time::Instant;

use endoloc_data::stream::FrameStream;

use crate::bail;
use crate::error::{Context, Result};
use crate::localize::{LatencyHistogram, LocalizeJob, RunSummary, StreamSummary, dataset_mask};
use crate::progress::{Progress, bar};

/// Replays a sequence as a live stream through the localizer and reports per-stage latency.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct LiveBenchJob {
    /// Model folder with its map (the train and map jobs).
    #[cfg_attr(feature = "cli", arg(long))]
    pub model: PathBuf,
    /// Sequence folder to replay in frame order, e.g. data/paper/test; or `video`.
    #[cfg_attr(
        feature = "cli",
        arg(
            long,
            default_value = "",
            value_parser = |s: &str| Ok::<_, std::convert::Infallible>(PathBuf::from(s)),
            hide_default_value = true,
            required_unless_present = "video",
            conflicts_with = "video"
        )
    )]
    pub seq: PathBuf,
    /// Instead of `seq`: a video file of the model's camera, localized live as `localize
    /// --live --video` does. Reported: decoding per frame at the video's size, decoding with
    /// the resize to the model's camera (each from a pass that only decodes), localization,
    /// and the latency from a frame's arrival to its pose, with the frames dropped.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE"))]
    pub video: Option<PathBuf>,
    /// With `video`: paced at the video's frame times, the newest frame winning (as
    /// `localize --realtime`); without it every frame is localized as fast as it can be.
    #[cfg_attr(feature = "cli", arg(long, requires = "video"))]
    pub realtime: bool,
    /// Replay only the first N frames (default: all).
    #[cfg_attr(feature = "cli", arg(long, value_name = "N"))]
    pub frames: Option<usize>,
    /// Also run the plain path (SURF's reference loop, every frame classified, tracked frames
    /// matched by brute force) on every frame, alternating which runs first (on by default;
    /// `no_compare` times the current localizer alone).
    #[cfg_attr(feature = "cli", arg(long = "no-compare", action = clap::ArgAction::SetFalse))]
    pub compare: bool,
    /// Replay this sequence too, through the current localizer, frame by frame alternating
    /// with `seq` (e.g. the same pass through the unchanged colon beside a changed one): the
    /// report gives the latency of both and their ratio. Replaces the plain-path comparison.
    #[cfg_attr(feature = "cli", arg(long, value_name = "SEQ"))]
    pub against: Option<PathBuf>,
    /// Confirm registrations against the map, as live localization does by default (both
    /// paths; `no_confirm` turns it off).
    #[cfg_attr(feature = "cli", arg(long = "no-confirm", action = clap::ArgAction::SetFalse))]
    pub confirm: bool,
}

impl Default for LiveBenchJob {
    fn default() -> Self {
        LiveBenchJob {
            model: PathBuf::new(),
            seq: PathBuf::new(),
            video: None,
            realtime: false,
            frames: None,
            compare: true,
            against: None,
            confirm: true,
        }
    }
}

/// What [`LiveBenchJob`] measured.
#[derive(Debug, Clone)]
pub struct LiveBenchReport {
    /// The sequence replayed.
    pub seq: PathBuf,
    /// The localizer as `endoloc localize --live` runs it.
    pub current: RunSummary,
    /// The plain path: SURF's reference loop, every frame classified, tracked frames matched
    /// by brute force (with `compare`).
    pub reference: Option<RunSummary>,
    /// Frames where the two gave a different status, zone, inlier count or pose (with
    /// `compare`): guided matching finds other (more) correspondences than brute force.
    pub differing_frames: Option<usize>,
    /// The `against` sequence and the current localizer on it.
    pub against: Option<(PathBuf, RunSummary)>,
    /// With `video`: decoding and the stream's arrivals and latency.
    pub video: Option<VideoBench>,
}

/// What [`LiveBenchJob`] measured on a video file.
#[derive(Debug, Clone)]
pub struct VideoBench {
    /// The video's frame size, pixels.
    pub native: (u32, u32),
    /// The model's camera size the frames are resized to, pixels.
    pub size: (u32, u32),
    /// Time per frame to decode it at the video's size (a pass that only decodes), ms.
    pub decode_ms: LatencyHistogram,
    /// Time per frame to decode it and resize it to the camera (a pass that only decodes),
    /// ms.
    pub decode_resize_ms: LatencyHistogram,
    /// The localization run: arrivals, drops, latency from arrival to pose.
    pub stream: StreamSummary,
}

/// The time between frames handed out by `stream`, read as fast as it goes, ms.
fn read_times(mut stream: FrameStream) -> Result<LatencyHistogram> {
    let mut h = LatencyHistogram::new();
    let mut last = Instant::now();
    while let Some(frame) = stream.next_frame() {
        frame?;
        let now = Instant::now();
        h.add(1e3 * now.duration_since(last).as_secs_f64());
        last = now;
    }
    Ok(h)
}

/// Runs `a` and `b` on frame `i`, `a` first on even frames and `b` first on odd ones, so
/// that both see the same machine load; returns their results as `(a, b)`.
fn alternate<T, E>(
    i: usize,
    a: impl FnOnce() -> Result<T, E>,
    b: impl FnOnce() -> Result<T, E>,
) -> Result<(T, T), E> {
    if i.is_multiple_of(2) {
        let ra = a()?;
        Ok((ra, b()?))
    } else {
        let rb = b()?;
        Ok((a()?, rb))
    }
}

fn same(a: &FrameResult, b: &FrameResult) -> bool {
    a.status == b.status && a.t_wc == b.t_wc && a.zone == b.zone && a.inliers == b.inliers
}

impl LiveBenchJob {
    /// Replays the sequence.
    ///
    /// # Errors
    /// A model or map that cannot be loaded, a sequence that cannot be read, or a localizer
    /// error on a frame.
    pub fn run(&self, progress: &dyn Progress) -> Result<LiveBenchReport> {
        if let Some(video) = &self.video {
            return self.run_video(video, progress);
        }
        if let Some(other) = &self.against {
            return self.run_against(other, progress);
        }
        let job = self.localize_job();
        let mask = dataset_mask(&self.seq)?;
        let current = job.localizer()?.with_mask(mask.clone());
        let reference = if self.compare {
            let localizer = job.localizer_with(|cfg, map_surf| {
                cfg.surf = Some(SurfConfig {
                    reference_filters: true,
                    ..cfg.test_surf(map_surf)
                });
                cfg.classify_tracked = true;
                cfg.motion.search_px = 0.0;
            })?;
            Some(localizer.with_mask(mask))
        } else {
            None
        };
        let seq =
            Sequence::open(&self.seq).with_context(|| format!("opening {}", self.seq.display()))?;
        let n = self.frames.map_or(seq.len(), |f| f.min(seq.len()));
        let mut states = (
            current.live_state(),
            reference.as_ref().map(Localizer::live_state),
        );
        let mut summaries = (RunSummary::default(), RunSummary::default());
        let mut differing = 0;
        let bar = bar(progress, n as u64, "live replay");
        for i in 0..n {
            let img = seq.load_gray(i)?;
            let mut run_current = || current.localize_live(&mut states.0, &img);
            let (a, b) = match (&reference, &mut states.1) {
                (Some(r), Some(state)) => {
                    let run_reference = || r.localize_live(state, &img);
                    let (a, b) = alternate(i, run_current, run_reference)?;
                    (a, Some(b))
                }
                _ => (run_current()?, None),
            };
            summaries.0.add(&a);
            if let Some(b) = b {
                summaries.1.add(&b);
                differing += usize::from(!same(&a, &b));
            }
            bar.inc(1);
        }
        drop(bar);
        Ok(LiveBenchReport {
            seq: self.seq.clone(),
            current: summaries.0,
            reference: self.compare.then_some(summaries.1),
            differing_frames: self.compare.then_some(differing),
            against: None,
            video: None,
        })
    }

    /// `video` decoded alone at its size and at the camera's, then localized live.
    fn run_video(&self, video: &Path, progress: &dyn Progress) -> Result<LiveBenchReport> {
        if self.against.is_some() || self.frames.is_some() {
            bail!("`video` is timed whole, without `against` or `frames`");
        }
        let job = self.localize_job();
        let camera = job.camera()?;
        let size = (camera.width, camera.height);
        let native = endoloc_data::import::video::frame_size(video)?;
        progress.note(&format!("decoding {} alone", video.display()));
        let decode_ms = read_times(FrameStream::open_video(video, native)?)?;
        let decode_resize_ms = read_times(FrameStream::open_video(video, size)?)?;
        let scratch = tempfile::tempdir().map_err(|e| crate::JobError::io(video, e))?;
        let report = LocalizeJob {
            seq: PathBuf::new(),
            video: Some(video.to_path_buf()),
            realtime: self.realtime,
            out: scratch.path().join("run"),
            ..job
        }
        .run(progress)?;
        let (Some(current), Some(stream)) = (report.summary, report.stream) else {
            bail!("the live run of {} gave no summary", video.display());
        };
        Ok(LiveBenchReport {
            seq: video.to_path_buf(),
            current,
            reference: None,
            differing_frames: None,
            against: None,
            video: Some(VideoBench {
                native,
                size,
                decode_ms,
                decode_resize_ms,
                stream,
            }),
        })
    }

    /// The live localize job this bench replays.
    fn localize_job(&self) -> LocalizeJob {
        LocalizeJob {
            model: Some(self.model.clone()),
            seq: self.seq.clone(),
            live: true,
            confirm: self.confirm,
            ..LocalizeJob::default()
        }
    }

    /// `seq` and `other` through the current localizer, frame by frame, alternating which
    /// goes first; as many frames of each as the shorter has (or `frames`).
    fn run_against(&self, other: &Path, progress: &dyn Progress) -> Result<LiveBenchReport> {
        let open = |path: &Path| -> Result<(Localizer, Sequence)> {
            // Each sequence with its own camera (a changed pass may come from another scope).
            let job = LocalizeJob {
                seq: path.to_path_buf(),
                ..self.localize_job()
            };
            let localizer = job.localizer()?.with_mask(dataset_mask(path)?);
            let seq =
                Sequence::open(path).with_context(|| format!("opening {}", path.display()))?;
            Ok((localizer, seq))
        };
        let (a, b) = (open(&self.seq)?, open(other)?);
        let n = a.1.len().min(b.1.len());
        let n = self.frames.map_or(n, |f| f.min(n));
        let mut states = (a.0.live_state(), b.0.live_state());
        let mut summaries = (RunSummary::default(), RunSummary::default());
        let bar = bar(progress, n as u64, "live replay, both sequences");
        for i in 0..n {
            let (img_a, img_b) = (a.1.load_gray(i)?, b.1.load_gray(i)?);
            let run_a = || a.0.localize_live(&mut states.0, &img_a);
            let run_b = || b.0.localize_live(&mut states.1, &img_b);
            let (ra, rb) = alternate(i, run_a, run_b)?;
            summaries.0.add(&ra);
            summaries.1.add(&rb);
            bar.inc(1);
        }
        drop(bar);
        Ok(LiveBenchReport {
            seq: self.seq.clone(),
            current: summaries.0,
            reference: None,
            differing_frames: None,
            against: Some((other.to_path_buf(), summaries.1)),
            video: None,
        })
    }
}

impl fmt::Display for VideoBench {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.stream;
        writeln!(
            f,
            "{}: {} frames of {}x{} at {:.1} fps, resized to {}x{}{}",
            s.source.display(),
            s.frames,
            self.native.0,
            self.native.1,
            s.source_fps,
            self.size.0,
            self.size.1,
            if s.realtime {
                ", paced in real time (newest frame wins)"
            } else {
                ", every frame"
            }
        )?;
        let q = |h: &LatencyHistogram| format!("{:.2} ({:.1})", h.quantile(0.5), h.quantile(0.95));
        writeln!(
            f,
            "ms: median (p95)   decode {}   decode + resize {}   waiting {}   arrival to pose {}",
            q(&self.decode_ms),
            q(&self.decode_resize_ms),
            q(&s.queue_ms),
            q(&s.latency_ms)
        )?;
        write!(
            f,
            "dropped {} of {} frames ({:.1} %)",
            s.dropped,
            s.frames,
            100.0 * s.dropped_fraction()
        )
    }
}

impl fmt::Display for LiveBenchReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(v) = &self.video {
            writeln!(f, "{v}")?;
            writeln!(
                f,
                "{:<22} {:>13} {:>13} {:>13} {:>13} {:>15} {:>9}",
                "ms: median (p95)", "zone", "SURF", "matching", "refinement", "localize", "refined"
            )?;
            write!(f, "{:<22}", "current")?;
            let s = &self.current;
            for h in s.stage_ms.iter().chain([&s.total_ms]) {
                write!(f, " {:>6.2} ({:>5.1})", h.quantile(0.5), h.quantile(0.95))?;
            }
            return write!(f, " {:>8.1}%", 100.0 * s.refined());
        }
        writeln!(
            f,
            "{}: {} frames replayed live, decoding outside the clock",
            self.seq.display(),
            self.current.frames
        )?;
        writeln!(
            f,
            "{:<22} {:>13} {:>13} {:>13} {:>13} {:>15} {:>9}",
            "ms: median (p95)", "zone", "SURF", "matching", "refinement", "frame", "refined"
        )?;
        let row = |f: &mut fmt::Formatter<'_>, name: &str, s: &RunSummary| {
            write!(f, "{name:<22}")?;
            for h in s.stage_ms.iter().chain([&s.total_ms]) {
                write!(f, " {:>6.2} ({:>5.1})", h.quantile(0.5), h.quantile(0.95))?;
            }
            writeln!(f, " {:>8.1}%", 100.0 * s.refined())
        };
        row(f, "current", &self.current)?;
        if let Some((path, other)) = &self.against {
            row(f, "current, against", other)?;
            let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
            write!(
                f,
                "against: {}\nthis sequence / against: frame {:.2}x (median), {:.2}x (p95)",
                path.display(),
                ratio(self.current.median_ms(), other.median_ms()),
                ratio(
                    self.current.total_ms.quantile(0.95),
                    other.total_ms.quantile(0.95)
                )
            )?;
        }
        if let Some(r) = &self.reference {
            row(f, "plain path", r)?;
            let ratio = |a: f64, b: f64| if a > 0.0 { b / a } else { f64::NAN };
            let (c, rm) = (self.current.median_stage_ms(), r.median_stage_ms());
            write!(
                f,
                "speed-up: SURF {:.2}x, frame {:.2}x (median), {:.2}x (p95)",
                ratio(c[1], rm[1]),
                ratio(self.current.median_ms(), r.median_ms()),
                ratio(
                    self.current.total_ms.quantile(0.95),
                    r.total_ms.quantile(0.95)
                )
            )?;
            if let Some(d) = self.differing_frames {
                write!(f, "; frames with a different result: {d}")?;
            }
        }
        Ok(())
    }
}
