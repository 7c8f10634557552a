//! Live localization of a stream: frames from a video file or a pipe
//! ([`endoloc_data::stream::FrameStream`]), decoded on their own thread and handed to the
//! localizer one at a time, with every frame's latency from arrival to pose.
//!
//! Two ways for frames to arrive:
//! - **as fast as they are localized** (without `realtime`): the source waits for the
//!   localizer, no frame is dropped;
//! - **as a camera delivers them** (`realtime`): a file is paced at its frame times, a pipe's
//!   frames are read as they come, and when a frame arrives before the last one was taken,
//!   the newest frame wins — the older one is dropped and counted, never queued.
//!
//! The run's files are written into the output folder as frames finish, each frame's rows
//! flushed: a killed run keeps every finished frame. `stream.csv` lists every frame of the
//! source:
//!
//! ```text
//! frame,time_s,status,queue_ms,localize_ms,latency_ms
//! ```
//!
//! `status` is `localized` or `dropped` (the other columns then empty); `queue_ms` is the time
//! from the frame's arrival (decoded, resized; for a paced file, its due time) to the start of
//! its localization, `latency_ms` from arrival to its rows written.

use std::fmt;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use endoloc_data::stream::{FrameStream, StreamFrame};
use endoloc_localize::{FrameResult, Localizer};

use endoloc_data::stream::PixelFormat;

use super::results::{
    ALONG_FILE, FRAMES_FILE, INLIERS_FILE, LineFile, ResultWriter, TRAJECTORY_FILE,
};
use super::summary::{LatencyHistogram, RunSummary};
use crate::bail;
use crate::error::{JobError, Result};
use crate::progress::{Progress, bar};

/// The file of a stream's run that lists every frame of the source with its latency.
pub const STREAM_FILE: &str = "stream.csv";

/// The files of a localization run's rows, removed before a stream's run (`force` checked
/// by the caller), with [`StreamRun::job_file`].
const ROW_FILES: [&str; 5] = [
    TRAJECTORY_FILE,
    FRAMES_FILE,
    INLIERS_FILE,
    ALONG_FILE,
    STREAM_FILE,
];

/// What a stream's run needs of its job.
pub(super) struct StreamRun<'a> {
    /// The output folder.
    pub out: &'a std::path::Path,
    /// Frames as a camera delivers them (see the module docs).
    pub realtime: bool,
    /// The raw frames' format (for messages).
    pub pix_fmt: PixelFormat,
    /// The file that holds the job, written by `save_job` into the folder when the first frame
    /// arrives.
    pub job_file: &'a str,
    /// Writes the job into a folder.
    pub save_job: &'a dyn Fn(&std::path::Path) -> Result<()>,
}

/// What a stream's run did.
pub(super) struct StreamOutcome {
    /// Counts and latencies of the frames localized.
    pub summary: RunSummary,
    /// Arrivals, drops, latency.
    pub stream: StreamSummary,
    /// Frames with a pose.
    pub with_pose: usize,
    /// Wall time, seconds.
    pub wall_s: f64,
}

/// How a stream's frames went: how many arrived, were dropped, and how long they waited.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamSummary {
    /// The source's name (a video's path, or `standard input`).
    pub source: PathBuf,
    /// Frames of the source.
    pub frames: usize,
    /// Frames dropped because a newer one arrived before they were taken.
    pub dropped: usize,
    /// Whether frames arrived as a camera delivers them (paced, newest wins).
    pub realtime: bool,
    /// Time from arrival to the start of localization, ms.
    pub queue_ms: LatencyHistogram,
    /// Time from arrival to the frame's rows written, ms.
    pub latency_ms: LatencyHistogram,
    /// Frames per second of the source's clock (frames over its time span; 0 for one frame).
    pub source_fps: f64,
}

impl StreamSummary {
    /// Fraction of the source's frames dropped, in [0, 1].
    pub fn dropped_fraction(&self) -> f64 {
        self.dropped as f64 / self.frames.max(1) as f64
    }
}

impl fmt::Display for StreamSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "stream    {} frames of {} ({:.1} fps{}), {} dropped ({:.1} %); arrival to pose median {:.1} ms, p95 {:.1} ms (waiting {:.1} ms)",
            self.frames,
            self.source.display(),
            self.source_fps,
            if self.realtime { ", in real time" } else { "" },
            self.dropped,
            100.0 * self.dropped_fraction(),
            self.latency_ms.quantile(0.5),
            self.latency_ms.quantile(0.95),
            self.queue_ms.quantile(0.5),
        )
    }
}

