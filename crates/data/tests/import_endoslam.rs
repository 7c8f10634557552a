//! EndoSLAM import: UnityCam CSV poses paired by row (Unity → OpenCV, explicit units),
//! ex-vivo pose sheets joined on ImageFrame, and errors naming the file and line.

use endoloc_data::import::endoslam::{EndoSlamConfig, Units, read_endoslam};
use endoloc_data::import::{WriteImportConfig, write_import};
use endoloc_data::{DataError, Dataset};
use endoloc_geometry::{Camera, Distortion};
use nalgebra::{UnitQuaternion, Vector3};
use std::fmt::Write as _;
use std::path::Path;

fn camera() -> Camera {
    Camera {
        width: 8,
        height: 6,
        fx: 5.0,
        fy: 5.0,
        cx: 3.5,
        cy: 2.5,
        distortion: Distortion::None,
    }
}

fn write_frame(path: &Path, value: u8) {
    image::GrayImage::from_pixel(8, 6, image::Luma([value]))
        .save(path)
        .unwrap();
}

fn truth(i: usize) -> (Vector3<f64>, UnitQuaternion<f64>) {
    (
        Vector3::new(0.01 * i as f64, -0.02, 0.003 * i as f64 + 0.1),
        UnitQuaternion::from_euler_angles(0.2, 0.1 * i as f64, -0.3),
    )
}

/// UnityCam: `Frames/` and `Poses/*.csv`, metres.
fn unity_fixture(src: &Path, n: usize) {
    std::fs::create_dir_all(src.join("Frames")).unwrap();
    std::fs::create_dir_all(src.join("Poses")).unwrap();
    let mut csv = String::from("tX,tY,tZ,rX,rY,rZ,rW,time(s)\n");
    for i in 0..n {
        let (t, q) = truth(i);
        let s = if i % 3 == 0 { -1.0 } else { 1.0 }; // sign flips between rows
        writeln!(
            csv,
            "{},{},{},{},{},{},{},{}",
            t.x,
            t.y,
            t.z,
            s * q.i,
            s * q.j,
            s * q.k,
            s * q.w,
            0.04 * i as f64
        )
        .unwrap();
        write_frame(&src.join(format!("Frames/image_{i}.png")), 10 * i as u8);
    }
    std::fs::write(src.join("Poses/colon_pose.csv"), csv).unwrap();
}

#[test]
fn unitycam_poses_pair_by_row_and_convert_from_unity() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("UnityCam_Colon");
    unity_fixture(&src, 12);
    let seq = read_endoslam(&src, &EndoSlamConfig::new(camera(), Units::M)).unwrap();
    let out = tmp.path().join("ds");
    let wc = WriteImportConfig {
        name: "endoslam".into(),
        ..Default::default()
    };
    write_import(&out, &[("train".into(), seq)], &wc).unwrap();
    let s = Dataset::open(&out).unwrap().sequence("train").unwrap();
    assert_eq!(s.len(), 12);
    for i in 0..12 {
        let (t, q) = truth(i);
        let p = &s.poses[i];
        // Hand-computed: t' = 1000 (tx, −ty, tz) mm; q' = ±(−qx, qy, −qz, qw) with qw ≥ 0.
        let te = Vector3::new(1000.0 * t.x, -1000.0 * t.y, 1000.0 * t.z);
        assert!((p.pose.translation.vector - te).norm() < 1e-6, "frame {i}");
        let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
        let qe = [-q.i, q.j, -q.k, q.w].map(|v| sign * v);
        let r = p.pose.rotation;
        let got = [r.i, r.j, r.k, r.w];
        for k in 0..4 {
            assert!(
                (got[k] - qe[k]).abs() < 1e-9,
                "frame {i}: {got:?} vs {qe:?}"
            );
        }
        assert!((p.timestamp_s - 0.04 * i as f64).abs() < 1e-9);
        // image_10 is frame 10 (natural order).
        assert_eq!(s.load_gray(i).unwrap().get_pixel(0, 0)[0], 10 * i as u8);
    }
}

