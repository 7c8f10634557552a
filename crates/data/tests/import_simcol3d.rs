//! SimCol3D import: Unity (left-handed, y up, cm) to endoloc (right-handed, OpenCV camera, mm),
//! quaternion sign flips, layout discovery and errors naming the file and line.

use endoloc_data::import::simcol3d::{SimCol3dConfig, pose_from_unity, read_simcol3d};
use endoloc_data::import::{WriteImportConfig, write_import};
use endoloc_data::{DataError, Dataset};
use endoloc_geometry::{Camera, Distortion};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use std::fmt::Write as _;
use std::path::Path;

fn camera() -> Camera {
    Camera {
        width: 8,
        height: 6,
        fx: 4.0,
        fy: 4.0,
        cx: 3.5,
        cy: 2.5,
        distortion: Distortion::None,
    }
}

/// Unity: rotating +90° about y turns the camera's forward (+z) to +x. Unchanged by the flip.
#[test]
fn yawed_camera_looks_along_x() {
    let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 90f64.to_radians());
    let p = pose_from_unity(Vector3::new(1.0, 2.0, 3.0), q, 10.0);
    assert!((p.translation.vector - Vector3::new(10.0, -20.0, 30.0)).norm() < 1e-12);
    let forward = p.rotation * Vector3::z();
    assert!((forward - Vector3::x()).norm() < 1e-12, "{forward}");
    // Unity's up (+y) is −y after the flip; the OpenCV camera's y (down) points along +y.
    let down = p.rotation * Vector3::y();
    assert!((down - Vector3::y()).norm() < 1e-12, "{down}");
    assert!(p.rotation.w >= 0.0);
}

/// Unity: +30° about x pitches the camera down (forward becomes (0, −0.5, 0.866), y up).
/// Converted, it looks towards +y, the converted world's "down".
#[test]
fn pitched_down_camera_looks_down_after_conversion() {
    let q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 30f64.to_radians());
    let p = pose_from_unity(Vector3::zeros(), q, 10.0);
    let forward = p.rotation * Vector3::z();
    let expect = Vector3::new(0.0, 0.5, 3f64.sqrt() / 2.0);
    assert!((forward - expect).norm() < 1e-12, "{forward}");
}

/// A scene point up and to the right of a Unity camera's optical axis must land in the upper
/// right of the converted image (u > cx, v < cy), for an arbitrary pose; and the rotation
/// equals the closed form (qx, qy, qz, qw) → (−qx, qy, −qz, qw).
#[test]
fn points_above_the_axis_project_to_the_upper_image() {
    let cam = camera();
    for k in 0..20 {
        let axis = nalgebra::Unit::new_normalize(Vector3::new(0.3 * k as f64 - 2.0, 1.0, 0.7));
        let q = UnitQuaternion::from_axis_angle(&axis, 0.37 * k as f64);
        let t = Vector3::new(k as f64, -2.0, 0.5 * k as f64);
        // Unity camera-local point: right 0.2, up 0.3, ahead 1.0 (cm).
        let local = Vector3::new(0.2, 0.3, 1.0);
        let world_unity = q * local + t;
        let world = Point3::new(world_unity.x, -world_unity.y, world_unity.z) * 10.0;
        let p = pose_from_unity(t, q, 10.0);
        let p_cam = p.inverse_transform_point(&world);
        assert!(
            (p_cam.coords - Vector3::new(2.0, -3.0, 10.0)).norm() < 1e-9,
            "{p_cam}"
        );
        let px = cam.project(&p_cam).unwrap();
        assert!(px.x > cam.cx && px.y < cam.cy, "{px}");
        let closed =
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, -q.i, q.j, -q.k));
        assert!(endoloc_geometry::so3::geodesic_distance(&p.rotation, &closed) < 1e-9);
    }
}

fn quat_line(q: &UnitQuaternion<f64>, flip: bool) -> String {
    let s = if flip { -1.0 } else { 1.0 };
    format!("{} {} {} {}", s * q.i, s * q.j, s * q.k, s * q.w)
}

