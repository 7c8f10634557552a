//! `endoloc view` on a small hand-made run: the page is one self-contained file with the run's
//! data, refuses to overwrite without `--force`, and — where a `chromium` binary is on PATH —
//! draws in a headless browser without script errors and follows `#frame=N`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use endoloc_data::{DatasetMeta, DatasetWriter, StampedPose, write_tum};
use endoloc_eval::{FrameRecord, write_frames_csv};
use endoloc_geometry::{Camera, Pose, Status};
use endoloc_jobs::LocalizeJob;
use endoloc_localize::map_io::save_map;
use endoloc_localize::{Map, MapConfig, MapPoint, ZoneMap};
use endoloc_net::{UniformBy, ZoneConfig, ZoneTable};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

const FRAMES: usize = 12;
const ZONES: usize = 3;

fn endoloc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_endoloc"))
        .args(args)
        .output()
        .expect("run endoloc")
}

/// Frame `i` of the test pass: 2 mm along world x per frame, looking along +x (camera z).
fn pose(i: usize) -> Pose {
    let r = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
    Isometry3::from_parts(Translation3::new(2.0 * i as f64, 1.0, 0.5), r)
}

/// A dataset (`data/`, one test sequence), a model (`model/`: train_poses.txt, zones.csv,
/// map.bin) and a run (`run/`: trajectory.txt, frames.csv, localize.toml) under `root`.
fn fake_run(root: &Path, with_gt: bool) -> PathBuf {
    let camera = Camera::from_hfov(64, 48, 90.0);
    let data = root.join("data");
    let writer = DatasetWriter::create(&data, &DatasetMeta::new("tiny", camera), false).unwrap();
    let seq = writer.sequence("test").unwrap();
    let poses: Vec<StampedPose> = (0..FRAMES)
        .map(|i| StampedPose {
            timestamp_s: i as f64 / 30.0,
            pose: pose(i),
        })
        .collect();
    for i in 0..FRAMES {
        let img: Vec<u8> = (0..64 * 48)
            .map(|p| ((p % 64) * 3 + (p / 64) * 2 + i * 10) as u8)
            .collect();
        seq.write_gray(i, 64, 48, &img).unwrap();
    }
    seq.finish(&poses, None).unwrap();
    writer.finish().unwrap();
    let seq_dir = data.join("test");
    if !with_gt {
        std::fs::remove_file(seq_dir.join("poses.txt")).unwrap();
    }

    let model = root.join("model");
    std::fs::create_dir_all(&model).unwrap();
    write_tum(&model.join("train_poses.txt"), &poses).unwrap();
    let plain: Vec<Pose> = poses.iter().map(|p| p.pose).collect();
    let config = ZoneConfig::uniform(ZONES, UniformBy::Frames);
    let table = ZoneTable::from_poses(&plain, None, &config).unwrap();
    table.save(&model.join("zones.csv")).unwrap();
    let zones = (0..ZONES)
        .map(|z| ZoneMap {
            zone: z,
            frames: vec![4 * z],
            points: (0..20)
                .map(|k| MapPoint {
                    p_world: Point3::new(
                        8.0 * z as f64 + 10.0 + k as f64 * 0.3,
                        (k % 5) as f64 - 2.0,
                        (k / 5) as f64 - 1.5,
                    ),
                    descriptor: vec![0.125; 64],
                    laplacian: 1,
                    observations: vec![(4 * z, [10.0, 10.0].into())],
                    reprojection_rms_px: 0.5,
                })
                .collect(),
            rejected_tracks: 0,
            keypoints: 0,
        })
        .collect();
    let map = Map {
        config: MapConfig::default(),
        camera,
        zones,
        model_zones: None,
    };
    save_map(&map, &model).unwrap();

    let run = root.join("run");
    std::fs::create_dir_all(&run).unwrap();
    let status = |i: usize| match i % 4 {
        1 => Status::InitOnly,
        3 => Status::Rejected,
        _ => Status::Refined,
    };
    let rows: Vec<FrameRecord> = (0..FRAMES)
        .map(|i| FrameRecord {
            frame: i,
            zone: Some(i * ZONES / FRAMES),
            zone_score: Some(0.9),
            status: status(i),
            reason: match status(i) {
                Status::Refined => String::new(),
                Status::InitOnly => "too_few_inliers".into(),
                Status::Rejected => "no_zone".into(),
            },
            inliers: Some(30 + i),
            reprojection_rms_px: Some(1.25),
            source: "refined".into(),
            position_std_mm: None,
            orientation_std_deg: None,
            time_ms: 12.5,
        })
        .collect();
    write_frames_csv(&run.join("frames.csv"), &rows).unwrap();
    // Frame 0 matched three keypoints, frame 1 one, the others none.
    std::fs::write(
        run.join("inliers.csv"),
        "frame,x_px,y_px\n0,10.0,20.0\n0,30.5,40.25\n0,50,60\n1,5,5\n",
    )
    .unwrap();
    let est: Vec<StampedPose> = poses
        .iter()
        .enumerate()
        .filter(|(i, _)| status(*i) != Status::Rejected)
        .map(|(i, p)| StampedPose {
            timestamp_s: p.timestamp_s,
            pose: Translation3::new(0.3 * (i % 3) as f64, 0.2, 0.0) * p.pose,
        })
        .collect();
    write_tum(&run.join("trajectory.txt"), &est).unwrap();
    LocalizeJob {
        model: Some(model),
        seq: seq_dir,
        out: run.clone(),
        ..LocalizeJob::default()
    }
    .save(&run)
    .unwrap();
    run
}

