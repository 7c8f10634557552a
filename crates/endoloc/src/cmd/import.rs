//! `endoloc import`: convert C3VD, SimCol3D and EndoSLAM recordings into an endoloc dataset.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::{ImportFormat, ImportJob, Progress};

/// Import a public colonoscopy dataset as an endoloc dataset (format v1: mm, T_wc
/// camera-to-world, OpenCV camera axes, TUM poses.txt, PNG images, 16-bit depth PNG).
///
/// One recording becomes one sequence (default `train`); cut it into train/test with
/// --split, or add a second recording of the same colon as `test` with --test.
/// An existing output folder is never replaced unless --force.
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
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(subcommand)]
    format: Format,
}

#[derive(Debug, clap::Subcommand)]
enum Format {
    /// C3VD recording folder: pose.txt (16 values per line, column-major T_wc in mm),
    /// {n}_color.png, optional {NNNN}_depth.tiff (mm = v / 65535 × 100). Camera: the common
    /// pinhole + OpenCV-fisheye fit of C3VD's omnidirectional model (1350×1080) unless --camera.
    C3vd {
        /// The recording folder (holding pose.txt).
        src: PathBuf,
        /// Resample images (bilinear) and depth (nearest) through the fisheye model into a
        /// pinhole with the same size, fx, fy, cx, cy; the dataset's camera is that pinhole.
        #[arg(long)]
        undistort: bool,
        /// Do not import the depth maps.
        #[arg(long)]
        no_depth: bool,
        /// Camera override: W,H,FX,FY,CX,CY (pinhole) or W,H,FX,FY,CX,CY,K1,K2,K3,K4 (OpenCV
        /// fisheye).
        #[arg(long, value_name = "W,H,FX,FY,CX,CY[,K1..K4]")]
        camera: Option<String>,
        #[command(flatten)]
        common: Common,
    },
    /// SimCol3D colon folder (SavedPosition_S*.txt in cm, SavedRotationQuaternion_S*.txt,
    /// Frames_S*/FrameBuffer_NNNN.png, optional Frames_S*/Depth_NNNN.png) or one Frames_S*
    /// folder. Unity's left-handed y-up poses are converted with R = S·R·S, t = 10·S·t,
    /// S = diag(1,-1,1). Depth (16-bit, z-depth) is imported when every frame has a
    /// Depth_NNNN.png, with the organisers' scale mm = v / (255 × 256) × 200 (65280 = 20 cm).
    /// Camera: 475×475, fx = fy = 227.60416, cx = cy = 237.5 unless --camera (cam.txt is
    /// ambiguous).
    Simcol3d {
        /// The colon folder, or a Frames_S* folder.
        src: PathBuf,
        /// Trajectory suffix when the folder holds several (S1 for SavedPosition_S1.txt).
        #[arg(long)]
        sequence: Option<String>,
        /// Do not import the Depth_NNNN.png maps.
        #[arg(long)]
        no_depth: bool,
        /// Camera override: W,H,FX,FY,CX,CY.
        #[arg(long, value_name = "W,H,FX,FY,CX,CY")]
        camera: Option<String>,
        #[command(flatten)]
        common: Common,
    },
    /// EndoSLAM recording: UnityCam (Poses/*.csv `tX,tY,tZ,rX,rY,rZ,rW,time(s)`, paired with
    /// Frames/ by row, Unity axes converted) or ex-vivo (an .xlsx pose workbook, or a CSV
    /// export of its sheet, with columns `ImageFrame,Pose_Index,trans_x..z,quot_x..w`, joined
    /// to the frames on ImageFrame; the sheet is --sheet, else the first whose header has
    /// ImageFrame). The length unit and the camera are not documented: give both.
    Endoslam {
        /// The recording folder (holding Frames/ and Poses/).
        src: PathBuf,
        /// Length unit of the pose file.
        #[arg(long, value_enum)]
        units: UnitsArg,
        /// Camera: W,H,FX,FY,CX,CY. EndoSLAM ships its calibrations only as MATLAB
        /// cameraParameters objects (Calibration/Camera/*/*_cameraParams_pinhole.mat), which
        /// only MATLAB decodes: read ImageSize, FocalLength and PrincipalPoint there.
        #[arg(long, value_name = "W,H,FX,FY,CX,CY")]
        camera: String,
        /// Pose file, .csv or .xlsx (default: the only .csv or .xlsx in SRC/Poses, else in SRC).
        #[arg(long)]
        poses: Option<PathBuf>,
        /// Worksheet of an .xlsx pose file (default: the first sheet whose header row has an
        /// ImageFrame column, else the first sheet).
        #[arg(long)]
        sheet: Option<String>,
        /// Frames folder (default: SRC/Frames, else SRC).
        #[arg(long)]
        frames: Option<PathBuf>,
        #[command(flatten)]
        common: Common,
    },
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum UnitsArg {
    Mm,
    Cm,
    M,
}

#[derive(Debug, clap::Args)]
struct Common {
    /// Output dataset folder.
    #[arg(short, long)]
    out: PathBuf,
    /// Replace an existing dataset at --out.
    #[arg(long)]
    force: bool,
    /// Dataset name in dataset.toml (default: the output folder's name).
    #[arg(long)]
    name: Option<String>,
    /// Cut the recording into sequences by 0-based, end-exclusive frame ranges, e.g.
    /// `train:0..1500,test:1500..` (ranges must not overlap).
    #[arg(long, value_name = "NAME:START..END,…", conflicts_with = "test")]
    split: Option<String>,
    /// A second recording of the same colon (same format and options), written as `test`;
    /// SRC is then written as `train`.
    #[arg(long, value_name = "SRC2")]
    test: Option<PathBuf>,
    /// Sequence name for SRC when neither --split nor --test is given.
    #[arg(long, default_value_t = ImportJob::default().seq)]
    seq: String,
    /// Frame rate for the time stamps (frame i at i / fps s) where the source has none.
    #[arg(long, default_value_t = ImportJob::default().fps)]
    fps: f64,
}

impl From<Args> for ImportJob {
    fn from(a: Args) -> Self {
        let base = ImportJob {
            command: Some(std::env::args().collect::<Vec<_>>().join(" ")),
            ..ImportJob::default()
        };
        let (job, common) = match a.format {
            Format::C3vd {
                src,
                undistort,
                no_depth,
                camera,
                common,
            } => (
                ImportJob {
                    format: ImportFormat::C3vd,
                    src,
                    undistort,
                    depth: !no_depth,
                    camera,
                    ..base
                },
                common,
            ),
            Format::Simcol3d {
                src,
                sequence,
                no_depth,
                camera,
                common,
            } => (
                ImportJob {
                    format: ImportFormat::Simcol3d,
                    src,
                    sequence,
                    depth: !no_depth,
                    camera,
                    ..base
                },
                common,
            ),
            Format::Endoslam {
                src,
                units,
                camera,
                poses,
                sheet,
                frames,
                common,
            } => (
                ImportJob {
                    format: ImportFormat::Endoslam,
                    src,
                    units: Some(format!("{units:?}").to_lowercase()),
                    camera: Some(camera),
                    poses,
                    sheet,
                    frames,
                    ..base
                },
                common,
            ),
        };
        ImportJob {
            out: common.out,
            force: common.force,
            name: common.name,
            split: common.split,
            test: common.test,
            seq: common.seq,
            fps: common.fps,
            ..job
        }
    }
}

/// Runs `endoloc import …`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&ImportJob::from(args).run(ui)?)?;
    Ok(())
}
