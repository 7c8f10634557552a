//! `endoloc simulate`: render a colonoscopy dataset with exact poses.

use std::path::PathBuf;
use std::sync::Mutex;

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use endoloc_sim::colon::from_mesh::MeshColonConfig;
use endoloc_sim::{Preset, Progress, SimConfig};
use indicatif::ProgressBar;

use crate::ui;

/// Render a colonoscopy dataset (train and test passes through one colon) with exact 6-DoF
/// poses, in endoloc's dataset format v1.
///
/// The colon is the built-in procedural large intestine (no files needed) or a surface mesh
/// with its mid-line, e.g. a CT colon. Poses are camera-to-world, in mm (TUM files).
///
/// Examples:
///
///   endoloc simulate --preset small --out data/small
///
///   endoloc simulate --preset paper --seed 3 --out data/paper
///
///   endoloc simulate --preset small --gca ../shared/data/gca-edin-00090 --out data/ct
///   (Edinburgh Gut Cell Atlas model EdinGCA_3D_00090, CC BY 4.0: attribute it)
///
///   endoloc simulate --preset paper --print-config > sim.toml   # edit, then:
///   endoloc simulate --config sim.toml --out data/custom
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Output dataset folder (created; must not exist unless --force).
    #[arg(short, long, required_unless_present = "print_config")]
    out: Option<PathBuf>,

    /// Starting configuration: `small` (300 + 300 frames, 320×240, depth maps) or `paper`
    /// (2610 + 2603 frames, 640×480, as in the paper).
    #[arg(long, value_enum, default_value = "small")]
    preset: PresetArg,

    /// Full configuration from a TOML file (as printed by --print-config, or a dataset's
    /// dataset.toml to regenerate that dataset). Options given on the command line override it.
    #[arg(long, conflicts_with = "preset")]
    config: Option<PathBuf>,

    /// Master seed: derives the colon shape, texture and both passes. Same seed, same dataset.
    #[arg(long)]
    seed: Option<u64>,

    /// Use a GCA model folder (surface .vtk, mid-line .jsn, landmarks .json) as the colon,
    /// e.g. ../shared/data/gca-edin-00090.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["mesh", "path"])]
    gca: Option<PathBuf>,

    /// Colon surface mesh (VTK legacy ASCII, OBJ, PLY or STL, mm). Needs --path.
    #[arg(long, requires = "path")]
    mesh: Option<PathBuf>,

    /// Mid-line path of the mesh colon, anus → caecum (GCA .jsn, or CSV of x,y,z in mm).
    #[arg(long, requires = "mesh")]
    path: Option<PathBuf>,

    /// Landmarks labelling the mid-line with anatomical sections (GCA model JSON).
    #[arg(long, requires = "mesh")]
    landmarks: Option<PathBuf>,

    /// Grow a mesh colon's lumen radially about its mid-line (CT scans are not insufflated);
    /// 1.0, the default, keeps the scanned wall. Where loops are packed, grown walls flatten
    /// against each other.
    #[arg(long)]
    inflation: Option<f64>,

    /// Frames in the training pass.
    #[arg(long)]
    train_frames: Option<usize>,

    /// Frames in the test pass.
    #[arg(long)]
    test_frames: Option<usize>,

    /// Frame rate of both passes, frames per second (default: the preset's, 30). A pass
    /// lasts frames / fps seconds and covers the whole colon whatever the frame count: half
    /// the frames at half the rate is the same pass sampled every second frame.
    #[arg(long)]
    fps: Option<f64>,

    /// Image width, pixels.
    #[arg(long)]
    width: Option<u32>,

    /// Image height, pixels.
    #[arg(long)]
    height: Option<u32>,

    /// Horizontal field of view of the pinhole camera, degrees.
    #[arg(long)]
    hfov: Option<f64>,

    /// Write 16-bit depth maps (mm × 100) next to the images.
    #[arg(long, overrides_with = "no_depth")]
    depth: bool,

    /// Do not write depth maps.
    #[arg(long)]
    no_depth: bool,

    /// Sensor noise standard deviation, 8-bit grey levels (0 = none).
    #[arg(long)]
    noise: Option<f64>,

    /// Sub-frames averaged per frame for motion blur (1 = none).
    #[arg(long)]
    motion_blur: Option<usize>,

    /// Smallest distance kept between the lens and the colon wall, mm.
    #[arg(long)]
    clearance: Option<f64>,

    /// Print the resolved configuration as TOML and exit without rendering.
    #[arg(long)]
    print_config: bool,

    /// Replace an existing output folder.
    #[arg(long)]
    force: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum PresetArg {
    Small,
    Paper,
}

