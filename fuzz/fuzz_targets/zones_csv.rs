//! `zones.csv`, both of them: a model's zone table (`ZoneTable::parse`) and the zone labels
//! the evaluation reads (`parse_zones_csv`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("zones.csv");
    let _ = endoloc_net::ZoneTable::parse(path, text);
    let _ = endoloc_eval::zones_csv::parse_zones_csv(text, path);
});
