//! Training, the model folder and the classifier on tiny synthetic sequences.

use endoloc_data::{Sequence, StampedPose};
use endoloc_geometry::{Camera, pose::pose_from_parts};
use endoloc_net::backbone::BackboneConfig;
use endoloc_net::train::{
    ImageCache, Schedule, TrainConfig, TrainReport, TrainTarget, ValidationConfig, fit, train,
};
use endoloc_net::{
    AugmentConfig, InputSize, NetError, PairRule, UniformBy, ZoneClassifier, ZoneConfig, ZoneTable,
};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

const ZONES: usize = 4;
const PER_ZONE: usize = 12;
const W: u32 = 64;
const H: u32 = 48;

/// Stripes at `angle` (radians) and spatial frequency `freq` (radians per pixel), a random
/// phase and noise.
/// One training at a time in this test binary: two trainings that share the rayon pool (tests
/// run on parallel threads) were seen to differ in the last bits of their losses, while a
/// training run alone gives the same bits for the same seed on any thread count.
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn stripes(angle: f32, freq: f32, rng: &mut ChaCha8Rng) -> image::GrayImage {
    let phase: f32 = rng.random_range(0.0..std::f32::consts::TAU);
    let (s, c) = angle.sin_cos();
    image::GrayImage::from_fn(W, H, |x, y| {
        let v = ((x as f32 * c + y as f32 * s) * freq + phase).sin();
        let n: f32 = rng.random_range(-0.2..0.2);
        image::Luma([((v + n) * 100.0 + 128.0).clamp(0.0, 255.0) as u8])
    })
}

/// A frame of zone `z`: stripes whose orientation and frequency depend on the zone, so that
/// zones are separable but frames differ.
fn frame(z: usize, rng: &mut ChaCha8Rng) -> image::GrayImage {
    stripes(
        z as f32 * std::f32::consts::PI / ZONES as f32,
        0.15 + 0.1 * z as f32,
        rng,
    )
}

fn camera() -> Camera {
    Camera::from_hfov(W, H, 90.0)
}

/// Writes a sequence folder of `ZONES · PER_ZONE` frames `make(i, rng)` (images + poses.txt
/// along x, 1 mm per frame) and opens it.
fn write_frames(
    dir: &Path,
    seed: u64,
    mut make: impl FnMut(usize, &mut ChaCha8Rng) -> image::GrayImage,
) -> Sequence {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let mut poses = Vec::new();
    for i in 0..ZONES * PER_ZONE {
        make(i, &mut rng)
            .save(dir.join("images").join(format!("{i:06}.png")))
            .unwrap();
        poses.push(StampedPose {
            timestamp_s: i as f64 / 30.0,
            pose: pose_from_parts(Vector3::new(i as f64, 0.0, 0.0), UnitQuaternion::identity()),
        });
    }
    endoloc_data::write_tum(&dir.join("poses.txt"), &poses).unwrap();
    Sequence::open(dir).unwrap()
}

/// A sequence of [`frame`]s, `PER_ZONE` per zone.
fn write_sequence(dir: &Path, seed: u64) -> Sequence {
    write_frames(dir, seed, |i, rng| frame(i / PER_ZONE, rng))
}

fn tiny_config(epochs: usize) -> TrainConfig {
    TrainConfig {
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
        schedule: Schedule {
            epochs,
            pairs_per_epoch: 32,
            batch_pairs: 16,
            learning_rate: 3e-3,
            final_learning_rate: 1e-3,
            share_images: true,
        },
        augment: AugmentConfig::off(),
        validation: ValidationConfig {
            holdout_every: 4,
            every_epochs: epochs,
            max_database_frames: 100,
            ..ValidationConfig::default()
        },
        checkpoint_every_epochs: 1,
        seed: 7,
        // 48 frames of 16-d descriptors are too few to learn a whitening from; the model
        // round trip turns it on.
        whitening: 0.0,
        database_smoothing_mm: 0.0,
        // The device is named explicitly (never `Device::default()` / BURN_DEVICE).
        device: "cpu".into(),
        ..TrainConfig::default()
    }
}

/// Trains a fresh model into `dir` (no force, no resume).
fn train_into(
    dir: &Path,
    cfg: &TrainConfig,
    seq: &Sequence,
    zones: &ZoneTable,
) -> Result<TrainReport, NetError> {
    let target = TrainTarget {
        dir: dir.to_path_buf(),
        force: false,
        resume: false,
    };
    train(
        cfg,
        seq,
        zones,
        &camera(),
        "synthetic",
        &target,
        &mut |_| {},
    )
}

