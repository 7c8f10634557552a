//! `weights.safetensors`, loaded into a tiny compact backbone (one 2-channel block,
//! descriptors of length 4) on the CPU backend.
#![no_main]

use endoloc_net::BackboneConfig;
use endoloc_net::preprocess::InputSize;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let cfg = BackboneConfig::Compact {
        input: InputSize {
            width: 16,
            height: 16,
        },
        channels: vec![2],
        descriptor_dim: 4,
        stem_stride: 2,
        pooling: Default::default(),
    };
    let device = endoloc_net::device::cpu();
    let _ = endoloc_net::model::load_weights_from_bytes(
        &cfg,
        Path::new("weights.safetensors"),
        data.to_vec(),
        &device,
    );
});
