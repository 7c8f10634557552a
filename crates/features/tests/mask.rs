//! SURF with a mask: no keypoint whose box filter reaches the black outside a circular field
//! stop, while the same image without the mask has many there.

use std::sync::Arc;

use endoloc_features::mask::DETECTOR_REACH_PER_SCALE;
use endoloc_features::{Mask, SurfConfig, texture};
use image::GrayImage;

#[test]
fn no_keypoint_near_or_outside_a_field_stop() {
    let (w, h) = (320u32, 240u32);
    let textured = texture::textured_image(w as usize, h as usize, 11);
    let (cx, cy, r) = (160.0f32, 120.0f32, 110.0f32);
    let inside = |x: u32, y: u32| (x as f32 - cx).powi(2) + (y as f32 - cy).powi(2) <= r * r;
    let image = GrayImage::from_fn(w, h, |x, y| {
        if inside(x, y) {
            *textured.get_pixel(x, y)
        } else {
            image::Luma([0])
        }
    });
    let valid: Vec<bool> = (0..w * h).map(|i| inside(i % w, i / w)).collect();
    let mask = Arc::new(Mask::from_valid(w as usize, h as usize, &valid).unwrap());
    let surf = SurfConfig::default().with_threshold(50.0).init().unwrap();
    let near_edge =
        |x: f32, y: f32, scale: f32| mask.clearance(x, y) < DETECTOR_REACH_PER_SCALE * scale;

    let plain = surf.detect_and_describe(&image).unwrap();
    let at_edge = plain
        .iter()
        .filter(|f| near_edge(f.keypoint.x, f.keypoint.y, f.keypoint.scale))
        .count();
    assert!(
        at_edge >= 10,
        "only {at_edge} keypoints at the stop's edge without a mask"
    );

    let masked = surf.clone().with_mask(Some(mask.clone()));
    let features = masked.detect_and_describe(&image).unwrap();
    assert!(features.len() >= 30, "{} keypoints inside", features.len());
    for f in &features {
        let k = f.keypoint;
        assert!(
            !near_edge(k.x, k.y, k.scale),
            "keypoint {k:?} reaches the black"
        );
        assert!(mask.is_valid(k.x.round() as i64, k.y.round() as i64));
    }
    // Interior keypoints far from the edge keep the descriptor they had without the mask.
    let far = |x: f32, y: f32, s: f32| mask.clearance(x, y) > 25.0 * s;
    let mut same = 0;
    for f in features
        .iter()
        .filter(|f| far(f.keypoint.x, f.keypoint.y, f.keypoint.scale))
    {
        if let Some(p) = plain.iter().find(|p| p.keypoint == f.keypoint) {
            assert_eq!(p.descriptor, f.descriptor);
            same += 1;
        }
    }
    assert!(same >= 5, "{same}");

    // An image of another size is refused with both sizes named.
    let small = GrayImage::new(160, 120);
    let e = masked.detect_and_describe(&small).unwrap_err().to_string();
    assert!(e.contains("320 × 240") && e.contains("160 × 120"), "{e}");
}
