//! Balanced pair sampling for the Siamese training.
//!
//! Each batch holds as many positive pairs (two images of one zone, label 0) as negative
//! pairs (images of two different zones, label 1). Zones are drawn uniformly (not frames), so
//! short and long zones weigh the same. A fraction of the negatives are *hard*: their two
//! zones are at most `hard_negative_reach` zones apart along the trajectory — the confusions
//! that matter for the ±1-zone accuracy and the localizer's start pose.
//!
//! Two layouts:
//! - **independent** (the paper): every pair has its own two images, `2 · pairs` images per
//!   batch;
//! - **shared** (faster; the default schedule): the batch is a chain of positive pairs
//!   `(f₀, g₀), (f₁, g₁), …` whose zones are neighbours with probability
//!   `hard_negative_fraction`, and the negatives are `(g_k, f_{k+1})`: as many pairs from half
//!   as many images, so each image's forward and backward pass serves two pairs.
//!
//! Two rules ([`PairRule`]): the paper's **zone** pairs above, and **track** pairs drawn by
//! distance along the training pass instead of by zone ([`PairSampler::along_track`]).

use crate::NetError;
use rand::Rng;
use rand::seq::IndexedRandom;
use serde::{Deserialize, Serialize};

/// Places of several colons in one training ([`crate::pretrain`]): the place of frame `f` of
/// colon `c` is `c · COLON_PLACE_STRIDE + f`. Track pairs are drawn within one colon (a
/// negative from the same colon as its partner, where the look-alikes are); a single colon
/// is colon 0, whose places are its frame indices.
pub const COLON_PLACE_STRIDE: usize = 1 << 32;

/// Which pairs the training draws (`[pairs]` of a training config, `endoloc train --pairs`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "rule", rename_all = "snake_case")]
pub enum PairRule {
    /// The paper: a positive pair is two frames of one zone, a negative pair two frames of
    /// different zones.
    #[default]
    Zone,
    /// Along the training pass, blind to zone borders: a positive pair is two images at most
    /// `positive_frames` apart along the (ordered) training sequence — a frame of a further
    /// pass counts at the place of its nearest training pose, so positives also join views
    /// of one place from different passes — a negative pair two images at least
    /// `negative_frames` apart, and a fraction `near_fraction` of the negatives lie
    /// at most `2 · negative_frames` apart. Frames in between are never paired, so two
    /// near-identical views never get opposite labels — which zone pairs do to every pair of
    /// neighbours across a zone border. The descriptor learns to place a frame along the
    /// pass, not only in its zone.
    Track {
        /// Largest frame gap of a positive pair (≥ 1).
        positive_frames: usize,
        /// Smallest frame gap of a negative pair (> `positive_frames`).
        negative_frames: usize,
        /// Fraction of negatives drawn from `negative_frames ..= 2 · negative_frames` frames
        /// away, in `[0, 1]`; the rest anywhere at least `negative_frames` away.
        near_fraction: f32,
        /// Fraction of each batch drawn as zone pairs instead, in `[0, 1)` (default 0).
        #[serde(default)]
        zone_fraction: f32,
    },
}

impl PairRule {
    /// Track pairs with the defaults measured on the simulator's `paper` preset: positives
    /// within 3 frames, negatives 10 or more frames apart, half of them within 20.
    pub fn track() -> Self {
        PairRule::Track {
            positive_frames: 3,
            negative_frames: 10,
            near_fraction: 0.5,
            zone_fraction: 0.0,
        }
    }

    /// Checks the values.
    ///
    /// # Errors
    /// [`NetError::Config`] naming the bad value.
    pub fn validate(&self) -> Result<(), NetError> {
        if let PairRule::Track {
            positive_frames,
            negative_frames,
            near_fraction,
            zone_fraction,
        } = *self
        {
            if !(0.0..1.0).contains(&zone_fraction) {
                return Err(NetError::Config(format!(
                    "pairs: zone_fraction {zone_fraction} must be in [0, 1)"
                )));
            }
            if positive_frames == 0 || negative_frames <= positive_frames {
                return Err(NetError::Config(format!(
                    "pairs: positive_frames {positive_frames} ≥ 1 and negative_frames {negative_frames} > positive_frames expected"
                )));
            }
            if !(0.0..=1.0).contains(&near_fraction) {
                return Err(NetError::Config(format!(
                    "pairs: near_fraction {near_fraction} must be in [0, 1]"
                )));
            }
        }
        Ok(())
    }
}

