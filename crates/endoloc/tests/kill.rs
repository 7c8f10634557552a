//! Kill-safety: `simulate`, `train`, `map`, `localize`, `eval`, `view` and an experiment are
//! killed with SIGKILL at random moments. Afterwards no output folder is half-written, a result that a
//! `--force` run was replacing is intact, and `train --resume` and the experiment's resume
//! finish with the same figures as an uninterrupted run.
//!
//! The moments are drawn from a seeded generator (`ENDOLOC_KILL_SEED`, default 0, printed) as
//! fractions of each command's uninterrupted wall time, so a failure can be replayed.

#![cfg(unix)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn endoloc() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_endoloc"));
    cmd.arg("-q").stdout(Stdio::null()).stderr(Stdio::piped());
    cmd
}

/// Runs to the end; returns the wall time.
fn run_ok(args: &[String]) -> Duration {
    let t = Instant::now();
    let out = endoloc().args(args).output().expect("run endoloc");
    assert!(
        out.status.success(),
        "endoloc {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    t.elapsed()
}

/// Starts the command and kills it (SIGKILL) after `delay`; true when it was killed before it
/// finished.
fn kill_after(args: &[String], delay: Duration) -> bool {
    let mut child = endoloc()
        .args(args)
        .stderr(Stdio::null())
        .spawn()
        .expect("start endoloc");
    let deadline = Instant::now() + delay;
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            assert!(status.success(), "endoloc {args:?} failed before the kill");
            return false;
        }
        if Instant::now() >= deadline {
            child.kill().expect("SIGKILL");
            child.wait().expect("reap");
            return true;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// SplitMix64: the kill moments.
struct Moments(u64);

impl Moments {
    fn from_env() -> Self {
        let seed = std::env::var("ENDOLOC_KILL_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        eprintln!("kill moments from ENDOLOC_KILL_SEED={seed}");
        Moments(seed)
    }

    /// A moment in 5–95 % of `full`.
    fn within(&mut self, full: Duration) -> Duration {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        let u = (z >> 11) as f64 / (1u64 << 53) as f64;
        full.mul_f64(0.05 + 0.9 * u)
    }
}

/// Every file under `dir` (relative path → bytes), without the hidden files a write killed
/// half-way leaves (`.NAME.tmp-PID-N`, `.NAME.staging-PID-N`, the earlier map's
/// `.map.*.prev`): never a visible file.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if name.starts_with('.')
                && (name.contains(".tmp-") || name.contains(".staging-") || name.ends_with(".prev"))
            {
                continue;
            }
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.insert(
                    p.strip_prefix(root).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// Asserts that `dir` holds exactly `expected` (names and bytes).
fn assert_same(dir: &Path, expected: &BTreeMap<PathBuf, Vec<u8>>, what: &str) {
    let found = snapshot(dir);
    let names = |m: &BTreeMap<PathBuf, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&found), names(expected), "{what}: files differ");
    for (name, bytes) in expected {
        assert!(found[name] == *bytes, "{what}: {} changed", name.display());
    }
}

/// A snapshot of localization results with `frames.csv`'s last column (the per-frame time,
/// which differs from run to run) cut off.
fn without_times(files: &BTreeMap<PathBuf, Vec<u8>>) -> BTreeMap<PathBuf, Vec<u8>> {
    files
        .iter()
        .map(|(name, bytes)| {
            let bytes = if name.ends_with("frames.csv") {
                String::from_utf8_lossy(bytes)
                    .lines()
                    .map(|l| l.rsplit_once(',').map_or(l, |(head, _)| head))
                    .collect::<Vec<_>>()
                    .join("\n")
                    .into_bytes()
            } else {
                bytes.clone()
            };
            (name.clone(), bytes)
        })
        .collect()
}

/// The visible entries of `dir`: what a user sees (hidden staging folders excluded).
fn visible(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    names.sort();
    names
}

/// A CSV's rows without the columns named in `skip` (wall times differ between runs).
fn csv_without(path: &Path, skip: &[&str]) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !skip.contains(&header[i]))
        .collect();
    let mut rows = vec![keep.iter().map(|&i| header[i].to_string()).collect()];
    for l in lines {
        let cols: Vec<&str> = l.split(',').collect();
        rows.push(keep.iter().map(|&i| cols[i].to_string()).collect());
    }
    rows
}

