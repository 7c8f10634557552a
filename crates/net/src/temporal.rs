//! Temporal filtering of per-frame zone predictions over a video: a hidden Markov model whose
//! states are the zones.
//!
//! - **Transitions** (per frame): stay with probability `stay`; move one zone forward or back
//!   with `step1` each, two zones with `step2` each; the remaining mass `1 − stay − 2·step1 −
//!   2·step2` is a uniform *jump* to any zone, which lets the filter recover after a run of
//!   wrong frames. Rows are renormalised at the ends of the colon. The scope may advance or
//!   withdraw: the model is symmetric.
//! - **Emissions**: `p(frame | zone z) ∝ exp(−(s_z − min s) / temperature)` with `s_z` the
//!   zone's score (a descriptor distance, [`crate::database`]).
//!
//! [`TemporalFilter`] is the causal forward filter (the belief after each frame depends only on
//! past frames: for live use); [`viterbi`] is the offline most-likely zone sequence over the
//! whole video.

use crate::database::ZonePrediction;
use serde::{Deserialize, Serialize};

/// HMM parameters; probabilities are per frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TemporalConfig {
    /// Probability of staying in the zone.
    pub stay: f64,
    /// Probability of moving one zone forward (and, separately, one back).
    pub step1: f64,
    /// Probability of moving two zones forward (and, separately, two back).
    pub step2: f64,
    /// Emission temperature, descriptor-distance units: how much a distance difference
    /// counts. Smaller trusts each frame more.
    pub temperature: f32,
}

impl Default for TemporalConfig {
    fn default() -> Self {
        TemporalConfig {
            stay: 0.95,
            step1: 0.02,
            step2: 0.003,
            temperature: 0.25,
        }
    }
}

impl TemporalConfig {
    /// The uniform jump mass `1 − stay − 2·step1 − 2·step2` (clamped at a tiny positive value).
    pub fn jump(&self) -> f64 {
        (1.0 - self.stay - 2.0 * self.step1 - 2.0 * self.step2).max(1e-9)
    }

    /// Checks that the probabilities are valid.
    ///
    /// # Errors
    /// [`crate::NetError::Config`] naming the bad value.
    pub fn validate(&self) -> Result<(), crate::NetError> {
        let p = [self.stay, self.step1, self.step2];
        if p.iter().any(|v| !(0.0..=1.0).contains(v))
            || self.stay + 2.0 * self.step1 + 2.0 * self.step2 > 1.0 + 1e-9
        {
            return Err(crate::NetError::Config(format!(
                "temporal: stay {} + 2·step1 {} + 2·step2 {} must be probabilities summing to at most 1",
                self.stay, self.step1, self.step2
            )));
        }
        if !(self.temperature > 0.0 && self.temperature.is_finite()) {
            return Err(crate::NetError::Config(format!(
                "temporal: temperature {} must be positive",
                self.temperature
            )));
        }
        Ok(())
    }
}

/// Banded part of the transition model: `w[d]` for a move of `d` zones (0, 1, 2), the jump
/// mass per target zone, and each row's normaliser.
struct Transitions {
    band: [f64; 3],
    jump_each: f64,
    row_norm: Vec<f64>,
}

impl Transitions {
    fn new(cfg: &TemporalConfig, zones: usize) -> Self {
        let band = [cfg.stay, cfg.step1, cfg.step2];
        let jump_each = cfg.jump() / zones.max(1) as f64;
        let row_norm = (0..zones)
            .map(|i| {
                let mut s = jump_each * zones as f64;
                for j in i.saturating_sub(2)..=(i + 2).min(zones - 1) {
                    s += band[i.abs_diff(j)];
                }
                s
            })
            .collect();
        Transitions {
            band,
            jump_each,
            row_norm,
        }
    }

    /// `P(i → j)`.
    fn p(&self, i: usize, j: usize) -> f64 {
        let d = i.abs_diff(j);
        let b = if d <= 2 { self.band[d] } else { 0.0 };
        (b + self.jump_each) / self.row_norm[i]
    }
}