fn zones_of(seq: &Sequence) -> ZoneTable {
    ZoneTable::from_sequence(seq, &ZoneConfig::uniform(ZONES, UniformBy::Frames)).unwrap()
}

#[test]
fn loss_falls_on_a_tiny_separable_task_and_resume_continues() {
    let _alone = one_at_a_time();
    let tmp = tempfile::tempdir().unwrap();
    let seq = write_sequence(&tmp.path().join("train"), 1);
    let zones = zones_of(&seq);
    let cfg = tiny_config(30);
    let cache = ImageCache::from_sequence(&seq, cfg.backbone.input(), &mut |_| {}).unwrap();
    let fitted = fit(&cfg, &cache, &zones, None, None, false, &mut |_| {}).unwrap();
    let h = &fitted.history;
    assert_eq!(h.len(), 30);
    let first: f32 = h[..3].iter().map(|r| r.loss).sum::<f32>() / 3.0;
    let last: f32 = h[h.len() - 3..].iter().map(|r| r.loss).sum::<f32>() / 3.0;
    assert!(last < 0.5 * first, "loss {first} → {last}");
    let acc = h.last().unwrap().val_accuracy.unwrap();
    assert!(acc >= 0.9, "held-out zone accuracy {acc}");

    // Interrupted after 2 epochs, then resumed to 4: continues from the checkpoint.
    let ckpt = tmp.path().join("ckpt");
    let a = fit(
        &tiny_config(2),
        &cache,
        &zones,
        None,
        Some(&ckpt),
        false,
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(a.resumed_after_epoch, None);
    // A save of epoch 3 killed after its weights and optimiser state were in place but before
    // `state.json` named them: the resumed run must take the whole checkpoint of epoch 2.
    for name in ["net-0003.bpk", "optim-0003.bpk", ".state.json.tmp"] {
        std::fs::write(ckpt.join(name), b"half-written").unwrap();
    }
    let b = fit(
        &tiny_config(4),
        &cache,
        &zones,
        None,
        Some(&ckpt),
        true,
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(b.resumed_after_epoch, Some(2));
    assert_eq!(b.history.len(), 4);
    assert_eq!(b.steps, 2 * tiny_config(4).schedule.steps_per_epoch());
    assert_eq!(b.history[..2], a.history[..]);
    let mut left: Vec<String> = std::fs::read_dir(&ckpt)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["net-0004.bpk", "optim-0004.bpk", "state.json"]);
}

#[test]
fn model_folder_round_trip_gives_identical_descriptors_and_refuses_other_cameras() {
    let _alone = one_at_a_time();
    let tmp = tempfile::tempdir().unwrap();
    let seq = write_sequence(&tmp.path().join("train"), 2);
    let zones = zones_of(&seq);
    let cfg = TrainConfig {
        whitening: 0.25,
        ..tiny_config(12)
    };
    let target = TrainTarget {
        dir: tmp.path().join("model"),
        force: false,
        resume: false,
    };
    let report = train(
        &cfg,
        &seq,
        &zones,
        &camera(),
        "synthetic",
        &target,
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(report.history.len(), 12);
    for f in [
        "model.toml",
        "weights.safetensors",
        "zones.csv",
        "database.bin",
        "train_poses.txt",
        "history.csv",
        "whitening.bin",
    ] {
        assert!(target.dir.join(f).is_file(), "{f} missing");
    }
    assert!(!target.staging_dir().exists());
    // A second run refuses to overwrite.
    let err = train(
        &cfg,
        &seq,
        &zones,
        &camera(),
        "synthetic",
        &target,
        &mut |_| {},
    )
    .unwrap_err();
    assert!(matches!(err, NetError::AlreadyExists { .. }), "{err}");

    let clf = ZoneClassifier::load(&target.dir).unwrap();
    assert_eq!(clf.zone_count(), ZONES);
    // Descriptors of the training frames after save → load equal the stored database rows,
    // which were computed by the network before it was saved.
    let imgs: Vec<image::GrayImage> = (0..seq.len()).map(|i| seq.load_gray(i).unwrap()).collect();
    let d = clf.describe_batch(&imgs).unwrap();
    for (i, q) in d.iter().enumerate() {
        let row = clf.database().row(i).unwrap();
        let diff = q
            .iter()
            .zip(row)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(diff < 1e-5, "frame {i}: max |Δ| {diff}");
    }
    // Prepared network inputs give the same descriptors; an input of the wrong size is refused.
    let size = clf.config().backbone.input();
    let inputs: Vec<Vec<f32>> = imgs
        .iter()
        .map(|im| endoloc_net::preprocess::network_input(im, size))
        .collect();
    assert_eq!(clf.describe_inputs(&inputs).unwrap(), d);
    let e = clf
        .describe_inputs(&[vec![0.0; 7]])
        .unwrap_err()
        .to_string();
    assert!(e.contains("7 values"), "{e}");
    // The descriptors are whitened ones: unit length, not the network's own.
    for q in &d {
        let n = q.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((n - 1.0).abs() < 1e-4, "norm {n}");
    }
    // Loading twice gives bit-identical descriptors.
    let again = ZoneClassifier::load(&target.dir)
        .unwrap()
        .describe(&imgs[5])
        .unwrap();
    assert_eq!(again, clf.describe(&imgs[5]).unwrap());
    // The model joined with itself: unit descriptors twice as long, the same distances and
    // zones; a model of another pass is refused, naming what differs.
    let pair = ZoneClassifier::load(&target.dir)
        .unwrap()
        .join(vec![ZoneClassifier::load(&target.dir).unwrap()])
        .unwrap();
    assert_eq!(pair.net_count(), 2);
    let q = pair.describe(&imgs[5]).unwrap();
    assert_eq!(q.len(), 2 * d[5].len());
    let norm = q.iter().map(|v| v * v).sum::<f32>().sqrt();
    assert!((norm - 1.0).abs() < 1e-4, "ensemble descriptor norm {norm}");
    let (joined, single) = (
        pair.frame_distances(&q).unwrap(),
        clf.frame_distances(&d[5]).unwrap(),
    );
    assert!(
        joined
            .iter()
            .zip(&single)
            .all(|(a, b)| (a - b).abs() < 1e-4),
        "{joined:?} vs {single:?}"
    );
    assert_eq!(
        pair.lookup(&q).unwrap().zone,
        clf.lookup(&d[5]).unwrap().zone
    );
    let moved = tmp.path().join("model_moved");
    std::fs::create_dir(&moved).unwrap();
    for entry in std::fs::read_dir(&target.dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            std::fs::copy(&path, moved.join(path.file_name().unwrap())).unwrap();
        }
    }
    let poses = std::fs::read_to_string(moved.join("train_poses.txt")).unwrap();
    let mut shifted = false;
    let edited: String = poses
        .lines()
        .map(|l| {
            if shifted || l.starts_with('#') {
                return format!("{l}\n");
            }
            shifted = true;
            let mut v: Vec<String> = l.split_whitespace().map(str::to_string).collect();
            v[1] = (v[1].parse::<f64>().unwrap() + 1.0).to_string();
            format!("{}\n", v.join(" "))
        })
        .collect();
    std::fs::write(moved.join("train_poses.txt"), edited).unwrap();
    let err = ZoneClassifier::load(&target.dir)
        .unwrap()
        .join(vec![ZoneClassifier::load(&moved).unwrap()])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("training poses") && err.contains("model_moved"),
        "{err}"
    );
    // New frames of each zone are classified correctly (a separable task).
    let test = write_sequence(&tmp.path().join("test"), 99);
    let preds = clf
        .classify_batch(
            &(0..test.len())
                .map(|i| test.load_gray(i).unwrap())
                .collect::<Vec<_>>(),
        )
        .unwrap();
    let right = preds
        .iter()
        .enumerate()
        .filter(|(i, p)| p.zone == i / PER_ZONE)
        .count();
    assert!(
        right as f64 >= 0.9 * preds.len() as f64,
        "{right}/{}",
        preds.len()
    );
    assert_eq!(clf.truth_zone(&test.poses[30].pose), Some(2));
    // The track filter over the test pass (real descriptors): causal and smoothed zones are
    // at least as right as the per-frame ones.
    let test_imgs: Vec<image::GrayImage> = (0..test.len())
        .map(|i| test.load_gray(i).unwrap())
        .collect();
    let dists: Vec<Vec<f32>> = clf
        .describe_batch(&test_imgs)
        .unwrap()
        .iter()
        .map(|q| clf.frame_distances(q).unwrap())
        .collect();
    assert!(dists.iter().all(|d| d.len() == seq.len()));
    let smoothed =
        endoloc_net::track::smooth(&dists, &clf.zones().zone_of_frame, &clf.config().track)
            .unwrap();
    let mut filter = clf.track_filter().unwrap();
    let tracked: Vec<usize> = dists
        .iter()
        .map(|d| filter.update(d).unwrap().zone)
        .collect();
    let count = |zones: &mut dyn Iterator<Item = usize>| {
        zones
            .enumerate()
            .filter(|(i, z)| *z == i / PER_ZONE)
            .count()
    };
    let right_smooth = count(&mut smoothed.iter().map(|e| e.zone));
    let right_track = count(&mut tracked.into_iter());
    assert!(
        right_smooth >= right,
        "smoothed {right_smooth} < per frame {right}"
    );
    assert!(
        right_track + 2 >= right,
        "tracked {right_track} vs per frame {right}"
    );

    // Another camera or image size is a clear error.
    let other = Camera::from_hfov(W * 2, H * 2, 90.0);
    let err = clf.check_compatible(&other).unwrap_err().to_string();
    assert!(err.contains("128x96") && err.contains("64x48"), "{err}");
    let err = clf
        .check_compatible(&Camera::from_hfov(W, H, 60.0))
        .unwrap_err()
        .to_string();
    assert!(err.contains("another camera"), "{err}");
    let err = clf
        .describe(&image::GrayImage::new(10, 10))
        .unwrap_err()
        .to_string();
    assert!(err.contains("10x10"), "{err}");

    // A model whose whitening file is gone says so.
    std::fs::remove_file(target.dir.join("whitening.bin")).unwrap();
    let err = ZoneClassifier::load(&target.dir).unwrap_err().to_string();
    assert!(err.contains("whitening.bin"), "{err}");
}

