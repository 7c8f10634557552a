//! `endoloc simulate`: render a colonoscopy dataset with exact poses.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::{Progress, SimulateJob};
use endoloc_sim::SimConfig;

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
///   endoloc simulate --preset small --gca data/gca-edin-00090 --out data/ct
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

    /// Starting configuration: `small` (300 + 300 frames, 320×240, depth maps), `paper`
    /// (2610 + 2603 frames, 640×480, as in the paper) or `c3vd-like` (the paper's passes
    /// through real-endoscope optics: 640×512 fisheye of 120°, circular field stop with its
    /// mask, saturating highlights, exposure changes, motion blur).
    #[arg(long, default_value_t = SimulateJob::default().preset,
          value_parser = ["small", "paper", "c3vd-like"])]
    preset: String,

    /// Full configuration from a TOML file (as printed by --print-config, or a dataset's
    /// dataset.toml to regenerate that dataset). Options given on the command line override it.
    #[arg(long, conflicts_with = "preset")]
    config: Option<PathBuf>,

    /// Master seed: derives the colon shape, texture and both passes. Same seed, same dataset.
    #[arg(long)]
    seed: Option<u64>,

    /// Use a GCA model folder (surface .vtk, mid-line .jsn, landmarks .json) as the colon,
    /// e.g. data/gca-edin-00090.
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

    /// Circular field stop: its radius as a fraction of the half image diagonal (0 = none;
    /// 0.9 blacks out the corners, as on real endoscopes). The dataset gets the renderer's
    /// mask (mask.png).
    #[arg(long)]
    field_stop: Option<f64>,

    /// Black columns on the left and the right of every frame, pixels (0 = none).
    #[arg(long)]
    black_border: Option<u32>,

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

impl Args {
    /// The job; without --seed, a --config file keeps its own seed.
    fn job(self) -> Result<SimulateJob> {
        let seed = match (self.seed, &self.config) {
            (Some(seed), _) => seed,
            (None, Some(file)) => SimConfig::from_toml_file(file)?.seed,
            (None, None) => SimulateJob::default().seed,
        };
        let depth = match (self.depth, self.no_depth) {
            (_, true) => Some(false),
            (true, false) => Some(true),
            (false, false) => None,
        };
        Ok(SimulateJob {
            preset: self.preset,
            config: self.config,
            seed,
            gca: self.gca,
            mesh: self.mesh,
            path: self.path,
            landmarks: self.landmarks,
            inflation: self.inflation,
            train_frames: self.train_frames,
            test_frames: self.test_frames,
            fps: self.fps,
            width: self.width,
            height: self.height,
            hfov: self.hfov,
            depth,
            noise: self.noise,
            motion_blur: self.motion_blur,
            field_stop: self.field_stop,
            black_border: self.black_border,
            clearance: self.clearance,
            out: self.out.unwrap_or_default(),
            force: self.force,
        })
    }
}

/// Runs `endoloc simulate`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let print_config = args.print_config;
    let job = args.job()?;
    if print_config {
        print!("{}", job.sim_config()?.to_toml()?);
        return Ok(());
    }
    crate::ui::print(&job.run(ui)?)?;
    Ok(())
}
