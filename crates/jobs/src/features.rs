//! `FeaturesJob`: SURF keypoints of one image — count, keypoint file, overlay picture.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

use endoloc_data::write_atomic;
use endoloc_eval::refuse_existing;
use endoloc_features::{Feature, Keypoint, SurfConfig, draw, io};
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::error::{Context, JobError, Result};
use crate::progress::Progress;

/// Detects SURF keypoints in `image` and optionally writes them (`keypoints`: `.csv` or
/// `.json`, by extension) and an overlay picture (`overlay`, PNG: circles of radius 2.5σ
/// with an orientation line; green = dark blob, magenta = bright blob). Detector settings are
/// [`SurfConfig`]'s defaults (or the `config` file's), overridden by the fields that are set.
/// Existing output files are kept unless `force`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct FeaturesJob {
    /// Input image (any format the `image` crate reads; colour is converted to grey).
    #[cfg_attr(feature = "cli", arg())]
    pub image: PathBuf,
    /// Write the image with the keypoints drawn (PNG).
    #[cfg_attr(feature = "cli", arg(long, value_name = "PNG"))]
    pub overlay: Option<PathBuf>,
    /// Write the keypoints: `.csv` (x,y,scale,orientation_rad,response,laplacian,octave;
    /// pixels, origin at the top-left pixel's centre) or `.json`.
    #[cfg_attr(feature = "cli", arg(long, value_name = "FILE"))]
    pub keypoints: Option<PathBuf>,
    /// Include the descriptors in the JSON keypoint file.
    #[cfg_attr(feature = "cli", arg(long, requires = "keypoints"))]
    pub descriptors: bool,
    /// Detector settings from a TOML file (fields of SurfConfig); the options below override
    /// it.
    #[cfg_attr(feature = "cli", arg(long, value_name = "TOML"))]
    pub config: Option<PathBuf>,
    /// Hessian threshold (MATLAB MetricThreshold).
    #[cfg_attr(feature = "cli", arg(long))]
    pub threshold: Option<f32>,
    /// Number of octaves (MATLAB NumOctaves).
    #[cfg_attr(feature = "cli", arg(long))]
    pub octaves: Option<usize>,
    /// Filter sizes per octave (MATLAB NumScaleLevels).
    #[cfg_attr(feature = "cli", arg(long))]
    pub scale_levels: Option<usize>,
    /// Sampling step of the first octave in pixels.
    #[cfg_attr(feature = "cli", arg(long))]
    pub initial_step: Option<usize>,
    /// U-SURF: no orientation (0 = along +x).
    #[cfg_attr(feature = "cli", arg(long))]
    pub upright: bool,
    /// 128-d descriptors instead of 64-d.
    #[cfg_attr(feature = "cli", arg(long))]
    pub extended: bool,
    /// Use one thread.
    #[cfg_attr(feature = "cli", arg(long))]
    pub single_thread: bool,
    /// Replace `overlay` and `keypoints` files that already exist.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

/// What `FeaturesJob` found and wrote.
#[derive(Debug, Clone)]
pub struct FeaturesReport {
    /// The input image.
    pub image: PathBuf,
    /// Image width and height, pixels.
    pub size: (u32, u32),
    /// Keypoints found.
    pub keypoints: usize,
    /// The detector settings used.
    pub surf: SurfConfig,
    /// Detection and description time, ms.
    pub ms: f64,
    /// Files written, in order.
    pub written: Vec<PathBuf>,
}

#[derive(Serialize)]
struct JsonOut<'a> {
    image: String,
    width: u32,
    height: u32,
    config: &'a SurfConfig,
    keypoints: Vec<&'a Keypoint>,
    #[serde(skip_serializing_if = "Option::is_none")]
    descriptors: Option<Vec<&'a [f32]>>,
}

