//! Regression tests for the inputs that fuzzing (`fuzz/`) found to crash, hang or allocate
//! without bound; each test is named after the bug it pins.

use endoloc_net::NetError;
use endoloc_net::whiten::Whitening;
use std::path::Path;

/// A `whitening.bin` whose header states a descriptor length near 2^32: the expected file
/// size `16 + 4 (d + d²)` overflowed (a panic with overflow checks). It is now computed
/// without overflow and the file is reported as the wrong size.
#[test]
fn whitening_huge_dimension_does_not_overflow() {
    let bytes: [u8; 40] = [
        0x45, 0x4c, 0x57, 0x48, 0x49, 0x54, 0x45, 0x31, 0x02, 0x00, 0xcc, 0xcc, 0x3d, 0x00, 0x80,
        0x3e, 0xcd, 0xcc, 0xcc, 0x3d, 0xcd, 0xcc, 0x4c, 0xbe, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00,
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f,
    ];
    let dim = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
    let e = Whitening::from_bytes(Path::new("whitening.bin"), &bytes, dim).unwrap_err();
    assert!(matches!(&e, NetError::Parse { .. }), "{e}");
    assert!(e.to_string().contains("whitening.bin"), "{e}");
}

/// A `whitening.bin` for descriptors of length 0 loaded, and applying it then panicked
/// (`chunks_exact(0)`). Such a file is now refused.
#[test]
fn whitening_of_length_zero_is_refused() {
    let mut bytes = b"ELWHITE1".to_vec();
    bytes.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 0x10]);
    let e = Whitening::from_bytes(Path::new("whitening.bin"), &bytes, 0).unwrap_err();
    assert!(e.to_string().contains("whitening.bin"), "{e}");
    assert!(e.to_string().contains("length 0"), "{e}");
}
