//! The bad-input catalogue: every command fed the broken files, mixed folders and unusable
//! outputs that users meet. Each case must end with exit status 2, one `error:` line that names
//! the file (and the line, where the format has lines) and says what was expected, no panic,
//! and no change at all to the case's folder: nothing half-written, nothing lost.
//!
//! `cargo test -p endoloc --test bad_input -- --nocapture` prints the table of cases and the
//! message each one gives (docs/RELIABILITY.md lists them).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The inputs every case starts from (never modified: cases copy what they break).
struct Fixture {
    _tmp: tempfile::TempDir,
    /// A tiny simulated dataset (train 60 and test 20 frames, 160×120).
    data: PathBuf,
    /// The same kind of dataset from another seed.
    other: PathBuf,
    /// A model indexed on `data` with its map.
    model: PathBuf,
    /// A model indexed on `other` with its map.
    other_model: PathBuf,
    /// A localization run of `model` on `data/test`.
    run: PathBuf,
}

fn endoloc(args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_endoloc"))
        .arg("-q")
        .args(args)
        .output()
        .expect("run endoloc")
}

fn ok(args: &[&str]) {
    let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    let out = endoloc(&args);
    assert!(
        out.status.success(),
        "endoloc {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

fn fixture() -> Fixture {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().to_path_buf();
    let (data, other) = (root.join("data"), root.join("other"));
    for (out, seed) in [(&data, "0"), (&other, "1")] {
        ok(&[
            "simulate",
            "--preset",
            "small",
            "--seed",
            seed,
            "--train-frames",
            "60",
            "--test-frames",
            "20",
            "--width",
            "160",
            "--height",
            "120",
            "--out",
            &s(out),
        ]);
    }
    let (model, other_model) = (root.join("model"), root.join("other_model"));
    for (m, d) in [(&model, &data), (&other_model, &other)] {
        ok(&[
            "train",
            "--data",
            &s(d),
            "--zones",
            "4",
            "--pretrained",
            "builtin-joint",
            "--epochs",
            "0",
            "--out",
            &s(m),
        ]);
        ok(&[
            "map",
            "--model",
            &s(m),
            "--data",
            &s(d),
            "--threshold",
            "20",
        ]);
    }
    let run = root.join("run");
    ok(&[
        "localize",
        "--model",
        &s(&model),
        "--seq",
        &s(&data.join("test")),
        "--out",
        &s(&run),
    ]);
    Fixture {
        _tmp: tmp,
        data,
        other,
        model,
        other_model,
        run,
    }
}

fn copy(src: &Path, dst: &Path) -> PathBuf {
    std::fs::create_dir_all(dst).unwrap();
    for e in std::fs::read_dir(src).unwrap() {
        let p = e.unwrap().path();
        let to = dst.join(p.file_name().unwrap());
        if p.is_dir() {
            copy(&p, &to);
        } else {
            std::fs::copy(&p, &to).unwrap();
        }
    }
    dst.to_path_buf()
}

/// Replaces line `n` (1-based, comments counted) of a text file.
fn edit_line(path: &Path, n: usize, f: impl Fn(&str) -> String) {
    let text = std::fs::read_to_string(path).unwrap();
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == n { f(l) } else { l.to_string() })
        .collect();
    std::fs::write(path, lines.join("\n") + "\n").unwrap();
}

/// Replaces the whitespace-separated column `c` (0-based) of line `n`.
fn edit_column(path: &Path, n: usize, c: usize, value: &str) {
    edit_line(path, n, |l| {
        let mut cols: Vec<String> = l.split_whitespace().map(str::to_string).collect();
        cols[c] = value.to_string();
        cols.join(" ")
    });
}

fn replace_in(path: &Path, from: &str, to: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains(from), "{} has no {from:?}", path.display());
    std::fs::write(path, text.replacen(from, to, 1)).unwrap();
}

fn truncate(path: &Path, len: usize) {
    let bytes = std::fs::read(path).unwrap();
    std::fs::write(path, &bytes[..len.min(bytes.len())]).unwrap();
}

fn gray_png(path: &Path, w: u32, h: u32, value: u8) {
    image::GrayImage::from_pixel(w, h, image::Luma([value]))
        .save(path)
        .unwrap();
}

fn args(list: &[&str]) -> Vec<String> {
    list.iter().map(|a| a.to_string()).collect()
}

