//! `ClassifyJob`: the zone of every frame of a sequence, raw and temporally filtered.

use std::fmt::{self, Write as _};
use std::path::PathBuf;
use std::time::Instant;

use endoloc_data::write_atomic;
use endoloc_data::{Dataset, Sequence};
use endoloc_eval::refuse_existing;
use endoloc_geometry::Status;
use endoloc_localize::map_io::{load_map, load_smoothed_level};
use endoloc_localize::{FrameResult, Localizer, LocalizerConfig};
use endoloc_net::track::{fixed_lag, smooth};
use endoloc_net::{
    TemporalFilter, TrackConfig, TrackEstimate, TrackFilter, ZoneClassifier, ZonePrediction,
    viterbi,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::bail;
use crate::choice::{Device, ZoneFilter};
use crate::error::Result;
use crate::localize::load_classifier;
use crate::progress::{Progress, bar};

/// Classifies every frame of a sequence into the model's zones (nearest training descriptor)
/// and compares with the truth zone (that of the nearest training pose, 10° of orientation
/// counting as 1 mm). The zones are also filtered over the video: an HMM over zones
/// (`forward` causal, `viterbi` offline) and an HMM over (training frame, speed) along the
/// training pass (`track` causal, `smooth` offline). With `verify` K > 0 (and the model's
/// maps) each frame is also registered against the SURF maps of its K best zones
/// (`verified`), and the live localizer runs over the sequence (`live`).
///
/// Writes a CSV with one row per frame to `out` (or returns it in the report), every zone's
/// score to `scores`, every frame's descriptor to `descriptors` (NumPy `.npy`, float32).
/// `Option` filter settings override the model's when set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ClassifyJob {
    /// Model folder written by the train job.
    #[cfg_attr(feature = "cli", arg(long, value_name = "MODEL"))]
    pub model: PathBuf,
    /// Ensemble: join this model too (trained on the same pass with the same zones;
    /// repeatable). Each frame's descriptor joins every model's; the squared distance to a
    /// training frame is the mean of the models'. Maps, camera and filter parameters are
    /// `model`'s.
    #[cfg_attr(feature = "cli", arg(long, value_name = "MODEL"))]
    pub also_model: Vec<PathBuf>,
    /// Sequence folder (images/ and poses.txt), e.g. DATASET/test.
    #[cfg_attr(feature = "cli", arg(long, value_name = "DIR"))]
    pub seq: PathBuf,
    /// Which zone the `zone` column holds: none (raw), forward, viterbi, track (causal, as
    /// live) or smooth. All are always in the CSV.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value_t = ClassifyJob::default().filter)
    )]
    pub filter: ZoneFilter,
    /// Write the per-frame CSV here (default: the report holds it; the command line prints
    /// it on stdout).
    #[cfg_attr(feature = "cli", arg(long, value_name = "CSV"))]
    pub out: Option<PathBuf>,
    /// Write every zone's score per frame (CSV: frame, then one column per zone).
    #[cfg_attr(feature = "cli", arg(long, value_name = "CSV"))]
    pub scores: Option<PathBuf>,
    /// Write every frame's descriptor here as a NumPy array (`.npy`, float32, frames ×
    /// descriptor length, row i = frame i; an ensemble's joined descriptor): for study in
    /// Python (`numpy.load`). Run on the training pass for the database's descriptors.
    #[cfg_attr(feature = "cli", arg(long, value_name = "NPY"))]
    pub descriptors: Option<PathBuf>,
    /// Only the first N frames.
    #[cfg_attr(feature = "cli", arg(long))]
    pub limit: Option<usize>,
    /// HMM: probability of staying in a zone per frame (default: the model's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub stay: Option<f64>,
    /// HMM: emission temperature in descriptor-distance units (default: the model's).
    #[cfg_attr(feature = "cli", arg(long))]
    pub temperature: Option<f32>,
    /// Track filter: emission temperature (descriptor-distance units).
    #[cfg_attr(feature = "cli", arg(long))]
    pub track_temperature: Option<f32>,
    /// Track filter: scale of the move per frame, in training frames.
    #[cfg_attr(feature = "cli", arg(long))]
    pub track_scale: Option<f64>,
    /// Track filter: largest move per frame, in training frames.
    #[cfg_attr(feature = "cli", arg(long))]
    pub track_step: Option<usize>,
    /// Track filter: largest speed, training frames per test frame (0: no speed state).
    #[cfg_attr(feature = "cli", arg(long))]
    pub track_speed: Option<usize>,
    /// Track filter: probability per frame of the speed changing by one.
    #[cfg_attr(feature = "cli", arg(long))]
    pub track_speed_change: Option<f64>,
    /// Track filter: report each frame's zone given the next L frames too (fixed-lag
    /// smoothing; live, the zone L frames late). 0 = causal.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "L", default_value_t = ClassifyJob::default().track_lag)
    )]
    pub track_lag: usize,
    /// Track filter: jump probability per frame.
    #[cfg_attr(feature = "cli", arg(long))]
    pub track_jump: Option<f64>,
    /// Verify every frame against the model's SURF maps in its K best zones (0 = off; needs
    /// the model's map first). Adds the verified (per frame) and live zones.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_name = "K", default_value_t = ClassifyJob::default().verify)
    )]
    pub verify: usize,
    /// Compute device: cpu, cuda, wgpu (GPU builds only) or auto.
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value_t = ClassifyJob::default().device)
    )]
    pub device: Device,
    /// Replace `out`, `scores` and `descriptors` files that already exist.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for ClassifyJob {
    fn default() -> Self {
        ClassifyJob {
            model: PathBuf::new(),
            also_model: Vec::new(),
            seq: PathBuf::new(),
            filter: ZoneFilter::Track,
            out: None,
            scores: None,
            descriptors: None,
            limit: None,
            stay: None,
            temperature: None,
            track_temperature: None,
            track_scale: None,
            track_step: None,
            track_speed: None,
            track_speed_change: None,
            track_lag: 0,
            track_jump: None,
            verify: 0,
            device: Device::Cpu,
            force: false,
        }
    }
}

