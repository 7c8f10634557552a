//! The 5-point essential-matrix solver, RANSAC and `recover_pose` on random two-view scenes
//! with a known relative pose, pixel noise and outliers.

use endoloc_geometry::essential::{
    EssentialError, EssentialRansacConfig, decompose_essential, eight_point, five_point,
    ransac_essential, recover_pose, sampson_distance_sq,
};
use endoloc_geometry::synthetic::{random_rotation, random_unit_vector, standard_normal};
use endoloc_geometry::{Camera, so3};
use nalgebra::{Point2, Point3, Rotation3, UnitQuaternion, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A two-view scene: camera 1 at the origin, camera 2 at `X₂ = R X₁ + t`.
struct TwoView {
    camera: Camera,
    r_21: Rotation3<f64>,
    t_21: Vector3<f64>,
    pixels1: Vec<Point2<f64>>,
    pixels2: Vec<Point2<f64>>,
    outlier: Vec<bool>,
}

/// Points 20–150 mm in front of camera 1 (a colonoscopy-like depth range), camera 2 moved by
/// `baseline_mm` in a random direction and rotated by up to `max_rot_deg`; both views see
/// every point (points that leave view 2 are redrawn).
fn two_view(seed: u64, n: usize, noise_px: f64, outliers: f64, baseline_mm: f64) -> TwoView {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let camera = Camera::from_hfov(640, 480, 90.0);
    let max_rot_deg: f64 = 15.0;
    let axis = random_unit_vector(&mut rng);
    let angle = rng.random_range(0.0..max_rot_deg).to_radians();
    let r_21 = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
    let centre2 = random_unit_vector(&mut rng) * baseline_mm; // camera 2 centre in frame 1
    let t_21 = -(r_21 * centre2);
    let (w, h) = (camera.width as f64 - 1.0, camera.height as f64 - 1.0);
    let n_out = (n as f64 * outliers).round() as usize;
    let (mut pixels1, mut pixels2, mut outlier) = (Vec::new(), Vec::new(), Vec::new());
    while pixels1.len() < n {
        let px = Point2::new(rng.random_range(0.0..=w), rng.random_range(0.0..=h));
        let depth = rng.random_range(20.0..150.0);
        let Some(p1) = camera.unproject(&px, depth) else {
            continue;
        };
        let p2 = Point3::from(r_21 * p1.coords + t_21);
        let Some(q) = camera.project(&p2) else {
            continue;
        };
        if !camera.contains(&q) {
            continue;
        }
        let noise = |rng: &mut ChaCha8Rng| {
            nalgebra::Vector2::new(standard_normal(rng), standard_normal(rng)) * noise_px
        };
        let is_out = pixels1.len() < n_out;
        let q = if is_out {
            Point2::new(rng.random_range(0.0..=w), rng.random_range(0.0..=h))
        } else {
            q + noise(&mut rng)
        };
        pixels1.push(px + noise(&mut rng));
        pixels2.push(q);
        outlier.push(is_out);
    }
    TwoView {
        camera,
        r_21,
        t_21: t_21.normalize(),
        pixels1,
        pixels2,
        outlier,
    }
}

fn rotation_error_deg(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    so3::log(&(a.inverse() * b)).norm().to_degrees()
}

fn direction_error_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.normalize()
        .dot(&b.normalize())
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

fn homogeneous(camera: &Camera, px: &[Point2<f64>]) -> Vec<Vector3<f64>> {
    px.iter()
        .map(|p| {
            let n = camera.normalized(p).unwrap();
            Vector3::new(n.x, n.y, 1.0)
        })
        .collect()
}

#[test]
fn five_point_recovers_the_exact_essential_matrix() {
    for seed in 0..50 {
        let s = two_view(seed, 5, 0.0, 0.0, 10.0);
        let x1 = homogeneous(&s.camera, &s.pixels1);
        let x2 = homogeneous(&s.camera, &s.pixels2);
        let truth = so3::hat(&s.t_21) * s.r_21.matrix();
        let truth = truth / truth.norm();
        let sols = five_point(
            &[x1[0], x1[1], x1[2], x1[3], x1[4]],
            &[x2[0], x2[1], x2[2], x2[3], x2[4]],
        );
        assert!(!sols.is_empty() && sols.len() <= 10, "seed {seed}");
        for e in &sols {
            // Every solution satisfies the five constraints and the essential constraints.
            for (a, b) in x1.iter().zip(&x2) {
                assert!(b.dot(&(e * a)).abs() < 1e-9, "seed {seed}");
            }
            assert!(e.determinant().abs() < 1e-9, "seed {seed}");
            let sv = e.singular_values();
            let mut v: Vec<f64> = sv.iter().copied().collect();
            v.sort_by(f64::total_cmp);
            assert!(
                (v[2] - v[1]).abs() < 1e-7 && v[0] < 1e-9,
                "seed {seed}: {v:?}"
            );
        }
        let best = sols
            .iter()
            .map(|e| (e - truth).norm().min((e + truth).norm()))
            .fold(f64::INFINITY, f64::min);
        assert!(best < 1e-7, "seed {seed}: closest solution {best}");
    }
}

#[test]
fn degenerate_samples_give_no_solution_instead_of_a_panic() {
    let same = [Vector3::new(0.1, 0.2, 1.0); 5];
    assert!(five_point(&same, &same).is_empty());
    let nan = [Vector3::new(f64::NAN, 0.0, 1.0); 5];
    assert!(five_point(&nan, &nan).is_empty());
}

#[test]
fn decomposition_with_cheirality_picks_the_true_pose() {
    for seed in 0..20 {
        let s = two_view(100 + seed, 50, 0.0, 0.0, 8.0);
        let x1 = homogeneous(&s.camera, &s.pixels1);
        let x2 = homogeneous(&s.camera, &s.pixels2);
        let e = so3::hat(&s.t_21) * s.r_21.matrix();
        // The four candidates include the truth; recover_pose picks it with all points in front.
        let cands = decompose_essential(&e).unwrap();
        assert!(
            cands
                .iter()
                .any(|c| rotation_error_deg(&c.r_21, &s.r_21) < 1e-6
                    && direction_error_deg(&c.t_21, &s.t_21) < 1e-6)
        );
        let r = recover_pose(&(e * -3.0), &x1, &x2, None, 50.0).unwrap();
        assert!(
            rotation_error_deg(&r.pose.r_21, &s.r_21) < 1e-6,
            "seed {seed}"
        );
        assert!(
            direction_error_deg(&r.pose.t_21, &s.t_21) < 1e-6,
            "seed {seed}"
        );
        assert_eq!(r.in_front_count, 50);
    }
}

#[test]
fn pose_2_in_1_is_the_camera_to_world_pose_of_camera_2() {
    let s = two_view(7, 30, 0.0, 0.0, 12.0);
    let x1 = homogeneous(&s.camera, &s.pixels1);
    let x2 = homogeneous(&s.camera, &s.pixels2);
    let e = so3::hat(&s.t_21) * s.r_21.matrix();
    let r = recover_pose(&e, &x1, &x2, None, 50.0).unwrap();
    let t_wc2 = r.pose.pose_2_in_1(12.0);
    // Camera 2's centre in frame 1 is at distance 12 and maps to the origin of frame 2.
    let centre = t_wc2.translation.vector;
    assert!((centre.norm() - 12.0).abs() < 1e-9);
    let x2_of_centre = s.r_21 * centre + s.t_21 * 12.0;
    assert!(x2_of_centre.norm() < 1e-9);
    let q = UnitQuaternion::from_rotation_matrix(&s.r_21.inverse());
    assert!(endoloc_geometry::so3::geodesic_distance(&t_wc2.rotation, &q) < 1e-9);
}

#[test]
fn eight_point_is_exact_without_noise() {
    let s = two_view(3, 40, 0.0, 0.0, 10.0);
    let x1 = homogeneous(&s.camera, &s.pixels1);
    let x2 = homogeneous(&s.camera, &s.pixels2);
    let e = eight_point(&x1, &x2).unwrap();
    for (a, b) in x1.iter().zip(&x2) {
        assert!(sampson_distance_sq(&e, a, b).sqrt() * 320.0 < 1e-6);
    }
    assert!(eight_point(&x1[..7], &x2[..7]).is_none());
}

#[test]
fn ransac_bad_input_is_a_clear_error() {
    let cam = Camera::from_hfov(640, 480, 90.0);
    let cfg = EssentialRansacConfig::default();
    let p = vec![Point2::new(1.0, 2.0); 10];
    assert_eq!(
        ransac_essential(&p, &p[..9], &cam, &cfg).unwrap_err(),
        EssentialError::LengthMismatch {
            first: 10,
            second: 9
        }
    );
    assert_eq!(
        ransac_essential(&p[..5], &p[..5], &cam, &cfg).unwrap_err(),
        EssentialError::TooFewCorrespondences { usable: 5 }
    );
    let mut bad = p.clone();
    bad[3].x = f64::INFINITY;
    assert_eq!(
        ransac_essential(&bad, &p, &cam, &cfg).unwrap_err(),
        EssentialError::NonFinite { index: 3 }
    );
    // Identical points in both views (no motion, all points equal): no consensus, no panic.
    assert!(ransac_essential(&p, &p, &cam, &cfg).is_err());
}

#[test]
fn ransac_is_deterministic_for_a_seed() {
    let s = two_view(11, 150, 0.5, 0.3, 10.0);
    let cfg = EssentialRansacConfig {
        seed: 5,
        ..Default::default()
    };
    let a = ransac_essential(&s.pixels1, &s.pixels2, &s.camera, &cfg).unwrap();
    let b = ransac_essential(&s.pixels1, &s.pixels2, &s.camera, &cfg).unwrap();
    assert_eq!(a, b);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, rng_seed: proptest::test_runner::RngSeed::Fixed(20261121), ..ProptestConfig::default() })]

    /// 200 correspondences, 0.5 px noise, 30 % outliers, baseline 5–20 mm at depths
    /// 20–150 mm: rotation error < 0.75°, translation direction error < max(2°, 45°·mm /
    /// baseline), outliers rejected. Fixed RNG seed: the same cases on every run.
    #[test]
    fn ransac_recovers_the_relative_pose(seed in 0u64..1_000_000, baseline in 5.0f64..20.0) {
        let s = two_view(seed, 200, 0.5, 0.3, baseline);
        let cfg = EssentialRansacConfig { seed, ..Default::default() };
        let est = ransac_essential(&s.pixels1, &s.pixels2, &s.camera, &cfg).unwrap();
        let rot = rotation_error_deg(&est.pose.r_21, &s.r_21);
        let dir = direction_error_deg(&est.pose.t_21, &s.t_21);
        prop_assert!(rot < 0.75, "rotation error {rot}° (stress runs: up to 0.52°)");
        // The direction is noise-limited by the parallax: baseline / depth is only 0.03–0.25
        // here. Stress runs (PROPTEST_CASES=3000) found 2.2° at a 7.3 mm and up to 5.8° at a 5.8 mm
        // baseline, so the bound scales with 1 / baseline.
        let bound = (45.0 / baseline).max(2.0);
        prop_assert!(dir < bound, "translation direction error {dir}° (bound {bound}°)");
        let false_inliers = est.inliers.iter().zip(&s.outlier).filter(|(i, o)| **i && **o).count();
        let true_inliers = est.inliers.iter().zip(&s.outlier).filter(|(i, o)| **i && !**o).count();
        // Random outliers can fall near their epipolar line by chance (a 1 px band).
        prop_assert!(false_inliers <= 10, "{false_inliers} outliers accepted");
        // 0.5 px noise in both views puts ~0.7 px on the epipolar distance: the default
        // 1.5 px threshold keeps ~97 % of the true inliers.
        prop_assert!(true_inliers >= 100, "only {true_inliers} of 140 inliers kept");
        prop_assert!(est.in_front_count as f64 >= 0.9 * est.inlier_count as f64);
    }
}

