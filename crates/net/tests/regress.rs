//! PoseNet and OffsetNet on tiny synthetic sequences: the loss falls, seeds reproduce,
//! save → load keeps predictions, OffsetNet composes `T_ref ∘ offset`.

use endoloc_geometry::pose::pose_from_parts;
use endoloc_geometry::{Pose, orientation_error_deg, position_error_mm};
use endoloc_net::backbone::BackboneConfig;
use endoloc_net::regress::{
    OffsetNetModel, PoseNetModel, RegressConfig, RegressSchedule, TrainingSet, compose,
    offset_between, train_offsetnet, train_posenet,
};
use endoloc_net::{AugmentConfig, InputSize, NetError};
use nalgebra::{UnitQuaternion, Vector3};

const W: u32 = 64;
const H: u32 = 48;
const FRAMES: usize = 40;

/// Frame `i` of a synthetic pass: a bright blob whose image position encodes the camera's
/// position (x along the image, y across it), on a faint fixed gradient.
fn frame(i: usize) -> image::GrayImage {
    let t = i as f32 / (FRAMES - 1) as f32;
    let (u, v) = (8.0 + 48.0 * t, 16.0 + 16.0 * (t * 6.0).sin());
    image::GrayImage::from_fn(W, H, |x, y| {
        let d2 = (x as f32 - u).powi(2) + (y as f32 - v).powi(2);
        let g = 30.0 + 0.5 * x as f32 + 200.0 * (-d2 / 18.0).exp();
        image::Luma([g.clamp(0.0, 255.0) as u8])
    })
}

/// Pose of frame `i`: 0 → 78 mm along x, ±20 mm along y, a yaw growing to 0.5 rad.
fn pose(i: usize) -> Pose {
    let t = i as f64 / (FRAMES - 1) as f64;
    pose_from_parts(
        Vector3::new(78.0 * t, 20.0 * (t * 6.0).sin(), 5.0),
        UnitQuaternion::from_euler_angles(0.1, 0.5 * t, 0.0),
    )
}

fn data() -> TrainingSet {
    let frames: Vec<_> = (0..FRAMES).map(frame).collect();
    let poses: Vec<_> = (0..FRAMES).map(pose).collect();
    TrainingSet::from_images(&frames, &poses, None, tiny_config(1).backbone.input()).unwrap()
}

fn tiny_config(epochs: usize) -> RegressConfig {
    RegressConfig {
        backbone: BackboneConfig::Compact {
            input: InputSize {
                width: 32,
                height: 24,
            },
            channels: vec![8, 16],
            descriptor_dim: 16,
            stem_stride: 2,
            pooling: Default::default(),
        },
        schedule: RegressSchedule {
            epochs,
            samples_per_epoch: 64,
            batch: 16,
            learning_rate: 3e-3,
            final_learning_rate: 1e-3,
        },
        hidden: 32,
        augment: AugmentConfig::off(),
        roll_deg: 0.0,
        pair_reach_frames: 6,
        seed: 5,
        device: "cpu".into(),
        ..RegressConfig::default()
    }
}

fn mean_position_error(est: &[Pose], truth: &[Pose]) -> f64 {
    est.iter()
        .zip(truth)
        .map(|(e, t)| position_error_mm(e, t))
        .sum::<f64>()
        / est.len() as f64
}

#[test]
fn posenet_learns_a_tiny_task_and_beats_the_mean_pose() {
    let data = data();
    let model = train_posenet(&tiny_config(25), &data, &mut |_| {}).unwrap();
    let h = model.history();
    let first = h[0].loss;
    let last = h.last().unwrap().loss;
    assert!(last < 0.5 * first, "loss {first} → {last}");
    let frames: Vec<_> = (0..FRAMES).map(frame).collect();
    let est = model.predict_batch(&frames).unwrap();
    let err = mean_position_error(&est, &data.poses);
    // Predicting the mean training position for every frame.
    let mean = data
        .poses
        .iter()
        .map(|p| p.translation.vector)
        .sum::<Vector3<f64>>()
        / FRAMES as f64;
    let mean_pose = pose_from_parts(mean, UnitQuaternion::identity());
    let baseline = mean_position_error(&vec![mean_pose; FRAMES], &data.poses);
    assert!(
        err < 0.5 * baseline,
        "PoseNet {err:.1} mm vs mean-position baseline {baseline:.1} mm"
    );
    let rot = est
        .iter()
        .zip(&data.poses)
        .map(|(e, t)| orientation_error_deg(e, t))
        .sum::<f64>()
        / FRAMES as f64;
    assert!(rot < 10.0, "orientation error {rot:.2}°");
}

