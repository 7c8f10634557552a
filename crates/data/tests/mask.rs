//! The image mask of a dataset: `[camera] mask` in `dataset.toml`, written by the dataset
//! writer or added afterwards, validated on load and by `check`.

use endoloc_data::{
    DataError, Dataset, DatasetMeta, DatasetWriter, MASK_FILE, StampedPose, check_dataset,
    write_dataset_mask,
};
use endoloc_geometry::{Camera, Pose};
use image::GrayImage;
use std::path::Path;

const W: u32 = 40;
const H: u32 = 30;

fn circle() -> GrayImage {
    GrayImage::from_fn(W, H, |x, y| {
        let (dx, dy) = (x as f64 - 19.5, y as f64 - 14.5);
        image::Luma([if dx * dx + dy * dy <= 14.0 * 14.0 {
            255
        } else {
            0
        }])
    })
}

fn write(dir: &Path, mask: Option<&GrayImage>) -> Result<(), DataError> {
    let meta = DatasetMeta::new("mask-test", Camera::from_hfov(W, H, 100.0));
    let mut w = DatasetWriter::create(dir, &meta, false)?;
    if let Some(m) = mask {
        w.write_mask(m)?;
    }
    let seq = w.sequence("train")?;
    seq.write_gray(0, W, H, &vec![128; (W * H) as usize])?;
    seq.finish(
        &[StampedPose {
            timestamp_s: 0.0,
            pose: Pose::identity(),
        }],
        None,
    )?;
    w.finish()?;
    Ok(())
}

#[test]
fn a_mask_round_trips_through_dataset_toml() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write(&dir, Some(&circle())).unwrap();
    let text = std::fs::read_to_string(dir.join("dataset.toml")).unwrap();
    assert!(text.contains("mask = \"mask.png\""), "{text}");
    let ds = Dataset::open(&dir).unwrap();
    assert_eq!(ds.meta.mask.as_deref(), Some(MASK_FILE));
    assert_eq!(ds.load_mask().unwrap().unwrap(), circle());
    assert!(check_dataset(&dir).unwrap().is_ok());
}

#[test]
fn a_mask_is_added_once_and_replaced_only_with_force() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write(&dir, None).unwrap();
    assert!(Dataset::open(&dir).unwrap().load_mask().unwrap().is_none());
    write_dataset_mask(&dir, &circle(), false).unwrap();
    assert_eq!(
        Dataset::open(&dir).unwrap().load_mask().unwrap().unwrap(),
        circle()
    );
    let all = GrayImage::from_pixel(W, H, image::Luma([1]));
    let e = write_dataset_mask(&dir, &all, false).unwrap_err();
    assert!(matches!(e, DataError::AlreadyExists { .. }), "{e}");
    write_dataset_mask(&dir, &all, true).unwrap();
    assert_eq!(
        Dataset::open(&dir).unwrap().load_mask().unwrap().unwrap(),
        all
    );
    // Wrong size and all-black masks are refused, naming the file and what was expected.
    let e = write_dataset_mask(&dir, &GrayImage::new(W + 1, H), true)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("mask.png") && e.contains("41×30") && e.contains("40×30"),
        "{e}"
    );
    let e = write_dataset_mask(&dir, &GrayImage::new(W, H), true)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no valid pixel"), "{e}");
}

#[test]
fn check_reports_a_mask_of_the_wrong_size_or_a_path_outside_the_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write(&dir, Some(&circle())).unwrap();
    GrayImage::new(10, 10).save(dir.join(MASK_FILE)).unwrap();
    let report = check_dataset(&dir).unwrap();
    assert!(!report.is_ok());
    let text = report.to_string();
    assert!(
        text.contains("mask.png") && text.contains("10×10"),
        "{text}"
    );
    let e = Dataset::open(&dir)
        .unwrap()
        .load_mask()
        .unwrap_err()
        .to_string();
    assert!(e.contains("10×10"), "{e}");

    let meta = dir.join("dataset.toml");
    let text = std::fs::read_to_string(&meta).unwrap();
    std::fs::write(&meta, text.replace("\"mask.png\"", "\"../elsewhere.png\"")).unwrap();
    let e = Dataset::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("expected a file name inside the dataset folder"),
        "{e}"
    );
}

#[test]
fn frames_load_black_outside_the_mask_wherever_the_sequence_is_opened_from() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write(&dir, Some(&circle())).unwrap();
    // What a recorder leaves in the border: a bright time stamp over the black.
    let raw = GrayImage::from_fn(W, H, |x, y| {
        image::Luma([if x < 6 { 250 } else { (x * 6 + y) as u8 }])
    });
    raw.save(dir.join("train/images/000000.png")).unwrap();
    let mask = circle();
    let expect = |img: &GrayImage| {
        for (x, y, p) in img.enumerate_pixels() {
            let want = if mask.get_pixel(x, y)[0] == 0 {
                0
            } else {
                raw.get_pixel(x, y)[0]
            };
            assert_eq!(p[0], want, "pixel ({x}, {y})");
        }
    };
    let from_dataset = Dataset::open(&dir).unwrap().sequence("train").unwrap();
    expect(&from_dataset.load_gray(0).unwrap());
    let from_folder = endoloc_data::Sequence::open(&dir.join("train")).unwrap();
    expect(&from_folder.load_gray(0).unwrap());
    let rgb = from_folder.load_rgb(0).unwrap();
    for (x, y, p) in rgb.enumerate_pixels() {
        if mask.get_pixel(x, y)[0] == 0 {
            assert_eq!(p.0, [0, 0, 0], "pixel ({x}, {y})");
        }
    }
    // As recorded, on request (finding the mask again).
    assert_eq!(from_folder.unmasked().load_gray(0).unwrap(), raw);
}
