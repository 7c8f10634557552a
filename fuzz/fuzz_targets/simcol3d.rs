//! SimCol3D `cam.txt` (input without a NUL byte), or a `SavedPosition_*.txt` and a
//! `SavedRotationQuaternion_*.txt` (the two texts separated by the first NUL byte).
#![no_main]

use endoloc_data::import::simcol3d::{parse_cam_txt, parse_simcol3d_poses};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match text.split_once('\0') {
        None => {
            let _ = parse_cam_txt(Path::new("cam.txt"), text);
        }
        Some((pos, rot)) => {
            let _ = parse_simcol3d_poses(
                Path::new("SavedPosition_S1.txt"),
                pos,
                Path::new("SavedRotationQuaternion_S1.txt"),
                rot,
            );
        }
    }
});
