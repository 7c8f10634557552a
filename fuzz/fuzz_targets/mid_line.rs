//! GCA mid-line paths: JSON (`.jsn`) when the input starts with `{`, else CSV.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let name = if text.trim_start().starts_with('{') {
        "path.jsn"
    } else {
        "path.csv"
    };
    if let Ok(points) = endoloc_data::parse_path(Path::new(name), text) {
        let _ = endoloc_data::cumulative_length(&points);
    }
});
