//! Brute-force descriptor matching: L2 distance, Lowe's ratio test, mutual-nearest check and
//! Laplacian-sign gating. One API for image↔image and image↔map-point matching: anything
//! that implements [`Describe`] (a descriptor and a Laplacian sign) can be matched.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{Describe, FeatureError};

/// Parameters of the [`Matcher`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatcherConfig {
    /// Lowe's ratio: keep a match when `d1 < ratio · d2` (L2 distances to the nearest and
    /// second-nearest candidate). 1.0 disables the test. Default 0.8. Range (0, 1].
    pub ratio: f32,
    /// Keep a match only when the query is also the train item's nearest query. Default true.
    pub mutual: bool,
    /// Only compare items whose Laplacian signs agree (0 = unknown agrees with both): bright
    /// blobs never match dark ones. Default true.
    pub laplacian_gating: bool,
    /// Largest accepted L2 distance between unit descriptors (∞ = none). Default ∞.
    pub max_distance: f32,
    /// Spread the work over all rayon threads. Same result either way. Default true.
    pub parallel: bool,
}

impl Default for MatcherConfig {
    fn default() -> Self {
        Self {
            ratio: 0.8,
            mutual: true,
            laplacian_gating: true,
            max_distance: f32::INFINITY,
            parallel: true,
        }
    }
}

impl MatcherConfig {
    /// Sets [`MatcherConfig::ratio`].
    pub fn with_ratio(mut self, ratio: f32) -> Self {
        self.ratio = ratio;
        self
    }
    /// Sets [`MatcherConfig::mutual`].
    pub fn with_mutual(mut self, mutual: bool) -> Self {
        self.mutual = mutual;
        self
    }
    /// Sets [`MatcherConfig::laplacian_gating`].
    pub fn with_laplacian_gating(mut self, gating: bool) -> Self {
        self.laplacian_gating = gating;
        self
    }
    /// Sets [`MatcherConfig::max_distance`].
    pub fn with_max_distance(mut self, max_distance: f32) -> Self {
        self.max_distance = max_distance;
        self
    }
    /// Sets [`MatcherConfig::parallel`].
    pub fn with_parallel(mut self, parallel: bool) -> Self {
        self.parallel = parallel;
        self
    }
}

/// One accepted correspondence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Match {
    /// Index into the query slice.
    pub query: usize,
    /// Index into the train slice.
    pub train: usize,
    /// L2 distance between the two descriptors (unit descriptors: 0..2).
    pub distance: f32,
}

/// Brute-force matcher.
///
/// ```
/// use endoloc_features::{Feature, Keypoint, Matcher, MatcherConfig};
/// let kp = Keypoint { x: 0.0, y: 0.0, scale: 2.0, orientation: 0.0, response: 300.0, laplacian: 1, octave: 0 };
/// let f = |d: [f32; 2]| Feature { keypoint: kp, descriptor: d.to_vec() };
/// let query = [f([1.0, 0.0]), f([0.0, 1.0])];
/// let train = [f([0.0, 1.0]), f([0.9, 0.1])];
/// let matches = Matcher::new(MatcherConfig::default()).match_descriptors(&query, &train)?;
/// assert_eq!((matches[0].query, matches[0].train), (0, 1));
/// assert_eq!((matches[1].query, matches[1].train), (1, 0));
/// # Ok::<(), endoloc_features::FeatureError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Matcher {
    config: MatcherConfig,
}

/// Nearest and second-nearest squared distances.
#[derive(Clone, Copy)]
struct Nearest {
    best: usize,
    d1: f32,
    d2: f32,
}

impl Matcher {
    /// Builds a matcher.
    pub fn new(config: MatcherConfig) -> Self {
        Self { config }
    }

    /// The configuration.
    pub fn config(&self) -> &MatcherConfig {
        &self.config
    }