#[test]
fn extra_passes_join_the_training_pairs_but_not_the_database_and_bad_passes_are_named() {
    let _alone = one_at_a_time();
    let tmp = tempfile::tempdir().unwrap();
    let seq = write_sequence(&tmp.path().join("train"), 4);
    let pass = write_sequence(&tmp.path().join("pass2"), 5);
    let zones = zones_of(&seq);
    let cfg = TrainConfig {
        extra_sequences: vec![pass.dir.clone()],
        ..tiny_config(6)
    };
    let dir = tmp.path().join("model");
    let report = train_into(&dir, &cfg, &seq, &zones).unwrap();
    assert_eq!(report.pass_frames, vec![pass.len()]);
    let clf = ZoneClassifier::load(&dir).unwrap();
    // Zones, database rows and poses are the training sequence's alone.
    assert_eq!(clf.database().len(), seq.len());
    assert_eq!(clf.zones().frame_count(), seq.len());
    assert_eq!(clf.train_poses().len(), seq.len());
    let saved = std::fs::read_to_string(dir.join("model.toml")).unwrap();
    assert!(saved.contains("pass2"), "{saved}");
    // Filter parameters edited into model.toml are checked when the model loads.
    let bad = saved.replace("temperature = 0.3\n", "temperature = -1.0\n");
    assert_ne!(bad, saved, "the track section is written: {saved}");
    std::fs::write(dir.join("model.toml"), bad).unwrap();
    let e = ZoneClassifier::load(&dir).unwrap_err().to_string();
    assert!(
        e.contains("model.toml") && e.contains("track: temperature"),
        "{e}"
    );

    // A pass taken with another camera size is refused, naming its first image.
    let small = tmp.path().join("small");
    std::fs::create_dir_all(small.join("images")).unwrap();
    image::GrayImage::new(W / 2, H / 2)
        .save(small.join("images").join("000000.png"))
        .unwrap();
    endoloc_data::write_tum(
        &small.join("poses.txt"),
        &[StampedPose {
            timestamp_s: 0.0,
            pose: pose_from_parts(Vector3::zeros(), UnitQuaternion::identity()),
        }],
    )
    .unwrap();
    let cfg = TrainConfig {
        extra_sequences: vec![small],
        ..tiny_config(1)
    };
    let e = train_into(&tmp.path().join("model2"), &cfg, &seq, &zones)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("000000.png") && e.contains("32x24") && e.contains("64x48"),
        "{e}"
    );
}

