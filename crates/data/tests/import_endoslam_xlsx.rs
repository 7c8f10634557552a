//! EndoSLAM ex-vivo poses read directly from `.xlsx` workbooks (feature `xlsx`): poses joined
//! on ImageFrame and converted with the given units, sheet choice, and errors naming the file,
//! the sheet, the row and the cell. Workbooks are written at test time (tests/support/xlsx.rs).
#![cfg(feature = "xlsx")]

use endoloc_data::DataError;
use endoloc_data::import::endoslam::{EndoSlamConfig, Units, read_endoslam};
use endoloc_geometry::{Camera, Distortion};
use nalgebra::{UnitQuaternion, Vector3};
mod support;

use std::path::{Path, PathBuf};
use support::xlsx::{Workbook, Worksheet};

fn camera() -> Camera {
    Camera {
        width: 8,
        height: 6,
        fx: 5.0,
        fy: 5.0,
        cx: 3.5,
        cy: 2.5,
        distortion: Distortion::None,
    }
}

fn truth(i: usize) -> (Vector3<f64>, UnitQuaternion<f64>) {
    (
        Vector3::new(0.0123 * i as f64, -0.0456, 0.00789 * i as f64 + 0.1),
        UnitQuaternion::from_euler_angles(0.2, 0.1 * i as f64, -0.3),
    )
}

const HEADER: [&str; 9] = [
    "ImageFrame",
    "Pose_Index",
    "trans_x",
    "trans_y",
    "trans_z",
    "quot_x",
    "quot_y",
    "quot_z",
    "quot_w",
];

/// A recording folder with `Frames/0000.png … 0005.png` (grey 30·i).
fn recording(tmp: &Path) -> PathBuf {
    let src = tmp.join("ExVivo_Colon");
    std::fs::create_dir_all(src.join("Frames")).unwrap();
    for i in 0..6 {
        image::GrayImage::from_pixel(8, 6, image::Luma([30 * i as u8]))
            .save(src.join(format!("Frames/{i:04}.png")))
            .unwrap();
    }
    src
}

/// Writes the pose table on `ws` with its header at spreadsheet row `row0` (0-based) and
/// column `col0`: rows for frames 3, 1, 2, 5 (out of order; 0 and 4 have no pose). The
/// quaternion of frame 2 is negated (same rotation). Frame 5's ImageFrame is the text
/// "0005.png" (a file name), the others are numbers.
fn pose_table(ws: &mut Worksheet, row0: u32, col0: u16) {
    for (k, h) in HEADER.iter().enumerate() {
        ws.write_string(row0, col0 + k as u16, h);
    }
    for (r, i) in [3usize, 1, 2, 5].into_iter().enumerate() {
        let row = row0 + 1 + r as u32;
        let (t, q) = truth(i);
        let s = if i == 2 { -1.0 } else { 1.0 };
        if i == 5 {
            ws.write_string(row, col0, "0005.png");
        } else {
            ws.write_number(row, col0, i as f64);
        }
        let vals = [r as f64, t.x, t.y, t.z, s * q.i, s * q.j, s * q.k, s * q.w];
        for (k, v) in vals.into_iter().enumerate() {
            ws.write_number(row, col0 + 1 + k as u16, v);
        }
    }
}

/// A workbook with a first sheet "Notes" (no pose table) and a sheet "Poses" whose table
/// starts at B3 (row 1 empty, row 2 a blank row too).
fn workbook(path: &Path) {
    let mut wb = Workbook::new();
    let notes = wb.add_worksheet();
    notes.set_name("Notes");
    notes.write_string(
        0,
        0,
        "Colon-IV recording, Olympus, poses from the magnetic tracker",
    );
    let ws = wb.add_worksheet();
    ws.set_name("Poses");
    pose_table(ws, 2, 1);
    wb.save(path);
}

fn config(poses: &Path, units: Units) -> EndoSlamConfig {
    EndoSlamConfig {
        poses: Some(poses.to_path_buf()),
        fps: 10.0,
        ..EndoSlamConfig::new(camera(), units)
    }
}