#[test]
fn unitycam_errors_name_the_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("u");
    unity_fixture(&src, 3);
    let csv = src.join("Poses/colon_pose.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let cfg = EndoSlamConfig::new(camera(), Units::Cm);

    std::fs::write(&csv, format!("{}\n{}\n{}\n", lines[0], lines[1], lines[2])).unwrap();
    let m = read_endoslam(&src, &cfg).unwrap_err().to_string();
    assert!(
        m.contains("colon_pose.csv") && m.contains("2 pose rows but 3 images"),
        "{m}"
    );

    std::fs::write(
        &csv,
        format!(
            "{}\n{}\n{}\n0,0,0,0,0,0,2,1\n",
            lines[0], lines[1], lines[2]
        ),
    )
    .unwrap();
    let e = read_endoslam(&src, &cfg).unwrap_err();
    let m = e.to_string();
    assert!(matches!(e, DataError::Parse { line: 4, .. }), "{m}");
    assert!(
        m.contains("colon_pose.csv:4") && m.contains("norm 2"),
        "{m}"
    );

    std::fs::write(
        &csv,
        format!("{}\n{}\n0,0\n{}\n", lines[0], lines[1], lines[3]),
    )
    .unwrap();
    let m = read_endoslam(&src, &cfg).unwrap_err().to_string();
    assert!(
        m.contains("colon_pose.csv:3") && m.contains("2 columns; expected 8"),
        "{m}"
    );

    std::fs::write(
        &csv,
        format!(
            "{}\n{}\nNaN,{}\n{}\n",
            lines[0],
            lines[1],
            lines[2].split_once(',').unwrap().1,
            lines[3]
        ),
    )
    .unwrap();
    let m = read_endoslam(&src, &cfg).unwrap_err().to_string();
    assert!(
        m.contains("colon_pose.csv:3") && m.contains("(tx)") && m.contains("not finite"),
        "{m}"
    );

    std::fs::write(&csv, "tX,tY,tZ,rX,rY,rZ,time(s)\n").unwrap();
    let m = read_endoslam(&src, &cfg).unwrap_err().to_string();
    assert!(
        m.contains("colon_pose.csv:1") && m.contains("\"rw\""),
        "{m}"
    );
}

#[test]
fn ex_vivo_poses_join_on_image_frame_with_the_given_units() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("ExVivo_Colon");
    std::fs::create_dir_all(src.join("Frames")).unwrap();
    for i in 0..5 {
        write_frame(&src.join(format!("Frames/{i:04}.png")), 30 * i as u8);
    }
    // Rows out of order; frames 0 and 4 have no pose; units cm.
    let mut csv = String::from(
        "ImageFrame, Pose_Index, trans_x, trans_y, trans_z, quot_x, quot_y, quot_z, quot_w\n",
    );
    for (row, i) in [3usize, 1, 2].into_iter().enumerate() {
        let (t, q) = truth(i);
        writeln!(
            csv,
            "{i},{row},{},{},{},{},{},{},{}",
            t.x, t.y, t.z, q.i, q.j, q.k, q.w
        )
        .unwrap();
    }
    let poses = tmp.path().join("poses.csv");
    std::fs::write(&poses, &csv).unwrap();
    let cfg = EndoSlamConfig {
        poses: Some(poses.clone()),
        fps: 10.0,
        ..EndoSlamConfig::new(camera(), Units::Cm)
    };
    let seq = read_endoslam(&src, &cfg).unwrap();
    assert_eq!(seq.frames.len(), 3);
    assert!(
        seq.notes
            .iter()
            .any(|n| n.contains("2 frames without a pose")),
        "{:?}",
        seq.notes
    );
    for (k, f) in seq.frames.iter().enumerate() {
        let i = k + 1;
        assert!(f.image.ends_with(format!("{i:04}.png")));
        let (t, q) = truth(i);
        assert!(
            (f.pose.pose.translation.vector - 10.0 * t).norm() < 1e-9,
            "frame {i}"
        );
        assert!(
            endoloc_geometry::so3::geodesic_distance(&f.pose.pose.rotation, &q) < 1e-9,
            "frame {i}"
        );
        assert!((f.pose.timestamp_s - i as f64 / 10.0).abs() < 1e-12);
    }

    // Duplicate ImageFrame: named by file and line.
    std::fs::write(&poses, format!("{csv}2,9,0,0,0,0,0,0,1\n")).unwrap();
    let m = read_endoslam(&src, &cfg).unwrap_err().to_string();
    assert!(m.contains("poses.csv:5") && m.contains("line 4"), "{m}");

    // A broken .xlsx: an error naming it (without the `xlsx` feature: told to export CSV).
    let xlsx = tmp.path().join("poses.xlsx");
    std::fs::write(&xlsx, b"PK").unwrap();
    let m = read_endoslam(
        &src,
        &EndoSlamConfig {
            poses: Some(xlsx),
            ..cfg.clone()
        },
    )
    .unwrap_err()
    .to_string();
    let expected = if cfg!(feature = "xlsx") {
        "cannot read the .xlsx workbook"
    } else {
        "export the sheet to CSV"
    };
    assert!(m.contains("poses.xlsx") && m.contains(expected), "{m}");
}