impl FeaturesJob {
    /// The validated detector settings of this job.
    ///
    /// # Errors
    /// An unreadable or invalid `config` file, or settings that do not validate.
    pub fn surf_config(&self) -> Result<SurfConfig> {
        let mut surf = match &self.config {
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("reading {}", path.display()))?;
                toml::from_str::<SurfConfig>(&text).map_err(|e| {
                    let (line, message) = endoloc_data::toml_error_line(&text, &e);
                    JobError::Invalid(format!("{}:{line}: {message}", path.display()))
                })?
            }
            None => SurfConfig::default(),
        };
        if let Some(t) = self.threshold {
            surf.threshold = t;
        }
        if let Some(o) = self.octaves {
            surf.octaves = o;
        }
        if let Some(l) = self.scale_levels {
            surf.scale_levels = l;
        }
        if let Some(s) = self.initial_step {
            surf.initial_step = s;
        }
        surf.upright |= self.upright;
        surf.extended |= self.extended;
        if self.single_thread {
            surf.parallel = false;
        }
        surf.validate()?;
        Ok(surf)
    }

    /// Whether the keypoint file is JSON (else CSV), checked against `descriptors`.
    fn keypoints_json(&self, path: &Path) -> Result<bool> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let json = match ext.as_deref() {
            Some("csv") => false,
            Some("json") => true,
            _ => bail!(
                "`keypoints` {}: expected a .csv or .json file name",
                path.display()
            ),
        };
        if self.descriptors && !json {
            bail!("`descriptors` needs a .json keypoint file (CSV holds keypoints only)");
        }
        Ok(json)
    }

    /// Detects, describes and writes.
    ///
    /// # Errors
    /// Invalid settings or file names, existing outputs without `force`, an unreadable
    /// image, or a failed write.
    pub fn run(&self, _progress: &dyn Progress) -> Result<FeaturesReport> {
        let surf_cfg = self.surf_config()?;
        let json = self
            .keypoints
            .as_deref()
            .map(|p| self.keypoints_json(p))
            .transpose()?;
        if let Some(p) = &self.overlay
            && !p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            bail!("`overlay` {}: expected a .png file name", p.display());
        }
        if self.overlay.is_some() && self.overlay == self.keypoints {
            bail!("`overlay` and `keypoints` name the same file; give two files");
        }
        let outputs: Vec<&PathBuf> = self.overlay.iter().chain(&self.keypoints).collect();
        refuse_existing(&outputs, self.force)?;

        let grey = image::open(&self.image)
            .map_err(|e| JobError::Invalid(format!("reading image {}: {e}", self.image.display())))?
            .to_luma8();
        let surf = surf_cfg.clone().init()?;
        let start = Instant::now();
        let features: Vec<Feature> = surf
            .detect_and_describe(&grey)
            .with_context(|| format!("detecting SURF keypoints in {}", self.image.display()))?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let keypoints: Vec<Keypoint> = features.iter().map(|f| f.keypoint).collect();
        let mut written = Vec::new();
        if let (Some(path), Some(json)) = (&self.keypoints, json) {
            let text = if json {
                serde_json::to_string_pretty(&JsonOut {
                    image: self.image.display().to_string(),
                    width: grey.width(),
                    height: grey.height(),
                    config: &surf_cfg,
                    keypoints: keypoints.iter().collect(),
                    descriptors: self
                        .descriptors
                        .then(|| features.iter().map(|f| f.descriptor.as_slice()).collect()),
                })
                .map_err(|e| JobError::Invalid(format!("encoding {}: {e}", path.display())))?
            } else {
                io::keypoints_to_csv(&keypoints)
            };
            write_file(path, text.as_bytes())?;
            written.push(path.clone());
        }
        if let Some(path) = &self.overlay {
            let picture = draw::draw_keypoints(&grey, &keypoints);
            let mut png = Vec::new();
            picture
                .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .map_err(|e| {
                    JobError::Invalid(format!("encoding overlay {}: {e}", path.display()))
                })?;
            write_file(path, &png)?;
            written.push(path.clone());
        }
        Ok(FeaturesReport {
            image: self.image.clone(),
            size: (grey.width(), grey.height()),
            keypoints: features.len(),
            surf: surf_cfg,
            ms,
            written,
        })
    }
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating folder {}", dir.display()))?;
    }
    Ok(write_atomic(path, bytes)?)
}

impl fmt::Display for FeaturesReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.surf;
        write!(
            f,
            "{}: {} × {} px, {} keypoints (threshold {}, {} octaves, {} scale levels{}{}) in {:.1} ms",
            self.image.display(),
            self.size.0,
            self.size.1,
            self.keypoints,
            s.threshold,
            s.octaves,
            s.scale_levels,
            if s.upright { ", upright" } else { "" },
            if s.extended { ", 128-d" } else { "" },
            self.ms
        )?;
        for p in &self.written {
            write!(f, "\nwrote {}", p.display())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_library_defaults() {
        let from_toml: FeaturesJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, FeaturesJob::default());
        assert_eq!(
            FeaturesJob::default().surf_config().unwrap(),
            SurfConfig::default()
        );
    }
}
