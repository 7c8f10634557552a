//! A model folder's `database.bin` (descriptors of the training frames), for a model of as
//! many zones as the first input byte says.
#![no_main]

use endoloc_net::DescriptorDatabase;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&zones, bytes)) = data.split_first() else {
        return;
    };
    let _ = DescriptorDatabase::from_bytes(Path::new("database.bin"), bytes, zones as usize);
});
