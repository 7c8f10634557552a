//! Recordings as they come: a rendered pass and a tracker log on its own clock, written at
//! 100 Hz from the pass's true camera path, 0.35 s off the video's clock, for a sensor 5 mm
//! behind the camera, with two 200 ms dropouts. From the PNG frames: the clock offset is found
//! from the images alone and the resampled camera poses match the pass's own. As a video (H.264
//! MP4 and MJPEG AVI, encoded with FFmpeg; skipped with a message without it): `import video`
//! finds the offset, leaves the dropout frames out and lists them, and gives the pass's poses.

use endoloc_data::import::endoslam::Units;
use endoloc_data::import::tracker::{
    OffsetSearch, PoseLog, PoseSample, ResampleConfig, TrackerLogConfig, estimate_time_offset,
    frame_motion, parse_pose_log, poses_at,
};
use endoloc_data::stream::{FrameStream, PixelFormat};
use endoloc_geometry::Pose;
use endoloc_jobs::{
    ImportFormat, ImportJob, LocalizeJob, MapJob, STREAM_FILE, Silent, SimulateJob, TrainJob,
};
use nalgebra::{Translation3, UnitQuaternion};

const OFFSET_S: f64 = 0.35;

/// The `dataset.toml` of the dataset at `dir`.
fn dataset_meta(dir: &std::path::Path) -> endoloc_data::DatasetMeta {
    endoloc_data::DatasetMeta::read(&dir.join("dataset.toml")).unwrap()
}

/// The built-in colon's passes, `train` and `test` frames at 160×120, into `out`.
fn simulate(out: &std::path::Path, train: usize, test: usize) {
    SimulateJob {
        train_frames: Some(train),
        test_frames: Some(test),
        width: Some(160),
        height: Some(120),
        depth: Some(false),
        out: out.to_path_buf(),
        ..SimulateJob::default()
    }
    .run(&Silent)
    .unwrap();
}