#[test]
fn posenet_same_seed_same_model_and_save_load_keeps_predictions() {
    let data = data();
    let cfg = tiny_config(2);
    let a = train_posenet(&cfg, &data, &mut |_| {}).unwrap();
    let b = train_posenet(&cfg, &data, &mut |_| {}).unwrap();
    let frames: Vec<_> = [0, 13, 39].into_iter().map(frame).collect();
    let pa = a.predict_batch(&frames).unwrap();
    assert_eq!(pa, b.predict_batch(&frames).unwrap());
    let c = train_posenet(
        &RegressConfig {
            seed: 6,
            ..cfg.clone()
        },
        &data,
        &mut |_| {},
    )
    .unwrap();
    assert_ne!(pa, c.predict_batch(&frames).unwrap());

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("posenet");
    a.save(&path, false).unwrap();
    assert!(path.join("regress.toml").is_file() && path.join("weights.safetensors").is_file());
    assert!(!dir.path().join("posenet.partial").exists());
    let loaded = PoseNetModel::load(&path).unwrap();
    assert_eq!(loaded.predict_batch(&frames).unwrap(), pa);
    assert_eq!(loaded.predict(&frames[1]).unwrap(), pa[1]);
    assert_eq!(loaded.info(), a.info());
    // An existing folder is kept unless overwriting is asked for.
    assert!(matches!(
        a.save(&path, false),
        Err(NetError::AlreadyExists { .. })
    ));
    a.save(&path, true).unwrap();
    // A PoseNet folder is not an OffsetNet model.
    let err = OffsetNetModel::load(&path).unwrap_err();
    assert!(
        err.to_string().contains("regress.toml") && err.to_string().contains("posenet"),
        "{err}"
    );
    // A frame of another size is refused with both sizes named.
    let err = a.predict(&image::GrayImage::new(32, 24)).unwrap_err();
    assert!(
        err.to_string().contains("32x24") && err.to_string().contains("64x48"),
        "{err}"
    );
}

#[test]
fn offsetnet_composes_reference_and_offset() {
    // Known offset: 10 mm forward along the reference camera's optical axis, turned 0.2 rad
    // about its y axis.
    let t_ref = pose_from_parts(
        Vector3::new(100.0, -20.0, 7.0),
        UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2),
    );
    let offset = pose_from_parts(
        Vector3::new(0.0, 0.0, 10.0),
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.2),
    );
    let p = compose(&t_ref, &offset);
    // The reference's z axis (optical axis) in the world: R_ref · (0, 0, 1).
    let forward = t_ref.rotation * Vector3::z();
    let expected_t = Vector3::new(100.0, -20.0, 7.0) + 10.0 * forward;
    assert!((p.translation.vector - expected_t).norm() < 1e-12);
    let expected_r = t_ref.rotation * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.2);
    assert!(p.rotation.angle_to(&expected_r) < 1e-12);
    let back = offset_between(&t_ref, &p);
    assert!(position_error_mm(&back, &offset) < 1e-12);
    assert!(orientation_error_deg(&back, &offset) < 1e-9);
}

#[test]
fn offsetnet_learns_a_tiny_task_and_predicts_t_ref_times_offset() {
    let data = data();
    let model = train_offsetnet(&tiny_config(60), &data, &mut |_| {}).unwrap();
    let h = model.history();
    let (first, last) = (h[0].loss, h.last().unwrap().loss);
    assert!(last < 0.4 * first, "loss {first} → {last}");
    // Pairs 4 frames apart (within the reach of 6): the predicted pose is closer to the truth
    // than the reference pose itself.
    let pairs: Vec<(usize, usize)> = (0..FRAMES - 4).step_by(3).map(|i| (i, i + 4)).collect();
    let queries: Vec<_> = pairs.iter().map(|&(_, j)| frame(j)).collect();
    let refs: Vec<_> = pairs.iter().map(|&(i, _)| frame(i)).collect();
    let t_refs: Vec<_> = pairs.iter().map(|&(i, _)| data.poses[i]).collect();
    let truth: Vec<_> = pairs.iter().map(|&(_, j)| data.poses[j]).collect();
    let est = model.predict_batch(&queries, &refs, &t_refs).unwrap();
    let err = mean_position_error(&est, &truth);
    let baseline = mean_position_error(&t_refs, &truth);
    assert!(
        err < 0.6 * baseline,
        "OffsetNet {err:.2} mm vs reference pose {baseline:.2} mm"
    );
    // predict = T_ref ∘ predict_offset, one pair at a time as in a batch.
    let off = model.predict_offset(&queries[2], &refs[2]).unwrap();
    let one = model.predict(&queries[2], &refs[2], &t_refs[2]).unwrap();
    assert!(position_error_mm(&one, &compose(&t_refs[2], &off)) < 1e-9);
    assert!(position_error_mm(&one, &est[2]) < 1e-3);
    // Save → load keeps predictions.
    let dir = tempfile::tempdir().unwrap();
    model.save(&dir.path().join("offsetnet"), false).unwrap();
    let loaded = OffsetNetModel::load(&dir.path().join("offsetnet")).unwrap();
    assert_eq!(loaded.predict_batch(&queries, &refs, &t_refs).unwrap(), est);
    assert!(matches!(
        model.predict_batch(&queries, &refs[1..], &t_refs),
        Err(NetError::Config(_))
    ));
}

#[test]
fn bad_training_data_gives_clear_errors() {
    let cfg = tiny_config(1);
    let frames = vec![frame(0), image::GrayImage::new(10, 10)];
    let err = TrainingSet::from_images(&frames, &[pose(0), pose(1)], None, cfg.backbone.input())
        .unwrap_err();
    assert!(err.to_string().contains("training frame 1"), "{err}");
    let err = TrainingSet::from_images(&[frame(0)], &[], None, cfg.backbone.input()).unwrap_err();
    assert!(matches!(err, NetError::Config(_)), "{err}");
    let one =
        TrainingSet::from_images(&[frame(0)], &[pose(0)], None, cfg.backbone.input()).unwrap();
    assert!(matches!(
        train_posenet(&cfg, &one, &mut |_| {}),
        Err(NetError::Config(_))
    ));
    let bad = RegressConfig { beta: -1.0, ..cfg };
    assert!(matches!(
        train_offsetnet(&bad, &data(), &mut |_| {}),
        Err(NetError::Config(_))
    ));
}
