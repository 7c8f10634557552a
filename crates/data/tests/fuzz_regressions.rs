//! Regression tests for the inputs that fuzzing (`fuzz/`) found to crash, hang or allocate
//! without bound; each test is named after the bug it pins.

use endoloc_data::DataError;
use endoloc_data::mesh::parse_ply;
use std::path::Path;

/// A PLY header declaring an element without properties and a huge count: reading its items
/// took no bytes, so the reader looped ~7e15 times. It now skips such an element and reports
/// the missing vertices.
#[test]
fn ply_element_without_properties_and_huge_count_does_not_hang() {
    let bytes = b"ply\nformat ascii 1.0\ncomment colon\nelement vertey 7444444444444444\n\
end_header\n+ 0 0\n44444x_indices\nend2\n";
    let e = parse_ply(Path::new("colon.ply"), bytes).unwrap_err();
    assert!(
        matches!(&e, DataError::Parse { path, .. } if path == Path::new("colon.ply")),
        "{e}"
    );
    assert!(e.to_string().contains("element vertex"), "{e}");
}

/// A PLY header claiming 10^11 vertices over a few bytes of body: room was reserved for up
/// to 2^24 vertices (400 MB) before the first was read. Now only what the rest of the file
/// can hold is reserved, and the file is reported truncated.
#[test]
fn ply_huge_vertex_count_reserves_only_what_the_file_holds() {
    let bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 100000000000\n\
property float x\nproperty float y\nproperty float z\nelement face 1\n\
property list uchar int vertex_indices\nend_header\n\0\0\0\0";
    let e = parse_ply(Path::new("colon.ply"), bytes).unwrap_err();
    assert!(e.to_string().starts_with("colon.ply"), "{e}");
}

