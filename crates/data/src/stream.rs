//! Frames as they come: a video file decoded while it is read, or raw frames on a pipe, each
//! frame grey and at the size the localizer wants, without a file per frame.
//!
//! - A **video file** (whatever FFmpeg decodes: MP4/H.264, MKV, AVI/MJPEG, MOV) is decoded by
//!   the `ffmpeg` program as a subprocess: its first video stream, every frame in decoding
//!   order (`-fps_mode passthrough`) on one thread, resized with FFmpeg's area filter when its
//!   size is not the wanted one (the aspect ratio must be the same), converted to RGB and handed over on a
//!   pipe. Each frame's presentation time (the container's, so a variable frame rate is kept)
//!   comes from FFmpeg's `showinfo` filter on the same run. A decoding error FFmpeg reports
//!   before a frame marks that frame damaged ([`StreamFrame::damage`]); the stream goes on.
//!   The frames are those `endoloc import video` writes as PNG, bit for bit.
//! - **Raw frames** (`gray8`: one byte per pixel; `rgb24`: three), back to back on a reader
//!   such as standard input (`ffmpeg … -f rawvideo -pix_fmt gray -`), of a stated size; a frame's
//!   time is its arrival, seconds after the first frame's. Frames of another size than the
//!   wanted one are resized (triangle filter; same aspect ratio).
//!
//! Grey is computed from RGB as every endoloc image is (`image`'s Rec. 709 luma), so a frame
//! from a stream equals the same frame read from a PNG.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc;
use std::time::Instant;

use image::{GrayImage, RgbImage};

use crate::DataError;

/// The layout of raw frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PixelFormat {
    /// One byte per pixel, grey.
    #[default]
    Gray8,
    /// Three bytes per pixel, R G B.
    Rgb24,
}

impl PixelFormat {
    /// Bytes per pixel.
    pub fn bytes_per_pixel(self) -> usize {
        match self {
            PixelFormat::Gray8 => 1,
            PixelFormat::Rgb24 => 3,
        }
    }

    /// The name on the command line (FFmpeg's is `gray` and `rgb24`).
    pub fn name(self) -> &'static str {
        match self {
            PixelFormat::Gray8 => "gray8",
            PixelFormat::Rgb24 => "rgb24",
        }
    }
}

impl std::fmt::Display for PixelFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for PixelFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "gray8" | "gray" => Ok(PixelFormat::Gray8),
            "rgb24" => Ok(PixelFormat::Rgb24),
            _ => Err(format!("pixel format {s:?}; expected gray8 or rgb24")),
        }
    }
}

/// One frame of a stream.
#[derive(Debug, Clone)]
pub struct StreamFrame {
    /// 0-based index in the source (every frame counts, also those a consumer drops).
    pub index: usize,
    /// Presentation time, seconds: the video's clock, or for raw frames the time since the
    /// first frame arrived.
    pub time_s: f64,
    /// The frame, grey, at the stream's size.
    pub image: GrayImage,
    /// The first decoding error FFmpeg reported for this frame (concealed damage), if any.
    pub damage: Option<String>,
}

/// What FFmpeg's diagnostic output says, line by line, in the order it happens.
enum Event {
    /// A frame left the filter graph with this presentation time, seconds.
    Frame(f64),
    /// An error (`[error]` or `[fatal]` level).
    Error(String),
}

enum Source {
    Ffmpeg {
        child: Child,
        stdout: ChildStdout,
        events: mpsc::Receiver<Event>,
        /// Errors seen before the next frame's time.
        pending: Vec<String>,
        /// The last error of the run, for the message when FFmpeg fails.
        last_error: Option<String>,
    },
    Raw {
        reader: Box<dyn Read + Send>,
        size: (u32, u32),
        format: PixelFormat,
        first: Option<Instant>,
    },
}

/// Frames from a video file or a pipe, in order, grey, at one size (see the module docs).
pub struct FrameStream {
    source: Source,
    /// The name in errors: the video's path, or e.g. `standard input`.
    name: PathBuf,
    size: (u32, u32),
    native: (u32, u32),
    next: usize,
    buf: Vec<u8>,
    done: bool,
}

