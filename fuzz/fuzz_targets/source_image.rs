//! Importers' source images and depth maps (PNG, TIFF, JPEG…, format from the content).
#![no_main]

use endoloc_data::import::{DepthEncoding, decode_source_image, source_depth_mm};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("0000_depth.tiff");
    if let Ok(img) = decode_source_image(path, data) {
        let _ = img.to_luma8();
    }
    let enc = DepthEncoding {
        mm_per_unit: 100.0 / 65535.0,
        invalid_value: Some(65535),
    };
    let _ = source_depth_mm(path, data, enc);
});
