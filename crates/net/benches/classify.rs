//! Per-frame cost of zone classification on the CPU: preprocessing a 640×480 frame, the
//! compact backbone's descriptor, the look-up in a 2610-frame database, and all of it
//! together (for one model, whitened or not, and for an ensemble of two); the temporal filters' update per
//! frame; plus one training step of the default schedule (64 pairs over 66 images).
//!
//! Weights are random (timing does not depend on them). Run with
//! `cargo bench -p endoloc-net --bench classify`.

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Int, Tensor, TensorData};
use criterion::{Criterion, criterion_group, criterion_main};
use endoloc_geometry::Camera;
use endoloc_geometry::pose::pose_from_parts;
use endoloc_net::backbone::BackboneConfig;
use endoloc_net::database::{DescriptorDatabase, ScoreRule};
use endoloc_net::loss::contrastive_loss;
use endoloc_net::model::{FORMAT_VERSION, ModelConfig};
use endoloc_net::preprocess::network_input;
use endoloc_net::{TemporalConfig, TrainConfig, UniformBy, ZoneClassifier, ZoneConfig, ZoneTable};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

const FRAMES: usize = 2610;
const ZONES: usize = 50;

fn frame(seed: u64) -> image::GrayImage {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    image::GrayImage::from_fn(640, 480, |x, y| {
        let v = ((x as f32 * 0.05).sin() + (y as f32 * 0.07).cos()) * 60.0 + 128.0;
        image::Luma([(v + rng.random_range(-10.0..10.0)).clamp(0.0, 255.0) as u8])
    })
}

fn classifier() -> ZoneClassifier {
    classifier_with(false)
}

/// The benchmark classifier; `whiten`: with a whitening learnt from its database (the
/// default of `endoloc train`), applied to every descriptor.
fn classifier_with(whiten: bool) -> ZoneClassifier {
    let device = endoloc_net::device::cpu();
    device.seed(1);
    let backbone = BackboneConfig::compact();
    let net = backbone.init(&device).valid();
    let poses: Vec<_> = (0..FRAMES)
        .map(|i| pose_from_parts(Vector3::new(i as f64, 0.0, 0.0), UnitQuaternion::identity()))
        .collect();
    let zcfg = ZoneConfig::uniform(ZONES, UniformBy::Frames);
    let zones = ZoneTable::from_poses(&poses, None, &zcfg).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let dim = backbone.descriptor_dim();
    let mut d: Vec<f32> = (0..FRAMES * dim)
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    for row in d.chunks_exact_mut(dim) {
        let n = row.iter().map(|v| v * v).sum::<f32>().sqrt();
        row.iter_mut().for_each(|v| *v /= n);
    }
    let whitening = whiten.then(|| {
        endoloc_net::whiten::Whitening::fit(&d, dim, endoloc_net::train::DEFAULT_WHITENING).unwrap()
    });
    if let Some(w) = &whitening {
        d = w.apply_rows(&d);
    }
    let db = DescriptorDatabase::new(dim, ZONES, d, zones.zone_of_frame.clone()).unwrap();
    let config = ModelConfig {
        format_version: FORMAT_VERSION,
        dataset: "bench".into(),
        sequence: "train".into(),
        frames: FRAMES,
        score: ScoreRule::Nearest,
        camera: Camera::from_hfov(640, 480, 90.0),
        backbone,
        zones: zcfg,
        temporal: TemporalConfig::default(),
        track: Default::default(),
        whitening: whitening.as_ref().map(|w| w.power),
        train: TrainConfig::default(),
        provenance: None,
    };
    ZoneClassifier::from_parts(
        std::path::PathBuf::from("bench"),
        config,
        net,
        whitening,
        device,
        zones,
        db,
        poses,
    )
    .unwrap()
}

