//! Per-frame cost of the visual odometry and of its essential-matrix RANSAC (one core):
//! `cargo bench -p endoloc-vo`.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use endoloc_geometry::synthetic::standard_normal;
use endoloc_geometry::{Camera, EssentialRansacConfig, five_point, ransac_essential};
use endoloc_sim::appearance::MucosaAtlas;
use endoloc_sim::config::{Preset, SimConfig};
use endoloc_sim::render::{RenderScratch, Renderer};
use endoloc_sim::simulate::build_colon;
use endoloc_sim::trajectory::PassGenerator;
use endoloc_vo::{VisualOdometry, VoConfig};
use image::{GrayImage, RgbImage};
use nalgebra::{Point2, Point3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Frames `first..first + count` of a 2610-frame pass through the `small` preset's colon,
/// at `width × height`.
fn render(first: usize, count: usize, width: u32, height: u32) -> (Camera, Vec<GrayImage>) {
    let mut cfg = SimConfig::preset(Preset::Small).with_seed(3);
    cfg.test.frames = 2610;
    cfg.camera.width = width;
    cfg.camera.height = height;
    let colon = build_colon(&cfg).expect("colon");
    let atlas = MucosaAtlas::bake(&colon, &cfg.appearance).expect("atlas");
    let camera = cfg.camera.camera().expect("camera");
    let renderer = Renderer::new(&colon, &atlas, camera, cfg.render.clone()).expect("renderer");
    let pass = PassGenerator::new(&colon, &cfg.test).expect("pass");
    let mut scratch = RenderScratch::default();
    let images = (first..first + count)
        .map(|k| {
            let (pose, s, _) = pass.pose_at(k as f64);
            let frame = renderer.render(&[(pose, s)], k as u64, &mut scratch);
            let rgb = RgbImage::from_raw(width, height, frame.rgb).expect("size");
            image::DynamicImage::ImageRgb8(rgb).to_luma8()
        })
        .collect();
    (camera, images)
}

fn bench_track(c: &mut Criterion) {
    for (w, h) in [(320u32, 240u32), (640, 480)] {
        let (camera, images) = render(400, 31, w, h);
        let mut vo = VisualOdometry::new(camera, VoConfig::default()).expect("vo");
        for img in &images[..30] {
            vo.track(img).expect("track");
        }
        assert!(vo.is_tracking(), "the bench sequence must be tracking");
        let last = &images[30];
        c.bench_function(&format!("vo/track one frame, {w}x{h}, tracking"), |b| {
            b.iter_batched(
                || vo.clone(),
                |mut v| black_box(v.track(last).expect("track")),
                BatchSize::LargeInput,
            )
        });
    }
}

fn bench_essential(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let camera = Camera::from_hfov(640, 480, 90.0);
    let r = Rotation3::from_euler_angles(0.05, -0.1, 0.02);
    let t = Vector3::new(0.3, -0.2, 1.0).normalize() * 10.0;
    let (mut p1, mut p2) = (Vec::new(), Vec::new());
    while p1.len() < 200 {
        let px = Point2::new(rng.random_range(0.0..639.0), rng.random_range(0.0..479.0));
        let p = camera
            .unproject(&px, rng.random_range(20.0..150.0))
            .expect("unproject");
        let Some(q) = camera.project(&Point3::from(r * p.coords + t)) else {
            continue;
        };
        let noise = nalgebra::Vector2::new(standard_normal(&mut rng), standard_normal(&mut rng));
        let q = if p1.len() < 60 {
            Point2::new(rng.random_range(0.0..639.0), rng.random_range(0.0..479.0))
        } else {
            q + noise * 0.5
        };
        p1.push(px);
        p2.push(q);
    }
    let x1: Vec<Vector3<f64>> = p1
        .iter()
        .map(|p| camera.normalized(p).expect("n").push(1.0))
        .collect();
    let x2: Vec<Vector3<f64>> = p2
        .iter()
        .map(|p| camera.normalized(p).expect("n").push(1.0))
        .collect();
    let a: [Vector3<f64>; 5] = core::array::from_fn(|i| x1[60 + i]);
    let b: [Vector3<f64>; 5] = core::array::from_fn(|i| x2[60 + i]);
    c.bench_function("essential/five_point (one minimal sample)", |bn| {
        bn.iter(|| five_point(black_box(&a), black_box(&b)))
    });
    let cfg = EssentialRansacConfig::default();
    c.bench_function("essential/ransac 200 corr, 0.5 px, 30% outliers", |bn| {
        bn.iter(|| ransac_essential(black_box(&p1), &p2, &camera, &cfg).expect("ransac"))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench_track, bench_essential
}
criterion_main!(benches);
