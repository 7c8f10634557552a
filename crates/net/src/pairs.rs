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

use crate::NetError;
use rand::Rng;
use rand::seq::IndexedRandom;

/// One batch of pairs: the images to run through the network and the pairs among them.
#[derive(Debug, Clone, PartialEq)]
pub struct PairBatch {
    /// Training frame of each batch row.
    pub images: Vec<usize>,
    /// Row of the first image of each pair.
    pub a: Vec<usize>,
    /// Row of the second image of each pair.
    pub b: Vec<usize>,
    /// Pair label: 0 = same zone, 1 = different zones (the paper's `x`).
    pub dissimilar: Vec<f32>,
}

/// Draws pairs from the frames of each zone.
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
}
