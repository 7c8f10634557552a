//! `SimulateJob`: a colonoscopy dataset rendered with exact poses.

use std::fmt;
use std::path::PathBuf;

use endoloc_sim::colon::from_mesh::MeshColonConfig;
use endoloc_sim::{ColonSource, Preset, SimConfig, SimSummary};
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::error::{Context, Result};
use crate::progress::Progress;

/// Renders a colonoscopy dataset (train and test passes through one colon) with exact 6-DoF
/// poses (`T_wc`, mm) into `out`, in endoloc's dataset format v1. The colon is the built-in
/// procedural one, a GCA model folder (`gca`) or a surface mesh with its mid-line
/// (`mesh` + `path`). `Option` fields override the preset (or `config` file) when set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimulateJob {
    /// Starting configuration: `small` or `paper`.
    pub preset: String,
    /// Full configuration from a TOML file instead of the preset (as printed by
    /// [`SimulateJob::sim_config`] + `to_toml`, or a dataset's `dataset.toml`).
    pub config: Option<PathBuf>,
    /// Master seed: derives the colon shape, texture and both passes. With `config`, a seed
    /// equal to the file's keeps the file's derived seeds.
    pub seed: u64,
    /// GCA model folder (surface `.vtk`, mid-line `.jsn`, landmarks `.json`) as the colon.
    pub gca: Option<PathBuf>,
    /// Colon surface mesh (VTK legacy ASCII, OBJ, PLY or STL, mm); needs `path`.
    pub mesh: Option<PathBuf>,
    /// Mid-line of the mesh colon, anus → caecum (GCA `.jsn`, or CSV of x,y,z in mm).
    pub path: Option<PathBuf>,
    /// Landmarks labelling the mid-line with anatomical sections (GCA model JSON).
    pub landmarks: Option<PathBuf>,
    /// Radial growth factor of a mesh colon's lumen (1.0 keeps the scanned wall).
    pub inflation: Option<f64>,
    /// Frames in the training pass.
    pub train_frames: Option<usize>,
    /// Frames in the test pass.
    pub test_frames: Option<usize>,
    /// Frame rate of both passes, frames per second.
    pub fps: Option<f64>,
    /// Image width, pixels.
    pub width: Option<u32>,
    /// Image height, pixels.
    pub height: Option<u32>,
    /// Horizontal field of view, degrees.
    pub hfov: Option<f64>,
    /// Write 16-bit depth maps (mm × 100) next to the images.
    pub depth: Option<bool>,
    /// Sensor noise standard deviation, 8-bit grey levels.
    pub noise: Option<f64>,
    /// Sub-frames averaged per frame for motion blur (1 = none).
    pub motion_blur: Option<usize>,
    /// Radius of a circular field stop, fraction of the half image diagonal (0 = none); the
    /// dataset then gets the renderer's mask.
    pub field_stop: Option<f64>,
    /// Black columns on the left and right of every frame, pixels.
    pub black_border: Option<u32>,
    /// Smallest distance kept between the lens and the colon wall, mm.
    pub clearance: Option<f64>,
    /// Output dataset folder.
    pub out: PathBuf,
    /// Replace an existing output folder.
    pub force: bool,
}

impl Default for SimulateJob {
    fn default() -> Self {
        SimulateJob {
            preset: Preset::Small.name().into(),
            config: None,
            seed: SimConfig::preset(Preset::Small).seed,
            gca: None,
            mesh: None,
            path: None,
            landmarks: None,
            inflation: None,
            train_frames: None,
            test_frames: None,
            fps: None,
            width: None,
            height: None,
            hfov: None,
            depth: None,
            noise: None,
            motion_blur: None,
            field_stop: None,
            black_border: None,
            clearance: None,
            out: PathBuf::new(),
            force: false,
        }
    }
}

/// What `SimulateJob` rendered.
#[derive(Debug, Clone)]
pub struct SimulateReport {
    /// The simulator's summary (folder, colon, sequences, clearance, time).
    pub summary: SimSummary,
    /// Image width and height, pixels.
    pub size: (u32, u32),
    /// Horizontal field of view, degrees.
    pub hfov_deg: f64,
    /// Whether depth maps were written.
    pub depth: bool,
    /// Worker threads used.
    pub threads: usize,
}

