//! `MapJob`: the per-zone 3-D maps of a trained model.

use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

use endoloc_data::Dataset;
use endoloc_localize::export::{write_colmap_text, write_zone_ply};
use endoloc_localize::map_io::save_map;
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
#[serde(default, deny_unknown_fields)]
pub struct MapJob {
    /// Model folder written by `TrainJob`.
    pub model: PathBuf,
    /// Dataset the model was trained on.
    pub data: PathBuf,
    /// Training sequence inside the dataset.
    pub seq: String,
    /// Images per zone (the paper's `m ≥ 3`).
    pub images_per_zone: usize,
    /// SURF threshold of the map (units of MATLAB's `MetricThreshold`).
    pub threshold: f32,
    /// δr: map points reprojecting farther than this are dropped, pixels.
    pub delta_r_px: f64,
    /// Replace an existing map.
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
            delta_r_px: cfg.triangulation.delta_r_px,
            force: false,
        }
    }
}

/// What `MapJob` built.
#[derive(Debug, Clone)]
pub struct MapReport {
    /// Counts and quality of the map.
    pub summary: MapSummary,
    /// The model folder the map was written to.
    pub model: PathBuf,
    /// Wall time, seconds.
    pub seconds: f64,
}

impl MapJob {
    /// The library configuration of this job.
    pub fn map_config(&self) -> MapConfig {
        let mut cfg = MapConfig {
            images_per_zone: self.images_per_zone,
            ..MapConfig::default()
        };
        cfg.surf.threshold = self.threshold;
        cfg.triangulation.delta_r_px = self.delta_r_px;
        cfg
    }

    /// Builds and writes the map.
    ///
    /// # Errors
    /// An existing map without `force`, an unreadable model or dataset, a model trained for
    /// another camera, or a failed write.
    pub fn run(&self, progress: &dyn Progress) -> Result<MapReport> {
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
        let train = dataset.sequence(&self.seq)?;
        let cfg = self.map_config();
        let t = Instant::now();
        let map = {
            let bar = bar(progress, classifier.zone_count() as u64, "map");
            build_map_masked(
                &train,
                classifier.zones(),
                &dataset.meta.camera,
                crate::localize::mask_of(&dataset)?,
                &cfg,
                &|_| bar.inc(1),
            )?
        };
        let summary = map.summary();
        save_map(&map, &self.model)?;
        let ply_dir = self.model.join("map_ply");
        std::fs::create_dir_all(&ply_dir).map_err(|e| JobError::io(&ply_dir, e))?;
        for z in &map.zones {
            write_zone_ply(z, &ply_dir.join(format!("zone_{:03}.ply", z.zone)))?;
        }
        write_colmap_text(&map, &train, &self.model.join("map_colmap"))?;
        for z in &summary.empty_zones {
            let frames = classifier
                .zones()
                .zone_of_frame
                .iter()
                .filter(|&&f| f == *z)
                .count();
            let cause = if frames < 2 {
                format!("it holds {frames} training frame(s): use fewer zones")
            } else {
                "its images are textureless or too few features matched".to_string()
            };
            progress.note(&format!(
                "warning: zone {z} has no map point ({cause}); its frames will be init_only"
            ));
        }
        Ok(MapReport {
            summary,
            model: self.model.clone(),
            seconds: t.elapsed().as_secs_f64(),
        })
    }
}

impl fmt::Display for MapReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.summary;
        writeln!(
            f,
            "map       {} zones, {} points (median {} per zone), mean reprojection RMS {:.2} px, {:.1} s",
            s.zones, s.points, s.median_points_per_zone, s.mean_reprojection_rms_px, self.seconds
        )?;
        write!(
            f,
            "wrote     {}/map.bin, map_ply/, map_colmap/",
            self.model.display()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_library_defaults() {
        assert_eq!(MapJob::default().map_config(), MapConfig::default());
        let from_toml: MapJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, MapJob::default());
    }
}
