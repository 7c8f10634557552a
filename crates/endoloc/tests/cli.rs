//! The command line end to end on a tiny simulated colon: simulate → train → map →
//! localize (every method) → eval → experiment compare / perturb, checking the files a user
//! gets and that bad input gives a clear error instead of a panic. The numbers are not the
//! point here (a one-epoch model on 160×120 frames); the crates' own tests check accuracy.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn endoloc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_endoloc"))
        .args(args)
        .output()
        .expect("run endoloc")
}

fn ok(args: &[&str]) -> String {
    let out = endoloc(args);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "endoloc {args:?} failed:\n{text}");
    text
}

fn fails(args: &[&str]) -> String {
    let out = endoloc(args);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success(), "endoloc {args:?} should fail");
    assert!(
        !err.contains("panicked"),
        "endoloc {args:?} panicked:\n{err}"
    );
    err
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

struct Setup {
    _tmp: tempfile::TempDir,
    root: PathBuf,
}

/// A tiny dataset and a one-epoch model with its map.
/// The files of a localization run agree with each other: `frames.csv` lists frames 0..n in
/// order, `trajectory.txt` has a line per frame with a pose (in frame order), `inliers.csv`
/// holds as many keypoints of each refined frame as its `inliers` column, and `along.csv` a
/// distance along the colon per pose.
fn check_run_files(run: &Path, n: usize) {
    let read = |f: &str| std::fs::read_to_string(run.join(f)).unwrap();
    let frames = read("frames.csv");
    let rows: Vec<Vec<&str>> = frames
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), n, "{frames}");
    let mut with_pose = 0;
    let mut inliers = vec![0usize; n];
    for l in read("inliers.csv").lines().skip(1) {
        inliers[l.split(',').next().unwrap().parse::<usize>().unwrap()] += 1;
    }
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[0], i.to_string(), "frames.csv out of order: {row:?}");
        if row[5] != "none" {
            with_pose += 1;
        }
        if row[3] == "refined" {
            assert_eq!(row[6], inliers[i].to_string(), "frame {i}: {row:?}");
        }
    }
    let trajectory = read("trajectory.txt");
    let stamps: Vec<f64> = trajectory
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split(' ').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(stamps.len(), with_pose, "{trajectory}");
    assert!(stamps.windows(2).all(|w| w[0] < w[1]), "{trajectory}");
    // The simulated dataset has a mid-line: each pose's distance along the colon.
    let along = read("along.csv");
    let rows: Vec<(usize, f64)> = along
        .lines()
        .skip(1)
        .map(|l| {
            let (f, s) = l.split_once(',').unwrap();
            (f.parse().unwrap(), s.parse().unwrap())
        })
        .collect();
    assert_eq!(rows.len(), with_pose, "{along}");
    assert!(
        rows.iter().all(|(_, s)| (0.0..2000.0).contains(s)),
        "{along}"
    );
}

fn setup() -> Setup {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().to_path_buf();
    let data = root.join("data");
    let model = root.join("model");
    ok(&[
        "simulate",
        "--preset",
        "small",
        "--train-frames",
        "120",
        "--test-frames",
        "40",
        "--width",
        "160",
        "--height",
        "120",
        "--out",
        &s(&data),
    ]);
    ok(&[
        "train",
        "--data",
        &s(&data),
        "--zones",
        "6",
        "--epochs",
        "1",
        // A small network input: the outputs, not the network's skill, are under test.
        "--input",
        "80x60",
        "--out",
        &s(&model),
    ]);
    ok(&[
        "map",
        "--model",
        &s(&model),
        "--data",
        &s(&data),
        "--threshold",
        "20",
    ]);
    Setup { _tmp: tmp, root }
}

