//! Per-zone maps on a simulated pass: triangulated points must lie on the rendered surface
//! (checked against the simulator's depth maps), survive a save/load round trip, and a damaged
//! map file must give an error naming it.

use endoloc_data::Dataset;
use endoloc_localize::map_io::{
    SMOOTHED_LEVEL_DIR, load_map, load_smoothed_level, save_map, save_smoothed_level,
};
use endoloc_localize::{MapConfig, build_map};
use endoloc_net::{UniformBy, ZoneConfig, ZoneTable};
use endoloc_sim::{Preset, SimConfig};

fn simulated_map() -> (tempfile::TempDir, endoloc_localize::Map, Dataset) {
    let (tmp, ds) = simulated_pass();
    let map = map_with(&ds, MapConfig::default().observation_radius_px);
    (tmp, map, ds)
}

fn simulated_pass() -> (tempfile::TempDir, Dataset) {
    let tmp = tempfile::tempdir().unwrap();
    let mut cfg = SimConfig::preset(Preset::Small).with_seed(1);
    cfg.train.frames = 300;
    cfg.test.frames = 2;
    cfg.depth = true;
    let out = tmp.path().join("ds");
    endoloc_sim::simulate(&cfg, &out, false, &|_| {}).unwrap();
    let ds = Dataset::open(&out).unwrap();
    (tmp, ds)
}

/// The map of 20 uniform zones, 8 images each, with `observation_radius_px`.
fn map_with(ds: &Dataset, observation_radius_px: f64) -> endoloc_localize::Map {
    map_of(
        ds,
        MapConfig {
            observation_radius_px,
            ..MapConfig::default()
        },
    )
}

/// The map of 20 uniform zones, 8 images each, SURF threshold 50, the rest from `cfg`.
fn map_of(ds: &Dataset, cfg: MapConfig) -> endoloc_localize::Map {
    let train = ds.sequence("train").unwrap();
    let zones =
        ZoneTable::from_sequence(&train, &ZoneConfig::uniform(20, UniformBy::ArcLength)).unwrap();
    let mut map_cfg = MapConfig {
        images_per_zone: 8,
        ..cfg
    };
    map_cfg.surf.threshold = 50.0;
    build_map(&train, &zones, &ds.meta.camera, &map_cfg, &|_| {}).unwrap()
}

/// For every point of `map`, `|depth / rendered depth − 1|` at its first observation (the
/// renderer's depth map there, nearest in the 5×5 neighbourhood).
fn first_view_depth_errors(map: &endoloc_localize::Map, ds: &Dataset) -> Vec<f64> {
    let train = ds.sequence("train").unwrap();
    let camera = ds.meta.camera;
    let (w, h) = (camera.width as i64, camera.height as i64);
    let mut depth_cache = std::collections::HashMap::new();
    let mut errors = Vec::new();
    for p in map.zones.iter().flat_map(|z| &z.points) {
        let (frame, px) = p.observations[0];
        let depth = depth_cache
            .entry(frame)
            .or_insert_with(|| train.load_depth_mm(frame).unwrap().2);
        let z = (train.poses[frame].pose.inverse() * p.p_world).z;
        let (u, v) = (px.x.round() as i64, px.y.round() as i64);
        let mut best = f64::INFINITY;
        for (uu, vv) in (-2..=2).flat_map(|dv| (-2..=2).map(move |du| (u + du, v + dv))) {
            if uu >= 0 && vv >= 0 && uu < w && vv < h {
                let d = depth[(vv * w + uu) as usize] as f64;
                if d > 0.0 && (z - d).abs() < (z - best).abs() {
                    best = d;
                }
            }
        }
        if best.is_finite() {
            errors.push((z / best - 1.0).abs());
        }
    }
    errors.sort_by(f64::total_cmp);
    errors
}

