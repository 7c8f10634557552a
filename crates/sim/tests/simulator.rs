//! End-to-end checks of the simulator: conventions, lumen clearance, determinism, dataset
//! output and bad inputs.

use std::path::{Path, PathBuf};

use endoloc_data::{Dataset, Section};
use endoloc_geometry::Pose;
use endoloc_sim::appearance::MucosaAtlas;
use endoloc_sim::colon::ColonModel;
use endoloc_sim::colon::from_mesh::MeshColonConfig;
use endoloc_sim::config::{ColonSource, Preset, SimConfig};
use endoloc_sim::render::{RenderScratch, Renderer};
use endoloc_sim::simulate::build_colon;
use endoloc_sim::trajectory::{Pass, PassGenerator};
use nalgebra::{Point2, Point3};

fn tiny_config(seed: u64) -> SimConfig {
    let mut cfg = SimConfig::preset(Preset::Small).with_seed(seed);
    cfg.camera.width = 160;
    cfg.camera.height = 120;
    cfg.train.frames = 40;
    cfg.test.frames = 30;
    cfg
}

fn gca_dir() -> Option<PathBuf> {
    // The CT colon's folder comes from the environment; `.ci/run` sets it when the data exists.
    match std::env::var_os("ENDOLOC_GCA_DIR").map(PathBuf::from) {
        Some(d) if d.join("large_intestine_path.jsn").is_file() => Some(d),
        other => {
            eprintln!(
                "SKIPPED: set ENDOLOC_GCA_DIR to a Gut Cell Atlas colon folder (now {:?})",
                other
            );
            None
        }
    }
}

