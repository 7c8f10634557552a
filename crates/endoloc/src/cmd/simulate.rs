//! `endoloc simulate`: render a colonoscopy dataset with exact poses.

use anyhow::{Result, bail};
use endoloc_jobs::{Progress, SimulateJob};

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
    #[command(flatten)]
    job: SimulateJob,

    /// Write 16-bit depth maps (mm × 100) next to the images (the pair of --no-depth; the
    /// last of the two wins).
    #[arg(long = "depth", overrides_with = "depth")]
    depth_on: bool,

    /// Print the resolved configuration as TOML and exit without rendering.
    #[arg(long)]
    print_config: bool,
}

/// Runs `endoloc simulate`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let mut job = args.job;
    if args.depth_on {
        job.depth = Some(true);
    }
    if args.print_config {
        print!("{}", job.sim_config()?.to_toml()?);
        return Ok(());
    }
    if job.out.as_os_str().is_empty() {
        bail!("--out is required (the output dataset folder), unless --print-config");
    }
    crate::ui::print(&job.run(ui)?)?;
    Ok(())
}