#[test]
fn every_method_and_experiment_writes_its_outputs() {
    let st = setup();
    let r = |p: &str| s(&st.root.join(p));

    // `endoloc localize` of the test pass into `out`, with `extra` options.
    let localize = |out: &str, extra: &[&str]| {
        let (model, seq, out) = (r("model"), r("data/test"), r(out));
        let mut args = vec!["localize", "--model", &model, "--seq", &seq, "--out", &out];
        args.extend_from_slice(extra);
        ok(&args)
    };
    let localize_live = |out: &str| localize(out, &["--live"]);
    // Our method, live, then evaluated.
    localize_live("run");
    let frames = std::fs::read_to_string(st.root.join("run/frames.csv")).unwrap();
    assert_eq!(
        frames.lines().count(),
        41,
        "header + one row per test frame"
    );
    check_run_files(&st.root.join("run"), 40);
    // The live replay benchmark localizes as `localize --live` does, with either SURF loop.
    let bench = ok(&[
        "bench",
        "live",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
    ]);
    assert!(bench.contains("40 frames replayed live"), "{bench}");
    assert!(
        bench.contains("frames with a different result: 0"),
        "the reference SURF loop must find the same keypoints:\n{bench}"
    );
    let refined = frames.lines().filter(|l| l.contains(",refined,")).count();
    let percent = format!("{:.1}%", 100.0 * refined as f64 / 40.0);
    let current = bench.lines().find(|l| l.starts_with("current")).unwrap();
    assert!(
        current.ends_with(&percent),
        "bench refines {current:?}, localize --live {percent}"
    );
    // Per frame: frames are localized in parallel blocks and written in frame order.
    localize("run-per-frame", &[]);
    check_run_files(&st.root.join("run-per-frame"), 40);
    // Registrations are confirmed against the map unless told otherwise, and the run's
    // settings say which.
    let settings = |run: &str| std::fs::read_to_string(st.root.join(run).join("localize.toml"));
    for run in ["run", "run-per-frame"] {
        let toml = settings(run).unwrap();
        assert!(toml.contains("confirm = true"), "{run}: {toml}");
    }
    ok(&[
        "localize",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--out",
        &r("run-no-confirm"),
        "--live",
        "--no-confirm",
    ]);
    let toml = settings("run-no-confirm").unwrap();
    assert!(toml.contains("confirm = false"), "{toml}");
    ok(&[
        "eval",
        "--gt",
        &r("data/test/poses.txt"),
        "--est",
        &r("run/trajectory.txt"),
        "--no-plots",
    ]);
    assert!(st.root.join("run/eval/metrics.json").is_file());
    // Results are never overwritten silently.
    let err = fails(&[
        "localize",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--out",
        &r("run"),
    ]);
    assert!(err.contains("--force"), "{err}");

    // An ensemble localizes too; baselines refuse it.
    ok(&[
        "localize",
        "--model",
        &r("model"),
        "--also-model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--out",
        &r("run-ensemble"),
        "--live",
    ]);
    let joined = std::fs::read_to_string(st.root.join("run-ensemble/frames.csv")).unwrap();
    assert_eq!(
        joined.lines().count(),
        41,
        "header + one row per test frame"
    );
    let err = fails(&[
        "localize",
        "--method",
        "vo",
        "--model",
        &r("model"),
        "--also-model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--out",
        &r("run-vo-ensemble"),
    ]);
    assert!(err.contains("--also-model"), "{err}");

    // Zones with geometric verification against the maps: two more columns, two more
    // summary lines (their accuracy is checked in the localize crate's pipeline test).
    let text = ok(&[
        "classify",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--verify",
        "3",
        "--out",
        &r("zones.csv"),
    ]);
    assert!(text.contains("verified") && text.contains("live"), "{text}");
    assert!(text.contains("track") && text.contains("smooth"), "{text}");
    let zones = std::fs::read_to_string(st.root.join("zones.csv")).unwrap();
    let header = zones.lines().next().unwrap();
    assert!(
        header.contains(
            ",forward_zone,viterbi_zone,track_zone,track_frame,smooth_zone,smooth_frame,"
        ),
        "{header}"
    );
    assert!(
        header.ends_with(",smooth_frame,truth_frame,truth_zone,verified_zone,live_zone"),
        "{header}"
    );
    assert_eq!(zones.lines().count(), 41, "header + one row per test frame");
    assert!(
        zones.lines().skip(1).all(|l| l
            .split(',')
            .rev()
            .take(2)
            .all(|z| z.parse::<usize>().is_ok_and(|z| z < 6))),
        "{zones}"
    );
    // An existing zone file is kept unless --force, and replaced whole with it.
    let again = [
        "classify",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--limit",
        "5",
        "--out",
        &r("zones.csv"),
    ];
    let err = fails(&again);
    assert!(
        err.contains("zones.csv") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(st.root.join("zones.csv")).unwrap(),
        zones
    );
    ok(&[&again[..], &["--force"]].concat());
    let replaced = std::fs::read_to_string(st.root.join("zones.csv")).unwrap();
    assert_eq!(
        replaced.lines().count(),
        6,
        "header + the 5 frames asked for"
    );
    // The model joined with itself (an ensemble of one model twice) gives the same zones.
    let joined = ok(&[
        "classify",
        "--model",
        &r("model"),
        "--also-model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--limit",
        "5",
        "--out",
        &r("zones_joined.csv"),
    ]);
    assert!(joined.contains(" + "), "names both models: {joined}");
    let zones_only = |text: &str| -> Vec<String> {
        text.lines()
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                format!("{} {} {}", c[2], c[7], c[9])
            })
            .collect()
    };
    assert_eq!(
        zones_only(&std::fs::read_to_string(st.root.join("zones_joined.csv")).unwrap()),
        zones_only(&replaced)
    );
    // Descriptors for Python: a float32 .npy of frames × descriptor length, unit rows.
    let err = fails(&[
        "classify",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--out",
        &r("same.npy"),
        "--descriptors",
        &r("same.npy"),
    ]);
    assert!(err.contains("different files"), "{err}");
    ok(&[
        "classify",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--limit",
        "5",
        "--out",
        &r("zones_desc.csv"),
        "--descriptors",
        &r("desc.npy"),
    ]);
    let npy = std::fs::read(st.root.join("desc.npy")).unwrap();
    assert_eq!(&npy[..8], b"\x93NUMPY\x01\x00");
    let header_len = u16::from_le_bytes([npy[8], npy[9]]) as usize;
    let header = std::str::from_utf8(&npy[10..10 + header_len]).unwrap();
    assert!(header.contains("'descr': '<f4'"), "{header}");
    let dim: usize = header
        .split("'shape': (5, ")
        .nth(1)
        .and_then(|t| t.split(')').next())
        .and_then(|d| d.parse().ok())
        .unwrap_or_else(|| panic!("shape (5, D) in {header}"));
    let values: Vec<f32> = npy[10 + header_len..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(values.len(), 5 * dim);
    for row in values.chunks(dim) {
        let norm = row.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((norm - 1.0).abs() < 1e-3, "descriptor norm {norm}");
    }
    // Without maps, --verify says what to run first.
    let bare = st.root.join("model_without_map");
    std::fs::create_dir(&bare).unwrap();
    for entry in std::fs::read_dir(st.root.join("model")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if path.is_file() && !name.starts_with("map") {
            std::fs::copy(&path, bare.join(&name)).unwrap();
        }
    }
    let err = fails(&[
        "classify",
        "--model",
        &s(&bare),
        "--seq",
        &r("data/test"),
        "--verify",
        "3",
    ]);
    assert!(
        err.contains("build the map first with the map job"),
        "{err}"
    );

    // Baselines through `localize --method`.
    for method in ["classify", "retrieval", "vo"] {
        let out = format!("run-{method}");
        ok(&[
            "localize",
            "--method",
            method,
            "--model",
            &r("model"),
            "--seq",
            &r("data/test"),
            "--out",
            &r(&out),
        ]);
        let traj = std::fs::read_to_string(st.root.join(&out).join("trajectory.txt")).unwrap();
        assert!(traj.lines().count() > 0, "{method}: empty trajectory");
    }
    let err = fails(&[
        "localize",
        "--method",
        "offsetnet",
        "--model",
        &r("model"),
        "--seq",
        &r("data/test"),
        "--out",
        &r("run-offsetnet"),
    ]);
    assert!(err.contains("--regressor"), "{err}");

    // The comparison table with every method that needs no extra training.
    ok(&[
        "experiment",
        "compare",
        "--data",
        &r("data"),
        "--model",
        &r("model"),
        "--threshold",
        "20",
        "--methods",
        "endoloc-paper,endoloc-live,classify,retrieval,vo",
        "--out",
        &r("compare"),
    ]);
    let rows: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(st.root.join("compare/compare.json")).unwrap(),
    )
    .unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 5);
    for row in rows {
        assert_eq!(row["frames"], 40);
    }
    let html = std::fs::read_to_string(st.root.join("compare/report.html")).unwrap();
    assert!(
        html.contains("data:image/png;base64,"),
        "plots are embedded"
    );
    assert!(html.contains("endoloc-live"));
    assert!(st.root.join("compare/compare.md").is_file());
    assert!(st.root.join("compare/runs/vo/note.txt").is_file());
    // Running it again reuses every finished run.
    let again = ok(&[
        "experiment",
        "compare",
        "--data",
        &r("data"),
        "--model",
        &r("model"),
        "--threshold",
        "20",
        "--methods",
        "classify",
        "--out",
        &r("compare"),
    ]);
    assert!(again.contains("reusing   classify"), "{again}");

    // The perturbation study.
    ok(&[
        "experiment",
        "perturb",
        "--data",
        &r("data"),
        "--model",
        &r("model"),
        "--threshold",
        "20",
        "--max",
        "1",
        "--out",
        &r("perturb"),
    ]);
    let csv = std::fs::read_to_string(st.root.join("perturb/perturb.csv")).unwrap();
    let offsets: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(offsets, ["-1", "0", "1"]);
    assert!(st.root.join("perturb/report.html").is_file());

    // A corrupt frame (a truncated PNG, as a live scope drops and corrupts frames) is
    // `rejected` with reason `unreadable_image` and the run goes on; `--strict` stops at it
    // and names the file, each cause once. The frame is restored afterwards.
    let corrupt = st.root.join("data/test/images/000005.png");
    let png = std::fs::read(&corrupt).unwrap();
    std::fs::write(&corrupt, &png[..png.len() / 2]).unwrap();
    let localize_args = |out: &str, extra: &[&str]| -> Vec<String> {
        let mut args = [
            "localize",
            "--model",
            &r("model"),
            "--seq",
            &r("data/test"),
            "--out",
        ]
        .map(String::from)
        .to_vec();
        args.push(r(out));
        args.extend(extra.iter().map(|a| a.to_string()));
        args
    };
    fn strs(args: &[String]) -> Vec<&str> {
        args.iter().map(String::as_str).collect()
    }
    for (out, mode) in [
        ("run-corrupt-live", "--live"),
        ("run-corrupt", "--neighbours=1"),
    ] {
        let text = ok(&strs(&localize_args(out, &[mode])));
        assert!(text.contains("(1 unreadable images)"), "{out}: {text}");
        let frames = std::fs::read_to_string(st.root.join(out).join("frames.csv")).unwrap();
        let row5 = frames.lines().nth(6).unwrap();
        assert!(
            row5.starts_with("5,") && row5.contains(",rejected,unreadable_image,"),
            "{out}: {row5}"
        );
        assert_eq!(frames.lines().count(), 41, "{out}: every frame has its row");
    }
    // Live, the frames are decoded on a thread of their own: its error stops the run too.
    for (out, mode) in [
        ("run-strict", "--neighbours=1"),
        ("run-strict-live", "--live"),
    ] {
        let err = fails(&strs(&localize_args(out, &["--strict", mode])));
        assert!(err.contains("000005.png"), "{out}: {err}");
        let first = err.lines().next().unwrap_or_default();
        let causes: Vec<&str> = first.split(": ").collect();
        for (k, c) in causes.iter().enumerate() {
            assert!(!causes[k + 1..].contains(c), "a cause said twice: {first}");
        }
        assert!(
            !st.root.join(out).join("frames.csv").exists(),
            "{out}: no partial output"
        );
    }
    std::fs::write(&corrupt, &png).unwrap();

    // The pretraining recipe: a second pass joins the pairs, and a model starts from our
    // own weights.
    let text = ok(&[
        "train",
        "--data",
        &r("data"),
        "--zones",
        "6",
        "--epochs",
        "1",
        "--also-seq",
        "test",
        "--pretrained",
        &r("model/weights.safetensors"),
        "--out",
        &r("model_passes"),
    ]);
    assert!(
        text.contains("extra pass") && text.contains("(40 frames joined the pairs)"),
        "{text}"
    );
    let err = fails(&[
        "train",
        "--data",
        &r("data"),
        "--also-seq",
        "nope",
        "--out",
        &r("model_nope"),
    ]);
    assert!(err.contains("nope") && err.contains("test"), "{err}");

    // The map's smoothed level: written beside the map, used by localize, removed by a map
    // built without it.
    let (model, data) = (r("model"), r("data"));
    let map_with_level = |extra: &[&str]| {
        let mut args = vec!["map", "--model", &model, "--data", &data];
        args.extend_from_slice(&["--threshold", "20", "--force"]);
        args.extend_from_slice(extra);
        ok(&args)
    };
    let report = map_with_level(&["--smoothed-level", "1.0"]);
    assert!(report.contains("map_smoothed/"), "{report}");
    assert!(st.root.join("model/map_smoothed/map.toml").is_file());
    localize_live("run-level");
    check_run_files(&st.root.join("run-level"), 40);
    // An experiment asked for that level uses the map as it is; asked for another, it refuses
    // the model and says how to build it; asked for none in particular, it uses any map.
    let compare_level = |sigma: Option<&str>, out: &str, succeeds: bool| {
        let mut args = vec!["experiment", "compare", "--data", &data, "--model", &model];
        args.extend_from_slice(&["--threshold", "20", "--methods", "classify", "--out", out]);
        if let Some(sigma) = sigma {
            args.extend_from_slice(&["--smoothed-level", sigma]);
        }
        if succeeds { ok(&args) } else { fails(&args) }
    };
    compare_level(Some("1.0"), &r("compare-level"), true);
    let err = compare_level(Some("2.0"), &r("compare-level-2"), false);
    assert!(
        err.contains("σ 1 px") && err.contains("--smoothed-level 2 --force"),
        "{err}"
    );
    map_with_level(&["--smoothed-level", "0"]);
    assert!(!st.root.join("model/map_smoothed").exists());
    compare_level(None, &r("compare-level-none"), true);
    let map_toml = std::fs::read_to_string(st.root.join("model/map.toml")).unwrap();
    assert!(
        !map_toml.contains("blur_px"),
        "a sharp map's map.toml as before:\n{map_toml}"
    );
    let err = fails(&[
        "map",
        "--model",
        &model,
        "--data",
        &data,
        "--smoothed-level=-1",
    ]);
    assert!(
        err.contains("--smoothed-level") && err.contains("-1 px"),
        "{err}"
    );
    assert!(
        st.root.join("model/map.bin").is_file(),
        "a refused map job keeps the map"
    );
}

