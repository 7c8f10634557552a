//! A model folder's `whitening.bin`, read for a backbone whose descriptor length is the one
//! the file's header states (so that any header is looked at).
#![no_main]

use endoloc_net::whiten::Whitening;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let dim = match data.get(8..12) {
        Some(w) => u32::from_le_bytes([w[0], w[1], w[2], w[3]]) as usize,
        None => 4,
    };
    if let Ok(w) = Whitening::from_bytes(Path::new("whitening.bin"), data, dim)
        && dim <= 64
    {
        let _ = w.apply(&vec![1.0; dim]);
    }
});
