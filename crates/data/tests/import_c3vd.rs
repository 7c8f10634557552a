//! C3VD import: column-major `pose.txt`, images paired with pose lines by frame number
//! (subsampled recordings), 16-bit TIFF depth with clipped values as no depth, fisheye camera
//! and undistortion, and errors that name the file and line.

use endoloc_data::import::c3vd::{C3vdConfig, read_c3vd, read_c3vd_poses};
use endoloc_data::import::{WriteImportConfig, write_import};
use endoloc_data::{DataError, Dataset};
use endoloc_geometry::{Camera, Distortion, Pose, orientation_error_deg};
use nalgebra::{Matrix4, Translation3, UnitQuaternion, Vector2, Vector3};
use std::fmt::Write as _;
use std::path::Path;

const W: u32 = 8;
const H: u32 = 6;

fn camera(distortion: Distortion) -> Camera {
    Camera {
        width: W,
        height: H,
        fx: 6.0,
        fy: 6.5,
        cx: 3.4,
        cy: 2.6,
        distortion,
    }
}

fn truth(i: usize) -> Pose {
    let axis = nalgebra::Unit::new_normalize(Vector3::new(1.0, -2.0, 0.5 + i as f64));
    Pose::from_parts(
        Translation3::new(i as f64, 2.0 * i as f64 - 7.0, 3.0 * i as f64 + 0.5),
        UnitQuaternion::from_axis_angle(&axis, 0.3 * i as f64 - 1.0),
    )
}

/// The 16 values of a C3VD line: the 4×4 matrix column by column.
fn c3vd_line(p: &Pose) -> String {
    let m: Matrix4<f64> = p.to_homogeneous();
    let vals: Vec<String> = m.iter().map(|v| format!("{v:.12}")).collect(); // column-major
    vals.join(",")
}

fn write_rgb(path: &Path, value: u8) {
    let img = image::RgbImage::from_fn(W, H, |x, y| image::Rgb([value, x as u8, y as u8]));
    img.save(path).unwrap();
}

fn write_depth_tiff(path: &Path, value: u16) {
    let img =
        image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(W, H, image::Luma([value]));
    img.save(path).unwrap();
}

/// A C3VD folder with `n` frames (`{i}_color.png`, value 10·i), poses `truth(i)` and,
/// optionally, depth `{i:04}_depth.tiff` of value 1000·(i+1).
fn fixture(dir: &Path, n: usize, depth: bool) {
    std::fs::create_dir_all(dir).unwrap();
    let mut text = String::new();
    for i in 0..n {
        writeln!(text, "{}", c3vd_line(&truth(i))).unwrap();
        write_rgb(&dir.join(format!("{i}_color.png")), 10 * i as u8);
        if depth {
            write_depth_tiff(
                &dir.join(format!("{i:04}_depth.tiff")),
                1000 * (i as u16 + 1),
            );
        }
    }
    std::fs::write(dir.join("pose.txt"), text).unwrap();
}

fn config() -> C3vdConfig {
    C3vdConfig {
        camera: camera(Distortion::None),
        fps: 10.0,
        depth: true,
    }
}

#[test]
fn poses_are_column_major_camera_to_world_mm() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("pose.txt");
    // Hand-written: rotation 90° about z (x_cam → world y), translation (10, 20, 30) mm at values 13–15.
    std::fs::write(&p, "0,1,0,0,-1,0,0,0,0,0,1,0,10,20,30,1\n").unwrap();
    let poses = read_c3vd_poses(&p).unwrap();
    assert_eq!(poses.len(), 1);
    let t = poses[0].translation.vector;
    assert!((t - Vector3::new(10.0, 20.0, 30.0)).norm() < 1e-12, "{t}");
    // The camera's x axis (first column of R_wc) points along world +y.
    let x_axis = poses[0].rotation * Vector3::x();
    assert!((x_axis - Vector3::y()).norm() < 1e-12, "{x_axis}");
    assert!(poses[0].rotation.w >= 0.0);
}