#[test]
fn bad_experiment_arguments_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("nothing");
    let err = fails(&[
        "experiment",
        "zones",
        "--data",
        &s(&missing),
        "--from",
        "20",
        "--to",
        "10",
        "--out",
        &s(&tmp.path().join("z")),
    ]);
    assert!(err.contains("--from 20, --to 10"), "{err}");
    let err = fails(&[
        "experiment",
        "compare",
        "--data",
        &s(&missing),
        "--out",
        &s(&tmp.path().join("c")),
    ]);
    assert!(err.contains("nothing"), "names the dataset folder: {err}");
    // A folder with someone else's files is not used without --force.
    let other = tmp.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("precious.txt"), "keep me").unwrap();
    let err = fails(&[
        "experiment",
        "perturb",
        "--data",
        &s(&missing),
        "--out",
        &s(&other),
    ]);
    assert!(err.contains("--force"), "{err}");
    assert_eq!(
        std::fs::read_to_string(other.join("precious.txt")).unwrap(),
        "keep me"
    );
}

#[test]
fn pretrain_chains_colons_and_writes_start_weights_that_train_accepts() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("pretrain");
    let args = [
        "pretrain",
        "--out",
        &s(&out),
        "--preset",
        "small",
        "--colons",
        "2",
        "--frames",
        "40",
        "--size",
        "160x120",
        "--zones",
        "4",
        "--epochs",
        "1",
    ];
    let text = ok(&args);
    for d in ["colon-101", "colon-202", "model-101", "model-202"] {
        assert!(out.join(d).is_dir(), "{d} missing:\n{text}");
    }
    // The second colon starts from the first one's weights.
    let second = std::fs::read_to_string(out.join("model-202/model.toml")).unwrap();
    assert!(second.contains("model-101"), "{second}");
    assert!(out.join("weights.safetensors").is_file());
    // Never overwritten silently; with --force the colons and models are reused.
    let err = fails(&args);
    assert!(err.contains("--force"), "{err}");
    let mut again = args.to_vec();
    again.push("--force");
    let text = ok(&again);
    assert!(text.contains("reusing"), "{text}");
    // The weights start a model on other data (indexing its pass with them as they are); so do
    // the shipped ones, and the model remembers where it started.
    let data = s(&out.join("colon-202"));
    let train_from = |weights: &str, model: &str| {
        let model = s(&tmp.path().join(model));
        ok(&[
            "train",
            "--data",
            &data,
            "--zones",
            "4",
            "--epochs",
            "0",
            "--pretrained",
            weights,
            "--out",
            &model,
        ])
    };
    train_from(&s(&out.join("weights.safetensors")), "model");
    train_from("builtin", "model-builtin");
    let toml = std::fs::read_to_string(tmp.path().join("model-builtin/model.toml")).unwrap();
    assert!(toml.contains("pretrained = \"builtin\""), "{toml}");
    // A pretraining continues from given weights with other pairs (recorded in each model;
    // 0 epochs: the pair rules themselves are the net crate's tests), its test pass through a
    // colon changed at random.
    let track = tmp.path().join("pretrain-track");
    let track_args = [
        "pretrain",
        "--out",
        &s(&track),
        "--preset",
        "small",
        "--colons",
        "1",
        "--frames",
        "40",
        "--size",
        "160x120",
        "--zones",
        "4",
        "--epochs",
        "0",
        "--pretrained",
        "builtin",
        "--pairs",
        "track",
        "--near-fraction",
        "0.1",
        "--changes",
        "mild",
    ];
    ok(&track_args);
    let toml = std::fs::read_to_string(track.join("model-101/model.toml")).unwrap();
    for want in [
        "pretrained = \"builtin\"",
        "rule = \"track\"",
        "near_fraction = 0.1",
    ] {
        assert!(toml.contains(want), "{want} missing:\n{toml}");
    }
    let colon = std::fs::read_to_string(track.join("colon-101/dataset.toml")).unwrap();
    assert!(colon.contains("severity = \"mild\""), "{colon}");
    assert!(track.join("colon-101/test/poses_changed.txt").is_file());
    // A colon simulated with another change is not reused for this one.
    let mut other = track_args.to_vec();
    *other.last_mut().unwrap() = "moderate";
    other.push("--force");
    let err = fails(&other);
    assert!(
        err.contains("colon-101") && err.contains("`mild`") && err.contains("`moderate`"),
        "{err}"
    );
    let err = fails(&[
        "pretrain",
        "--out",
        &s(&tmp.path().join("p0")),
        "--colons",
        "0",
    ]);
    assert!(err.contains("--colons 0"), "{err}");
}