/// Track-pair state of a [`PairSampler`].
#[derive(Debug, Clone)]
struct TrackPairs {
    /// Usable images as (place along the pass, image), ascending.
    frames: Vec<(usize, usize)>,
    positive: usize,
    negative: usize,
    near: f64,
    /// Fraction of each batch drawn as zone pairs.
    zone_share: f64,
}

impl TrackPairs {
    /// Usable images whose place is within `lo..=hi` (indices into `frames`).
    fn range(&self, lo: usize, hi: usize) -> std::ops::Range<usize> {
        let a = self.frames.partition_point(|&(p, _)| p < lo);
        let b = self.frames.partition_point(|&(p, _)| p <= hi);
        a..b.max(a)
    }

    /// A random usable entry (place, image).
    fn any<R: Rng>(&self, rng: &mut R) -> (usize, usize) {
        self.frames[rng.random_range(0..self.frames.len())]
    }

    /// Another image at most `positive` frames from `(place, image)` (the nearest in place
    /// when none is that close).
    fn positive_of<R: Rng>(&self, (place, image): (usize, usize), rng: &mut R) -> (usize, usize) {
        let r = self.range(place.saturating_sub(self.positive), place + self.positive);
        let near: Vec<(usize, usize)> = self.frames[r]
            .iter()
            .copied()
            .filter(|&(_, i)| i != image)
            .collect();
        if let Some(&e) = near.choose(rng) {
            return e;
        }
        self.frames
            .iter()
            .copied()
            .filter(|&(_, i)| i != image)
            .min_by_key(|&(p, _)| p.abs_diff(place))
            .unwrap_or((place, image))
    }

    /// An image at least `negative` frames from `place` (within `2 · negative` with
    /// probability `near`), from the same colon ([`COLON_PLACE_STRIDE`]). The constructor
    /// ensures one exists for a single colon.
    fn negative_of<R: Rng>(&self, place: usize, rng: &mut R) -> (usize, usize) {
        let n = self.negative;
        let first = place - place % COLON_PLACE_STRIDE;
        let last = first
            .saturating_add(COLON_PLACE_STRIDE - 1)
            .min(usize::MAX - 1);
        let (below, above) = if rng.random_bool(self.near) {
            (
                place
                    .checked_sub(n)
                    .filter(|&hi| hi >= first)
                    .map_or(0..0, |hi| {
                        self.range(place.saturating_sub(2 * n).max(first), hi)
                    }),
                self.range(place + n, (place + 2 * n).min(last)),
            )
        } else {
            (0..0, 0..0)
        };
        let (below, above) = if below.is_empty() && above.is_empty() {
            // Anywhere in the colon at least `n` away.
            (
                place
                    .checked_sub(n)
                    .filter(|&hi| hi >= first)
                    .map_or(0..0, |hi| self.range(first, hi)),
                self.range(place + n, last),
            )
        } else {
            (below, above)
        };
        let count = below.len() + above.len();
        if count == 0 {
            return self.any(rng);
        }
        let k = rng.random_range(0..count);
        if k < below.len() {
            self.frames[below.start + k]
        } else {
            self.frames[above.start + k - below.len()]
        }
    }
}

/// One batch of pairs: the images to run through the network and the pairs among them.
#[derive(Debug, Clone, PartialEq)]
pub struct PairBatch {
    /// Image of each batch row (training frame, or a further pass's frame after them).
    pub images: Vec<usize>,
    /// Row of the first image of each pair.
    pub a: Vec<usize>,
    /// Row of the second image of each pair.
    pub b: Vec<usize>,
    /// Pair label (the paper's `x`): 0 = alike (same zone; track pairs: near along the
    /// pass), 1 = different (other zones; track pairs: far along the pass).
    pub dissimilar: Vec<f32>,
}

