//! GCA model configuration JSON: the landmarks, then the section cut they give.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(landmarks) = endoloc_data::parse_gca_landmarks(Path::new("model.json"), text) {
        let n = landmarks.iter().map(|l| l.path_index).max().unwrap_or(0);
        let _ = endoloc_data::section_cut(n.saturating_add(1).min(1 << 20), &landmarks);
    }
});