/// The JSON object embedded in the page.
fn page_data(html: &str) -> serde_json::Value {
    let open = "<script type=\"application/json\" id=\"viewer-data\">";
    let start = html.find(open).expect("data script") + open.len();
    let end = start + html[start..].find("</script>").expect("end of data");
    serde_json::from_str(&html[start..end]).expect("page data is JSON")
}

#[test]
fn the_page_is_one_self_contained_file_with_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let run = fake_run(dir.path(), true);
    let run_s = run.to_str().unwrap();
    let out = endoloc(&["view", run_s, "--thumb-width", "32"]);
    let text =
        String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "endoloc view failed:\n{text}");
    let page = run.join("view.html");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "the page refers to the network"
    );
    assert!(
        !html.contains("src=\"") && !html.contains("href=\""),
        "the page refers to other files"
    );
    let data = page_data(&html);
    assert_eq!(data["frames"], FRAMES);
    assert_eq!(data["keypoints"][0].as_array().unwrap().len(), 6);
    assert_eq!(data["keypoints"][1].as_array().unwrap().len(), 2);
    assert_eq!(data["images"].as_array().unwrap().len(), FRAMES);
    assert_eq!(data["est"].as_array().unwrap().len(), FRAMES);
    assert!(data["est"][3].is_null(), "a rejected frame has no pose");
    assert_eq!(data["zones"], ZONES);
    assert_eq!(data["points"].as_array().unwrap().len(), 3 * 20 * ZONES);
    assert_eq!(data["train"].as_array().unwrap().len(), 3 * FRAMES);
    assert_eq!(data["thumb"]["width"], 32);
    assert_eq!(data["thumb"]["height"], 24);
    let err0 = data["pos_err"][0].as_f64().unwrap();
    assert!(
        (err0 - 0.2).abs() < 1e-6,
        "position error of frame 0: {err0}"
    );
    let jpeg = data["images"][0].as_str().unwrap();
    assert!(jpeg.starts_with("/9j/"), "thumbnails are base64 JPEG");

    // no overwrite without --force; with it, the page is replaced
    let again = endoloc(&["view", run_s]);
    assert!(!again.status.success());
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(
        err.contains("view.html") && err.contains("--force"),
        "{err}"
    );
    let forced = endoloc(&["view", run_s, "--force", "--max-points", "30"]);
    assert!(forced.status.success());
    let data = page_data(&std::fs::read_to_string(&page).unwrap());
    assert_eq!(data["points"].as_array().unwrap().len(), 3 * 30);

    // --no-gt: poses and status only
    let other = dir.path().join("other.html");
    let out = endoloc(&["view", run_s, "--no-gt", "--out", other.to_str().unwrap()]);
    assert!(out.status.success());
    let data = page_data(&std::fs::read_to_string(&other).unwrap());
    assert!(data["gt"].is_null() && data["pos_err"].is_null());
}