impl Args {
    /// Raw arguments → a validated simulation config.
    fn resolve(&self) -> Result<SimConfig> {
        let mut cfg = match &self.config {
            Some(file) => SimConfig::from_toml_file(file)?,
            None => SimConfig::preset(match self.preset {
                PresetArg::Small => Preset::Small,
                PresetArg::Paper => Preset::Paper,
            }),
        };
        if let Some(seed) = self.seed {
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
                endoloc_sim::ColonSource::Mesh(m) => m.inflation = f,
                endoloc_sim::ColonSource::Procedural(_) => {
                    bail!("--inflation applies to a mesh colon (--gca or --mesh/--path)")
                }
            }
        }
        if let Some(n) = self.train_frames {
            cfg.train.frames = n;
        }
        if let Some(n) = self.test_frames {
            cfg.test.frames = n;
        }
        if let Some(f) = self.fps {
            cfg.train.fps = f;
            cfg.test.fps = f;
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
        if self.depth {
            cfg.depth = true;
        }
        if self.no_depth {
            cfg.depth = false;
        }
        if let Some(n) = self.noise {
            cfg.render.noise_sigma = n;
        }
        if let Some(n) = self.motion_blur {
            cfg.render.motion_blur_samples = n;
        }
        if let Some(c) = self.clearance {
            cfg.train.clearance_mm = c;
            cfg.test.clearance_mm = c;
        }
        cfg.validate()?;
        Ok(cfg)
    }
}

/// Runs `endoloc simulate`.
pub fn run(args: Args) -> Result<()> {
    let cfg = args.resolve()?;
    if args.print_config {
        print!("{}", cfg.to_toml()?);
        return Ok(());
    }
    let Some(out) = args.out.as_ref() else {
        bail!("--out is required");
    };
    let bar: Mutex<Option<ProgressBar>> = Mutex::new(None);
    let progress = |event: Progress<'_>| {
        let mut guard = bar.lock().unwrap_or_else(|e| e.into_inner());
        match event {
            Progress::Stage(stage) => eprintln!("preparing {stage}…"),
            Progress::SequenceStarted { name, frames } => {
                if let Some(old) = guard.take() {
                    old.finish();
                }
                *guard = Some(ui::progress_bar(frames as u64, name));
            }
            Progress::FrameDone => {
                if let Some(b) = guard.as_ref() {
                    b.inc(1);
                }
            }
        }
    };
    let summary = endoloc_sim::simulate(&cfg, out, args.force, &progress)
        .with_context(|| format!("simulating into {}", out.display()))?;
    if let Some(b) = bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
        b.finish();
    }
    println!("dataset   {}", summary.dataset.display());
    println!("colon     {}", summary.colon);
    for (name, frames) in &summary.sequences {
        println!("sequence  {name}: {frames} frames");
    }
    println!(
        "camera    {}x{}, hfov {:.1}°, depth maps {}",
        cfg.camera.width,
        cfg.camera.height,
        cfg.camera.hfov_deg,
        if cfg.depth { "yes" } else { "no" }
    );
    println!(
        "clearance min {:.2} mm from the wall",
        summary.min_clearance_mm
    );
    println!(
        "time      {:.1} s ({:.1} frames/s rendering + PNG, {} threads)",
        summary.total_seconds,
        summary.frames_per_second(),
        rayon::current_num_threads()
    );
    Ok(())
}
