//! Dataset v1: write → open round trip, overwrite protection, count checks.

use endoloc_data::{DataError, Dataset, DatasetMeta, DatasetWriter, Section, StampedPose};
use endoloc_geometry::{Camera, Distortion, Pose};
use nalgebra::{Translation3, UnitQuaternion};
use rayon::prelude::*;
use std::path::Path;

const W: u32 = 32;
const H: u32 = 24;

fn meta() -> DatasetMeta {
    let mut camera = Camera::from_hfov(W, H, 100.0);
    camera.distortion = Distortion::RadialTangential {
        k1: -0.1,
        k2: 0.01,
        p1: 0.0,
        p2: 0.001,
        k3: 0.0,
    };
    let mut m = DatasetMeta::new("unit-test", camera);
    m.source.insert("tool".into(), "endoloc-data tests".into());
    let mut sim = toml::Table::new();
    sim.insert("seed".into(), 42.into());
    m.simulation = Some(sim);
    m
}

fn pose(i: usize) -> StampedPose {
    StampedPose {
        timestamp_s: i as f64 / 30.0,
        pose: Pose::from_parts(
            Translation3::new(i as f64, 2.0 * i as f64, -0.5),
            UnitQuaternion::from_euler_angles(0.1 * i as f64, -0.2, 0.3),
        ),
    }
}

fn rgb(frame: usize) -> Vec<u8> {
    (0..W * H * 3)
        .map(|k| ((k as usize * 7 + frame * 31) % 256) as u8)
        .collect()
}

fn depth(frame: usize) -> Vec<f32> {
    (0..W * H)
        .map(|k| match k {
            0 => f32::NAN,
            1 => -3.0,
            2 => 700.0,
            _ => 5.0 + (k as f32) * 0.123 + frame as f32,
        })
        .collect()
}

fn write_dataset(dir: &Path, overwrite: bool, frames: usize) -> Result<(), DataError> {
    let w = DatasetWriter::create(dir, &meta(), overwrite)?;
    let seq = w.sequence("train")?;
    (0..frames).into_par_iter().try_for_each(|f| {
        seq.write_rgb(f, W, H, &rgb(f))?;
        seq.write_depth(f, W, H, &depth(f))
    })?;
    let poses: Vec<_> = (0..frames).map(pose).collect();
    let sections = [Section::Rectum, Section::Rectosigmoid, Section::Sigmoid];
    seq.finish(&poses, Some(&sections[..frames.min(3)]))?;
    w.finish()?;
    Ok(())
}

#[test]
fn write_then_open_gives_the_same_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write_dataset(&dir, false, 3).unwrap();
    // Nothing but the dataset is left in the parent (no staging folder).
    let names: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec!["ds"]);

    let ds = Dataset::open(&dir).unwrap();
    assert_eq!(ds.meta.name, "unit-test");
    assert_eq!(ds.meta.camera, meta().camera);
    assert_eq!(ds.meta.simulation, meta().simulation);
    assert_eq!(ds.sequences, vec!["train".to_string()]);
    let text = std::fs::read_to_string(dir.join("dataset.toml")).unwrap();
    assert!(text.contains("model = \"pinhole\""), "{text}");

    let seq = ds.sequence("train").unwrap();
    assert_eq!(seq.len(), 3);
    for i in 0..3 {
        let p = pose(i);
        let q = seq.poses[i];
        assert!((p.timestamp_s - q.timestamp_s).abs() < 1e-6);
        assert!((p.pose.translation.vector - q.pose.translation.vector).amax() < 1e-9);
        assert!(
            endoloc_geometry::so3::geodesic_distance(&p.pose.rotation, &q.pose.rotation) < 1e-9
        );
        assert_eq!(seq.load_rgb(i).unwrap().into_raw(), rgb(i));
        let (w, h, d) = seq.load_depth_mm(i).unwrap();
        assert_eq!((w, h), (W, H));
        let truth = depth(i);
        assert_eq!(&d[..3], &[0.0, 0.0, 0.0], "invalid depths must read as 0");
        for (a, b) in d.iter().zip(&truth).skip(3) {
            assert!((a - b).abs() <= 0.01, "depth {a} vs {b}");
        }
        let g = seq.load_gray(i).unwrap();
        assert_eq!(g.dimensions(), (W, H));
    }
    assert_eq!(
        seq.sections.as_deref(),
        Some(&[Section::Rectum, Section::Rectosigmoid, Section::Sigmoid][..])
    );
    assert!(seq.load_rgb(3).is_err());
    assert!(ds.sequence("test").is_err());
}

