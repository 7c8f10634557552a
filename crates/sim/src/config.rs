//! The full simulation config, its presets, and seed derivation.
//!
//! A config is stored in the dataset's `dataset.toml` under `[simulation]`, so every dataset
//! can be regenerated exactly from its own files (`endoloc simulate --config dataset.toml`).

use std::path::PathBuf;

use endoloc_geometry::{Camera, Distortion};
use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::appearance::AppearanceConfig;
use crate::change::ChangeConfig;
use crate::colon::from_mesh::MeshColonConfig;
use crate::colon::procedural::ProceduralColonConfig;
use crate::render::RenderConfig;
use crate::trajectory::TrajectoryConfig;

/// Which colon to simulate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ColonSource {
    /// The built-in procedural colon.
    Procedural(ProceduralColonConfig),
    /// A surface mesh with its mid-line (e.g. a CT colon).
    Mesh(MeshColonConfig),
}

/// The scope camera, principal point at the image centre: an ideal pinhole, or with lens
/// distortion (OpenCV radial-tangential or fisheye), rendered through a wider pinhole and
/// resampled.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Horizontal field of view, degrees (square pixels). For a fisheye camera the focal
    /// length is that of the equidistant model over the image width:
    /// `f = (width/2) / (hfov/2 in radians)`.
    pub hfov_deg: f64,
    /// Lens distortion of the rendered images (none by default).
    #[serde(default, skip_serializing_if = "Distortion::is_none")]
    pub distortion: Distortion,
}

impl CameraConfig {
    /// The pinhole camera this config describes.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] for a zero size or a field of view outside (1°, 170°).
    pub fn camera(&self) -> Result<Camera, SimError> {
        if self.width < 16 || self.height < 16 || self.width > 8192 || self.height > 8192 {
            return Err(SimError::InvalidConfig(format!(
                "camera: image size must be between 16 and 8192 pixels, got {}x{}",
                self.width, self.height
            )));
        }
        if !(self.hfov_deg.is_finite() && self.hfov_deg > 1.0 && self.hfov_deg < 170.0) {
            return Err(SimError::InvalidConfig(format!(
                "camera: hfov_deg must be in (1, 170), got {}",
                self.hfov_deg
            )));
        }
        let mut camera = Camera::from_hfov(self.width, self.height, self.hfov_deg);
        if let Distortion::Fisheye { .. } = self.distortion {
            let f = (self.width as f64 / 2.0) / (self.hfov_deg.to_radians() / 2.0);
            camera.fx = f;
            camera.fy = f;
        }
        camera.distortion = self.distortion;
        camera.validate().map_err(SimError::InvalidConfig)?;
        Ok(camera)
    }
}

/// Everything that determines a simulated dataset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimConfig {
    /// Dataset name.
    pub name: String,
    /// Master seed; [`SimConfig::with_seed`] derives every stage's seed from it.
    pub seed: u64,
    /// Write 16-bit depth maps next to the images.
    pub depth: bool,
    /// Colon model.
    pub colon: ColonSource,
    /// Scope camera.
    pub camera: CameraConfig,
    /// Mucosa texture.
    pub appearance: AppearanceConfig,
    /// Lighting, optics and sensor.
    pub render: RenderConfig,
    /// Training pass.
    pub train: TrajectoryConfig,
    /// Test pass (same colon, independent motion).
    pub test: TrajectoryConfig,
    /// How the colon, its look and the scope change between the training and the test pass
    /// (nothing by default; stored only when something changes).
    #[serde(default, skip_serializing_if = "ChangeConfig::is_none")]
    pub changes: ChangeConfig,
}

/// Named starting points for a config.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// The paper's scale: 2610 train + 2603 test frames at 640×480, 30 fps, 90° horizontal
    /// field of view (fx = fy = 320 px).
    Paper,
    /// A quick dataset for tests and the demo: 300 + 300 frames at 320×240, same field of
    /// view, depth maps on.
    Small,
    /// The `paper` passes seen through a real endoscope's optics, after C3VD's recordings
    /// (1350×1080 scaled to 640×512): an equidistant fisheye of 120° horizontal field of view,
    /// a circular field stop that blacks out the corners, stronger (saturating) specular
    /// highlights, per-frame exposure changes and motion blur.
    C3vdLike,
}

impl Preset {
    /// All presets.
    pub const ALL: [Preset; 3] = [Preset::Paper, Preset::Small, Preset::C3vdLike];

    /// The preset's name on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            Preset::Paper => "paper",
            Preset::Small => "small",
            Preset::C3vdLike => "c3vd-like",
        }
    }
}

impl std::fmt::Display for Preset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Preset {
    type Err = SimError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Preset::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| {
                SimError::InvalidConfig(format!(
                    "unknown preset {s:?}; expected paper, small or c3vd-like"
                ))
            })
    }
}

/// The tag of the change's seed among the seeds derived from the master seed.
const CHANGES_SEED_TAG: u64 = 5;

/// The seed of one stage, derived from the master seed (63 bits: TOML integers are signed
/// 64-bit).
fn derived_seed(master: u64, tag: u64) -> u64 {
    crate::appearance::splitmix64(master ^ tag.wrapping_mul(0x9E37_79B9)) >> 1
}