fn fixture(colon: &Path, n: usize) -> Vec<(Vector3<f64>, UnitQuaternion<f64>)> {
    let frames = colon.join("Frames_S1");
    std::fs::create_dir_all(&frames).unwrap();
    let mut pos = String::new();
    let mut rot = String::new();
    let mut truth = Vec::new();
    for i in 0..n {
        let t = Vector3::new(0.5 * i as f64, 1.0 - 0.25 * i as f64, 2.0 + i as f64);
        let q = UnitQuaternion::from_euler_angles(0.1 * i as f64, -0.2, 0.05 * i as f64);
        writeln!(pos, "{} {} {}", t.x, t.y, t.z).unwrap();
        // Pitfall: the sign of the quaternion flips between rows.
        writeln!(rot, "{}", quat_line(&q, i % 2 == 1)).unwrap();
        truth.push((t, q));
        let img = image::RgbaImage::from_pixel(8, 6, image::Rgba([20 * i as u8, 1, 2, 255]));
        img.save(frames.join(format!("FrameBuffer_{i:04}.png")))
            .unwrap();
    }
    std::fs::write(colon.join("SavedPosition_S1.txt"), pos).unwrap();
    std::fs::write(colon.join("SavedRotationQuaternion_S1.txt"), rot).unwrap();
    truth
}

fn config() -> SimCol3dConfig {
    SimCol3dConfig {
        camera: camera(),
        fps: 20.0,
        sequence: None,
        depth: true,
        cam_txt: true,
    }
}

#[test]
fn imports_colon_folder_with_converted_poses() {
    let tmp = tempfile::tempdir().unwrap();
    let colon = tmp.path().join("SyntheticColon_I");
    let truth = fixture(&colon, 11);
    // From the colon folder and from its Frames_S1 folder: the same frames and poses.
    let a = read_simcol3d(&colon, &config()).unwrap();
    let b = read_simcol3d(&colon.join("Frames_S1"), &config()).unwrap();
    assert_eq!(a.frames, b.frames);
    let out = tmp.path().join("ds");
    let wc = WriteImportConfig {
        name: "simcol".into(),
        ..Default::default()
    };
    write_import(&out, &[("train".into(), a)], &wc).unwrap();
    let s = Dataset::open(&out).unwrap().sequence("train").unwrap();
    assert_eq!(s.len(), 11);
    for (i, (t, q)) in truth.iter().enumerate() {
        let p = &s.poses[i];
        // Hand-computed: t' = 10 (tx, −ty, tz) mm; q' = (−qx, qy, −qz, qw), sign qw ≥ 0.
        let t_expect = Vector3::new(10.0 * t.x, -10.0 * t.y, 10.0 * t.z);
        assert!(
            (p.pose.translation.vector - t_expect).norm() < 1e-6,
            "frame {i}"
        );
        let mut qe = [-q.i, q.j, -q.k, q.w];
        if qe[3] < 0.0 {
            qe = qe.map(|v| -v);
        }
        let r = p.pose.rotation;
        let got = [r.i, r.j, r.k, r.w];
        for k in 0..4 {
            assert!(
                (got[k] - qe[k]).abs() < 1e-9,
                "frame {i}: {got:?} vs {qe:?}"
            );
        }
        assert!((p.timestamp_s - i as f64 / 20.0).abs() < 1e-9);
        // Natural order: FrameBuffer_0010 is frame 10; RGBA is stored as RGB.
        assert_eq!(s.load_rgb(i).unwrap().get_pixel(1, 1)[0], 20 * i as u8);
    }
}