/// A random rotation of any size is recovered too (the solver is not limited to small
/// motions), with a clean sample.
#[test]
fn large_rotations_are_recovered() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut solved = 0;
    while solved < 20 {
        let r = random_rotation(&mut rng).to_rotation_matrix();
        let t = random_unit_vector(&mut rng);
        let mut x1 = Vec::new();
        let mut x2 = Vec::new();
        for _ in 0..200 {
            if x1.len() == 5 {
                break;
            }
            let p = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(2.0..6.0),
            );
            let q = r * p + t;
            if q.z > 0.1 {
                x1.push(p / p.z);
                x2.push(q / q.z);
            }
        }
        if x1.len() < 5 {
            continue; // camera 2 looks away from the points: draw another motion
        }
        solved += 1;
        let sols = five_point(
            &[x1[0], x1[1], x1[2], x1[3], x1[4]],
            &[x2[0], x2[1], x2[2], x2[3], x2[4]],
        );
        let truth = so3::hat(&t) * r.matrix();
        let truth = truth / truth.norm();
        let best = sols
            .iter()
            .map(|e| (e - truth).norm().min((e + truth).norm()))
            .fold(f64::INFINITY, f64::min);
        assert!(best < 1e-6, "closest {best}");
    }
}

/// The property over 300 fixed seeds (deterministic), with the worst case printed. Measured:
/// worst rotation error 0.18°, worst translation direction error 1.06°, mean 0.20°.
#[test]
fn ransac_worst_case_over_fixed_seeds() {
    let (mut worst_rot, mut worst_dir) = (0.0f64, 0.0f64);
    for seed in 0..300u64 {
        let baseline = 5.0 + 15.0 * (seed as f64 / 300.0);
        let s = two_view(50_000 + seed, 200, 0.5, 0.3, baseline);
        let cfg = EssentialRansacConfig {
            seed,
            ..Default::default()
        };
        let est = ransac_essential(&s.pixels1, &s.pixels2, &s.camera, &cfg).unwrap();
        worst_rot = worst_rot.max(rotation_error_deg(&est.pose.r_21, &s.r_21));
        worst_dir = worst_dir.max(direction_error_deg(&est.pose.t_21, &s.t_21));
    }
    eprintln!("worst rotation error {worst_rot:.3}°, worst direction error {worst_dir:.3}°");
    assert!(worst_rot < 0.5 && worst_dir < 2.0);
}