/// A pass whose look turns smoothly with the frame index (stripes at angle `i · π / n`):
/// neighbours look alike, and only the angle places a frame.
fn write_smooth_sequence(dir: &Path, seed: u64) -> Sequence {
    let n = (ZONES * PER_ZONE) as f32;
    write_frames(dir, seed, |i, rng| {
        stripes(i as f32 * std::f32::consts::PI / n, 0.3, rng)
    })
}

/// Mean |nearest training frame − frame| over the frames of `query`.
fn mean_frame_error(clf: &ZoneClassifier, query: &Sequence) -> f64 {
    let errors: Vec<usize> = (0..query.len())
        .map(|i| {
            let d = clf
                .frame_distances(&clf.describe(&query.load_gray(i).unwrap()).unwrap())
                .unwrap();
            let nearest = (0..d.len()).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap();
            nearest.abs_diff(i)
        })
        .collect();
    errors.iter().sum::<usize>() as f64 / errors.len() as f64
}

#[test]
fn track_pairs_place_a_frame_along_the_pass_more_finely_than_zone_pairs() {
    let _alone = one_at_a_time();
    let tmp = tempfile::tempdir().unwrap();
    let seq = write_smooth_sequence(&tmp.path().join("train"), 8);
    let query = write_smooth_sequence(&tmp.path().join("query"), 9);
    let zones = zones_of(&seq);
    let mut errors = Vec::new();
    for (name, pairs) in [
        ("zone", PairRule::Zone),
        (
            "track",
            PairRule::Track {
                positive_frames: 1,
                negative_frames: 4,
                near_fraction: 0.5,
                zone_fraction: 0.0,
            },
        ),
    ] {
        let cfg = TrainConfig {
            pairs,
            ..tiny_config(30)
        };
        let dir = tmp.path().join(name);
        train_into(&dir, &cfg, &seq, &zones).unwrap();
        let clf = ZoneClassifier::load(&dir).unwrap();
        errors.push(mean_frame_error(&clf, &query));
    }
    eprintln!(
        "mean frame error: zone pairs {}, track pairs {}",
        errors[0], errors[1]
    );
    // Measured: zone pairs 0.48 frames, track pairs 0.02.
    assert!(
        errors[1] <= 0.25,
        "track pairs: mean frame error {}",
        errors[1]
    );
    assert!(
        errors[1] < 0.5 * errors[0],
        "zone pairs {} vs track pairs {}",
        errors[0],
        errors[1]
    );
}