/// Draws pairs from the frames of each zone ([`PairSampler::new`]) or by place along the
/// training pass ([`PairSampler::along_track`]).
#[derive(Debug, Clone)]
pub struct PairSampler {
    /// Usable frames of each zone (zone index = position).
    zone_frames: Vec<Vec<usize>>,
    /// Zones with at least two frames (can give a positive pair).
    pos_zones: Vec<usize>,
    /// Zones with at least one frame.
    any_zones: Vec<usize>,
    hard_fraction: f64,
    hard_reach: usize,
    /// Set for [`PairRule::Track`]: pairs by frame distance instead of zones.
    track: Option<TrackPairs>,
}

impl PairSampler {
    /// A sampler over `zone_frames[z]` = the training frames of zone `z` that may be used.
    ///
    /// # Errors
    /// [`NetError::Zoning`] when fewer than two zones have frames or no zone has two frames.
    pub fn new(
        zone_frames: Vec<Vec<usize>>,
        hard_negative_fraction: f32,
        hard_negative_reach: usize,
    ) -> Result<Self, NetError> {
        let pos_zones: Vec<usize> = (0..zone_frames.len())
            .filter(|&z| zone_frames[z].len() >= 2)
            .collect();
        let any_zones: Vec<usize> = (0..zone_frames.len())
            .filter(|&z| !zone_frames[z].is_empty())
            .collect();
        if any_zones.len() < 2 {
            return Err(NetError::Zoning(format!(
                "training needs frames in at least 2 zones to form negative pairs; {} zone(s) have frames",
                any_zones.len()
            )));
        }
        if pos_zones.is_empty() {
            return Err(NetError::Zoning(
                "training needs a zone with at least 2 frames to form positive pairs; every zone has one frame (ask for fewer zones)".into(),
            ));
        }
        Ok(PairSampler {
            zone_frames,
            pos_zones,
            any_zones,
            hard_fraction: hard_negative_fraction.clamp(0.0, 1.0) as f64,
            hard_reach: hard_negative_reach.max(1),
            track: None,
        })
    }

    /// A sampler of [`PairRule::Track`] pairs over usable images given as `(place, image)`:
    /// the image's place along the training pass (its frame index, or for a frame of another
    /// pass the nearest training frame) and its index in the batch source. Zone pairs come
    /// from [`PairSampler::new`].
    ///
    /// # Errors
    /// [`NetError::Config`] for a rule other than `Track` or bad values;
    /// [`NetError::Zoning`] when the usable frames span fewer than `2 · negative_frames`
    /// frames (some frame would have no negative partner).
    pub fn along_track(mut frames: Vec<(usize, usize)>, rule: PairRule) -> Result<Self, NetError> {
        rule.validate()?;
        let PairRule::Track {
            positive_frames,
            negative_frames,
            near_fraction,
            zone_fraction,
        } = rule
        else {
            return Err(NetError::Config(
                "PairSampler::along_track takes a track pair rule".into(),
            ));
        };
        frames.sort_unstable();
        frames.dedup();
        let span = match (frames.first(), frames.last()) {
            (Some(a), Some(b)) => b.0 - a.0,
            _ => 0,
        };
        if span < 2 * negative_frames {
            return Err(NetError::Zoning(format!(
                "track pairs need a pass spanning at least 2 × negative_frames = {} frames; the usable frames span {span}",
                2 * negative_frames
            )));
        }
        Ok(PairSampler {
            zone_frames: Vec::new(),
            pos_zones: Vec::new(),
            any_zones: Vec::new(),
            hard_fraction: 0.0,
            hard_reach: 1,
            track: Some(TrackPairs {
                frames,
                positive: positive_frames,
                negative: negative_frames,
                near: near_fraction as f64,
                zone_share: zone_fraction as f64,
            }),
        })
    }

