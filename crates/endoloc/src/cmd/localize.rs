//! `endoloc map` and `endoloc localize`: the geometric half of the method.

use anyhow::Result;
use endoloc_jobs::{LocalizeJob, MapJob, Progress};

/// Build the per-zone 3-D maps of a trained model: SURF tracks over `m` images of each zone,
/// triangulated with the known training poses; points reprojecting farther than δr are
/// dropped. Writes map.toml and map.bin into the model folder, one PLY per zone
/// (map_ply/zone_NNN.ply) and a COLMAP text model (map_colmap/), and the map's smoothed
/// level: the map of the training images smoothed by a Gaussian (map_smoothed/; σ 1.5 px per
/// 320 px of image width, --smoothed-level to choose, 0 for none), where localize registers
/// a frame that the map does not.
///
/// Examples:
///
///   endoloc map --model models/small --data data/small
///   endoloc map --model models/small --data data/small --smoothed-level 0 --force
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct MapArgs {
    #[command(flatten)]
    job: MapJob,
}

/// Runs `endoloc map`.
pub fn run_map(args: MapArgs, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}

/// Localize every frame of a sequence: zone (Siamese classifier) → initial pose = zone median
/// → SURF matched to the zone's map points → Gauss-Newton on SE(3) → validity check.
/// Writes trajectory.txt (TUM, T_wc, mm; one line per frame that has a pose) and frames.csv
/// (frame, zone, zone score, status refined|init_only|rejected, reason, inliers,
/// reprojection RMS, time) into --out. Then `endoloc eval --gt SEQ/poses.txt --est
/// OUT/trajectory.txt` gives the errors.
///
/// Examples:
///
///   endoloc localize --model models/small --seq data/small/test --out runs/small
///
///   endoloc localize --model models/small --seq data/small/test --out runs/live --live
///
/// A recording as it plays, watched in the browser at http://127.0.0.1:8080/:
///
///   endoloc localize --model models/small --live --video pass.mp4 --realtime --out runs/video --serve
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct LocalizeArgs {
    #[command(flatten)]
    job: LocalizeJob,
    #[command(flatten)]
    confirm: ConfirmArgs,
    /// With --video: serve a live view at ADDR while the stream is localized — the colon
    /// (training pass, map points by zone) with the scope moving in 3-D, its trail by status,
    /// the current frame with its matched keypoints, where it is along the colon and the
    /// status with its uncertainty. Loopback (127.0.0.1:8080) unless ADDR names another
    /// interface. The page stays up after the stream ends, until Ctrl-C; Ctrl-C during the
    /// stream ends the run after the frame in hand, its files complete.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8080", requires = "video")]
    serve: Option<String>,
    /// With --serve: the dataset the model was trained on — the view then gives distances
    /// from the anus along its mid-line and the anatomical section (otherwise along the
    /// training pass from its first frame).
    #[arg(long, value_name = "DATASET", requires = "serve")]
    train_data: Option<std::path::PathBuf>,
    /// With --serve: exit when the stream ends instead of serving the page until Ctrl-C.
    #[arg(long, requires = "serve")]
    exit_at_end: bool,
}

/// Runs `endoloc localize`.
pub fn run_localize(args: LocalizeArgs, ui: &dyn Progress) -> Result<()> {
    let mut job = args.job;
    args.confirm.apply(&mut job.confirm);
    match &args.serve {
        Some(addr) => serve(&job, addr, args.train_data.as_deref(), args.exit_at_end, ui),
        None => {
            crate::ui::print(&job.run(ui)?)?;
            Ok(())
        }
    }
}

/// `localize --video … --serve ADDR`: the live view's server around the stream's run.
fn serve(
    job: &LocalizeJob,
    addr: &str,
    train_data: Option<&std::path::Path>,
    exit_at_end: bool,
    ui: &dyn Progress,
) -> Result<()> {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    let model = job
        .model
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("a model folder is required (--model)"))?;
    // The frames' camera (another scope's with --camera): the scope drawn with its field of view.
    let model_camera = job.camera()?;
    let camera = job.frames_camera(&model_camera)?.unwrap_or(model_camera);
    let title = job
        .video
        .as_deref()
        .and_then(|v| v.file_name())
        .map_or_else(
            || "standard input".to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
    let view = endoloc_jobs::LiveView::new(model, &camera, train_data, &title, 30_000)?;
    for m in &view.missing {
        ui.note(&format!("live view: left out {m}"));
    }
    let interrupt = Arc::new(AtomicBool::new(false));
    let server =
        endoloc_serve::LiveServer::start(addr, view.page().to_string(), interrupt.clone())?;
    let bound = server.addr();
    ui.note(&format!("live view: http://{bound}/"));
    if !endoloc_serve::is_loopback(&bound) {
        ui.note(&format!(
            "live view: {bound} is not loopback — other machines on the network can open the page"
        ));
    }
    let mut failed = None;
    let report = job.run_video_watched(ui, &interrupt, &mut |f| match view.frame_event(&f) {
        Ok((full, light)) => server.publish(full, light),
        Err(e) => {
            failed.get_or_insert(e);
        }
    });
    let stopped = interrupt.load(Ordering::SeqCst);
    let line = match (&report, stopped) {
        (Err(e), _) => format!("the run failed: {e}"),
        (Ok(_), true) => format!("stopped (Ctrl-C) after {} frames", server.frames()),
        (Ok(_), false) => format!("the stream ended after {} frames", server.frames()),
    };
    server.end(&line);
    let report = report?;
    if let Some(e) = failed {
        return Err(e.into());
    }
    crate::ui::print(&report)?;
    if !stopped && !exit_at_end {
        ui.note(&format!(
            "live view: {line}; the page stays at http://{bound}/ until Ctrl-C"
        ));
        while !interrupt.load(Ordering::SeqCst) {
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
    }
    server.stop();
    Ok(())
}

/// `--confirm`, the explicit pair of the jobs' `--no-confirm` (shared by `localize` and
/// `bench live`): the last of the two on the command line wins.
#[derive(Debug, clap::Args)]
pub struct ConfirmArgs {
    /// Confirm registrations against the map (the default; see --no-confirm).
    #[arg(long = "confirm", overrides_with = "confirm")]
    confirm_on: bool,
}

impl ConfirmArgs {
    /// Turns `confirm` on when `--confirm` came after any `--no-confirm`.
    pub fn apply(&self, confirm: &mut bool) {
        if self.confirm_on {
            *confirm = true;
        }
    }
}