#[test]
fn a_sequence_without_poses_gives_a_page_without_errors() {
    let dir = tempfile::tempdir().unwrap();
    let run = fake_run(dir.path(), false);
    let out = endoloc(&["view", run.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let data = page_data(&std::fs::read_to_string(run.join("view.html")).unwrap());
    assert!(data["gt"].is_null() && data["pos_err"].is_null());
    assert_eq!(data["est"].as_array().unwrap().len(), FRAMES);
}

#[test]
fn a_folder_that_is_not_a_run_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = endoloc(&["view", dir.path().to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not a localization run folder") && err.contains("frames.csv"),
        "{err}"
    );
}

/// `chromium` or `chromium-browser` on PATH.
fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

/// Runs headless chromium with `args`, killed after 90 s. Its output is read while it runs: a
/// dumped page larger than a pipe's buffer would otherwise hold it up.
fn headless(browser: &Path, profile: &Path, args: &[String]) -> Output {
    let child = Command::new(browser)
        .args([
            "--headless",
            "--disable-gpu",
            "--no-sandbox",
            "--no-first-run",
            "--disable-extensions",
            "--hide-scrollbars",
            "--virtual-time-budget=3000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start chromium");
    let pid = child.id().to_string();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let watchdog = {
        let done = done.clone();
        std::thread::spawn(move || {
            let start = Instant::now();
            while !done.load(std::sync::atomic::Ordering::SeqCst) {
                if start.elapsed() > Duration::from_secs(90) {
                    let _ = Command::new("kill").args(["-KILL", &pid]).status();
                    break;
                }
                std::thread::sleep(Duration::from_millis(100));
            }
        })
    };
    let out = child.wait_with_output().expect("chromium output");
    done.store(true, std::sync::atomic::Ordering::SeqCst);
    let _ = watchdog.join();
    out
}

/// The value of attribute `name` on the dumped page's `<body>`.
fn body_attr(dom: &str, name: &str) -> Option<String> {
    let start = dom.find("<body")?;
    let tag = &dom[start..start + dom[start..].find('>')?];
    let key = format!("{name}=\"");
    let at = tag.find(&key)? + key.len();
    Some(tag[at..at + tag[at..].find('"')?].to_string())
}

#[test]
fn the_page_draws_in_a_headless_browser() {
    let Some(browser) = chromium() else {
        println!("skipped: no chromium or chromium-browser on PATH (apt-get install chromium)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let run = fake_run(dir.path(), true);
    let out = endoloc(&["view", run.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = run.join("view.html").canonicalize().unwrap();
    let url = format!("file://{}", page.display());
    let profile = dir.path().join("chromium-profile");

    // Kept after the test (the temporary folder is not): cargo's folder for test artefacts.
    let artefacts = Path::new(env!("CARGO_TARGET_TMPDIR")).join("endoloc-view");
    std::fs::create_dir_all(&artefacts).unwrap();
    let shot = artefacts.join("view.png");
    let _ = std::fs::remove_file(&shot);
    let res = headless(
        &browser,
        &profile,
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1200,800".into(),
            url.clone(),
        ],
    );
    assert!(
        shot.is_file(),
        "no screenshot from chromium:\n{}",
        String::from_utf8_lossy(&res.stderr)
    );
    println!("screenshot: {}", shot.display());
    let img = image::open(&shot).unwrap().into_rgb8();
    // The 3-D canvas fills the top left of the page: the pass, map points and frustums draw
    // bright pixels on its near-black background.
    let (w, h) = img.dimensions();
    let mut bright = 0;
    for y in 40..450.min(h) {
        for x in 20..720.min(w) {
            let p = img.get_pixel(x, y);
            if p.0.iter().map(|&c| c as u32).sum::<u32>() > 200 {
                bright += 1;
            }
        }
    }
    assert!(
        bright > 300,
        "the 3-D view looks blank ({bright} bright pixels)"
    );

    let dump = |frame: usize| {
        let res = headless(
            &browser,
            &profile,
            &["--dump-dom".into(), format!("{url}#frame={frame}")],
        );
        String::from_utf8_lossy(&res.stdout).into_owned()
    };
    let (dom0, dom5) = (dump(0), dump(5));
    for (dom, frame) in [(&dom0, "0"), (&dom5, "5")] {
        assert_eq!(
            body_attr(dom, "data-frame").as_deref(),
            Some(frame),
            "page state: {:.300}",
            dom
        );
        assert_eq!(
            body_attr(dom, "data-errors").as_deref(),
            Some("0"),
            "script errors at frame {frame}"
        );
        let drawn: usize = body_attr(dom, "data-drawn-points")
            .unwrap()
            .parse()
            .unwrap();
        assert!(drawn > 0, "no map points drawn at frame {frame}");
    }
    assert_eq!(body_attr(&dom0, "data-zone").as_deref(), Some("0"));
    assert_eq!(body_attr(&dom5, "data-zone").as_deref(), Some("1"));
    assert_eq!(
        body_attr(&dom5, "data-status").as_deref(),
        Some("init_only")
    );
    let reproj: usize = body_attr(&dom0, "data-reprojected")
        .unwrap()
        .parse()
        .unwrap();
    assert!(reproj > 0, "no map point reprojected onto frame 0");
    assert_eq!(body_attr(&dom0, "data-keypoints").as_deref(), Some("3"));
    assert_eq!(body_attr(&dom5, "data-keypoints").as_deref(), Some("0"));
}

/// Reads one HTTP response from `addr` for `GET path`: the status line and everything after.
fn http_get(addr: &str, path: &str) -> String {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    text
}

/// The live view (`localize --live --video … --serve`) in headless Chromium while a 10 s video
/// streams in real time: the page draws the scope moving and its distance along the colon
/// growing without script errors; a viewer connecting mid-stream gets the frames so far; each
/// frame's event leaves the server within 100 ms of its pose; any other path is refused;
/// Ctrl-C ends the server cleanly, and mid-stream ends the run with its files complete.
#[test]
fn the_live_view_follows_a_streamed_video() {
    let (Some(browser), true) = (
        chromium(),
        Command::new("ffmpeg")
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success()),
    ) else {
        println!("skipped: needs chromium and ffmpeg on PATH (apt-get install chromium ffmpeg)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let path = |p: &str| root.join(p).to_str().unwrap().to_string();
    for args in [
        &[
            "simulate",
            "--preset",
            "small",
            "--train-frames",
            "300",
            "--test-frames",
            "300",
            "--width",
            "160",
            "--height",
            "120",
            "--no-depth",
            "--out",
            &path("data"),
        ][..],
        &[
            "train",
            "--data",
            &path("data"),
            "--zones",
            "50",
            "--pretrained",
            "builtin-joint",
            "--epochs",
            "0",
            "--out",
            &path("model"),
        ],
        &[
            "map",
            "--model",
            &path("model"),
            "--data",
            &path("data"),
            "--threshold",
            "20",
        ],
    ] {
        let out = endoloc(args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let video = path("pass.mp4");
    let status = Command::new("ffmpeg")
        .args([
            "-v",
            "error",
            "-framerate",
            "30",
            "-i",
            &path("data/test/images/%06d.png"),
        ])
        .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", &video])
        .status()
        .unwrap();
    assert!(status.success());

    // The run, serving on a free loopback port (printed on stderr).
    let start = |out: &str| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_endoloc"))
            .args([
                "localize",
                "--model",
                &path("model"),
                "--live",
                "--realtime",
            ])
            .args([
                "--video",
                &video,
                "--out",
                &path(out),
                "--serve",
                "127.0.0.1:0",
            ])
            .args(["--train-data", &path("data")])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let stderr = child.stderr.take().unwrap();
        let mut lines = std::io::BufRead::lines(std::io::BufReader::new(stderr));
        let addr = lines
            .by_ref()
            .map_while(Result::ok)
            .find_map(|l| {
                l.split("http://")
                    .nth(1)
                    .map(|a| a.trim_end_matches('/').to_string())
            })
            .expect("the address on stderr");
        // Keep draining stderr so that the run never blocks on it.
        std::thread::spawn(move || lines.for_each(drop));
        (child, addr)
    };
    let interrupt = |child: &std::process::Child| {
        let ok = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(ok.success());
    };
    let (mut child, addr) = start("run");
    let url = format!("http://{addr}/");
    assert!(http_get(&addr, "/").starts_with("HTTP/1.1 200"));
    for other in ["/etc/passwd", "/events/../x", "/view.html", "/favicon.ico"] {
        let r = http_get(&addr, other);
        assert!(r.starts_with("HTTP/1.1 404"), "{other}: {r:.80}");
    }
    // An event stream read by hand: the delay from each frame's pose to its arrival here.
    let events = {
        let addr = addr.clone();
        std::thread::spawn(move || {
            use std::io::{BufRead, Write};
            let mut s = std::net::TcpStream::connect(&addr).unwrap();
            write!(s, "GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
            let mut delays = Vec::new();
            for line in std::io::BufReader::new(s).lines().map_while(Result::ok) {
                if line.starts_with("event: end") {
                    break;
                }
                let Some(json) = line.strip_prefix("data: {") else {
                    continue;
                };
                let now = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .unwrap()
                    .as_secs_f64()
                    * 1e3;
                let sent: f64 = json
                    .rsplit_once("\"sent\":")
                    .and_then(|(_, v)| v.trim_end_matches('}').parse().ok())
                    .unwrap();
                delays.push(now - sent);
            }
            delays
        })
    };
    let viewer = |name: &str| {
        let (browser, url, profile) = (browser.clone(), url.clone(), root.join(name));
        std::thread::spawn(move || {
            let out = headless(&browser, &profile, &["--dump-dom".into(), url]);
            let dom = String::from_utf8_lossy(&out.stdout).into_owned();
            let attr = |k: &str| body_attr(&dom, k).unwrap_or_default();
            [
                "data-errors",
                "data-frames",
                "data-scope-moves",
                "data-along-first",
                "data-along",
                "data-snapshot",
                "data-live",
            ]
            .map(attr)
        })
    };
    let first = viewer("first");
    // The second viewer joins late: once 60 frames are localized (their rows are flushed as
    // they finish), or, on a machine too slow for that, after 8 s of the 10 s video.
    let rows_so_far = || {
        std::fs::read_to_string(root.join("run/frames.csv"))
            .map_or(0, |t| t.lines().count().saturating_sub(1))
    };
    let waited = std::time::Instant::now();
    while rows_so_far() < 60 && waited.elapsed() < Duration::from_secs(8) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let before_second = rows_so_far();
    let second = viewer("second");
    let (first, second) = (first.join().unwrap(), second.join().unwrap());
    let delays = events.join().unwrap();
    interrupt(&child);
    let exit = child.wait().unwrap();
    assert!(exit.success(), "Ctrl-C after the stream: {exit:?}");

    let rows = std::fs::read_to_string(root.join("run/frames.csv")).unwrap();
    let localized = rows.lines().count() - 1;
    // Frames dropped in real time depend on the machine; enough must remain to watch.
    assert!(
        localized >= 100,
        "{localized} of 300 frames localized in real time"
    );
    println!("first viewer {first:?}\nsecond viewer {second:?}");
    for (name, v) in [("first", &first), ("second", &second)] {
        let [errors, frames, moves, along_first, along, snapshot, live] = v;
        assert_eq!(errors, "0", "{name} viewer: script errors");
        assert!(live.starts_with("ended"), "{name} viewer: {live}");
        assert_eq!(frames, &localized.to_string(), "{name} viewer: every frame");
        let (a0, a1): (f64, f64) = (along_first.parse().unwrap(), along.parse().unwrap());
        assert!(
            a1 > a0 + 20.0,
            "{name} viewer: along the colon {a0} → {a1} mm"
        );
        let moves: usize = moves.parse().unwrap();
        let snapshot: usize = snapshot.parse().unwrap();
        if name == "first" {
            assert!(moves >= 100, "the scope drawn at {moves} places");
        } else {
            assert!(
                before_second >= 10 && snapshot >= before_second,
                "a late viewer gets the frames so far: {snapshot} of {before_second}"
            );
        }
    }
    let mut sorted = delays.clone();
    sorted.sort_by(f64::total_cmp);
    println!(
        "pose to viewer: median {:.2} ms, p95 {:.2} ms over {} events",
        sorted[sorted.len() / 2],
        sorted[sorted.len() * 95 / 100],
        sorted.len()
    );
    assert!(sorted.len() >= 150, "{} events read", sorted.len());
    assert!(
        sorted[sorted.len() / 2] <= 100.0,
        "pose to viewer: median {:.1} ms",
        sorted[sorted.len() / 2]
    );

    // Ctrl-C mid-stream: the run ends at once, every finished frame in its files.
    let (mut child, _) = start("stopped");
    std::thread::sleep(Duration::from_secs(3));
    interrupt(&child);
    let exit = child.wait().unwrap();
    assert!(exit.success(), "Ctrl-C mid-stream: {exit:?}");
    let rows = std::fs::read_to_string(root.join("stopped/frames.csv")).unwrap();
    let log = std::fs::read_to_string(root.join("stopped/stream.csv")).unwrap();
    let localized = rows.lines().count() - 1;
    assert!(
        (10..250).contains(&localized),
        "{localized} frames before Ctrl-C"
    );
    assert_eq!(log.matches(",localized,").count(), localized);
    assert!(root.join("stopped/localize.toml").is_file());
}
