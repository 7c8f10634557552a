//! Per-zone 3-D map points: SURF tracks across `m` images of a zone, triangulated with the
//! known training poses (the paper's step I, Eq. 1), outliers dropped by `δr`.
//!
//! Tracks: every pair of the zone's selected images is matched (ratio test, mutual nearest,
//! Laplacian gating); matches are joined into tracks by union-find; a track that would see
//! two keypoints in one image is dropped (ambiguous). Each remaining track with at least
//! `min_views` images is triangulated by [`endoloc_geometry::Triangulator`] (linear start,
//! Gauss-Newton on the reprojection error, cheirality, parallax and `δr` checks). A map point
//! keeps the mean of its observations' descriptors (re-normalised) and their Laplacian sign.

use endoloc_data::Sequence;
use endoloc_features::{Feature, Matcher, MatcherConfig, Surf, SurfConfig};
use endoloc_geometry::{Camera, Observation, TriangulationConfig, Triangulator};
use endoloc_net::ZoneTable;
use nalgebra::{Point2, Point3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::LocalizeError;
pub use crate::map_point::MapPoint;

/// SURF threshold of the maps (units of MATLAB's `MetricThreshold`). The paper used 200; on
/// 640×480 simulated frames a lower threshold gives denser maps and more registered frames
/// (`paper` preset, live: 200 → 42 map points per zone and 22 % refined; 50 → 446 and 94.4 %;
/// 25 → 962 and 95.4 %), so 25 is the default. Test frames keep a keypoint budget above
/// 0.4 times it ([`crate::TEST_KEYPOINT_BUDGET`]).
pub const DEFAULT_MAP_THRESHOLD: f32 = 25.0;

/// How maps are built.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapConfig {
    /// Images per zone (`m` in the paper, at least 3), chosen evenly over the zone's frames.
    pub images_per_zone: usize,
    /// Smallest number of images a track must be seen in.
    pub min_views: usize,
    /// SURF settings (the paper's: threshold 200, 4 octaves, 6 scale levels).
    pub surf: SurfConfig,
    /// Matching between the zone's images.
    pub matcher: MatcherConfig,
    /// Triangulation, including the paper's `δr = 10 px`.
    pub triangulation: TriangulationConfig,
    /// Beyond the paper (opt-in): every other training frame of the zone also looks for the
    /// map points. Each point is projected with the frame's known pose and matched to the
    /// frame's SURF features within this many pixels (same descriptor tests as the tracks);
    /// the new observations join the point's track and the point is triangulated again from
    /// all of them, kept only when every observation agrees with it within this radius (more
    /// views and a wider baseline: a sharper point). 0 (default) = off: the
    /// `images_per_zone` images only. At 3 px, median errors drop by 5–10 % across colons,
    /// but live localization's few wrong `refined` frames do not (docs/RESULTS.md).
    pub observation_radius_px: f64,
    /// Beyond the paper: the training images are smoothed by a Gaussian of this
    /// standard deviation, pixels, before SURF detects and describes them; the frames
    /// localized against the map are described as they are. A map of the coarser structure,
    /// whose descriptors hold better when the pass being localized has another look (fainter
    /// texture, highlights, a blurred scope). 0 (default) = the images as they are. The
    /// map's smoothed level is a map built with it (by `endoloc map`, by default), where a
    /// frame that the map does not register goes next ([`crate::Localizer::with_smoothed_level`]).
    /// Not written to `map.toml` when 0, so a map built without it reads as before.
    #[serde(skip_serializing_if = "is_zero")]
    pub blur_px: f64,
}

impl Default for MapConfig {
    fn default() -> Self {
        MapConfig {
            images_per_zone: 8,
            min_views: 2,
            surf: SurfConfig::default().with_threshold(DEFAULT_MAP_THRESHOLD),
            matcher: MatcherConfig::default(),
            triangulation: TriangulationConfig::default(),
            observation_radius_px: 0.0,
            blur_px: 0.0,
        }
    }
}

