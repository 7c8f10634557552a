//! The evaluation streams its inputs: read from files line by line it gives exactly what it
//! gives in memory, its statistics equal the sorted-array ones, a pass longer than the plot
//! limit is plotted thinned, and rows out of frame order are refused with the line.

use std::path::Path;

use endoloc_data::{StampedPose, read_tum, write_tum};
use endoloc_eval::align::AlignmentKind;
use endoloc_eval::association::AssociationConfig;
use endoloc_eval::rpe::RpeConfig;
use endoloc_eval::{
    Cdf, EvalConfig, EvalFiles, EvalInputs, FrameRecord, PLOT_FRAMES, PlotConfig, Statistics,
    WriteOptions, ZoneLabel, evaluate, evaluate_files, read_frames_csv, read_zones_csv,
    write_frames_csv, write_results,
};
use endoloc_geometry::{Pose, Status};
use nalgebra::{Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A pass of `n` frames: every 9th frame without a pose, every 11th with two estimated poses
/// near its time stamp (both associate when the estimate is the shorter file), statuses and
/// zones (`zones` equal runs, one in 13 predicted one zone off).
fn write_pass(dir: &Path, n: usize, zones: usize, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut gt, mut est, mut rows) = (vec![], vec![], vec![]);
    let mut z = String::from("frame,zone\n");
    for k in 0..n {
        let s = k as f64 / n as f64;
        let t = Vector3::new(60.0 * (5.0 * s).sin(), 500.0 * s, 20.0 * (3.0 * s).cos());
        let r = UnitQuaternion::from_euler_angles(-1.5, 0.2 * s, 4.0 * s);
        let ts = k as f64 / 30.0;
        gt.push(StampedPose {
            timestamp_s: ts,
            pose: Pose::from_parts(Translation3::from(t), r),
        });
        let zone = k * zones / n;
        z.push_str(&format!("{k},{zone}\n"));
        let status = match k % 9 {
            0 => Status::Rejected,
            4 => Status::InitOnly,
            _ => Status::Refined,
        };
        let mut noisy = |dt: f64| StampedPose {
            timestamp_s: ts + dt,
            pose: Pose::from_parts(
                Translation3::from(t + Vector3::from_fn(|_, _| rng.random_range(-2.0..2.0))),
                r * UnitQuaternion::from_scaled_axis(Vector3::from_fn(|_, _| {
                    rng.random_range(-0.03..0.03)
                })),
            ),
        };
        if status != Status::Rejected {
            est.push(noisy(-0.004));
            if k % 11 == 0 {
                est.push(noisy(0.004));
            }
        }
        rows.push(FrameRecord {
            frame: k,
            zone: (status != Status::Rejected).then_some(zone + usize::from(k % 13 == 0)),
            zone_score: Some(0.5),
            status,
            reason: String::new(),
            source: "refined".into(),
            inliers: Some(30),
            reprojection_rms_px: Some(1.0),
            position_std_mm: None,
            orientation_std_deg: None,
            time_ms: 10.0,
        });
    }
    write_tum(&dir.join("gt.txt"), &gt).unwrap();
    write_tum(&dir.join("est.txt"), &est).unwrap();
    write_frames_csv(&dir.join("frames.csv"), &rows).unwrap();
    std::fs::write(dir.join("zones.csv"), z).unwrap();
}

fn files(dir: &Path) -> EvalFiles {
    EvalFiles {
        gt: dir.join("gt.txt"),
        est: dir.join("est.txt"),
        frames: Some(dir.join("frames.csv")),
        gt_zones: Some(dir.join("zones.csv")),
        scratch_dir: Some(dir.to_path_buf()),
        midline: None,
    }
}

