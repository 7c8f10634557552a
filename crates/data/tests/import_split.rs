//! Splitting one imported recording into train/test by frame ranges.

use endoloc_data::Dataset;
use endoloc_data::import::c3vd::{C3vdConfig, read_c3vd};
use endoloc_data::import::split::{SplitPart, parse_split, split_sequence};
use endoloc_data::import::{WriteImportConfig, write_import};
use endoloc_geometry::{Camera, Distortion};
use std::fmt::Write as _;

#[test]
fn parses_named_ranges() {
    let p = parse_split("train:0..1500, test:1500..").unwrap();
    assert_eq!(
        p,
        vec![
            SplitPart {
                name: "train".into(),
                start: 0,
                end: Some(1500)
            },
            SplitPart {
                name: "test".into(),
                start: 1500,
                end: None
            },
        ]
    );
    for (bad, needle) in [
        ("train", "expected NAME:START..END"),
        ("train:5..5", "empty range"),
        ("tr ain:0..3", "must be letters"),
        ("train:0..3,train:3..", "appears twice"),
        ("train:a..3", "not a frame number"),
        ("", "empty split"),
    ] {
        let e = parse_split(bad).unwrap_err();
        assert!(e.contains(needle), "{bad}: {e}");
    }
}

#[test]
fn splits_a_recording_into_train_and_test() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("rec");
    std::fs::create_dir_all(&src).unwrap();
    let mut poses = String::new();
    for i in 0..10 {
        // Identity rotation, translation (i, 0, 0) mm at values 13-15.
        writeln!(poses, "1,0,0,0,0,1,0,0,0,0,1,0,{i},0,0,1").unwrap();
        image::RgbImage::from_pixel(8, 6, image::Rgb([i as u8, 0, 0]))
            .save(src.join(format!("{i}_color.png")))
            .unwrap();
    }
    std::fs::write(src.join("pose.txt"), poses).unwrap();
    let cfg = C3vdConfig {
        camera: Camera {
            width: 8,
            height: 6,
            fx: 5.0,
            fy: 5.0,
            cx: 3.5,
            cy: 2.5,
            distortion: Distortion::None,
        },
        fps: 1.0,
        depth: true,
    };
    let seq = read_c3vd(&src, &cfg).unwrap();

    let e = split_sequence(&seq, &parse_split("train:0..6,test:5..").unwrap()).unwrap_err();
    assert!(e.to_string().contains("overlap"), "{e}");
    let e = split_sequence(&seq, &parse_split("train:0..11").unwrap()).unwrap_err();
    assert!(
        e.to_string().contains("outside the recording's 10 frames"),
        "{e}"
    );

    let parts = split_sequence(&seq, &parse_split("train:0..7,test:7..").unwrap()).unwrap();
    let out = tmp.path().join("ds");
    write_import(
        &out,
        &parts,
        &WriteImportConfig {
            name: "split".into(),
            ..Default::default()
        },
    )
    .unwrap();
    let ds = Dataset::open(&out).unwrap();
    assert_eq!(ds.sequences, vec!["test".to_string(), "train".to_string()]);
    let train = ds.sequence("train").unwrap();
    let test = ds.sequence("test").unwrap();
    assert_eq!((train.len(), test.len()), (7, 3));
    for (k, p) in test.poses.iter().enumerate() {
        let i = 7 + k;
        assert!((p.pose.translation.vector.x - i as f64).abs() < 1e-9);
        assert!((p.timestamp_s - i as f64).abs() < 1e-9, "time stamps kept");
        assert_eq!(test.load_rgb(k).unwrap().get_pixel(0, 0)[0], i as u8);
    }
}
