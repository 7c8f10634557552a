//! Measurement on a real dataset (ignored by default; minutes of training):
//!
//! ```text
//! cargo test --release -p endoloc-net --test regress_paper -- --ignored --nocapture paper_posenet
//! cargo test --release -p endoloc-net --test regress_paper -- --ignored --nocapture paper_offsetnet
//! ```
//!
//! Environment: `ENDOLOC_REGRESS_DATA` (dataset with `train/` and `test/`, e.g. the output of
//! `endoloc simulate --preset paper --out data/paper`; the tests skip with a message when it
//! is unset), `ENDOLOC_REGRESS_OUT` (where the models are written, default a temporary
//! folder), `ENDOLOC_REGRESS_ZONE_MODEL` (a zone-classifier model folder, e.g.
//! `models/paper50`, whose nearest training frame is OffsetNet's reference; skipped when unset
//! or when it cannot be loaded), `ENDOLOC_REGRESS_SCHEDULE` (`fast` or `paper`, default
//! `fast`).
//!
//! Prints the mean and median position (mm) and orientation (°) errors on the test sequence
//! and the training time; asserts that each baseline beats predicting the mean training pose.

use endoloc_data::{Dataset, Sequence};
use endoloc_geometry::pose::pose_from_parts;
use endoloc_geometry::rotation_mean::chordal_mean;
use endoloc_geometry::{Camera, Pose, orientation_error_deg, position_error_mm};
use endoloc_net::ZoneClassifier;
use endoloc_net::regress::{
    RegressConfig, RegressSchedule, TrainingSet, train_offsetnet, train_posenet,
};
use std::path::PathBuf;
use std::time::Instant;

fn env_path(name: &str) -> Option<PathBuf> {
    std::env::var_os(name).map(PathBuf::from)
}

fn config() -> RegressConfig {
    let schedule = std::env::var("ENDOLOC_REGRESS_SCHEDULE").unwrap_or_else(|_| "fast".into());
    RegressConfig {
        schedule: RegressSchedule::from_name(&schedule).unwrap(),
        ..RegressConfig::default()
    }
}

/// The dataset named by `ENDOLOC_REGRESS_DATA`, or `None` (with the reason printed) when the
/// variable is unset.
fn open() -> Option<(Sequence, Sequence, Camera)> {
    let Some(dir) = env_path("ENDOLOC_REGRESS_DATA") else {
        println!(
            "skipped: set ENDOLOC_REGRESS_DATA to a dataset with train/ and test/ \
             (e.g. endoloc simulate --preset paper --out data/paper)"
        );
        return None;
    };
    let ds = Dataset::open(&dir).unwrap();
    Some((
        ds.sequence("train").unwrap(),
        ds.sequence("test").unwrap(),
        ds.meta.camera,
    ))
}

