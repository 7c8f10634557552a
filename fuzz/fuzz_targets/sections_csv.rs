//! `sections.csv`: `endoloc_data::parse_sections`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = endoloc_data::parse_sections(Path::new("sections.csv"), text);
    }
});
