//! `endoloc import`: convert C3VD, SimCol3D and EndoSLAM recordings, or a video with a tracker
//! log, into an endoloc dataset.

use anyhow::Result;
use endoloc_jobs::{ImportJob, Progress};

/// Import a public colonoscopy dataset (FORMAT c3vd, simcol3d or endoslam), or a video file
/// with its tracker's pose log (FORMAT video; see below), as an endoloc dataset (format v1:
/// mm, T_wc camera-to-world, OpenCV camera axes, TUM poses.txt, PNG images, 16-bit depth PNG).
///
/// One recording becomes one sequence (default `train`); cut it into train/test with
/// --split, or add a second recording of the same colon as `test` with --test. One recording
/// imported into an existing dataset is added beside its sequences as --seq (its frames the
/// size of the dataset's camera). Nothing is replaced unless --force: the whole folder, or
/// when adding, the sequence of that name only.
///
/// Examples:
///
///   endoloc import c3vd C3VD/cecum_t1_a --out data/c3vd_cecum --split train:0..600,test:600..
///
///   endoloc import c3vd C3VD/cecum_t1_a --out data/c3vd_pinhole --undistort
///
///   endoloc import simcol3d SyntheticColon_I --sequence S1 --test SyntheticColon_I/Frames_S2 \
///       --out data/simcol_I
///
///   endoloc import endoslam UnityCam/Colon --units m --camera 320,320,156.0,156.0,160.0,160.0 \
///       --out data/endoslam_colon
///
///   endoloc import endoslam ExVivo/Colon-IV --poses ExVivo/Colon-IV/Poses/poses.xlsx \
///       --sheet Sheet1 --units mm --camera W,H,FX,FY,CX,CY --out data/endoslam_colon_iv
///
///   endoloc import video pass1.mp4 --poses em1.csv --test pass2.mp4 --test-poses em2.csv \
///       --camera 1280,1024,700,700,639.5,511.5 --time-offset auto \
///       --sensor-to-camera hand_eye.txt --out data/mine
///
///   endoloc import video pass3.mp4 --camera 1280,1024,700,700,639.5,511.5 \
///       --out data/mine --seq today     # no log: frames.txt, localized but not evaluated
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: ImportJob,
}

/// Runs `endoloc import`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let job = ImportJob {
        command: Some(std::env::args().collect::<Vec<_>>().join(" ")),
        ..args.job
    };
    crate::ui::print(&job.run(ui)?)?;
    Ok(())
}
