//! TUM trajectory files: round trip, and errors that name the file and the line.

use endoloc_data::{DataError, StampedPose, read_tum, write_tum};
use endoloc_geometry::Pose;
use nalgebra::{Translation3, UnitQuaternion, Vector3};

fn poses() -> Vec<StampedPose> {
    (0..50)
        .map(|i| {
            let f = i as f64;
            let r = UnitQuaternion::from_scaled_axis(Vector3::new(
                0.3 * (f * 0.7).sin(),
                -1.9 + 0.05 * f,
                0.11 * f,
            ));
            StampedPose {
                timestamp_s: f / 30.0,
                pose: Pose::from_parts(
                    Translation3::new(123.456789123 + f * 1.1, -987.654321 * f.cos(), 1e-7 * f),
                    r,
                ),
            }
        })
        .collect()
}

#[test]
fn write_then_read_gives_the_same_poses_to_1e9() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("poses.txt");
    let original = poses();
    write_tum(&path, &original).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with('#'), "header comment expected:\n{text}");
    let back = read_tum(&path).unwrap();
    assert_eq!(back.len(), original.len());
    for (a, b) in original.iter().zip(&back) {
        assert!((a.timestamp_s - b.timestamp_s).abs() < 1e-6);
        let dt = (a.pose.translation.vector - b.pose.translation.vector).amax();
        assert!(dt <= 1e-9, "translation differs by {dt}");
        // Same rotation up to the quaternion sign.
        let qa = a.pose.rotation.into_inner();
        let qb = b.pose.rotation.into_inner();
        let dq = (qa - qb).coords.amax().min((qa + qb).coords.amax());
        assert!(dq <= 1e-9, "quaternion differs by {dq}");
        assert!(b.pose.rotation.w >= 0.0, "qw must be canonicalised to >= 0");
    }
    // No temporary file left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 1);
}

#[test]
fn seven_columns_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("traj.txt");
    std::fs::write(
        &path,
        "# comment\n0.0 1 2 3 0 0 0 1\n0.1 1 2 3 0 0 0\n0.2 1 2 3 0 0 0 1\n",
    )
    .unwrap();
    let err = read_tum(&path).unwrap_err();
    match &err {
        DataError::Parse { path: p, line, .. } => {
            assert_eq!(p, &path);
            assert_eq!(*line, 3);
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("traj.txt:3:")
            && msg.contains("expected 8 columns: timestamp tx ty tz qx qy qz qw"),
        "{msg}"
    );
}

#[test]
fn nan_in_a_pose_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("traj.txt");
    std::fs::write(&path, "\n0.0 1 2 3 0 0 0 1\n\n0.1 1 NaN 3 0 0 0 1\n").unwrap();
    let msg = read_tum(&path).unwrap_err().to_string();
    assert!(msg.contains("traj.txt:4:") && msg.contains("ty"), "{msg}");
}

#[test]
fn non_unit_quaternion_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("traj.txt");
    std::fs::write(&path, "0.0 1 2 3 0 0 0.1 1\n").unwrap();
    let msg = read_tum(&path).unwrap_err().to_string();
    assert!(
        msg.contains(":1:") && msg.contains("unit quaternion"),
        "{msg}"
    );
}

#[test]
fn writing_a_nan_pose_fails_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("traj.txt");
    let mut p = poses();
    p[3].timestamp_s = f64::NAN;
    assert!(matches!(
        write_tum(&path, &p),
        Err(DataError::Invalid { .. })
    ));
    assert!(!path.exists());
}
