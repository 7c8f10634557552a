//! A run's `frames.csv`: `endoloc_eval::parse_frames_csv`, and the parsed rows written back.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(rows) = endoloc_eval::frames_csv::parse_frames_csv(text, Path::new("frames.csv")) {
        let _ = endoloc_eval::frames_csv::format_frames_csv(&rows);
    }
});