#[test]
fn a_pass_with_a_tracker_log_on_its_own_clock_imports_from_frames_and_from_video() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    simulate(&data, 240, 2);
    let seq = endoloc_data::Dataset::open(&data)
        .unwrap()
        .sequence("train")
        .unwrap();
    let times: Vec<f64> = seq.poses.iter().map(|p| p.timestamp_s).collect();

    // The true camera path as a log on the video's clock, to sample the tracker from.
    let truth = PoseLog {
        source: "truth".into(),
        samples: seq
            .poses
            .iter()
            .enumerate()
            .map(|(i, p)| PoseSample {
                time_s: p.timestamp_s,
                pose: Some(p.pose),
                line: i + 1,
            })
            .collect(),
        notes: Vec::new(),
    };
    // The sensor sits 5 mm behind the camera: T_sc moves 5 mm along the camera's z.
    let t_sc = Pose::from_parts(Translation3::new(0.0, 0.0, 5.0), UnitQuaternion::identity());
    let t_cs = t_sc.inverse();
    let dropouts = [(2.0, 2.2), (5.0, 5.2)];
    let mut csv = String::from("time [s],x,y,z,qx,qy,qz,qw,valid\n");
    let (t0, t1) = (times[0], *times.last().unwrap());
    for k in 0.. {
        let log_time = -0.5 + k as f64 * 0.01;
        let video_time = log_time - OFFSET_S;
        if video_time > t1 + 0.5 {
            break;
        }
        let camera = (video_time >= t0 && video_time <= t1)
            .then(|| {
                poses_at(&truth, &[video_time], &ResampleConfig::default())[0]
                    .expect("inside the pass")
            })
            .filter(|_| !dropouts.iter().any(|(a, b)| (*a..*b).contains(&log_time)));
        match camera {
            Some(c) => {
                let s = c * t_cs;
                let (t, q) = (s.translation.vector, s.rotation);
                csv.push_str(&format!(
                    "{log_time},{},{},{},{},{},{},{},1\n",
                    t.x, t.y, t.z, q.i, q.j, q.k, q.w
                ));
            }
            None => csv.push_str(&format!("{log_time},,,,,,,,0\n")),
        }
    }
    let csv_text = csv.clone();
    let log = parse_pose_log(
        std::path::Path::new("tracker.csv"),
        csv.into_bytes(),
        &TrackerLogConfig {
            units: Units::Mm,
            rate_hz: None,
        },
    )
    .unwrap();

    // The offset from the images alone.
    let frames: Vec<image::GrayImage> = (0..seq.len()).map(|i| seq.load_gray(i).unwrap()).collect();
    let motion: Vec<f64> = (0..frames.len())
        .map(|i| match i {
            0 => f64::NAN,
            _ => frame_motion(&frames[i - 1], &frames[i]),
        })
        .collect();
    let found = estimate_time_offset(&log, &times, &motion, &OffsetSearch::default()).unwrap();
    eprintln!("{found:?}");
    let frame_s = 1.0 / 30.0;
    assert!(
        (found.offset_s - OFFSET_S).abs() < frame_s,
        "found {found:?}, true offset {OFFSET_S} s"
    );

    // The poses at the frame times: with the true offset the pass's own (to the interpolation
    // of a 100 Hz log sampled from a path that bends at every frame: 0.3 mm here), with the found one off by at most the camera's speed times the clock
    // error; none in the dropouts.
    let fastest_mm_s = seq
        .poses
        .windows(2)
        .map(|w| {
            (w[1].pose.translation.vector - w[0].pose.translation.vector).norm()
                / (w[1].timestamp_s - w[0].timestamp_s)
        })
        .fold(0.0, f64::max);
    let resample = |offset_s: f64| {
        let cfg = ResampleConfig {
            time_offset_s: offset_s,
            max_gap_s: 0.05,
            sensor_to_camera: Some(t_sc),
        };
        let mut worst = 0.0_f64;
        let mut unposed = Vec::new();
        for (i, (p, truth)) in poses_at(&log, &times, &cfg)
            .iter()
            .zip(&seq.poses)
            .enumerate()
        {
            match p {
                Some(p) => {
                    worst = worst.max((p.translation.vector - truth.pose.translation.vector).norm())
                }
                None => unposed.push(i),
            }
        }
        (worst, unposed)
    };
    let (exact_mm, _) = resample(OFFSET_S);
    assert!(
        exact_mm < 0.5,
        "true offset: largest position error {exact_mm:.3} mm"
    );
    let (worst, unposed) = resample(found.offset_s);
    let allowed = fastest_mm_s * (found.offset_s - OFFSET_S).abs() + 0.5;
    assert!(
        worst < allowed,
        "largest position error {worst:.3} mm, allowed {allowed:.3}"
    );
    // Unposed: in a dropout, or (a fraction of a frame off the true clock) past either end
    // of the log's valid samples.
    let (first, last) = (t0 + OFFSET_S, t1 + OFFSET_S);
    let in_dropout = |i: usize| {
        let t = times[i] + found.offset_s;
        t < first + 0.05
            || t > last - 0.05
            || dropouts.iter().any(|(a, b)| t > a - 0.05 && t < b + 0.05)
    };
    assert!(unposed.iter().all(|&i| in_dropout(i)), "{unposed:?}");
    assert!(unposed.len() >= 10, "{unposed:?}");

    // The same pass as a video file.
    let ffmpeg_ok = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ffmpeg_ok {
        eprintln!("skipped: import video needs ffmpeg (Debian: apt install ffmpeg)");
        return;
    }
    let root = tmp.path();
    std::fs::write(root.join("tracker.csv"), &csv_text).unwrap();
    std::fs::write(
        root.join("hand_eye.txt"),
        "1 0 0 0\n0 1 0 0\n0 0 1 5\n0 0 0 1\n",
    )
    .unwrap();
    let c = &endoloc_data::Dataset::open(&data).unwrap().meta.camera;
    let camera = format!(
        "{},{},{},{},{},{}",
        c.width, c.height, c.fx, c.fy, c.cx, c.cy
    );
    for (file, codec) in [
        (
            "pass.mp4",
            &["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18"][..],
        ),
        ("pass.avi", &["-c:v", "mjpeg", "-q:v", "2"][..]),
    ] {
        let video = root.join(file);
        let status = std::process::Command::new("ffmpeg")
            .args(["-v", "error", "-y", "-framerate", "30", "-i"])
            .arg(seq.dir.join("images/%06d.png"))
            .args(codec)
            .arg(&video)
            .status()
            .unwrap();
        assert!(status.success(), "encoding {file}");
        let import = |time_offset: &str, out: &str| {
            ImportJob {
                format: ImportFormat::Video,
                src: video.clone(),
                out: root.join(out),
                poses: Some(root.join("tracker.csv")),
                camera: Some(camera.clone()),
                time_offset: time_offset.into(),
                sensor_to_camera: Some(root.join("hand_eye.txt")),
                ..ImportJob::default()
            }
            .run(&Silent)
            .unwrap()
        };
        let report = import("auto", &format!("{file}-auto"));
        let pass = &report.videos[0];
        eprintln!("{file}: {report}");
        assert!(
            (pass.offset_s - OFFSET_S).abs() < frame_s,
            "{file}: {pass:?}"
        );
        assert!(
            pass.unposed.iter().all(|&(i, _)| in_dropout(i)) && pass.unposed.len() >= 10,
            "{file}: {:?}",
            pass.unposed
        );
        // With the true offset, each imported frame has the pass's own pose (codec loss does
        // not touch poses): the same frames as from the PNGs.
        let report = import(&OFFSET_S.to_string(), &format!("{file}-exact"));
        let imported = endoloc_data::Dataset::open(&report.summary.dir)
            .unwrap()
            .sequence("train")
            .unwrap();
        let (_, unposed) = resample(OFFSET_S);
        assert_eq!(imported.len() + unposed.len(), seq.len(), "{file}");
        for p in &imported.poses {
            let truth = seq
                .poses
                .iter()
                .find(|t| (t.timestamp_s - p.timestamp_s).abs() < 1e-4)
                .expect("a frame of the pass");
            let err = (p.pose.translation.vector - truth.pose.translation.vector).norm();
            assert!(
                err < 0.5,
                "{file}: frame at {} s is {err:.3} mm off",
                p.timestamp_s
            );
        }
    }

    // Streamed (decoded while read, no file per frame): the frames and times the import
    // wrote. The stream is grey from the decoder's luma plane; the import's PNGs are colour
    // that endoloc turns grey, a few levels darker where the decoded colour of a red wall
    // clips below black in green and blue (measured: 5.6 levels on average, 9 at most).
    let exact = endoloc_data::Dataset::open(&root.join("pass.mp4-exact"))
        .unwrap()
        .sequence("train")
        .unwrap();
    let streamed: Vec<_> = FrameStream::open_video(&root.join("pass.mp4"), (c.width, c.height))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(streamed.len(), seq.len());
    for (k, p) in exact.poses.iter().enumerate() {
        let f = streamed
            .iter()
            .find(|f| (f.time_s - p.timestamp_s).abs() < 1e-4)
            .expect("the imported frame streamed");
        assert!(f.damage.is_none());
        let png = exact.load_gray(k).unwrap();
        assert_eq!(f.image.dimensions(), png.dimensions());
        let diffs: Vec<u8> = f
            .image
            .as_raw()
            .iter()
            .zip(png.as_raw())
            .map(|(a, b)| a.abs_diff(*b))
            .collect();
        let mean = diffs.iter().map(|&d| f64::from(d)).sum::<f64>() / diffs.len() as f64;
        let max = diffs.iter().copied().max().unwrap_or(0);
        assert!(
            mean < 7.0 && max <= 12,
            "frame at {} s: the streamed frame is {mean:.2} grey levels off the imported one on \
             average, {max} at most",
            f.time_s
        );
    }

    // Subsampled and resized: at most 15 frames per second, 80×60 with the camera scaled.
    let small = ImportJob {
        format: ImportFormat::Video,
        src: root.join("pass.mp4"),
        out: root.join("small"),
        poses: Some(root.join("tracker.csv")),
        camera: Some(camera.clone()),
        time_offset: OFFSET_S.to_string(),
        sensor_to_camera: Some(root.join("hand_eye.txt")),
        max_fps: Some(15.0),
        size: Some("80x60".into()),
        ..ImportJob::default()
    }
    .run(&Silent)
    .unwrap();
    let dataset = endoloc_data::Dataset::open(&small.summary.dir).unwrap();
    let (sc, half) = (&dataset.meta.camera, c.scaled(0.5));
    assert_eq!(
        (sc.width, sc.height, sc.fx, sc.cx),
        (80, 60, half.fx, half.cx)
    );
    let kept = dataset.sequence("train").unwrap();
    assert_eq!(kept.load_gray(0).unwrap().dimensions(), (80, 60));
    let (_, unposed) = resample(OFFSET_S);
    let every_other = (0..seq.len())
        .step_by(2)
        .filter(|i| !unposed.contains(i))
        .count();
    assert_eq!(kept.len(), every_other, "30 fps kept at 15");
    // Every third frame: FFmpeg writes only those, each the frame of its time.
    let thirds = ImportJob {
        format: ImportFormat::Video,
        src: root.join("pass.mp4"),
        out: root.join("thirds"),
        poses: Some(root.join("tracker.csv")),
        camera: Some(camera.clone()),
        time_offset: OFFSET_S.to_string(),
        sensor_to_camera: Some(root.join("hand_eye.txt")),
        every: 3,
        ..ImportJob::default()
    }
    .run(&Silent)
    .unwrap();
    let thirds = endoloc_data::Dataset::open(&thirds.summary.dir)
        .unwrap()
        .sequence("train")
        .unwrap();
    assert!(thirds.len() >= seq.len() / 3 - unposed.len() && thirds.len() <= seq.len() / 3 + 1);
    for (k, p) in thirds.poses.iter().enumerate() {
        let frame = (p.timestamp_s * 30.0).round() as usize;
        assert_eq!(frame % 3, 0, "frame {frame} kept");
        let whole = exact
            .poses
            .iter()
            .position(|q| q.timestamp_s == p.timestamp_s)
            .expect("the same frame in the whole import");
        assert_eq!(
            thirds.load_rgb(k).unwrap(),
            exact.load_rgb(whole).unwrap(),
            "frame {frame}: the image of its time"
        );
    }

    // C3VD's pose.txt as the log (one camera pose per frame, column-major 4×4, no time
    // stamps): taken at the video's frame rate, each frame gets its own pose.
    let c3vd: String = seq
        .poses
        .iter()
        .map(|p| {
            let m = p.pose.to_homogeneous();
            let v: Vec<String> = (0..16).map(|i| format!("{}", m[(i % 4, i / 4)])).collect();
            v.join(",") + "\n"
        })
        .collect();
    std::fs::write(root.join("pose.txt"), c3vd).unwrap();
    let from_c3vd = ImportJob {
        format: ImportFormat::Video,
        src: root.join("pass.mp4"),
        out: root.join("c3vd-log"),
        poses: Some(root.join("pose.txt")),
        camera: Some(camera.clone()),
        ..ImportJob::default()
    }
    .run(&Silent)
    .unwrap();
    let imported = endoloc_data::Dataset::open(&from_c3vd.summary.dir)
        .unwrap()
        .sequence("train")
        .unwrap();
    assert_eq!(imported.len(), seq.len());
    for (p, truth) in imported.poses.iter().zip(&seq.poses) {
        let err = (p.pose.translation.vector - truth.pose.translation.vector).norm();
        assert!(
            err < 1e-3,
            "frame at {} s is {err:.2e} mm off",
            p.timestamp_s
        );
    }

    // Damaged videos are refused, naming the file, and nothing is written: truncated, and a
    // run of corrupt bytes in the middle.
    let good = std::fs::read(root.join("pass.mp4")).unwrap();
    let mut corrupt = good.clone();
    let mid = corrupt.len() / 2;
    corrupt[mid..mid + 2000].fill(0xAB);
    for (name, bytes) in [
        ("truncated.mp4", good[..good.len() / 2].to_vec()),
        ("corrupt.mp4", corrupt),
    ] {
        let video = root.join(name);
        std::fs::write(&video, bytes).unwrap();
        let out = root.join(format!("{name}-data"));
        let err = ImportJob {
            format: ImportFormat::Video,
            src: video,
            out: out.clone(),
            poses: Some(root.join("tracker.csv")),
            camera: Some(camera.clone()),
            ..ImportJob::default()
        }
        .run(&Silent)
        .unwrap_err();
        let mut message = err.to_string();
        let mut source = std::error::Error::source(&err);
        while let Some(e) = source {
            message = format!("{message}: {e}");
            source = e.source();
        }
        assert!(
            message.contains(name)
                && (message.contains("damaged") || message.contains("cannot decode")),
            "{message}"
        );
        assert!(!out.exists(), "{name}: nothing is written");
        // Streamed: a truncated file is refused up front; the corrupt packets mark the frames
        // decoded from them damaged (localized as `rejected`), and the stream goes on.
        let stream = FrameStream::open_video(&root.join(name), (c.width, c.height));
        if name == "truncated.mp4" {
            let e = stream.unwrap_err().to_string();
            assert!(e.contains(name), "{e}");
        } else {
            let frames: Vec<_> = stream.unwrap().map(Result::unwrap).collect();
            let damaged = frames.iter().filter(|f| f.damage.is_some()).count();
            assert!(damaged >= 1, "the corrupt packets are reported");
            assert!(
                frames.len() >= seq.len() - 10 && damaged < 10,
                "{} frames, {damaged} damaged",
                frames.len()
            );
        }
    }
}

