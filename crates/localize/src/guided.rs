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
use endoloc_geometry::reprojection::wall_motion_scale;
use endoloc_geometry::{Camera, Pose};

use crate::map_point::MapPoint;

/// Where a map point looks for its feature: within a window about its projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// The window's radius, pixels, for a point the wall did not move.
    pub radius_px: f64,
    /// Points closer to the camera than this (depth, mm) are skipped.
    pub min_depth_mm: f64,
    /// How far the wall may have moved since the map was built (standard deviation, mm): a
    /// point's window is `radius_px` times its [`wall_motion_scale`] at its depth
    /// ([`RefineConfig::wall_motion_mm`](endoloc_geometry::RefineConfig::wall_motion_mm)).
    /// 0: every window `radius_px` wide.
    pub wall_motion_mm: f64,
}

impl Window {
    /// A window of `radius_px` for every point deeper than `min_depth_mm`: a rigid wall.
    pub fn rigid(radius_px: f64, min_depth_mm: f64) -> Self {
        Window {
            radius_px,
            min_depth_mm,
            wall_motion_mm: 0.0,
        }
    }

    /// This window widened for near points when the wall may have moved by `wall_motion_mm`.
    pub fn with_wall_motion(mut self, wall_motion_mm: f64) -> Self {
        self.wall_motion_mm = wall_motion_mm;
        self
    }
}