/// Every file and folder under `dir`, hidden ones included, with file contents.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Option<Vec<u8>>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(root).unwrap().to_path_buf();
            if p.is_dir() {
                out.insert(rel, None);
                walk(root, &p, out);
            } else {
                out.insert(rel, Some(std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

type Setup = Box<dyn Fn(&Fixture, &Path) -> Vec<String>>;

/// One row of the catalogue.
struct Case {
    /// What is wrong.
    name: &'static str,
    /// Builds the broken input inside the case's own folder and gives the command line.
    setup: Setup,
    /// What the message must contain: the file (and line) and the expectation.
    expect: &'static [&'static str],
}

fn case(
    name: &'static str,
    expect: &'static [&'static str],
    setup: impl Fn(&Fixture, &Path) -> Vec<String> + 'static,
) -> Case {
    Case {
        name,
        setup: Box::new(setup),
        expect,
    }
}

/// `train` on `data` into `dir/model`, indexing only.
fn train_on(data: &Path, dir: &Path) -> Vec<String> {
    args(&[
        "train",
        "--data",
        &s(data),
        "--zones",
        "4",
        "--pretrained",
        "builtin-joint",
        "--epochs",
        "0",
        "--out",
        &s(&dir.join("model")),
    ])
}

/// Turns the sequence at `seq` into a pass without poses: `frames.txt` (its times) in place
/// of `poses.txt`.
fn unposed(seq: &Path) {
    let poses = endoloc_data::read_tum(&seq.join("poses.txt")).unwrap();
    let times: Vec<f64> = poses.iter().map(|p| p.timestamp_s).collect();
    endoloc_data::write_frame_times(&seq.join("frames.txt"), &times).unwrap();
    std::fs::remove_file(seq.join("poses.txt")).unwrap();
}

/// `localize` of `seq` with `model` into `dir/run`.
fn localize(model: &Path, seq: &Path, dir: &Path) -> Vec<String> {
    args(&[
        "localize",
        "--model",
        &s(model),
        "--seq",
        &s(seq),
        "--out",
        &s(&dir.join("run")),
    ])
}

/// `classify` of `seq` with `model` into `dir/zones.csv`.
fn classify(model: &Path, seq: &Path, dir: &Path) -> Vec<String> {
    args(&[
        "classify",
        "--model",
        &s(model),
        "--seq",
        &s(seq),
        "--out",
        &s(&dir.join("zones.csv")),
    ])
}

/// `simulate` on colon surface `mesh` along a straight 10 mm mid-line, into `dir/sim`.
fn simulate_mesh(mesh: &Path, dir: &Path) -> Vec<String> {
    let path = write(&dir.join("path.csv"), "0,0,0\n0,0,10\n");
    args(&[
        "simulate",
        "--mesh",
        &s(mesh),
        "--path",
        &s(&path),
        "--out",
        &s(&dir.join("sim")),
    ])
}

fn eval(gt: &Path, est: &Path, dir: &Path) -> Vec<String> {
    args(&[
        "eval",
        "--gt",
        &s(gt),
        "--est",
        &s(est),
        "--out",
        &s(&dir.join("eval")),
    ])
}

/// A copy of the fixture's dataset in `dir/data`.
fn data_copy(fx: &Fixture, dir: &Path) -> PathBuf {
    copy(&fx.data, &dir.join("data"))
}

/// A copy of the fixture's model in `dir/model_copy`.
fn model_copy(fx: &Fixture, dir: &Path) -> PathBuf {
    copy(&fx.model, &dir.join("model_copy"))
}

fn frame(data: &Path, seq: &str, i: usize) -> PathBuf {
    data.join(seq).join("images").join(format!("{i:06}.png"))
}

/// `import video` of a (missing) video with the pose log `log`: the log is read and checked
/// before the video is decoded.
fn video_import(dir: &Path, log: &str) -> Vec<String> {
    let log = write(&dir.join("tracker.csv"), log);
    args(&[
        "import",
        "video",
        &s(&dir.join("pass.mp4")),
        "--poses",
        &s(&log),
        "--camera",
        "160,120,80,80,79.5,59.5",
        "--out",
        &s(&dir.join("imported")),
    ])
}

/// `localize --live --video VIDEO` with the fixture's model into `dir/run` (`extra`: more
/// options); standard input is empty.
fn video_localize(fx: &Fixture, video: &str, extra: &[&str], dir: &Path) -> Vec<String> {
    let mut a = args(&[
        "localize",
        "--model",
        &s(&fx.model),
        "--live",
        "--video",
        video,
        "--out",
        &s(&dir.join("run")),
    ]);
    a.extend(extra.iter().map(|x| x.to_string()));
    a
}

fn write(path: &Path, text: &str) -> PathBuf {
    std::fs::write(path, text).unwrap();
    path.to_path_buf()
}

fn catalogue() -> Vec<Case> {
    vec![
        // ---- images ----
        case(
            "truncated PNG in the training pass (train)",
            &["000003.png", "unexpected end of file"],
            |fx, d| {
                let data = data_copy(fx, d);
                truncate(&frame(&data, "train", 3), 300);
                train_on(&data, d)
            },
        ),
        case(
            "truncated PNG in the test pass, --strict (localize)",
            &["000004.png", "unexpected end of file"],
            |fx, d| {
                let data = data_copy(fx, d);
                truncate(&frame(&data, "test", 4), 300);
                let mut a = localize(&fx.model, &data.join("test"), d);
                a.push("--strict".into());
                a
            },
        ),
        case(
            "training image of the wrong size (train)",
            &["000005.png", "80x60", "expected the camera's 160x120"],
            |fx, d| {
                let data = data_copy(fx, d);
                gray_png(&frame(&data, "train", 5), 80, 60, 128);
                train_on(&data, d)
            },
        ),
        case(
            "test image of the wrong size, --strict (localize)",
            &["000002.png", "80x60", "160x120"],
            |fx, d| {
                let data = data_copy(fx, d);
                gray_png(&frame(&data, "test", 2), 80, 60, 128);
                let mut a = localize(&fx.model, &data.join("test"), d);
                a.push("--strict".into());
                a
            },
        ),
        case(
            "negative polish kernel scale (localize)",
            &["-0.5 px", "--polish-px", "expected a finite value > 0"],
            |fx, d| {
                let mut a = localize(&fx.model, &fx.data.join("test"), d);
                a.push("--polish-px=-0.5".into());
                a
            },
        ),
        case(
            "negative wall motion (localize)",
            &["--wall-motion-mm -1 mm", "expected a finite value ≥ 0"],
            |fx, d| {
                let mut a = localize(&fx.model, &fx.data.join("test"), d);
                a.push("--wall-motion-mm=-1".into());
                a
            },
        ),
        case(
            "negative keypoint noise (localize)",
            &["--keypoint-noise-px -1 px", "expected a finite value ≥ 0"],
            |fx, d| {
                let mut a = localize(&fx.model, &fx.data.join("test"), d);
                a.push("--keypoint-noise-px=-1".into());
                a
            },
        ),
        case(
            "image that is not an image (features)",
            &["notes.png"],
            |_, d| {
                let img = write(&d.join("notes.png"), "not a PNG\n");
                args(&["features", &s(&img), "--keypoints", &s(&d.join("kp.csv"))])
            },
        ),
        case(
            "truncated image (classify --verify)",
            &["000001.png", "unexpected end of file"],
            |fx, d| {
                let data = data_copy(fx, d);
                truncate(&frame(&data, "test", 1), 200);
                classify(&fx.model, &data.join("test"), d)
            },
        ),
        // ---- poses ----
        case(
            "pose line with 7 columns (train)",
            &["poses.txt:3", "expected 8 columns"],
            |fx, d| {
                let data = data_copy(fx, d);
                edit_line(&data.join("train/poses.txt"), 3, |l| {
                    l.rsplit_once(' ').unwrap().0.to_string()
                });
                train_on(&data, d)
            },
        ),
        case(
            "NaN in a pose (train)",
            &["poses.txt:4", "nan", "expected a finite number"],
            |fx, d| {
                let data = data_copy(fx, d);
                edit_column(&data.join("train/poses.txt"), 4, 1, "nan");
                train_on(&data, d)
            },
        ),
        case(
            "non-unit quaternion (localize)",
            &["poses.txt:5", "expected a unit quaternion"],
            |fx, d| {
                let data = data_copy(fx, d);
                edit_column(&data.join("test/poses.txt"), 5, 7, "2.0");
                localize(&fx.model, &data.join("test"), d)
            },
        ),
        case(
            "time stamps out of order (train)",
            &["poses.txt:6", "expected strictly increasing time stamps"],
            |fx, d| {
                let data = data_copy(fx, d);
                edit_column(&data.join("train/poses.txt"), 6, 0, "0.0");
                train_on(&data, d)
            },
        ),
        case(
            "fewer images than poses (train)",
            &["train/images", "59 images but 60 poses"],
            |fx, d| {
                let data = data_copy(fx, d);
                std::fs::remove_file(frame(&data, "train", 59)).unwrap();
                train_on(&data, d)
            },
        ),
        case(
            "more images than poses (localize)",
            &["test/images", "21 images but 20 poses"],
            |fx, d| {
                let data = data_copy(fx, d);
                std::fs::copy(frame(&data, "test", 0), frame(&data, "test", 20)).unwrap();
                localize(&fx.model, &data.join("test"), d)
            },
        ),
        case(
            "training on a pass without poses (frames.txt only)",
            &["train", "a pass without poses", "not trained on"],
            |fx, d| {
                let data = data_copy(fx, d);
                unposed(&data.join("train"));
                train_on(&data, d)
            },
        ),
        case(
            "a pass without poses whose frames.txt has a NaN (localize)",
            &["frames.txt:4", "expected a finite time stamp"],
            |fx, d| {
                let data = data_copy(fx, d);
                unposed(&data.join("test"));
                edit_column(&data.join("test/frames.txt"), 4, 0, "NaN");
                localize(&fx.model, &data.join("test"), d)
            },
        ),
        case(
            "sections.csv with a row missing (train)",
            &["sections.csv", "59 rows but 60 poses"],
            |fx, d| {
                let data = data_copy(fx, d);
                let p = data.join("train/sections.csv");
                let text = std::fs::read_to_string(&p).unwrap();
                let mut lines: Vec<&str> = text.lines().collect();
                lines.pop();
                std::fs::write(&p, lines.join("\n") + "\n").unwrap();
                train_on(&data, d)
            },
        ),
        // ---- dataset.toml and mask ----
        case(
            "dataset.toml with an unknown key (train)",
            &["dataset.toml:5", "unknown field `colour`"],
            |fx, d| {
                let data = data_copy(fx, d);
                replace_in(
                    &data.join("dataset.toml"),
                    "units = \"mm\"\n",
                    "units = \"mm\"\ncolour = \"red\"\n",
                );
                train_on(&data, d)
            },
        ),
        case(
            "dataset.toml of another format version (map)",
            &["dataset.toml", "format_version = 7; expected 1"],
            |fx, d| {
                let data = data_copy(fx, d);
                replace_in(
                    &data.join("dataset.toml"),
                    "format_version = 1",
                    "format_version = 7",
                );
                args(&[
                    "map",
                    "--model",
                    &s(&model_copy(fx, d)),
                    "--data",
                    &s(&data),
                    "--force",
                ])
            },
        ),
        case(
            "negative focal length (train)",
            &["dataset.toml", "focal lengths must be positive"],
            |fx, d| {
                let data = data_copy(fx, d);
                let p = data.join("dataset.toml");
                let text = std::fs::read_to_string(&p).unwrap();
                let line = text
                    .lines()
                    .find(|l| l.starts_with("fx = "))
                    .unwrap()
                    .to_string();
                replace_in(&p, &line, "fx = -80.0");
                train_on(&data, d)
            },
        ),
        case(
            "no dataset.toml (train)",
            &["not an endoloc dataset (no dataset.toml)"],
            |fx, d| {
                let data = data_copy(fx, d);
                std::fs::remove_file(data.join("dataset.toml")).unwrap();
                train_on(&data, d)
            },
        ),
        case(
            "a sequence folder given as the dataset (train)",
            &["data/train", "a sequence folder, not a dataset"],
            |fx, d| train_on(&fx.data.join("train"), d),
        ),
        case(
            "mask of the wrong size (localize)",
            &["mask.png", "80×60", "160×120"],
            |fx, d| {
                let data = data_copy(fx, d);
                gray_png(&data.join("mask.png"), 80, 60, 255);
                replace_in(
                    &data.join("dataset.toml"),
                    "model = \"pinhole\"\n",
                    "model = \"pinhole\"\nmask = \"mask.png\"\n",
                );
                localize(&fx.model, &data.join("test"), d)
            },
        ),
        case(
            "mask without a valid pixel (map)",
            &["mask.png", "no valid pixel"],
            |fx, d| {
                let data = data_copy(fx, d);
                gray_png(&data.join("mask.png"), 160, 120, 0);
                replace_in(
                    &data.join("dataset.toml"),
                    "model = \"pinhole\"\n",
                    "model = \"pinhole\"\nmask = \"mask.png\"\n",
                );
                args(&[
                    "map",
                    "--model",
                    &s(&model_copy(fx, d)),
                    "--data",
                    &s(&data),
                    "--force",
                ])
            },
        ),
        case(
            "mask file named but missing (localize)",
            &["nomask.png", "No such file"],
            |fx, d| {
                let data = data_copy(fx, d);
                replace_in(
                    &data.join("dataset.toml"),
                    "model = \"pinhole\"\n",
                    "model = \"pinhole\"\nmask = \"nomask.png\"\n",
                );
                localize(&fx.model, &data.join("test"), d)
            },
        ),
        case(
            "test pass from another camera (localize)",
            &["another camera", "fx 95.0"],
            |fx, d| {
                let data = data_copy(fx, d);
                let p = data.join("dataset.toml");
                let text = std::fs::read_to_string(&p).unwrap();
                let line = text
                    .lines()
                    .find(|l| l.starts_with("fx = "))
                    .unwrap()
                    .to_string();
                replace_in(&p, &line, "fx = 95.0");
                localize(&fx.model, &data.join("test"), d)
            },
        ),
        case(
            "test pass's own camera of another image size (localize)",
            &[
                "test/camera.toml",
                "a 320x240 camera",
                "expected the dataset's image size, 160x120",
            ],
            |fx, d| {
                let data = data_copy(fx, d);
                write(
                    &data.join("test/camera.toml"),
                    "[camera]\nwidth = 320\nheight = 240\nfx = 160.0\nfy = 160.0\ncx = 159.5\ncy = 119.5\n",
                );
                localize(&fx.model, &data.join("test"), d)
            },
        ),
        case(
            "camera file without a [camera] table (localize --camera)",
            &["scope.toml", "no [camera] table", "fx, fy, cx, cy"],
            |fx, d| {
                let file = write(&d.join("scope.toml"), "fx = 80.0\n");
                let mut a = localize(&fx.model, &fx.data.join("test"), d);
                a.extend(["--camera".to_string(), s(&file)]);
                a
            },
        ),
        // ---- model folders ----
        case(
            "model folder from another dataset (localize)",
            &[
                "other/train/poses.txt",
                "poses fingerprint",
                "train a model on this dataset",
            ],
            |fx, d| localize(&fx.model, &fx.other.join("test"), d),
        ),
        case(
            "model folder from another dataset (classify)",
            &["data/train/poses.txt", "poses fingerprint"],
            |fx, d| classify(&fx.other_model, &fx.data.join("test"), d),
        ),
        case(
            "model folder from another dataset (map)",
            &["data/train/poses.txt", "poses fingerprint"],
            |fx, d| {
                let m = copy(&fx.other_model, &d.join("m"));
                args(&["map", "--model", &s(&m), "--data", &s(&fx.data), "--force"])
            },
        ),
        case(
            "model folder of another format version (localize)",
            &[
                "model.toml",
                "model format version 99; this build reads version 1",
            ],
            |fx, d| {
                let m = model_copy(fx, d);
                replace_in(
                    &m.join("model.toml"),
                    "format_version = 1",
                    "format_version = 99",
                );
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "model.toml with an unknown key (localize)",
            &["model.toml:2", "unknown field `colour`"],
            |fx, d| {
                let m = model_copy(fx, d);
                edit_line(&m.join("model.toml"), 1, |l| format!("{l}\ncolour = 1"));
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "no model folder (localize)",
            &["nothing/model.toml", "No such file"],
            |fx, d| localize(&d.join("nothing"), &fx.data.join("test"), d),
        ),
        case(
            "map built for another model (localize)",
            &[
                "built for zones with fingerprint",
                "rebuild it with the map job (--model",
            ],
            |fx, d| {
                let m = model_copy(fx, d);
                for f in ["map.bin", "map.toml"] {
                    std::fs::copy(fx.other_model.join(f), m.join(f)).unwrap();
                }
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "model without a map (localize)",
            &["map.toml", "build the map first"],
            |fx, d| {
                let m = model_copy(fx, d);
                std::fs::remove_file(m.join("map.toml")).unwrap();
                std::fs::remove_file(m.join("map.bin")).unwrap();
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "truncated map.bin (localize)",
            &["map.bin", "different builds"],
            |fx, d| {
                let m = model_copy(fx, d);
                truncate(&m.join("map.bin"), 200);
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "corrupt database.bin (localize)",
            &["database.bin", "100 bytes; expected"],
            |fx, d| {
                let m = model_copy(fx, d);
                truncate(&m.join("database.bin"), 100);
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "zero-length weights (localize)",
            &["weights.safetensors"],
            |fx, d| {
                let m = model_copy(fx, d);
                truncate(&m.join("weights.safetensors"), 0);
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "truncated whitening.bin (classify)",
            &["whitening.bin", "50 bytes; expected"],
            |fx, d| {
                let m = model_copy(fx, d);
                truncate(&m.join("whitening.bin"), 50);
                classify(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "zones.csv with a broken line (localize)",
            &["zones.csv:3", "expected the header"],
            |fx, d| {
                let m = model_copy(fx, d);
                edit_line(&m.join("zones.csv"), 3, |_| "1,2,x,y".into());
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "zones.csv edited after training (localize)",
            &[
                "zones.csv has fingerprint",
                "replaced or edited after training",
            ],
            |fx, d| {
                let m = model_copy(fx, d);
                let p = m.join("zones.csv");
                let text = std::fs::read_to_string(&p).unwrap();
                std::fs::write(&p, text + "# edited\n").unwrap();
                localize(&m, &fx.data.join("test"), d)
            },
        ),
        case(
            "more zones than training frames (train)",
            &["100 zones need at least 100 frames", "at most 60 zones"],
            |fx, d| {
                let mut a = train_on(&fx.data, d);
                a[4] = "100".into();
                a
            },
        ),
        // ---- outputs ----
        case(
            "localize into an existing run without --force",
            &["trajectory.txt exists", "--force"],
            |fx, d| {
                let run = copy(&fx.run, &d.join("run"));
                localize(&fx.model, &fx.data.join("test"), run.parent().unwrap())
            },
        ),
        case(
            "train into an existing model folder without --force",
            &["already exists"],
            |fx, d| {
                copy(&fx.model, &d.join("model"));
                train_on(&fx.data, d)
            },
        ),
        case(
            "simulate into an existing folder without --force",
            &["already exists"],
            |_, d| {
                std::fs::create_dir_all(d.join("sim")).unwrap();
                write(&d.join("sim/keep.txt"), "mine");
                args(&["simulate", "--preset", "small", "--out", &s(&d.join("sim"))])
            },
        ),
        case(
            "classify onto an existing CSV without --force",
            &["zones.csv", "--force"],
            |fx, d| {
                write(&d.join("zones.csv"), "mine\n");
                classify(&fx.model, &fx.data.join("test"), d)
            },
        ),
        case(
            "output folder under a file (localize)",
            &["blocker: is a file, not a folder"],
            |fx, d| {
                write(&d.join("blocker"), "a file");
                args(&[
                    "localize",
                    "--model",
                    &s(&fx.model),
                    "--seq",
                    &s(&fx.data.join("test")),
                    "--out",
                    &s(&d.join("blocker/run")),
                ])
            },
        ),
        // ---- trajectories and run files (eval, view) ----
        case(
            "estimate file missing (eval)",
            &["none.txt", "No such file"],
            |fx, d| eval(&fx.data.join("test/poses.txt"), &d.join("none.txt"), d),
        ),
        case(
            "estimate line with 7 columns (eval)",
            &["est.txt:3", "expected 8 columns"],
            |fx, d| {
                let est = d.join("est.txt");
                std::fs::copy(fx.run.join("trajectory.txt"), &est).unwrap();
                edit_line(&est, 3, |l| l.rsplit_once(' ').unwrap().0.to_string());
                eval(&fx.data.join("test/poses.txt"), &est, d)
            },
        ),
        case(
            "estimate with no time stamp in common (eval)",
            &["no matching timestamps"],
            |fx, d| {
                let est = d.join("est.txt");
                let text = std::fs::read_to_string(fx.run.join("trajectory.txt")).unwrap();
                let shifted: Vec<String> = text
                    .lines()
                    .filter(|l| !l.starts_with('#'))
                    .map(|l| {
                        let (t, rest) = l.split_once(' ').unwrap();
                        format!("{} {rest}", t.parse::<f64>().unwrap() + 1000.0)
                    })
                    .collect();
                std::fs::write(&est, shifted.join("\n")).unwrap();
                eval(&fx.data.join("test/poses.txt"), &est, d)
            },
        ),
        case(
            "frames.csv with a foreign header (eval)",
            &["frames.csv:1", "expected \"frame,zone,zone_score"],
            |fx, d| {
                let run = copy(&fx.run, &d.join("run"));
                edit_line(&run.join("frames.csv"), 1, |_| "frame,zone,oops".into());
                let mut a = eval(
                    &fx.data.join("test/poses.txt"),
                    &run.join("trajectory.txt"),
                    d,
                );
                a.extend(args(&["--frames", &s(&run.join("frames.csv"))]));
                a
            },
        ),
        case(
            "view of a folder that is no run (view)",
            &["is not a localization run folder", "frames.csv"],
            |_, d| {
                std::fs::create_dir_all(d.join("empty")).unwrap();
                args(&[
                    "view",
                    &s(&d.join("empty")),
                    "--out",
                    &s(&d.join("view.html")),
                ])
            },
        ),
        // ---- simulator inputs ----
        case(
            "simulator config with an unknown key (simulate)",
            &["sim.toml", "unknown field `colour`"],
            |_, d| {
                let cfg = write(&d.join("sim.toml"), "colour = 1\n");
                args(&[
                    "simulate",
                    "--config",
                    &s(&cfg),
                    "--out",
                    &s(&d.join("sim")),
                ])
            },
        ),
        case(
            "OBJ face pointing at no vertex (simulate --mesh)",
            &["bad.obj:4", "refers to no vertex"],
            |_, d| {
                let mesh = write(&d.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
                simulate_mesh(&mesh, d)
            },
        ),
        case(
            "truncated VTK mesh (simulate --mesh)",
            &["bad.vtk:6", "truncated"],
            |_, d| {
                let mesh = write(
                    &d.join("bad.vtk"),
                    "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0\n",
                );
                simulate_mesh(&mesh, d)
            },
        ),
        case(
            "GCA folder without a mid-line (simulate --gca)",
            &["no mid-line path", "large_intestine_path.jsn"],
            |_, d| {
                std::fs::create_dir_all(d.join("gca")).unwrap();
                args(&[
                    "simulate",
                    "--gca",
                    &s(&d.join("gca")),
                    "--out",
                    &s(&d.join("sim")),
                ])
            },
        ),
        // ---- importers ----
        case(
            "C3VD pose line with 15 values (import c3vd)",
            &["pose.txt:1", "expected 16 comma-separated values"],
            |_, d| {
                std::fs::create_dir_all(d.join("c3vd")).unwrap();
                write(&d.join("c3vd/pose.txt"), "1,0,0,0,0,1,0,0,0,0,1,0,0,0,0\n");
                args(&[
                    "import",
                    "c3vd",
                    &s(&d.join("c3vd")),
                    "--out",
                    &s(&d.join("imported")),
                ])
            },
        ),
        case(
            "SimCol3D folder without pose files (import simcol3d)",
            &["no SavedPosition_*.txt"],
            |_, d| {
                std::fs::create_dir_all(d.join("simcol")).unwrap();
                args(&[
                    "import",
                    "simcol3d",
                    &s(&d.join("simcol")),
                    "--out",
                    &s(&d.join("imported")),
                ])
            },
        ),
        case(
            "EndoSLAM folder without a pose file (import endoslam)",
            &["no pose file"],
            |_, d| {
                std::fs::create_dir_all(d.join("endoslam")).unwrap();
                args(&[
                    "import",
                    "endoslam",
                    &s(&d.join("endoslam")),
                    "--units",
                    "mm",
                    "--camera",
                    "160,120,80,80,79.5,59.5",
                    "--out",
                    &s(&d.join("imported")),
                ])
            },
        ),
        case(
            "tracker log with time stamps out of order (import video)",
            &[
                "tracker.csv:4",
                "is before that of line 3",
                "expected increasing time stamps",
            ],
            |_, d| {
                video_import(
                    d,
                    "t,x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n0.2,1,0,0,0,0,0,1\n0.1,2,0,0,0,0,0,1\n",
                )
            },
        ),
        case(
            "tracker log with NaN in a row not flagged missing (import video)",
            &["tracker.csv:3", "x", "expected a finite number"],
            |_, d| {
                video_import(
                    d,
                    "t,x,y,z,qx,qy,qz,qw,missing\n0,0,0,0,0,0,0,1,0\n0.1,nan,0,0,0,0,0,1,0\n",
                )
            },
        ),
        case(
            "tracker log without orientation columns (import video)",
            &["tracker.csv", "orientation columns"],
            |_, d| video_import(d, "time,x,y,z\n0,0,0,0\n"),
        ),
        case(
            "a video file that is not a video (localize --video)",
            &["pass.mp4", "cannot decode the video"],
            |fx, d| {
                let video = write(&d.join("pass.mp4"), "not a video at all");
                video_localize(fx, &s(&video), &[], d)
            },
        ),
        case(
            "raw frames on standard input without their size (localize --video -)",
            &["standard input", "size", "WxH"],
            |fx, d| video_localize(fx, "-", &[], d),
        ),
        case(
            "no frame on standard input (localize --video -)",
            &["standard input", "no frame", "160x120 gray8"],
            |fx, d| video_localize(fx, "-", &["--size", "160x120"], d),
        ),
        // ---- run configs and experiments ----
        case(
            "run config with an unknown table (run)",
            &["run.toml", "unknown field `job`"],
            |_, d| {
                let cfg = write(&d.join("run.toml"), "[job]\nkind = \"x\"\n");
                args(&["run", "--config", &s(&cfg)])
            },
        ),
        case(
            "experiment on a missing dataset (experiment compare)",
            &["nothing", "no such folder"],
            |_, d| {
                args(&[
                    "experiment",
                    "compare",
                    "--data",
                    &s(&d.join("nothing")),
                    "--out",
                    &s(&d.join("exp")),
                ])
            },
        ),
    ]
}

/// A file system mounted for one case (a tiny tmpfs, a read-only bind mount), unmounted on
/// drop. Mounting needs privileges: without them the case is skipped with a message.
struct Mount(PathBuf);

impl Mount {
    fn new(args: &[&str], at: &Path) -> Option<Mount> {
        std::fs::create_dir_all(at).unwrap();
        let ok = Command::new("mount")
            .args(args)
            .arg(at)
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        ok.then(|| Mount(at.to_path_buf()))
    }
}

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// A case on its own file system: name, the mount (`None`: skipped), arguments, expectations.
type MountedCase = (
    &'static str,
    Option<Mount>,
    Vec<String>,
    &'static [&'static str],
);

/// Output cases on mounted file systems: a full disk (a 256 KiB tmpfs) and a read-only
/// folder (a read-only bind mount, which holds for root too).
fn mounted_cases(fx: &Fixture) -> Vec<MountedCase> {
    let root = fx._tmp.path().join("mounts");
    let full = root.join("full");
    let disk = Mount::new(&["-t", "tmpfs", "-o", "size=256k", "tmpfs"], &full);
    let readonly = root.join("readonly");
    std::fs::create_dir_all(&readonly).unwrap();
    let ro = Mount::new(&["--bind", &s(&readonly)], &readonly).and_then(|m| {
        let remounted = Command::new("mount")
            .args(["-o", "remount,ro,bind"])
            .arg(&readonly)
            .status()
            .is_ok_and(|st| st.success());
        remounted.then_some(m)
    });
    vec![
        (
            "disk full while simulating (simulate)",
            disk,
            args(&[
                "simulate",
                "--preset",
                "small",
                "--train-frames",
                "60",
                "--test-frames",
                "20",
                "--width",
                "160",
                "--height",
                "120",
                "--out",
                &s(&full.join("sim")),
            ]),
            &["full/sim/", "No space left on device"],
        ),
        (
            "read-only output folder (localize)",
            ro,
            localize(&fx.model, &fx.data.join("test"), &readonly),
            &["readonly/run", "Read-only file system"],
        ),
    ]
}

#[test]
fn every_bad_input_exits_2_with_one_message_naming_the_file_and_changes_nothing() {
    let fx = fixture();
    let cases = catalogue();
    assert!(cases.len() >= 40, "the catalogue has {} cases", cases.len());
    let mut failures = Vec::new();
    println!("| # | bad input (command) | message |\n|---|---|---|");
    for (i, c) in cases.iter().enumerate() {
        let dir = fx._tmp.path().join(format!("case{i:02}"));
        std::fs::create_dir_all(&dir).unwrap();
        let args = (c.setup)(&fx, &dir);
        let before = snapshot(&dir);
        let out = endoloc(&args);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let error_lines: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
        let message = error_lines.first().copied().unwrap_or("").to_string();
        let shown = message.replace(&s(fx._tmp.path()), "…").replace('|', "\\|");
        println!("| {} | {} | `{}` |", i + 1, c.name, shown);
        let mut problems = Vec::new();
        if out.status.code() != Some(2) {
            problems.push(format!("exit status {:?}, expected 2", out.status.code()));
        }
        if stderr.contains("panicked") {
            problems.push("panicked".into());
        }
        if error_lines.len() != 1 {
            problems.push(format!("{} error lines", error_lines.len()));
        }
        for want in c.expect {
            if !message.contains(want) {
                problems.push(format!("message lacks {want:?}"));
            }
        }
        if snapshot(&dir) != before {
            problems.push("the case's folder changed (partial output or lost input)".into());
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{} ({}): {}\n  stderr: {stderr}",
                i + 1,
                c.name,
                problems.join("; ")
            ));
        }
    }
    for (k, (name, mount, args, expect)) in mounted_cases(&fx).into_iter().enumerate() {
        let Some(mount) = mount else {
            println!("| – | {name} | skipped: cannot mount here (needs root) |");
            continue;
        };
        let before = snapshot(&mount.0);
        let out = endoloc(&args);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let message = stderr
            .lines()
            .find(|l| l.starts_with("error:"))
            .unwrap_or("")
            .to_string();
        println!(
            "| {} | {name} | `{}` |",
            cases.len() + k + 1,
            message.replace(&s(fx._tmp.path()), "…")
        );
        let mut problems = Vec::new();
        if out.status.code() != Some(2) {
            problems.push(format!("exit status {:?}, expected 2", out.status.code()));
        }
        for want in expect {
            if !message.contains(want) {
                problems.push(format!("message lacks {want:?}"));
            }
        }
        if snapshot(&mount.0) != before {
            problems.push("the folder changed (partial output left behind)".into());
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{name}: {}\n  stderr: {stderr}",
                problems.join("; ")
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
