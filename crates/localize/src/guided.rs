//! Matching guided by a predicted pose: a frame's features are compared only with the map
//! points that the prediction projects near them.
//!
//! Brute-force matching against all map points of three zones must tell each feature's true
//! point from thousands of look-alikes, and the ratio test discards a feature whenever a
//! look-alike comes close. With a pose predicted to within a few millimetres, each map point
//! is projected (`camera.project(T_wc⁻¹ · p_w)`, distortion included) and compared only with
//! the features within `radius_px` of its projection: the same descriptors and tests
//! (Laplacian gating, Lowe's ratio among the candidates in the window, mutual nearest), far
//! fewer competitors, so more true matches survive in weakly textured stretches — and much
//! less work.

use endoloc_features::{Describe, Feature, Match, MatcherConfig};
use endoloc_geometry::{Camera, Pose};

use crate::map::MapPoint;

/// Matches `features` (query) to `points` (train) whose projection with `t_wc` (camera-to-world,
/// mm) lies within `radius_px` pixels of the feature; sorted by query index. Points behind the
/// camera (closer than `min_depth_mm`) are skipped.
pub fn match_guided(
    features: &[Feature],
    points: &[&MapPoint],
    camera: &Camera,
    t_wc: &Pose,
    radius_px: f64,
    min_depth_mm: f64,
    cfg: &MatcherConfig,
) -> Vec<Match> {
    if features.is_empty() || points.is_empty() {
        return Vec::new();
    }
    // Features bucketed on a grid of cells `radius_px` wide.
    let cell = radius_px.max(1.0);
    let cols = (camera.width as f64 / cell).ceil().max(1.0) as usize;
    let rows = (camera.height as f64 / cell).ceil().max(1.0) as usize;
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); cols * rows];
    let cell_of = |x: f64, y: f64| -> Option<(usize, usize)> {
        let (cx, cy) = ((x + 0.5) / cell, (y + 0.5) / cell);
        (cx >= 0.0 && cy >= 0.0 && (cx as usize) < cols && (cy as usize) < rows)
            .then_some((cx as usize, cy as usize))
    };
    for (i, f) in features.iter().enumerate() {
        if let Some((cx, cy)) = cell_of(f.keypoint.x as f64, f.keypoint.y as f64) {
            grid[cy * cols + cx].push(i as u32);
        }
    }
    let t_cw = t_wc.inverse();
    let r2 = radius_px * radius_px;
    // Per feature: (best point, d1², d2²); per point: (best feature, d²).
    let mut forward: Vec<(usize, f32, f32)> =
        vec![(usize::MAX, f32::INFINITY, f32::INFINITY); features.len()];
    let mut backward: Vec<(usize, f32)> = vec![(usize::MAX, f32::INFINITY); points.len()];
    for (j, p) in points.iter().enumerate() {
        let pc = t_cw * p.p_world;
        if pc.z < min_depth_mm {
            continue;
        }
        let Some(px) = camera.project(&pc) else {
            continue;
        };
        let (lo_x, lo_y) = ((px.x - radius_px).max(0.0), (px.y - radius_px).max(0.0));
        let Some((c0, r0)) = cell_of(lo_x, lo_y) else {
            continue;
        };
        let (c1, r1) = match cell_of(
            (px.x + radius_px).min(camera.width as f64 - 1.0),
            (px.y + radius_px).min(camera.height as f64 - 1.0),
        ) {
            Some(c) => c,
            None => continue,
        };
        for cy in r0..=r1 {
            for cx in c0..=c1 {
                for &i in &grid[cy * cols + cx] {
                    let i = i as usize;
                    let f = &features[i];
                    let (dx, dy) = (f.keypoint.x as f64 - px.x, f.keypoint.y as f64 - px.y);
                    if dx * dx + dy * dy > r2 {
                        continue;
                    }
                    let (a, b) = (f.laplacian(), p.laplacian());
                    if cfg.laplacian_gating && a != 0 && b != 0 && a != b {
                        continue;
                    }
                    let d = squared_distance(f.descriptor(), p.descriptor());
                    let fw = &mut forward[i];
                    if d < fw.1 {
                        *fw = (j, d, fw.1);
                    } else if d < fw.2 {
                        fw.2 = d;
                    }
                    if d < backward[j].1 {
                        backward[j] = (i, d);
                    }
                }
            }
        }
    }
    let ratio2 = cfg.ratio * cfg.ratio;
    let max2 = cfg.max_distance * cfg.max_distance;
    forward
        .iter()
        .enumerate()
        .filter_map(|(i, &(j, d1, d2))| {
            let ok = j != usize::MAX
                && (d2.is_infinite() || d1 < ratio2 * d2)
                && d1 <= max2
                && (!cfg.mutual || backward[j].0 == i);
            ok.then(|| Match {
                query: i,
                train: j,
                distance: d1.sqrt(),
            })
        })
        .collect()
}

