//! Golden-file test: keypoints of a fixed synthetic image (integer arithmetic only, so the
//! image is bit-identical on every platform) must not drift.
//!
//! Regenerate after an intended change with
//! `UPDATE_GOLDEN=1 cargo test -p endoloc-features --test golden` and review the diff.

use endoloc_features::io::{keypoints_from_csv, keypoints_to_csv};
use endoloc_features::{Keypoint, SurfConfig};
use image::GrayImage;

/// Discs of radius 3…12 px, dark and bright, on a 192 × 160 background with a gentle ramp,
/// then a 3 × 3 box blur (integer).
/// (centre x, centre y, radius, intensity change) of the discs.
const DISCS: [(i64, i64, i64, i64); 9] = [
    (30, 30, 4, -90),
    (80, 35, 7, 80),
    (145, 40, 10, -70),
    (35, 95, 12, 60),
    (100, 90, 5, 100),
    (150, 105, 8, -60),
    (60, 135, 3, 110),
    (120, 135, 6, -100),
    (170, 140, 4, 90),
];

fn golden_image() -> GrayImage {
    let (w, h) = (192i64, 160i64);
    let raw: Vec<i64> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut v = 110 + x / 8 + y / 10;
            for &(cx, cy, r, a) in &DISCS {
                if (x - cx).pow(2) + (y - cy).pow(2) <= r * r {
                    v += a;
                }
            }
            v
        })
        .collect();
    GrayImage::from_fn(w as u32, h as u32, |x, y| {
        let (x, y) = (i64::from(x), i64::from(y));
        let mut s = 0;
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (xx, yy) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                s += raw[(yy * w + xx) as usize];
            }
        }
        image::Luma([(s / 9).clamp(0, 255) as u8])
    })
}

#[test]
fn keypoints_of_the_golden_image_match_the_golden_file() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden_keypoints.csv");
    let surf = SurfConfig::default().with_parallel(false).init().unwrap();
    let got = surf.detect(&golden_image()).unwrap();
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&path, keypoints_to_csv(&got)).unwrap();
    }
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run with UPDATE_GOLDEN=1 to create it)",
            path.display()
        )
    });
    let want: Vec<Keypoint> = keypoints_from_csv(&text, &path.display().to_string()).unwrap();
    // Every disc of radius ≥ 4 px is found at its centre, with the right Laplacian sign
    // (radius 3 is below the smallest detectable scale); the ramp produces no keypoints.
    for &(cx, cy, r, a) in DISCS.iter().filter(|d| d.2 >= 4) {
        let hit = got.iter().any(|k| {
            (k.x - cx as f32).hypot(k.y - cy as f32) < 0.1
                && k.laplacian == if a < 0 { 1 } else { -1 }
        });
        assert!(hit, "disc at ({cx}, {cy}) radius {r} not detected");
    }
    assert!(got.iter().all(|k| {
        DISCS
            .iter()
            .any(|d| (k.x - d.0 as f32).hypot(k.y - d.1 as f32) < 0.2)
    }));
    assert_eq!(got.len(), want.len(), "keypoint count changed");
    for (g, w) in got.iter().zip(&want) {
        let close = |a: f32, b: f32, tol: f32| (a - b).abs() <= tol * (1.0 + b.abs());
        assert!(
            close(g.x, w.x, 1e-4) && close(g.y, w.y, 1e-4) && close(g.scale, w.scale, 1e-4),
            "position/scale drifted: got {g:?}, golden {w:?}"
        );
        assert!(
            close(g.response, w.response, 1e-3),
            "response drifted: got {g:?}, golden {w:?}"
        );
        assert!(
            close(g.orientation, w.orientation, 1e-3),
            "orientation drifted: got {g:?}, golden {w:?}"
        );
        assert_eq!(
            (g.laplacian, g.octave),
            (w.laplacian, w.octave),
            "got {g:?}, golden {w:?}"
        );
    }
}