#[test]
fn xlsx_poses_join_on_image_frame_with_the_given_units() {
    let tmp = tempfile::tempdir().unwrap();
    let src = recording(tmp.path());
    let xlsx = tmp.path().join("poses.xlsx");
    workbook(&xlsx);
    for (units, mm) in [(Units::M, 1000.0), (Units::Mm, 1.0), (Units::Cm, 10.0)] {
        let seq = read_endoslam(&src, &config(&xlsx, units)).unwrap();
        let got: Vec<usize> = seq
            .frames
            .iter()
            .map(|f| {
                let name = f.image.file_stem().unwrap().to_str().unwrap();
                name.parse().unwrap()
            })
            .collect();
        assert_eq!(got, vec![1, 2, 3, 5], "frames 0 and 4 have no pose");
        assert!(
            seq.notes
                .iter()
                .any(|n| n.contains("2 frames without a pose")),
            "{:?}",
            seq.notes
        );
        for (f, i) in seq.frames.iter().zip(got) {
            let (t, q) = truth(i);
            let p = &f.pose.pose;
            assert!(
                (p.translation.vector - mm * t).norm() < 1e-9 * mm,
                "frame {i}: {} vs {}",
                p.translation.vector,
                mm * t
            );
            assert!(
                endoloc_geometry::so3::geodesic_distance(&p.rotation, &q) < 1e-12,
                "frame {i}"
            );
            assert!(p.rotation.w >= 0.0, "canonical quaternion");
            assert!((f.pose.timestamp_s - i as f64 / 10.0).abs() < 1e-12);
        }
    }

    // The same table exported to CSV gives the same poses.
    let mut csv = HEADER.join(",") + "\n";
    for (r, i) in [3usize, 1, 2, 5].into_iter().enumerate() {
        let (t, q) = truth(i);
        let s = if i == 2 { -1.0 } else { 1.0 };
        let key = if i == 5 {
            "0005.png".into()
        } else {
            i.to_string()
        };
        csv += &format!(
            "{key},{r},{},{},{},{},{},{},{}\n",
            t.x,
            t.y,
            t.z,
            s * q.i,
            s * q.j,
            s * q.k,
            s * q.w
        );
    }
    let csv_path = tmp.path().join("poses.csv");
    std::fs::write(&csv_path, csv).unwrap();
    let a = read_endoslam(&src, &config(&xlsx, Units::Mm)).unwrap();
    let b = read_endoslam(&src, &config(&csv_path, Units::Mm)).unwrap();
    assert_eq!(a.poses(), b.poses());
}

#[test]
fn xlsx_is_found_in_poses_folder_and_sheet_can_be_named() {
    let tmp = tempfile::tempdir().unwrap();
    let src = recording(tmp.path());
    std::fs::create_dir_all(src.join("Poses")).unwrap();
    workbook(&src.join("Poses/Colon-IV.xlsx"));
    let seq = read_endoslam(&src, &EndoSlamConfig::new(camera(), Units::Mm)).unwrap();
    assert_eq!(seq.frames.len(), 4);

    let xlsx = src.join("Poses/Colon-IV.xlsx");
    let named = EndoSlamConfig {
        sheet: Some("Poses".into()),
        fps: 30.0,
        ..config(&xlsx, Units::Mm)
    };
    assert_eq!(read_endoslam(&src, &named).unwrap().poses(), seq.poses());

    // Naming the sheet without a table: the missing columns, with file, sheet and row.
    let notes = EndoSlamConfig {
        sheet: Some("Notes".into()),
        ..config(&xlsx, Units::Mm)
    };
    let e = read_endoslam(&src, &notes).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("Colon-IV.xlsx")
            && m.contains("sheet \"Notes\" row 1")
            && m.contains("no column \"imageframe\""),
        "{m}"
    );

    let missing = EndoSlamConfig {
        sheet: Some("Sheet9".into()),
        ..config(&xlsx, Units::Mm)
    };
    let m = read_endoslam(&src, &missing).unwrap_err().to_string();
    assert!(
        m.contains("Colon-IV.xlsx")
            && m.contains("no sheet \"Sheet9\"")
            && m.contains("\"Notes\", \"Poses\""),
        "{m}"
    );
}

/// Writes a one-sheet ("Poses", table at A1) workbook, then lets `edit` change it.
fn edited(path: &Path, edit: impl FnOnce(&mut Worksheet)) {
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    ws.set_name("Poses");
    pose_table(ws, 0, 0);
    edit(ws);
    wb.save(path);
}

fn error_of(src: &Path, xlsx: &Path) -> DataError {
    read_endoslam(src, &config(xlsx, Units::Mm)).unwrap_err()
}

