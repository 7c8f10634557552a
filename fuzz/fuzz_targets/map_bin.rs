//! A map: `map.bin` with a fixed valid `map.toml` (input without a NUL byte), or a `map.toml`
//! and a `map.bin` separated by the first NUL byte.
#![no_main]

use endoloc_localize::map_io::parse_map;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

const MAP_TOML: &str = include_str!("map.toml");

fuzz_target!(|data: &[u8]| {
    let (toml, bin) = match data.iter().position(|&b| b == 0) {
        Some(i) => match std::str::from_utf8(&data[..i]) {
            Ok(t) => (t, &data[i + 1..]),
            Err(_) => return,
        },
        None => (MAP_TOML, data),
    };
    let _ = parse_map(Path::new("map.toml"), toml, Path::new("map.bin"), bin);
});