/// Emission log-likelihoods of one frame (max 0).
fn log_emission(pred: &ZonePrediction, zones: usize, temperature: f32) -> Vec<f64> {
    let min = pred
        .zone_scores
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f32::INFINITY, f32::min);
    (0..zones)
        .map(|z| {
            let s = pred.zone_scores.get(z).copied().unwrap_or(f32::INFINITY);
            if s.is_finite() && min.is_finite() {
                -((s - min) / temperature) as f64
            } else {
                -1e4
            }
        })
        .collect()
}

/// Causal forward filter over zones (see the module documentation).
#[derive(Debug, Clone)]
pub struct TemporalFilter {
    cfg: TemporalConfig,
    zones: usize,
    belief: Vec<f64>,
    started: bool,
}

impl TemporalFilter {
    /// A filter over `zones` zones, starting from a uniform belief.
    pub fn new(zones: usize, cfg: TemporalConfig) -> Self {
        let zones = zones.max(1);
        TemporalFilter {
            cfg,
            zones,
            belief: vec![1.0 / zones as f64; zones],
            started: false,
        }
    }

    /// Forgets the past (a new video).
    pub fn reset(&mut self) {
        self.belief.fill(1.0 / self.zones as f64);
        self.started = false;
    }

    /// The current posterior probability of each zone.
    pub fn belief(&self) -> &[f64] {
        &self.belief
    }

    /// Sets the belief to `zone` with probability `1 − ε` (the rest spread evenly), e.g. when a
    /// frame was localized geometrically and its zone is known; `ε = 0.05`. A zone out of
    /// range is ignored.
    pub fn anchor(&mut self, zone: usize) {
        if zone >= self.zones {
            return;
        }
        const EPS: f64 = 0.05;
        let rest = if self.zones > 1 {
            EPS / (self.zones - 1) as f64
        } else {
            0.0
        };
        self.belief.fill(rest);
        self.belief[zone] = if self.zones > 1 { 1.0 - EPS } else { 1.0 };
        self.started = true;
    }

    /// Folds in one frame's prediction and returns the most probable zone now.
    pub fn update(&mut self, pred: &ZonePrediction) -> usize {
        let n = self.zones;
        let t = Transitions::new(&self.cfg, n);
        let prior: Vec<f64> = if self.started {
            let jump: f64 = self
                .belief
                .iter()
                .enumerate()
                .map(|(i, b)| b * t.jump_each / t.row_norm[i])
                .sum();
            (0..n)
                .map(|j| {
                    let mut s = jump;
                    for i in j.saturating_sub(2)..=(j + 2).min(n - 1) {
                        s += self.belief[i] * t.band[i.abs_diff(j)] / t.row_norm[i];
                    }
                    s
                })
                .collect()
        } else {
            vec![1.0 / n as f64; n]
        };
        let le = log_emission(pred, n, self.cfg.temperature);
        let mut post: Vec<f64> = prior.iter().zip(&le).map(|(p, l)| p * l.exp()).collect();
        let sum: f64 = post.iter().sum();
        if sum > 0.0 && sum.is_finite() {
            for v in post.iter_mut() {
                *v /= sum;
            }
        } else {
            // Numerical underflow: restart from this frame alone.
            post = le.iter().map(|l| l.exp()).collect();
            let s: f64 = post.iter().sum::<f64>().max(1e-300);
            post.iter_mut().for_each(|v| *v /= s);
        }
        self.belief = post;
        self.started = true;
        argmax(&self.belief)
    }
}

fn argmax(v: &[f64]) -> usize {
    v.iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(i, _)| i)
}

