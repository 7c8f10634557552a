//! EndoSLAM pose tables: an `.xlsx` workbook when the input starts like a zip file (`PK`),
//! else CSV text.
#![no_main]

use endoloc_data::import::endoslam::{Units, parse_pose_table};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(
    init: {
        // The workbook reader runs calamine under `catch_unwind` and turns its panics into
        // errors; libFuzzer's hook would abort on them first. With the default hook, a panic
        // that reaches the target still aborts (and is reported), a caught one does not.
        let _ = std::panic::take_hook();
    },
    |data: &[u8]| {
    let name = if data.starts_with(b"PK") {
        "Poses.xlsx"
    } else {
        "Poses.csv"
    };
    let _ = parse_pose_table(Path::new(name), data.to_vec(), None, Units::Mm);
    }
);
