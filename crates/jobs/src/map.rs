//! `MapJob`: the per-zone 3-D maps of a trained model.

use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

use endoloc_data::Dataset;
use endoloc_localize::export::{write_colmap_text, write_zone_ply};
use endoloc_localize::map_io::{save_map, save_smoothed_level};
use endoloc_localize::{MapConfig, MapSummary, build_map_masked};
use endoloc_net::ZoneClassifier;
use serde::{Deserialize, Serialize};

use crate::error::{Context, JobError, Result};
use crate::progress::{Progress, bar};

/// Builds the per-zone maps of a model: SURF tracks over `images_per_zone` images of each zone,
/// triangulated with the known training poses; points reprojecting farther than `delta_r_px`
/// are dropped. Writes `map.toml` and `map.bin` into the model folder, one PLY per zone
/// (`map_ply/zone_NNN.ply`) and a COLMAP text model (`map_colmap/`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct MapJob {
    /// Model folder written by the train job.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub model: PathBuf,
    /// Dataset the model was trained on.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub data: PathBuf,
    /// Training sequence inside the dataset.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = MapJob::default().seq))]
    pub seq: String,
    /// Images per zone (the paper's m ≥ 3).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = MapJob::default().images_per_zone))]
    pub images_per_zone: usize,
    /// SURF threshold of the map (units of MATLAB's MetricThreshold; the paper's 200 suits
    /// larger, richer images). Test frames keep their strongest keypoints above 0.4 times it
    /// (a budget per frame, see `localize --keypoint-budget`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = MapJob::default().threshold))]
    pub threshold: f32,
    /// How intensities enter SURF, for the map and for the frames localized against it:
    /// `linear` (as they are: SURF as published) or `log` (a gain is an offset and a gamma a
    /// gain, and a dim region's texture counts as much as a bright one's: more frames register
    /// when the light, exposure and highlights differ between the passes; the map has more
    /// points and a frame takes longer).
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value_t = MapJob::default().intensity)
    )]
    pub intensity: endoloc_features::Intensity,
    /// δr: drop map points reprojecting farther than this, pixels.
    #[cfg_attr(
        feature = "cli",
        arg(long = "delta-r", default_value_t = MapJob::default().delta_r_px)
    )]
    pub delta_r_px: f64,
    /// Every other training frame of a zone also looks for the zone's map points (projected
    /// with its known pose, matched within this many pixels, e.g. 3), and each point is
    /// triangulated again from all its observations: sharper points, a longer build (SURF on
    /// every training frame). 0 (default) = only the `images_per_zone` images.
    #[cfg_attr(
        feature = "cli",
        arg(long = "observation-radius", default_value_t = MapJob::default().observation_radius_px)
    )]
    pub observation_radius_px: f64,
    /// σ of the map's smoothed level, pixels: besides the map, the map of the training images
    /// smoothed by a Gaussian of this σ is built into `map_smoothed/`, and a frame that does
    /// not register against the map is registered against it (its coarser structure holds
    /// when the pass has another look: fainter texture, highlights, a blurred scope). Default:
    /// [`SMOOTHED_LEVEL_PX_PER_320`] per 320 pixels of image width (1.5 at 320×240, 3 at
    /// 640×480); 0 = no level (an earlier one is removed).
    #[cfg_attr(feature = "cli", arg(long = "smoothed-level", value_name = "SIGMA_PX"))]
    pub smoothed_level_px: Option<f64>,
    /// Replace an existing map.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for MapJob {
    fn default() -> Self {
        let cfg = MapConfig::default();
        MapJob {
            model: PathBuf::new(),
            data: PathBuf::new(),
            seq: "train".into(),
            images_per_zone: cfg.images_per_zone,
            threshold: cfg.surf.threshold,
            intensity: cfg.surf.intensity,
            delta_r_px: cfg.triangulation.delta_r_px,
            observation_radius_px: cfg.observation_radius_px,
            smoothed_level_px: None,
            force: false,
        }
    }
}

