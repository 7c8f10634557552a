//! Rotation and scale invariance under known transforms; descriptors of rotated patches.

use endoloc_features::repeatability::{EvaluationConfig, Transform, evaluate, image_pair};
use endoloc_features::warp::Homography;
use endoloc_features::{Keypoint, SurfConfig, texture};
use image::GrayImage;

fn small_eval() -> EvaluationConfig {
    let mut cfg = EvaluationConfig {
        size: (320, 240),
        seed: 11,
        ..EvaluationConfig::default()
    };
    cfg.surf = cfg.surf.with_parallel(false);
    cfg
}

#[test]
fn keypoints_and_matches_survive_rotation_and_zoom() {
    let rows = evaluate(
        &small_eval(),
        &[
            Transform::Rotation(90.0),
            Transform::Rotation(45.0),
            Transform::Scale(1.5),
            Transform::Scale(0.7),
        ],
    )
    .unwrap();
    // (minimum repeatability, minimum precision) per transform.
    let limits = [(0.9, 0.95), (0.7, 0.88), (0.7, 0.88), (0.7, 0.88)];
    for (row, (min_rep, min_prec)) in rows.iter().zip(limits) {
        let (rep, prec) = (row.repeatability.repeatability, row.precision.precision);
        assert!(
            row.repeatability.overlap_1 > 50,
            "{}: too few keypoints",
            row.transform
        );
        assert!(
            rep >= min_rep,
            "{}: repeatability {rep:.3} < {min_rep}",
            row.transform
        );
        assert!(
            prec >= min_prec,
            "{}: precision {prec:.3} < {min_prec}",
            row.transform
        );
        assert!(
            row.precision.matches > 30,
            "{}: only {} matches",
            row.transform,
            row.precision.matches
        );
    }
}

/// Rotating the image by exactly 90° (a pixel permutation) rotates the keypoint orientation
/// by 90° and leaves its descriptor nearly unchanged.
#[test]
fn descriptor_of_a_rotated_patch_matches_the_original() {
    let img = texture::textured_image(200, 200, 21);
    let n = img.width();
    // Rotation by +90° in image axes (x right, y down): (x, y) → (n−1−y, x).
    let rot = GrayImage::from_fn(n, n, |x, y| *img.get_pixel(y, n - 1 - x));
    let surf = SurfConfig::default().with_parallel(false).init().unwrap();
    let a = surf.detect_and_describe(&img).unwrap();
    let b = surf.detect_and_describe(&rot).unwrap();
    let map = |k: &Keypoint| ((n - 1) as f32 - k.y, k.x);
    let mut checked = 0;
    for fa in a.iter().filter(|f| f.keypoint.scale < 6.0) {
        let (mx, my) = map(&fa.keypoint);
        let Some(fb) = b
            .iter()
            .find(|f| (f.keypoint.x - mx).abs() < 0.05 && (f.keypoint.y - my).abs() < 0.05)
        else {
            continue;
        };
        checked += 1;
        let dtheta =
            (fb.keypoint.orientation - fa.keypoint.orientation - std::f32::consts::FRAC_PI_2)
                .rem_euclid(std::f32::consts::TAU);
        let dtheta = dtheta.min(std::f32::consts::TAU - dtheta);
        assert!(
            dtheta < 0.02,
            "orientation off by {dtheta} rad at {:?}",
            fa.keypoint
        );
        let d: f32 = fa
            .descriptor
            .iter()
            .zip(&fb.descriptor)
            .map(|(p, q)| (p - q).powi(2))
            .sum::<f32>()
            .sqrt();
        assert!(d < 0.05, "descriptor distance {d} at {:?}", fa.keypoint);
    }
    assert!(checked > 20, "only {checked} keypoints could be compared");
}