fn bench_inference(c: &mut Criterion) {
    let clf = classifier();
    let img = frame(3);
    let size = clf.config().backbone.input();
    let q = clf.describe(&img).unwrap();
    let mut g = c.benchmark_group("classify_640x480");
    g.sample_size(30);
    g.bench_function("preprocess", |b| {
        b.iter(|| network_input(black_box(&img), size))
    });
    g.bench_function("describe", |b| {
        b.iter(|| clf.describe(black_box(&img)).unwrap())
    });
    g.bench_function("lookup_2610", |b| {
        b.iter(|| clf.lookup(black_box(&q)).unwrap())
    });
    g.bench_function("describe_and_lookup", |b| {
        b.iter(|| clf.classify(black_box(&img)).unwrap())
    });
    // With the default whitening: one 128 × 128 product more per frame.
    let whitened = classifier_with(true);
    g.bench_function("describe_and_lookup_whitened", |b| {
        b.iter(|| whitened.classify(black_box(&img)).unwrap())
    });
    // An ensemble of two models (`ZoneClassifier::join`): two networks, a 256-d look-up.
    let pair = classifier().join(vec![classifier()]).unwrap();
    g.bench_function("describe_and_lookup_ensemble_of_2", |b| {
        b.iter(|| pair.classify(black_box(&img)).unwrap())
    });
    // The live filters' cost per frame, after the look-up: the zone HMM (50 states) and the
    // track filter (2610 training frames × 7 speeds), with the frame distances it needs.
    let pred = clf.lookup(&q).unwrap();
    let mut zone_filter = endoloc_net::TemporalFilter::new(ZONES, clf.config().temporal);
    g.bench_function("zone_filter_update", |b| {
        b.iter(|| zone_filter.update(black_box(&pred)))
    });
    g.bench_function("frame_distances_2610", |b| {
        b.iter(|| clf.frame_distances(black_box(&q)).unwrap())
    });
    let dist = clf.frame_distances(&q).unwrap();
    let mut track = clf.track_filter().unwrap();
    g.bench_function("track_filter_update_2610", |b| {
        b.iter(|| track.update(black_box(&dist)).unwrap())
    });
    let batch: Vec<image::GrayImage> = (0..64).map(frame).collect();
    g.sample_size(10);
    g.bench_function("classify_batch_64_frames", |b| {
        b.iter(|| clf.classify_batch(black_box(&batch)).unwrap())
    });
    g.finish();
}

fn bench_train_step(c: &mut Criterion) {
    let device = endoloc_net::device::cpu().autodiff();
    device.seed(1);
    let backbone = BackboneConfig::compact();
    let size = backbone.input();
    let mut net = backbone.init(&device);
    let mut optim = AdamConfig::new().init();
    let n = 66;
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let buf: Vec<f32> = (0..n * size.pixels())
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let a: Vec<i32> = (0..64).map(|k| (k % 33) * 2).collect();
    let bidx: Vec<i32> = (0..64).map(|k| (k % 33) * 2 + 1).collect();
    let y: Vec<f32> = (0..64).map(|k| (k / 32) as f32).collect();
    let mut g = c.benchmark_group("train_step");
    g.sample_size(10);
    g.bench_function("compact_64_pairs_66_images", |b| {
        b.iter(|| {
            let x = Tensor::<4>::from_data(
                TensorData::new(
                    buf.clone(),
                    [n, 1, size.height as usize, size.width as usize],
                ),
                &device,
            );
            let d = net.forward(x);
            let ia = Tensor::<1, Int>::from_ints(TensorData::new(a.clone(), [64]), &device);
            let ib = Tensor::<1, Int>::from_ints(TensorData::new(bidx.clone(), [64]), &device);
            let yt = Tensor::<1>::from_data(TensorData::new(y.clone(), [64]), &device);
            let loss = contrastive_loss(d.clone().select(0, ia), d.select(0, ib), yt, 1.0);
            let grads = GradientsParams::from_grads(loss.backward(), &net);
            net = optim.step(1e-3, net.clone(), grads);
        })
    });
    g.finish();
}

criterion_group!(benches, bench_inference, bench_train_step);
criterion_main!(benches);