impl SimConfig {
    /// The config of a preset, with the default master seed 0.
    pub fn preset(preset: Preset) -> Self {
        let base = SimConfig {
            name: format!("endoloc-sim-{}", preset.name()),
            seed: 0,
            depth: false,
            colon: ColonSource::Procedural(ProceduralColonConfig::default()),
            camera: CameraConfig {
                width: 640,
                height: 480,
                hfov_deg: 90.0,
                distortion: Distortion::None,
            },
            appearance: AppearanceConfig::default(),
            render: RenderConfig::default(),
            train: TrajectoryConfig::default(),
            test: TrajectoryConfig::default(),
            changes: ChangeConfig::default(),
        };
        // The paper's passes: 2610 training and 2603 test frames.
        let paper_passes = SimConfig {
            train: TrajectoryConfig {
                frames: 2610,
                ..TrajectoryConfig::default()
            },
            test: TrajectoryConfig {
                frames: 2603,
                ..TrajectoryConfig::default()
            },
            ..base.clone()
        };
        let cfg = match preset {
            Preset::Paper => paper_passes,
            Preset::Small => SimConfig {
                depth: true,
                camera: CameraConfig {
                    width: 320,
                    height: 240,
                    hfov_deg: 90.0,
                    distortion: Distortion::None,
                },
                train: TrajectoryConfig {
                    frames: 300,
                    ..TrajectoryConfig::default()
                },
                test: TrajectoryConfig {
                    frames: 300,
                    ..TrajectoryConfig::default()
                },
                ..base
            },
            Preset::C3vdLike => SimConfig {
                camera: CameraConfig {
                    width: 640,
                    height: 512,
                    hfov_deg: 120.0,
                    distortion: Distortion::Fisheye {
                        k1: -0.03,
                        k2: 0.004,
                        k3: 0.0,
                        k4: 0.0,
                    },
                },
                render: RenderConfig {
                    field_stop: 0.8,
                    specular: 1.2,
                    exposure_jitter: 0.15,
                    motion_blur_samples: 3,
                    ..RenderConfig::default()
                },
                ..paper_passes
            },
        };
        cfg.with_seed(0)
    }

    /// Sets the master seed and derives from it the seeds of the colon shape, the texture and
    /// both passes (train and test always differ).
    pub fn with_seed(mut self, seed: u64) -> Self {
        let derive = |tag: u64| derived_seed(seed, tag);
        self.seed = seed;
        if let ColonSource::Procedural(p) = &mut self.colon {
            p.seed = derive(1);
        }
        self.appearance.seed = derive(2);
        self.train.seed = derive(3);
        self.test.seed = derive(4);
        self.changes.seed = derive(CHANGES_SEED_TAG);
        self
    }

    /// Changes the colon between the passes as a severity preset does (the change's seed
    /// kept).
    pub fn with_changes(mut self, severity: crate::change::Severity) -> Self {
        let seed = self.changes.seed;
        self.changes = ChangeConfig {
            seed,
            ..ChangeConfig::preset(severity)
        };
        self
    }

    /// Uses a mesh colon instead of the procedural one.
    pub fn with_mesh_colon(mut self, mesh: MeshColonConfig) -> Self {
        self.colon = ColonSource::Mesh(mesh);
        self
    }

    /// Checks every part of the config.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] naming the first problem.
    pub fn validate(&self) -> Result<(), SimError> {
        if self.seed > i64::MAX as u64 {
            return Err(SimError::InvalidConfig(format!(
                "seed must be below 2^63 (stored in TOML), got {}",
                self.seed
            )));
        }
        self.camera.camera()?;
        self.render.validate()?;
        self.train.validate()?;
        self.test.validate()?;
        self.changes.validate()?;
        if let ColonSource::Mesh(m) = &self.colon {
            for (what, p) in [("surface", &m.surface), ("path", &m.path)] {
                if !p.is_file() {
                    return Err(SimError::InvalidConfig(format!(
                        "mesh colon: {what} file {} does not exist",
                        p.display()
                    )));
                }
            }
        }
        Ok(())
    }

    /// The config as TOML.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] if serialisation fails (never for a valid config).
    pub fn to_toml(&self) -> Result<String, SimError> {
        toml::to_string_pretty(self).map_err(|e| SimError::InvalidConfig(e.to_string()))
    }

    /// Parses a config from TOML: either a bare simulation config, or a `dataset.toml` whose
    /// `[simulation]` table holds one.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] naming the file and the TOML error (with line and column).
    pub fn from_toml_file(path: &std::path::Path) -> Result<Self, SimError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| SimError::InvalidConfig(format!("{}: {e}", path.display())))?;
        let value: toml::Table = toml::from_str(&text)
            .map_err(|e| SimError::InvalidConfig(format!("{}: {e}", path.display())))?;
        let table = match value.get("simulation") {
            Some(toml::Value::Table(t)) => t.clone(),
            _ => value,
        };
        let has_changes = table.contains_key("changes");
        let mut cfg: SimConfig = table.try_into().map_err(|e: toml::de::Error| {
            SimError::InvalidConfig(format!("{}: {e}", path.display()))
        })?;
        if !has_changes {
            // An unchanged colon stores no change; its seed derives from the master seed.
            cfg.changes.seed = derived_seed(cfg.seed, CHANGES_SEED_TAG);
        }
        Ok(cfg)
    }

    /// Files this config reads (mesh colon inputs), for provenance.
    pub fn input_files(&self) -> Vec<PathBuf> {
        match &self.colon {
            ColonSource::Procedural(_) => Vec::new(),
            ColonSource::Mesh(m) => {
                let mut v = vec![m.surface.clone(), m.path.clone()];
                v.extend(m.landmarks.clone());
                v
            }
        }
    }
}
