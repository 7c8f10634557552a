//! A model folder's `model.toml`: `ModelConfig::parse`, then the backbone it names.
#![no_main]

use endoloc_net::ModelConfig;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(cfg) = ModelConfig::parse(Path::new("model.toml"), text) {
        let _ = cfg.backbone.name();
    }
});