#[test]
fn files_read_line_by_line_give_exactly_the_in_memory_evaluation() {
    let dir = tempfile::tempdir().unwrap();
    write_pass(dir.path(), 600, 12, 1);
    let gt = read_tum(&dir.path().join("gt.txt")).unwrap();
    let est = read_tum(&dir.path().join("est.txt")).unwrap();
    let rows = read_frames_csv(&dir.path().join("frames.csv")).unwrap();
    let zones: Vec<ZoneLabel> = read_zones_csv(&dir.path().join("zones.csv")).unwrap();
    for (alignment, all_pairs, max_diff_s) in [
        (AlignmentKind::None, false, 0.01),
        (AlignmentKind::Sim3, true, 0.01),
        (AlignmentKind::Se3, false, 0.005),
    ] {
        let config = EvalConfig {
            association: AssociationConfig {
                max_diff_s,
                offset_s: 0.0,
            },
            alignment,
            rpe: RpeConfig {
                delta_frames: 3,
                all_pairs,
            },
        };
        let memory = evaluate(
            &EvalInputs {
                gt: &gt,
                est: &est,
                frames: Some(&rows),
                gt_zones: Some(&zones),
                midline: None,
            },
            &config,
        )
        .unwrap();
        let streamed = evaluate_files(&files(dir.path()), &config).unwrap();
        assert_eq!(streamed.metrics, memory.metrics, "{alignment:?}");
        assert_eq!(streamed.frames().unwrap(), memory.frames().unwrap());
        assert_eq!(streamed.plots, memory.plots);
        let m = &memory.metrics;
        // The estimate is the shorter file: each of its poses is a pair (evo's rule), so
        // frames with two nearby estimates count twice in the APE and once as localized.
        assert_eq!(m.localized, 600 - 600usize.div_ceil(9));
        assert_eq!(m.association.matched, est.len());
        assert_eq!(m.position_mm.count, est.len());
        assert!(est.len() > m.localized);
        assert_eq!(m.per_zone.len(), 12);
        // Per-zone medians are those of the sorted per-frame errors.
        let frames = memory.frames().unwrap();
        for row in &m.per_zone {
            let errors: Vec<f64> = frames
                .iter()
                .filter(|f| f.gt_zone == Some(row.zone))
                .filter_map(|f| f.orientation_deg)
                .collect();
            assert_eq!(
                row.orientation_deg_median,
                Some(Statistics::from_errors(&errors, "r").unwrap().median)
            );
        }
    }
    // Nothing is left behind by the temporary records.
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["est.txt", "frames.csv", "gt.txt", "zones.csv"]);
}

#[test]
fn the_shorter_estimate_pairs_each_of_its_poses_and_counts_every_pair() {
    let dir = tempfile::tempdir().unwrap();
    write_pass(dir.path(), 200, 4, 2);
    // Keep every 3rd estimated pose: now the estimate is the shorter file and is walked.
    let est = read_tum(&dir.path().join("est.txt")).unwrap();
    let kept: Vec<StampedPose> = est.iter().step_by(3).copied().collect();
    write_tum(&dir.path().join("est.txt"), &kept).unwrap();
    let e = evaluate_files(&files(dir.path()), &EvalConfig::default()).unwrap();
    assert_eq!(e.metrics.association.matched, kept.len());
    assert_eq!(e.metrics.position_mm.count, kept.len());
    assert_eq!(e.metrics.association.unmatched_est, 0);
}

#[test]
fn a_pass_longer_than_the_plot_limit_is_plotted_thinned() {
    let dir = tempfile::tempdir().unwrap();
    let n = PLOT_FRAMES + 5_000;
    write_pass(dir.path(), n, 50, 3);
    let e = evaluate_files(&files(dir.path()), &EvalConfig::default()).unwrap();
    let p = &e.plots;
    assert_eq!((p.frames, p.stride), (n, 2));
    assert_eq!(p.track.len(), n.div_ceil(2));
    assert!(p.along_position.len() <= 2 * n.div_ceil(2));
    assert!(p.along_position.windows(2).all(|w| w[0].0 < w[1].0));
    let Cdf::Histogram { max, counts } = &p.cdf_position else {
        panic!("expected a histogram for a thinned pass");
    };
    assert_eq!(counts.iter().sum::<u64>() as usize, e.metrics.localized);
    assert_eq!(*max, e.metrics.position_mm.max);
    // The largest error of the pass is among the points drawn.
    assert!(p.along_position.iter().any(|q| q.1 == *max));
    let out = dir.path().join("eval");
    let w = write_results(
        &e,
        &out,
        &WriteOptions {
            plot: PlotConfig {
                text: Some(false),
                ..Default::default()
            },
            ..Default::default()
        },
    )
    .unwrap();
    assert!(w.files.iter().all(|f| f.is_file()));
    let csv = std::fs::read_to_string(out.join("errors.csv")).unwrap();
    assert_eq!(csv.lines().count(), n + 1);
}

#[test]
fn rows_out_of_frame_order_are_refused_with_their_line() {
    let dir = tempfile::tempdir().unwrap();
    write_pass(dir.path(), 30, 3, 4);
    let p = dir.path().join("frames.csv");
    let mut lines: Vec<String> = std::fs::read_to_string(&p)
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    lines.swap(5, 6);
    std::fs::write(&p, lines.join("\n")).unwrap();
    let e = evaluate_files(&files(dir.path()), &EvalConfig::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("frames.csv:7:")
            && e.contains("frame 4 after frame 5")
            && e.contains("in frame order"),
        "{e}"
    );
}