    /// Adds the zone pairs that a track rule's `zone_fraction` asks for, drawn from
    /// `zone_frames` as [`PairSampler::new`] does (no hard negatives).
    ///
    /// # Errors
    /// Those of [`PairSampler::new`].
    pub fn with_zone_pairs(self, zone_frames: Vec<Vec<usize>>) -> Result<Self, NetError> {
        let zones = PairSampler::new(zone_frames, 0.0, 1)?;
        Ok(PairSampler {
            track: self.track,
            ..zones
        })
    }

    fn frame<R: Rng>(&self, zone: usize, rng: &mut R) -> usize {
        *self.zone_frames[zone].choose(rng).unwrap_or(&0)
    }

    fn two_frames<R: Rng>(&self, zone: usize, rng: &mut R) -> (usize, usize) {
        let f = &self.zone_frames[zone];
        let i = rng.random_range(0..f.len());
        let mut j = rng.random_range(0..f.len() - 1);
        if j >= i {
            j += 1;
        }
        (f[i], f[j])
    }

    /// A zone different from `z`: a neighbour within the reach (hard) or any other zone,
    /// restricted to `candidates`.
    fn other_zone<R: Rng>(&self, z: usize, candidates: &[usize], rng: &mut R) -> usize {
        if rng.random_bool(self.hard_fraction) {
            let near: Vec<usize> = candidates
                .iter()
                .copied()
                .filter(|&c| c != z && c.abs_diff(z) <= self.hard_reach)
                .collect();
            if let Some(&c) = near.choose(rng) {
                return c;
            }
        }
        loop {
            let c = *candidates.choose(rng).unwrap_or(&z);
            if c != z || candidates.len() < 2 {
                return c;
            }
        }
    }

    /// A batch of `pairs` pairs (half positive, half negative; an odd count gets one more
    /// positive).
    pub fn batch<R: Rng>(&self, pairs: usize, shared: bool, rng: &mut R) -> PairBatch {
        let Some(t) = &self.track else {
            return self.zone_batch(pairs, shared, rng);
        };
        let zone_pairs = if self.any_zones.len() >= 2 && !self.pos_zones.is_empty() {
            ((pairs as f64 * t.zone_share).round() as usize).min(pairs.saturating_sub(2))
        } else {
            0
        };
        let track_pairs = pairs - zone_pairs;
        let mut out = PairBatch {
            images: Vec::with_capacity(2 * pairs),
            a: Vec::with_capacity(pairs),
            b: Vec::with_capacity(pairs),
            dissimilar: Vec::with_capacity(pairs),
        };
        track_batch(
            t,
            track_pairs.div_ceil(2),
            track_pairs / 2,
            shared,
            rng,
            &mut out,
        );
        if zone_pairs >= 2 {
            let z = self.zone_batch(zone_pairs, shared, rng);
            let offset = out.images.len();
            out.images.extend(z.images);
            out.a.extend(z.a.iter().map(|i| i + offset));
            out.b.extend(z.b.iter().map(|i| i + offset));
            out.dissimilar.extend(z.dissimilar);
        }
        out
    }