/// Squared Euclidean distance, summed in eight lanes (which the compiler turns into SIMD) and
/// then across them.
fn squared_distance(a: &[f32], b: &[f32]) -> f32 {
    const LANES: usize = 8;
    let mut acc = [0.0f32; LANES];
    let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f32 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| (x - y) * (x - y))
        .sum();
    for (xa, xb) in ca.zip(cb) {
        for k in 0..LANES {
            let d = xa[k] - xb[k];
            acc[k] += d * d;
        }
    }
    acc.iter().sum::<f32>() + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use endoloc_features::Keypoint;
    use nalgebra::{Point2, Point3};

    fn point(p: [f64; 3], d: [f32; 2]) -> MapPoint {
        MapPoint {
            p_world: Point3::new(p[0], p[1], p[2]),
            descriptor: d.to_vec(),
            laplacian: 1,
            observations: vec![(0, Point2::new(0.0, 0.0))],
            reprojection_rms_px: 0.0,
        }
    }

    fn feature(x: f32, y: f32, d: [f32; 2]) -> Feature {
        Feature {
            keypoint: Keypoint {
                x,
                y,
                scale: 2.0,
                orientation: 0.0,
                response: 1.0,
                laplacian: 1,
                octave: 0,
            },
            descriptor: d.to_vec(),
        }
    }

    #[test]
    fn the_lane_wise_distance_is_the_squared_distance() {
        for n in [0, 3, 8, 64, 67, 128] {
            let a: Vec<f32> = (0..n)
                .map(|i| ((i * 37 % 19) as f32 - 9.0) / 31.0)
                .collect();
            let b: Vec<f32> = (0..n)
                .map(|i| ((i * 11 % 23) as f32 - 11.0) / 29.0)
                .collect();
            let plain: f64 = a
                .iter()
                .zip(&b)
                .map(|(x, y)| f64::from(x - y).powi(2))
                .sum();
            let got = f64::from(squared_distance(&a, &b));
            assert!(
                (got - plain).abs() <= 1e-6 * plain.max(1.0),
                "{n}: {got} vs {plain}"
            );
        }
    }

    #[test]
    fn only_points_projected_near_a_feature_compete() {
        let camera = Camera::from_hfov(200, 200, 90.0);
        let pose = Pose::identity();
        // Two identical descriptors: brute force would fail the ratio test; the window keeps
        // each feature's own point only.
        let a = point([-10.0, 0.0, 50.0], [1.0, 0.0]);
        let b = point([10.0, 0.0, 50.0], [1.0, 0.0]);
        let pa = camera.project(&a.p_world).unwrap();
        let pb = camera.project(&b.p_world).unwrap();
        let features = [
            feature(pa.x as f32 + 2.0, pa.y as f32, [0.99, 0.14]),
            feature(pb.x as f32 - 1.0, pb.y as f32 + 1.0, [0.98, 0.2]),
        ];
        let pts = [&a, &b];
        let cfg = MatcherConfig::default();
        let m = match_guided(&features, &pts, &camera, &pose, 10.0, 1.0, &cfg);
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].query, m[0].train), (0, 0));
        assert_eq!((m[1].query, m[1].train), (1, 1));
        // A point behind the camera, or projected beyond the radius, matches nothing.
        let behind = point([0.0, 0.0, -50.0], [1.0, 0.0]);
        let far = [feature(pa.x as f32 + 30.0, pa.y as f32, [1.0, 0.0])];
        assert!(match_guided(&far, &[&a], &camera, &pose, 10.0, 1.0, &cfg).is_empty());
        assert!(match_guided(&features, &[&behind], &camera, &pose, 10.0, 1.0, &cfg).is_empty());
    }
}