#[test]
fn imports_frames_in_natural_order_with_poses_and_depth() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("cecum_t1_a");
    fixture(&src, 12, true);
    let seq = read_c3vd(&src, &config()).unwrap();
    assert_eq!(seq.frames.len(), 12);
    assert!(seq.frames[10].image.ends_with("10_color.png"));
    assert!(
        seq.frames[10]
            .depth
            .as_ref()
            .unwrap()
            .ends_with("0010_depth.tiff")
    );

    let out = tmp.path().join("ds");
    let wc = WriteImportConfig {
        name: "c3vd".into(),
        ..Default::default()
    };
    write_import(&out, &[("train".to_string(), seq)], &wc).unwrap();
    let ds = Dataset::open(&out).unwrap();
    let s = ds.sequence("train").unwrap();
    assert_eq!(s.len(), 12);
    for i in 0..12 {
        let p = &s.poses[i];
        assert!((p.timestamp_s - i as f64 / 10.0).abs() < 1e-9);
        let dt = (p.pose.translation.vector - truth(i).translation.vector).norm();
        assert!(dt < 1e-6, "frame {i}: {dt} mm");
        assert!(
            orientation_error_deg(&p.pose, &truth(i)) < 1e-6,
            "frame {i}"
        );
        // Natural order: frame 10 is 10_color.png (value 100), not 2_color.png.
        assert_eq!(s.load_rgb(i).unwrap().get_pixel(0, 0)[0], 10 * i as u8);
        // Depth: v / 65535 × 100 mm.
        let (_, _, d) = s.load_depth_mm(i).unwrap();
        let expect = 1000.0 * (i as f64 + 1.0) / 65535.0 * 100.0;
        assert!(
            (d[5] as f64 - expect).abs() < 0.006,
            "frame {i}: {} vs {expect}",
            d[5]
        );
    }
    // Never overwrite without asking.
    let seq = read_c3vd(&src, &config()).unwrap();
    let e = write_import(&out, &[("train".to_string(), seq)], &wc).unwrap_err();
    assert!(matches!(e, DataError::AlreadyExists { .. }), "{e}");
}

#[test]
fn pose_file_errors_name_the_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("pose.txt");
    let good = c3vd_line(&truth(1));
    let cases: [(String, &str); 4] = [
        (
            format!("{good}\n1,2,3\n"),
            "expected 16 comma-separated values",
        ),
        (
            format!("{good}\nNaN,{}\n", good.split_once(',').unwrap().1),
            "value 1: NaN is not finite",
        ),
        // Row-major storage (translation at 4, 8, 12): the bottom row is not 0 0 0 1.
        (
            format!(
                "{good}\n{}\n",
                truth(2)
                    .to_homogeneous()
                    .transpose()
                    .iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            ),
            "row-major",
        ),
        (
            format!("{good}\n2,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\n"),
            "not a rotation",
        ),
    ];
    for (text, needle) in cases {
        std::fs::write(&p, &text).unwrap();
        let e = read_c3vd_poses(&p).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, DataError::Parse { line: 2, .. }), "{msg}");
        assert!(msg.contains("pose.txt:2") && msg.contains(needle), "{msg}");
    }
}

#[test]
fn count_mismatch_and_missing_depth_are_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("rec");
    fixture(&src, 3, true);
    std::fs::remove_file(src.join("0001_depth.tiff")).unwrap();
    let e = read_c3vd(&src, &config()).unwrap_err().to_string();
    assert!(
        e.contains("1_color.png") && e.contains("no depth map"),
        "{e}"
    );
    fixture(&src, 3, false);
    std::fs::write(
        src.join("3_color.png"),
        std::fs::read(src.join("0_color.png")).unwrap(),
    )
    .unwrap();
    let e = read_c3vd(
        &src,
        &C3vdConfig {
            depth: false,
            ..config()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("pose.txt") && e.contains("3_color.png") && e.contains("3 pose lines"),
        "{e}"
    );
}

/// A recording that keeps all 31 pose lines but only images 0, 10, 20, 30 (unpadded), with
/// depth `0000_depth.tiff` … `0030_depth.tiff` (padded) of value 100·(n+1).
fn subsampled_fixture(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let mut text = String::new();
    for i in 0..31 {
        writeln!(text, "{}", c3vd_line(&truth(i))).unwrap();
        if i % 10 == 0 {
            write_rgb(&dir.join(format!("{i}_color.png")), i as u8);
            write_depth_tiff(
                &dir.join(format!("{i:04}_depth.tiff")),
                100 * (i as u16 + 1),
            );
        }
    }
    std::fs::write(dir.join("pose.txt"), text).unwrap();
}

#[test]
fn subsampled_images_take_the_pose_line_and_time_of_their_frame_number() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("sigmoid_t3_a");
    subsampled_fixture(&src);
    let seq = read_c3vd(&src, &config()).unwrap();
    assert_eq!(seq.frames.len(), 4);
    assert!(
        seq.notes
            .iter()
            .any(|n| n.contains("4 of 31 pose lines have an image (every 10th frame)")),
        "{:?}",
        seq.notes
    );
    for (k, f) in seq.frames.iter().enumerate() {
        let n = 10 * k;
        assert!(f.image.ends_with(format!("{n}_color.png")));
        assert!(
            f.depth
                .as_ref()
                .unwrap()
                .ends_with(format!("{n:04}_depth.tiff"))
        );
    }

    let out = tmp.path().join("ds");
    let wc = WriteImportConfig {
        name: "c3vd".into(),
        ..Default::default()
    };
    write_import(&out, &[("all".to_string(), seq)], &wc).unwrap();
    let ds = Dataset::open(&out).unwrap();
    let s = ds.sequence("all").unwrap();
    assert_eq!(s.len(), 4);
    for k in 0..4 {
        let n = 10 * k;
        let p = &s.poses[k];
        assert!(
            (p.timestamp_s - n as f64 / 10.0).abs() < 1e-9,
            "frame {n}: {} s",
            p.timestamp_s
        );
        let dt = (p.pose.translation.vector - truth(n).translation.vector).norm();
        assert!(dt < 1e-6, "frame {n}: {dt} mm");
        assert!(
            orientation_error_deg(&p.pose, &truth(n)) < 1e-6,
            "frame {n}"
        );
        assert_eq!(s.load_rgb(k).unwrap().get_pixel(0, 0)[0], n as u8);
        let (_, _, d) = s.load_depth_mm(k).unwrap();
        let expect = 100.0 * (n as f64 + 1.0) / 65535.0 * 100.0;
        assert!((d[5] as f64 - expect).abs() < 0.006, "frame {n}: {}", d[5]);
    }
}

