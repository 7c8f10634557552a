//! `endoloc import`: convert C3VD, SimCol3D and EndoSLAM recordings into an endoloc dataset.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use endoloc_data::import::c3vd::{C3vdConfig, c3vd_camera, read_c3vd};
use endoloc_data::import::endoslam::{EndoSlamConfig, Units, read_endoslam};
use endoloc_data::import::simcol3d::{SimCol3dConfig, read_simcol3d, simcol3d_camera};
use endoloc_data::import::split::{parse_split, split_sequence};
use endoloc_data::import::{ImportedSequence, WriteImportConfig, write_import};
use endoloc_geometry::{Camera, Distortion};

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
        /// Camera: W,H,FX,FY,CX,CY.
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

#[derive(Debug, Clone, Copy, ValueEnum)]
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
    #[arg(long, default_value = "train")]
    seq: String,
    /// Frame rate for the time stamps (frame i at i / fps s) where the source has none.
    #[arg(long, default_value_t = 30.0)]
    fps: f64,
}

/// Parses `W,H,FX,FY,CX,CY` (and, when `allow_fisheye`, 4 more fisheye coefficients).
fn parse_camera(text: &str, allow_fisheye: bool) -> Result<Camera> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .with_context(|| format!("--camera: {s:?} is not a number"))
        })
        .collect::<Result<_>>()?;
    let distortion = match (v.len(), allow_fisheye) {
        (6, _) => Distortion::None,
        (10, true) => Distortion::Fisheye {
            k1: v[6],
            k2: v[7],
            k3: v[8],
            k4: v[9],
        },
        (n, true) => {
            bail!("--camera: {n} values; expected W,H,FX,FY,CX,CY or W,H,FX,FY,CX,CY,K1,K2,K3,K4")
        }
        (n, false) => bail!("--camera: {n} values; expected W,H,FX,FY,CX,CY"),
    };
    let size = |x: f64, what: &str| -> Result<u32> {
        if x.fract() != 0.0 || !(1.0..=100_000.0).contains(&x) {
            bail!("--camera: {what} = {x}; expected a positive whole number of pixels");
        }
        Ok(x as u32)
    };
    let cam = Camera {
        width: size(v[0], "W")?,
        height: size(v[1], "H")?,
        fx: v[2],
        fy: v[3],
        cx: v[4],
        cy: v[5],
        distortion,
    };
    cam.validate()
        .map_err(|e| anyhow::anyhow!("--camera: {e}"))?;
    Ok(cam)
}

/// Runs `endoloc import …`.
pub fn run(args: Args) -> Result<()> {
    let (format, src, common, undistort, read): (
        &str,
        PathBuf,
        Common,
        bool,
        Box<dyn Fn(&Path) -> Result<ImportedSequence, endoloc_data::DataError>>,
    ) = match args.format {
        Format::C3vd {
            src,
            undistort,
            no_depth,
            camera,
            common,
        } => {
            let cfg = C3vdConfig {
                camera: camera
                    .as_deref()
                    .map(|c| parse_camera(c, true))
                    .transpose()?
                    .unwrap_or_else(c3vd_camera),
                fps: common.fps,
                depth: !no_depth,
            };
            (
                "c3vd",
                src,
                common,
                undistort,
                Box::new(move |p| read_c3vd(p, &cfg)),
            )
        }
        Format::Simcol3d {
            src,
            sequence,
            no_depth,
            camera,
            common,
        } => {
            let cfg = SimCol3dConfig {
                camera: camera
                    .as_deref()
                    .map(|c| parse_camera(c, false))
                    .transpose()?
                    .unwrap_or_else(simcol3d_camera),
                fps: common.fps,
                sequence,
                depth: !no_depth,
            };
            // A --test recording is usually another Frames_S* folder: its suffix comes from
            // its own folder name, not from --sequence.
            let test_cfg = SimCol3dConfig {
                sequence: None,
                ..cfg.clone()
            };
            let first = src.clone();
            (
                "simcol3d",
                src,
                common,
                false,
                Box::new(move |p| read_simcol3d(p, if p == first { &cfg } else { &test_cfg })),
            )
        }
        Format::Endoslam {
            src,
            units,
            camera,
            poses,
            sheet,
            frames,
            common,
        } => {
            let units = match units {
                UnitsArg::Mm => Units::Mm,
                UnitsArg::Cm => Units::Cm,
                UnitsArg::M => Units::M,
            };
            let cfg = EndoSlamConfig {
                camera: parse_camera(&camera, false)?,
                units,
                poses,
                sheet,
                frames,
                fps: common.fps,
            };
            let first = src.clone();
            let test_cfg = EndoSlamConfig {
                poses: None,
                sheet: None,
                frames: None,
                ..cfg.clone()
            };
            (
                "endoslam",
                src,
                common,
                false,
                Box::new(move |p| read_endoslam(p, if p == first { &cfg } else { &test_cfg })),
            )
        }
    };
    let main =
        read(&src).with_context(|| format!("reading {format} recording {}", src.display()))?;
    let sequences = if let Some(spec) = &common.split {
        let parts = parse_split(spec).map_err(|e| anyhow::anyhow!("--split: {e}"))?;
        split_sequence(&main, &parts)?
    } else if let Some(test) = &common.test {
        let t = read(test)
            .with_context(|| format!("reading {format} test recording {}", test.display()))?;
        vec![("train".to_string(), main), ("test".to_string(), t)]
    } else {
        vec![(common.seq.clone(), main)]
    };
    let mut source = toml::Table::new();
    source.insert("tool".into(), format!("endoloc import {format}").into());
    source.insert("version".into(), env!("CARGO_PKG_VERSION").into());
    source.insert("format".into(), format.into());
    source.insert(
        "command".into(),
        std::env::args().collect::<Vec<_>>().join(" ").into(),
    );
    let mut recordings = vec![toml::Value::from(src.display().to_string())];
    if let Some(t) = &common.test {
        recordings.push(t.display().to_string().into());
    }
    source.insert("recordings".into(), toml::Value::Array(recordings));
    let name = common.name.clone().unwrap_or_else(|| {
        common.out.file_name().map_or_else(
            || format!("{format} import"),
            |n| n.to_string_lossy().into_owned(),
        )
    });
    let summary = write_import(
        &common.out,
        &sequences,
        &WriteImportConfig {
            name,
            undistort,
            overwrite: common.force,
            source,
        },
    )
    .map_err(|e| match e {
        endoloc_data::DataError::AlreadyExists { .. } => {
            anyhow::Error::new(e).context("not replacing it: add --force to overwrite")
        }
        e => anyhow::Error::new(e).context(format!("writing {}", common.out.display())),
    })?;
    for (_, s) in &sequences {
        for n in &s.notes {
            tracing::info!("{}: {n}", s.source.display());
        }
    }
    let c = &summary.camera;
    println!(
        "imported {format} into {}: camera {}x{} fx {} fy {} cx {} cy {}{}",
        summary.dir.display(),
        c.width,
        c.height,
        c.fx,
        c.fy,
        c.cx,
        c.cy,
        if c.distortion.is_none() {
            String::new()
        } else {
            format!(" {:?}", c.distortion)
        }
    );
    for (name, frames, depth) in &summary.sequences {
        println!(
            "  {name}: {frames} frames{}",
            if *depth { ", depth" } else { "" }
        );
    }
    Ok(())
}