/// Every other frame of a zone adding its observations makes the points sharper: the same
/// points, seen in more images, lie closer to the rendered surface.
#[test]
fn observations_from_every_frame_of_a_zone_sharpen_the_points() {
    let (_tmp, ds) = simulated_pass();
    let paper = map_with(&ds, 0.0);
    let extended = map_with(&ds, 3.0);
    assert_eq!(paper.summary().points, extended.summary().points);
    let views = |m: &endoloc_localize::Map| -> f64 {
        let pts: Vec<_> = m.zones.iter().flat_map(|z| &z.points).collect();
        pts.iter().map(|p| p.observations.len()).sum::<usize>() as f64 / pts.len() as f64
    };
    let (v0, v1) = (views(&paper), views(&extended));
    assert!(v1 > 2.0 * v0, "views per point: {v0:.2} → {v1:.2}");
    let q = |e: &[f64], f: f64| e[((e.len() - 1) as f64 * f) as usize];
    let (e0, e1) = (
        first_view_depth_errors(&paper, &ds),
        first_view_depth_errors(&extended, &ds),
    );
    eprintln!(
        "views per point {v0:.2} → {v1:.2}; relative depth error median {:.4} → {:.4}, p75 {:.4} → {:.4}",
        q(&e0, 0.5),
        q(&e1, 0.5),
        q(&e0, 0.75),
        q(&e1, 0.75)
    );
    // (0.0345 → 0.0303 and 0.122 → 0.117 at this seed; the rendered depth near a blob is
    // itself only good to a few per cent, which bounds what this check can see.)
    assert!(q(&e1, 0.5) < 0.92 * q(&e0, 0.5), "median");
    assert!(q(&e1, 0.75) < 0.99 * q(&e0, 0.75), "p75");
}

/// A map of the smoothed training images (`blur_px`, the map's smoothed level) holds the
/// coarser structure: fewer points, and they still lie on the rendered surface as the sharp
/// map's do. Saved as a model folder's level it reads back; a map saved without a level
/// removes the earlier build's.
#[test]
fn a_smoothed_level_has_coarser_points_on_the_surface_and_round_trips() {
    let (tmp, ds) = simulated_pass();
    let sharp = map_of(&ds, MapConfig::default());
    let smoothed = map_of(
        &ds,
        MapConfig {
            blur_px: 1.5,
            ..MapConfig::default()
        },
    );
    let (n0, n1) = (sharp.summary().points, smoothed.summary().points);
    assert!(n1 < n0 && n1 >= 200, "points {n0} → {n1}");
    let median = |e: Vec<f64>| e[e.len() / 2];
    let (e0, e1) = (
        median(first_view_depth_errors(&sharp, &ds)),
        median(first_view_depth_errors(&smoothed, &ds)),
    );
    eprintln!("points {n0} → {n1}; relative depth error median {e0:.4} → {e1:.4}");
    assert!(
        e1 < 0.06 && e1 < 1.5 * e0,
        "median relative depth error {e0:.4} → {e1:.4}"
    );
    for bad in [-1.0, f64::NAN] {
        let cfg = MapConfig {
            blur_px: bad,
            ..MapConfig::default()
        };
        let err = cfg.validate().unwrap_err().to_string();
        assert!(err.contains("blur_px"), "{err}");
    }
    let model = tmp.path().join("model");
    std::fs::create_dir_all(&model).unwrap();
    assert!(load_smoothed_level(&model).unwrap().is_none());
    save_smoothed_level(Some(&smoothed), &model).unwrap();
    let back = load_smoothed_level(&model).unwrap().expect("the level");
    assert_eq!(back.config.blur_px, 1.5);
    assert_eq!(back.summary().points, n1);
    save_smoothed_level(None, &model).unwrap();
    assert!(load_smoothed_level(&model).unwrap().is_none());
    assert!(!model.join(SMOOTHED_LEVEL_DIR).exists());
}

