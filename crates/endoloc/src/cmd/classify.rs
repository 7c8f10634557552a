//! `endoloc classify`: the zone of every frame of a sequence, raw and temporally filtered.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use endoloc_data::{Dataset, Sequence};
use endoloc_eval::{refuse_existing, write_atomic};
use endoloc_geometry::Status;
use endoloc_localize::map_io::load_map;
use endoloc_localize::{FrameResult, Localizer, LocalizerConfig};
use endoloc_net::track::{fixed_lag, smooth};
use endoloc_net::{
    TemporalFilter, TrackConfig, TrackEstimate, TrackFilter, ZoneClassifier, ZonePrediction,
    viterbi,
};
use rayon::prelude::*;

use crate::cmd::localize::{load_classifier, test_frame_surf};

/// Classify every frame of a sequence into the model's zones and compare with the truth.
///
/// Each frame goes to the zone of its nearest training descriptor (zone score = distance in
/// descriptor space, lower is better). Beyond the paper, the zones are filtered over the
/// video, two ways:
///
///   - an HMM over zones: `forward` is the causal filter (live use), `viterbi` the offline
///     best path;
///   - an HMM over (training frame, speed) that tracks the video along the training pass and
///     takes the zone holding most of the belief: `track` is the causal filter, `smooth`
///     forward–backward over the whole video (offline).
///
/// The truth zone of a frame is the zone of the nearest training pose (position, with 10° of
/// orientation counting as 1 mm); that training frame is the `truth_frame` column.
///
/// With --verify K (and the model's maps, from `endoloc map`), each frame is also checked
/// geometrically: its SURF features are registered in its K best zones, best first, and the
/// frame goes to the zone of the first registered pose (`verified`, per frame); the live
/// localizer does the same with the track filter and tracking (`live`). A frame that
/// registers nowhere keeps its raw (or tracked) zone.
///
/// Output: a CSV with one row per frame (frame, chosen zone, raw zone, its distance, nearest
/// training frame, forward and Viterbi zones, track and smoothed zones and training frames,
/// truth frame and zone; then verified and live zones with --verify) to --out or stdout, all
/// zone scores with --scores, every frame's descriptor with --descriptors (a NumPy `.npy`
/// array), and a summary of accuracies and timing on stderr. Existing --out, --scores and
/// --descriptors files are kept unless --force; files are written whole or not at all.
///
/// Examples:
///
///   endoloc classify --model models/paper50 --seq data/paper/test --out zones.csv
///
///   endoloc classify --model models/paper50 --seq data/paper/test --filter viterbi > zones.csv
///
///   endoloc classify --model models/paper50 --seq data/paper/test --verify 5 --out zones.csv
///
///   endoloc classify --model models/zone50 --also-model models/track50 --seq data/paper/test
///
///   endoloc classify --model models/paper50 --seq data/paper/train --descriptors train.npy --out train.csv
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Model folder written by `endoloc train`.
    #[arg(long, value_name = "MODEL")]
    model: PathBuf,

    /// Ensemble: join this model too (trained on the same pass with the same zones; repeat the
    /// flag for more). Each frame's descriptor joins every model's; the squared distance to a
    /// training frame is the mean of the models'. Maps, camera and filter parameters are
    /// --model's.
    #[arg(long, value_name = "MODEL")]
    also_model: Vec<PathBuf>,

    /// Sequence folder (images/ and poses.txt), e.g. DATASET/test.
    #[arg(long, value_name = "DIR")]
    seq: PathBuf,

    /// Which zone the `zone` column holds: none (raw), forward, viterbi, track (the default:
    /// causal, as live) or smooth. All are always in the CSV.
    #[arg(long, default_value = "track")]
    filter: String,

    /// Write the per-frame CSV here (default: stdout).
    #[arg(long, value_name = "CSV")]
    out: Option<PathBuf>,

    /// Write every zone's score per frame (CSV: frame, then one column per zone).
    #[arg(long, value_name = "CSV")]
    scores: Option<PathBuf>,

    /// Write every frame's descriptor here as a NumPy array (`.npy`, float32, frames ×
    /// descriptor length, row i = frame i; an ensemble's joined descriptor): for study in
    /// Python (`numpy.load`). Run on the training pass for the database's descriptors.
    #[arg(long, value_name = "NPY")]
    descriptors: Option<PathBuf>,

    /// Only the first N frames.
    #[arg(long)]
    limit: Option<usize>,

    /// HMM: probability of staying in a zone per frame (default: the model's).
    #[arg(long)]
    stay: Option<f64>,

    /// HMM: emission temperature in descriptor-distance units (default: the model's).
    #[arg(long)]
    temperature: Option<f32>,

    /// Track filter: emission temperature (descriptor-distance units).
    #[arg(long)]
    track_temperature: Option<f32>,

    /// Track filter: scale of the move per frame, in training frames.
    #[arg(long)]
    track_scale: Option<f64>,

    /// Track filter: largest move per frame, in training frames.
    #[arg(long)]
    track_step: Option<usize>,

    /// Track filter: largest speed, training frames per test frame (0: no speed state).
    #[arg(long)]
    track_speed: Option<usize>,

    /// Track filter: probability per frame of the speed changing by one.
    #[arg(long)]
    track_speed_change: Option<f64>,

    /// Track filter: report each frame's zone given the next L frames too (fixed-lag
    /// smoothing; live, the zone L frames late). 0 = causal.
    #[arg(long, value_name = "L", default_value_t = 0)]
    track_lag: usize,

    /// Track filter: jump probability per frame.
    #[arg(long)]
    track_jump: Option<f64>,

    /// Verify every frame against the model's SURF maps in its K best zones (0 = off; needs
    /// `endoloc map` first). Adds the verified (per frame) and live zones.
    #[arg(long, value_name = "K", default_value_t = 0)]
    verify: usize,

    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto.
    #[arg(long, default_value = "cpu")]
    device: String,

    /// Replace --out, --scores and --descriptors files that already exist.
    #[arg(long)]
    force: bool,
}

