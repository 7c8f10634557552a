//! Renders a contact sheet of frames along a pass, to look at the simulator's output.
//!
//! `cargo run --release -p endoloc-sim --example preview -- OUT.png [small|paper] [seed] [GCA_DIR]`

use endoloc_sim::appearance::MucosaAtlas;
use endoloc_sim::colon::from_mesh::MeshColonConfig;
use endoloc_sim::config::{Preset, SimConfig};
use endoloc_sim::render::{RenderScratch, Renderer};
use endoloc_sim::simulate::build_colon;
use endoloc_sim::trajectory::PassGenerator;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = args.get(1).map_or("preview.png", String::as_str);
    let preset: Preset = args.get(2).map_or("paper", String::as_str).parse()?;
    let seed: u64 = args.get(3).map_or(Ok(0), |s| s.parse())?;
    let mut cfg = SimConfig::preset(preset).with_seed(seed);
    if let Some(dir) = args.get(4) {
        cfg = cfg.with_mesh_colon(MeshColonConfig::from_gca_folder(std::path::Path::new(dir))?);
    }
    let t = std::time::Instant::now();
    let colon = build_colon(&cfg)?;
    eprintln!("{} in {:.2?}", colon.description, t.elapsed());
    let t = std::time::Instant::now();
    let atlas = MucosaAtlas::bake(&colon, &cfg.appearance)?;
    eprintln!(
        "atlas {} MB in {:.2?}",
        atlas.bytes() / 1_000_000,
        t.elapsed()
    );
    let camera = cfg.camera.camera()?;
    let renderer = Renderer::new(&colon, &atlas, camera, cfg.render.clone())?;
    let t = std::time::Instant::now();
    let pass = PassGenerator::new(&colon, &cfg.train)?.generate()?;
    eprintln!("pass of {} frames in {:.2?}", pass.poses.len(), t.elapsed());
    let (cols, rows) = (4u32, 4u32);
    let (w, h) = (camera.width, camera.height);
    let mut sheet = image::RgbImage::new(w * cols, h * rows);
    let mut scratch = RenderScratch::default();
    let n = pass.poses.len();
    let t = std::time::Instant::now();
    for k in 0..(cols * rows) as usize {
        let f = k * (n - 1) / (cols * rows - 1) as usize;
        let frame = renderer.render(&[(pass.poses[f], pass.s_mm[f])], f as u64, &mut scratch);
        let img = image::RgbImage::from_raw(w, h, frame.rgb).ok_or("frame size")?;
        let (cx, cy) = ((k as u32 % cols) * w, (k as u32 / cols) * h);
        image::imageops::replace(&mut sheet, &img, cx as i64, cy as i64);
        eprintln!(
            "frame {f}: s = {:.0} mm, {}, clearance {:.1} mm",
            pass.s_mm[f], pass.sections[f], pass.clearance_mm[f]
        );
    }
    eprintln!("{} frames in {:.2?}", cols * rows, t.elapsed());
    sheet.save(out)?;
    Ok(())
}
