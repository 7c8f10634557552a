//! `SimulateJob`: a colonoscopy dataset rendered with exact poses.

use std::fmt;
use std::path::PathBuf;

use endoloc_sim::colon::from_mesh::MeshColonConfig;
use endoloc_sim::{ColonSource, Preset, Severity, SimConfig, SimSummary};
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::error::{Context, Result};
use crate::progress::Progress;

/// Renders a colonoscopy dataset (train and test passes through one colon) with exact 6-DoF
/// poses (`T_wc`, mm) into `out`, in endoloc's dataset format v1. The colon is the built-in
/// procedural one, a GCA model folder (`gca`) or a surface mesh with its mid-line
/// (`mesh` + `path`). `Option` fields override the preset (or `config` file) when set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct SimulateJob {
    /// Starting configuration: `small` (300 + 300 frames, 320×240, depth maps), `paper`
    /// (2610 + 2603 frames, 640×480, as in the paper) or `c3vd-like` (the paper's passes
    /// through real-endoscope optics: 640×512 fisheye of 120°, circular field stop with its
    /// mask, saturating highlights, exposure changes, motion blur).
    #[cfg_attr(
        feature = "cli",
        arg(long, default_value_t = SimulateJob::default().preset,
            value_parser = clap::builder::TypedValueParser::map(
                clap::builder::PossibleValuesParser::new(Preset::ALL.map(|p| p.name())),
                |s| s.parse::<Preset>().expect("a listed preset")))
    )]
    pub preset: Preset,
    /// Full configuration from a TOML file instead of the preset (as printed by
    /// [`SimulateJob::sim_config`] + `to_toml`, or a dataset's dataset.toml to regenerate
    /// that dataset). The other options override it.
    #[cfg_attr(feature = "cli", arg(long, conflicts_with = "preset"))]
    pub config: Option<PathBuf>,
    /// Master seed: derives the colon shape, texture and both passes. Same seed, same
    /// dataset. Default: the preset's, or the `config` file's (a seed equal to the file's
    /// keeps the file's derived seeds).
    #[cfg_attr(feature = "cli", arg(long))]
    pub seed: Option<u64>,
    /// Use a GCA model folder (surface .vtk, mid-line .jsn, landmarks .json) as the colon,
    /// e.g. data/gca-edin-00090.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "DIR", conflicts_with_all = ["mesh", "path"])
    )]
    pub gca: Option<PathBuf>,
    /// Colon surface mesh (VTK legacy ASCII, OBJ, PLY or STL, mm). Needs `path`.
    #[cfg_attr(feature = "cli", arg(long, requires = "path"))]
    pub mesh: Option<PathBuf>,
    /// Mid-line path of the mesh colon, anus → caecum (GCA .jsn, or CSV of x,y,z in mm).
    #[cfg_attr(feature = "cli", arg(long, requires = "mesh"))]
    pub path: Option<PathBuf>,
    /// Landmarks labelling the mid-line with anatomical sections (GCA model JSON).
    #[cfg_attr(feature = "cli", arg(long, requires = "mesh"))]
    pub landmarks: Option<PathBuf>,
    /// Grow a mesh colon's lumen radially about its mid-line (CT scans are not insufflated);
    /// 1.0, the default, keeps the scanned wall. Where loops are packed, grown walls flatten
    /// against each other.
    #[cfg_attr(feature = "cli", arg(long))]
    pub inflation: Option<f64>,
    /// Frames in the training pass.
    #[cfg_attr(feature = "cli", arg(long))]
    pub train_frames: Option<usize>,
    /// Frames in the test pass.
    #[cfg_attr(feature = "cli", arg(long))]
    pub test_frames: Option<usize>,
    /// Frame rate of both passes, frames per second (default: the preset's, 30). A pass
    /// lasts frames / fps seconds and covers the whole colon whatever the frame count: half
    /// the frames at half the rate is the same pass sampled every second frame.
    #[cfg_attr(feature = "cli", arg(long))]
    pub fps: Option<f64>,
    /// Image width, pixels.
    #[cfg_attr(feature = "cli", arg(long))]
    pub width: Option<u32>,
    /// Image height, pixels.
    #[cfg_attr(feature = "cli", arg(long))]
    pub height: Option<u32>,
    /// Horizontal field of view of the pinhole camera, degrees.
    #[cfg_attr(feature = "cli", arg(long))]
    pub hfov: Option<f64>,
    /// Write 16-bit depth maps (mm × 100) next to the images (default: the preset's;
    /// `no_depth` turns them off).
    #[cfg_attr(
        feature = "cli",
        arg(long = "no-depth", num_args = 0, default_missing_value = "false")
    )]
    pub depth: Option<bool>,
    /// Sensor noise standard deviation, 8-bit grey levels (0 = none).
    #[cfg_attr(feature = "cli", arg(long))]
    pub noise: Option<f64>,
    /// Sub-frames averaged per frame for motion blur (1 = none).
    #[cfg_attr(feature = "cli", arg(long))]
    pub motion_blur: Option<usize>,
    /// Circular field stop: its radius as a fraction of the half image diagonal (0 = none;
    /// 0.9 blacks out the corners, as on real endoscopes). The dataset gets the renderer's
    /// mask (mask.png).
    #[cfg_attr(feature = "cli", arg(long))]
    pub field_stop: Option<f64>,
    /// Black columns on the left and the right of every frame, pixels (0 = none).
    #[cfg_attr(feature = "cli", arg(long))]
    pub black_border: Option<u32>,
    /// Smallest distance kept between the lens and the colon wall, mm.
    #[cfg_attr(feature = "cli", arg(long))]
    pub clearance: Option<f64>,
    /// How the colon changes between the training and the test pass: `none` (both passes
    /// through the same colon, as before), `mild`, `moderate` or `severe` — mobile segments
    /// shifted, the lumen insufflated or collapsed, local deformation, another light and
    /// exposure, residue, fluid and bubbles, a blurred test scope. The test pass's poses.txt
    /// holds the anatomical poses (in the colon as mapped), poses_changed.txt the poses it was
    /// rendered from. Each factor can be set alone in the `[simulation.changes]` table of a
    /// `config` file (`endoloc simulate --changes moderate --print-config` prints one);
    /// docs/SIMULATOR.md lists what each level means.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "SEVERITY", value_parser = crate::severity_parser())
    )]
    pub changes: Option<Severity>,
    /// Output dataset folder (created; must not exist unless `force`).
    #[cfg_attr(
        feature = "cli",
        arg(short, long, value_parser = crate::path_or_empty(), default_value_os_t = SimulateJob::default().out, hide_default_value = true)
    )]
    pub out: PathBuf,
    /// Replace an existing output folder.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for SimulateJob {
    fn default() -> Self {
        SimulateJob {
            preset: Preset::Small,
            config: None,
            seed: None,
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
            changes: None,
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
            None => SimConfig::preset(self.preset),
        };
        if let Some(seed) = self.seed
            && (self.config.is_none() || cfg.seed != seed)
        {
            cfg = cfg.with_seed(seed);
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
                    bail!("`inflation` applies to a mesh colon (`gca` or `mesh`)")
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
        if let Some(severity) = self.changes {
            cfg = cfg.with_changes(severity);
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
        self.run_config(&self.sim_config()?, progress)
    }

    /// Renders the dataset of `cfg`, a configuration of this job's (see
    /// [`SimulateJob::sim_config`]) that the caller changed further, into `out`.
    ///
    /// # Errors
    /// No `out`, an existing `out` without `force`, settings that do not validate, or a
    /// failed render or write.
    pub fn run_config(&self, cfg: &SimConfig, progress: &dyn Progress) -> Result<SimulateReport> {
        cfg.validate()?;
        if self.out.as_os_str().is_empty() {
            bail!("`out` is required");
        }
        let on_event = |event: endoloc_sim::Progress<'_>| match event {
            endoloc_sim::Progress::Stage(stage) => progress.note(&format!("preparing {stage}…")),
            endoloc_sim::Progress::Note(note) => progress.note(note),
            endoloc_sim::Progress::SequenceStarted { name, frames } => {
                progress.start(name, frames as u64)
            }
            endoloc_sim::Progress::FrameDone => progress.inc(1),
        };
        let summary = endoloc_sim::simulate(cfg, &self.out, self.force, &on_event)
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
        // The dataset's mid-line is found beside the ground truth.
        let midline = report.metrics.midline.as_deref().unwrap_or_default();
        assert!(midline.contains("midline.txt"), "{midline}");
        assert!(report.metrics.along_colon_mm.unwrap().max < 1e-9);
        assert!(tmp.path().join("eval/metrics.json").is_file());
    }
}
