//! TUM trajectory text (`poses.txt`, `trajectory.txt`): `endoloc_data::parse_tum`, and the
//! line-by-line reader (`TumReader`) over the raw bytes, which must agree with it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("poses.txt");
    let lines = endoloc_data::fsutil::TextLines::new(path, data);
    let streamed: Result<Vec<_>, _> = endoloc_data::TumReader::new(path, lines).collect();
    if let Ok(text) = std::str::from_utf8(data) {
        let whole = endoloc_data::parse_tum(path, text);
        // A lone '\r' before a line break is a line end for `str::lines` only.
        if !text.contains('\r') {
            match (&whole, &streamed) {
                (Ok(a), Ok(b)) => assert_eq!(a, b),
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                _ => panic!("whole {whole:?} vs streamed {streamed:?}"),
            }
        }
    }
});