/// The ex-vivo recordings as published:
/// `Cameras/HighCam/Colon-IV/TumorfreeTrajectory_1/Frames/frame_000001.jpg`, … and one pose
/// sheet in `Poses/` whose `ImageFrame` is the number in the frame's name (here its CSV
/// export, columns as in the workbook). Given the trajectory folder alone, the importer finds
/// both, pairs by number, and writes a dataset.
#[test]
fn the_published_ex_vivo_layout_imports_from_the_trajectory_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp
        .path()
        .join("Cameras/HighCam/Colon-IV/TumorfreeTrajectory_1");
    std::fs::create_dir_all(src.join("Frames")).unwrap();
    std::fs::create_dir_all(src.join("Poses")).unwrap();
    std::fs::create_dir_all(tmp.path().join("Cameras/HighCam/Calibration")).unwrap();
    for i in 1..=6 {
        image::RgbImage::from_pixel(8, 6, image::Rgb([40 * i as u8, 0, 0]))
            .save(src.join(format!("Frames/frame_{i:06}.jpg")))
            .unwrap();
    }
    let mut csv =
        String::from("ImageFrame,Pose_Index,trans_x,trans_y,trans_z,quot_x,quot_y,quot_z,quot_w\n");
    for i in 1..=6 {
        let (t, q) = truth(i);
        writeln!(
            csv,
            "{i},{},{},{},{},{},{},{},{}",
            i - 1,
            t.x,
            t.y,
            t.z,
            q.i,
            q.j,
            q.k,
            q.w
        )
        .unwrap();
    }
    std::fs::write(
        src.join("Poses/low_high_pose_colon_test_1_high_images.csv"),
        csv,
    )
    .unwrap();
    let cfg = EndoSlamConfig {
        fps: 20.0,
        ..EndoSlamConfig::new(camera(), Units::M)
    };
    let seq = read_endoslam(&src, &cfg).unwrap();
    assert_eq!(seq.frames.len(), 6);
    assert!(seq.notes.is_empty(), "{:?}", seq.notes);
    for (k, f) in seq.frames.iter().enumerate() {
        let i = k + 1;
        assert!(f.image.ends_with(format!("frame_{i:06}.jpg")));
        let (t, _) = truth(i);
        assert!(
            (f.pose.pose.translation.vector - 1000.0 * t).norm() < 1e-9,
            "frame {i}"
        );
        assert!((f.pose.timestamp_s - i as f64 / 20.0).abs() < 1e-12);
    }
    let out = tmp.path().join("ds");
    write_import(
        &out,
        &[("train".into(), seq)],
        &WriteImportConfig::default(),
    )
    .unwrap();
    let s = Dataset::open(&out).unwrap().sequence("train").unwrap();
    assert_eq!(s.len(), 6);
    // JPEG frames are written as PNG, in frame order.
    let red: Vec<u8> = (0..6)
        .map(|i| s.load_rgb(i).unwrap().get_pixel(4, 3)[0])
        .collect();
    assert!(red.windows(2).all(|w| w[0] < w[1]), "{red:?}");
}
