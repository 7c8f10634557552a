//! Regression tests for the inputs that fuzzing (`fuzz/`) found to crash, hang or allocate
//! without bound; each test is named after the bug it pins.

use endoloc_data::DataError;
use endoloc_data::import::endoslam::{Units, parse_pose_table};
use endoloc_data::mesh::parse_ply;
mod support;

use std::path::Path;
use support::xlsx::Workbook;

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

/// A workbook whose sheet has a cell reference with more column letters than a `u32` holds
/// (found by fuzzing; the reader's column arithmetic overflowed, a panic with overflow checks
/// and a wrapped, huge column without). It is an error naming the file.
#[test]
fn xlsx_cell_reference_overflow_is_an_error() {
    let bytes = include_bytes!("fixtures/xlsx_cell_reference_overflow.xlsx").to_vec();
    let e = parse_pose_table(Path::new("Poses.xlsx"), bytes, None, Units::Mm).unwrap_err();
    assert!(e.to_string().starts_with("Poses.xlsx"), "{e}");
}

/// Two cells far apart (A1 and XFD1048576) made the workbook reader build a dense range of
/// 17 billion cells (hundreds of GB). The table now holds only the rows with a value.
#[test]
fn xlsx_cells_far_apart_do_not_allocate_the_range_between_them() {
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    ws.write_string(0, 0, "ImageFrame");
    ws.write_number(1_048_575, 16_383, 1.0);
    let bytes = wb.save_to_buffer();
    let e = parse_pose_table(Path::new("Poses.xlsx"), bytes, None, Units::Mm).unwrap_err();
    assert!(
        matches!(&e, DataError::Parse { path, .. } if path == Path::new("Poses.xlsx")),
        "{e}"
    );
}

/// A sheet whose rows span every column: the table it would make is refused, naming the
/// sheet and its size, instead of being built cell by cell.
#[test]
fn xlsx_table_of_too_many_cells_is_refused() {
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    for row in 0..300 {
        ws.write_number(row, 0, 1.0);
        ws.write_number(row, 16_383, 1.0);
    }
    let bytes = wb.save_to_buffer();
    let e = parse_pose_table(Path::new("Poses.xlsx"), bytes, None, Units::Mm).unwrap_err();
    assert!(matches!(&e, DataError::Invalid { .. }), "{e}");
    let m = e.to_string();
    assert!(
        m.starts_with("Poses.xlsx") && m.contains("300 rows") && m.contains("A to XFD"),
        "{m}"
    );
}
