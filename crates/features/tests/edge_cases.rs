//! Degenerate inputs: zero keypoints or a clear error, never a panic.

use endoloc_features::{FeatureError, SurfConfig, texture};
use image::GrayImage;

fn surf() -> endoloc_features::Surf {
    SurfConfig::default().with_parallel(false).init().unwrap()
}

#[test]
fn black_and_constant_images_have_no_keypoints() {
    for v in [0u8, 128, 255] {
        let img = GrayImage::from_pixel(320, 240, image::Luma([v]));
        assert!(
            surf().detect_and_describe(&img).unwrap().is_empty(),
            "constant {v}"
        );
    }
    let flat = vec![0.5f32; 100 * 80];
    assert!(
        surf()
            .detect_and_describe_f32(&flat, 100, 80)
            .unwrap()
            .is_empty()
    );
}

#[test]
fn tiny_and_empty_images_give_few_or_no_keypoints_inside_the_image() {
    let s = surf();
    for (w, h) in [
        (0u32, 0u32),
        (1, 1),
        (0, 50),
        (50, 0),
        (8, 8),
        (20, 31),
        (31, 31),
        (9, 200),
    ] {
        let img = if w > 0 && h > 0 {
            texture::textured_image(w as usize, h as usize, 3)
        } else {
            GrayImage::new(w, h)
        };
        let f = s.detect_and_describe(&img).unwrap();
        for kp in f.iter().map(|f| f.keypoint) {
            assert!(
                kp.x >= -0.5 && kp.y >= -0.5 && kp.x < w as f32 && kp.y < h as f32,
                "{w}×{h}: {kp:?}"
            );
            assert!(kp.scale > 0.0 && kp.orientation.is_finite());
        }
        assert!(f.iter().all(|f| f.descriptor.iter().all(|v| v.is_finite())));
    }
}

#[test]
fn oversized_images_and_bad_buffers_are_clear_errors() {
    let small_limit = SurfConfig::default()
        .with_max_pixels(10_000)
        .init()
        .unwrap();
    let e = small_limit.detect(&GrayImage::new(101, 100)).unwrap_err();
    assert_eq!(
        e,
        FeatureError::ImageTooLarge {
            width: 101,
            height: 100,
            max_pixels: 10_000
        }
    );
    assert!(e.to_string().contains("101 × 100"));
    // Beyond the default limit of 4096 × 4096 pixels.
    let huge = GrayImage::new(20_000, 1_000);
    assert!(matches!(
        surf().detect(&huge),
        Err(FeatureError::ImageTooLarge { .. })
    ));
    assert!(matches!(
        surf().detect_and_describe_f32(&[0.0; 10], usize::MAX, 2),
        Err(FeatureError::ImageTooLarge { .. })
    ));

    let e = surf()
        .detect_and_describe_f32(&[0.0; 10], 4, 3)
        .unwrap_err();
    assert_eq!(
        e,
        FeatureError::BufferSize {
            width: 4,
            height: 3,
            expected: 12,
            actual: 10
        }
    );
    let mut px = vec![0.2f32; 12];
    px[7] = f32::NAN;
    let e = surf().detect_and_describe_f32(&px, 4, 3).unwrap_err();
    assert!(
        matches!(e, FeatureError::NonFinitePixel { x: 3, y: 1, .. }),
        "{e:?}"
    );
}

#[test]
fn invalid_configurations_are_rejected_with_the_field_name() {
    for (cfg, field) in [
        (SurfConfig::default().with_octaves(0), "octaves"),
        (SurfConfig::default().with_scale_levels(2), "scale_levels"),
        (SurfConfig::default().with_threshold(f32::NAN), "threshold"),
        (SurfConfig::default().with_initial_step(0), "initial_step"),
    ] {
        match cfg.init() {
            Err(FeatureError::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: expected InvalidConfig, got {other:?}"),
        }
    }
}

#[test]
fn parallel_and_single_threaded_results_are_identical() {
    let img = texture::textured_image(200, 150, 9);
    let a = SurfConfig::default()
        .with_parallel(true)
        .init()
        .unwrap()
        .detect_and_describe(&img)
        .unwrap();
    let b = SurfConfig::default()
        .with_parallel(false)
        .init()
        .unwrap()
        .detect_and_describe(&img)
        .unwrap();
    assert!(!a.is_empty());
    assert_eq!(a, b);
}

#[test]
fn u8_and_unit_float_inputs_agree() {
    let img = texture::textured_image(160, 120, 2);
    let px: Vec<f32> = img.as_raw().iter().map(|&v| f32::from(v) / 255.0).collect();
    let a = surf().detect_and_describe(&img).unwrap();
    let b = surf().detect_and_describe_f32(&px, 160, 120).unwrap();
    assert_eq!(a.len(), b.len());
    for (fa, fb) in a.iter().zip(&b) {
        assert!(
            (fa.keypoint.x - fb.keypoint.x).abs() < 1e-3
                && (fa.keypoint.scale - fb.keypoint.scale).abs() < 1e-3
        );
    }
}

#[test]
fn threshold_controls_the_keypoint_count() {
    let img = texture::textured_image(320, 240, 4);
    let count = |t: f32| {
        SurfConfig::default()
            .with_threshold(t)
            .init()
            .unwrap()
            .detect(&img)
            .unwrap()
            .len()
    };
    let (low, mid, high) = (count(50.0), count(200.0), count(2000.0));
    assert!(low > mid && mid > high, "{low} {mid} {high}");
}