#[test]
fn bad_cells_name_the_file_sheet_row_and_column() {
    let tmp = tempfile::tempdir().unwrap();
    let src = recording(tmp.path());
    let xlsx = tmp.path().join("bad.xlsx");

    // Non-numeric cell: trans_y (column D) of spreadsheet row 3.
    edited(&xlsx, |ws| {
        ws.write_string(2, 3, "n/a");
    });
    let e = error_of(&src, &xlsx);
    let m = e.to_string();
    assert!(matches!(e, DataError::Parse { line: 3, .. }), "{m}");
    assert!(
        m.contains("bad.xlsx:3")
            && m.contains("sheet \"Poses\" row 3, cell D3 (trans_y)")
            && m.contains("\"n/a\" is not a number"),
        "{m}"
    );

    // A boolean cell: quot_z (column H) of row 4.
    edited(&xlsx, |ws| {
        ws.write_boolean(3, 7, true);
    });
    let m = error_of(&src, &xlsx).to_string();
    assert!(
        m.contains("sheet \"Poses\" row 4, cell H4 (quot_z)") && m.contains("not a number"),
        "{m}"
    );

    // An empty cell inside the table: trans_z (column E) of row 5.
    edited(&xlsx, |ws| {
        ws.write_blank(4, 4);
    });
    let m = error_of(&src, &xlsx).to_string();
    assert!(
        m.contains("sheet \"Poses\" row 5, cell E5 (trans_z)") && m.contains("empty"),
        "{m}"
    );

    // Missing column: quot_w's header renamed.
    edited(&xlsx, |ws| {
        ws.write_string(0, 8, "w");
    });
    let m = error_of(&src, &xlsx).to_string();
    assert!(
        m.contains("bad.xlsx:1")
            && m.contains("sheet \"Poses\" row 1 (header)")
            && m.contains("no column \"quot_w\""),
        "{m}"
    );

    // A quaternion that is not unit: named with the sheet and row.
    edited(&xlsx, |ws| {
        for c in 5..9 {
            ws.write_number(3, c, 0.8);
        }
    });
    let m = error_of(&src, &xlsx).to_string();
    assert!(
        m.contains("bad.xlsx:4") && m.contains("sheet \"Poses\" row 4") && m.contains("norm 1.6"),
        "{m}"
    );

    // The same frame twice.
    edited(&xlsx, |ws| {
        ws.write_number(3, 0, 3.0);
    });
    let m = error_of(&src, &xlsx).to_string();
    assert!(
        m.contains("bad.xlsx:4: sheet \"Poses\" row 4")
            && m.contains("already has a pose on sheet \"Poses\" row 2"),
        "{m}"
    );
}

#[test]
fn empty_and_broken_workbooks_are_errors_not_panics() {
    let tmp = tempfile::tempdir().unwrap();
    let src = recording(tmp.path());

    // A workbook whose only sheet is empty.
    let empty = tmp.path().join("empty.xlsx");
    let mut wb = Workbook::new();
    wb.add_worksheet().set_name("Poses");
    wb.save(&empty);
    let m = error_of(&src, &empty).to_string();
    assert!(
        m.contains("empty.xlsx") && m.contains("sheet \"Poses\" is empty"),
        "{m}"
    );

    // Only a header: no pose matches a frame.
    let header_only = tmp.path().join("header.xlsx");
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    for (k, h) in HEADER.iter().enumerate() {
        ws.write_string(0, k as u16, h);
    }
    wb.save(&header_only);
    let m = error_of(&src, &header_only).to_string();
    assert!(
        m.contains("header.xlsx") && m.contains("no ImageFrame matches"),
        "{m}"
    );

    // Not a workbook: a few bytes, a zip of something else, a truncated workbook, nothing.
    let good = tmp.path().join("good.xlsx");
    workbook(&good);
    let bytes = std::fs::read(&good).unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("text.xlsx", b"ImageFrame,trans_x\n".to_vec()),
        ("pk.xlsx", b"PK\x03\x04garbage".to_vec()),
        ("truncated.xlsx", bytes[..bytes.len() / 2].to_vec()),
        ("zero.xlsx", Vec::new()),
        (
            "flipped.xlsx",
            bytes
                .iter()
                .enumerate()
                .map(|(i, b)| if i % 97 == 50 { b ^ 0x5a } else { *b })
                .collect(),
        ),
    ];
    for (name, data) in cases {
        let p = tmp.path().join(name);
        std::fs::write(&p, data).unwrap();
        let m = error_of(&src, &p).to_string();
        assert!(m.contains(name), "{name}: {m}");
    }

    // A missing file: an I/O error naming it.
    let m = error_of(&src, &tmp.path().join("absent.xlsx")).to_string();
    assert!(
        m.contains("absent.xlsx") && m.contains("No such file"),
        "{m}"
    );
}

/// A workbook written by openpyxl (the writer behind pandas' `to_excel`), committed with the
/// script that made it (`tests/fixtures/make_endoslam_xlsx.py`): found on its second sheet.
#[test]
fn reads_a_workbook_written_by_openpyxl() {
    let tmp = tempfile::tempdir().unwrap();
    let src = recording(tmp.path());
    let xlsx =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/endoslam_exvivo_openpyxl.xlsx");
    let seq = read_endoslam(&src, &config(&xlsx, Units::Mm)).unwrap();
    assert_eq!(seq.frames.len(), 3);
    for (k, f) in seq.frames.iter().enumerate() {
        let i = k + 1;
        assert!(f.image.ends_with(format!("{i:04}.png")));
        let p = &f.pose.pose;
        let t = Vector3::new(1.5 * i as f64, -2.0, 10.0 + i as f64);
        assert!((p.translation.vector - t).norm() < 1e-12, "frame {i}");
        let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.1 * i as f64);
        assert!(
            endoloc_geometry::so3::geodesic_distance(&p.rotation, &q) < 1e-12,
            "frame {i}"
        );
    }
    let m = read_endoslam(
        &src,
        &EndoSlamConfig {
            sheet: Some("Info".into()),
            ..config(&xlsx, Units::Mm)
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        m.contains("endoslam_exvivo_openpyxl.xlsx:1: sheet \"Info\" row 1 (header)")
            && m.contains("no column \"imageframe\""),
        "{m}"
    );
}