fn load_training(train: &Sequence, camera: &Camera, cfg: &RegressConfig) -> TrainingSet {
    let t = Instant::now();
    let data =
        TrainingSet::from_sequence(train, camera, cfg.backbone.input(), &mut |_| {}).unwrap();
    println!(
        "loaded {} training frames in {:.1} s",
        data.len(),
        t.elapsed().as_secs_f64()
    );
    data
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// (mean mm, median mm, mean °, median °)
fn summary(est: &[Pose], truth: &[Pose]) -> (f64, f64, f64, f64) {
    let p: Vec<f64> = est
        .iter()
        .zip(truth)
        .map(|(e, t)| position_error_mm(e, t))
        .collect();
    let o: Vec<f64> = est
        .iter()
        .zip(truth)
        .map(|(e, t)| orientation_error_deg(e, t))
        .collect();
    let n = p.len() as f64;
    (
        p.iter().sum::<f64>() / n,
        median(p),
        o.iter().sum::<f64>() / n,
        median(o),
    )
}

fn report(name: &str, est: &[Pose], truth: &[Pose]) -> (f64, f64) {
    let (pm, pmed, om, omed) = summary(est, truth);
    println!(
        "| {name} | {pm:.1} | {pmed:.1} | {om:.2} | {omed:.2} | {} |",
        est.len()
    );
    (pm, om)
}

/// Error of predicting the mean training position and the chordal-mean rotation.
fn mean_pose_baseline(train: &Sequence, truth: &[Pose]) -> (f64, f64) {
    let n = train.poses.len() as f64;
    let t = train
        .poses
        .iter()
        .map(|p| p.pose.translation.vector)
        .sum::<nalgebra::Vector3<f64>>()
        / n;
    let rots: Vec<_> = train.poses.iter().map(|p| p.pose.rotation).collect();
    let mean = pose_from_parts(t, chordal_mean(&rots).unwrap());
    report("mean training pose", &vec![mean; truth.len()], truth)
}

fn out_dir(name: &str) -> (PathBuf, Option<tempfile::TempDir>) {
    match std::env::var_os("ENDOLOC_REGRESS_OUT") {
        Some(d) => (PathBuf::from(d).join(name), None),
        None => {
            let t = tempfile::tempdir().unwrap();
            (t.path().join(name), Some(t))
        }
    }
}

const HEADER: &str = "| method | mean pos (mm) | median pos (mm) | mean rot (°) | median rot (°) | frames |\n|---|---|---|---|---|---|";

#[test]
#[ignore = "trains on a real dataset for minutes"]
fn paper_posenet() {
    let Some((train, test, camera)) = open() else {
        return;
    };
    let cfg = config();
    let data = load_training(&train, &camera, &cfg);
    let t = Instant::now();
    let mut last = 0;
    let model = train_posenet(&cfg, &data, &mut |p| {
        if p.epoch != last {
            last = p.epoch;
            if let Some(l) = p.loss {
                eprintln!(
                    "epoch {} loss {l:.4} at {:.0} s",
                    p.epoch,
                    t.elapsed().as_secs_f64()
                );
            }
        }
    })
    .unwrap();
    println!("posenet training: {:.1} s wall", t.elapsed().as_secs_f64());
    let (dir, _keep) = out_dir("posenet");
    model.save(&dir, true).unwrap();
    let t = Instant::now();
    let mut est = Vec::with_capacity(test.len());
    let frames: Vec<usize> = (0..test.len()).collect();
    for chunk in frames.chunks(256) {
        let imgs: Vec<_> = chunk.iter().map(|&i| test.load_gray(i).unwrap()).collect();
        est.extend(model.predict_batch(&imgs).unwrap());
    }
    println!(
        "posenet inference: {:.2} ms per frame (PNG decoding included)",
        1e3 * t.elapsed().as_secs_f64() / test.len() as f64
    );
    let truth: Vec<Pose> = test.poses.iter().map(|p| p.pose).collect();
    println!("{HEADER}");
    let (bp, bo) = mean_pose_baseline(&train, &truth);
    let (p, o) = report("PoseNet", &est, &truth);
    assert!(p < bp && o < bo, "PoseNet does not beat the mean pose");
}

#[test]
#[ignore = "trains on a real dataset for minutes"]
fn paper_offsetnet() {
    let Some((train, test, camera)) = open() else {
        return;
    };
    let cfg = config();
    let data = load_training(&train, &camera, &cfg);
    let t = Instant::now();
    let mut last = 0;
    let model = train_offsetnet(&cfg, &data, &mut |p| {
        if p.epoch != last {
            last = p.epoch;
            if let Some(l) = p.loss {
                eprintln!(
                    "epoch {} loss {l:.4} at {:.0} s",
                    p.epoch,
                    t.elapsed().as_secs_f64()
                );
            }
        }
    })
    .unwrap();
    println!(
        "offsetnet training: {:.1} s wall",
        t.elapsed().as_secs_f64()
    );
    let (dir, _keep) = out_dir("offsetnet");
    model.save(&dir, true).unwrap();

    let truth: Vec<Pose> = test.poses.iter().map(|p| p.pose).collect();
    let train_poses: Vec<Pose> = train.poses.iter().map(|p| p.pose).collect();
    // Oracle reference: the training frame nearest in position (upper bound of the method).
    let oracle: Vec<usize> = truth
        .iter()
        .map(|t| {
            (0..train_poses.len())
                .min_by(|&a, &b| {
                    position_error_mm(&train_poses[a], t)
                        .total_cmp(&position_error_mm(&train_poses[b], t))
                })
                .unwrap_or(0)
        })
        .collect();
    let retrieved: Option<Vec<usize>> = match env_path("ENDOLOC_REGRESS_ZONE_MODEL") {
        None => {
            println!("ENDOLOC_REGRESS_ZONE_MODEL unset: Siamese reference skipped");
            None
        }
        Some(zone_model) => match ZoneClassifier::load(&zone_model) {
            Ok(clf) => {
                let mut v = Vec::with_capacity(test.len());
                let frames: Vec<usize> = (0..test.len()).collect();
                for chunk in frames.chunks(256) {
                    let imgs: Vec<_> = chunk.iter().map(|&i| test.load_gray(i).unwrap()).collect();
                    v.extend(
                        clf.classify_batch(&imgs)
                            .unwrap()
                            .into_iter()
                            .map(|p| p.nearest_frame),
                    );
                }
                Some(v)
            }
            Err(e) => {
                println!(
                    "zone model {} not usable ({e}): Siamese reference skipped",
                    zone_model.display()
                );
                None
            }
        },
    };
    let run = |refs: &[usize]| -> Vec<Pose> {
        let t = Instant::now();
        let mut est = Vec::with_capacity(test.len());
        let frames: Vec<usize> = (0..test.len()).collect();
        for chunk in frames.chunks(256) {
            let q: Vec<_> = chunk.iter().map(|&i| test.load_gray(i).unwrap()).collect();
            let r: Vec<_> = chunk
                .iter()
                .map(|&i| train.load_gray(refs[i]).unwrap())
                .collect();
            let tr: Vec<_> = chunk.iter().map(|&i| train_poses[refs[i]]).collect();
            est.extend(model.predict_batch(&q, &r, &tr).unwrap());
        }
        println!(
            "offsetnet inference: {:.2} ms per frame (two PNG decodings included)",
            1e3 * t.elapsed().as_secs_f64() / test.len() as f64
        );
        est
    };
    let est_oracle = run(&oracle);
    let est_siamese = retrieved.as_ref().map(|r| run(r));
    println!("{HEADER}");
    let (bp, bo) = mean_pose_baseline(&train, &truth);
    let oracle_ref: Vec<Pose> = oracle.iter().map(|&i| train_poses[i]).collect();
    report(
        "nearest-position training pose (oracle retrieval)",
        &oracle_ref,
        &truth,
    );
    let (p, o) = report("OffsetNet, oracle reference", &est_oracle, &truth);
    if let (Some(r), Some(est)) = (&retrieved, &est_siamese) {
        let ref_poses: Vec<Pose> = r.iter().map(|&i| train_poses[i]).collect();
        report(
            "Siamese nearest training pose (retrieval)",
            &ref_poses,
            &truth,
        );
        report("OffsetNet, Siamese nearest-frame reference", est, &truth);
    }
    assert!(p < bp && o < bo, "OffsetNet does not beat the mean pose");
}