    /// Zone pairs ([`PairRule::Zone`]).
    fn zone_batch<R: Rng>(&self, pairs: usize, shared: bool, rng: &mut R) -> PairBatch {
        let n_pos = pairs.div_ceil(2);
        let n_neg = pairs / 2;
        let mut out = PairBatch {
            images: Vec::with_capacity(2 * pairs),
            a: Vec::with_capacity(pairs),
            b: Vec::with_capacity(pairs),
            dissimilar: Vec::with_capacity(pairs),
        };
        if shared && self.pos_zones.len() >= 2 {
            // Chain of positive pairs whose consecutive zones differ.
            let mut zones = Vec::with_capacity(n_pos.max(n_neg + 1));
            let chain = n_pos.max(n_neg + 1);
            let mut z = *self.pos_zones.choose(rng).unwrap_or(&0);
            for _ in 0..chain {
                zones.push(z);
                z = self.other_zone(z, &self.pos_zones, rng);
            }
            for (k, &z) in zones.iter().enumerate() {
                let (f, g) = self.two_frames(z, rng);
                out.images.push(f);
                out.images.push(g);
                if k < n_pos {
                    out.a.push(2 * k);
                    out.b.push(2 * k + 1);
                    out.dissimilar.push(0.0);
                }
            }
            for k in 0..n_neg {
                out.a.push(2 * k + 1);
                out.b.push(2 * (k + 1));
                out.dissimilar.push(1.0);
            }
        } else {
            for _ in 0..n_pos {
                let z = *self.pos_zones.choose(rng).unwrap_or(&0);
                let (f, g) = self.two_frames(z, rng);
                out.a.push(out.images.len());
                out.images.push(f);
                out.b.push(out.images.len());
                out.images.push(g);
                out.dissimilar.push(0.0);
            }
            for _ in 0..n_neg {
                let z = *self.any_zones.choose(rng).unwrap_or(&0);
                let z2 = self.other_zone(z, &self.any_zones, rng);
                out.a.push(out.images.len());
                out.images.push(self.frame(z, rng));
                out.b.push(out.images.len());
                out.images.push(self.frame(z2, rng));
                out.dissimilar.push(1.0);
            }
        }
        out
    }
}