/// The classifier alone, or inside a localizer for --verify.
enum Classifier {
    Plain(Box<ZoneClassifier>),
    Verifying(Box<Localizer>),
}

impl Classifier {
    fn get(&self) -> &ZoneClassifier {
        match self {
            Classifier::Plain(c) => c,
            Classifier::Verifying(l) => l.classifier(),
        }
    }
}

/// Zones from geometric verification: per frame and live.
struct Verified {
    per_frame: Vec<usize>,
    live: Vec<usize>,
    seconds: f64,
}

/// The zone of a registered pose (the zone of the nearest training pose), else `fallback`.
fn zone_of(clf: &ZoneClassifier, r: &FrameResult, fallback: usize) -> usize {
    match (r.status, &r.t_wc) {
        (Status::Refined, Some(p)) => clf.truth_zone(p).unwrap_or(fallback),
        _ => fallback,
    }
}

/// Registers every frame in its best zones (in parallel), then runs the live localizer over
/// the sequence in order; `causal` holds the track filter's zones, the live fallback.
fn verify(
    localizer: &Localizer,
    seq: &Sequence,
    preds: &[ZonePrediction],
    causal: &[usize],
) -> Result<Verified> {
    let clf = localizer.classifier();
    let n = preds.len();
    let t0 = Instant::now();
    let bar = crate::ui::progress_bar(n as u64, "verifying");
    let per_frame: Result<Vec<usize>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let img = seq.load_gray(i)?;
            let r = localizer.localize_with_prediction(&img, &preds[i], preds[i].zone, 0.0)?;
            bar.inc(1);
            Ok(zone_of(clf, &r, preds[i].zone))
        })
        .collect();
    let per_frame = per_frame?;
    bar.finish_and_clear();
    let bar = crate::ui::progress_bar(n as u64, "live");
    let mut state = localizer.live_state();
    let mut live = Vec::with_capacity(n);
    for (i, &fallback) in causal.iter().enumerate() {
        let img = seq.load_gray(i)?;
        let r = localizer.localize_live(&mut state, &img)?;
        live.push(zone_of(clf, &r, fallback));
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(Verified {
        per_frame,
        live,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Accuracy counters.
#[derive(Default)]
struct Acc {
    n: usize,
    exact: usize,
    near: usize,
}

impl Acc {
    fn add(&mut self, pred: usize, truth: usize) {
        self.n += 1;
        self.exact += usize::from(pred == truth);
        self.near += usize::from(pred.abs_diff(truth) <= 1);
    }
    fn line(&self, name: &str) -> String {
        let pct = |k: usize| 100.0 * k as f64 / self.n.max(1) as f64;
        format!(
            "{name:<10} {:6.2} % exact   {:6.2} % within ±1 zone   ({} frames)",
            pct(self.exact),
            pct(self.near),
            self.n
        )
    }
}

/// Runs `endoloc classify`.
pub fn run(args: Args) -> Result<()> {
    let filter = args.filter.trim().to_ascii_lowercase();
    if !["none", "raw", "forward", "viterbi", "track", "smooth"].contains(&filter.as_str()) {
        bail!(
            "--filter {}: expected none, forward, viterbi, track or smooth",
            args.filter
        );
    }
    // Refuse before the work, not after it.
    let outputs: Vec<&PathBuf> = args
        .out
        .iter()
        .chain(&args.scores)
        .chain(&args.descriptors)
        .collect();
    if (1..outputs.len()).any(|i| outputs[..i].contains(&outputs[i])) {
        bail!("--out, --scores and --descriptors must name different files");
    }
    refuse_existing(&outputs, args.force)?;
    let loaded = load_classifier(&args.model, &args.also_model, &args.device)?;
    let source = if args.verify > 0 {
        let map = load_map(&args.model)?;
        let cfg = LocalizerConfig {
            candidate_zones: args.verify,
            ..test_frame_surf(&map.config.surf, None, None)
        };
        Classifier::Verifying(Box::new(Localizer::new(loaded, map, cfg)?))
    } else {
        Classifier::Plain(Box::new(loaded))
    };
    let clf = source.get();
    let seq = Sequence::open(&args.seq)?;
    // The dataset's camera, when the sequence sits in a dataset folder.
    if let Some(parent) = args.seq.parent()
        && parent.join("dataset.toml").is_file()
    {
        let ds = Dataset::open(parent)?;
        clf.check_compatible(&ds.meta.camera)?;
    }
    let n = args.limit.map_or(seq.len(), |l| l.min(seq.len()));
    let mut temporal = clf.config().temporal;
    if let Some(s) = args.stay {
        temporal.stay = s;
    }
    if let Some(t) = args.temperature {
        temporal.temperature = t;
    }
    temporal.validate()?;
    let mut track_cfg: TrackConfig = clf.config().track;
    if let Some(v) = args.track_temperature {
        track_cfg.temperature = v;
    }
    if let Some(v) = args.track_scale {
        track_cfg.step_scale = v;
    }
    if let Some(v) = args.track_step {
        track_cfg.max_step = v;
    }
    if let Some(v) = args.track_speed {
        track_cfg.max_speed = v;
    }
    if let Some(v) = args.track_speed_change {
        track_cfg.speed_change = v;
    }
    if let Some(v) = args.track_jump {
        track_cfg.jump = v;
    }
    track_cfg.validate()?;

    let bar = crate::ui::progress_bar(n as u64, "classifying");
    let t0 = Instant::now();
    let mut preds: Vec<ZonePrediction> = Vec::with_capacity(n);
    let frames: Vec<usize> = (0..n).collect();
    for chunk in frames.chunks(64) {
        let imgs: Result<Vec<image::GrayImage>, _> =
            chunk.par_iter().map(|&i| seq.load_gray(i)).collect();
        preds.extend(clf.classify_batch(&imgs?)?);
        bar.set_position(preds.len() as u64);
    }
    bar.finish_and_clear();
    let classify_s = t0.elapsed().as_secs_f64();

    let mut f = TemporalFilter::new(clf.zone_count(), temporal);
    let forward: Vec<usize> = preds.iter().map(|p| f.update(p)).collect();
    let offline = viterbi(&preds, clf.zone_count(), &temporal);
    let frame_dist: Vec<Vec<f32>> = preds
        .par_iter()
        .map(|p| clf.frame_distances(&p.descriptor))
        .collect::<Result<_, _>>()?;
    let zone_of_frame = clf.zones().zone_of_frame.clone();
    let tracked: Vec<TrackEstimate> = if args.track_lag == 0 {
        let mut tf = TrackFilter::new(zone_of_frame.clone(), track_cfg)?;
        frame_dist
            .iter()
            .map(|d| tf.update(d))
            .collect::<Result<_, _>>()?
    } else {
        fixed_lag(&frame_dist, &zone_of_frame, &track_cfg, args.track_lag)?
    };
    let smoothed = smooth(&frame_dist, &zone_of_frame, &track_cfg)?;
    // The truth: the nearest training frame and its zone (ZoneTable::truth_zone's rule).
    let truth_frame: Vec<Option<usize>> = seq.poses[..n]
        .par_iter()
        .map(|p| clf.nearest_train_frame(&p.pose))
        .collect();
    let truth: Vec<Option<usize>> = truth_frame
        .iter()
        .map(|f| f.and_then(|f| zone_of_frame.get(f).copied()))
        .collect();

    let verified = match &source {
        Classifier::Verifying(l) => {
            let causal: Vec<usize> = tracked.iter().map(|e| e.zone).collect();
            Some(verify(l, &seq, &preds, &causal)?)
        }
        Classifier::Plain(_) => None,
    };

    let mut csv = String::from(
        "frame,zone,raw_zone,distance,nearest_train_frame,forward_zone,viterbi_zone,track_zone,track_frame,smooth_zone,smooth_frame,truth_frame,truth_zone",
    );
    csv.push_str(if verified.is_some() {
        ",verified_zone,live_zone\n"
    } else {
        "\n"
    });
    let (mut raw_acc, mut fwd_acc, mut vit_acc) = (Acc::default(), Acc::default(), Acc::default());
    let (mut ver_acc, mut live_acc) = (Acc::default(), Acc::default());
    let (mut track_acc, mut smooth_acc) = (Acc::default(), Acc::default());
    for i in 0..n {
        let chosen = match filter.as_str() {
            "forward" => forward[i],
            "viterbi" => viterbi_zone(&offline, i),
            "track" => tracked[i].zone,
            "smooth" => smoothed[i].zone,
            _ => preds[i].zone,
        };
        let t = truth[i];
        let _ = write!(
            csv,
            "{i},{chosen},{},{:.5},{},{},{},{},{},{},{},{},{}",
            preds[i].zone,
            preds[i].distance,
            preds[i].nearest_frame,
            forward[i],
            viterbi_zone(&offline, i),
            tracked[i].zone,
            tracked[i].frame,
            smoothed[i].zone,
            smoothed[i].frame,
            truth_frame[i].map_or(String::new(), |f| f.to_string()),
            t.map_or(String::new(), |t| t.to_string())
        );
        if let Some(v) = &verified {
            let _ = write!(csv, ",{},{}", v.per_frame[i], v.live[i]);
        }
        csv.push('\n');
        if let Some(t) = t {
            raw_acc.add(preds[i].zone, t);
            fwd_acc.add(forward[i], t);
            vit_acc.add(viterbi_zone(&offline, i), t);
            track_acc.add(tracked[i].zone, t);
            smooth_acc.add(smoothed[i].zone, t);
            if let Some(v) = &verified {
                ver_acc.add(v.per_frame[i], t);
                live_acc.add(v.live[i], t);
            }
        }
    }
    match &args.out {
        Some(p) => write_atomic(p, csv.as_bytes())?,
        None => print!("{csv}"),
    }
    if let Some(p) = &args.scores {
        let mut s = String::from("frame");
        for z in 0..clf.zone_count() {
            let _ = write!(s, ",zone_{z}");
        }
        s.push('\n');
        for (i, pr) in preds.iter().enumerate() {
            let _ = write!(s, "{i}");
            for v in &pr.zone_scores {
                let _ = write!(s, ",{v:.5}");
            }
            s.push('\n');
        }
        write_atomic(p, s.as_bytes())?;
    }
    if let Some(p) = &args.descriptors {
        let rows: Vec<Vec<f32>> = preds.iter().map(|pr| pr.descriptor.clone()).collect();
        endoloc_eval::npy::write_npy_rows(p, &rows)?;
    }
    eprintln!(
        "model {}{} ({} zones), sequence {} ({} frames)",
        args.model.display(),
        args.also_model
            .iter()
            .map(|m| format!(" + {}", m.display()))
            .collect::<String>(),
        clf.zone_count(),
        args.seq.display(),
        n
    );
    if raw_acc.n > 0 {
        eprintln!("{}", raw_acc.line("raw"));
        eprintln!("{}", fwd_acc.line("forward"));
        eprintln!("{}", vit_acc.line("viterbi"));
        eprintln!("{}", track_acc.line("track"));
        eprintln!("{}", smooth_acc.line("smooth"));
        if verified.is_some() {
            eprintln!("{}", ver_acc.line("verified"));
            eprintln!("{}", live_acc.line("live"));
        }
    }
    eprintln!(
        "time {:.1} s: {:.2} ms per frame (decode + descriptor + look-up, batches of 64, {} threads)",
        classify_s,
        1000.0 * classify_s / n.max(1) as f64,
        rayon::current_num_threads()
    );
    if let Some(v) = &verified {
        eprintln!(
            "verification {:.1} s: {:.1} ms per frame (per frame in parallel, then live in order)",
            v.seconds,
            1000.0 * v.seconds / n.max(1) as f64
        );
    }
    Ok(())
}

fn viterbi_zone(path: &[usize], i: usize) -> usize {
    path.get(i).copied().unwrap_or(0)
}
