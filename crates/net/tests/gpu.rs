//! A GPU gives the CPU's results within float tolerance: the same seed trains the same
//! network, and descriptors of the same images agree.
//!
//! Runs in a build with `--features cuda` (or `wgpu`) on a machine with such a device:
//! `cargo test --release -p endoloc-net --features cuda --test gpu -- --nocapture`.
//! Anywhere else it prints why it was skipped and passes.

use endoloc_data::{Sequence, StampedPose};
use endoloc_geometry::{Camera, pose::pose_from_parts};
use endoloc_net::backbone::BackboneConfig;
use endoloc_net::train::{ImageCache, Schedule, TrainConfig, TrainTarget, fit, train};
use endoloc_net::{AugmentConfig, InputSize, UniformBy, ZoneClassifier, ZoneConfig, ZoneTable};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

const ZONES: usize = 4;
const PER_ZONE: usize = 12;
const W: u32 = 64;
const H: u32 = 48;

/// The GPU device compiled into this build that answers a first tensor operation, or why
/// there is none.
fn gpu() -> Result<&'static str, String> {
    let compiled: Vec<&str> = endoloc_net::device::available()
        .into_iter()
        .filter(|d| *d != "cpu")
        .collect();
    let Some(&name) = compiled.first() else {
        return Err("built without a GPU backend (`--features cuda` or `wgpu`)".into());
    };
    let device = endoloc_net::device::from_name(name).map_err(|e| e.to_string())?;
    // A backend without a usable device panics on its first operation.
    let probe = std::panic::catch_unwind(|| {
        let t = burn::tensor::Tensor::<1>::from_floats([1.0f32, 2.0, 3.0], &device);
        t.sum()
            .into_data()
            .try_into_vec::<f32>()
            .ok()
            .and_then(|v| v.first().copied())
            .unwrap_or(f32::NAN)
    });
    match probe {
        Ok(v) if (v - 6.0).abs() < 1e-6 => Ok(name),
        Ok(v) => Err(format!("{name}: a sum of 1+2+3 gave {v}")),
        Err(_) => Err(format!("{name} is compiled in but no device answered")),
    }
}

fn frame(z: usize, rng: &mut ChaCha8Rng) -> image::GrayImage {
    let angle = z as f32 * std::f32::consts::PI / ZONES as f32;
    let freq = 0.15 + 0.1 * z as f32;
    let phase: f32 = rng.random_range(0.0..std::f32::consts::TAU);
    let (s, c) = angle.sin_cos();
    image::GrayImage::from_fn(W, H, |x, y| {
        let v = ((x as f32 * c + y as f32 * s) * freq + phase).sin();
        let n: f32 = rng.random_range(-0.2..0.2);
        image::Luma([((v + n) * 100.0 + 128.0).clamp(0.0, 255.0) as u8])
    })
}

/// A sequence of striped frames, `PER_ZONE` per zone, 1 mm apart along x.
fn write_sequence(dir: &Path) -> (Sequence, Vec<image::GrayImage>) {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let mut poses = Vec::new();
    let mut images = Vec::new();
    for i in 0..ZONES * PER_ZONE {
        let img = frame(i / PER_ZONE, &mut rng);
        img.save(dir.join("images").join(format!("{i:06}.png")))
            .unwrap();
        images.push(img);
        poses.push(StampedPose {
            timestamp_s: i as f64 / 30.0,
            pose: pose_from_parts(Vector3::new(i as f64, 0.0, 0.0), UnitQuaternion::identity()),
        });
    }
    endoloc_data::write_tum(&dir.join("poses.txt"), &poses).unwrap();
    (Sequence::open(dir).unwrap(), images)
}

fn config(device: &str) -> TrainConfig {
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
            epochs: 6,
            pairs_per_epoch: 32,
            batch_pairs: 16,
            learning_rate: 3e-3,
            final_learning_rate: 1e-3,
            share_images: true,
        },
        augment: AugmentConfig::off(),
        seed: 11,
        whitening: 0.0,
        database_smoothing_mm: 0.0,
        device: device.into(),
        ..TrainConfig::default()
    }
}

fn max_abs_diff(a: &[Vec<f32>], b: &[Vec<f32>]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f32::max)
}

#[test]
fn a_gpu_trains_and_describes_as_the_cpu_does() {
    let name = match gpu() {
        Ok(name) => name,
        Err(why) => {
            println!("skipped: {why}");
            return;
        }
    };
    println!("GPU backend: {name}");
    let tmp = tempfile::tempdir().unwrap();
    let (seq, images) = write_sequence(&tmp.path().join("train"));
    let zones =
        ZoneTable::from_sequence(&seq, &ZoneConfig::uniform(ZONES, UniformBy::Frames)).unwrap();
    let camera = Camera::from_hfov(W, H, 90.0);

    // Same seed, same pairs: the loss of every epoch agrees.
    let cpu_cfg = config("cpu");
    let gpu_cfg = config(name);
    let cache = ImageCache::from_sequence(&seq, cpu_cfg.backbone.input(), &mut |_| {}).unwrap();
    let on_cpu = fit(&cpu_cfg, &cache, &zones, None, None, false, &mut |_| {}).unwrap();
    let on_gpu = fit(&gpu_cfg, &cache, &zones, None, None, false, &mut |_| {}).unwrap();
    for (c, g) in on_cpu.history.iter().zip(&on_gpu.history) {
        println!(
            "epoch {}: loss cpu {:.6} {name} {:.6}",
            c.epoch, c.loss, g.loss
        );
        assert!(
            (c.loss - g.loss).abs() <= 1e-3 * c.loss.abs().max(1.0),
            "epoch {}: loss {} on the CPU, {} on {name}",
            c.epoch,
            c.loss,
            g.loss
        );
    }

    // Whole model folders trained on each device describe the images alike, on either device.
    let target = |d: &str| TrainTarget {
        dir: tmp.path().join(d),
        force: false,
        resume: false,
    };
    train(
        &cpu_cfg,
        &seq,
        &zones,
        &camera,
        "gpu-test",
        &target("cpu"),
        &mut |_| {},
    )
    .unwrap();
    train(
        &gpu_cfg,
        &seq,
        &zones,
        &camera,
        "gpu-test",
        &target(name),
        &mut |_| {},
    )
    .unwrap();
    let cpu_model = ZoneClassifier::load(&tmp.path().join("cpu")).unwrap();
    let gpu_model = ZoneClassifier::load_on(&tmp.path().join(name), name).unwrap();
    let cpu_model_on_gpu = ZoneClassifier::load_on(&tmp.path().join("cpu"), name).unwrap();
    let reference = cpu_model.describe_batch(&images).unwrap();
    let inference = max_abs_diff(
        &reference,
        &cpu_model_on_gpu.describe_batch(&images).unwrap(),
    );
    let trained = max_abs_diff(&reference, &gpu_model.describe_batch(&images).unwrap());
    println!(
        "descriptors (unit length): CPU model on {name} ±{inference:.2e}, {name}-trained model ±{trained:.2e}"
    );
    assert!(inference <= 1e-4, "inference differs by {inference}");
    assert!(trained <= 1e-3, "trained models differ by {trained}");
    let zone = |m: &ZoneClassifier| -> Vec<usize> {
        images.iter().map(|i| m.classify(i).unwrap().zone).collect()
    };
    assert_eq!(zone(&cpu_model), zone(&gpu_model), "zone decisions differ");
}
