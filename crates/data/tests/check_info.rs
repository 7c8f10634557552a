//! `check_dataset` finds every problem (with its file and line); `dataset_info` summarizes.

use endoloc_data::{DatasetMeta, DatasetWriter, Section, StampedPose, check_dataset, dataset_info};
use endoloc_geometry::{Camera, Pose};
use nalgebra::{Translation3, UnitQuaternion};
use std::path::Path;

const W: u32 = 16;
const H: u32 = 12;

/// A clean dataset: train (5 frames, depth, sections) and test (3 frames, grey).
fn make(dir: &Path) {
    let meta = DatasetMeta::new("check-test", Camera::from_hfov(W, H, 90.0));
    let w = DatasetWriter::create(dir, &meta, false).unwrap();
    let pose = |i: usize| StampedPose {
        timestamp_s: i as f64 * 0.5,
        pose: Pose::from_parts(
            Translation3::new(3.0 * i as f64, 4.0 * i as f64, 0.0),
            UnitQuaternion::identity(),
        ),
    };
    let train = w.sequence("train").unwrap();
    for f in 0..5 {
        train
            .write_rgb(f, W, H, &vec![f as u8; (W * H * 3) as usize])
            .unwrap();
        train
            .write_depth(f, W, H, &vec![10.0; (W * H) as usize])
            .unwrap();
    }
    let sections = [
        Section::AnalCanal,
        Section::Rectum,
        Section::Rectum,
        Section::Rectum,
        Section::Sigmoid,
    ];
    train
        .finish(&(0..5).map(pose).collect::<Vec<_>>(), Some(&sections))
        .unwrap();
    let test = w.sequence("test").unwrap();
    for f in 0..3 {
        test.write_gray(f, W, H, &vec![7; (W * H) as usize])
            .unwrap();
    }
    test.finish(&(0..3).map(pose).collect::<Vec<_>>(), None)
        .unwrap();
    w.finish().unwrap();
}

#[test]
fn clean_dataset_passes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    make(&dir);
    let r = check_dataset(&dir).unwrap();
    assert!(r.is_ok(), "{r}");
    assert_eq!(r.frames_checked, 8);
    assert_eq!(r.files_decoded, 5 + 5 + 3);
    assert_eq!(r.sequences, vec!["test", "train"]);
    assert!(r.to_string().ends_with("OK"), "{r}");
}

#[test]
fn every_problem_is_reported_with_its_file() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    make(&dir);
    let train = dir.join("train");
    let test = dir.join("test");
    // A missing image in test, a wrong-size image and a corrupt PNG in train.
    std::fs::remove_file(test.join("images/000001.png")).unwrap();
    image::RgbImage::new(W + 2, H)
        .save(train.join("images/000002.png"))
        .unwrap();
    let good = std::fs::read(train.join("images/000003.png")).unwrap();
    std::fs::write(train.join("images/000003.png"), &good[..good.len() / 2]).unwrap();
    // A bad pose line (line 3: the header comment is line 1) and a time going backwards.
    let poses = std::fs::read_to_string(train.join("poses.txt")).unwrap();
    let mut lines: Vec<String> = poses.lines().map(str::to_string).collect();
    lines[2] = "0.5 3 4 0 0 0 0".to_string();
    lines[5] = lines[5].replacen("2.000000", "0.100000", 1);
    std::fs::write(train.join("poses.txt"), lines.join("\n") + "\n").unwrap();
    // A bad label on line 4 of sections.csv, and a missing depth map.
    let s = std::fs::read_to_string(train.join("sections.csv")).unwrap();
    std::fs::write(train.join("sections.csv"), s.replace("2,rectum", "2,colon")).unwrap();
    std::fs::remove_file(train.join("depth/000004.png")).unwrap();
    // A wrong units value.
    let m = std::fs::read_to_string(dir.join("dataset.toml")).unwrap();
    std::fs::write(
        dir.join("dataset.toml"),
        m.replace("units = \"mm\"", "units = \"m\""),
    )
    .unwrap();

    let r = check_dataset(&dir).unwrap();
    assert!(!r.is_ok());
    let text = r.to_string();
    let has = |path_end: &str, line: Option<usize>, words: &[&str]| {
        let found = r.problems.iter().any(|p| {
            p.path.ends_with(path_end)
                && p.line == line
                && words.iter().all(|w| p.message.contains(w))
        });
        assert!(
            found,
            "no problem for {path_end}:{line:?} with {words:?} in:\n{text}"
        );
    };
    has("test/images", None, &["2 images but 3 poses"]);
    has(
        "train/images/000002.png",
        None,
        &["18x12", "expected the camera's size 16x12"],
    );
    has("train/images/000003.png", None, &["cannot decode"]);
    has("train/poses.txt", Some(3), &["expected 8 columns"]);
    has(
        "train/poses.txt",
        Some(6),
        &["expected increasing timestamps"],
    );
    has("train/sections.csv", Some(4), &["\"colon\""]);
    has("train/depth", None, &["4 depth maps but 5 poses"]);
    let units_line = m.lines().position(|l| l.starts_with("units")).unwrap() + 1;
    has("dataset.toml", Some(units_line), &["expected \"mm\""]);
    assert_eq!(r.problems.len(), 8, "{text}");
    // Display: `path:line: message` and a summary.
    assert!(
        text.contains("train/poses.txt:3: expected 8 columns"),
        "{text}"
    );
    assert!(text.ends_with("8 problems"), "{text}");
}

#[test]
fn unreadable_metadata_is_the_only_hard_error() {
    let tmp = tempfile::tempdir().unwrap();
    assert!(check_dataset(tmp.path()).is_err());
    std::fs::write(
        tmp.path().join("dataset.toml"),
        "name = \"x\"\nformat_version = \n",
    )
    .unwrap();
    let r = check_dataset(tmp.path()).unwrap();
    let text = r.to_string();
    assert!(r.problems.iter().any(|p| p.line == Some(2)), "{text}");
    assert!(text.contains("no sequence found"), "{text}");
}

#[test]
fn info_summarizes_sequences() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    make(&dir);
    let info = dataset_info(&dir).unwrap();
    assert_eq!(info.sequences.len(), 2);
    let train = &info.sequences[1];
    assert_eq!(train.name, "train");
    assert_eq!(train.frames, 5);
    assert!((train.duration_s - 2.0).abs() < 1e-9);
    assert!(
        (train.path_length_mm - 20.0).abs() < 1e-9,
        "4 steps of 5 mm"
    );
    assert!((train.mean_speed_mm_s - 10.0).abs() < 1e-9);
    assert_eq!(
        train.sections,
        vec![
            (Section::AnalCanal, 1),
            (Section::Rectum, 3),
            (Section::Sigmoid, 1)
        ]
    );
    assert!(train.has_depth && !info.sequences[0].has_depth);
    assert_eq!(train.pixel_type.as_deref(), Some("RGB 8-bit"));
    assert_eq!(info.sequences[0].pixel_type.as_deref(), Some("grey 8-bit"));
    let text = info.to_string();
    for want in [
        "check-test",
        "16x12 px",
        "fov 90.0°",
        "rectum",
        "train",
        "20.0",
    ] {
        assert!(text.contains(want), "{want:?} missing in:\n{text}");
    }
    println!("{text}");
}