fn args(list: &[&str]) -> Vec<String> {
    list.iter().map(|s| s.to_string()).collect()
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

#[test]
fn killed_runs_leave_no_half_written_output_and_resume_to_the_same_figures() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let mut moments = Moments::from_env();
    let data = root.join("data");
    let sim = |out: &Path, force: bool| {
        let mut a = args(&[
            "simulate",
            "--preset",
            "small",
            "--train-frames",
            "60",
            "--test-frames",
            "24",
            "--width",
            "160",
            "--height",
            "120",
            "--out",
        ]);
        a.push(s(out));
        if force {
            a.push("--force".into());
        }
        a
    };

    // simulate: a --force run that is killed leaves the earlier dataset as it was; a killed
    // run into a new folder leaves no folder (or, had it finished, the whole dataset).
    let full = run_ok(&sim(&data, false));
    let dataset = snapshot(&data);
    for _ in 0..3 {
        kill_after(&sim(&data, true), moments.within(full));
        assert_same(&data, &dataset, "dataset after a killed simulate --force");
        // No folder, or (a run that finished, or was killed between publishing its dataset
        // and exiting) the whole dataset.
        let fresh = root.join("fresh");
        kill_after(&sim(&fresh, false), moments.within(full));
        if fresh.exists() {
            assert_same(
                &fresh,
                &dataset,
                "a simulate killed after publishing or finished",
            );
            std::fs::remove_dir_all(&fresh).unwrap();
        }
    }
    assert_eq!(visible(root), ["data"], "stray output folders");

    // train: three epochs with a checkpoint after each.
    let config = root.join("train.toml");
    std::fs::write(&config, "checkpoint_every_epochs = 1\n").unwrap();
    let train = |out: &Path, extra: &[&str]| {
        let mut a = args(&[
            "train",
            "--data",
            &s(&data),
            "--zones",
            "4",
            "--epochs",
            "3",
        ]);
        // A small network input keeps the epochs short; kills still land inside them.
        a.extend(args(&[
            "--input",
            "80x60",
            "--config",
            &s(&config),
            "--out",
            &s(out),
        ]));
        a.extend(args(extra));
        a
    };
    let model = root.join("model");
    let full = run_ok(&train(&model, &[]));
    let trained = snapshot(&model);
    if kill_after(&train(&model, &["--force"]), moments.within(full)) {
        assert_same(&model, &trained, "model after a killed train --force");
    }
    // An interrupted run into a new folder continues with --resume to the same model.
    let resumed = root.join("resumed");
    let staging = root.join("resumed.partial");
    // A run killed between publishing its model and exiting has nothing to resume; the
    // comparison below checks that model.
    if kill_after(&train(&resumed, &[]), moments.within(full)) && !resumed.exists() {
        let state = staging.join("checkpoint/state.json");
        eprintln!(
            "train killed; {}",
            if state.is_file() {
                "resuming from its checkpoint"
            } else {
                "no checkpoint yet: starting over"
            }
        );
        let a = if staging.exists() {
            train(&resumed, &["--resume"])
        } else {
            train(&resumed, &[])
        };
        run_ok(&a);
    }
    assert!(!staging.exists(), "the staging folder outlived the run");
    // The database holds every training frame's descriptor from the final weights: equal
    // bytes mean an equal network (the safetensors header's key order is not fixed).
    for file in ["database.bin", "zones.csv", "model.toml"] {
        assert!(
            std::fs::read(resumed.join(file)).unwrap() == std::fs::read(model.join(file)).unwrap(),
            "{file} of the resumed run differs from the uninterrupted run's"
        );
    }
    assert_eq!(
        csv_without(&resumed.join("history.csv"), &["elapsed_s"]),
        csv_without(&model.join("history.csv"), &["elapsed_s"]),
        "the resumed run's losses differ"
    );

    // map: a killed rebuild leaves a map that loads (the earlier one or a whole new one).
    let map = |force: bool| {
        let mut a = args(&["map", "--model", &s(&model), "--data", &s(&data)]);
        a.extend(args(&["--threshold", "20"]));
        if force {
            a.push("--force".into());
        }
        a
    };
    let full = run_ok(&map(false));
    let mapped = snapshot(&model);
    for _ in 0..3 {
        // The map is deterministic: a rebuild that finished leaves the same bytes too.
        kill_after(&map(true), moments.within(full));
        assert_same(&model, &mapped, "model after a killed map --force");
    }

    // localize: a killed --force run leaves the earlier results.
    let run = root.join("run");
    let localize = |force: bool| {
        let mut a = args(&["localize", "--model", &s(&model), "--seq"]);
        a.extend([s(&data.join("test")), "--out".into(), s(&run)]);
        if force {
            a.push("--force".into());
        }
        a
    };
    let full = run_ok(&localize(false));
    let mut results = snapshot(&run);
    for _ in 0..3 {
        if kill_after(&localize(true), moments.within(full)) {
            // The earlier results; or, when the kill came after the run had published its own
            // and before it exited, the complete new ones (equal but for the per-frame times).
            let found = snapshot(&run);
            if found != results {
                assert_eq!(
                    without_times(&found),
                    without_times(&results),
                    "results after a killed localize --force: neither the earlier ones nor a \
                     complete new set"
                );
                results = found;
            }
        } else {
            // Finished before the kill (its per-frame times differ): the new reference.
            results = snapshot(&run);
        }
    }

    // eval and view: a killed --force run leaves the earlier report and page.
    let eval = |force: bool| {
        let mut a = args(&["eval", "--gt", &s(&data.join("test/poses.txt"))]);
        a.extend([
            "--est".into(),
            s(&run.join("trajectory.txt")),
            "--out".into(),
            s(&run.join("eval")),
        ]);
        if force {
            a.push("--force".into());
        }
        a
    };
    let view = |force: bool| {
        let mut a = args(&["view", &s(&run), "--out", &s(&run.join("view.html"))]);
        if force {
            a.push("--force".into());
        }
        a
    };
    for command in [&eval as &dyn Fn(bool) -> Vec<String>, &view] {
        let full = run_ok(&command(false));
        let mut results = snapshot(&run);
        for _ in 0..3 {
            if kill_after(&command(true), moments.within(full)) {
                assert_same(&run, &results, "results after a killed eval/view --force");
            } else {
                results = snapshot(&run);
            }
        }
    }

    // An experiment killed half-way and started again finishes with the same table.
    let sweep = |out: &Path| {
        let mut a = args(&["experiment", "zones", "--data", &s(&data)]);
        a.extend(args(&[
            "--from", "2", "--to", "4", "--step", "2", "--runs", "1",
        ]));
        // Indexed with the shipped weights: the cells and the resume are what is tested.
        a.extend(args(&["--epochs", "0", "--pretrained", "builtin"]));
        a.extend(args(&["--out", &s(out)]));
        a
    };
    let whole = root.join("sweep");
    let full = run_ok(&sweep(&whole));
    let again = root.join("sweep-resumed");
    kill_after(&sweep(&again), moments.within(full));
    run_ok(&sweep(&again));
    assert_eq!(
        csv_without(&again.join("results.csv"), &["seconds"]),
        csv_without(&whole.join("results.csv"), &["seconds"]),
        "the resumed sweep's table differs"
    );
}