/// A frame of a stream once localized and written, for a live view.
#[derive(Debug)]
pub struct StreamedFrame<'a> {
    /// The frame's index in the source.
    pub index: usize,
    /// Its time, seconds (the video's clock; raw frames: since the first).
    pub time_s: f64,
    /// The frame as localized (grey, the model's camera size).
    pub image: &'a image::GrayImage,
    /// What the localizer made of it.
    pub result: FrameResult,
    /// From its arrival to its rows written, ms.
    pub latency_ms: f64,
}

/// A frame taken from the mailbox, with the frames dropped before it (index, time).
type Taken = (Arrived, Vec<(usize, f64)>);

/// A frame as it arrived.
struct Arrived {
    frame: StreamFrame,
    at: Instant,
}

#[derive(Default)]
struct Slot {
    frame: Option<Arrived>,
    /// Frames overwritten before they were taken: (index, time_s).
    dropped: Vec<(usize, f64)>,
    /// The source ended (with its error, if any).
    ended: Option<Option<endoloc_data::DataError>>,
    /// The consumer stopped: the reader stops too.
    stop: bool,
}

/// One frame between the decoding thread and the localizer.
#[derive(Default)]
struct Mailbox {
    slot: Mutex<Slot>,
    changed: Condvar,
}

impl Mailbox {
    fn lock(&self) -> std::sync::MutexGuard<'_, Slot> {
        self.slot
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Puts a frame; with `newest_wins` an untaken one is dropped, otherwise this waits until
    /// it is taken. False when the consumer has stopped.
    fn put(&self, a: Arrived, newest_wins: bool) -> bool {
        let mut s = self.lock();
        while !newest_wins && s.frame.is_some() && !s.stop {
            s = self
                .changed
                .wait(s)
                .unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        if s.stop {
            return false;
        }
        if let Some(old) = s.frame.replace(a) {
            s.dropped.push((old.frame.index, old.frame.time_s));
        }
        self.changed.notify_all();
        true
    }

    fn end(&self, error: Option<endoloc_data::DataError>) {
        self.lock().ended = Some(error);
        self.changed.notify_all();
    }

    fn stop(&self) {
        self.lock().stop = true;
        self.changed.notify_all();
    }

    /// The next frame with the frames dropped before it; `None` at the end, or once `stop` is
    /// set.
    fn take(&self, stop: &AtomicBool) -> Option<std::result::Result<Taken, JobError>> {
        let mut s = self.lock();
        loop {
            if stop.load(Ordering::Relaxed) {
                return None;
            }
            if let Some(a) = s.frame.take() {
                let dropped = std::mem::take(&mut s.dropped);
                self.changed.notify_all();
                return Some(Ok((a, dropped)));
            }
            if let Some(ended) = s.ended.take() {
                // Put back the end, for the next call.
                s.ended = Some(None);
                return ended.map(|e| Err(e.into()));
            }
            // Woken by a frame or the end; every 100 ms to look at `stop`.
            s = self
                .changed
                .wait_timeout(s, Duration::from_millis(100))
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .0;
        }
    }
}

/// Feeds `stream` into `mailbox`: paced at the frame times with `pace`, newest frame winning
/// with `newest_wins`.
fn feed(mut stream: FrameStream, mailbox: &Mailbox, pace: bool, newest_wins: bool) {
    let start = Instant::now();
    let mut first_time = None;
    while let Some(item) = stream.next_frame() {
        let frame = match item {
            Ok(f) => f,
            Err(e) => {
                mailbox.end(Some(e));
                return;
            }
        };
        // A paced file's frame arrives at its due time, as a camera would deliver it: a frame
        // decoded late counts its lateness in its latency.
        let at = if pace {
            let t0 = *first_time.get_or_insert(frame.time_s);
            let due = start + Duration::from_secs_f64((frame.time_s - t0).max(0.0));
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            due
        } else {
            Instant::now()
        };
        let arrived = Arrived { frame, at };
        if !mailbox.put(arrived, newest_wins) {
            return;
        }
    }
    mailbox.end(None);
}

/// Stops the decoding thread when the localization ends, however it ends.
struct StopOnDrop(Arc<Mailbox>);

impl Drop for StopOnDrop {
    fn drop(&mut self) {
        self.0.stop();
    }
}

/// Writes `stream.csv` rows.
struct StreamLog {
    file: LineFile,
}

impl StreamLog {
    fn create(dir: &std::path::Path) -> Result<Self> {
        let path = dir.join(STREAM_FILE);
        Ok(StreamLog {
            file: LineFile::create(
                &path,
                path.clone(),
                "frame,time_s,status,queue_ms,localize_ms,latency_ms\n",
            )?,
        })
    }

