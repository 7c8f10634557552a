//! A run's `frames.csv`: `endoloc_eval::parse_frames_csv`, the parsed rows written back, and
//! the line-by-line reader (`FramesCsvReader`), which reads what the whole-file parser reads
//! when the rows are in frame order.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("frames.csv");
    let lines = endoloc_data::fsutil::TextLines::new(path, data);
    let streamed: Result<Vec<_>, _> = endoloc_eval::FramesCsvReader::new(path, lines).collect();
    if let Ok(rows) = endoloc_eval::frames_csv::parse_frames_csv(text, path) {
        let _ = endoloc_eval::frames_csv::format_frames_csv(&rows);
        let ordered = rows.windows(2).all(|w| w[0].frame < w[1].frame);
        if ordered && !text.contains('\r') {
            assert_eq!(streamed.ok(), Some(rows));
        }
    }
});
