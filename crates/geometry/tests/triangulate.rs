//! Triangulation on synthetic scenes with known truth, and on degenerate input.

use endoloc_geometry::synthetic::standard_normal;
use endoloc_geometry::{
    Camera, Distortion, Observation, Pose, TriangulationConfig, TriangulationError,
    triangulate_track, triangulate_tracks,
};
use nalgebra::{Point2, Point3, Translation3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Three cameras a few mm apart looking down +z, slightly rotated (colonoscope-like).
fn cameras() -> Vec<Pose> {
    vec![
        Pose::from_parts(
            Translation3::new(-5.0, 0.0, 0.0),
            UnitQuaternion::from_euler_angles(0.02, 0.05, 0.0),
        ),
        Pose::from_parts(
            Translation3::new(0.0, 2.0, 3.0),
            UnitQuaternion::from_euler_angles(-0.03, 0.0, 0.1),
        ),
        Pose::from_parts(
            Translation3::new(5.0, -1.0, 6.0),
            UnitQuaternion::from_euler_angles(0.0, -0.04, -0.05),
        ),
    ]
}

fn observe(camera: &Camera, poses: &[Pose], p: &Point3<f64>) -> Vec<Observation> {
    poses
        .iter()
        .map(|pose| Observation {
            pose: *pose,
            pixel: camera
                .project(&pose.inverse_transform_point(p))
                .expect("in front"),
        })
        .collect()
}

fn random_point(rng: &mut ChaCha8Rng) -> Point3<f64> {
    Point3::new(
        rng.random_range(-20.0..20.0),
        rng.random_range(-15.0..15.0),
        rng.random_range(30.0..90.0),
    )
}

#[test]
fn noise_free_tracks_recover_the_truth_to_1e9() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let poses = cameras();
    let mut cam = Camera::from_hfov(640, 480, 100.0);
    for distortion in [
        Distortion::None,
        Distortion::RadialTangential {
            k1: -0.25,
            k2: 0.06,
            p1: 0.001,
            p2: -0.0005,
            k3: 0.0,
        },
    ] {
        cam.distortion = distortion;
        for _ in 0..200 {
            let p = random_point(&mut rng);
            let tp = triangulate_track(&observe(&cam, &poses, &p), &cam, &Default::default())
                .expect("triangulates");
            assert!(
                (tp.p_world - p).norm() < 1e-9,
                "{distortion:?}: error {} mm",
                (tp.p_world - p).norm()
            );
            assert!(tp.reprojection_rms_px < 1e-6);
            assert_eq!(tp.views, 3);
        }
    }
}

#[test]
fn noisy_tracks_are_close_and_rms_matches_the_noise() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let poses = cameras();
    let cam = Camera::from_hfov(640, 480, 100.0);
    let truth: Vec<_> = (0..500).map(|_| random_point(&mut rng)).collect();
    let tracks: Vec<Vec<Observation>> = truth
        .iter()
        .map(|p| {
            let mut t = observe(&cam, &poses, p);
            for o in &mut t {
                o.pixel.x += 0.5 * standard_normal(&mut rng);
                o.pixel.y += 0.5 * standard_normal(&mut rng);
            }
            t
        })
        .collect();
    let results = triangulate_tracks(&tracks, &cam, &TriangulationConfig::default());
    let mut errors = Vec::new();
    let mut rms_sq = 0.0;
    for (r, p) in results.iter().zip(&truth) {
        let tp = r.as_ref().expect("noisy tracks still triangulate");
        errors.push((tp.p_world - p).norm() / p.z);
        rms_sq += tp.reprojection_rms_px.powi(2);
    }
    errors.sort_by(f64::total_cmp);
    let median_rel = errors[errors.len() / 2];
    // 0.5 px at f ≈ 270 px and baselines of ~10 mm at 30–90 mm: depth errors of a few 0.1 %.
    assert!(median_rel < 0.01, "median relative error {median_rel}");
    // The RMS is of the 2D error norm: E‖r‖² = 2σ² per view before the fit, and the fit
    // absorbs 3 of the 6 degrees of freedom, so RMS ≈ σ·√2·√(3/6) = σ = 0.5 px.
    let rms = (rms_sq / truth.len() as f64).sqrt();
    assert!((0.45..0.55).contains(&rms), "rms {rms}");
}