/// Per-frame zone accuracy of one method.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ZoneAccuracy {
    /// Frames with a truth zone.
    pub frames: usize,
    /// Frames in the truth zone.
    pub exact: usize,
    /// Frames at most one zone from the truth zone.
    pub within_one: usize,
}

impl ZoneAccuracy {
    fn add(&mut self, pred: usize, truth: usize) {
        self.frames += 1;
        self.exact += usize::from(pred == truth);
        self.within_one += usize::from(pred.abs_diff(truth) <= 1);
    }
}

/// What `ClassifyJob` found.
#[derive(Debug, Clone)]
pub struct ClassifyReport {
    /// The per-frame CSV when no `out` file was given (else `None`).
    pub csv: Option<String>,
    /// The model folders (`model`, then `also_model`).
    pub models: Vec<PathBuf>,
    /// Zones of the model.
    pub zones: usize,
    /// The sequence folder.
    pub seq: PathBuf,
    /// Frames classified.
    pub frames: usize,
    /// Accuracy per method, in order: raw, forward, viterbi, track, smooth (then verified
    /// and live with `verify`); empty without truth.
    pub accuracy: Vec<(&'static str, ZoneAccuracy)>,
    /// Classification time (decode + descriptor + look-up), seconds.
    pub classify_s: f64,
    /// Worker threads.
    pub threads: usize,
    /// Verification time (per frame, then live), seconds, with `verify`.
    pub verify_s: Option<f64>,
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
    progress: &dyn Progress,
) -> Result<Verified> {
    let clf = localizer.classifier();
    let n = preds.len();
    let t0 = Instant::now();
    let per_frame = {
        let bar = bar(progress, n as u64, "verifying");
        (0..n)
            .into_par_iter()
            .map(|i| {
                let img = seq.load_gray(i)?;
                let r = localizer.localize_with_prediction(&img, &preds[i], preds[i].zone, 0.0)?;
                bar.inc(1);
                Ok(zone_of(clf, &r, preds[i].zone))
            })
            .collect::<Result<Vec<usize>>>()?
    };
    let bar = bar(progress, n as u64, "live");
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

fn viterbi_zone(path: &[usize], i: usize) -> usize {
    path.get(i).copied().unwrap_or(0)
}

impl ClassifyJob {
    /// The model's filter settings with this job's overrides.
    fn filters(&self, clf: &ZoneClassifier) -> Result<(endoloc_net::TemporalConfig, TrackConfig)> {
        let mut temporal = clf.config().temporal;
        if let Some(s) = self.stay {
            temporal.stay = s;
        }
        if let Some(t) = self.temperature {
            temporal.temperature = t;
        }
        temporal.validate()?;
        let mut track: TrackConfig = clf.config().track;
        if let Some(v) = self.track_temperature {
            track.temperature = v;
        }
        if let Some(v) = self.track_scale {
            track.step_scale = v;
        }
        if let Some(v) = self.track_step {
            track.max_step = v;
        }
        if let Some(v) = self.track_speed {
            track.max_speed = v;
        }
        if let Some(v) = self.track_speed_change {
            track.speed_change = v;
        }
        if let Some(v) = self.track_jump {
            track.jump = v;
        }
        track.validate()?;
        Ok((temporal, track))
    }

    /// Classifies, filters, verifies and writes.
    ///
    /// # Errors
    /// Outputs that name one file or exist without `force`, a model that
    /// cannot be loaded (or has no map with `verify`), a model for another camera, an
    /// unreadable image, or a failed write.
    pub fn run(&self, progress: &dyn Progress) -> Result<ClassifyReport> {
        // Refuse before the work, not after it.
        let outputs: Vec<&PathBuf> = self
            .out
            .iter()
            .chain(&self.scores)
            .chain(&self.descriptors)
            .collect();
        if (1..outputs.len()).any(|i| outputs[..i].contains(&outputs[i])) {
            bail!("`out`, `scores` and `descriptors` must name different files");
        }
        refuse_existing(&outputs, self.force)?;
        let loaded = load_classifier(&self.model, &self.also_model, self.device)?;
        let (plain, localizer) = if self.verify > 0 {
            let map = load_map(&self.model)?;
            let cfg = LocalizerConfig {
                candidate_zones: self.verify,
                ..LocalizerConfig::default()
            };
            let mask = crate::localize::dataset_mask(&self.seq)?;
            let mut localizer = Localizer::new(loaded, map, cfg)?
                .with_smoothed_level(load_smoothed_level(&self.model)?)?
                .with_mask(mask);
            // A pass from another scope registers with its own camera.
            let ds = crate::localize::dataset_camera(&self.seq)?;
            if let Some(camera) = endoloc_data::sequence_camera(&self.seq, &ds)? {
                localizer = localizer.with_camera(camera)?;
            }
            (None, Some(localizer))
        } else {
            (Some(loaded), None)
        };
        let clf = match (&plain, &localizer) {
            (Some(c), _) => c,
            (None, Some(l)) => l.classifier(),
            (None, None) => unreachable!("a classifier or a localizer"),
        };
        let seq = Sequence::open(&self.seq)?;
        // The dataset's camera, when the sequence sits in a dataset folder.
        if let Some(parent) = self.seq.parent()
            && parent.join("dataset.toml").is_file()
        {
            let ds = Dataset::open(parent)?;
            clf.check_compatible(&ds.meta.camera)?;
            clf.check_dataset(&ds)?;
        }
        let n = self.limit.map_or(seq.len(), |l| l.min(seq.len()));
        let (temporal, track_cfg) = self.filters(clf)?;

        let t0 = Instant::now();
        let mut preds: Vec<ZonePrediction> = Vec::with_capacity(n);
        {
            let bar = bar(progress, n as u64, "classifying");
            let frames: Vec<usize> = (0..n).collect();
            for chunk in frames.chunks(64) {
                let imgs: Result<Vec<image::GrayImage>, _> =
                    chunk.par_iter().map(|&i| seq.load_gray(i)).collect();
                preds.extend(clf.classify_batch(&imgs?)?);
                bar.set_position(preds.len() as u64);
            }
        }
        let classify_s = t0.elapsed().as_secs_f64();

        let mut f = TemporalFilter::new(clf.zone_count(), temporal);
        let forward: Vec<usize> = preds.iter().map(|p| f.update(p)).collect();
        let offline = viterbi(&preds, clf.zone_count(), &temporal);
        let frame_dist: Vec<Vec<f32>> = preds
            .par_iter()
            .map(|p| clf.frame_distances(&p.descriptor))
            .collect::<Result<_, _>>()?;
        let zone_of_frame = clf.zones().zone_of_frame.clone();
        let tracked: Vec<TrackEstimate> = if self.track_lag == 0 {
            let mut tf = TrackFilter::new(zone_of_frame.clone(), track_cfg)?;
            frame_dist
                .iter()
                .map(|d| tf.update(d))
                .collect::<Result<_, _>>()?
        } else {
            fixed_lag(&frame_dist, &zone_of_frame, &track_cfg, self.track_lag)?
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

        let verified = match &localizer {
            Some(l) => {
                let causal: Vec<usize> = tracked.iter().map(|e| e.zone).collect();
                Some(verify(l, &seq, &preds, &causal, progress)?)
            }
            None => None,
        };

        let mut csv = String::from(
            "frame,zone,raw_zone,distance,nearest_train_frame,forward_zone,viterbi_zone,track_zone,track_frame,smooth_zone,smooth_frame,truth_frame,truth_zone",
        );
        csv.push_str(if verified.is_some() {
            ",verified_zone,live_zone\n"
        } else {
            "\n"
        });
        let names = [
            "raw", "forward", "viterbi", "track", "smooth", "verified", "live",
        ];
        let mut acc = [ZoneAccuracy::default(); 7];
        for i in 0..n {
            let zones = [
                preds[i].zone,
                forward[i],
                viterbi_zone(&offline, i),
                tracked[i].zone,
                smoothed[i].zone,
            ];
            let chosen = match self.filter {
                ZoneFilter::None => zones[0],
                ZoneFilter::Forward => zones[1],
                ZoneFilter::Viterbi => zones[2],
                ZoneFilter::Track => zones[3],
                ZoneFilter::Smooth => zones[4],
            };
            let t = truth[i];
            let _ = write!(
                csv,
                "{i},{chosen},{},{:.5},{},{},{},{},{},{},{},{},{}",
                preds[i].zone,
                preds[i].distance,
                preds[i].nearest_frame,
                forward[i],
                zones[2],
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
                for (a, z) in acc.iter_mut().zip(zones) {
                    a.add(z, t);
                }
                if let Some(v) = &verified {
                    acc[5].add(v.per_frame[i], t);
                    acc[6].add(v.live[i], t);
                }
            }
        }
        let csv = match &self.out {
            Some(p) => {
                write_atomic(p, csv.as_bytes())?;
                None
            }
            None => Some(csv),
        };
        if let Some(p) = &self.scores {
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
        if let Some(p) = &self.descriptors {
            let rows: Vec<Vec<f32>> = preds.iter().map(|pr| pr.descriptor.clone()).collect();
            endoloc_eval::npy::write_npy_rows(p, &rows)?;
        }
        let methods = if verified.is_some() { 7 } else { 5 };
        let accuracy = if acc[0].frames > 0 {
            names.into_iter().zip(acc).take(methods).collect()
        } else {
            Vec::new()
        };
        Ok(ClassifyReport {
            csv,
            models: std::iter::once(&self.model)
                .chain(&self.also_model)
                .cloned()
                .collect(),
            zones: clf.zone_count(),
            seq: self.seq.clone(),
            frames: n,
            accuracy,
            classify_s,
            threads: rayon::current_num_threads(),
            verify_s: verified.map(|v| v.seconds),
        })
    }
}

/// The summary (not the CSV): models, accuracies and timing.
impl fmt::Display for ClassifyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let models: Vec<String> = self
            .models
            .iter()
            .map(|m| m.display().to_string())
            .collect();
        writeln!(
            f,
            "model {} ({} zones), sequence {} ({} frames)",
            models.join(" + "),
            self.zones,
            self.seq.display(),
            self.frames
        )?;
        for (name, a) in &self.accuracy {
            let pct = |k: usize| 100.0 * k as f64 / a.frames.max(1) as f64;
            writeln!(
                f,
                "{name:<10} {:6.2} % exact   {:6.2} % within ±1 zone   ({} frames)",
                pct(a.exact),
                pct(a.within_one),
                a.frames
            )?;
        }
        let per_frame = |s: f64| 1000.0 * s / self.frames.max(1) as f64;
        write!(
            f,
            "time {:.1} s: {:.2} ms per frame (decode + descriptor + look-up, batches of 64, {} threads)",
            self.classify_s,
            per_frame(self.classify_s),
            self.threads
        )?;
        if let Some(s) = self.verify_s {
            write!(
                f,
                "\nverification {s:.1} s: {:.1} ms per frame (per frame in parallel, then live in order)",
                per_frame(s)
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_from_an_empty_file() {
        let from_toml: ClassifyJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, ClassifyJob::default());
    }
}