#[test]
fn features_writes_keypoints_and_overlay_and_keeps_them_without_force() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str| s(&tmp.path().join(name));
    // Dark discs on a bright ground: blobs SURF finds.
    let img = image::GrayImage::from_fn(160, 120, |x, y| {
        let (cx, cy) = (40 + 40 * (x / 40), 30 + 40 * (y / 40));
        let r2 = (x as i64 - cx as i64).pow(2) + (y as i64 - cy as i64).pow(2);
        image::Luma([if r2 < 64 { 30 } else { 220 }])
    });
    img.save(tmp.path().join("frame.png")).unwrap();

    let args = [
        "features",
        &p("frame.png"),
        "--keypoints",
        &p("kp.csv"),
        "--overlay",
        &p("overlay.png"),
    ];
    ok(&args);
    let keypoints = std::fs::read_to_string(tmp.path().join("kp.csv")).unwrap();
    assert!(keypoints.lines().count() > 1, "{keypoints}");
    let overlay = image::open(tmp.path().join("overlay.png")).unwrap();
    assert_eq!((overlay.width(), overlay.height()), (160, 120));

    std::fs::write(tmp.path().join("kp.csv"), "mine").unwrap();
    let err = fails(&args);
    // The first existing output is named; nothing is replaced.
    assert!(
        err.contains("overlay.png") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("kp.csv")).unwrap(),
        "mine"
    );
    ok(&[&args[..], &["--force"]].concat());
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("kp.csv")).unwrap(),
        keypoints
    );

    let err = fails(&["features", &p("frame.png"), "--overlay", &p("o.jpg")]);
    assert!(err.contains("o.jpg") && err.contains(".png"), "{err}");
}