#[test]
fn clipped_depth_65535_is_imported_as_no_depth() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("rec");
    fixture(&src, 1, true);
    let mut img =
        image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(W, H, image::Luma([1000]));
    img.put_pixel(0, 0, image::Luma([65535]));
    img.put_pixel(1, 0, image::Luma([65534]));
    img.save(src.join("0000_depth.tiff")).unwrap();
    let seq = read_c3vd(&src, &config()).unwrap();
    let out = tmp.path().join("ds");
    let wc = WriteImportConfig {
        name: "c3vd".into(),
        ..Default::default()
    };
    write_import(&out, &[("all".to_string(), seq)], &wc).unwrap();
    let s = Dataset::open(&out).unwrap().sequence("all").unwrap();
    let (_, _, d) = s.load_depth_mm(0).unwrap();
    assert_eq!(d[0], 0.0, "65535 is C3VD's clipped depth: no depth");
    let near_max = 65534.0 / 65535.0 * 100.0;
    assert!((d[1] as f64 - near_max).abs() < 0.006, "{}", d[1]);
    let expect = 1000.0 / 65535.0 * 100.0;
    assert!((d[2] as f64 - expect).abs() < 0.006, "{}", d[2]);
}

#[test]
fn image_numbered_beyond_the_pose_lines_is_refused_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("rec");
    subsampled_fixture(&src);
    write_rgb(&src.join("40_color.png"), 40);
    write_depth_tiff(&src.join("0040_depth.tiff"), 4100);
    let e = read_c3vd(&src, &config()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, DataError::Invalid { .. }), "{msg}");
    assert!(
        msg.contains("40_color.png") && msg.contains("frame 40") && msg.contains("31 pose lines"),
        "{msg}"
    );
}

#[test]
fn undistort_resamples_through_the_fisheye_model() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("rec");
    fixture(&src, 2, true);
    // Image linear in x (exact under bilinear interpolation): value 20·u + 10.
    let img = image::RgbImage::from_fn(W, H, |x, _| image::Rgb([(20 * x + 10) as u8, 0, 0]));
    img.save(src.join("0_color.png")).unwrap();
    let fisheye = Distortion::Fisheye {
        k1: -0.18867,
        k2: -0.00393,
        k3: 0.03052,
        k4: -0.01276,
    };
    let cfg = C3vdConfig {
        camera: camera(fisheye),
        ..config()
    };
    let seq = read_c3vd(&src, &cfg).unwrap();
    let out = tmp.path().join("ds");
    let wc = WriteImportConfig {
        name: "c3vd".into(),
        undistort: true,
        ..Default::default()
    };
    let summary = write_import(&out, &[("all".to_string(), seq)], &wc).unwrap();
    assert!(summary.camera.distortion.is_none());
    let ds = Dataset::open(&out).unwrap();
    assert_eq!(ds.meta.camera, camera(Distortion::None));
    let s = ds.sequence("all").unwrap();
    let got = s.load_rgb(0).unwrap();
    let cam = camera(fisheye);
    for v in 0..H {
        for u in 0..W {
            let xn = Vector2::new((u as f64 - cam.cx) / cam.fx, (v as f64 - cam.cy) / cam.fy);
            let xd = fisheye.distort(xn);
            let su = cam.fx * xd.x + cam.cx;
            let sv = cam.fy * xd.y + cam.cy;
            let g = got.get_pixel(u, v)[0] as f64;
            if su >= 0.0 && sv >= 0.0 && su <= (W - 1) as f64 && sv <= (H - 1) as f64 {
                assert!(
                    (g - (20.0 * su + 10.0)).abs() <= 0.51,
                    "({u},{v}): {g} vs {su}"
                );
            } else {
                assert_eq!(g, 0.0, "({u},{v}) maps outside the source");
            }
        }
    }
    // Barrel distortion: the pinhole's corner pixel samples the source nearer the centre.
    let xn = Vector2::new((0.0 - cam.cx) / cam.fx, (0.0 - cam.cy) / cam.fy);
    assert!(fisheye.distort(xn).norm() < xn.norm());
    // Depth is resampled too (constant map stays constant where defined).
    let (_, _, d) = s.load_depth_mm(0).unwrap();
    let centre = d[(3 * W + 3) as usize] as f64;
    assert!(
        (centre - 1000.0 / 65535.0 * 100.0).abs() < 0.006,
        "{centre}"
    );
}
