//! A run's `inliers.csv`, for a sequence of as many frames as the first input byte says.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&frames, rest)) = data.split_first() else {
        return;
    };
    if let Ok(text) = std::str::from_utf8(rest) {
        let _ = endoloc_jobs::localize::parse_inliers_csv(
            Path::new("inliers.csv"),
            text,
            frames as usize,
        );
    }
});