#[test]
fn existing_dataset_is_kept_unless_overwrite() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("precious.txt"), "keep me").unwrap();
    let err = DatasetWriter::create(&dir, &meta(), false).unwrap_err();
    assert!(matches!(err, DataError::AlreadyExists { .. }), "{err:?}");
    assert_eq!(
        std::fs::read_to_string(dir.join("precious.txt")).unwrap(),
        "keep me"
    );
    // With overwrite, the old folder stays until finish() succeeds…
    let w = DatasetWriter::create(&dir, &meta(), true).unwrap();
    assert!(dir.join("precious.txt").exists());
    let seq = w.sequence("train").unwrap();
    seq.write_rgb(0, W, H, &rgb(0)).unwrap();
    seq.finish(&[pose(0)], None).unwrap();
    w.finish().unwrap();
    // …and is replaced then.
    assert!(!dir.join("precious.txt").exists());
    assert_eq!(
        Dataset::open(&dir)
            .unwrap()
            .sequence("train")
            .unwrap()
            .len(),
        1
    );
    let names: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().collect();
    assert_eq!(names.len(), 1, "old or staging folder left behind");
}

#[test]
fn frame_count_mismatch_fails_and_leaves_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    let w = DatasetWriter::create(&dir, &meta(), false).unwrap();
    let seq = w.sequence("train").unwrap();
    for f in 0..3 {
        seq.write_gray(f, W, H, &vec![f as u8; (W * H) as usize])
            .unwrap();
    }
    let poses: Vec<_> = (0..4).map(pose).collect();
    let msg = seq.finish(&poses, None).unwrap_err().to_string();
    assert!(msg.contains("3 images written but 4 poses"), "{msg}");
    // The dataset cannot be finished with an unfinished sequence, and nothing appears.
    let msg = w.finish().unwrap_err().to_string();
    assert!(msg.contains("train"), "{msg}");
    assert!(!dir.exists());
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn gaps_wrong_sizes_and_bad_sections_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    let w = DatasetWriter::create(&dir, &meta(), false).unwrap();
    let seq = w.sequence("a").unwrap();
    let img = vec![0u8; (W * H) as usize];
    let msg = seq.write_gray(0, W + 1, H, &img).unwrap_err().to_string();
    assert!(msg.contains("expected the camera's size 32x24"), "{msg}");
    let msg = seq.write_gray(0, W, H, &img[1..]).unwrap_err().to_string();
    assert!(msg.contains("expected 32x24x1"), "{msg}");
    seq.write_gray(0, W, H, &img).unwrap();
    seq.write_gray(2, W, H, &img).unwrap();
    let msg = seq
        .finish(&[pose(0), pose(1)], None)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("frame 1 has no image"), "{msg}");

    let seq = w.sequence("b").unwrap();
    seq.write_gray(0, W, H, &img).unwrap();
    seq.write_gray(1, W, H, &img).unwrap();
    let msg = seq
        .finish(&[pose(0), pose(1)], Some(&[Section::Caecum]))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("1 section labels for 2 frames"), "{msg}");
    assert!(w.sequence("b").is_err(), "duplicate sequence name");
    assert!(w.sequence("../x").is_err(), "path-like sequence name");
}

#[test]
fn bad_metadata_is_refused_at_create() {
    let tmp = tempfile::tempdir().unwrap();
    let mut m = meta();
    m.units = "m".into();
    let msg = DatasetWriter::create(&tmp.path().join("x"), &m, false)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("expected \"mm\""), "{msg}");
    let mut m = meta();
    m.camera.fx = -1.0;
    assert!(DatasetWriter::create(&tmp.path().join("x"), &m, false).is_err());
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn sequence_writer_is_sync() {
    fn assert_sync<T: Sync + Send>() {}
    assert_sync::<endoloc_data::SequenceWriter>();
    assert_sync::<DatasetWriter>();
}

#[test]
fn abandoned_writer_leaves_nothing_behind() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    {
        let w = DatasetWriter::create(&dir, &meta(), false).unwrap();
        let seq = w.sequence("train").unwrap();
        seq.write_rgb(0, W, H, &rgb(0)).unwrap();
        // Dropped without finish (an error or a panic on the way).
    }
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn bad_dataset_toml_names_the_line() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write_dataset(&dir, false, 1).unwrap();
    let toml_path = dir.join("dataset.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    let model_line = text.lines().position(|l| l.starts_with("model")).unwrap() + 1;
    std::fs::write(&toml_path, text.replace("\"pinhole\"", "\"omni\"")).unwrap();
    match Dataset::open(&dir).unwrap_err() {
        DataError::Parse { line, message, .. } => {
            // The error points into the [camera] table.
            assert!(line > 0 && line <= model_line + 1, "line {line}: {message}");
            assert!(message.contains("expected \"pinhole\""), "{message}");
        }
        other => panic!("{other:?}"),
    }
    std::fs::write(
        &toml_path,
        text.replace("format_version = 1", "format_version = 2"),
    )
    .unwrap();
    let msg = Dataset::open(&dir).unwrap_err().to_string();
    assert!(msg.contains("format_version = 2; expected 1"), "{msg}");
}