/// The loss of every epoch, bit for bit.
fn loss_bits(f: &endoloc_net::train::Fitted) -> Vec<u32> {
    f.history.iter().map(|r| r.loss.to_bits()).collect()
}

#[test]
fn same_seed_trains_the_same_network_bit_for_bit_on_any_thread_count() {
    let _alone = one_at_a_time();
    let tmp = tempfile::tempdir().unwrap();
    let seq = write_sequence(&tmp.path().join("train"), 3);
    let zones = zones_of(&seq);
    let mut cfg = tiny_config(6);
    cfg.augment = AugmentConfig::default();
    let cache = ImageCache::from_sequence(&seq, cfg.backbone.input(), &mut |_| {}).unwrap();
    let run = |cfg: &TrainConfig| fit(cfg, &cache, &zones, None, None, false, &mut |_| {}).unwrap();

    let a = run(&cfg);
    let b = run(&cfg);
    assert_eq!(loss_bits(&a), loss_bits(&b), "same seed, same thread pool");

    // The matrix products split their work over threads but not their sums: one thread
    // gives the same bits as the default pool.
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run(&cfg));
    assert_eq!(
        loss_bits(&a),
        loss_bits(&one),
        "one thread against the default pool"
    );

    let mut other = cfg.clone();
    other.seed += 1;
    assert_ne!(loss_bits(&a), loss_bits(&run(&other)), "another seed");
}

