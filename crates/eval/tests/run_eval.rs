//! End-to-end evaluation of a synthetic run: metrics.json fields, zone accuracy, outputs,
//! the no-overwrite rule and plots.

use std::path::Path;

use endoloc_data::{StampedPose, write_tum};
use endoloc_eval::{
    EvalConfig, EvalInputs, FrameRecord, Sources, WriteOptions, ZoneLabel, evaluate,
    read_frames_csv, write_frames_csv, write_results,
};
use endoloc_geometry::{Pose, Status};
use nalgebra::{Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

struct Run {
    gt: Vec<StampedPose>,
    est: Vec<StampedPose>,
    frames: Vec<FrameRecord>,
    zones: Vec<ZoneLabel>,
}

/// 120 frames along an S-curve in the coronal plane; every 10 frames a zone. Frames ≡ 7 mod
/// 20 are rejected (no pose), ≡ 3 mod 10 init_only (larger error), one in 12 has the wrong
/// zone (off by one).
fn synthetic_run() -> Run {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let n = 120;
    let mut run = Run {
        gt: vec![],
        est: vec![],
        frames: vec![],
        zones: vec![],
    };
    for k in 0..n {
        let s = k as f64 / n as f64;
        let t = Vector3::new(80.0 * (3.0 * s).sin(), 400.0 * s, 10.0 * s);
        let r = UnitQuaternion::from_euler_angles(-1.5, 0.0, 3.0 * s);
        let gt = Pose::from_parts(Translation3::from(t), r);
        let ts = k as f64 / 30.0;
        run.gt.push(StampedPose {
            timestamp_s: ts,
            pose: gt,
        });
        let zone = k / 10;
        run.zones.push(ZoneLabel { frame: k, zone });
        let status = if k % 20 == 7 {
            Status::Rejected
        } else if k % 10 == 3 {
            Status::InitOnly
        } else {
            Status::Refined
        };
        let scale: f64 = if status == Status::InitOnly { 8.0 } else { 1.5 };
        if status != Status::Rejected {
            let dt = Vector3::from_fn(|_, _| noise.sample(&mut rng) * scale);
            let dr = UnitQuaternion::from_scaled_axis(Vector3::from_fn(|_, _| {
                noise.sample(&mut rng) * scale.to_radians()
            }));
            run.est.push(StampedPose {
                timestamp_s: ts + rng.random_range(-0.002..0.002),
                pose: Pose::from_parts(Translation3::from(t + dt), r * dr),
            });
        }
        let predicted = if k % 12 == 5 { zone + 1 } else { zone };
        run.frames.push(FrameRecord {
            frame: k,
            zone: Some(predicted),
            zone_score: Some(0.9),
            status,
            reason: match status {
                Status::Refined => String::new(),
                Status::InitOnly => "too_few_inliers".into(),
                Status::Rejected => "jump_too_large".into(),
            },
            inliers: Some(50),
            reprojection_rms_px: Some(0.7),
            source: "refined".into(),
            position_std_mm: None,
            orientation_std_deg: None,
            time_ms: 30.0,
        });
    }
    run
}

#[test]
fn metrics_have_the_design_fields_and_sensible_values() {
    let run = synthetic_run();
    let e = evaluate(
        &EvalInputs {
            gt: &run.gt,
            est: &run.est,
            frames: Some(&run.frames),
            gt_zones: Some(&run.zones),
            midline: None,
        },
        &EvalConfig::default(),
    )
    .unwrap();
    let m = &e.metrics;
    assert_eq!(m.frames, 120);
    assert_eq!(m.localized, 114); // 6 rejected frames have no pose
    assert!((m.localized_fraction - 114.0 / 120.0).abs() < 1e-12);
    let c = m.status_counts.unwrap();
    assert_eq!(
        (c.refined, c.init_only, c.rejected, c.without_row),
        (102, 12, 6, 0)
    );
    // 10 of 120 frames (k ≡ 5 mod 12) predicted one zone off.
    assert!((m.zone_accuracy.unwrap() - 110.0 / 120.0).abs() < 1e-12);
    assert_eq!(m.zone_within_one, Some(1.0));
    // Refined frames: 3-D noise σ 1.5 mm → median ≈ 1.5·1.54 ≈ 2.3 mm; init_only much worse.
    let refined = m.by_status["refined"].position_mm.median;
    let init = m.by_status["init_only"].position_mm.median;
    assert!((1.5..3.2).contains(&refined), "{refined}");
    assert!(init > 3.0 * refined, "{init} vs {refined}");
    assert_eq!(m.per_zone.len(), 12);
    assert_eq!(m.per_zone.iter().map(|z| z.frames).sum::<usize>(), 120);
    let rpe = m.rpe.unwrap();
    assert_eq!(rpe.translation_mm.count, 113);

    let json: serde_json::Value = serde_json::to_value(m).unwrap();
    for stat in ["position_mm", "orientation_deg"] {
        for key in ["mean", "median", "rmse", "p90", "max", "min", "std"] {
            assert!(json[stat][key].is_f64(), "{stat}.{key} missing: {json}");
        }
    }
    for key in [
        "frames",
        "localized_fraction",
        "zone_accuracy",
        "status_counts",
        "rpe",
    ] {
        assert!(!json[key].is_null(), "{key} missing");
    }
}

#[test]
fn frames_csv_written_by_the_localizer_is_read_back() {
    let run = synthetic_run();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("frames.csv");
    write_frames_csv(&p, &run.frames).unwrap();
    assert_eq!(read_frames_csv(&p).unwrap(), run.frames);
}

fn write_inputs(dir: &Path, run: &Run) {
    write_tum(&dir.join("poses.txt"), &run.gt).unwrap();
    write_tum(&dir.join("trajectory.txt"), &run.est).unwrap();
}

#[test]
fn outputs_are_written_once_and_plots_render_with_and_without_text() {
    let run = synthetic_run();
    let dir = tempfile::tempdir().unwrap();
    write_inputs(dir.path(), &run);
    let e = evaluate(
        &EvalInputs {
            gt: &run.gt,
            est: &run.est,
            frames: Some(&run.frames),
            gt_zones: None,
            midline: None,
        },
        &EvalConfig::default(),
    )
    .unwrap();
    let out = dir.path().join("eval");
    let mut opts = WriteOptions {
        sources: Sources {
            gt: "poses.txt".into(),
            est: "trajectory.txt".into(),
            ..Default::default()
        },
        ..Default::default()
    };
    opts.plot.width_px = 500;
    opts.plot.height_px = 400;
    let w = write_results(&e, &out, &opts).unwrap();
    assert_eq!(w.files.len(), 6);
    for f in &w.files {
        assert!(std::fs::metadata(f).unwrap().len() > 100, "{}", f.display());
    }
    let png = std::fs::read(out.join("trajectory_xy.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("](trajectory_xy.png)") && report.contains("| position (mm) |"));
    assert!(report.contains("predicted zone"));

    // A second run into the same folder is refused and leaves the files untouched.
    let before = std::fs::read(out.join("metrics.json")).unwrap();
    let err = write_results(&e, &out, &opts).unwrap_err().to_string();
    assert!(
        err.contains("already exists") && err.contains("`force`"),
        "{err}"
    );
    assert_eq!(std::fs::read(out.join("metrics.json")).unwrap(), before);
    // With force and no font (text off), it is replaced and still renders.
    opts.force = true;
    opts.plot.text = Some(false);
    let w = write_results(&e, &out, &opts).unwrap();
    assert!(!w.plot_text);
    // No temporary files are left behind.
    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|d| d.ok())
        .filter(|d| d.file_name().to_string_lossy().starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}
