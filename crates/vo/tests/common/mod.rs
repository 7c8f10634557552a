//! A short simulated sequence rendered in memory (the `small` preset's colon and camera,
//! 320×240, 90° field of view, with the `paper` preset's frame density along the pass).

use endoloc_geometry::{Camera, Pose};
use endoloc_sim::appearance::MucosaAtlas;
use endoloc_sim::config::{Preset, SimConfig};
use endoloc_sim::render::{RenderScratch, Renderer};
use endoloc_sim::simulate::build_colon;
use endoloc_sim::trajectory::PassGenerator;
use image::{GrayImage, RgbImage};

/// A rendered sequence with its ground truth.
pub struct Sequence {
    pub camera: Camera,
    pub images: Vec<GrayImage>,
    pub poses: Vec<Pose>,
}

/// Renders `count` consecutive frames starting at `first` of a 2610-frame pass (about
/// 0.6 mm of travel per frame, as the paper's 30 fps sequences).
pub fn render_sequence(first: usize, count: usize) -> Sequence {
    let mut cfg = SimConfig::preset(Preset::Small).with_seed(3);
    cfg.test.frames = 2610;
    let colon = build_colon(&cfg).expect("colon");
    let atlas = MucosaAtlas::bake(&colon, &cfg.appearance).expect("atlas");
    let camera = cfg.camera.camera().expect("camera");
    let renderer = Renderer::new(&colon, &atlas, camera, cfg.render.clone()).expect("renderer");
    let pass = PassGenerator::new(&colon, &cfg.test).expect("pass");
    let mut scratch = RenderScratch::default();
    let mut images = Vec::with_capacity(count);
    let mut poses = Vec::with_capacity(count);
    for k in first..first + count {
        let (pose, s, _) = pass.pose_at(k as f64);
        let frame = renderer.render(&[(pose, s)], k as u64, &mut scratch);
        let rgb = RgbImage::from_raw(camera.width, camera.height, frame.rgb).expect("size");
        images.push(image::DynamicImage::ImageRgb8(rgb).to_luma8());
        poses.push(pose);
    }
    Sequence {
        camera,
        images,
        poses,
    }
}
