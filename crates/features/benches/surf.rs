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
    let mut group = c.benchmark_group("match");
    group.sample_size(20);
    for (mode, parallel) in [("single", false), ("parallel", true)] {
        let m = Matcher::new(MatcherConfig::default().with_parallel(parallel));
        group.bench_function(format!("{}x{}/{mode}", a.len(), b.len()), |bch| {
            bch.iter(|| {
                m.match_descriptors(black_box(&a), black_box(&b))
                    .expect("match")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, detect_describe, matching);
criterion_main!(benches);
