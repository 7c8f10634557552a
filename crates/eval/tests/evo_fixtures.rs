//! Our APE/RPE against evo's on committed fixtures, to 1e-6 (evo itself is not needed).
//!
//! `tests/fixtures/evo/{gt,est}.txt` come from `scripts/evo_crosscheck.py fixtures` (seeded);
//! `evo_stats.json` from `scripts/evo_crosscheck.py evo-stats` (evo version inside). The
//! estimate misses frames, has time-stamp jitter, an unmatched pose and flipped quaternion
//! signs, so association, alignment and RPE pairing are all exercised.

use std::path::{Path, PathBuf};

use endoloc_data::read_tum;
use endoloc_eval::{
    AlignmentKind, AssociationConfig, PoseRelation, RpeConfig, Statistics, align_trajectory,
    ape_errors, associate, rpe_errors,
};
use endoloc_geometry::Pose;
use serde_json::Value;

const TOL: f64 = 1e-6;

fn fixture_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/evo")
}

struct Loaded {
    gt: Vec<Pose>,
    est: Vec<Pose>,
    est_stamps: Vec<f64>,
    evo: Value,
}

fn load() -> Loaded {
    let d = fixture_dir();
    let gt = read_tum(&d.join("gt.txt")).unwrap();
    let est = read_tum(&d.join("est.txt")).unwrap();
    let gs: Vec<f64> = gt.iter().map(|p| p.timestamp_s).collect();
    let es: Vec<f64> = est.iter().map(|p| p.timestamp_s).collect();
    let a = associate(&gs, &es, &AssociationConfig::default()).unwrap();
    let evo: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("evo_stats.json")).unwrap()).unwrap();
    Loaded {
        gt: a.pairs.iter().map(|p| gt[p.gt_index].pose).collect(),
        est: a.pairs.iter().map(|p| est[p.est_index].pose).collect(),
        est_stamps: a
            .pairs
            .iter()
            .map(|p| est[p.est_index].timestamp_s)
            .collect(),
        evo,
    }
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Compares the statistics and the per-pair error array of one evo case.
fn check(l: &Loaded, case: &str, errors: &[f64]) {
    let c = &l.evo["cases"][case];
    assert!(c.is_object(), "case {case} missing from evo_stats.json");
    let want = floats(&c["errors"]);
    assert_eq!(errors.len(), want.len(), "{case}: number of errors");
    for (i, (a, b)) in errors.iter().zip(&want).enumerate() {
        assert!((a - b).abs() < TOL, "{case}: error {i}: ours {a}, evo {b}");
    }
    let s = Statistics::from_errors(errors, case).unwrap();
    let st = &c["stats"];
    for (key, ours) in [
        ("rmse", s.rmse),
        ("mean", s.mean),
        ("median", s.median),
        ("std", s.std),
        ("min", s.min),
        ("max", s.max),
    ] {
        let evo = st[key].as_f64().unwrap();
        assert!(
            (ours - evo).abs() < TOL,
            "{case} {key}: ours {ours}, evo {evo} (|diff| {:e})",
            (ours - evo).abs()
        );
    }
}

#[test]
fn fixtures_are_what_the_docs_say() {
    let l = load();
    let evo = &l.evo;
    assert!(evo["evo_version"].as_str().unwrap().contains("1.38"));
    // 48 ground-truth poses, 43 estimated, 6 frames missing, 1 estimate unmatched → 42 pairs.
    assert_eq!(l.gt.len(), 42);
}

#[test]
fn association_matches_evo() {
    let l = load();
    let want = floats(&l.evo["cases"]["ape_trans_part"]["est_timestamps"]);
    assert_eq!(l.est_stamps, want);
}

#[test]
fn ape_matches_evo_without_alignment() {
    let l = load();
    for (case, rel) in [
        ("ape_trans_part", PoseRelation::TransPart),
        ("ape_angle_deg", PoseRelation::AngleDeg),
        ("ape_rot_part", PoseRelation::RotPart),
        ("ape_full", PoseRelation::Full),
    ] {
        check(&l, case, &ape_errors(&l.gt, &l.est, rel).unwrap());
    }
}

#[test]
fn ape_matches_evo_with_umeyama_alignment() {
    let l = load();
    for (case, kind, rel) in [
        (
            "ape_trans_part_se3",
            AlignmentKind::Se3,
            PoseRelation::TransPart,
        ),
        (
            "ape_angle_deg_se3",
            AlignmentKind::Se3,
            PoseRelation::AngleDeg,
        ),
        (
            "ape_trans_part_sim3",
            AlignmentKind::Sim3,
            PoseRelation::TransPart,
        ),
    ] {
        let (_, aligned) = align_trajectory(&l.gt, &l.est, kind).unwrap();
        check(&l, case, &ape_errors(&l.gt, &aligned, rel).unwrap());
    }
}

#[test]
fn rpe_matches_evo() {
    let l = load();
    let d1 = RpeConfig::default();
    let d3 = RpeConfig {
        delta_frames: 3,
        all_pairs: false,
    };
    let d3_all = RpeConfig {
        delta_frames: 3,
        all_pairs: true,
    };
    for (case, cfg, rel) in [
        ("rpe_trans_part", d1, PoseRelation::TransPart),
        ("rpe_angle_deg", d1, PoseRelation::AngleDeg),
        ("rpe_rot_part", d1, PoseRelation::RotPart),
        ("rpe_trans_part_d3", d3, PoseRelation::TransPart),
        ("rpe_trans_part_d3_all", d3_all, PoseRelation::TransPart),
    ] {
        check(
            &l,
            case,
            &rpe_errors(&l.gt, &l.est, &cfg, rel).unwrap().errors,
        );
    }
}