impl std::fmt::Debug for FrameStream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameStream")
            .field("name", &self.name)
            .field("size", &self.size)
            .field("native", &self.native)
            .field("next", &self.next)
            .finish_non_exhaustive()
    }
}

/// Checks that `from` resized to `to` keeps the aspect ratio (within 1 %).
fn check_aspect(name: &Path, from: (u32, u32), to: (u32, u32)) -> Result<(), DataError> {
    let aspect = |(w, h): (u32, u32)| f64::from(w) / f64::from(h);
    if (aspect(from) / aspect(to) - 1.0).abs() > 0.01 {
        return Err(DataError::invalid(
            name,
            format!(
                "frames of {}x{} cannot be resized to {}x{} without changing the aspect ratio; \
                 expected frames of the camera's aspect ratio",
                from.0, from.1, to.0, to.1
            ),
        ));
    }
    Ok(())
}

impl FrameStream {
    /// Opens a video file to be decoded as it is read, its frames resized to `size`
    /// `(width, height)`.
    ///
    /// # Errors
    /// [`DataError::Invalid`] naming the video when `ffprobe`/`ffmpeg` is missing, the file
    /// cannot be read as a video (a truncated MP4, not a video), or its frames have another
    /// aspect ratio than `size`.
    pub fn open_video(video: &Path, size: (u32, u32)) -> Result<Self, DataError> {
        let native = crate::import::video::frame_size(video)?;
        check_aspect(video, native, size)?;
        let mut filter = String::new();
        if native != size {
            filter.push_str(&format!("scale={}:{}:flags=area,", size.0, size.1));
        }
        filter.push_str("showinfo");
        let mut child = Command::new("ffmpeg")
            .args(["-hide_banner", "-nostdin", "-nostats", "-loglevel", "level+info"])
            // One thread to decode and one to filter: a 1080p H.264 frame takes about 10 ms of
            // one core, and the localizer keeps the others (FFmpeg's default, a thread per core,
            // drops more frames in real time on 2 cores: 10.4 against 6.2 %).
            .args(["-threads", "1", "-filter_threads", "1", "-i"])
            .arg(video)
            .args(["-map", "0:v:0", "-fps_mode", "passthrough", "-vf"])
            .arg(&filter)
            // Grey straight from the decoder's luma plane: a third of the bytes to scale and
            // pipe, and no colour conversion on either side (a 1080p H.264 frame: 8.4 ms of
            // one core instead of 10.3 ms with RGB).
            .args(["-pix_fmt", "gray", "-f", "rawvideo", "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| {
                DataError::invalid(
                    video,
                    if e.kind() == std::io::ErrorKind::NotFound {
                        "`ffmpeg` not found: a video is decoded with FFmpeg (Debian: apt install ffmpeg)"
                            .to_string()
                    } else {
                        format!("running `ffmpeg`: {e}")
                    },
                )
            })?;
        let (stdout, stderr) = match (child.stdout.take(), child.stderr.take()) {
            (Some(o), Some(e)) => (o, e),
            _ => {
                return Err(DataError::invalid(
                    video,
                    "ffmpeg's output pipes are missing",
                ));
            }
        };
        let (tx, events) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if let Some(event) = parse_event(&line)
                    && tx.send(event).is_err()
                {
                    break;
                }
            }
        });
        Ok(FrameStream {
            source: Source::Ffmpeg {
                child,
                stdout,
                events,
                pending: Vec::new(),
                last_error: None,
            },
            name: video.to_path_buf(),
            size,
            native,
            next: 0,
            buf: Vec::new(),
            done: false,
        })
    }

    /// Raw frames of `native` size `(width, height)` and `format`, back to back on `reader`
    /// (`name` is what errors call it), resized to `size`.
    ///
    /// # Errors
    /// [`DataError::Invalid`] when a size is zero or the aspect ratios differ.
    pub fn raw(
        name: impl Into<PathBuf>,
        reader: Box<dyn Read + Send>,
        native: (u32, u32),
        format: PixelFormat,
        size: (u32, u32),
    ) -> Result<Self, DataError> {
        let name = name.into();
        if native.0 == 0 || native.1 == 0 {
            return Err(DataError::invalid(
                &name,
                format!("frame size {}x{}; expected WxH > 0", native.0, native.1),
            ));
        }
        check_aspect(&name, native, size)?;
        Ok(FrameStream {
            source: Source::Raw {
                reader,
                size: native,
                format,
                first: None,
            },
            name,
            size,
            native,
            next: 0,
            buf: Vec::new(),
            done: false,
        })
    }

    /// The size of the frames handed out `(width, height)`, pixels.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// The size of the frames in the source, pixels.
    pub fn native_size(&self) -> (u32, u32) {
        self.native
    }

    /// Whether the frames are raw frames from a reader (no frame times of their own).
    pub fn is_raw(&self) -> bool {
        matches!(self.source, Source::Raw { .. })
    }

    /// The source's name (the video's path, or e.g. `standard input`).
    pub fn name(&self) -> &Path {
        &self.name
    }

    /// The next frame; `None` at the end of the stream.
    ///
    /// # Errors
    /// [`DataError::Invalid`] naming the source when FFmpeg fails (with its last message) or
    /// a raw stream ends inside a frame; [`DataError::Io`] when the pipe cannot be read. After
    /// an error the stream ends.
    pub fn next_frame(&mut self) -> Option<Result<StreamFrame, DataError>> {
        if self.done {
            return None;
        }
        let r = self.read_frame();
        if !matches!(r, Some(Ok(_))) {
            self.done = true;
        }
        r
    }

    fn read_frame(&mut self) -> Option<Result<StreamFrame, DataError>> {
        let index = self.next;
        match &mut self.source {
            Source::Ffmpeg {
                child,
                stdout,
                events,
                pending,
                last_error,
            } => {
                let (w, h) = self.size;
                self.buf.resize(w as usize * h as usize, 0);
                match read_full(stdout, &mut self.buf) {
                    Err(e) => return Some(Err(DataError::io(&self.name, e))),
                    Ok(0) => {
                        // The end: FFmpeg's verdict on the whole run.
                        let status = child.wait();
                        for event in events.iter() {
                            if let Event::Error(m) = event {
                                *last_error = Some(m);
                            }
                        }
                        return match status {
                            Ok(s) if s.success() => None,
                            Ok(_) => Some(Err(DataError::invalid(
                                &self.name,
                                format!(
                                    "cannot decode the video (ffmpeg: {}){}",
                                    last_error.as_deref().unwrap_or("no message"),
                                    if index > 0 {
                                        format!(" after {index} frames")
                                    } else {
                                        String::new()
                                    }
                                ),
                            ))),
                            Err(e) => Some(Err(DataError::io(&self.name, e))),
                        };
                    }
                    Ok(n) if n < self.buf.len() => {
                        return Some(Err(DataError::invalid(
                            &self.name,
                            format!("frame {index} ends after {n} of {} bytes", self.buf.len()),
                        )));
                    }
                    Ok(_) => {}
                }
                // The frame's time: the showinfo line FFmpeg printed before writing it.
                let mut time_s = None;
                for event in events.iter() {
                    match event {
                        Event::Frame(t) => {
                            time_s = Some(t);
                            break;
                        }
                        Event::Error(m) => {
                            *last_error = Some(m.clone());
                            pending.push(m);
                        }
                    }
                }
                let Some(time_s) = time_s else {
                    return Some(Err(DataError::invalid(
                        &self.name,
                        format!("ffmpeg gave frame {index} without its time"),
                    )));
                };
                let damage = (!pending.is_empty()).then(|| pending.remove(0));
                pending.clear();
                let image = GrayImage::from_raw(w, h, std::mem::take(&mut self.buf))?;
                self.next += 1;
                Some(Ok(StreamFrame {
                    index,
                    time_s,
                    image,
                    damage,
                }))
            }
            Source::Raw {
                reader,
                size,
                format,
                first,
            } => {
                let (w, h) = *size;
                self.buf
                    .resize(format.bytes_per_pixel() * w as usize * h as usize, 0);
                match read_full(reader, &mut self.buf) {
                    Err(e) => return Some(Err(DataError::io(&self.name, e))),
                    Ok(0) => return None,
                    Ok(n) if n < self.buf.len() => {
                        return Some(Err(DataError::invalid(
                            &self.name,
                            format!(
                                "the stream ends inside frame {index}: {n} of {} bytes \
                                 ({w}x{h} {}); expected whole frames of the stated size and format",
                                self.buf.len(),
                                format.name()
                            ),
                        )));
                    }
                    Ok(_) => {}
                }
                let now = Instant::now();
                let time_s = now.duration_since(*first.get_or_insert(now)).as_secs_f64();
                let bytes = std::mem::take(&mut self.buf);
                let gray = match format {
                    PixelFormat::Gray8 => GrayImage::from_raw(w, h, bytes)?,
                    PixelFormat::Rgb24 => {
                        image::DynamicImage::ImageRgb8(RgbImage::from_raw(w, h, bytes)?)
                            .into_luma8()
                    }
                };
                let image = if (w, h) == self.size {
                    gray
                } else {
                    image::imageops::resize(
                        &gray,
                        self.size.0,
                        self.size.1,
                        image::imageops::FilterType::Triangle,
                    )
                };
                self.next += 1;
                Some(Ok(StreamFrame {
                    index,
                    time_s,
                    image,
                    damage: None,
                }))
            }
        }
    }
}