#[test]
fn delta_r_filter_drops_a_track_with_an_outlier() {
    let poses = cameras();
    let cam = Camera::from_hfov(640, 480, 100.0);
    let p = Point3::new(3.0, -2.0, 50.0);
    let mut track = observe(&cam, &poses, &p);
    track[1].pixel.x += 40.0;
    match triangulate_track(&track, &cam, &TriangulationConfig::default()) {
        Err(TriangulationError::ReprojectionTooHigh { max_px, delta_r_px }) => {
            assert!(max_px > 10.0);
            assert_eq!(delta_r_px, 10.0);
        }
        other => panic!("expected the δr filter to fire, got {other:?}"),
    }
    // A looser δr accepts it.
    let loose = TriangulationConfig {
        delta_r_px: 100.0,
        ..Default::default()
    };
    assert!(triangulate_track(&track, &cam, &loose).is_ok());
}

#[test]
fn degenerate_tracks_return_typed_errors() {
    let poses = cameras();
    let cam = Camera::from_hfov(640, 480, 100.0);
    let cfg = TriangulationConfig::default();
    let p = Point3::new(3.0, -2.0, 50.0);
    let track = observe(&cam, &poses, &p);

    assert_eq!(
        triangulate_track(&[], &cam, &cfg),
        Err(TriangulationError::TooFewViews { views: 0 })
    );
    assert_eq!(
        triangulate_track(&track[..1], &cam, &cfg),
        Err(TriangulationError::TooFewViews { views: 1 })
    );

    let mut nan = track.clone();
    nan[2].pixel.y = f64::NAN;
    assert_eq!(
        triangulate_track(&nan, &cam, &cfg),
        Err(TriangulationError::NonFinite { view: 2 })
    );

    // Zero baseline: the same camera centre, different rotations.
    let mut same_centre = track.clone();
    for o in &mut same_centre {
        o.pose.translation = Translation3::new(1.0, 1.0, 1.0);
    }
    assert_eq!(
        triangulate_track(&same_centre, &cam, &cfg),
        Err(TriangulationError::ZeroBaseline { views: 3 })
    );

    // A point far away: rays almost parallel.
    let far = Point3::new(10.0, 0.0, 5.0e4);
    assert!(matches!(
        triangulate_track(&observe(&cam, &poses, &far), &cam, &cfg),
        Err(TriangulationError::InsufficientParallax { .. })
    ));

    // Pixels consistent with a point *behind* the cameras (z < 0): the mirrored projection.
    let behind = Point3::new(2.0, 1.0, -60.0);
    let mirrored: Vec<Observation> = poses
        .iter()
        .map(|pose| {
            let q = pose.inverse_transform_point(&behind);
            Observation {
                pose: *pose,
                pixel: Point2::new(cam.fx * q.x / q.z + cam.cx, cam.fy * q.y / q.z + cam.cy),
            }
        })
        .collect();
    assert!(matches!(
        triangulate_track(&mirrored, &cam, &cfg),
        Err(TriangulationError::BehindCamera { .. })
    ));

    // Identical rays from two distinct centres along the ray itself: singular or no parallax.
    let along = vec![
        Observation {
            pose: Pose::identity(),
            pixel: Point2::new(cam.cx, cam.cy),
        },
        Observation {
            pose: Pose::from_parts(
                Translation3::new(0.0, 0.0, 10.0),
                UnitQuaternion::identity(),
            ),
            pixel: Point2::new(cam.cx, cam.cy),
        },
    ];
    let err = triangulate_track(&along, &cam, &cfg).expect_err("degenerate");
    assert!(
        matches!(
            err,
            TriangulationError::Degenerate | TriangulationError::InsufficientParallax { .. }
        ),
        "{err:?}"
    );
    // The error messages read well.
    assert!(err.to_string().contains("degenerate") || err.to_string().contains("parallax"));
}