/// Like [`write_smooth_sequence`], under a random light ramp of each frame's own direction
/// and strength: what places a frame is learnt, not given by the raw pixels.
fn write_ramped_sequence(dir: &Path, seed: u64) -> Sequence {
    let n = (ZONES * PER_ZONE) as f32;
    write_frames(dir, seed, |i, rng| {
        let mut im = stripes(i as f32 * std::f32::consts::PI / n, 0.3, rng);
        let dir: f32 = rng.random_range(0.0..std::f32::consts::TAU);
        let gain: f32 = rng.random_range(1.0..3.0);
        let (s, c) = dir.sin_cos();
        for (x, y, p) in im.enumerate_pixels_mut() {
            let t = (x as f32 / W as f32 - 0.5) * c + (y as f32 / H as f32 - 0.5) * s;
            p.0[0] = (p.0[0] as f32 * 0.4 + 128.0 * (1.0 + gain * t)).clamp(0.0, 255.0) as u8;
        }
        im
    })
}

/// Joint pretraining: two colons, each with a second pass, in one training; their places and
/// zones kept apart; its weights place the frames of a new pass without further training;
/// other cameras and existing outputs refused.
#[test]
fn joint_pretraining_trains_on_every_colon_at_once_and_its_weights_transfer() {
    let _alone = one_at_a_time();
    use endoloc_net::pairs::COLON_PLACE_STRIDE;
    use endoloc_net::pretrain::{PretrainColon, joint_cache, pretrain};
    let tmp = tempfile::tempdir().unwrap();
    let colon = |name: &str, seed: u64| {
        let train = write_ramped_sequence(&tmp.path().join(name).join("train"), seed);
        let pass = write_ramped_sequence(&tmp.path().join(name).join("test"), seed + 1);
        PretrainColon {
            train,
            passes: vec![pass.dir],
            camera: camera(),
        }
    };
    let colons = vec![colon("a", 20), colon("b", 30)];
    let zcfg = ZoneConfig::uniform(ZONES, UniformBy::Frames);
    let cfg = TrainConfig {
        pairs: PairRule::Track {
            positive_frames: 1,
            negative_frames: 4,
            near_fraction: 0.5,
            zone_fraction: 0.0,
        },
        ..tiny_config(30)
    };
    let n = ZONES * PER_ZONE;
    let (cache, zones, images) = joint_cache(&colons, &zcfg, &cfg, &mut |_| {}).unwrap();
    assert_eq!(images, vec![2 * n, 2 * n]);
    assert_eq!(cache.len(), 4 * n);
    assert_eq!(zones.len(), 2 * ZONES);
    // Colon b's training frame 5 and its second pass's frame 5 (same pose) share a place.
    assert_eq!(cache.along_of(2 * n + 5), COLON_PLACE_STRIDE + 5);
    assert_eq!(cache.along_of(3 * n + 5), COLON_PLACE_STRIDE + 5);
    assert_eq!(zones.zone_of_frame[2 * n], ZONES);
    assert_eq!(zones.zones[ZONES].first_frame, 2 * n);

    let dir = tmp.path().join("joint");
    let target = TrainTarget {
        dir: dir.clone(),
        force: false,
        resume: true,
    };
    let report = pretrain(&cfg, &zcfg, &colons, &target, &mut |_| {}).unwrap();
    assert_eq!(report.images, images);
    let (first, last) = (&report.history[0], report.history.last().unwrap());
    assert!(
        last.loss < 0.5 * first.loss,
        "loss {} → {}",
        first.loss,
        last.loss
    );
    for f in ["weights.safetensors", "pretrain.toml", "history.csv"] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    assert!(!dir.join("checkpoint").exists());
    assert!(!target.staging_dir().exists());
    let record = std::fs::read_to_string(dir.join("pretrain.toml")).unwrap();
    assert!(record.contains("rule = \"track\""), "{record}");

    // A new colon: its database from the pretrained weights, one step at a negligible rate
    // (no training to speak of), places a second pass's frames far better than from random
    // weights.
    let seq = write_ramped_sequence(&tmp.path().join("new/train"), 50);
    let query = write_ramped_sequence(&tmp.path().join("new/test"), 51);
    let mut errors = Vec::new();
    for (name, start) in [
        ("random", None),
        ("pretrained", Some(dir.join("weights.safetensors"))),
    ] {
        let mut cfg = TrainConfig {
            pretrained: start,
            ..tiny_config(1)
        };
        cfg.schedule.learning_rate = 1e-9;
        cfg.schedule.final_learning_rate = 1e-9;
        let model = tmp.path().join(name);
        train_into(&model, &cfg, &seq, &zones_of(&seq)).unwrap();
        errors.push(mean_frame_error(
            &ZoneClassifier::load(&model).unwrap(),
            &query,
        ));
    }
    eprintln!(
        "mean frame error: random {}, pretrained {}",
        errors[0], errors[1]
    );
    // Measured: random weights 11.3 frames, pretrained 3.3 (of 48).
    assert!(
        errors[1] < 0.4 * errors[0],
        "random weights {} vs pretrained {} frames",
        errors[0],
        errors[1]
    );

    // An existing folder is kept; a colon of another camera is refused by name.
    let e = pretrain(&cfg, &zcfg, &colons, &target, &mut |_| {}).unwrap_err();
    assert!(matches!(e, NetError::AlreadyExists { .. }), "{e}");
    let mut odd = colons.clone();
    odd[1].camera = Camera::from_hfov(W, H, 60.0);
    let e = joint_cache(&odd, &zcfg, &cfg, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("camera") && e.contains("b/train"), "{e}");
}

