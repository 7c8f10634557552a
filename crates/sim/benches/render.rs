//! Rendering throughput: frames per second at 640×480 including PNG encoding, the figure the
//! `paper` preset's run time depends on (issue: ≥ 30 frames/s on 2 cores).
//!
//! `cargo bench -p endoloc-sim --bench render`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use endoloc_sim::appearance::MucosaAtlas;
use endoloc_sim::colon::procedural;
use endoloc_sim::config::{Preset, SimConfig};
use endoloc_sim::render::{RenderScratch, Renderer};
use endoloc_sim::trajectory::PassGenerator;
use rayon::prelude::*;

fn bench_render(c: &mut Criterion) {
    let cfg = SimConfig::preset(Preset::Paper);
    let endoloc_sim::ColonSource::Procedural(colon_cfg) = &cfg.colon else {
        unreachable!("the paper preset uses the procedural colon")
    };
    let colon = procedural::build(colon_cfg).expect("procedural colon");
    let atlas = MucosaAtlas::bake(&colon, &cfg.appearance).expect("atlas");
    let camera = cfg.camera.camera().expect("camera");
    let renderer = Renderer::new(&colon, &atlas, camera, cfg.render.clone()).expect("renderer");
    let mut traj = cfg.train.clone();
    traj.frames = 64;
    let pass = PassGenerator::new(&colon, &traj)
        .expect("pass")
        .generate()
        .expect("pass");

    let mut group = c.benchmark_group("render_640x480");
    group.sample_size(10);
    group.throughput(Throughput::Elements(1));
    let mut scratch = RenderScratch::default();
    let mut k = 0usize;
    group.bench_function("one_frame_single_thread", |b| {
        b.iter(|| {
            k = (k + 1) % pass.poses.len();
            renderer.render(&[(pass.poses[k], pass.s_mm[k])], k as u64, &mut scratch)
        })
    });
    group.bench_function("one_frame_single_thread_with_png", |b| {
        b.iter(|| {
            k = (k + 1) % pass.poses.len();
            let f = renderer.render(&[(pass.poses[k], pass.s_mm[k])], k as u64, &mut scratch);
            encode_png(&f.rgb, camera.width, camera.height)
        })
    });
    group.throughput(Throughput::Elements(pass.poses.len() as u64));
    group.bench_function("64_frames_all_cores_with_png", |b| {
        b.iter(|| {
            (0..pass.poses.len())
                .into_par_iter()
                .map_init(RenderScratch::default, |s, k| {
                    let f = renderer.render(&[(pass.poses[k], pass.s_mm[k])], k as u64, s);
                    encode_png(&f.rgb, camera.width, camera.height)
                })
                .sum::<usize>()
        })
    });
    group.finish();
}

/// PNG-encodes with the same settings as the dataset writer; returns the byte count.
fn encode_png(rgb: &[u8], w: u32, h: u32) -> usize {
    let mut out = Vec::with_capacity(rgb.len());
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    let mut writer = enc.write_header().expect("png header");
    writer.write_image_data(rgb).expect("png data");
    drop(writer);
    out.len()
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