/// The most likely zone sequence for a whole video (Viterbi, log domain, `O(frames · zones)`).
pub fn viterbi(preds: &[ZonePrediction], zones: usize, cfg: &TemporalConfig) -> Vec<usize> {
    if preds.is_empty() || zones == 0 {
        return Vec::new();
    }
    let t = Transitions::new(cfg, zones);
    let log_jump: Vec<f64> = (0..zones)
        .map(|i| (t.jump_each / t.row_norm[i]).ln())
        .collect();
    let mut delta: Vec<f64> = log_emission(&preds[0], zones, cfg.temperature)
        .iter()
        .map(|l| l - (zones as f64).ln())
        .collect();
    let mut back: Vec<Vec<u32>> = Vec::with_capacity(preds.len());
    for pred in &preds[1..] {
        // Best jump origin: max_i delta_i + log jump_i.
        let (jump_from, jump_val) = delta
            .iter()
            .zip(&log_jump)
            .map(|(d, j)| d + j)
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, f64::NEG_INFINITY));
        let le = log_emission(pred, zones, cfg.temperature);
        let mut next = vec![0.0; zones];
        let mut bp = vec![0u32; zones];
        for j in 0..zones {
            let (mut best, mut arg) = (jump_val, jump_from);
            let (lo, hi) = (j.saturating_sub(2), (j + 2).min(zones - 1));
            for (i, &d) in delta.iter().enumerate().take(hi + 1).skip(lo) {
                let v = d + t.p(i, j).ln();
                if v > best {
                    best = v;
                    arg = i;
                }
            }
            next[j] = best + le[j];
            bp[j] = arg as u32;
        }
        delta = next;
        back.push(bp);
    }
    let mut path = vec![0usize; preds.len()];
    let mut z = argmax(&delta);
    path[preds.len() - 1] = z;
    for (k, bp) in back.iter().enumerate().rev() {
        z = bp[z] as usize;
        path[k] = z;
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A prediction whose scores favour `zone` (distance 0.2) over the others (0.6).
    fn pred(zone: usize, zones: usize) -> ZonePrediction {
        let mut zone_scores = vec![0.6; zones];
        zone_scores[zone] = 0.2;
        ZonePrediction {
            zone,
            zone_scores,
            nearest_frame: 0,
            distance: 0.2,
            descriptor: Vec::new(),
        }
    }

    #[test]
    fn anchor_overrides_a_wrong_belief() {
        let zones = 10;
        let mut f = TemporalFilter::new(zones, TemporalConfig::default());
        for _ in 0..20 {
            f.update(&pred(2, zones));
        }
        f.anchor(7);
        assert!((f.belief().iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(f.belief()[7] > 0.9);
        // An ambiguous frame now stays at the anchored zone.
        let flat = ZonePrediction {
            zone: 2,
            zone_scores: vec![0.5; zones],
            nearest_frame: 0,
            distance: 0.5,
            descriptor: Vec::new(),
        };
        assert_eq!(f.update(&flat), 7);
        f.anchor(99); // ignored
        assert_eq!(f.belief().len(), zones);
    }

    #[test]
    fn transition_rows_sum_to_one() {
        let cfg = TemporalConfig::default();
        for n in [1, 2, 3, 10] {
            let t = Transitions::new(&cfg, n);
            for i in 0..n {
                let s: f64 = (0..n).map(|j| t.p(i, j)).sum();
                assert!((s - 1.0).abs() < 1e-12, "n {n} row {i}: {s}");
            }
        }
    }

    #[test]
    fn filter_and_viterbi_remove_isolated_outliers_and_follow_real_moves() {
        let zones = 20;
        // True path: zone 5 for 30 frames, then 6 for 30 frames; frames 10 and 40 misclassified
        // as far-away zones (15 and 0).
        let truth: Vec<usize> = (0..60).map(|i| if i < 30 { 5 } else { 6 }).collect();
        let mut raw = truth.clone();
        raw[10] = 15;
        raw[40] = 0;
        let preds: Vec<ZonePrediction> = raw.iter().map(|&z| pred(z, zones)).collect();
        let cfg = TemporalConfig {
            temperature: 0.1,
            ..TemporalConfig::default()
        };
        let mut f = TemporalFilter::new(zones, cfg);
        let causal: Vec<usize> = preds.iter().map(|p| f.update(p)).collect();
        let offline = viterbi(&preds, zones, &cfg);
        assert_eq!(offline, truth);
        // The causal filter cannot see the future: it may lag one or two frames at the real
        // move, but it ignores both outliers.
        assert_eq!(causal[10], 5);
        assert_eq!(causal[40], 6);
        let wrong = causal.iter().zip(&truth).filter(|(a, b)| a != b).count();
        assert!(wrong <= 2, "{causal:?}");
        // A persistent change far away is eventually followed (the jump mass).
        let mut g = TemporalFilter::new(zones, cfg);
        for _ in 0..10 {
            g.update(&pred(3, zones));
        }
        let mut last = 0;
        for _ in 0..10 {
            last = g.update(&pred(17, zones));
        }
        assert_eq!(last, 17);
    }
}