#[test]
fn several_trajectories_need_a_choice_and_wrong_sizes_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let colon = tmp.path().join("SyntheticColon_II");
    fixture(&colon, 2);
    std::fs::write(colon.join("SavedPosition_S2.txt"), "0 0 0\n").unwrap();
    let e = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(
        e.contains("several trajectories") && e.contains("S1, S2"),
        "{e}"
    );
    let cfg = SimCol3dConfig {
        sequence: Some("S1".into()),
        camera: endoloc_data::import::simcol3d::simcol3d_camera(),
        ..config()
    };
    let seq = read_simcol3d(&colon, &cfg).unwrap();
    let e = write_import(
        &tmp.path().join("ds"),
        &[("t".into(), seq)],
        &WriteImportConfig::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("FrameBuffer_0000.png") && e.contains("8x6") && e.contains("475x475"),
        "{e}"
    );
}

#[test]
fn bad_rows_name_the_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let colon = tmp.path().join("C");
    fixture(&colon, 3);
    let rot = colon.join("SavedRotationQuaternion_S1.txt");
    let pos = colon.join("SavedPosition_S1.txt");
    let good_rot = std::fs::read_to_string(&rot).unwrap();
    let lines: Vec<&str> = good_rot.lines().collect();

    std::fs::write(&rot, format!("{}\n0 0 0 0.5\n{}\n", lines[0], lines[2])).unwrap();
    let e = read_simcol3d(&colon, &config()).unwrap_err();
    let m = e.to_string();
    assert!(matches!(e, DataError::Parse { line: 2, .. }), "{m}");
    assert!(
        m.contains("SavedRotationQuaternion_S1.txt:2") && m.contains("norm 0.5"),
        "{m}"
    );

    std::fs::write(&rot, format!("{}\n{}\n0 0 1\n", lines[0], lines[1])).unwrap();
    let m = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(
        m.contains("SavedRotationQuaternion_S1.txt:3") && m.contains("expected 4 values"),
        "{m}"
    );

    std::fs::write(&rot, &good_rot).unwrap();
    std::fs::write(&pos, "0 0 0\n1 nan 2\n0 0 0\n").unwrap();
    let m = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(
        m.contains("SavedPosition_S1.txt:2") && m.contains("ty"),
        "{m}"
    );

    std::fs::write(&pos, "0 0 0\n1 1 2\n").unwrap();
    let m = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(m.contains("3 quaternions but 2 positions"), "{m}");
}

/// Writes a 16-bit grey `Depth_NNNN.png` (8×6) whose pixel (x, y) is `f(x, y)`.
fn write_depth_png(path: &Path, f: impl Fn(u32, u32) -> u16) {
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(8, 6, |x, y| image::Luma([f(x, y)]))
        .save(path)
        .unwrap();
}

/// The stored 16-bit value of pixel (x, y) of frame i's depth map.
fn depth_value(i: usize, x: u32, y: u32) -> u16 {
    match (x, y) {
        (0, 0) => 0,     // no depth
        (1, 0) => 65280, // 1.0 in the organisers' scale: 20 cm
        (2, 0) => 32640, // 10 cm
        (3, 0) => 65535, // the largest code: 200.78 mm
        _ => 1000 * (i as u16 + 1) + 7 * x as u16 + 3 * y as u16,
    }
}