/// A pass streamed live as raw frames (as `localize --video -` reads them from standard input)
/// is localized as from its PNG files — the same zones, statuses and poses — and each frame's
/// rows are on disk before the next frame is taken, so a killed run keeps them. The same pass
/// as a lossless video imported without a pose log, added to its dataset: localized as from its
/// PNG files too. As H.264 with corrupt packets: the damaged frames are rejected and the stream
/// goes on.
#[test]
fn a_stream_of_raw_frames_is_localized_as_its_png_files_are() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let data = root.join("data");
    // As `endoloc demo` indexes the small preset, at 160×120: enough test frames that some are
    // refined (19 of 100), so that the runs below are compared on registrations too.
    simulate(&data, 300, 100);
    let model = root.join("model");
    TrainJob {
        data: data.clone(),
        zones: endoloc_net::ZoneSpec::Uniform(50),
        epochs: Some(0),
        pretrained: Some("builtin-joint".into()),
        out: model.clone(),
        ..TrainJob::default()
    }
    .run(&Silent)
    .unwrap();
    MapJob {
        model: model.clone(),
        data: data.clone(),
        threshold: 20.0,
        ..MapJob::default()
    }
    .run(&Silent)
    .unwrap();
    let job = |out: &str| LocalizeJob {
        model: Some(model.clone()),
        out: root.join(out),
        live: true,
        ..LocalizeJob::default()
    };
    let from_files = root.join("files");
    LocalizeJob {
        seq: data.join("test"),
        ..job("files")
    }
    .run(&Silent)
    .unwrap();

    // The test pass as RGB bytes, back to back.
    let seq = endoloc_data::Dataset::open(&data)
        .unwrap()
        .sequence("test")
        .unwrap();
    let mut bytes = Vec::new();
    for i in 0..seq.len() {
        let path = seq.dir.join(format!("images/{i:06}.png"));
        bytes.extend(image::open(&path).unwrap().into_rgb8().into_raw());
    }
    let stream = FrameStream::raw(
        "test pass",
        Box::new(std::io::Cursor::new(bytes)),
        (160, 120),
        PixelFormat::Rgb24,
        (160, 120),
    )
    .unwrap();
    let streamed = root.join("streamed");
    let mut finished = 0;
    let report = job("streamed")
        .run_frames(stream, &Silent, &mut |_| {
            finished += 1;
            let rows = std::fs::read_to_string(streamed.join("frames.csv")).unwrap();
            assert_eq!(
                rows.lines().count(),
                1 + finished,
                "rows on disk as frames finish"
            );
        })
        .unwrap();
    let stream = report.stream.expect("a stream's summary");
    assert_eq!((stream.frames, stream.dropped), (seq.len(), 0));

    // frames.csv the same but for the time spent; the same poses (the stream's clock aside).
    let rows = |dir: &std::path::Path| -> Vec<String> {
        std::fs::read_to_string(dir.join("frames.csv"))
            .unwrap()
            .lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string())
            .collect()
    };
    assert_eq!(rows(&streamed), rows(&from_files));
    let poses = |dir: &std::path::Path| -> Vec<_> {
        endoloc_data::read_tum(&dir.join("trajectory.txt"))
            .unwrap()
            .into_iter()
            .map(|p| p.pose)
            .collect()
    };
    assert_eq!(poses(&streamed), poses(&from_files));
    let log = std::fs::read_to_string(streamed.join(STREAM_FILE)).unwrap();
    assert_eq!(log.lines().count(), 1 + seq.len());
    assert!(log.lines().skip(1).all(|l| l.contains(",localized,")));

    // The pass as an H.264 video with a run of corrupt bytes in the middle: the frames decoded
    // from them are `rejected` and the stream goes on to the end.
    if !std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        eprintln!("skipped: a video needs ffmpeg (Debian: apt install ffmpeg)");
        return;
    }
    let video = root.join("test.mp4");
    let status = std::process::Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-framerate", "30", "-i"])
        .arg(seq.dir.join("images/%06d.png"))
        .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18"])
        .arg(&video)
        .status()
        .unwrap();
    assert!(status.success());

    // The pass as a lossless video (PNG in Matroska: the codec loses nothing, so what is
    // compared is endoloc's path), without a log, added to the dataset as its own pass: its
    // frames and times (frames.txt), the other passes untouched; localized, it gives what the
    // PNG files give; it is refused where poses are needed.
    let lossless = root.join("test.mkv");
    let status = std::process::Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-framerate", "30", "-i"])
        .arg(seq.dir.join("images/%06d.png"))
        .args(["-c:v", "png", "-pix_fmt", "rgb24"])
        .arg(&lossless)
        .status()
        .unwrap();
    assert!(status.success());
    let c = &endoloc_data::Dataset::open(&data).unwrap().meta.camera;
    let add = |force: bool| ImportJob {
        format: ImportFormat::Video,
        src: lossless.clone(),
        out: data.clone(),
        seq: "recorded".into(),
        camera: Some(format!(
            "{},{},{},{},{},{}",
            c.width, c.height, c.fx, c.fy, c.cx, c.cy
        )),
        force,
        ..ImportJob::default()
    };
    let meta_before = dataset_meta(&data);
    let test_poses = std::fs::read(data.join("test/poses.txt")).unwrap();
    let report = add(false).run(&Silent).unwrap();
    assert!(report.to_string().contains("frames.txt"), "{report}");
    let dataset = endoloc_data::Dataset::open(&data).unwrap();
    assert_eq!(
        (dataset.sequences.clone(), dataset.unposed.clone()),
        (
            vec!["test".to_string(), "train".into()],
            vec!["recorded".into()]
        )
    );
    assert_eq!(
        std::fs::read(data.join("test/poses.txt")).unwrap(),
        test_poses
    );
    let meta_after = dataset_meta(&data);
    let mut expected = meta_before.clone();
    expected
        .source
        .insert("recorded".into(), meta_after.source["recorded"].clone());
    assert_eq!(
        meta_after, expected,
        "only the added pass's provenance is new"
    );
    let e = dataset.sequence("recorded").unwrap_err().to_string();
    assert!(
        e.contains("without poses") && e.contains("localized"),
        "{e}"
    );
    let checked = endoloc_data::check_dataset(&data).unwrap();
    assert!(checked.is_ok(), "{checked}");
    assert!(
        checked
            .sequences
            .contains(&"recorded (no poses)".to_string())
    );
    let e = add(false).run(&Silent).unwrap_err();
    let e = format!("{e}: {}", std::error::Error::source(&e).unwrap());
    assert!(e.contains("recorded") && e.contains("force"), "{e}");
    add(true).run(&Silent).unwrap();

    let recorded = root.join("recorded-run");
    LocalizeJob {
        seq: data.join("recorded"),
        ..job("recorded-run")
    }
    .run(&Silent)
    .unwrap();
    assert_eq!(rows(&recorded), rows(&from_files));
    assert_eq!(poses(&recorded), poses(&from_files));

    let mut bytes = std::fs::read(&video).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid..mid + 1500].fill(0xAB);
    std::fs::write(&video, bytes).unwrap();
    let damaged = root.join("damaged");
    let report = LocalizeJob {
        video: Some(video.clone()),
        ..job("damaged")
    }
    .run(&Silent)
    .unwrap();
    let rows = std::fs::read_to_string(damaged.join("frames.csv")).unwrap();
    let rejected = rows
        .lines()
        .filter(|l| l.contains(",unreadable_image,"))
        .count();
    let last = rows
        .lines()
        .last()
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .to_string();
    assert!(rejected >= 1, "the damaged frames are rejected:\n{rows}");
    assert!(
        report.frame_count >= seq.len() - 5 && last.parse::<usize>().unwrap() >= seq.len() - 5,
        "the stream goes on to its end: {} frames, the last {last}",
        report.frame_count
    );
}