#[test]
fn map_points_lie_on_the_rendered_surface_and_round_trip() {
    let (tmp, map, ds) = simulated_map();
    let summary = map.summary();
    assert_eq!(summary.zones, 20);
    assert!(summary.points >= 500, "only {} map points", summary.points);
    assert!(summary.mean_reprojection_rms_px < 2.0, "{summary:?}");

    // Each observation of a map point: its depth along the optical axis must match the depth
    // the renderer wrote at that pixel.
    let train = ds.sequence("train").unwrap();
    let camera = ds.meta.camera;
    let (mut good, mut total) = (0usize, 0usize);
    let mut ratios: Vec<f64> = Vec::new();
    let mut depth_cache = std::collections::HashMap::new();
    for z in &map.zones {
        for p in &z.points {
            for (frame, px) in &p.observations {
                let depth = depth_cache
                    .entry(*frame)
                    .or_insert_with(|| train.load_depth_mm(*frame).unwrap().2);
                let p_cam = train.poses[*frame].pose.inverse() * p.p_world;
                let (u, v) = (px.x.round() as i64, px.y.round() as i64);
                if u < 0 || v < 0 || u >= camera.width as i64 || v >= camera.height as i64 {
                    continue;
                }
                // A blob on a fold's silhouette sees the fold or the wall behind it within a few
                // pixels: accept the nearest depth in the 5×5 neighbourhood.
                let (w, h) = (camera.width as i64, camera.height as i64);
                let mut best = f64::INFINITY;
                for dv in -2..=2 {
                    for du in -2..=2 {
                        let (uu, vv) = (u + du, v + dv);
                        if uu < 0 || vv < 0 || uu >= w || vv >= h {
                            continue;
                        }
                        let d = depth[(vv * w + uu) as usize] as f64;
                        if d > 0.0 && (p_cam.z - d).abs() < (p_cam.z - best).abs() {
                            best = d;
                        }
                    }
                }
                if !best.is_finite() {
                    continue;
                }
                total += 1;
                ratios.push(p_cam.z / best);
                if (p_cam.z - best).abs() < (0.05 * best).max(1.0) {
                    good += 1;
                }
            }
        }
    }
    ratios.sort_by(f64::total_cmp);
    let q = |f: f64| ratios[((ratios.len() - 1) as f64 * f) as usize];
    eprintln!(
        "depth ratio triangulated/rendered: p10 {:.3} p25 {:.3} median {:.3} p75 {:.3} p90 {:.3}",
        q(0.1),
        q(0.25),
        q(0.5),
        q(0.75),
        q(0.9)
    );
    assert!(total > 100, "only {total} observations checked");
    // No bias (this pins the camera, pose and pixel conventions of map building against the
    // renderer's), and most points on the surface. The tails are the points seen with little
    // parallax by a scope moving along the lumen (the paper's caveat) and specular blobs.
    assert!((q(0.5) - 1.0).abs() < 0.02, "median depth ratio {}", q(0.5));
    assert!(
        q(0.25) > 0.9 && q(0.75) < 1.1,
        "interquartile depth ratio {} – {}",
        q(0.25),
        q(0.75)
    );
    let fraction = good as f64 / total as f64;
    assert!(
        fraction > 0.45,
        "{good}/{total} observations within 5 % of the rendered depth"
    );

    let dir = tmp.path().join("model");
    std::fs::create_dir_all(&dir).unwrap();
    save_map(&map, &dir).unwrap();
    let back = load_map(&dir).unwrap();
    assert_eq!(back.zones.len(), map.zones.len());
    for (a, b) in back.zones.iter().zip(&map.zones) {
        assert_eq!(a.points, b.points);
        assert_eq!(a.frames, b.frames);
    }
    assert_eq!(back.camera, map.camera);

    // A rebuild killed between its two renames: the new map.bin beside the earlier map.toml.
    // The earlier map is read whole from the copy kept beside them, and the next build
    // finishes cleanly.
    let mut other = map.clone();
    other.zones[0].points.truncate(1);
    let other_dir = tmp.path().join("other");
    std::fs::create_dir_all(&other_dir).unwrap();
    save_map(&other, &other_dir).unwrap();
    for (from, to) in [("map.bin", ".map.bin.prev"), ("map.toml", ".map.toml.prev")] {
        std::fs::hard_link(dir.join(from), dir.join(to)).unwrap();
    }
    // (renamed over map.bin, as the build does: the kept hard link holds the earlier bytes)
    std::fs::rename(other_dir.join("map.bin"), dir.join("map.bin")).unwrap();
    let back = load_map(&dir).unwrap();
    assert_eq!(back.zones[0].points, map.zones[0].points, "the earlier map");
    save_map(&other, &dir).unwrap();
    assert_eq!(
        load_map(&dir).unwrap().zones[0].points.len(),
        1,
        "the new map"
    );
    assert!(!dir.join(".map.bin.prev").exists() && !dir.join(".map.toml.prev").exists());
    save_map(&map, &dir).unwrap();

    // A truncated map.bin is an error naming the file: map.toml's fingerprint of map.bin
    // catches it, and without that record (older maps) the reader does.
    let bin = dir.join("map.bin");
    let bytes = std::fs::read(&bin).unwrap();
    std::fs::write(&bin, &bytes[..bytes.len() / 2]).unwrap();
    let err = load_map(&dir).unwrap_err().to_string();
    assert!(
        err.contains("map.bin") && err.contains("different builds"),
        "{err}"
    );
    let toml_path = dir.join("map.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    let without: Vec<&str> = text.lines().filter(|l| !l.starts_with("bin = ")).collect();
    std::fs::write(&toml_path, without.join("\n")).unwrap();
    let err = load_map(&dir).unwrap_err().to_string();
    assert!(
        err.contains("map.bin") && err.contains("truncated"),
        "{err}"
    );
}

#[test]
fn too_few_images_per_zone_is_a_config_error() {
    let cfg = MapConfig {
        images_per_zone: 2,
        ..MapConfig::default()
    };
    let err = cfg.validate().unwrap_err().to_string();
    assert!(err.contains("images_per_zone"), "{err}");
}