#[test]
fn depth_maps_are_imported_in_millimetres() {
    let tmp = tempfile::tempdir().unwrap();
    let colon = tmp.path().join("SyntheticColon_I");
    fixture(&colon, 11);
    for i in 0..11 {
        let p = colon.join(format!("Frames_S1/Depth_{i:04}.png"));
        write_depth_png(&p, |x, y| depth_value(i, x, y));
    }
    let seq = read_simcol3d(&colon, &config()).unwrap();
    // Joined by number: Depth_0010 belongs to FrameBuffer_0010 (natural order).
    assert!(
        seq.frames[10]
            .depth
            .as_ref()
            .unwrap()
            .ends_with("Depth_0010.png")
    );
    let out = tmp.path().join("ds");
    let wc = WriteImportConfig {
        name: "simcol".into(),
        ..Default::default()
    };
    let summary = write_import(&out, &[("train".into(), seq)], &wc).unwrap();
    assert_eq!(summary.sequences, vec![("train".to_string(), 11, true)]);
    let s = Dataset::open(&out).unwrap().sequence("train").unwrap();
    for i in [0usize, 3, 10] {
        let (w, h, d) = s.load_depth_mm(i).unwrap();
        assert_eq!((w, h), (8, 6));
        let at = |x: u32, y: u32| d[(y * w + x) as usize] as f64;
        assert_eq!(at(0, 0), 0.0, "frame {i}: 0 stays 'no depth'");
        // The dataset stores round(mm × 100), so values agree to 0.005 mm.
        assert!((at(1, 0) - 200.0).abs() <= 0.006, "{}", at(1, 0));
        assert!((at(2, 0) - 100.0).abs() <= 0.006, "{}", at(2, 0));
        assert!((at(3, 0) - 200.78125).abs() <= 0.006, "{}", at(3, 0));
        for y in 0..h {
            for x in 0..w {
                let v = depth_value(i, x, y) as f64;
                let mm = v * 200.0 / 65280.0;
                assert!((at(x, y) - mm).abs() <= 0.006, "frame {i} ({x},{y})");
            }
        }
    }
}