/// [`PairSampler::batch`] for track pairs; the same two layouts as zone pairs.
fn track_batch<R: Rng>(
    t: &TrackPairs,
    n_pos: usize,
    n_neg: usize,
    shared: bool,
    rng: &mut R,
    out: &mut PairBatch,
) {
    if shared {
        // Chain f₀ g₀ f₁ g₁ …: (f_k, g_k) positive, (g_k, f_{k+1}) negative.
        let chain = n_pos.max(n_neg + 1);
        let mut f = t.any(rng);
        for k in 0..chain {
            let g = t.positive_of(f, rng);
            out.images.push(f.1);
            out.images.push(g.1);
            if k < n_pos {
                out.a.push(2 * k);
                out.b.push(2 * k + 1);
                out.dissimilar.push(0.0);
            }
            f = t.negative_of(g.0, rng);
        }
        for k in 0..n_neg {
            out.a.push(2 * k + 1);
            out.b.push(2 * (k + 1));
            out.dissimilar.push(1.0);
        }
    } else {
        for (count, label) in [(n_pos, 0.0), (n_neg, 1.0)] {
            for _ in 0..count {
                let f = t.any(rng);
                let g = if label == 0.0 {
                    t.positive_of(f, rng)
                } else {
                    t.negative_of(f.0, rng)
                };
                out.a.push(out.images.len());
                out.images.push(f.1);
                out.b.push(out.images.len());
                out.images.push(g.1);
                out.dissimilar.push(label);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn zone_of(frames: &[Vec<usize>], f: usize) -> usize {
        frames.iter().position(|z| z.contains(&f)).unwrap()
    }

    #[test]
    fn batches_are_balanced_and_labels_are_true_in_both_layouts() {
        let zf: Vec<Vec<usize>> = (0..10).map(|z| (z * 10..z * 10 + 10).collect()).collect();
        let s = PairSampler::new(zf.clone(), 0.5, 2).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for shared in [false, true] {
            let mut hard = 0;
            let mut neg = 0;
            for _ in 0..50 {
                let b = s.batch(64, shared, &mut rng);
                assert_eq!(b.a.len(), 64);
                assert_eq!(b.dissimilar.iter().filter(|&&d| d == 0.0).count(), 32);
                let expected_images = if shared { 66 } else { 128 };
                assert_eq!(b.images.len(), expected_images);
                for k in 0..64 {
                    let (fa, fb) = (b.images[b.a[k]], b.images[b.b[k]]);
                    let (za, zb) = (zone_of(&zf, fa), zone_of(&zf, fb));
                    if b.dissimilar[k] == 0.0 {
                        assert_eq!(za, zb);
                        assert_ne!(fa, fb, "a positive pair of one image teaches nothing");
                    } else {
                        assert_ne!(za, zb);
                        neg += 1;
                        if za.abs_diff(zb) <= 2 {
                            hard += 1;
                        }
                    }
                }
            }
            // Half the negatives are hard by construction, plus uniform draws that land near.
            let frac = hard as f64 / neg as f64;
            assert!(frac > 0.5 && frac < 0.8, "hard fraction {frac}");
        }
    }

    #[test]
    fn impossible_pairings_are_clear_errors() {
        let err = PairSampler::new(vec![vec![0, 1, 2]], 0.5, 2)
            .unwrap_err()
            .to_string();
        assert!(err.contains("at least 2 zones"), "{err}");
        let err = PairSampler::new(vec![vec![0], vec![1]], 0.5, 2)
            .unwrap_err()
            .to_string();
        assert!(err.contains("at least 2 frames"), "{err}");
    }

    #[test]
    fn track_pairs_respect_the_frame_gaps_and_skip_held_frames() {
        // Every fifth frame held out, as validation does.
        let frames: Vec<usize> = (0..300).filter(|f| f % 5 != 2).collect();
        let rule = PairRule::Track {
            positive_frames: 3,
            negative_frames: 10,
            near_fraction: 0.5,
            zone_fraction: 0.0,
        };
        let s = PairSampler::along_track(frames.iter().map(|&f| (f, f)).collect(), rule).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for shared in [false, true] {
            let (mut neg, mut near) = (0, 0);
            for _ in 0..40 {
                let b = s.batch(64, shared, &mut rng);
                assert_eq!(b.a.len(), 64);
                assert_eq!(b.dissimilar.iter().filter(|&&d| d == 0.0).count(), 32);
                assert!(
                    b.images.iter().all(|f| frames.contains(f)),
                    "held frame used"
                );
                for k in 0..64 {
                    let gap = b.images[b.a[k]].abs_diff(b.images[b.b[k]]);
                    if b.dissimilar[k] == 0.0 {
                        assert!((1..=3).contains(&gap), "positive gap {gap}");
                    } else {
                        assert!(gap >= 10, "negative gap {gap}");
                        neg += 1;
                        if gap <= 20 {
                            near += 1;
                        }
                    }
                }
            }
            // Half near by construction, plus the few uniform draws that land within 20.
            let frac = near as f64 / neg as f64;
            assert!(frac > 0.45 && frac < 0.62, "near fraction {frac}");
        }
    }

    #[test]
    fn track_pairs_of_several_colons_stay_within_a_colon() {
        // Three colons of 200 frames; a colon's images are numbered after the previous ones.
        let frames: Vec<(usize, usize)> = (0..3)
            .flat_map(|c| (0..200).map(move |f| (c * COLON_PLACE_STRIDE + f, c * 200 + f)))
            .collect();
        let place_of = |image: usize| frames[image].0;
        let rule = PairRule::Track {
            positive_frames: 3,
            negative_frames: 10,
            near_fraction: 0.1,
            zone_fraction: 0.0,
        };
        let s = PairSampler::along_track(frames.clone(), rule).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut colons_seen = [0usize; 3];
        for shared in [false, true] {
            for _ in 0..40 {
                let b = s.batch(64, shared, &mut rng);
                for k in 0..b.a.len() {
                    let (pa, pb) = (place_of(b.images[b.a[k]]), place_of(b.images[b.b[k]]));
                    let (ca, cb) = (pa / COLON_PLACE_STRIDE, pb / COLON_PLACE_STRIDE);
                    assert_eq!(ca, cb, "a pair across colons: places {pa} and {pb}");
                    colons_seen[ca] += 1;
                    let gap = pa.abs_diff(pb);
                    if b.dissimilar[k] == 0.0 {
                        assert!(gap <= 3, "positive gap {gap}");
                    } else {
                        assert!((10..200).contains(&gap), "negative gap {gap}");
                    }
                }
            }
        }
        // Every colon is drawn, about equally (pairs are drawn by frame).
        assert!(colons_seen.iter().all(|&n| n > 1000), "{colons_seen:?}");
    }

    #[test]
    fn track_pairs_refuse_short_passes_and_bad_gaps() {
        let rule = PairRule::track();
        let err = PairSampler::along_track((0..15).map(|f| (f, f)).collect(), rule)
            .unwrap_err()
            .to_string();
        assert!(err.contains("at least 2 × negative_frames = 20"), "{err}");
        let bad = PairRule::Track {
            positive_frames: 5,
            negative_frames: 5,
            near_fraction: 0.5,
            zone_fraction: 0.0,
        };
        let err = PairSampler::along_track((0..100).map(|f| (f, f)).collect(), bad)
            .unwrap_err()
            .to_string();
        assert!(err.contains("negative_frames 5 > positive_frames"), "{err}");
        let err = PairSampler::along_track((0..100).map(|f| (f, f)).collect(), PairRule::Zone)
            .unwrap_err()
            .to_string();
        assert!(err.contains("track pair rule"), "{err}");
    }

    #[test]
    fn pair_rule_reads_from_toml() {
        #[derive(Deserialize)]
        struct W {
            pairs: PairRule,
        }
        let w: W = toml::from_str(
            "[pairs]\nrule = \"track\"\npositive_frames = 2\nnegative_frames = 8\nnear_fraction = 0.25\n",
        )
        .unwrap();
        assert_eq!(
            w.pairs,
            PairRule::Track {
                positive_frames: 2,
                negative_frames: 8,
                near_fraction: 0.25,
                zone_fraction: 0.0,
            }
        );
        let w: W = toml::from_str("[pairs]\nrule = \"zone\"\n").unwrap();
        assert_eq!(w.pairs, PairRule::Zone);
    }

    #[test]
    fn track_pairs_join_passes_by_their_place_along_the_training_pass() {
        // Images 0..100 are the training pass; images 100..200 another pass, image 100 + k
        // nearest to training frame k.
        let frames: Vec<(usize, usize)> = (0..100)
            .map(|f| (f, f))
            .chain((0..100).map(|k| (k, 100 + k)))
            .collect();
        let place = |i: usize| if i >= 100 { i - 100 } else { i };
        let s = PairSampler::along_track(frames, PairRule::track()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let (mut positives, mut across) = (0, 0);
        for _ in 0..20 {
            let b = s.batch(64, true, &mut rng);
            for k in 0..64 {
                let (i, j) = (b.images[b.a[k]], b.images[b.b[k]]);
                let gap = place(i).abs_diff(place(j));
                if b.dissimilar[k] == 0.0 {
                    assert!(gap <= 3 && i != j, "positive {i} {j}");
                    positives += 1;
                    if (i >= 100) != (j >= 100) {
                        across += 1;
                    }
                } else {
                    assert!(gap >= 10, "negative {i} {j}");
                }
            }
        }
        // About half the partners of an image come from the other pass.
        let frac = across as f64 / positives as f64;
        assert!(frac > 0.35 && frac < 0.65, "across passes {frac}");
    }

    #[test]
    fn mixed_batches_hold_track_pairs_then_the_asked_share_of_zone_pairs() {
        let zf: Vec<Vec<usize>> = (0..10).map(|z| (z * 30..z * 30 + 30).collect()).collect();
        let rule = PairRule::Track {
            positive_frames: 3,
            negative_frames: 10,
            near_fraction: 0.5,
            zone_fraction: 0.25,
        };
        let s = PairSampler::along_track((0..300).map(|f| (f, f)).collect(), rule)
            .unwrap()
            .with_zone_pairs(zf)
            .unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for shared in [false, true] {
            let b = s.batch(64, shared, &mut rng);
            assert_eq!(b.a.len(), 64);
            assert_eq!(b.dissimilar.iter().filter(|&&d| d == 0.0).count(), 32);
            for k in 0..64 {
                let (i, j) = (b.images[b.a[k]], b.images[b.b[k]]);
                let same = b.dissimilar[k] == 0.0;
                if k < 48 {
                    let gap = i.abs_diff(j);
                    assert!(if same { gap <= 3 } else { gap >= 10 }, "track pair {k}");
                } else {
                    assert_eq!(i / 30 == j / 30, same, "zone pair {k}: {i} {j}");
                }
            }
        }
    }
}