/// Matches `features` (query) to `points` (train) whose projection with `t_wc` (camera-to-world,
/// mm) lies within the [`Window`] of the feature; sorted by query index.
pub fn match_guided(
    features: &[Feature],
    points: &[&MapPoint],
    camera: &Camera,
    t_wc: &Pose,
    window: Window,
    cfg: &MatcherConfig,
) -> Vec<Match> {
    if features.is_empty() || points.is_empty() {
        return Vec::new();
    }
    let Window {
        radius_px,
        min_depth_mm,
        wall_motion_mm,
    } = window;
    // Features bucketed on a grid of cells `radius_px` wide (at least 8 px, so that small
    // windows do not make a huge grid), stored as one index array sorted by cell.
    let cell = radius_px.max(8.0);
    let cols = (camera.width as f64 / cell).ceil().max(1.0) as usize;
    let rows = (camera.height as f64 / cell).ceil().max(1.0) as usize;
    let cell_of = |x: f64, y: f64| -> Option<(usize, usize)> {
        let (cx, cy) = ((x + 0.5) / cell, (y + 0.5) / cell);
        (cx >= 0.0 && cy >= 0.0 && (cx as usize) < cols && (cy as usize) < rows)
            .then_some((cx as usize, cy as usize))
    };
    let cells: Vec<Option<usize>> = features
        .iter()
        .map(|f| cell_of(f.keypoint.x as f64, f.keypoint.y as f64).map(|(cx, cy)| cy * cols + cx))
        .collect();
    // `start[c]..start[c + 1]` indexes `slots` for cell `c`; features keep their order. A slot
    // holds what the window test needs, so a window is scanned in contiguous memory.
    let mut start = vec![0u32; cols * rows + 1];
    for c in cells.iter().flatten() {
        start[c + 1] += 1;
    }
    for c in 0..cols * rows {
        start[c + 1] += start[c];
    }
    let mut slots = vec![Slot::default(); start[cols * rows] as usize];
    let mut fill = start.clone();
    for (i, (f, c)) in features.iter().zip(&cells).enumerate() {
        if let Some(c) = *c {
            slots[fill[c] as usize] = Slot {
                x: f.keypoint.x,
                y: f.keypoint.y,
                laplacian: f.laplacian(),
                index: i as u32,
            };
            fill[c] += 1;
        }
    }
    let t_cw = t_wc.inverse();
    // A pair farther apart than `max_distance / ratio` can neither be accepted nor fail a
    // feature's ratio test (its best is within `max_distance`), nor beat an accepted match in
    // the mutual check: it is skipped as soon as a partial sum exceeds that bound. The slack
    // covers the rounding of `ratio² · d2` in the test below, so the matches are exactly those
    // of the full distances.
    let ratio2 = cfg.ratio * cfg.ratio;
    let max2 = cfg.max_distance * cfg.max_distance;
    let bound = if ratio2 > 0.0 {
        max2 / ratio2 * (1.0 + 1e-4)
    } else {
        f32::INFINITY
    };
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
        let radius_px = radius_px * wall_motion_scale(camera.fx, pc.z, wall_motion_mm);
        let r2 = radius_px * radius_px;
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
                let c = cy * cols + cx;
                for slot in &slots[start[c] as usize..start[c + 1] as usize] {
                    let (dx, dy) = (slot.x as f64 - px.x, slot.y as f64 - px.y);
                    if dx * dx + dy * dy > r2 {
                        continue;
                    }
                    let (a, b) = (slot.laplacian, p.laplacian());
                    if cfg.laplacian_gating && a != 0 && b != 0 && a != b {
                        continue;
                    }
                    let i = slot.index as usize;
                    let f = &features[i];
                    let Some(d) = squared_distance_within(f.descriptor(), p.descriptor(), bound)
                    else {
                        continue;
                    };
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

/// A feature in the window grid: its pixel, Laplacian sign and index.
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    x: f32,
    y: f32,
    laplacian: i8,
    index: u32,
}

/// Squared Euclidean distance, summed in eight lanes (which the compiler turns into SIMD) and
/// then across them; `None` once the first half of the sum exceeds `bound` (the terms are
/// non-negative, so the whole sum would too). An unbounded call is the plain distance.
fn squared_distance_within(a: &[f32], b: &[f32], bound: f32) -> Option<f32> {
    const LANES: usize = 8;
    let mut acc = [0.0f32; LANES];
    let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f32 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| (x - y) * (x - y))
        .sum();
    let half = ca.len() / 2;
    let lanes = |acc: &mut [f32; LANES], xa: &[f32], xb: &[f32]| {
        for k in 0..LANES {
            let d = xa[k] - xb[k];
            acc[k] += d * d;
        }
    };
    let mut chunks = ca.zip(cb);
    for (xa, xb) in chunks.by_ref().take(half) {
        lanes(&mut acc, xa, xb);
    }
    if bound.is_finite() && acc.iter().sum::<f32>() > bound {
        return None;
    }
    for (xa, xb) in chunks {
        lanes(&mut acc, xa, xb);
    }
    Some(acc.iter().sum::<f32>() + tail)
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
            let got = squared_distance_within(&a, &b, f32::INFINITY).map(f64::from);
            let got = got.expect("an unbounded distance is always computed");
            assert!(
                (got - plain).abs() <= 1e-6 * plain.max(1.0),
                "{n}: {got} vs {plain}"
            );
            // Bounded: the distance when within the bound, never `None` below it.
            let at = got as f32;
            assert_eq!(
                squared_distance_within(&a, &b, at * 1.001),
                Some(got as f32)
            );
            if n >= 16 {
                assert_eq!(squared_distance_within(&a, &b, 0.0), None, "{n}");
            }
        }
    }

    /// Every pair within the window, every distance in full, the tests applied to the nearest
    /// two: the guided matches, computed the plain way (camera at the origin).
    fn reference(
        features: &[Feature],
        points: &[&MapPoint],
        camera: &Camera,
        radius: f64,
        cfg: &MatcherConfig,
    ) -> Vec<Match> {
        let px: Vec<_> = points.iter().map(|p| camera.project(&p.p_world)).collect();
        let pairs = |i: usize| {
            let f = &features[i];
            px.iter().enumerate().filter_map(move |(j, q)| {
                let q = q.as_ref()?;
                let (dx, dy) = (f.keypoint.x as f64 - q.x, f.keypoint.y as f64 - q.y);
                let plain: f32 = f
                    .descriptor
                    .iter()
                    .zip(&points[j].descriptor)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum();
                (dx * dx + dy * dy <= radius * radius).then_some((j, plain))
            })
        };
        let mut best_feature = vec![(usize::MAX, f32::INFINITY); points.len()];
        for i in 0..features.len() {
            for (j, d) in pairs(i) {
                if d < best_feature[j].1 {
                    best_feature[j] = (i, d);
                }
            }
        }
        let (ratio2, max2) = (cfg.ratio * cfg.ratio, cfg.max_distance * cfg.max_distance);
        let mut out = Vec::new();
        for i in 0..features.len() {
            let mut d: Vec<(usize, f32)> = pairs(i).collect();
            d.sort_by(|a, b| a.1.total_cmp(&b.1));
            let Some(&(j, d1)) = d.first() else {
                continue;
            };
            let d2 = d.get(1).map_or(f32::INFINITY, |x| x.1);
            if (d2.is_infinite() || d1 < ratio2 * d2)
                && d1 <= max2
                && (!cfg.mutual || best_feature[j].0 == i)
            {
                out.push(Match {
                    query: i,
                    train: j,
                    distance: d1.sqrt(),
                });
            }
        }
        out
    }

    /// The grid-scanned, pruned search gives exactly the matches of the plain computation,
    /// for a distance cap with the ratio test and mutual check on or off. Each feature has a
    /// close point (squared distance up to 0.12) and a rival beside it whose distance
    /// straddles the pruning bound (0.05–0.3), so the ratio test and the mutual check are
    /// decided near it.
    #[test]
    fn guided_matches_are_those_of_the_plain_computation() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let unit = |v: Vec<f32>| {
            let n = v.iter().map(|x| x * x).sum::<f32>().sqrt();
            v.into_iter().map(|x| x / n).collect::<Vec<f32>>()
        };
        // `v` moved by a random direction of squared length `d2` (≈ the squared distance).
        let near = |v: &[f32], d2: f32, uniform: &mut dyn FnMut() -> f32| {
            let dir = unit((0..v.len()).map(|_| uniform() - 0.5).collect());
            unit(v.iter().zip(&dir).map(|(a, e)| a + d2.sqrt() * e).collect())
        };
        let camera = Camera::from_hfov(640, 480, 90.0);
        let mut points = Vec::new();
        let mut features = Vec::new();
        for _ in 0..800 {
            let (u, v) = (
                20.0 + 600.0 * uniform() as f64,
                20.0 + 440.0 * uniform() as f64,
            );
            let true_point: Vec<f32> = unit((0..64).map(|_| uniform() - 0.5).collect());
            let fd = near(&true_point, 0.12 * uniform(), &mut uniform);
            let rival = near(&fd, 0.05 + 0.25 * uniform(), &mut uniform);
            for (desc, du) in [(true_point, 0.0), (rival, 4.0 * (uniform() as f64 - 0.5))] {
                let z = 30.0 + 50.0 * uniform() as f64;
                let p_c = camera
                    .unproject(&nalgebra::Point2::new(u + du, v), z)
                    .expect("inside the image");
                let mut p = point([p_c.x, p_c.y, p_c.z], [0.0, 0.0]);
                p.descriptor = desc;
                points.push(p);
            }
            let mut f = feature(u as f32 + 2.0 * (uniform() - 0.5), v as f32, [0.0, 0.0]);
            f.descriptor = fd;
            features.push(f);
        }
        let pts: Vec<&MapPoint> = points.iter().collect();
        let pose = Pose::identity();
        for (max_distance, mutual) in [(0.3, true), (0.3, false), (0.25, true)] {
            let cfg = MatcherConfig {
                max_distance,
                mutual,
                ..MatcherConfig::default()
            };
            let full = reference(&features, &pts, &camera, 6.0, &cfg);
            let pruned = match_guided(
                &features,
                &pts,
                &camera,
                &pose,
                Window::rigid(6.0, 1.0),
                &cfg,
            );
            let pairs = |m: &[Match]| -> Vec<(usize, usize)> {
                m.iter().map(|m| (m.query, m.train)).collect()
            };
            let (want, got) = (pairs(&full), pairs(&pruned));
            let differ = want.iter().filter(|m| !got.contains(m)).count();
            assert!(
                want == got,
                "{max_distance} mutual {mutual}: {differ} of {} matches differ, {} vs {}",
                want.len(),
                want.len(),
                got.len()
            );
            for (a, b) in full.iter().zip(&pruned) {
                assert!((a.distance - b.distance).abs() < 1e-5, "{a:?} vs {b:?}");
            }
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
        let m = match_guided(
            &features,
            &pts,
            &camera,
            &pose,
            Window::rigid(10.0, 1.0),
            &cfg,
        );
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].query, m[0].train), (0, 0));
        assert_eq!((m[1].query, m[1].train), (1, 1));
        // A point behind the camera, or projected beyond the radius, matches nothing.
        let behind = point([0.0, 0.0, -50.0], [1.0, 0.0]);
        let far = [feature(pa.x as f32 + 30.0, pa.y as f32, [1.0, 0.0])];
        assert!(
            match_guided(&far, &[&a], &camera, &pose, Window::rigid(10.0, 1.0), &cfg).is_empty()
        );
        assert!(
            match_guided(
                &features,
                &[&behind],
                &camera,
                &pose,
                Window::rigid(10.0, 1.0),
                &cfg
            )
            .is_empty()
        );
    }

    /// With wall motion, a near point's window widens (f·σ/z pixels of wall motion at its
    /// depth), a far point's hardly: a feature 20 px from a point 20 mm deep is found with a
    /// wall moved by 1 mm (f = 100 px: 5 px of motion, a window 10 · √26 ≈ 51 px wide), the
    /// same offset from a point 400 mm deep is not (0.25 px: 10.3 px).
    #[test]
    fn wall_motion_widens_the_windows_of_near_points() {
        let camera = Camera::from_hfov(200, 200, 90.0);
        let pose = Pose::identity();
        let cfg = MatcherConfig::default();
        for (depth, found) in [(20.0, true), (400.0, false)] {
            let p = point([0.0, 0.0, depth], [1.0, 0.0]);
            let px = camera.project(&p.p_world).unwrap();
            let features = [feature(px.x as f32 + 20.0, px.y as f32, [1.0, 0.0])];
            let window = Window::rigid(10.0, 1.0);
            let rigid = match_guided(&features, &[&p], &camera, &pose, window, &cfg);
            let moved = window.with_wall_motion(1.0);
            let tolerant = match_guided(&features, &[&p], &camera, &pose, moved, &cfg);
            assert!(rigid.is_empty(), "{depth} mm: {rigid:?}");
            assert_eq!(
                tolerant.len(),
                usize::from(found),
                "{depth} mm: {tolerant:?}"
            );
        }
    }
}