/// `epochs = 0` with start weights: no optimisation, the database of the pass from the start
/// weights as they are — the same rows a model with those weights wrote. Refused from random
/// weights.
#[test]
fn zero_epochs_index_the_pass_with_the_start_weights_and_need_them() {
    let _alone = one_at_a_time();
    let tmp = tempfile::tempdir().unwrap();
    let seq = write_sequence(&tmp.path().join("train"), 60);
    let zones = zones_of(&seq);
    let first = tmp.path().join("first");
    train_into(&first, &tiny_config(4), &seq, &zones).unwrap();
    let mut cfg = TrainConfig {
        pretrained: Some(first.join("weights.safetensors")),
        ..tiny_config(4)
    };
    cfg.schedule.epochs = 0;
    let indexed = tmp.path().join("indexed");
    let report = train_into(&indexed, &cfg, &seq, &zones).unwrap();
    assert_eq!(report.steps, 0);
    assert!(report.history.is_empty());
    let (a, b) = (
        ZoneClassifier::load(&first).unwrap(),
        ZoneClassifier::load(&indexed).unwrap(),
    );
    assert_eq!(a.database().len(), b.database().len());
    for i in 0..a.database().len() {
        assert_eq!(a.database().row(i), b.database().row(i), "row {i}");
    }

    // Smoothed along the pass, the rows are the smoothed rows of the first model.
    // (frames are 1 mm apart: ±2 mm is ±2 frames.)
    cfg.database_smoothing_mm = 2.0;
    let smoothed = tmp.path().join("smoothed");
    train_into(&smoothed, &cfg, &seq, &zones).unwrap();
    let c = ZoneClassifier::load(&smoothed).unwrap();
    let path: Vec<f64> = (0..seq.len()).map(|i| i as f64).collect();
    let want = endoloc_net::database::smooth_along_pass(
        &a.database().descriptors,
        a.database().dim,
        &path,
        2.0,
    );
    assert_eq!(c.database().descriptors, want);
    assert_ne!(c.database().descriptors, a.database().descriptors);

    // Zoom-blurred views: after the sharp rows (those of the first model), one row per frame
    // and amplitude, each of its frame and zone; through a file and back.
    cfg.database_smoothing_mm = 0.0;
    cfg.index_zoom_blur = vec![0.05, 0.1];
    cfg.index_view_penalty = 0.04;
    let zoomed = tmp.path().join("zoomed");
    train_into(&zoomed, &cfg, &seq, &zones).unwrap();
    let z = ZoneClassifier::load(&zoomed).unwrap();
    let (n, dim) = (seq.len(), a.database().dim);
    assert_eq!(z.database().len(), 3 * n);
    // The views' look-up penalty comes back with the model.
    assert_eq!(z.database().view_penalty, 0.04);
    assert_eq!(z.database().frame_count(), n);
    assert_eq!(
        &z.database().descriptors[..n * dim],
        &a.database().descriptors[..]
    );
    for view in 1..3 {
        for f in 0..n {
            let r = view * n + f;
            assert_eq!(z.database().frame_of_row[r], f);
            assert_eq!(z.database().zone_of_row[r], zones.zone_of_frame[f]);
            assert_ne!(z.database().row(r), a.database().row(f), "row {r}");
        }
    }

    cfg.pretrained = None;
    let e = train_into(&tmp.path().join("none"), &cfg, &seq, &zones)
        .unwrap_err()
        .to_string();
    assert!(e.contains("0 epochs") && e.contains("start weights"), "{e}");
}
