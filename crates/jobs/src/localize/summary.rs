//! What a localization run amounts to — counts per status and latency quantiles — gathered
//! frame by frame in memory that does not grow with the run's length.

use std::fmt;

use endoloc_geometry::Status;
use endoloc_localize::FrameResult;

/// Latencies in logarithmic bins (1 % wide, from 1 µs to 100 s): quantiles to within 0.5 %
/// of the exact order statistic, in a fixed 15 KiB whatever the number of frames.
#[derive(Debug, Clone, PartialEq)]
pub struct LatencyHistogram {
    counts: Vec<u32>,
    total: u64,
}

impl LatencyHistogram {
    /// Smallest time binned apart, ms (smaller times share the first bin).
    const MIN_MS: f64 = 1e-3;
    /// Ratio between a bin's upper and lower edge.
    const RATIO: f64 = 1.01;
    /// Bins from `MIN_MS` to 1e5 ms.
    const BINS: usize = 1852;

    /// An empty histogram.
    pub fn new() -> Self {
        LatencyHistogram {
            counts: vec![0; Self::BINS],
            total: 0,
        }
    }

    fn bin(ms: f64) -> usize {
        if ms.is_nan() || ms <= Self::MIN_MS {
            return 0;
        }
        let k = ((ms / Self::MIN_MS).ln() / Self::RATIO.ln()) as usize;
        k.min(Self::BINS - 1)
    }

    /// Counts one time, ms.
    pub fn add(&mut self, ms: f64) {
        let b = Self::bin(ms);
        self.counts[b] = self.counts[b].saturating_add(1);
        self.total += 1;
    }

    /// Times counted.
    pub fn len(&self) -> u64 {
        self.total
    }

    /// Whether nothing was counted.
    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    /// The `q`-quantile (`q` in [0, 1]; 0.5 = the median, the element at rank ⌊n/2⌋ of the
    /// sorted times), ms, as the geometric centre of its bin; 0 when empty.
    pub fn quantile(&self, q: f64) -> f64 {
        if self.total == 0 {
            return 0.0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.total as f64) as u64).min(self.total - 1);
        let mut seen = 0u64;
        for (b, &c) in self.counts.iter().enumerate() {
            seen += u64::from(c);
            if seen > rank {
                return if b == 0 {
                    Self::MIN_MS
                } else {
                    Self::MIN_MS * Self::RATIO.powf(b as f64 + 0.5)
                };
            }
        }
        Self::MIN_MS * Self::RATIO.powf(Self::BINS as f64)
    }
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        Self::new()
    }
}

/// Counts per status and per-stage latency of a run, built frame by frame
/// ([`RunSummary::add`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunSummary {
    /// Frames.
    pub frames: usize,
    /// Frames `refined`, `init_only`, `rejected`.
    pub counts: [usize; 3],
    /// Frames whose image could not be read (counted in `rejected`).
    pub unreadable: usize,
    /// Total time per frame, ms.
    pub total_ms: LatencyHistogram,
    /// Zone, SURF, matching and refinement times per frame, ms.
    pub stage_ms: [LatencyHistogram; 4],
}

impl RunSummary {
    /// Counts one more frame.
    pub fn add(&mut self, r: &FrameResult) {
        self.frames += 1;
        let k = match r.status {
            Status::Refined => 0,
            Status::InitOnly => 1,
            Status::Rejected => 2,
        };
        self.counts[k] += 1;
        if !r.has_zone() {
            self.unreadable += 1;
        }
        let t = &r.times;
        self.total_ms.add(t.total_ms());
        for (h, ms) in
            self.stage_ms
                .iter_mut()
                .zip([t.zone_ms, t.surf_ms, t.matching_ms, t.refine_ms])
        {
            h.add(ms);
        }
    }

    fn fraction(&self, k: usize) -> f64 {
        self.counts[k] as f64 / self.frames.max(1) as f64
    }

    /// Fraction of frames `refined`, in [0, 1].
    pub fn refined(&self) -> f64 {
        self.fraction(0)
    }

    /// Fraction of frames `init_only`, in [0, 1].
    pub fn init_only(&self) -> f64 {
        self.fraction(1)
    }

    /// Fraction of frames `rejected`, in [0, 1].
    pub fn rejected(&self) -> f64 {
        self.fraction(2)
    }

    /// Median total time per frame, ms.
    pub fn median_ms(&self) -> f64 {
        self.total_ms.quantile(0.5)
    }

    /// Median zone, SURF, matching and refinement times, ms.
    pub fn median_stage_ms(&self) -> [f64; 4] {
        self.stage_ms.each_ref().map(|h| h.quantile(0.5))
    }
}

impl fmt::Display for RunSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let unreadable = if self.unreadable > 0 {
            format!(" ({} unreadable images)", self.unreadable)
        } else {
            String::new()
        };
        writeln!(
            f,
            "frames    {} — refined {:.1} %, init_only {:.1} %, rejected {:.1} %{unreadable}",
            self.frames,
            100.0 * self.refined(),
            100.0 * self.init_only(),
            100.0 * self.rejected(),
        )?;
        let [zone, surf, matching, refine] = self.median_stage_ms();
        write!(
            f,
            "latency   median per frame {:.1} ms, p95 {:.1} ms (zone {zone:.1}, SURF {surf:.1}, matching {matching:.1}, refine {refine:.2})",
            self.median_ms(),
            self.total_ms.quantile(0.95)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_within_half_a_percent_of_the_exact_order_statistic() {
        let mut h = LatencyHistogram::new();
        // Skewed latencies over four decades, in a scrambled order.
        let mut times: Vec<f64> = (0..10_001)
            .map(|i| 0.05 * (1.0 + ((i * 7919) % 10_001) as f64).powf(1.3))
            .collect();
        for &t in &times {
            h.add(t);
        }
        times.sort_by(f64::total_cmp);
        for q in [0.0, 0.05, 0.5, 0.95, 0.99, 1.0] {
            let exact = times[((q * times.len() as f64) as usize).min(times.len() - 1)];
            let got = h.quantile(q);
            assert!(
                (got / exact - 1.0).abs() <= 0.005 + 1e-12,
                "q {q}: {got} vs exact {exact}"
            );
        }
        assert_eq!(h.len(), 10_001);
        assert_eq!(LatencyHistogram::new().quantile(0.5), 0.0);
    }

    #[test]
    fn times_outside_the_range_land_in_the_end_bins() {
        let mut h = LatencyHistogram::new();
        for t in [0.0, -1.0, f64::NAN, 1e-9] {
            h.add(t);
        }
        assert_eq!(h.quantile(1.0), LatencyHistogram::MIN_MS);
        h.add(1e9);
        assert!(h.quantile(1.0) >= 9.9e4);
    }
}
