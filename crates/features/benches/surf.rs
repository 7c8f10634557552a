//! SURF detect+describe and matching benchmarks.
//!
//! `cargo bench -p endoloc-features --bench surf`
//!
//! Images: a 640 × 480 textured image made here (`texture::textured_image`, seed 1, ≈800
//! keypoints at threshold 200) and, when present, the rendered colon frame
//! `benches/data/colon_640x480.png`.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use endoloc_features::{Feature, Matcher, MatcherConfig, SurfConfig, texture};
use image::GrayImage;

fn images() -> Vec<(&'static str, GrayImage)> {
    let mut v = vec![("textured_640x480", texture::textured_image(640, 480, 1))];
    let colon = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/data/colon_640x480.png");
    match image::open(&colon) {
        Ok(img) => v.push(("colon_640x480", img.to_luma8())),
        Err(e) => eprintln!("note: skipping the colon frame ({}: {e})", colon.display()),
    }
    v
}

fn detect_describe(c: &mut Criterion) {
    let mut group = c.benchmark_group("surf_detect_describe");
    group.sample_size(20);
    for (name, img) in images() {
        for (mode, parallel) in [("single", false), ("parallel", true)] {
            let surf = SurfConfig::default()
                .with_parallel(parallel)
                .init()
                .expect("valid config");
            let n = surf.detect_and_describe(&img).expect("detect").len();
            eprintln!("{name}: {n} keypoints at threshold 200");
            group.bench_function(format!("{name}/{mode}"), |b| {
                b.iter(|| surf.detect_and_describe(black_box(&img)).expect("detect"))
            });
        }
        let upright = SurfConfig::default()
            .with_parallel(false)
            .with_upright(true)
            .init()
            .expect("valid config");
        group.bench_function(format!("{name}/single_upright"), |b| {
            b.iter(|| {
                upright
                    .detect_and_describe(black_box(&img))
                    .expect("detect")
            })
        });
        let detect_only = SurfConfig::default()
            .with_parallel(false)
            .init()
            .expect("valid config");
        group.bench_function(format!("{name}/single_detect_only"), |b| {
            b.iter(|| detect_only.detect(black_box(&img)).expect("detect"))
        });
    }
    group.finish();
}

fn matching(c: &mut Criterion) {
    let surf = SurfConfig::default().init().expect("valid config");
    let a: Vec<Feature> = surf
        .detect_and_describe(&texture::textured_image(640, 480, 1))
        .expect("detect");
    let b: Vec<Feature> = surf
        .detect_and_describe(&texture::textured_image(640, 480, 2))
        .expect("detect");
    // A live frame against three zones of a densified map: 1300 × 4000 descriptors.
    let frame = random_features(1300, 3);
    let map = random_features(4000, 4);
    let mut group = c.benchmark_group("match");
    group.sample_size(20);
    for (q, t) in [(&a, &b), (&frame, &map)] {
        for (mode, parallel) in [("single", false), ("parallel", true)] {
            let m = Matcher::new(MatcherConfig::default().with_parallel(parallel));
            group.bench_function(format!("{}x{}/{mode}", q.len(), t.len()), |bch| {
                bch.iter(|| {
                    m.match_descriptors(black_box(q), black_box(t))
                        .expect("match")
                })
            });
            group.bench_function(format!("{}x{}/{mode}_naive", q.len(), t.len()), |bch| {
                bch.iter(|| {
                    m.match_descriptors_naive(black_box(q), black_box(t))
                        .expect("match")
                })
            });
        }
    }
    group.finish();
}

/// `n` features with random unit 64-d descriptors and random Laplacian signs.
fn random_features(n: usize, seed: u64) -> Vec<Feature> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let kp = endoloc_features::Keypoint {
        x: 0.0,
        y: 0.0,
        scale: 2.0,
        orientation: 0.0,
        response: 100.0,
        laplacian: 1,
        octave: 0,
    };
    (0..n)
        .map(|_| {
            let mut d: Vec<f32> = (0..64).map(|_| rng.random::<f32>() - 0.5).collect();
            let norm = d.iter().map(|v| v * v).sum::<f32>().sqrt();
            d.iter_mut().for_each(|v| *v /= norm);
            Feature {
                keypoint: endoloc_features::Keypoint {
                    laplacian: if rng.random::<bool>() { 1 } else { -1 },
                    ..kp
                },
                descriptor: d,
            }
        })
        .collect()
}

criterion_group!(benches, detect_describe, matching);
criterion_main!(benches);
