//! C3VD `pose.txt`: `endoloc_data::import::c3vd::parse_c3vd_poses`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = endoloc_data::import::c3vd::parse_c3vd_poses(Path::new("pose.txt"), text);
    }
});