/// What `MapJob` built.
#[derive(Debug, Clone)]
pub struct MapReport {
    /// Counts and quality of the map.
    pub summary: MapSummary,
    /// Counts and quality of its smoothed level, when built.
    pub smoothed: Option<MapSummary>,
    /// The model folder the map was written to.
    pub model: PathBuf,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// The smoothed level's σ by default, pixels per 320 pixels of image width
/// ([`MapJob::smoothed_level_px`]). Over five procedural colons and the CT colon (`small`
/// preset, 320×240, live): every `moderate` look and scope change at once 40.2 → 60.9 %
/// refined, the unchanged pass 95.7 → 95.9 % with the same errors (docs/RESULTS.md).
pub const SMOOTHED_LEVEL_PX_PER_320: f64 = 1.5;

/// The σ of the smoothed level for images `width` pixels wide: `sigma_px` when given, else
/// [`SMOOTHED_LEVEL_PX_PER_320`] scaled to the width; 0 = no level.
pub fn smoothed_level_sigma(sigma_px: Option<f64>, width: u32) -> f64 {
    sigma_px.unwrap_or(SMOOTHED_LEVEL_PX_PER_320 * f64::from(width) / 320.0)
}

/// Checks a smoothed level's σ (`smoothed_level_px`, `--smoothed-level`): finite and ≥ 0.
///
/// # Errors
/// [`JobError::Invalid`] naming the option.
pub fn check_smoothed_level(sigma_px: Option<f64>) -> Result<()> {
    let Some(sigma_px) = sigma_px else {
        return Ok(());
    };
    if sigma_px.is_finite() && sigma_px >= 0.0 {
        return Ok(());
    }
    Err(JobError::Invalid(format!(
        "the smoothed level's σ (`smoothed_level_px`, `--smoothed-level`) is {sigma_px} px; \
         expected a finite value >= 0 (0: no smoothed level)"
    )))
}

impl MapJob {
    /// The library configuration of this job.
    pub fn map_config(&self) -> MapConfig {
        let mut cfg = MapConfig {
            images_per_zone: self.images_per_zone,
            observation_radius_px: self.observation_radius_px,
            ..MapConfig::default()
        };
        cfg.surf.threshold = self.threshold;
        cfg.surf.intensity = self.intensity;
        cfg.triangulation.delta_r_px = self.delta_r_px;
        cfg
    }