impl SimulateJob {
    /// The validated simulation configuration of this job.
    ///
    /// # Errors
    /// An unknown preset, an unreadable `config` or GCA folder, `inflation` without a mesh
    /// colon, or settings that do not validate.
    pub fn sim_config(&self) -> Result<SimConfig> {
        let mut cfg = match &self.config {
            Some(file) => SimConfig::from_toml_file(file)?,
            None => SimConfig::preset(self.preset.parse::<Preset>()?),
        };
        if self.config.is_none() || cfg.seed != self.seed {
            cfg = cfg.with_seed(self.seed);
        }
        if let Some(dir) = &self.gca {
            cfg = cfg.with_mesh_colon(
                MeshColonConfig::from_gca_folder(dir)
                    .with_context(|| format!("reading GCA model folder {}", dir.display()))?,
            );
        }
        if let (Some(mesh), Some(path)) = (&self.mesh, &self.path) {
            cfg = cfg.with_mesh_colon(MeshColonConfig::new(
                mesh.clone(),
                path.clone(),
                self.landmarks.clone(),
            ));
        }
        if let Some(f) = self.inflation {
            match &mut cfg.colon {
                ColonSource::Mesh(m) => m.inflation = f,
                ColonSource::Procedural(_) => {
                    bail!("--inflation applies to a mesh colon (--gca or --mesh/--path)")
                }
            }
        }
        let (train, test) = (&mut cfg.train, &mut cfg.test);
        if let Some(n) = self.train_frames {
            train.frames = n;
        }
        if let Some(n) = self.test_frames {
            test.frames = n;
        }
        if let Some(f) = self.fps {
            (train.fps, test.fps) = (f, f);
        }
        if let Some(c) = self.clearance {
            (train.clearance_mm, test.clearance_mm) = (c, c);
        }
        if let Some(w) = self.width {
            cfg.camera.width = w;
        }
        if let Some(h) = self.height {
            cfg.camera.height = h;
        }
        if let Some(f) = self.hfov {
            cfg.camera.hfov_deg = f;
        }
        if let Some(d) = self.depth {
            cfg.depth = d;
        }
        if let Some(n) = self.noise {
            cfg.render.noise_sigma = n;
        }
        if let Some(n) = self.motion_blur {
            cfg.render.motion_blur_samples = n;
        }
        if let Some(r) = self.field_stop {
            cfg.render.field_stop = r;
        }
        if let Some(b) = self.black_border {
            cfg.render.black_border_px = b;
        }
        cfg.validate()?;
        Ok(cfg)
    }

    /// Renders the dataset.
    ///
    /// # Errors
    /// A configuration error (see [`SimulateJob::sim_config`]), no `out`, an existing `out`
    /// without `force`, or a failed render or write.
    pub fn run(&self, progress: &dyn Progress) -> Result<SimulateReport> {
        let cfg = self.sim_config()?;
        if self.out.as_os_str().is_empty() {
            bail!("--out is required");
        }
        let on_event = |event: endoloc_sim::Progress<'_>| match event {
            endoloc_sim::Progress::Stage(stage) => progress.note(&format!("preparing {stage}…")),
            endoloc_sim::Progress::Note(note) => progress.note(note),
            endoloc_sim::Progress::SequenceStarted { name, frames } => {
                progress.start(name, frames as u64)
            }
            endoloc_sim::Progress::FrameDone => progress.inc(1),
        };
        let summary = endoloc_sim::simulate(&cfg, &self.out, self.force, &on_event)
            .with_context(|| format!("simulating into {}", self.out.display()));
        progress.finish();
        Ok(SimulateReport {
            summary: summary?,
            size: (cfg.camera.width, cfg.camera.height),
            hfov_deg: cfg.camera.hfov_deg,
            depth: cfg.depth,
            threads: rayon::current_num_threads(),
        })
    }
}

impl fmt::Display for SimulateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.summary;
        writeln!(f, "dataset   {}", s.dataset.display())?;
        writeln!(f, "colon     {}", s.colon)?;
        for note in &s.notes {
            writeln!(f, "note      {note}")?;
        }
        for (name, frames) in &s.sequences {
            writeln!(f, "sequence  {name}: {frames} frames")?;
        }
        writeln!(
            f,
            "camera    {}x{}, hfov {:.1}°, depth maps {}",
            self.size.0,
            self.size.1,
            self.hfov_deg,
            if self.depth { "yes" } else { "no" }
        )?;
        writeln!(
            f,
            "clearance min {:.2} mm from the wall",
            s.min_clearance_mm
        )?;
        write!(
            f,
            "time      {:.1} s ({:.1} frames/s rendering + PNG, {} threads)",
            s.total_seconds,
            s.frames_per_second(),
            self.threads
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_small_preset() {
        let from_toml: SimulateJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, SimulateJob::default());
        assert_eq!(
            SimulateJob::default().sim_config().unwrap(),
            SimConfig::preset(Preset::Small)
        );
    }

    #[test]
    fn a_tiny_colon_simulates_checks_and_evaluates() {
        let tmp = tempfile::tempdir().unwrap();
        let data = tmp.path().join("data");
        let job = SimulateJob {
            train_frames: Some(12),
            test_frames: Some(12),
            width: Some(64),
            height: Some(48),
            out: data.clone(),
            ..SimulateJob::default()
        };
        let report = job.run(&crate::Silent).unwrap();
        assert!(
            report.to_string().contains("sequence  test: 12 frames"),
            "{report}"
        );
        assert!(
            job.run(&crate::Silent).is_err(),
            "an existing dataset is kept"
        );
        let check = crate::DatasetJob {
            dir: data.clone(),
            ..crate::DatasetJob::default()
        };
        assert_eq!(check.run(&crate::Silent).unwrap().problems(), 0);
        let poses = data.join("test/poses.txt");
        let eval = crate::EvalJob {
            gt: poses.clone(),
            est: poses,
            out: tmp.path().join("eval"),
            no_plots: true,
            ..crate::EvalJob::default()
        };
        let report = eval.run(&crate::Silent).unwrap();
        assert_eq!(report.metrics.localized, 12);
        assert!(report.metrics.position_mm.max < 1e-9);
        assert!(tmp.path().join("eval/metrics.json").is_file());
    }
}