#[test]
fn depth_on_some_frames_only_is_an_error_unless_depth_is_off() {
    let tmp = tempfile::tempdir().unwrap();
    let colon = tmp.path().join("SyntheticColon_I");
    fixture(&colon, 3);
    for i in [0usize, 2] {
        let p = colon.join(format!("Frames_S1/Depth_{i:04}.png"));
        write_depth_png(&p, |x, y| depth_value(i, x, y));
    }
    let m = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(
        m.contains("FrameBuffer_0001.png")
            && m.contains("Depth_0001.png")
            && m.contains("no depth map"),
        "{m}"
    );
    let cfg = SimCol3dConfig {
        depth: false,
        ..config()
    };
    let seq = read_simcol3d(&colon, &cfg).unwrap();
    assert!(seq.depth_encoding.is_none());
    assert!(seq.frames.iter().all(|f| f.depth.is_none()));

    // A depth map that is not a grey image, or of the wrong size: an error naming the file.
    let p1 = colon.join("Frames_S1/Depth_0001.png");
    image::RgbImage::from_pixel(8, 6, image::Rgb([1, 2, 3]))
        .save(&p1)
        .unwrap();
    let seq = read_simcol3d(&colon, &config()).unwrap();
    let m = write_import(
        &tmp.path().join("a"),
        &[("t".into(), seq)],
        &WriteImportConfig::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        m.contains("Depth_0001.png") && m.contains("one channel"),
        "{m}"
    );
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(5, 5, image::Luma([9]))
        .save(&p1)
        .unwrap();
    let seq = read_simcol3d(&colon, &config()).unwrap();
    let m = write_import(
        &tmp.path().join("b"),
        &[("t".into(), seq)],
        &WriteImportConfig::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(m.contains("Depth_0001.png") && m.contains("5x5"), "{m}");
    // Not a PNG at all.
    std::fs::write(&p1, b"not a png").unwrap();
    let seq = read_simcol3d(&colon, &config()).unwrap();
    let m = write_import(
        &tmp.path().join("c"),
        &[("t".into(), seq)],
        &WriteImportConfig::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(m.contains("Depth_0001.png"), "{m}");
}

/// The published layout keeps every pose line; a copy may keep only every 4th frame
/// (`FrameBuffer_0000.png`, `FrameBuffer_0004.png`, …). Each image takes the pose line of its
/// number, and its time stamp is its number / fps.
#[test]
fn a_subsampled_frames_folder_pairs_images_with_pose_lines_by_number() {
    let tmp = tempfile::tempdir().unwrap();
    let colon = tmp.path().join("SyntheticColon_I");
    let truth = fixture(&colon, 12);
    for i in (0..12).filter(|i| i % 4 != 0) {
        std::fs::remove_file(colon.join(format!("Frames_S1/FrameBuffer_{i:04}.png"))).unwrap();
    }
    let seq = read_simcol3d(&colon, &config()).unwrap();
    assert_eq!(seq.frames.len(), 3);
    for (frame, n) in seq.frames.iter().zip([0usize, 4, 8]) {
        assert!(frame.image.ends_with(format!("FrameBuffer_{n:04}.png")));
        let t = truth[n].0;
        let expect = Vector3::new(10.0 * t.x, -10.0 * t.y, 10.0 * t.z);
        assert!(
            (frame.pose.pose.translation.vector - expect).norm() < 1e-9,
            "frame {n}"
        );
        assert!((frame.pose.timestamp_s - n as f64 / 20.0).abs() < 1e-12);
    }
    assert!(
        seq.notes
            .iter()
            .any(|n| n.contains("3 of 12 pose lines have an image")),
        "{:?}",
        seq.notes
    );

    // An image beyond the pose lines names itself and the pose file.
    let img = image::RgbaImage::from_pixel(8, 6, image::Rgba([0, 0, 0, 255]));
    img.save(colon.join("Frames_S1/FrameBuffer_0012.png"))
        .unwrap();
    let m = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(
        m.contains("SavedPosition_S1.txt")
            && m.contains("FrameBuffer_0012.png is frame 12")
            && m.contains("12 pose lines (frames 0-11)"),
        "{m}"
    );
}

/// `cam.txt` in the colon folder gives the focal length (its first value); the principal
/// point stays the configured one; a malformed file is named with its line.
#[test]
fn cam_txt_gives_the_focal_length_and_bad_ones_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let colon = tmp.path().join("SyntheticColon_I");
    fixture(&colon, 2);
    std::fs::write(colon.join("cam.txt"), "5.5 0 5.5 0 3 3 0 0 1\n").unwrap();
    for src in [colon.clone(), colon.join("Frames_S1")] {
        let seq = read_simcol3d(&src, &config()).unwrap();
        assert_eq!((seq.camera.fx, seq.camera.fy), (5.5, 5.5));
        assert_eq!((seq.camera.cx, seq.camera.cy), (3.5, 2.5));
        assert!(
            seq.notes.iter().any(|n| n.contains("cam.txt")),
            "{:?}",
            seq.notes
        );
    }
    // An explicit camera keeps its own focal length.
    let explicit = SimCol3dConfig {
        cam_txt: false,
        ..config()
    };
    assert_eq!(read_simcol3d(&colon, &explicit).unwrap().camera, camera());

    std::fs::write(colon.join("cam.txt"), "227.6 0 227.6\n").unwrap();
    let m = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(
        m.contains("cam.txt:1") && m.contains("expected 9 values"),
        "{m}"
    );
    std::fs::write(colon.join("cam.txt"), "-1 0 0 0 1 0 0 0 1\n").unwrap();
    let m = read_simcol3d(&colon, &config()).unwrap_err().to_string();
    assert!(m.contains("cam.txt:1") && m.contains("positive"), "{m}");
}

/// The dataset's root folder (`misc/`, `SyntheticColon_I`, …) is refused with the colon
/// folders it holds.
#[test]
fn the_dataset_root_names_its_colon_folders() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("SimCol3D");
    fixture(&root.join("SyntheticColon_I"), 1);
    std::fs::create_dir_all(root.join("SyntheticColon_II")).unwrap();
    std::fs::create_dir_all(root.join("misc")).unwrap();
    let m = read_simcol3d(&root, &config()).unwrap_err().to_string();
    assert!(
        m.contains("SimCol3D dataset folder")
            && m.contains("SyntheticColon_I, SyntheticColon_II")
            && m.contains("`sequence` S1"),
        "{m}"
    );
    // Its colon folder imports.
    assert_eq!(
        read_simcol3d(&root.join("SyntheticColon_I"), &config())
            .unwrap()
            .frames
            .len(),
        1
    );
}