    /// Builds and writes the map.
    ///
    /// # Errors
    /// An existing map without `force`, an unreadable model or dataset, a model trained for
    /// another camera, or a failed write.
    pub fn run(&self, progress: &dyn Progress) -> Result<MapReport> {
        check_smoothed_level(self.smoothed_level_px)?;
        if self.model.join("map.bin").exists() && !self.force {
            return Err(JobError::Exists {
                path: self.model.join("map.bin"),
                hint: " (rebuilds the map)".into(),
            });
        }
        let classifier = ZoneClassifier::load(&self.model)
            .with_context(|| format!("loading model {}", self.model.display()))?;
        let dataset = Dataset::open(&self.data)?;
        classifier.check_compatible(&dataset.meta.camera)?;
        classifier.check_dataset(&dataset)?;
        let train = dataset.sequence(&self.seq)?;
        let cfg = self.map_config();
        let t = Instant::now();
        let mask = crate::localize::mask_of(&dataset)?;
        let model_zones = classifier
            .config()
            .provenance
            .as_ref()
            .map(|p| p.zones.clone());
        let build = |cfg: &MapConfig, what: &str| -> Result<endoloc_localize::Map> {
            let bar = bar(progress, classifier.zone_count() as u64, what);
            let map = build_map_masked(
                &train,
                classifier.zones(),
                &dataset.meta.camera,
                mask.clone(),
                cfg,
                &|_| bar.inc(1),
            )?;
            Ok(endoloc_localize::Map {
                model_zones: model_zones.clone(),
                ..map
            })
        };
        let map = build(&cfg, "map")?;
        let sigma = smoothed_level_sigma(self.smoothed_level_px, dataset.meta.camera.width);
        let level = if sigma > 0.0 {
            let level_cfg = MapConfig {
                blur_px: sigma,
                ..cfg.clone()
            };
            Some(build(&level_cfg, "smoothed level")?)
        } else {
            None
        };
        let summary = map.summary();
        save_map(&map, &self.model)?;
        save_smoothed_level(level.as_ref(), &self.model)?;
        let ply_dir = self.model.join("map_ply");
        std::fs::create_dir_all(&ply_dir).map_err(|e| JobError::io(&ply_dir, e))?;
        for z in &map.zones {
            write_zone_ply(z, &ply_dir.join(format!("zone_{:03}.ply", z.zone)))?;
        }
        write_colmap_text(&map, &train, &self.model.join("map_colmap"))?;
        for &z in &summary.empty_zones {
            let frames = classifier
                .zones()
                .zones
                .get(z)
                .map_or(0, |zone| zone.frame_count);
            if let Some(zone_map) = map.zones.get(z) {
                let cause = empty_zone_cause(frames, zone_map);
                progress.note(&format!(
                    "warning: zone {z} has no map point: {cause}; its frames will be init_only"
                ));
            }
        }
        Ok(MapReport {
            summary,
            smoothed: level.as_ref().map(endoloc_localize::Map::summary),
            model: self.model.clone(),
            seconds: t.elapsed().as_secs_f64(),
        })
    }
}

/// Mean SURF keypoints per map image below which a zone's images count as textureless.
const TEXTURELESS_KEYPOINTS_PER_IMAGE: usize = 10;

/// Why a zone got no map point, for the user: the frames the zone holds (one frame gives no
/// second view to triangulate from: the scope moved fast there), its texture (few SURF
/// keypoints), or features that were found but not tracked and triangulated.
/// `frames` is the number of training frames in the zone.
pub fn empty_zone_cause(frames: usize, zone: &endoloc_localize::ZoneMap) -> String {
    let images = zone.frames.len();
    if frames < 2 {
        return format!(
            "it holds {frames} training frame (the scope moved fast there), and a map point \
             needs two views; train with fewer zones or a larger `min_zone_frames`"
        );
    }
    let per_image = zone.keypoints / images.max(1);
    if per_image < TEXTURELESS_KEYPOINTS_PER_IMAGE {
        return format!(
            "its {images} map images (of {frames} training frames) have {} SURF keypoints in \
             all, {per_image} per image: the zone is textureless (or dark, or blurred); a lower \
             map `threshold` finds more",
            zone.keypoints
        );
    }
    format!(
        "its {images} map images (of {frames} training frames) have {} SURF keypoints, but none \
         was matched across images and triangulated ({} tracks rejected): too little overlap \
         or parallax between its frames{}",
        zone.keypoints,
        zone.rejected_tracks,
        if frames < 3 {
            "; it holds only 2 training frames, train with a larger `min_zone_frames`"
        } else {
            ""
        }
    )
}

impl fmt::Display for MapReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.summary;
        writeln!(
            f,
            "map       {} zones, {} points (median {} per zone), mean reprojection RMS {:.2} px, {:.1} s",
            s.zones, s.points, s.median_points_per_zone, s.mean_reprojection_rms_px, self.seconds
        )?;
        if let Some(l) = &self.smoothed {
            writeln!(
                f,
                "smoothed  {} points (median {} per zone), mean reprojection RMS {:.2} px",
                l.points, l.median_points_per_zone, l.mean_reprojection_rms_px
            )?;
        }
        write!(
            f,
            "wrote     {}/map.bin{}, map_ply/, map_colmap/",
            self.model.display(),
            if self.smoothed.is_some() {
                ", map_smoothed/"
            } else {
                ""
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn zone_map(images: usize, keypoints: usize, rejected: usize) -> endoloc_localize::ZoneMap {
        endoloc_localize::ZoneMap {
            zone: 16,
            frames: (0..images).collect(),
            keypoints,
            rejected_tracks: rejected,
            ..Default::default()
        }
    }

    #[test]
    fn an_empty_zone_names_its_real_cause() {
        // One frame: no second view, whatever the texture.
        let c = empty_zone_cause(1, &zone_map(1, 400, 0));
        assert!(
            c.contains("holds 1 training frame") && c.contains("moved fast"),
            "{c}"
        );
        assert!(!c.contains("textureless"), "{c}");
        // Enough frames, few keypoints: texture.
        let c = empty_zone_cause(40, &zone_map(8, 20, 0));
        assert!(
            c.contains("textureless") && c.contains("20 SURF keypoints"),
            "{c}"
        );
        assert!(c.contains("8 map images (of 40 training frames)"), "{c}");
        // Keypoints but no track: overlap; two frames are named as the likely cause.
        let c = empty_zone_cause(2, &zone_map(2, 900, 3));
        assert!(
            c.contains("900 SURF keypoints") && c.contains("3 tracks rejected"),
            "{c}"
        );
        assert!(
            c.contains("only 2 training frames") && !c.contains("textureless"),
            "{c}"
        );
    }

    #[test]
    fn defaults_are_the_library_defaults() {
        assert_eq!(MapJob::default().map_config(), MapConfig::default());
        let from_toml: MapJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, MapJob::default());
    }
}
