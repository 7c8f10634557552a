//! Dataset writing speed: one 640×480 frame (RGB PNG, grey PNG, 16-bit depth PNG) per
//! iteration, single-threaded, with texture-like content (smooth shading plus fine detail, as
//! rendered colon images have). Also TUM writing and reading of 2610 poses.
//!
//! `cargo bench -p endoloc-data --bench write`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use endoloc_data::{DatasetMeta, DatasetWriter, StampedPose, read_tum, write_tum};
use endoloc_geometry::{Camera, Pose};
use nalgebra::{Translation3, UnitQuaternion};
use std::hint::black_box;

const W: u32 = 640;
const H: u32 = 480;

/// A deterministic pseudo-random byte per pixel (no rand dependency needed).
fn hash(x: u32, y: u32) -> u32 {
    let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^ (h >> 12)
}

fn rendered_like_rgb() -> Vec<u8> {
    let mut v = Vec::with_capacity((W * H * 3) as usize);
    for y in 0..H {
        for x in 0..W {
            let dx = x as f32 - W as f32 / 2.0;
            let dy = y as f32 - H as f32 / 2.0;
            let r = (dx * dx + dy * dy).sqrt() / (W as f32 / 2.0);
            let shade = (1.0 - 0.8 * r).clamp(0.05, 1.0);
            let detail = (hash(x / 2, y / 2) % 24) as f32;
            v.push((shade * 200.0 + detail).min(255.0) as u8);
            v.push((shade * 110.0 + detail * 0.6) as u8);
            v.push((shade * 90.0 + detail * 0.5) as u8);
        }
    }
    v
}

fn bench_frames(c: &mut Criterion) {
    let rgb = rendered_like_rgb();
    let gray: Vec<u8> = rgb.chunks(3).map(|p| p[0]).collect();
    let depth: Vec<f32> = (0..W * H)
        .map(|k| 5.0 + ((k % W) as f32 * 0.1) + (k / W) as f32 * 0.05)
        .collect();
    let tmp = tempfile::tempdir().expect("tempdir");
    let meta = DatasetMeta::new("bench", Camera::from_hfov(W, H, 90.0));
    let writer = DatasetWriter::create(&tmp.path().join("ds"), &meta, false).expect("create");
    let seq = writer.sequence("train").expect("sequence");

    let mut g = c.benchmark_group("frame_640x480");
    g.throughput(Throughput::Elements(1));
    g.sample_size(30);
    let mut f = 0usize;
    g.bench_function("write_rgb", |b| {
        b.iter(|| {
            f = (f + 1) % 64;
            seq.write_rgb(f, W, H, black_box(&rgb)).expect("write");
        })
    });
    g.bench_function("write_gray", |b| {
        b.iter(|| {
            f = (f + 1) % 64;
            seq.write_gray(f, W, H, black_box(&gray)).expect("write");
        })
    });
    g.bench_function("write_depth", |b| {
        b.iter(|| {
            f = (f + 1) % 64;
            seq.write_depth(f, W, H, black_box(&depth)).expect("write");
        })
    });
    g.finish();
}

fn bench_tum(c: &mut Criterion) {
    let poses: Vec<StampedPose> = (0..2610)
        .map(|i| StampedPose {
            timestamp_s: i as f64 / 30.0,
            pose: Pose::from_parts(
                Translation3::new(i as f64 * 0.5, 100.0 - i as f64 * 0.1, 3.0),
                UnitQuaternion::from_euler_angles(0.01 * i as f64, 0.2, -0.3),
            ),
        })
        .collect();
    let tmp = tempfile::tempdir().expect("tempdir");
    let path = tmp.path().join("poses.txt");
    let mut g = c.benchmark_group("tum_2610_poses");
    g.sample_size(20);
    g.bench_function("write_tum", |b| {
        b.iter(|| write_tum(&path, black_box(&poses)).expect("write"))
    });
    g.bench_function("read_tum", |b| b.iter(|| read_tum(&path).expect("read")));
    g.finish();
}

criterion_group!(benches, bench_frames, bench_tum);
criterion_main!(benches);
