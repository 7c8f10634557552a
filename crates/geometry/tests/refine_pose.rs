//! Pose refinement on synthetic scenes with known truth, and on degenerate input.

use endoloc_geometry::synthetic::{PnpSceneConfig, perturb_pose, pnp_scene};
use endoloc_geometry::{
    Distortion, RefineConfig, RefineError, RobustKernel, orientation_error_deg, position_error_mm,
    refine_pose,
};
use nalgebra::{Point2, Point3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn clean(points: usize) -> PnpSceneConfig {
    PnpSceneConfig {
        points,
        noise_px: 0.0,
        outlier_fraction: 0.0,
        ..Default::default()
    }
}

#[test]
fn noise_free_scenes_recover_the_truth_to_1e9() {
    for seed in 0..20 {
        let s = pnp_scene(&clean(50), seed);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let prior = perturb_pose(&s.t_wc, 10.0, 10.0, &mut rng);
        for kernel in [
            RobustKernel::None,
            RobustKernel::Huber { scale_px: 2.0 },
            RobustKernel::Cauchy { scale_px: 2.0 },
        ] {
            let cfg = RefineConfig {
                kernel,
                ..Default::default()
            };
            let est = refine_pose(&prior, &s.points_world, &s.pixels, &s.camera, &cfg).unwrap();
            let dp = position_error_mm(&est.t_wc, &s.t_wc);
            let dr = orientation_error_deg(&est.t_wc, &s.t_wc).to_radians();
            assert!(
                dp < 1e-9 && dr < 1e-9,
                "seed {seed} {kernel:?}: {dp} mm, {dr} rad"
            );
            assert!(est.converged);
            assert_eq!(est.inlier_count, 50);
            assert!(est.rms_px < 1e-6);
        }
    }
}

#[test]
fn noise_free_with_distortion_recovers_the_truth() {
    let mut s = pnp_scene(&clean(60), 7);
    s.camera.distortion = Distortion::RadialTangential {
        k1: -0.2,
        k2: 0.04,
        p1: 0.001,
        p2: 0.0005,
        k3: 0.0,
    };
    // Re-project through the distorted camera.
    for (px, p) in s.pixels.iter_mut().zip(&s.points_world) {
        *px = s
            .camera
            .project(&s.t_wc.inverse_transform_point(p))
            .unwrap();
    }
    let prior = perturb_pose(&s.t_wc, 8.0, 8.0, &mut ChaCha8Rng::seed_from_u64(3));
    let est = refine_pose(
        &prior,
        &s.points_world,
        &s.pixels,
        &s.camera,
        &RefineConfig::default(),
    )
    .unwrap();
    assert!(position_error_mm(&est.t_wc, &s.t_wc) < 1e-9);
    assert!(orientation_error_deg(&est.t_wc, &s.t_wc) < 1e-7);
}

#[test]
fn noise_and_30_percent_outliers_from_a_nearby_prior() {
    let mut pos = Vec::new();
    let mut rot = Vec::new();
    for seed in 0..20 {
        let s = pnp_scene(&PnpSceneConfig::default(), 100 + seed);
        let prior = perturb_pose(&s.t_wc, 5.0, 5.0, &mut ChaCha8Rng::seed_from_u64(seed));
        let est = refine_pose(
            &prior,
            &s.points_world,
            &s.pixels,
            &s.camera,
            &RefineConfig::default(),
        )
        .unwrap();
        // Every true inlier (0.5 px noise) is found; few outliers slip under 4 px by chance.
        let true_in = s.outlier.iter().filter(|o| !**o).count();
        let found_true = est
            .inliers
            .iter()
            .zip(&s.outlier)
            .filter(|(i, o)| **i && !**o)
            .count();
        assert_eq!(found_true, true_in, "seed {seed}");
        assert!(est.inlier_count <= true_in + 5);
        assert!((0.4..0.9).contains(&est.rms_px), "rms {}", est.rms_px);
        pos.push(position_error_mm(&est.t_wc, &s.t_wc));
        rot.push(orientation_error_deg(&est.t_wc, &s.t_wc));
    }
    let mean_pos = pos.iter().sum::<f64>() / pos.len() as f64;
    let mean_rot = rot.iter().sum::<f64>() / rot.len() as f64;
    assert!(mean_pos < 0.5, "mean position error {mean_pos} mm");
    assert!(mean_rot < 0.2, "mean orientation error {mean_rot}°");
}

#[test]
fn bad_prior_30_degrees_and_20_mm_off_without_outliers() {
    let cfg = PnpSceneConfig {
        outlier_fraction: 0.0,
        ..Default::default()
    };
    for seed in 0..20 {
        let s = pnp_scene(&cfg, 300 + seed);
        let prior = perturb_pose(&s.t_wc, 30.0, 20.0, &mut ChaCha8Rng::seed_from_u64(seed));
        let est = refine_pose(
            &prior,
            &s.points_world,
            &s.pixels,
            &s.camera,
            &RefineConfig::default(),
        )
        .unwrap();
        assert!(
            position_error_mm(&est.t_wc, &s.t_wc) < 1.0,
            "seed {seed}: {} mm",
            position_error_mm(&est.t_wc, &s.t_wc)
        );
        assert!(orientation_error_deg(&est.t_wc, &s.t_wc) < 0.5);
    }
}

/// Map points triangulated from a few views are sometimes a pixel or two off where a new
/// view sees them: inside the inlier threshold, so they reach the polish. The default Cauchy
/// polish must all but ignore them where least squares is pulled.
#[test]
fn the_polish_resists_points_a_few_pixels_off() {
    let cfg = PnpSceneConfig {
        points: 120,
        noise_px: 0.3,
        outlier_fraction: 0.0,
        ..Default::default()
    };
    let least_squares = RefineConfig {
        polish_kernel: RobustKernel::None,
        ..Default::default()
    };
    let (mut err_default, mut err_ls) = (0.0, 0.0);
    for seed in 0..30 {
        let mut s = pnp_scene(&cfg, 700 + seed);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        // A quarter of the correspondences 1–3.5 px off (all within the 4 px inlier threshold),
        // pushed the same way so that they bias rather than average out.
        let push = rng.random_range(0.0..std::f64::consts::TAU);
        for px in s.pixels.iter_mut().step_by(4) {
            let angle = push + rng.random_range(-0.5..0.5);
            let r = rng.random_range(1.0..3.5);
            *px += nalgebra::Vector2::new(angle.cos(), angle.sin()) * r;
        }
        let refine = |c: &RefineConfig| {
            let est = refine_pose(&s.t_wc, &s.points_world, &s.pixels, &s.camera, c).unwrap();
            assert_eq!(
                est.inlier_count, 120,
                "seed {seed}: every correspondence is an inlier"
            );
            position_error_mm(&est.t_wc, &s.t_wc)
        };
        err_default += refine(&RefineConfig::default());
        err_ls += refine(&least_squares);
    }
    assert!(
        err_default < 0.75 * err_ls,
        "mean position error: Cauchy polish {} mm, least squares {} mm",
        err_default / 30.0,
        err_ls / 30.0
    );
}

#[test]
fn covariance_predicts_the_spread_of_the_error() {
    // Over many noisy trials, the squared Mahalanobis-free check: the mean squared position
    // error is of the order of the predicted largest variance (within a factor of 3).
    let cfg = PnpSceneConfig {
        outlier_fraction: 0.0,
        noise_px: 1.0,
        ..Default::default()
    };
    let mut err_sq = 0.0;
    let mut pred_sq = 0.0;
    let n = 40;
    for seed in 0..n {
        let s = pnp_scene(&cfg, 500 + seed);
        let est = refine_pose(
            &s.t_wc,
            &s.points_world,
            &s.pixels,
            &s.camera,
            &RefineConfig::default(),
        )
        .unwrap();
        err_sq += position_error_mm(&est.t_wc, &s.t_wc).powi(2);
        pred_sq += est.position_sigma_mm().powi(2);
        assert!(est.covariance.iter().all(|v| v.is_finite()));
    }
    let ratio = err_sq / pred_sq;
    // The largest-axis variance bounds the total from below and 3× it from above.
    assert!((0.3..3.0).contains(&ratio), "error²/σ² = {ratio}");
}

#[test]
fn degenerate_input_returns_typed_errors() {
    let s = pnp_scene(&clean(30), 9);
    let cfg = RefineConfig::default();
    let r =
        |pts: &[Point3<f64>], px: &[Point2<f64>]| refine_pose(&s.t_wc, pts, px, &s.camera, &cfg);

    assert_eq!(
        r(&s.points_world[..2], &s.pixels[..2]),
        Err(RefineError::TooFewCorrespondences { usable: 2 })
    );
    assert_eq!(
        r(&[], &[]),
        Err(RefineError::TooFewCorrespondences { usable: 0 })
    );
    assert_eq!(
        r(&s.points_world[..5], &s.pixels[..4]),
        Err(RefineError::LengthMismatch {
            points: 5,
            pixels: 4
        })
    );
    let mut nan = s.points_world.clone();
    nan[4].y = f64::NAN;
    assert_eq!(r(&nan, &s.pixels), Err(RefineError::NonFinite { index: 4 }));
    let mut bad_prior = s.t_wc;
    bad_prior.translation.x = f64::INFINITY;
    assert_eq!(
        refine_pose(&bad_prior, &s.points_world, &s.pixels, &s.camera, &cfg),
        Err(RefineError::NonFinitePrior)
    );

    // Collinear points: rotation about their line is unobservable.
    let a = s.points_world[0];
    let b = s.points_world[1];
    let line: Vec<Point3<f64>> = (0..20).map(|k| a + (b - a) * (k as f64 / 19.0)).collect();
    let line_px: Vec<Point2<f64>> = line
        .iter()
        .map(|p| {
            s.camera
                .project(&s.t_wc.inverse_transform_point(p))
                .unwrap()
        })
        .collect();
    assert!(matches!(
        r(&line, &line_px),
        Err(RefineError::Degenerate { .. })
    ));

    // Every point behind the prior camera.
    let flipped: Vec<Point3<f64>> = s
        .points_world
        .iter()
        .map(|p| {
            let c = s.t_wc.inverse_transform_point(p);
            s.t_wc * Point3::new(c.x, c.y, -c.z)
        })
        .collect();
    assert_eq!(
        r(&flipped, &s.pixels),
        Err(RefineError::TooFewCorrespondences { usable: 0 })
    );
}