/// Under a 37° rotation (bilinear resampling), the descriptor of a keypoint's geometric
/// counterpart is usually its nearest neighbour among all descriptors of the other image (raw
/// nearest neighbour, no ratio test; the misses are keypoints whose dominant orientation is
/// ambiguous — near-isotropic blobs — measured 82/111).
#[test]
fn descriptors_of_corresponding_keypoints_are_nearest_neighbours_under_rotation() {
    let cfg = small_eval();
    let (a, b, h): (_, _, Homography) = image_pair(&cfg, Transform::Rotation(37.0));
    let surf = cfg.surf.clone().init().unwrap();
    let fa = surf.detect_and_describe(&a.to_gray()).unwrap();
    let fb = surf.detect_and_describe(&b.to_gray()).unwrap();
    let (mut pairs, mut nn_ok) = (0, 0);
    for f in &fa {
        let Some((mx, my)) = h.apply(f64::from(f.keypoint.x), f64::from(f.keypoint.y)) else {
            continue;
        };
        let Some((j, _)) = fb
            .iter()
            .enumerate()
            .map(|(j, g)| {
                (
                    j,
                    (f64::from(g.keypoint.x) - mx).hypot(f64::from(g.keypoint.y) - my),
                )
            })
            .filter(|(j, d)| {
                *d < 1.5 && (fb[*j].keypoint.scale / f.keypoint.scale - 1.0).abs() < 0.2
            })
            .min_by(|x, y| x.1.total_cmp(&y.1))
        else {
            continue;
        };
        pairs += 1;
        let dist = |g: &endoloc_features::Feature| -> f32 {
            f.descriptor
                .iter()
                .zip(&g.descriptor)
                .map(|(p, q)| (p - q).powi(2))
                .sum()
        };
        let nearest = (0..fb.len()).min_by(|&x, &y| dist(&fb[x]).total_cmp(&dist(&fb[y])));
        if nearest == Some(j) {
            nn_ok += 1;
        }
    }
    assert!(pairs > 50, "only {pairs} geometric correspondences");
    let frac = nn_ok as f64 / pairs as f64;
    assert!(
        frac > 0.7,
        "only {nn_ok}/{pairs} counterparts are nearest neighbours"
    );
}

/// Correct nearest-neighbour matches (ratio 0.8, same place within 1.5 px) between a scene
/// lit by an endoscope's light (bright centre, dim periphery) and the same scene under a
/// dimmer, narrower light with another exposure curve (gamma 1.15).
fn matches_under_relighting(intensity: endoloc_features::Intensity) -> usize {
    let (w, h) = (320usize, 240usize);
    let img = texture::textured_image(w, h, 5);
    let lit = |beam: f32, gain: f32, gamma: f32| {
        GrayImage::from_fn(w as u32, h as u32, |x, y| {
            let (dx, dy) = (x as f32 - 160.0, y as f32 - 120.0);
            let falloff = (1.0 + (dx * dx + dy * dy) / (120.0 * 120.0)).powf(-beam);
            let v = f32::from(img.get_pixel(x, y)[0]) / 255.0;
            image::Luma([(255.0 * (gain * falloff * v).powf(gamma)).round() as u8])
        })
    };
    let (img, relit) = (lit(1.0, 1.0, 1.0), lit(2.0, 0.7, 1.15));
    let surf = SurfConfig::default()
        .with_threshold(50.0)
        .with_intensity(intensity)
        .with_parallel(false)
        .init()
        .unwrap();
    let a = surf.detect_and_describe(&img).unwrap();
    let b = surf.detect_and_describe(&relit).unwrap();
    let matcher = endoloc_features::Matcher::new(endoloc_features::MatcherConfig::default());
    matcher
        .match_descriptors(&a, &b)
        .unwrap()
        .iter()
        .filter(|m| {
            let (p, q) = (&a[m.query].keypoint, &b[m.train].keypoint);
            (p.x - q.x).hypot(p.y - q.y) < 1.5
        })
        .count()
}

/// On a log scale a gamma is a gain and a light's fall-off an offset that varies slowly:
/// log-intensity SURF keeps more correct matches under another exposure curve and light.
#[test]
fn log_intensity_keeps_matches_under_another_light() {
    use endoloc_features::Intensity;
    let linear = matches_under_relighting(Intensity::Linear);
    let log = matches_under_relighting(Intensity::Log);
    eprintln!("correct matches under relighting: linear {linear}, log {log}");
    assert!(log >= 30, "log intensity: only {log} correct matches");
    assert!(
        log as f64 >= 1.3 * linear as f64,
        "log intensity {log} correct matches, linear {linear}: expected clearly more"
    );
}
