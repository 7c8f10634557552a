//! `zones.csv`, both of them: a model's zone table (`ZoneTable::parse`) and the zone labels
//! the evaluation reads (`parse_zones_csv`, and `ZonesCsvReader` line by line, which reads
//! the same labels when they are in frame order).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("zones.csv");
    let _ = endoloc_net::ZoneTable::parse(path, text);
    let lines = endoloc_data::fsutil::TextLines::new(path, data);
    let streamed: Result<Vec<_>, _> = endoloc_eval::ZonesCsvReader::new(path, lines).collect();
    if let Ok(labels) = endoloc_eval::zones_csv::parse_zones_csv(text, path) {
        let ordered = labels.windows(2).all(|w| w[0].frame < w[1].frame);
        if ordered && !text.contains('\r') {
            assert_eq!(streamed.ok(), Some(labels));
        }
    }
});