    /// Matches every query item to its nearest train item and keeps those passing the
    /// configured tests; sorted by query index.
    ///
    /// # Errors
    /// [`FeatureError::InvalidConfig`] for a ratio outside (0, 1];
    /// [`FeatureError::DescriptorLength`] when descriptors differ in length.
    pub fn match_descriptors<Q: Describe + Sync, T: Describe + Sync>(
        &self,
        query: &[Q],
        train: &[T],
    ) -> Result<Vec<Match>, FeatureError> {
        let cfg = &self.config;
        if !(cfg.ratio > 0.0 && cfg.ratio <= 1.0) {
            return Err(FeatureError::InvalidConfig {
                field: "ratio",
                reason: format!("is {}, expected a value in (0, 1]", cfg.ratio),
            });
        }
        let Some(first) = query.first() else {
            return Ok(Vec::new());
        };
        let dim = first.descriptor().len();
        check_lengths(query, dim, "query")?;
        check_lengths(train, dim, "train")?;
        let q_flat = flatten(query, dim);
        let t_flat = flatten(train, dim);
        let q_sign: Vec<i8> = query.iter().map(|q| q.laplacian()).collect();
        let t_sign: Vec<i8> = train.iter().map(|t| t.laplacian()).collect();
        let gating = cfg.laplacian_gating;

        let forward = nearest_all(
            &q_flat,
            &q_sign,
            &t_flat,
            &t_sign,
            dim,
            gating,
            cfg.parallel,
        );
        let backward = if cfg.mutual {
            Some(nearest_all(
                &t_flat,
                &t_sign,
                &q_flat,
                &q_sign,
                dim,
                gating,
                cfg.parallel,
            ))
        } else {
            None
        };
        let ratio2 = cfg.ratio * cfg.ratio;
        let max2 = cfg.max_distance * cfg.max_distance;
        let mut out = Vec::new();
        for (qi, n) in forward.iter().enumerate() {
            let Some(n) = n else { continue };
            if cfg.ratio < 1.0 && n.d1 >= ratio2 * n.d2 {
                continue;
            }
            if n.d1 > max2 {
                continue;
            }
            if let Some(back) = &backward
                && back[n.best].map(|b| b.best) != Some(qi)
            {
                continue;
            }
            out.push(Match {
                query: qi,
                train: n.best,
                distance: n.d1.sqrt(),
            });
        }
        Ok(out)
    }
}

fn check_lengths<D: Describe>(
    items: &[D],
    dim: usize,
    which: &'static str,
) -> Result<(), FeatureError> {
    match items.iter().position(|d| d.descriptor().len() != dim) {
        Some(index) => Err(FeatureError::DescriptorLength {
            which,
            index,
            expected: dim,
            actual: items[index].descriptor().len(),
        }),
        None => Ok(()),
    }
}

fn flatten<D: Describe>(items: &[D], dim: usize) -> Vec<f32> {
    let mut v = Vec::with_capacity(items.len() * dim);
    for d in items {
        v.extend_from_slice(d.descriptor());
    }
    v
}

fn signs_agree(a: i8, b: i8) -> bool {
    a == 0 || b == 0 || a == b
}

#[inline]
fn sq_dist(a: &[f32], b: &[f32]) -> f32 {
    // Eight independent accumulators let the compiler vectorise.
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            let d = x[k] - y[k];
            acc[k] += d * d;
        }
    }
    let mut s: f32 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += (x - y) * (x - y);
    }
    s
}

