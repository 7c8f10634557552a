//! Synthetic blobs at known positions and scales are found there, at that scale.

use endoloc_features::{BLOB_SIGMA_PER_SCALE, Keypoint, SurfConfig};
use image::GrayImage;

/// A `size × size` grey image with one Gaussian blob of standard deviation `sigma` px centred
/// at `(cx, cy)`; `dark` makes it darker than the background.
fn blob_image(size: u32, cx: f32, cy: f32, sigma: f32, dark: bool) -> GrayImage {
    GrayImage::from_fn(size, size, |x, y| {
        let (dx, dy) = (x as f32 - cx, y as f32 - cy);
        let g = (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
        let v = if dark {
            200.0 - 150.0 * g
        } else {
            50.0 + 150.0 * g
        };
        image::Luma([(v + 0.5) as u8])
    })
}

fn strongest(kps: &[Keypoint]) -> Keypoint {
    *kps.iter()
        .max_by(|a, b| a.response.total_cmp(&b.response))
        .expect("at least one keypoint")
}

#[test]
fn blobs_are_found_at_their_position_and_scale() {
    let surf = SurfConfig::default().with_parallel(false).init().unwrap();
    // The SURF σ of a filter is 1.2·L/9; a Gaussian blob of σ_b peaks at L ≈ 5.3·σ_b, so the
    // reported scale is σ_b / BLOB_SIGMA_PER_SCALE. Blob σ 2.5 … 16 spans octaves 0–2.
    for (sigma, cx, cy, dark) in [
        (2.5f32, 60.3f32, 58.6f32, true),
        (4.0, 61.0, 59.5, false),
        (6.0, 64.4, 63.2, true),
        (9.0, 100.0, 101.7, false),
        (16.0, 128.2, 127.4, true),
    ] {
        let size = if sigma < 8.0 { 128 } else { 256 };
        let img = blob_image(size, cx, cy, sigma, dark);
        let kps = surf.detect(&img).unwrap();
        let k = strongest(&kps);
        let pos_err = ((k.x - cx).powi(2) + (k.y - cy).powi(2)).sqrt();
        let scale_ratio = k.scale * BLOB_SIGMA_PER_SCALE / sigma;
        assert!(pos_err < 0.1, "σ_b {sigma}: position error {pos_err} px");
        // One keypoint per blob (a second, weaker one may come from the next octave).
        assert!(
            (1..=2).contains(&kps.len()),
            "σ_b {sigma}: {} keypoints",
            kps.len()
        );
        assert!(
            (0.94..1.06).contains(&scale_ratio),
            "σ_b {sigma}: blob σ {} vs {sigma}",
            k.blob_sigma()
        );
        assert_eq!(
            k.laplacian,
            if dark { 1 } else { -1 },
            "σ_b {sigma}: Laplacian sign"
        );
    }
}

/// A 256 × 256 grid of blobs of different contrast, scaled by `gain`.
fn blob_grid(gain: f32) -> GrayImage {
    GrayImage::from_fn(256, 256, |x, y| {
        let (cx, cy) = ((x / 32) as f32 * 32.0 + 16.0, (y / 32) as f32 * 32.0 + 16.0);
        let contrast = 40.0 + 20.0 * ((x / 32 + 3 * (y / 32)) % 8) as f32;
        let (dx, dy) = (x as f32 - cx, y as f32 - cy);
        let g = (-(dx * dx + dy * dy) / (2.0 * 16.0)).exp();
        image::Luma([(gain * (60.0 + contrast * g)) as u8])
    })
}

#[test]
fn a_keypoint_budget_keeps_a_dim_frame_its_keypoints() {
    let count = |cfg: SurfConfig, img: &GrayImage| cfg.init().unwrap().detect(img).unwrap().len();
    let (bright, dim) = (blob_grid(1.0), blob_grid(0.3));
    // A fixed threshold loses most of the dim frame's keypoints.
    let fixed = SurfConfig::default().with_threshold(400.0);
    let (b, d) = (count(fixed.clone(), &bright), count(fixed, &dim));
    assert!(b > 20 && d * 2 < b, "fixed threshold: {b} bright, {d} dim");
    // A budget of 0.1 · √(256 · 256) = 26 keypoints above a low threshold keeps both frames to
    // the same count; a fixed cap below it wins.
    let budget = SurfConfig::default()
        .with_threshold(5.0)
        .with_keypoint_budget(0.1);
    assert_eq!(budget.keypoint_cap(256, 256), Some(26));
    assert_eq!(
        budget.keypoint_cap(1024, 1024),
        Some(102),
        "grows with the side"
    );
    assert_eq!(count(budget.clone(), &bright), 26);
    assert_eq!(count(budget.clone(), &dim), 26);
    assert_eq!(count(budget.with_max_keypoints(10), &dim), 10);
    assert_eq!(SurfConfig::default().keypoint_cap(256, 256), None);
    assert!(
        SurfConfig::default()
            .with_keypoint_budget(-1.0)
            .init()
            .is_err()
    );
}

#[test]
fn max_keypoints_keeps_the_strongest() {
    // A grid of blobs of different contrast: the cap must keep the highest responses.
    let img = blob_grid(1.0);
    let all = SurfConfig::default()
        .with_threshold(50.0)
        .init()
        .unwrap()
        .detect_and_describe(&img)
        .unwrap();
    assert!(
        all.len() > 20,
        "the grid gives many keypoints ({})",
        all.len()
    );
    let capped = SurfConfig::default()
        .with_threshold(50.0)
        .with_max_keypoints(10)
        .init()
        .unwrap()
        .detect_and_describe(&img)
        .unwrap();
    assert_eq!(capped.len(), 10);
    let mut responses: Vec<f32> = all.iter().map(|f| f.keypoint.response.abs()).collect();
    responses.sort_by(|a, b| b.total_cmp(a));
    let weakest_kept = capped
        .iter()
        .map(|f| f.keypoint.response.abs())
        .fold(f32::INFINITY, f32::min);
    assert!(
        weakest_kept >= responses[9] - 1e-6,
        "{weakest_kept} vs {}",
        responses[9]
    );
}