/// `experiment benchmark`: one command per colon from `--print-jobs`, a colon run alone,
/// a merge that names the colons not finished, then the whole run reusing the finished one;
/// the summary is the mean ± 95 % interval over the colons.
#[test]
fn the_benchmark_runs_colon_by_colon_and_merges() {
    let tmp = tempfile::tempdir().unwrap();
    let out = s(&tmp.path().join("bench"));
    let base = [
        "experiment",
        "benchmark",
        "--preset",
        "small",
        "--seeds",
        "1-2",
        "--dev-seeds",
        "3",
        "--train-frames",
        "60",
        "--test-frames",
        "30",
        "--zones",
        "6",
        "--methods",
        "endoloc-live,classify",
        "--out",
        &out,
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter().chain(extra).map(|a| a.to_string()).collect()
    };
    let run = |extra: &[&str]| -> String {
        let a = with(extra);
        ok(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let jobs = run(&["--print-jobs"]);
    let lines: Vec<&str> = jobs.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 4, "{jobs}");
    assert!(lines[0].ends_with("--colon seed-1") && lines[1].ends_with("--colon seed-2"));
    assert!(lines[2].ends_with("--colon dev-seed-3"), "{jobs}");
    assert!(
        lines[3].starts_with('#') && lines[3].ends_with("--merge"),
        "{jobs}"
    );
    assert!(!Path::new(&out).exists(), "--print-jobs writes nothing");

    run(&["--colon", "seed-1"]);
    let bench = Path::new(&out);
    assert!(bench.join("colons/seed-1/row.json").is_file());
    assert!(!bench.join("benchmark.md").exists());
    let merged = run(&["--merge"]);
    assert!(
        merged.contains("not finished: seed-2, dev-seed-3"),
        "{merged}"
    );
    let md = std::fs::read_to_string(bench.join("benchmark.md")).unwrap();
    assert!(md.contains("Not finished: seed-2, dev-seed-3"), "{md}");

    let all = run(&[]);
    assert!(all.contains("reusing   seed-1"), "{all}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(bench.join("benchmark.json")).unwrap())
            .unwrap();
    assert_eq!(json["colons"].as_array().unwrap().len(), 3);
    assert!(json["missing"].as_array().unwrap().is_empty());
    // The development colon is reported on its own, outside the mean ± interval.
    assert_eq!(json["colons"][2]["colon"], "dev-seed-3");
    assert_eq!(json["colons"][2]["development"], true);
    let md = std::fs::read_to_string(bench.join("benchmark.md")).unwrap();
    assert!(
        md.starts_with("# Benchmark across colons\n\n2 colons (seed-1, seed-2)"),
        "{md}"
    );
    assert!(md.contains("Development colon (settings") && md.contains("| dev-seed-3 |"));
    let live = &json["summary"][0];
    assert_eq!(live["method"], "endoloc-live");
    let pos = &live["median_position_mm"];
    assert_eq!(pos["colons"], 2);
    let per_colon: Vec<f64> = json["colons"]
        .as_array()
        .unwrap()
        .iter()
        .take(2)
        .map(|c| c["methods"][0]["median_position_mm"].as_f64().unwrap())
        .collect();
    let mean = pos["mean"].as_f64().unwrap();
    assert!((mean - 0.5 * (per_colon[0] + per_colon[1])).abs() < 1e-9);
    // Two colons: t(1) = 12.706 times the standard error.
    let se = (per_colon[0] - per_colon[1]).abs() / 2.0;
    assert!((pos["half_width"].as_f64().unwrap() - 12.706 * se).abs() < 1e-6);
    assert!(bench.join("benchmark.png").is_file() && bench.join("report.html").is_file());

    let err = fails(
        &with(&["--colon", "seed-9"])
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(
        err.contains("not a colon of this benchmark") && err.contains("seed-1, seed-2, dev-seed-3"),
        "{err}"
    );
    // A colon's model made earlier is used as it is: asked for views it does not have, the
    // benchmark stops before it writes anything and says how to train it again.
    let settings = std::fs::read(bench.join("benchmark.toml")).unwrap();
    let err = fails(
        &with(&["--colon", "seed-1", "--index-zoom-blur", "0.05"])
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(
        err.contains("has zoom-blurred views []")
            && err.contains("[0.05]")
            && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read(bench.join("benchmark.toml")).unwrap(),
        settings,
        "a refused run leaves the recorded settings as they were"
    );
}

/// `experiment zones` as independent jobs: one command per (count, run) cell from
/// `--print-jobs`, cells run alone into their own folders, a merge that names the unfinished
/// ones, and a table equal to the one the whole sweep writes in one go.
#[test]
fn the_zone_sweep_runs_cell_by_cell_and_merges_to_the_whole_sweeps_table() {
    let tmp = tempfile::tempdir().unwrap();
    let data = s(&tmp.path().join("data"));
    ok(&[
        "simulate",
        "--preset",
        "small",
        "--train-frames",
        "120",
        "--test-frames",
        "30",
        "--width",
        "160",
        "--height",
        "120",
        "--out",
        &data,
    ]);
    let sweep = |out: &str, extra: &[&str]| -> Vec<String> {
        let base = [
            "experiment",
            "zones",
            "--data",
            &data,
            "--from",
            "2",
            "--to",
            "4",
            "--step",
            "2",
            "--runs",
            "1",
            // Each run indexes the pass with the shipped network: the sweep's cells and
            // tables are under test here, training in `train`'s tests.
            "--epochs",
            "0",
            "--pretrained",
            "builtin-joint",
            "--threshold",
            "20",
            "--out",
            out,
        ];
        base.iter().chain(extra).map(|a| a.to_string()).collect()
    };
    let run = |out: &str, extra: &[&str]| -> String {
        let a = sweep(out, extra);
        ok(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let cells = s(&tmp.path().join("cells"));
    let jobs = run(&cells, &["--print-jobs"]);
    let lines: Vec<&str> = jobs.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 3, "{jobs}");
    for (line, cell) in lines.iter().zip(["2:0", "4:0"]) {
        assert!(
            line.starts_with("endoloc experiment zones --data"),
            "{line}"
        );
        assert!(line.ends_with(&format!("--cell {cell}")), "{line}");
    }
    assert!(
        lines[2].starts_with('#') && lines[2].ends_with("--merge"),
        "{jobs}"
    );
    assert!(!Path::new(&cells).exists(), "--print-jobs writes nothing");

    let one = run(&cells, &["--cell", "4:0"]);
    assert!(one.contains("4,0,0,30,"), "the cell's row: {one}");
    let root = Path::new(&cells);
    assert!(root.join("models/z004/run00/row.csv").is_file());
    assert!(
        !root.join("zones.md").exists(),
        "a cell alone writes no table"
    );
    let merged = run(&cells, &["--merge"]);
    assert!(merged.contains("Not finished: 1 cell(s) (2:0)"), "{merged}");
    run(&cells, &["--cell", "2:0"]);
    let merged = run(&cells, &["--merge"]);
    assert!(!merged.contains("Not finished"), "{merged}");

    let whole = s(&tmp.path().join("whole"));
    run(&whole, &[]);
    let without_seconds = |dir: &str| -> Vec<String> {
        std::fs::read_to_string(Path::new(dir).join("results.csv"))
            .unwrap()
            .lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string())
            .collect()
    };
    let table = without_seconds(&cells);
    assert_eq!(table.len(), 3, "{table:?}");
    assert_eq!(table, without_seconds(&whole), "cells vs the whole sweep");

    // Sweeps over disjoint counts may share one folder: its results.csv keeps every cell.
    let halves = s(&tmp.path().join("halves"));
    for count in ["2", "4"] {
        let mut a = sweep(&halves, &[]);
        for flag in ["--from", "--to"] {
            let i = a.iter().position(|x| x == flag).unwrap();
            a[i + 1] = count.to_string();
        }
        ok(&a.iter().map(String::as_str).collect::<Vec<_>>());
    }
    assert_eq!(
        without_seconds(&halves),
        without_seconds(&whole),
        "two sweeps over disjoint counts vs the whole sweep"
    );

    let err = fails(
        &sweep(&cells, &["--cell", "3:0"])
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(
        err.contains("not a cell of this sweep") && err.contains("2, 4"),
        "{err}"
    );
    let err = fails(&[
        "experiment",
        "zones",
        "--data",
        &data,
        "--runs",
        "2",
        "--epochs",
        "0",
        "--pretrained",
        "builtin-joint",
        "--out",
        &s(&tmp.path().join("indexed")),
    ]);
    assert!(err.contains("use --runs 1"), "{err}");
}
