//! `dataset.toml`: parsed, validated and written back.
#![no_main]

use endoloc_data::DatasetMeta;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(meta) = DatasetMeta::from_toml_str(Path::new("dataset.toml"), text)
        && meta.validate().is_ok()
    {
        let _ = meta.to_toml_string();
    }
});
