//! TUM trajectory text (`poses.txt`, `trajectory.txt`): `endoloc_data::parse_tum`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = endoloc_data::parse_tum(Path::new("poses.txt"), text);
    }
});
