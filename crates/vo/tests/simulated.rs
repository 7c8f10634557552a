//! The visual odometry on a short simulated sequence with known poses: tracking, alignment
//! to the ground truth, loss on a black frame, bad input.

mod common;

use endoloc_geometry::{Camera, Pose, orientation_error_deg, position_error_mm};
use endoloc_vo::{
    NoPoseReason, TrackStatus, VisualOdometry, VoConfig, VoError, align_segments, report,
};
use image::GrayImage;

/// Frames of the test sequence: 60 frames (about 2 s at 30 fps) starting 400 frames into the
/// pass.
const FIRST: usize = 400;
const COUNT: usize = 60;

#[test]
fn tracks_a_simulated_sequence_and_aligns_to_the_ground_truth() {
    let seq = common::render_sequence(FIRST, COUNT);
    let mut vo = VisualOdometry::new(seq.camera, VoConfig::default()).unwrap();
    for img in &seq.images {
        vo.track(img).unwrap();
    }
    let frames = vo.frames();
    for f in frames {
        eprintln!(
            "{:3} {:12} seg {:?} feat {:4} match {:4} inl {:4} kf {} {}",
            f.index,
            f.status.to_string(),
            f.segment,
            f.features,
            f.matches,
            f.inliers,
            f.keyframe,
            f.reason.as_ref().map(|r| r.to_string()).unwrap_or_default()
        );
    }
    let r = report(frames, &seq.poses).unwrap();
    let travelled: f64 = seq
        .poses
        .windows(2)
        .map(|w| (w[1].translation.vector - w[0].translation.vector).norm())
        .sum();
    let mut pos = Vec::new();
    let mut rot = Vec::new();
    for (est, gt) in r.t_wc.iter().zip(&seq.poses) {
        if let Some(p) = est {
            pos.push(position_error_mm(p, gt));
            rot.push(orientation_error_deg(p, gt));
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "tracked {:.3}, lost at {:?}, segments {:?}, travelled {travelled:.1} mm, position mean {:.2} max {:.2} mm, rotation mean {:.2} max {:.2} deg",
        r.tracked_fraction,
        r.lost_at,
        r.segments,
        mean(&pos),
        max(&pos),
        mean(&rot),
        max(&rot)
    );
    // Measured (default config): all 60 frames tracked in one segment, 36.5 mm travelled,
    // position error mean 1.22 mm, max 2.31 mm (6.3 % of the distance), orientation error
    // mean 1.49°, max 2.22°. The bounds leave room for platform differences, not for a
    // regression to the 5.7 mm / 10° of the paper's SURF threshold at this resolution.
    assert!(r.tracked_fraction >= 0.9, "tracked {}", r.tracked_fraction);
    assert!(r.lost_at.is_empty(), "lost at {:?}", r.lost_at);
    assert_eq!(r.segments.len(), 1);
    assert!(
        max(&pos) / travelled < 0.10,
        "max position error {} mm",
        max(&pos)
    );
    assert!(
        mean(&pos) / travelled < 0.05,
        "mean position error {} mm",
        mean(&pos)
    );
    assert!(max(&rot) < 4.0, "max orientation error {}°", max(&rot));
}

#[test]
fn a_black_frame_loses_track_with_a_clear_status() {
    let seq = common::render_sequence(FIRST, 16);
    let mut vo = VisualOdometry::new(seq.camera, VoConfig::default()).unwrap();
    for img in &seq.images[..12] {
        vo.track(img).unwrap();
    }
    assert!(vo.is_tracking(), "not tracking after 12 frames");
    let black = GrayImage::new(seq.camera.width, seq.camera.height);
    let f = vo.track(&black).unwrap();
    assert_eq!(f.status, TrackStatus::Lost);
    assert!(f.t_wc.is_none());
    assert!(
        matches!(
            f.reason,
            Some(NoPoseReason::TooFewFeatures { count: 0, .. })
        ),
        "{:?}",
        f.reason
    );
    assert_eq!(vo.lost_at(), &[12]);
    assert!(!vo.is_tracking());
    // It starts again afterwards: the next frames re-initialize a new segment.
    for img in &seq.images[12..] {
        vo.track(img).unwrap();
    }
    let frames = vo.frames();
    let r = report(
        frames,
        &[&seq.poses[..12], &seq.poses[12..13], &seq.poses[12..]].concat(),
    )
    .unwrap();
    assert_eq!(r.lost_at, vec![12]);
    assert!(r.t_wc[12].is_none());
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let camera = Camera::from_hfov(320, 240, 90.0);
    let mut vo = VisualOdometry::new(camera, VoConfig::default()).unwrap();
    let e = vo.track(&GrayImage::new(100, 80)).unwrap_err();
    assert!(
        matches!(
            e,
            VoError::ImageSize {
                frame: 0,
                width: 100,
                height: 80,
                ..
            }
        ),
        "{e}"
    );
    // A constant image: no features, no pose, no panic.
    let f = vo
        .track(&GrayImage::from_pixel(320, 240, image::Luma([128])))
        .unwrap();
    assert_eq!(f.status, TrackStatus::Initializing);
    assert!(f.t_wc.is_none());

    let bad = VoConfig {
        min_tracked_inliers: 2,
        ..VoConfig::default()
    };
    assert!(matches!(
        VisualOdometry::new(camera, bad),
        Err(VoError::InvalidConfig(m)) if m.contains("min_tracked_inliers")
    ));
    let bad_cam = Camera { fx: -1.0, ..camera };
    assert!(matches!(
        VisualOdometry::new(bad_cam, VoConfig::default()),
        Err(VoError::InvalidCamera(_))
    ));
    assert!(matches!(
        align_segments(vo.frames(), &[Pose::identity(); 3]),
        Err(VoError::LengthMismatch { vo: 1, gt: 3 })
    ));
}

#[test]
fn config_round_trips_through_toml() {
    let cfg = VoConfig::default();
    let s = toml::to_string(&cfg).unwrap();
    let back: VoConfig = toml::from_str(&s).unwrap();
    assert_eq!(cfg, back);
    let partial: VoConfig = toml::from_str("min_tracked_inliers = 20").unwrap();
    assert_eq!(partial.min_tracked_inliers, 20);
}
