//! The localizer on a colon that changes between the passes (docs/SIMULATOR.md, "A colon that
//! changes between the passes"). Three datasets from one seed share their training pass
//! (changes touch the test pass only), so one model and map serve them all: the test pass
//! through the unchanged colon, through a colon whose mobile segments moved by 15 mm, and
//! behind foam on the lens in every frame.

use std::path::{Path, PathBuf};

use endoloc_jobs::{ClassifyJob, LocalizeJob, MapJob, Silent, SimulateJob, TrainJob};
use endoloc_net::ZoneSpec;
use endoloc_sim::change::ChangeConfig;

/// As `endoloc demo` indexes the small preset.
const ZONES: usize = 50;

/// Simulates the `small` preset (300 + 150 frames at 160×120) with `changes` into `out`.
fn simulate(out: &Path, changes: ChangeConfig) -> PathBuf {
    let base = SimulateJob {
        train_frames: Some(300),
        test_frames: Some(150),
        width: Some(160),
        height: Some(120),
        depth: Some(false),
        ..SimulateJob::default()
    };
    let mut cfg = base.sim_config().unwrap();
    cfg.changes = ChangeConfig {
        seed: cfg.changes.seed,
        ..changes
    };
    let file = out.with_extension("toml");
    std::fs::write(&file, cfg.to_toml().unwrap()).unwrap();
    SimulateJob {
        config: Some(file),
        out: out.to_path_buf(),
        ..SimulateJob::default()
    }
    .run(&Silent)
    .unwrap();
    out.to_path_buf()
}

/// The status column of a localize run's frames.csv.
fn statuses(run: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(run.join("frames.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "status").unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().to_string())
        .collect()
}

fn localize(model: &Path, data: &Path, out: &Path, live: bool) -> Vec<String> {
    LocalizeJob {
        model: Some(model.to_path_buf()),
        seq: data.join("test"),
        out: out.to_path_buf(),
        live,
        ..LocalizeJob::default()
    }
    .run(&Silent)
    .unwrap();
    statuses(out)
}

fn refined(statuses: &[String]) -> usize {
    statuses.iter().filter(|s| *s == "refined").count()
}

#[test]
fn a_changed_test_pass_is_placed_by_the_unchanged_map_or_flagged() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let none = simulate(&root.join("none"), ChangeConfig::default());
    let mut shift = ChangeConfig::default();
    shift.shape.shift_mm = 15.0;
    let shifted = simulate(&root.join("shifted"), shift);
    let mut foam = ChangeConfig::default();
    foam.look.bubble_frames = 1.0;
    foam.look.bubble_cover = 1.0;
    let foam = simulate(&root.join("foam"), foam);
    for data in [&shifted, &foam] {
        assert_eq!(
            std::fs::read(data.join("train/poses.txt")).unwrap(),
            std::fs::read(none.join("train/poses.txt")).unwrap(),
            "a change touches the test pass only"
        );
    }

    let model = root.join("model");
    TrainJob {
        data: none.clone(),
        zones: ZoneSpec::Uniform(ZONES),
        epochs: Some(0),
        pretrained: Some("builtin-joint".into()),
        out: model.clone(),
        ..TrainJob::default()
    }
    .run(&Silent)
    .unwrap();
    MapJob {
        model: model.clone(),
        data: none.clone(),
        threshold: 20.0,
        ..MapJob::default()
    }
    .run(&Silent)
    .unwrap();

    // The shifted pass: its anatomical poses (poses.txt) are where the frames are in the
    // map's colon; the camera really moved with the colon (poses_changed.txt).
    let read = |p: PathBuf| endoloc_data::read_tum(&p).unwrap();
    let (anatomical, moved) = (
        read(shifted.join("test/poses.txt")),
        read(shifted.join("test/poses_changed.txt")),
    );
    let largest = anatomical
        .iter()
        .zip(&moved)
        .map(|(a, m)| (a.pose.translation.vector - m.pose.translation.vector).norm())
        .fold(0.0, f64::max);
    assert!(
        largest > 10.0,
        "the shift moves the camera: {largest:.1} mm"
    );
    // Each frame goes to the zone of its anatomical pose (or the next one) as often as in the
    // unchanged pass, with the tracking filter of live localization (the raw per-frame choice
    // loses a few frames to the shift; the track keeps them).
    let classify = |data: &Path| {
        let report = ClassifyJob {
            model: model.clone(),
            seq: data.join("test"),
            ..ClassifyJob::default()
        }
        .run(&Silent)
        .unwrap();
        eprintln!("{}: {:?}", data.display(), report.accuracy);
        let track = report.accuracy.iter().find(|(name, _)| *name == "track");
        track.expect("the track filter's accuracy").1
    };
    let (unchanged, moved) = (classify(&none), classify(&shifted));
    assert!(
        moved.within_one * 10 >= moved.frames * 9 && moved.within_one + 3 >= unchanged.within_one,
        "shifted pass: {moved:?}, unchanged: {unchanged:?}"
    );

    // Behind foam on the lens nothing on the wall is where the map has it: no frame is
    // refined, live or per frame, where a quarter of the unchanged pass's frames are.
    for live in [false, true] {
        let clear = localize(&model, &none, &root.join(format!("none-{live}")), live);
        assert!(
            refined(&clear) * 4 >= clear.len(),
            "unchanged pass, live {live}: {clear:?}"
        );
        let behind = localize(&model, &foam, &root.join(format!("foam-{live}")), live);
        assert_eq!(refined(&behind), 0, "foam, live {live}: {behind:?}");
    }
}