impl MapConfig {
    /// Checks ranges.
    ///
    /// # Errors
    /// [`LocalizeError::Config`] naming the bad field.
    pub fn validate(&self) -> Result<(), LocalizeError> {
        if self.images_per_zone < 3 {
            return Err(LocalizeError::Config(format!(
                "map: images_per_zone must be at least 3 (the paper's m ≥ 3), got {}",
                self.images_per_zone
            )));
        }
        if !(self.observation_radius_px.is_finite() && self.observation_radius_px >= 0.0) {
            return Err(LocalizeError::Config(format!(
                "map: observation_radius_px must be a finite value >= 0, got {}",
                self.observation_radius_px
            )));
        }
        if !(self.blur_px.is_finite() && self.blur_px >= 0.0) {
            return Err(LocalizeError::Config(format!(
                "map: blur_px must be a finite value >= 0, got {}",
                self.blur_px
            )));
        }
        if self.min_views < 2 {
            return Err(LocalizeError::Config(format!(
                "map: min_views must be at least 2, got {}",
                self.min_views
            )));
        }
        Ok(())
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The map of one zone.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ZoneMap {
    /// Zone index.
    pub zone: usize,
    /// Training frames the map was built from.
    pub frames: Vec<usize>,
    /// Map points.
    pub points: Vec<MapPoint>,
    /// Tracks that failed triangulation or `δr`.
    pub rejected_tracks: usize,
    /// SURF keypoints detected over the zone's images (a textureless zone has few). Not
    /// stored in `map.bin`: 0 for a loaded map.
    pub keypoints: usize,
}

/// All zone maps of a model.
#[derive(Debug, Clone, PartialEq)]
pub struct Map {
    /// The settings the map was built with.
    pub config: MapConfig,
    /// The camera of the training images.
    pub camera: Camera,
    /// One map per zone, in zone order.
    pub zones: Vec<ZoneMap>,
    /// Fingerprint of the model's `zones.csv` the map was built for (set by whoever builds the
    /// map for a model folder; `None` for maps written before fingerprints existed). A
    /// [`crate::Localizer`] refuses a map whose zones are not its model's.
    pub model_zones: Option<endoloc_data::Fingerprint>,
}

/// Counts for a report.
#[derive(Debug, Clone, PartialEq)]
pub struct MapSummary {
    /// Zones.
    pub zones: usize,
    /// Map points over all zones.
    pub points: usize,
    /// Zones without any map point (localization there falls back to the median pose).
    pub empty_zones: Vec<usize>,
    /// Median points per zone.
    pub median_points_per_zone: usize,
    /// Mean reprojection RMS over all points, pixels.
    pub mean_reprojection_rms_px: f64,
}

impl Map {
    /// Counts points and empty zones.
    pub fn summary(&self) -> MapSummary {
        let mut counts: Vec<usize> = self.zones.iter().map(|z| z.points.len()).collect();
        let points: usize = counts.iter().sum();
        let rms: f64 = self
            .zones
            .iter()
            .flat_map(|z| z.points.iter().map(|p| p.reprojection_rms_px))
            .sum::<f64>()
            / points.max(1) as f64;
        counts.sort_unstable();
        MapSummary {
            zones: self.zones.len(),
            points,
            empty_zones: self
                .zones
                .iter()
                .filter(|z| z.points.is_empty())
                .map(|z| z.zone)
                .collect(),
            median_points_per_zone: counts.get(counts.len() / 2).copied().unwrap_or(0),
            mean_reprojection_rms_px: rms,
        }
    }
}

/// `m` frames spread evenly over `first..=last` (all of them when the zone is shorter).
pub fn pick_frames(first: usize, last: usize, m: usize) -> Vec<usize> {
    let n = last - first + 1;
    if n <= m {
        return (first..=last).collect();
    }
    let mut out: Vec<usize> = (0..m)
        .map(|i| first + (i as f64 * (n - 1) as f64 / (m - 1) as f64).round() as usize)
        .collect();
    out.dedup();
    out
}

/// Builds the map of every zone of the training sequence.
///
/// `progress` is called once per finished zone (from worker threads).
///
/// # Errors
/// Invalid config, a zone table that does not fit the sequence, or unreadable images.
pub fn build_map(
    train: &Sequence,
    zones: &ZoneTable,
    camera: &Camera,
    cfg: &MapConfig,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Map, LocalizeError> {
    build_map_masked(train, zones, camera, None, cfg, progress)
}

/// [`build_map`] for frames with an image mask (black border, field stop): SURF detects and
/// describes only inside it ([`endoloc_features::mask`]).
///
/// # Errors
/// As [`build_map`]; a mask of another size than the frames.
pub fn build_map_masked(
    train: &Sequence,
    zones: &ZoneTable,
    camera: &Camera,
    mask: Option<std::sync::Arc<endoloc_features::Mask>>,
    cfg: &MapConfig,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Map, LocalizeError> {
    cfg.validate()?;
    if zones.frame_count() != train.len() {
        return Err(LocalizeError::Mismatch(format!(
            "the model's zones cover {} training frames but {} has {}",
            zones.frame_count(),
            train.dir.display(),
            train.len()
        )));
    }
    let surf = cfg
        .surf
        .clone()
        .with_parallel(false)
        .init()?
        .with_mask(mask);
    let matcher = Matcher::new(cfg.matcher.clone().with_parallel(false));
    let zone_maps: Result<Vec<ZoneMap>, LocalizeError> = zones
        .zones
        .par_iter()
        .map(|zone| {
            let frames = pick_frames(zone.first_frame, zone.last_frame, cfg.images_per_zone);
            let map = build_zone_map(train, zone.index, &frames, camera, cfg, &surf, &matcher)
                .and_then(|mut map| {
                    if cfg.observation_radius_px > 0.0 {
                        let others =
                            (zone.first_frame..=zone.last_frame).filter(|f| !frames.contains(f));
                        extend_observations(train, others, &mut map.points, camera, cfg, &surf)?;
                    }
                    Ok(map)
                });
            progress(zone.index);
            map
        })
        .collect();
    Ok(Map {
        config: cfg.clone(),
        camera: *camera,
        zones: zone_maps?,
        model_zones: None,
    })
}

fn build_zone_map(
    train: &Sequence,
    zone: usize,
    frames: &[usize],
    camera: &Camera,
    cfg: &MapConfig,
    surf: &Surf,
    matcher: &Matcher,
) -> Result<ZoneMap, LocalizeError> {
    let mut features: Vec<Vec<Feature>> = Vec::with_capacity(frames.len());
    for &f in frames {
        let img = map_image(train, f, cfg)?;
        features.push(surf.detect_and_describe(&img)?);
    }
    // Union-find over (image, keypoint) nodes.
    let offsets: Vec<usize> = features
        .iter()
        .scan(0, |acc, f| {
            let o = *acc;
            *acc += f.len();
            Some(o)
        })
        .collect();
    let total: usize = features.iter().map(Vec::len).sum();
    let mut parent: Vec<usize> = (0..total).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for i in 0..features.len() {
        for j in i + 1..features.len() {
            for m in matcher.match_descriptors(&features[i], &features[j])? {
                let a = find(&mut parent, offsets[i] + m.query);
                let b = find(&mut parent, offsets[j] + m.train);
                if a != b {
                    parent[a] = b;
                }
            }
        }
    }
    let mut tracks: std::collections::BTreeMap<usize, Vec<(usize, usize)>> = Default::default();
    for (img, feats) in features.iter().enumerate() {
        for k in 0..feats.len() {
            let root = find(&mut parent, offsets[img] + k);
            tracks.entry(root).or_default().push((img, k));
        }
    }
    let mut triangulator = Triangulator::new(*camera, cfg.triangulation);
    let mut points = Vec::new();
    let mut rejected = 0;
    for track in tracks.values() {
        if track.len() < cfg.min_views {
            continue;
        }
        // Two keypoints of one image in a track: ambiguous, drop.
        let mut images: Vec<usize> = track.iter().map(|t| t.0).collect();
        images.sort_unstable();
        if images.windows(2).any(|w| w[0] == w[1]) {
            rejected += 1;
            continue;
        }
        let observations: Vec<Observation> = track
            .iter()
            .map(|&(img, k)| {
                let kp = &features[img][k].keypoint;
                Observation {
                    pose: train.poses[frames[img]].pose,
                    pixel: Point2::new(kp.x as f64, kp.y as f64),
                }
            })
            .collect();
        match triangulator.triangulate(&observations) {
            Ok(tp) => {
                let dim = features[track[0].0][track[0].1].descriptor.len();
                let mut descriptor = vec![0f32; dim];
                for &(img, k) in track {
                    for (d, v) in descriptor.iter_mut().zip(&features[img][k].descriptor) {
                        *d += v;
                    }
                }
                let norm = descriptor
                    .iter()
                    .map(|v| v * v)
                    .sum::<f32>()
                    .sqrt()
                    .max(1e-12);
                descriptor.iter_mut().for_each(|v| *v /= norm);
                points.push(MapPoint {
                    p_world: tp.p_world,
                    descriptor,
                    laplacian: features[track[0].0][track[0].1].keypoint.laplacian,
                    observations: track
                        .iter()
                        .zip(&observations)
                        .map(|(&(img, _), o)| (frames[img], o.pixel))
                        .collect(),
                    reprojection_rms_px: tp.reprojection_rms_px,
                });
            }
            Err(_) => rejected += 1,
        }
    }
    Ok(ZoneMap {
        zone,
        frames: frames.to_vec(),
        points,
        rejected_tracks: rejected,
        keypoints: total,
    })
}

/// Training frame `f` as the map sees it: grey, smoothed by [`MapConfig::blur_px`].
fn map_image(
    train: &Sequence,
    f: usize,
    cfg: &MapConfig,
) -> Result<image::GrayImage, LocalizeError> {
    let img = train.load_gray(f)?;
    Ok(if cfg.blur_px > 0.0 {
        image::imageops::blur(&img, cfg.blur_px as f32)
    } else {
        img
    })
}

/// [`MapConfig::observation_radius_px`]: the observations of `points` in the training frames
/// `others` (found by projecting each point with the frame's known pose), and the points
/// triangulated again from all their observations.
fn extend_observations(
    train: &Sequence,
    others: impl Iterator<Item = usize>,
    points: &mut [MapPoint],
    camera: &Camera,
    cfg: &MapConfig,
    surf: &Surf,
) -> Result<(), LocalizeError> {
    if points.is_empty() {
        return Ok(());
    }
    let mut found: Vec<Vec<(usize, Point2<f64>)>> = vec![Vec::new(); points.len()];
    let refs: Vec<&MapPoint> = points.iter().collect();
    for f in others {
        let img = map_image(train, f, cfg)?;
        let features = surf.detect_and_describe(&img)?;
        let matches = crate::guided::match_guided(
            &features,
            &refs,
            camera,
            &train.poses[f].pose,
            crate::guided::Window::rigid(cfg.observation_radius_px, cfg.triangulation.min_depth_mm),
            &cfg.matcher,
        );
        for m in matches {
            let kp = &features[m.query].keypoint;
            found[m.train].push((f, Point2::new(kp.x as f64, kp.y as f64)));
        }
    }
    // The point moves only when every observation, old and new, agrees with it within the
    // search radius: a wrong match in a repetitive texture fails this and leaves it as it was.
    let strict = TriangulationConfig {
        delta_r_px: cfg.observation_radius_px.min(cfg.triangulation.delta_r_px),
        ..cfg.triangulation
    };
    let mut triangulator = Triangulator::new(*camera, strict);
    for (point, new) in points.iter_mut().zip(found) {
        if new.is_empty() {
            continue;
        }
        let mut all = point.observations.clone();
        all.extend(new);
        all.sort_by_key(|o| o.0);
        let observations: Vec<Observation> = all
            .iter()
            .map(|&(f, pixel)| Observation {
                pose: train.poses[f].pose,
                pixel,
            })
            .collect();
        if let Ok(tp) = triangulator.triangulate(&observations) {
            point.p_world = tp.p_world;
            point.reprojection_rms_px = tp.reprojection_rms_px;
            point.observations = all;
        }
    }
    Ok(())
}

/// The 3-D map points and the pixels of `matches` (query: `features`, train: `points`), in
/// the form [`endoloc_geometry::localize_pose`] takes.
pub(crate) fn correspondences(
    matches: &[endoloc_features::Match],
    features: &[Feature],
    points: &[&MapPoint],
) -> (Vec<Point3<f64>>, Vec<Point2<f64>>) {
    matches
        .iter()
        .map(|m| {
            let kp = &features[m.query].keypoint;
            (
                points[m.train].p_world,
                Point2::new(kp.x as f64, kp.y as f64),
            )
        })
        .unzip()
}

/// The pixels flagged in `inliers` (one flag per pixel).
pub(crate) fn inlier_pixels(pixels: &[Point2<f64>], inliers: &[bool]) -> Vec<[f32; 2]> {
    pixels
        .iter()
        .zip(inliers)
        .filter(|(_, inlier)| **inlier)
        .map(|(p, _)| [p.x as f32, p.y as f32])
        .collect()
}

/// The map points flagged in `inliers` (one flag per point).
pub(crate) fn inlier_points(points: &[Point3<f64>], inliers: &[bool]) -> Vec<Point3<f64>> {
    points
        .iter()
        .zip(inliers)
        .filter(|(_, inlier)| **inlier)
        .map(|(p, _)| *p)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_picked_evenly_and_include_both_ends() {
        assert_eq!(pick_frames(10, 50, 5), vec![10, 20, 30, 40, 50]);
        assert_eq!(pick_frames(3, 5, 8), vec![3, 4, 5]);
        let f = pick_frames(0, 51, 8);
        assert_eq!((f[0], *f.last().unwrap(), f.len()), (0, 51, 8));
    }
}
