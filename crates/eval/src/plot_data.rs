//! What the plots of an evaluation draw, collected frame by frame: bounded by [`PLOT_FRAMES`]
//! whatever the pass length. A longer pass is drawn from every k-th frame (trajectory), each
//! run of k frames' smallest and largest error (errors along the pass) and a 4096-bin
//! histogram (CDF); [`PlotData::stride`] is k.

use endoloc_geometry::Status;

use crate::EvalError;
use crate::frame_error::FrameEvaluation;
use crate::spill::Spill;

/// Passes up to this many frames are plotted frame by frame; longer ones are thinned.
pub const PLOT_FRAMES: usize = 20_000;

/// Bins of the CDF histogram of a thinned pass.
const CDF_BINS: usize = 4096;

/// One frame on the trajectory plot: world X-Y positions, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPoint {
    /// Ground-truth position `(x, y)`.
    pub gt: (f64, f64),
    /// Estimated position (after alignment), if localized.
    pub est: Option<(f64, f64)>,
    /// Status from `frames.csv`.
    pub status: Option<Status>,
}

/// A point of the errors-along plot: frame index, error, status.
pub type AlongPoint = (usize, f64, Option<Status>);

/// The distribution of one error over the frames.
#[derive(Debug, Clone, PartialEq)]
pub enum Cdf {
    /// Every error, ascending.
    Sorted(Vec<f64>),
    /// `counts[b]` errors in `[b·w, (b+1)·w)` with `w = max / bins` (the last bin holds `max`).
    Histogram {
        /// The largest error.
        max: f64,
        /// Errors per bin.
        counts: Vec<u64>,
    },
}

/// What the plots draw: bounded by [`PLOT_FRAMES`] whatever the pass length.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotData {
    /// Test frames in the pass.
    pub frames: usize,
    /// Every `stride`-th frame is drawn on the trajectory plot (1: every frame).
    pub stride: usize,
    /// The trajectory plot's frames.
    pub track: Vec<TrackPoint>,
    /// Position errors along the pass: every localized frame, or per run of `stride` frames
    /// the smallest and largest.
    pub along_position: Vec<AlongPoint>,
    /// Orientation errors along the pass, likewise.
    pub along_orientation: Vec<AlongPoint>,
    /// Position error distribution over the localized frames.
    pub cdf_position: Cdf,
    /// Orientation error distribution.
    pub cdf_orientation: Cdf,
}

/// The smallest and largest error of a run of frames.
#[derive(Debug, Clone, Copy, Default)]
struct Extremes {
    lo: Option<AlongPoint>,
    hi: Option<AlongPoint>,
}

impl Extremes {
    fn add(&mut self, p: AlongPoint) {
        if self.lo.is_none_or(|q| p.1 < q.1) {
            self.lo = Some(p);
        }
        if self.hi.is_none_or(|q| p.1 > q.1) {
            self.hi = Some(p);
        }
    }

    fn flush(&mut self, out: &mut Vec<AlongPoint>) {
        let (lo, hi) = (self.lo.take(), self.hi.take());
        match (lo, hi) {
            (Some(a), Some(b)) if a.0 == b.0 => out.push(a),
            (Some(a), Some(b)) if a.0 < b.0 => out.extend([a, b]),
            (Some(a), Some(b)) => out.extend([b, a]),
            _ => {}
        }
    }
}

/// Collects [`PlotData`] frame by frame during an evaluation.
pub(crate) struct PlotCollector {
    data: PlotData,
    runs: [Extremes; 2],
    max: [f64; 2],
    exact: [Vec<f64>; 2],
}

impl PlotCollector {
    pub(crate) fn new(frames: usize) -> Self {
        Self {
            data: PlotData {
                frames,
                stride: frames.div_ceil(PLOT_FRAMES).max(1),
                track: Vec::new(),
                along_position: Vec::new(),
                along_orientation: Vec::new(),
                cdf_position: Cdf::Sorted(Vec::new()),
                cdf_orientation: Cdf::Sorted(Vec::new()),
            },
            runs: [Extremes::default(); 2],
            max: [0.0; 2],
            exact: [Vec::new(), Vec::new()],
        }
    }

    /// The next frame, with its ground-truth and (aligned) estimated pose.
    pub(crate) fn add(
        &mut self,
        f: &FrameEvaluation,
        gt: &endoloc_geometry::Pose,
        est: Option<&endoloc_geometry::Pose>,
    ) {
        let k = self.data.stride;
        let xy = |p: &endoloc_geometry::Pose| (p.translation.x, p.translation.y);
        if f.frame.is_multiple_of(k) {
            self.data.track.push(TrackPoint {
                gt: xy(gt),
                est: est.map(xy),
                status: f.status,
            });
        }
        if k > 1 && f.frame.is_multiple_of(k) {
            let d = &mut self.data;
            self.runs[0].flush(&mut d.along_position);
            self.runs[1].flush(&mut d.along_orientation);
        }
        for (q, e) in [f.position_mm, f.orientation_deg].into_iter().enumerate() {
            let Some(e) = e else { continue };
            if e.is_finite() {
                self.max[q] = self.max[q].max(e);
            }
            if k == 1 {
                let along = [
                    &mut self.data.along_position,
                    &mut self.data.along_orientation,
                ];
                along[q].push((f.frame, e, f.status));
                self.exact[q].push(e);
            } else {
                self.runs[q].add((f.frame, e, f.status));
            }
        }
    }

    /// The plot data; a thinned pass's histograms are read from `frames` (sealed).
    pub(crate) fn finish(mut self, frames: &Spill<FrameEvaluation>) -> Result<PlotData, EvalError> {
        let mut d = self.data;
        self.runs[0].flush(&mut d.along_position);
        self.runs[1].flush(&mut d.along_orientation);
        if d.stride == 1 {
            let [mut p, mut r] = self.exact;
            p.sort_by(f64::total_cmp);
            r.sort_by(f64::total_cmp);
            d.cdf_position = Cdf::Sorted(p);
            d.cdf_orientation = Cdf::Sorted(r);
            return Ok(d);
        }
        let mut counts = [vec![0u64; CDF_BINS], vec![0u64; CDF_BINS]];
        let max = self.max;
        frames.for_each(|f| {
            for (q, e) in [f.position_mm, f.orientation_deg].into_iter().enumerate() {
                if let Some(e) = e.filter(|e| e.is_finite()) {
                    let b = if max[q] > 0.0 {
                        ((e / max[q] * CDF_BINS as f64) as usize).min(CDF_BINS - 1)
                    } else {
                        0
                    };
                    counts[q][b] += 1;
                }
            }
            Ok(())
        })?;
        let [p, r] = counts;
        d.cdf_position = Cdf::Histogram {
            max: max[0],
            counts: p,
        };
        d.cdf_orientation = Cdf::Histogram {
            max: max[1],
            counts: r,
        };
        Ok(d)
    }
}