impl Iterator for FrameStream {
    type Item = Result<StreamFrame, DataError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}

impl Drop for FrameStream {
    fn drop(&mut self) {
        if let Source::Ffmpeg { child, .. } = &mut self.source {
            // A stream left before its end: FFmpeg is stopped, not left writing to a pipe.
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// Reads until `buf` is full or the end; the bytes read.
fn read_full(reader: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match reader.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// One line of FFmpeg's output at `-loglevel level+info`: a frame's time from `showinfo`, an
/// error, or nothing of interest.
fn parse_event(line: &str) -> Option<Event> {
    if line.contains("[error]") || line.contains("[fatal]") {
        let message = line
            .rsplit_once("] ")
            .map_or(line, |(_, m)| m)
            .trim()
            .to_string();
        return Some(Event::Error(message));
    }
    if !line.contains("showinfo") {
        return None;
    }
    let rest = &line[line.find(" pts_time:")? + " pts_time:".len()..];
    let value = rest.split_whitespace().next()?;
    value.parse().ok().map(Event::Frame)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn showinfo_and_error_lines_are_read() {
        let frame = "[Parsed_showinfo_1 @ 0x55d2] [info] n:   3 pts:   1536 pts_time:0.1     pos: 48 fmt:rgb24";
        assert!(matches!(parse_event(frame), Some(Event::Frame(t)) if t == 0.1));
        let config = "[Parsed_showinfo_1 @ 0x55d2] [info] config in time_base: 1/15360";
        assert!(parse_event(config).is_none());
        let err = "[h264 @ 0x55d2] [error] corrupt macroblock 3 1 (total_coeff=-1)";
        assert!(
            matches!(parse_event(err), Some(Event::Error(m)) if m == "corrupt macroblock 3 1 (total_coeff=-1)")
        );
        assert!(parse_event("[info]   Duration: 00:00:01.00").is_none());
    }

    #[test]
    fn raw_frames_arrive_grey_resized_and_a_short_one_is_named() {
        // Two 8x6 RGB frames and half of a third.
        let mut bytes = Vec::new();
        for v in [10u8, 200] {
            bytes.extend(std::iter::repeat_n([v, v, v], 48).flatten());
        }
        bytes.extend([1u8; 70]);
        let reader = Box::new(std::io::Cursor::new(bytes));
        let mut s = FrameStream::raw("pipe", reader, (8, 6), PixelFormat::Rgb24, (4, 3)).unwrap();
        let a = s.next_frame().unwrap().unwrap();
        assert_eq!((a.index, a.image.dimensions()), (0, (4, 3)));
        assert!(a.image.pixels().all(|p| p.0[0] == 10));
        let b = s.next_frame().unwrap().unwrap();
        assert!(b.index == 1 && b.image.pixels().all(|p| p.0[0] == 200));
        let e = s.next_frame().unwrap().unwrap_err().to_string();
        assert!(
            e.contains("pipe") && e.contains("inside frame 2") && e.contains("70 of 144"),
            "{e}"
        );
        assert!(s.next_frame().is_none());
        let e = FrameStream::raw(
            "pipe",
            Box::new(std::io::empty()),
            (8, 6),
            PixelFormat::Gray8,
            (8, 8),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("aspect ratio"), "{e}");
    }
}