/// For each row of `a`, the nearest and second-nearest rows of `b` (squared L2).
fn nearest_all(
    a: &[f32],
    a_sign: &[i8],
    b: &[f32],
    b_sign: &[i8],
    dim: usize,
    gating: bool,
    parallel: bool,
) -> Vec<Option<Nearest>> {
    let one = |(ai, row): (usize, &[f32])| -> Option<Nearest> {
        let mut n = Nearest {
            best: usize::MAX,
            d1: f32::INFINITY,
            d2: f32::INFINITY,
        };
        for (bi, other) in b.chunks_exact(dim).enumerate() {
            if gating && !signs_agree(a_sign[ai], b_sign[bi]) {
                continue;
            }
            let d = sq_dist(row, other);
            if d < n.d1 {
                n.d2 = n.d1;
                n.d1 = d;
                n.best = bi;
            } else if d < n.d2 {
                n.d2 = d;
            }
        }
        (n.best != usize::MAX).then_some(n)
    };
    if dim == 0 {
        return vec![None; a_sign.len()];
    }
    if parallel {
        a.par_chunks_exact(dim).enumerate().map(one).collect()
    } else {
        a.chunks_exact(dim).enumerate().map(one).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Feature, Keypoint};

    fn feat(d: &[f32], lap: i8) -> Feature {
        Feature {
            keypoint: Keypoint {
                x: 0.0,
                y: 0.0,
                scale: 2.0,
                orientation: 0.0,
                response: 1.0,
                laplacian: lap,
                octave: 0,
            },
            descriptor: d.to_vec(),
        }
    }

    #[test]
    fn ratio_test_rejects_ambiguous_matches() {
        let q = [feat(&[1.0, 0.0], 1)];
        let t = [feat(&[0.9, 0.1], 1), feat(&[0.88, 0.12], 1)];
        let m = Matcher::new(MatcherConfig::default())
            .match_descriptors(&q, &t)
            .unwrap();
        assert!(m.is_empty());
        let m = Matcher::new(MatcherConfig::default().with_ratio(1.0))
            .match_descriptors(&q, &t)
            .unwrap();
        assert_eq!(m.len(), 1);
    }

    #[test]
    fn laplacian_gating_skips_opposite_signs() {
        let q = [feat(&[1.0, 0.0], 1)];
        let t = [feat(&[1.0, 0.0], -1), feat(&[0.0, 1.0], 1)];
        let m = Matcher::new(MatcherConfig::default())
            .match_descriptors(&q, &t)
            .unwrap();
        assert_eq!(m[0].train, 1);
        let off = MatcherConfig::default().with_laplacian_gating(false);
        let m = Matcher::new(off).match_descriptors(&q, &t).unwrap();
        assert_eq!(m[0].train, 0);
    }

    #[test]
    fn mutual_check_drops_one_sided_matches() {
        // Both queries prefer train 0; train 0 prefers query 0.
        let q = [feat(&[1.0, 0.0], 1), feat(&[0.8, 0.6], 1)];
        let t = [feat(&[0.95, 0.3], 1), feat(&[-1.0, 0.0], 1)];
        let cfg = MatcherConfig::default().with_ratio(1.0);
        let m = Matcher::new(cfg.clone()).match_descriptors(&q, &t).unwrap();
        assert_eq!(
            m.iter().map(|m| (m.query, m.train)).collect::<Vec<_>>(),
            [(0, 0)]
        );
        let m = Matcher::new(cfg.with_mutual(false))
            .match_descriptors(&q, &t)
            .unwrap();
        assert_eq!(m.len(), 2);
    }

    #[test]
    fn mixed_descriptor_lengths_are_a_clear_error() {
        let q = [feat(&[1.0; 64], 1)];
        let t = [feat(&[1.0; 64], 1), feat(&[1.0; 128], 1)];
        let e = Matcher::new(MatcherConfig::default())
            .match_descriptors(&q, &t)
            .unwrap_err();
        assert_eq!(
            e,
            FeatureError::DescriptorLength {
                which: "train",
                index: 1,
                expected: 64,
                actual: 128
            }
        );
        assert!(
            Matcher::new(MatcherConfig::default().with_ratio(0.0))
                .match_descriptors(&q, &t)
                .is_err()
        );
    }

    #[test]
    fn parallel_and_serial_agree() {
        let mk = |seed: usize| -> Vec<Feature> {
            (0..300)
                .map(|i| {
                    let d: Vec<f32> = (0..64)
                        .map(|k| (((i * 31 + k * 17 + seed) % 97) as f32).sin())
                        .collect();
                    feat(&d, if i % 3 == 0 { -1 } else { 1 })
                })
                .collect()
        };
        let (q, t) = (mk(1), mk(5));
        let a = Matcher::new(MatcherConfig::default().with_ratio(0.95))
            .match_descriptors(&q, &t)
            .unwrap();
        let b = Matcher::new(
            MatcherConfig::default()
                .with_ratio(0.95)
                .with_parallel(false),
        )
        .match_descriptors(&q, &t)
        .unwrap();
        assert_eq!(a, b);
    }
}
