//! Benchmarks of the geometry hot paths (one core): `cargo bench -p endoloc-geometry`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use endoloc_geometry::synthetic::{PnpSceneConfig, perturb_pose, pnp_scene, standard_normal};
use endoloc_geometry::{
    Camera, Observation, Pose, RansacConfig, RefineConfig, RegistrationConfig, RobustKernel,
    TriangulationConfig, Triangulator, WallCovarianceConfig, localize_pose, ransac_pnp,
    refine_pose, wall_covariance,
};
use nalgebra::{Point3, Translation3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn bench_refine(c: &mut Criterion) {
    let s = pnp_scene(&PnpSceneConfig::default(), 42);
    let prior = perturb_pose(&s.t_wc, 5.0, 5.0, &mut ChaCha8Rng::seed_from_u64(1));
    let cfg = RefineConfig::default();
    // The default (Cauchy polish), then least squares as the polish: its cost, in one run.
    let least_squares = RefineConfig {
        polish_kernel: RobustKernel::None,
        ..cfg
    };
    for (name, cfg) in [
        (
            "refine_pose/200 corr, 0.5 px, 30% outliers, prior 5°/5 mm",
            &cfg,
        ),
        (
            "refine_pose/200 corr, 0.5 px, 30% outliers, prior 5°/5 mm, least-squares polish",
            &least_squares,
        ),
    ] {
        c.bench_function(name, |b| {
            b.iter(|| {
                refine_pose(
                    black_box(&prior),
                    &s.points_world,
                    &s.pixels,
                    &s.camera,
                    cfg,
                )
            })
        });
    }
    let clean = pnp_scene(
        &PnpSceneConfig {
            outlier_fraction: 0.0,
            ..Default::default()
        },
        43,
    );
    let clean_prior = perturb_pose(&clean.t_wc, 5.0, 5.0, &mut ChaCha8Rng::seed_from_u64(1));
    c.bench_function(
        "refine_pose/200 corr, 0.5 px, no outliers, prior 5°/5 mm",
        |b| {
            b.iter(|| {
                refine_pose(
                    black_box(&clean_prior),
                    &clean.points_world,
                    &clean.pixels,
                    &clean.camera,
                    &cfg,
                )
            })
        },
    );
    // The wall-motion term of the covariance at the refined pose, on its 200 inliers (one
    // exponential per pair of points): against the refinement itself.
    let refined = refine_pose(
        &clean_prior,
        &clean.points_world,
        &clean.pixels,
        &clean.camera,
        &cfg,
    )
    .expect("the clean scene refines");
    let wall = WallCovarianceConfig::default();
    c.bench_function("wall_covariance/200 inliers, 0.5 px", |b| {
        b.iter(|| {
            wall_covariance(
                black_box(&refined.t_wc),
                &clean.points_world,
                &clean.pixels,
                &clean.camera,
                &cfg,
                &wall,
            )
        })
    });
}

fn three_view_tracks(n: usize) -> (Camera, Vec<[Observation; 3]>) {
    let cam = Camera::from_hfov(640, 480, 100.0);
    let poses = [
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
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let tracks = (0..n)
        .map(|_| {
            let p = Point3::new(
                rng.random_range(-20.0..20.0),
                rng.random_range(-15.0..15.0),
                rng.random_range(30.0..90.0),
            );
            poses.map(|pose| {
                let mut px = cam
                    .project(&pose.inverse_transform_point(&p))
                    .unwrap_or_default();
                px.x += 0.5 * standard_normal(&mut rng);
                px.y += 0.5 * standard_normal(&mut rng);
                Observation { pose, pixel: px }
            })
        })
        .collect();
    (cam, tracks)
}

fn bench_triangulate(c: &mut Criterion) {
    let (cam, tracks) = three_view_tracks(1000);
    let mut tri = Triangulator::new(cam, TriangulationConfig::default());
    c.bench_function("triangulate/1000 three-view tracks, 0.5 px", |b| {
        b.iter(|| {
            let mut ok = 0usize;
            for t in &tracks {
                ok += tri.triangulate(black_box(t)).is_ok() as usize;
            }
            ok
        })
    });
}

fn bench_ransac(c: &mut Criterion) {
    let s = pnp_scene(&PnpSceneConfig::default(), 44);
    let cfg = RansacConfig::default();
    c.bench_function("ransac_pnp/200 corr, 30% outliers", |b| {
        b.iter(|| ransac_pnp(black_box(&s.points_world), &s.pixels, &s.camera, &cfg))
    });
    let prior = perturb_pose(&s.t_wc, 30.0, 20.0, &mut ChaCha8Rng::seed_from_u64(2));
    let lcfg = RegistrationConfig::new();
    c.bench_function(
        "localize_pose/200 corr, 30% outliers, prior 30°/20 mm",
        |b| {
            b.iter(|| {
                localize_pose(
                    black_box(&prior),
                    &s.points_world,
                    &s.pixels,
                    &s.camera,
                    &lcfg,
                )
            })
        },
    );
}

criterion_group!(benches, bench_refine, bench_triangulate, bench_ransac);
criterion_main!(benches);
