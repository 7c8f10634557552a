//! A dataset's PNGs as endoloc reads them: images (grey and RGB), 16-bit depth maps in mm,
//! and the mask checked against a camera.
#![no_main]

use endoloc_geometry::Camera;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("frame.png");
    if let Ok(img) = endoloc_data::decode_png(path, data) {
        let _ = img.to_luma8();
        let _ = img.to_rgb8();
    }
    let _ = endoloc_data::depth_mm_from_png(path, data);
    let camera = Camera::from_hfov(8, 8, 90.0);
    let _ = endoloc_data::mask_from_png(Path::new("mask.png"), data, &camera);
});