/// Möller–Trumbore: does the open segment `a → b` cross triangle `t`?
fn segment_hits_triangle(a: &Point3<f64>, b: &Point3<f64>, t: [Point3<f64>; 3]) -> bool {
    let dir = b - a;
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let p = dir.cross(&e2);
    let det = e1.dot(&p);
    if det.abs() < 1e-12 {
        return false;
    }
    let inv = 1.0 / det;
    let s = a - t[0];
    let u = s.dot(&p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(&e1);
    let v = dir.dot(&q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let x = e2.dot(&q) * inv;
    x > 1e-9 && x < 1.0 - 1e-9
}

/// Every pose is finite, at least `clearance` from the wall, and inside the lumen: the segment
/// from the mid-line to the lens crosses no wall triangle.
fn assert_inside_lumen(colon: &ColonModel, pass: &Pass, clearance: f64) {
    let c = &colon.centerline;
    for (k, (pose, s)) in pass.poses.iter().zip(&pass.s_mm).enumerate() {
        let t = pose.translation.vector;
        let q = pose.rotation.coords;
        assert!(
            t.iter().chain(q.iter()).all(|v| v.is_finite()),
            "frame {k}: non-finite pose {pose:?}"
        );
        let p = Point3::from(t);
        let (d, _) = colon.distance_to_surface(&p, s - 120.0, s + 120.0);
        assert!(
            d >= clearance - 1e-6,
            "frame {k}: lens {d:.3} mm from the wall, clearance {clearance} mm"
        );
        let centre = c.point_at(*s);
        let chunks = colon.mesh.chunks_between(s - 60.0, s + 60.0);
        let crossings = colon.mesh.triangles[colon.mesh.triangle_range(chunks)]
            .iter()
            .filter(|t| {
                segment_hits_triangle(&centre, &p, t.map(|v| colon.mesh.positions[v as usize]))
            })
            .count();
        assert_eq!(crossings, 0, "frame {k}: the lens is outside the lumen");
    }
}

#[test]
fn procedural_passes_stay_inside_the_lumen_with_clearance() {
    let cfg = SimConfig::preset(Preset::Small).with_seed(3);
    let colon = build_colon(&cfg).unwrap();
    for traj in [&cfg.train, &cfg.test] {
        let pass = PassGenerator::new(&colon, traj)
            .unwrap()
            .generate()
            .unwrap();
        assert_inside_lumen(&colon, &pass, traj.clearance_mm);
        // The pass runs from the anal canal to the caecum.
        assert_eq!(pass.sections[0], Section::AnalCanal);
        assert_eq!(*pass.sections.last().unwrap(), Section::Caecum);
    }
}

#[test]
fn ct_mesh_passes_stay_inside_the_inflated_lumen() {
    let Some(dir) = gca_dir() else { return };
    let mut mesh = MeshColonConfig::from_gca_folder(&dir).unwrap();
    mesh.surface = dir.join("large_intestine_20k.vtk"); // faster, same colon
    mesh.inflation = 1.5; // the scanned lumen is narrower than 2 × 3 mm in places
    let cfg = tiny_config(5).with_mesh_colon(mesh);
    let colon = build_colon(&cfg).unwrap();
    let len = colon.centerline.length_mm();
    assert!((1300.0..1450.0).contains(&len), "mid-line {len} mm");
    let ranges = colon.section_ranges();
    let order: Vec<Section> = ranges.iter().map(|r| r.0).collect();
    assert_eq!(order, Section::ALL.to_vec());
    let mut traj = cfg.train.clone();
    traj.frames = 400;
    let pass = PassGenerator::new(&colon, &traj)
        .unwrap()
        .generate()
        .unwrap();
    assert_inside_lumen(&colon, &pass, traj.clearance_mm);
    assert_eq!(*pass.sections.last().unwrap(), Section::Caecum);
}

/// Pins the camera and pose conventions: a rendered pixel back-projected with its depth and
/// its pose lands on the colon surface.
#[test]
fn rendered_pixels_back_project_onto_the_surface() {
    back_project_onto_the_surface(tiny_config(1), 2e-4);
}

/// A fisheye camera (rendered through a wider pinhole and resampled) with a field stop: every
/// pixel with depth, unprojected through the fisheye model, lands on the colon wall.
#[test]
fn fisheye_pixels_back_project_onto_the_surface() {
    let mut cfg = tiny_config(1);
    cfg.camera.hfov_deg = 120.0;
    cfg.camera.distortion = endoloc_geometry::Distortion::Fisheye {
        k1: -0.03,
        k2: 0.004,
        k3: 0.0,
        k4: 0.0,
    };
    cfg.render.field_stop = 0.8;
    // Resampled depth (bilinear between raster pixels, nearest across folds): within one
    // pixel's footprint, depth / f.
    let f = cfg.camera.camera().unwrap().fx;
    back_project_onto_the_surface(cfg, 1.0 / f);
}

fn back_project_onto_the_surface(cfg: SimConfig, per_mm: f64) {
    let colon = build_colon(&cfg).unwrap();
    let atlas = MucosaAtlas::bake(&colon, &cfg.appearance).unwrap();
    let camera = cfg.camera.camera().unwrap();
    let renderer = Renderer::new(&colon, &atlas, camera, cfg.render.clone()).unwrap();
    let pass = PassGenerator::new(&colon, &cfg.train)
        .unwrap()
        .generate()
        .unwrap();
    let mut scratch = RenderScratch::default();
    let mut checked = 0;
    for k in [0, 13, 27, 39] {
        let pose: Pose = pass.poses[k];
        let frame = renderer.render(&[(pose, pass.s_mm[k])], 0, &mut scratch);
        for v in (3..camera.height).step_by(17) {
            for u in (5..camera.width).step_by(23) {
                let z = frame.depth_mm[(v * camera.width + u) as usize] as f64;
                if z <= 0.0 {
                    continue;
                }
                let p_cam = camera
                    .unproject(&Point2::new(u as f64, v as f64), z)
                    .unwrap();
                let p_world = pose * p_cam;
                let s = pass.s_mm[k];
                let (d, _) = colon.distance_to_surface(&p_world, s - 60.0, s + 300.0);
                assert!(
                    d < 0.01 + per_mm * z,
                    "frame {k} pixel ({u},{v}) depth {z:.2} mm lands {d:.4} mm off the surface"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 100, "only {checked} pixels had depth");
}

#[test]
fn images_are_lit_from_the_tip_with_a_dark_lumen_ahead() {
    let cfg = tiny_config(2);
    let colon = build_colon(&cfg).unwrap();
    let atlas = MucosaAtlas::bake(&colon, &cfg.appearance).unwrap();
    let camera = cfg.camera.camera().unwrap();
    let renderer = Renderer::new(&colon, &atlas, camera, cfg.render.clone()).unwrap();
    let pass = PassGenerator::new(&colon, &cfg.train)
        .unwrap()
        .generate()
        .unwrap();
    let frame = renderer.render(
        &[(pass.poses[20], pass.s_mm[20])],
        0,
        &mut RenderScratch::default(),
    );
    // Brightness falls with depth: near pixels are brighter than far ones.
    let (mut near, mut far) = (Vec::new(), Vec::new());
    for (i, &z) in frame.depth_mm.iter().enumerate() {
        let grey = frame.rgb[3 * i..3 * i + 3]
            .iter()
            .map(|&c| c as f64)
            .sum::<f64>()
            / 3.0;
        if z > 0.0 && z < 15.0 {
            near.push(grey);
        } else if z > 60.0 || z == 0.0 {
            far.push(grey);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    assert!(!near.is_empty() && !far.is_empty());
    assert!(
        mean(&near) > 2.0 * mean(&far),
        "near {:.1} far {:.1}",
        mean(&near),
        mean(&far)
    );
    // Mucosa is reddish.
    let (r, g) = frame
        .rgb
        .chunks_exact(3)
        .fold((0u64, 0u64), |(r, g), p| (r + p[0] as u64, g + p[1] as u64));
    assert!(r > g, "red {r} green {g}");
}

#[test]
fn same_seed_gives_identical_dataset_and_other_seed_differs() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |seed: u64, name: &str| {
        let out = tmp.path().join(name);
        endoloc_sim::simulate(&tiny_config(seed), &out, false, &|_| {}).unwrap();
        out
    };
    let a = run(9, "a");
    let b = run(9, "b");
    let c = run(10, "c");
    for rel in [
        "train/poses.txt",
        "test/poses.txt",
        "train/images/000017.png",
        "test/depth/000003.png",
    ] {
        let fa = std::fs::read(a.join(rel)).unwrap();
        assert_eq!(
            fa,
            std::fs::read(b.join(rel)).unwrap(),
            "{rel} differs for the same seed"
        );
    }
    assert_ne!(
        std::fs::read(a.join("train/poses.txt")).unwrap(),
        std::fs::read(c.join("train/poses.txt")).unwrap()
    );
    // train and test are different passes.
    assert_ne!(
        std::fs::read(a.join("train/images/000010.png")).unwrap(),
        std::fs::read(a.join("test/images/000010.png")).unwrap()
    );
}

#[test]
fn simulate_writes_a_valid_dataset_and_refuses_to_overwrite() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ds");
    let cfg = tiny_config(4);
    let summary = endoloc_sim::simulate(&cfg, &out, false, &|_| {}).unwrap();
    assert_eq!(
        summary.sequences,
        vec![("train".into(), 40), ("test".into(), 30)]
    );
    let ds = Dataset::open(&out).unwrap();
    assert_eq!(ds.meta.camera.width, 160);
    let train = ds.sequence("train").unwrap();
    assert_eq!(train.len(), 40);
    assert_eq!(train.sections.as_ref().unwrap().len(), 40);
    let img = train.load_rgb(5).unwrap();
    assert_eq!(img.dimensions(), (160, 120));
    let (w, h, depth) = train.load_depth_mm(5).unwrap();
    assert_eq!((w, h), (160, 120));
    assert!(depth.iter().any(|&d| d > 1.0));
    // The stored config regenerates the same dataset.
    let stored = SimConfig::from_toml_file(&out.join("dataset.toml")).unwrap();
    assert_eq!(stored, cfg);
    let report = endoloc_data::check_dataset(&out).unwrap();
    assert!(report.is_ok(), "{report:?}");

    let before = std::fs::read(out.join("train/poses.txt")).unwrap();
    let err = endoloc_sim::simulate(&tiny_config(5), &out, false, &|_| {}).unwrap_err();
    assert!(err.to_string().contains("exists"), "{err}");
    assert_eq!(before, std::fs::read(out.join("train/poses.txt")).unwrap());
    endoloc_sim::simulate(&tiny_config(5), &out, true, &|_| {}).unwrap();
    assert_ne!(before, std::fs::read(out.join("train/poses.txt")).unwrap());
}

#[test]
fn bad_mesh_inputs_give_errors_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let vtk = tmp.path().join("colon.vtk");
    std::fs::write(
        &vtk,
        "# vtk DataFile Version 1.0\ntest\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n0 0 0\n1 0 0\n",
    )
    .unwrap();
    let csv = tmp.path().join("path.csv");
    std::fs::write(&csv, "x,y,z\n0,0,0\n0,0,10\n0,nan,20\n").unwrap();
    let good_csv = tmp.path().join("good.csv");
    std::fs::write(&good_csv, "x,y,z\n0,0,0\n0,0,100\n0,0,200\n").unwrap();

    let mesh_cfg = |surface: &Path, path: &Path| {
        MeshColonConfig::new(surface.to_path_buf(), path.to_path_buf(), None)
    };
    let err = build_colon(&tiny_config(1).with_mesh_colon(mesh_cfg(&vtk, &csv)))
        .unwrap_err()
        .to_string();
    assert!(err.contains("path.csv") && err.contains('4'), "{err}");
    let err = build_colon(&tiny_config(1).with_mesh_colon(mesh_cfg(&vtk, &good_csv)))
        .unwrap_err()
        .to_string();
    assert!(err.contains("colon.vtk"), "{err}");
    let cfg = tiny_config(1).with_mesh_colon(mesh_cfg(&tmp.path().join("missing.ply"), &good_csv));
    let err = cfg.validate().unwrap_err().to_string();
    assert!(err.contains("missing.ply"), "{err}");
}

#[test]
fn a_lumen_too_narrow_for_the_clearance_is_a_clear_error() {
    let mut cfg = tiny_config(2);
    cfg.train.clearance_mm = 40.0; // wider than the colon
    let colon = build_colon(&cfg).unwrap();
    let err = PassGenerator::new(&colon, &cfg.train)
        .unwrap()
        .generate()
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("too narrow") && err.contains("`clearance`"),
        "{err}"
    );
}

#[test]
fn presets_have_the_documented_sizes() {
    let paper = SimConfig::preset(Preset::Paper);
    assert_eq!((paper.train.frames, paper.test.frames), (2610, 2603));
    assert_eq!((paper.camera.width, paper.camera.height), (640, 480));
    let cam = paper.camera.camera().unwrap();
    assert!((cam.hfov_deg() - 90.0).abs() < 1e-9);
    assert!(matches!(paper.colon, ColonSource::Procedural(_)));
    let small = SimConfig::preset(Preset::Small);
    assert!(small.train.frames <= 500 && small.camera.width < 640);
    assert_ne!(small.train.seed, small.test.seed);
}

/// The CT colon as other GCA models come: its landmark file rewritten without RSJ and CCJ (the
/// mid-line already runs on through the appendix orifice to the appendix tip). The colon
/// builds, every section is labelled, the missing landmarks are noted, and a pass at the
/// default settings stays clear of the wall and out of the appendix.
#[test]
fn ct_colon_without_rsj_and_ccj_simulates_and_stops_before_the_appendix() {
    let Some(dir) = gca_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let json = dir.join("EdinGCA_3D_00090_1_1.json");
    let mut model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let lms = model["landmarks"].as_array_mut().unwrap();
    let abbr = |l: &serde_json::Value| {
        l["anatomy"][0]["abbreviated_name"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let before = lms.len();
    lms.retain(|l| !matches!(abbr(l).as_str(), "RSJ" | "CCJ"));
    assert_eq!(lms.len(), before - 2);
    let landmarks = tmp.path().join("model.json");
    std::fs::write(&landmarks, model.to_string()).unwrap();

    let mut mesh = MeshColonConfig::new(
        dir.join("large_intestine_20k.vtk"),
        dir.join("large_intestine_path.jsn"),
        Some(landmarks),
    );
    mesh.inflation = 1.5;
    let cfg = tiny_config(5).with_mesh_colon(mesh);
    let colon = build_colon(&cfg).unwrap();
    let order: Vec<Section> = colon.section_ranges().iter().map(|r| r.0).collect();
    assert_eq!(order, Section::ALL.to_vec());
    let notes = colon.notes.join("\n");
    assert!(
        notes.contains("landmark RSJ (recto-sigmoid junction) is missing"),
        "{notes}"
    );
    assert!(
        notes.contains("the caecum starts at ICVc (path index 1314)"),
        "{notes}"
    );

    // The appendix orifice is path point 1352 of 1375; the pass ends before it.
    let path = endoloc_data::read_path(&dir.join("large_intestine_path.jsn")).unwrap();
    let raw = endoloc_data::cumulative_length(&path);
    let scale = colon.centerline.length_mm() / raw.last().unwrap();
    let ao_mm = raw[1352] * scale;
    assert!(
        colon.pass_range_mm.1 < ao_mm - 5.0,
        "{:?} vs AO at {ao_mm:.0} mm",
        colon.pass_range_mm
    );
    let mut traj = cfg.train.clone();
    traj.frames = 300;
    let pass = PassGenerator::new(&colon, &traj)
        .unwrap()
        .generate()
        .unwrap();
    assert_inside_lumen(&colon, &pass, traj.clearance_mm);
    assert_eq!(*pass.sections.last().unwrap(), Section::Caecum);
    assert!(pass.s_mm.iter().all(|&s| s < ao_mm - 5.0));
}

/// FNV-1a 64 over every file of a folder (relative path, then bytes, in path order), skipping
/// the files named in `skip`.
fn folder_hash(dir: &Path, skip: &[&str]) -> u64 {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    walk(dir, &mut files);
    let mut rel: Vec<String> = files
        .iter()
        .map(|p| p.strip_prefix(dir).unwrap().to_string_lossy().into_owned())
        .filter(|r| !skip.contains(&r.as_str()))
        .collect();
    rel.sort();
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            h ^= *b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for r in &rel {
        eat(r.as_bytes());
        eat(&std::fs::read(dir.join(r)).unwrap());
    }
    h
}

/// `endoloc simulate --train-frames 12 --test-frames 12 --width 64 --height 48` with
/// `changes` (the `small` preset).
fn micro_config(changes: endoloc_sim::Severity) -> SimConfig {
    let mut cfg = SimConfig::preset(Preset::Small).with_changes(changes);
    cfg.camera.width = 64;
    cfg.camera.height = 48;
    cfg.train.frames = 12;
    cfg.test.frames = 12;
    cfg
}

#[test]
fn an_unchanged_colon_gives_the_same_bytes_and_a_changed_one_keeps_anatomical_poses() {
    use endoloc_sim::Severity;
    let tmp = tempfile::tempdir().unwrap();
    let none = tmp.path().join("none");
    endoloc_sim::simulate(&micro_config(Severity::None), &none, false, &|_| {}).unwrap();
    // The hash of this dataset as the simulator wrote it before colons could change.
    // (The mid-line file is new beside them.)
    assert_eq!(folder_hash(&none, &["midline.txt"]), 0x7814_96fa_557d_d78b);
    let midline = endoloc_data::read_path(&none.join("midline.txt")).unwrap();
    assert!(
        midline.len() > 1000,
        "a point per mm of a colon: {}",
        midline.len()
    );

    let cfg = micro_config(Severity::Moderate);
    let moved = tmp.path().join("moderate");
    let summary = endoloc_sim::simulate(&cfg, &moved, false, &|_| {}).unwrap();
    assert!(summary.notes.iter().any(|n| n.contains("changed colon")));
    let read = |d: &Path, rel: &str| std::fs::read(d.join(rel)).unwrap();
    // The map pass is untouched; the test pass keeps its anatomical poses and looks different.
    assert_eq!(
        folder_hash(&none.join("train"), &[]),
        folder_hash(&moved.join("train"), &[])
    );
    assert_eq!(
        read(&none, "test/poses.txt"),
        read(&moved, "test/poses.txt")
    );
    assert_ne!(
        read(&none, "test/images/000005.png"),
        read(&moved, "test/images/000005.png")
    );
    // The stored config regenerates the change.
    assert_eq!(
        SimConfig::from_toml_file(&moved.join("dataset.toml")).unwrap(),
        cfg
    );

    // poses_changed.txt carried back through the change is the anatomical pose.
    let colon = build_colon(&cfg).unwrap();
    let change =
        endoloc_sim::change::ChangedPass::new(&cfg.changes, &cfg.appearance, &colon).unwrap();
    let d = change
        .deformation
        .expect("a moderate change moves the colon");
    let pass = PassGenerator::new(&colon, &cfg.test)
        .unwrap()
        .generate()
        .unwrap();
    let ds = Dataset::open(&moved).unwrap();
    let test = ds.sequence("test").unwrap();
    let changed = endoloc_data::read_tum(&moved.join("test/poses_changed.txt")).unwrap();
    let mut moved_by: f64 = 0.0;
    for (k, (truth, seen)) in test.poses.iter().zip(&changed).enumerate() {
        let truth = &truth.pose;
        let back = d.unmap_pose(&seen.pose, pass.s_mm[k]);
        let off = (back.translation.vector - truth.translation.vector).norm();
        assert!(off < 0.01, "frame {k}: {off} mm");
        assert!(back.rotation.angle_to(&truth.rotation) < 1e-6);
        moved_by = moved_by.max((seen.pose.translation.vector - truth.translation.vector).norm());
    }
    assert!(
        moved_by > 1.0,
        "the change moves the test pass ({moved_by} mm)"
    );
}

#[test]
fn motion_blur_in_mm_spans_that_travel_whatever_the_frame_spacing() {
    use endoloc_sim::render::RenderConfig;
    use endoloc_sim::simulate::exposure_frames;
    let cfg = SimConfig::preset(Preset::Small).with_seed(3);
    let colon = build_colon(&cfg).unwrap();
    let travel = |frames: usize, render: &RenderConfig| -> f64 {
        let mut traj = cfg.test.clone();
        traj.frames = frames;
        let g = PassGenerator::new(&colon, &traj).unwrap();
        // The exposure of frames mid-pass, as the camera's travel from its start to its end.
        let at = |t: f64| g.pose_at(t).0.translation.vector;
        let ks = (frames / 2..frames / 2 + 8).map(|k| k as f64);
        let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
        mean(
            ks.map(|k| {
                let span = exposure_frames(render, &g, k as usize);
                (at(k + span / 2.0) - at(k - span / 2.0)).norm()
            })
            .collect(),
        )
    };
    let shutter = RenderConfig::default();
    let in_mm = RenderConfig {
        motion_blur_mm: 0.3,
        ..RenderConfig::default()
    };
    // Over the shutter, a pass four times as sparse blurs over about four times the travel;
    // in mm, both blur over 0.3 mm.
    let (sparse, dense) = (travel(300, &shutter), travel(1200, &shutter));
    assert!(
        sparse > 2.5 * dense && sparse > 1.0,
        "{sparse} vs {dense} mm"
    );
    for frames in [300, 1200] {
        let mm = travel(frames, &in_mm);
        assert!((mm - 0.3).abs() < 0.03, "{frames} frames: {mm} mm");
    }
}