    fn dropped(&mut self, frame: usize, time_s: f64) -> Result<()> {
        self.file
            .write(&format!("{frame},{time_s:.6},dropped,,,\n"))
    }

    fn localized(&mut self, frame: usize, time_s: f64, ms: [f64; 3]) -> Result<()> {
        self.file.write(&format!(
            "{frame},{time_s:.6},localized,{:.3},{:.3},{:.3}\n",
            ms[0], ms[1], ms[2]
        ))?;
        self.file.flush()
    }
}

impl StreamRun<'_> {
    /// Starts a stream's files in `out`: an earlier run's files there removed, the job saved,
    /// the rows' files created.
    fn start_files(&self) -> Result<(ResultWriter, StreamLog)> {
        let out = self.out;
        std::fs::create_dir_all(out).map_err(|e| JobError::io(out, e))?;
        for name in ROW_FILES.iter().chain([&self.job_file]) {
            let p = out.join(name);
            if p.exists() {
                std::fs::remove_file(&p).map_err(|e| JobError::io(&p, e))?;
            }
        }
        (self.save_job)(out)?;
        Ok((ResultWriter::streaming(out)?, StreamLog::create(out)?))
    }

    /// Localizes `stream` live into `out` (see the module docs); `realtime` paces a file and
    /// lets the newest frame win; `black`: the mask outside which every frame is set to black,
    /// as a dataset's frames are when read; `stop`: ends the run after the frame in hand.
    pub(super) fn localize(
        &self,
        localizer: &Localizer,
        stream: FrameStream,
        black: Option<image::GrayImage>,
        progress: &dyn Progress,
        stop: &AtomicBool,
        watch: &mut dyn FnMut(StreamedFrame<'_>),
    ) -> Result<StreamOutcome> {
        // The folder is written as frames finish, not staged, from the first frame on: a source
        // that gives none leaves it as it was.
        let mut files: Option<(ResultWriter, StreamLog)> = None;
        let source = stream.name().to_path_buf();
        let pipe = stream.is_raw();
        let raw_size = stream.native_size();
        let newest_wins = self.realtime;
        let pace = self.realtime && !pipe;
        let expected = if pipe {
            0
        } else {
            endoloc_data::import::video::frame_count_hint(&source).unwrap_or(0)
        };
        let mailbox = Arc::new(Mailbox::default());
        let _stop = StopOnDrop(mailbox.clone());
        {
            let mailbox = mailbox.clone();
            std::thread::Builder::new()
                .name("endoloc-decode".into())
                .spawn(move || feed(stream, &mailbox, pace, newest_wins))
                .map_err(|e| JobError::io(&source, e))?;
        }
        let mut state = localizer.live_state();
        let mut summary = RunSummary::default();
        let mut stream_summary = StreamSummary {
            source: source.clone(),
            frames: 0,
            dropped: 0,
            realtime: newest_wins,
            queue_ms: LatencyHistogram::new(),
            latency_ms: LatencyHistogram::new(),
            source_fps: 0.0,
        };
        let mut with_pose = 0;
        let mut span = (f64::INFINITY, f64::NEG_INFINITY);
        let bar = bar(
            progress,
            expected as u64,
            if pace { "real time" } else { "stream" },
        );
        let t = Instant::now();
        while let Some(next) = mailbox.take(stop) {
            let (arrived, dropped) = next?;
            let (writer, log) = match &mut files {
                Some(f) => f,
                None => files.insert(self.start_files()?),
            };
            for &(i, time_s) in &dropped {
                log.dropped(i, time_s)?;
                span = (span.0.min(time_s), span.1.max(time_s));
            }
            stream_summary.dropped += dropped.len();
            stream_summary.frames += dropped.len() + 1;
            let begin = Instant::now();
            let StreamFrame {
                index,
                time_s,
                mut image,
                damage,
            } = arrived.frame;
            if let Some(mask) = &black {
                endoloc_data::black_outside(&mut image, mask);
            }
            span = (span.0.min(time_s), span.1.max(time_s));
            let r = match damage {
                Some(d) => {
                    progress.note(&format!(
                        "warning: frame {index} at {time_s:.3} s rejected (damaged): {d}"
                    ));
                    FrameResult::unreadable(format!("damaged frame: {d}"))
                }
                None => localizer.localize_live(&mut state, &image)?,
            };
            let localized = Instant::now();
            writer.push_at(index, time_s, &r)?;
            let done = Instant::now();
            let ms = |a: Instant, b: Instant| 1e3 * b.duration_since(a).as_secs_f64();
            let times = [
                ms(arrived.at, begin),
                ms(begin, localized),
                ms(arrived.at, done),
            ];
            log.localized(index, time_s, times)?;
            stream_summary.queue_ms.add(times[0]);
            stream_summary.latency_ms.add(times[2]);
            summary.add(&r);
            with_pose += usize::from(r.t_wc.is_some());
            watch(StreamedFrame {
                index,
                time_s,
                image: &image,
                result: r,
                latency_ms: times[2],
            });
            bar.inc(1 + dropped.len() as u64);
        }
        drop(bar);
        let wall_s = t.elapsed().as_secs_f64();
        if stream_summary.frames == 0 && !stop.load(Ordering::Relaxed) {
            let (w, h) = (raw_size.0, raw_size.1);
            bail!(
                "{}: no frame arrived{}",
                source.display(),
                if pipe {
                    format!(
                        "; expected raw {w}x{h} {} frames back to back",
                        self.pix_fmt
                    )
                } else {
                    String::new()
                }
            );
        }
        let Some((writer, log)) = files else {
            bail!(
                "{}: no frame arrived before the run was stopped",
                source.display()
            );
        };
        writer.finish()?;
        log.file.finish()?;
        if stream_summary.frames > 1 && span.1 > span.0 {
            stream_summary.source_fps = (stream_summary.frames - 1) as f64 / (span.1 - span.0);
        }
        Ok(StreamOutcome {
            summary,
            stream: stream_summary,
            with_pose,
            wall_s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use endoloc_data::stream::PixelFormat;

    /// `n` raw 4×3 grey frames, frame k filled with k.
    fn frames(n: u8) -> FrameStream {
        let bytes: Vec<u8> = (0..n).flat_map(|k| [k; 12]).collect();
        let reader = Box::new(std::io::Cursor::new(bytes));
        FrameStream::raw("frames", reader, (4, 3), PixelFormat::Gray8, (4, 3)).unwrap()
    }

    /// Takes every frame from a mailbox fed with `n` frames, slower than they arrive; the
    /// frames taken and the frames dropped.
    fn drain(n: u8, newest_wins: bool) -> (Vec<usize>, Vec<usize>) {
        let mailbox = Arc::new(Mailbox::default());
        let feeder = {
            let mailbox = mailbox.clone();
            std::thread::spawn(move || feed(frames(n), &mailbox, false, newest_wins))
        };
        let (mut taken, mut dropped) = (Vec::new(), Vec::new());
        while let Some(next) = mailbox.take(&AtomicBool::new(false)) {
            let (a, d) = next.unwrap();
            assert_eq!(usize::from(a.frame.image.as_raw()[0]), a.frame.index);
            dropped.extend(d.into_iter().map(|(i, _)| i));
            taken.push(a.frame.index);
            std::thread::sleep(Duration::from_millis(2));
        }
        feeder.join().unwrap();
        (taken, dropped)
    }

    #[test]
    fn the_newest_frame_wins_and_every_dropped_one_is_counted() {
        let (taken, dropped) = drain(50, true);
        assert!(!dropped.is_empty(), "a slow consumer drops frames");
        assert_eq!(taken.last(), Some(&49), "the last frame is never dropped");
        let mut all: Vec<usize> = taken.iter().chain(&dropped).copied().collect();
        all.sort_unstable();
        assert_eq!(
            all,
            (0..50).collect::<Vec<_>>(),
            "each frame taken or dropped, once"
        );
        assert!(taken.windows(2).all(|w| w[0] < w[1]));
        // Without newest-wins the source waits: every frame, in order.
        assert_eq!(drain(20, false), ((0..20).collect(), Vec::new()));
    }

    #[test]
    fn a_source_error_ends_the_stream_after_its_frames() {
        // Two whole frames, then 5 bytes of a third.
        let mut bytes = vec![7u8; 24];
        bytes.extend([1u8; 5]);
        let stream = FrameStream::raw(
            "pipe",
            Box::new(std::io::Cursor::new(bytes)),
            (4, 3),
            PixelFormat::Gray8,
            (4, 3),
        )
        .unwrap();
        let mailbox = Arc::new(Mailbox::default());
        let feeder = {
            let mailbox = mailbox.clone();
            std::thread::spawn(move || feed(stream, &mailbox, false, false))
        };
        let mut got = Vec::new();
        let error = loop {
            match mailbox.take(&AtomicBool::new(false)) {
                Some(Ok((a, _))) => got.push(a.frame.index),
                Some(Err(e)) => break e.to_string(),
                None => panic!("the stream ended without its error"),
            }
        };
        feeder.join().unwrap();
        assert_eq!(got, [0, 1]);
        assert!(error.contains("inside frame 2"), "{error}");
        assert!(
            mailbox.take(&AtomicBool::new(false)).is_none(),
            "after the error, the end"
        );
    }
}
