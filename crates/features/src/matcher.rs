//! Brute-force descriptor matching: L2 distance, Lowe's ratio test, mutual-nearest check and
//! Laplacian-sign gating. One API for image↔image and image↔map-point matching: anything
//! that implements [`Describe`] (a descriptor and a Laplacian sign) can be matched.
//!
//! Distances come from one matrix product per block of queries:
//! `‖q − t‖² = ‖q‖² + ‖t‖² − 2 q·t`, with `q·t` from `matrixmultiply`'s SGEMM (AVX2/FMA
//! kernels chosen at run time). One pass over the product gives both directions: each query's
//! nearest and second-nearest train item, and each train item's nearest query (the mutual
//! check). [`Matcher::match_descriptors_naive`] is the plain double loop, kept as the
//! reference for tests and benchmarks (`cargo bench -p endoloc-features --bench surf -- match`).

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
        let Some(f) = Flat::new(cfg, query, train)? else {
            return Ok(Vec::new());
        };
        let (forward, backward) = nearest_both(
            &f.q,
            &f.q_sign,
            &f.t,
            &f.t_sign,
            f.dim,
            cfg.laplacian_gating,
            cfg.parallel,
        );
        Ok(self.accept(&forward, cfg.mutual.then_some(&backward[..])))
    }

    /// [`Matcher::match_descriptors`] by the plain double loop over descriptor pairs (twice
    /// with the mutual check): the reference the fast path is tested and benchmarked against.
    /// Same matches, up to ties between distances that differ by float rounding.
    ///
    /// # Errors
    /// As [`Matcher::match_descriptors`].
    pub fn match_descriptors_naive<Q: Describe + Sync, T: Describe + Sync>(
        &self,
        query: &[Q],
        train: &[T],
    ) -> Result<Vec<Match>, FeatureError> {
        let cfg = &self.config;
        let Some(f) = Flat::new(cfg, query, train)? else {
            return Ok(Vec::new());
        };
        let gating = cfg.laplacian_gating;

        let forward = nearest_all(
            &f.q,
            &f.q_sign,
            &f.t,
            &f.t_sign,
            f.dim,
            gating,
            cfg.parallel,
        );
        let backward = if cfg.mutual {
            Some(nearest_all(
                &f.t,
                &f.t_sign,
                &f.q,
                &f.q_sign,
                f.dim,
                gating,
                cfg.parallel,
            ))
        } else {
            None
        };
        let backward: Option<Vec<Option<usize>>> =
            backward.map(|b| b.iter().map(|n| n.map(|n| n.best)).collect());
        Ok(self.accept(&forward, backward.as_deref()))
    }

    /// The ratio, distance and mutual tests over the nearest neighbours.
    fn accept(
        &self,
        forward: &[Option<Nearest>],
        backward: Option<&[Option<usize>]>,
    ) -> Vec<Match> {
        let cfg = &self.config;
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
            if let Some(back) = backward
                && back[n.best] != Some(qi)
            {
                continue;
            }
            out.push(Match {
                query: qi,
                train: n.best,
                distance: n.d1.sqrt(),
            });
        }
        out
    }
}

/// Query and train descriptors as flat row-major arrays, with their Laplacian signs.
struct Flat {
    dim: usize,
    q: Vec<f32>,
    q_sign: Vec<i8>,
    t: Vec<f32>,
    t_sign: Vec<i8>,
}

impl Flat {
    /// Checks the ratio and the descriptor lengths and flattens both sides; `None` for an
    /// empty query.
    fn new<Q: Describe, T: Describe>(
        cfg: &MatcherConfig,
        query: &[Q],
        train: &[T],
    ) -> Result<Option<Self>, FeatureError> {
        if !(cfg.ratio > 0.0 && cfg.ratio <= 1.0) {
            return Err(FeatureError::InvalidConfig {
                field: "ratio",
                reason: format!("is {}, expected a value in (0, 1]", cfg.ratio),
            });
        }
        let Some(first) = query.first() else {
            return Ok(None);
        };
        let dim = first.descriptor().len();
        check_lengths(query, dim, "query")?;
        check_lengths(train, dim, "train")?;
        Ok(Some(Flat {
            dim,
            q: flatten(query, dim),
            q_sign: query.iter().map(|q| q.laplacian()).collect(),
            t: flatten(train, dim),
            t_sign: train.iter().map(|t| t.laplacian()).collect(),
        }))
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

fn sign_slot(s: i8) -> usize {
    (s.signum() + 1) as usize
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

/// Per block of queries: each query's nearest neighbours, and per train item the block's
/// nearest query (squared distance, index).
type BlockNearest = (Vec<Option<Nearest>>, Vec<(f32, usize)>);

/// Queries per block of the distance matrix: the block's `rows × b` product stays within
/// about 8 MB.
fn block_rows(b_rows: usize) -> usize {
    (2_000_000 / b_rows.max(1)).clamp(16, 256)
}

/// For each row of `a`, the nearest and second-nearest rows of `b`; for each row of `b`, the
/// nearest row of `a` (squared L2 from one SGEMM per block of `a`; ties go to the lower
/// index, so the result does not depend on `parallel`).
fn nearest_both(
    a: &[f32],
    a_sign: &[i8],
    b: &[f32],
    b_sign: &[i8],
    dim: usize,
    gating: bool,
    parallel: bool,
) -> (Vec<Option<Nearest>>, Vec<Option<usize>>) {
    let (na, nb) = match (a.len().checked_div(dim), b.len().checked_div(dim)) {
        (Some(na), Some(nb)) => (na, nb),
        _ => (a_sign.len(), b_sign.len()),
    };
    if dim == 0 || na == 0 || nb == 0 {
        return (vec![None; na], vec![None; nb]);
    }
    let norm2 = |v: &[f32]| -> Vec<f32> {
        v.chunks_exact(dim)
            .map(|r| r.iter().map(|x| x * x).sum())
            .collect()
    };
    let (a_n2, b_n2) = (norm2(a), norm2(b));
    // Per query sign (−1, 0, +1): 0 for the rows of `b` it may match, +∞ for the others.
    let penalty: [Vec<f32>; 3] = [-1i8, 0, 1].map(|s| {
        b_sign
            .iter()
            .map(|&t| {
                if !gating || signs_agree(s, t) {
                    0.0
                } else {
                    f32::INFINITY
                }
            })
            .collect()
    });
    let rows = block_rows(nb);
    // One block: its rows' nearest neighbours, and per row of `b` the block's nearest row.
    let block = |bi: usize| -> BlockNearest {
        let r0 = bi * rows;
        let r = rows.min(na - r0);
        let mut dots = vec![0f32; r * nb];
        // SAFETY: `a[r0·dim..]` holds `r × dim` (row stride dim), `b` holds `nb × dim`, read
        // as its transpose `dim × nb` (row stride 1, column stride dim), and `dots` is
        // `r × nb` (row stride nb); no two of them alias.
        unsafe {
            matrixmultiply::sgemm(
                r,
                dim,
                nb,
                1.0,
                a[r0 * dim..].as_ptr(),
                dim as isize,
                1,
                b.as_ptr(),
                1,
                dim as isize,
                0.0,
                dots.as_mut_ptr(),
                nb as isize,
                1,
            );
        }
        // Per row of `b`: this block's nearest distance and row of `a`.
        let mut col_d = vec![f32::INFINITY; nb];
        let mut col_i = vec![u32::MAX; nb];
        let near = (0..r)
            .map(|i| {
                let ai = r0 + i;
                let row = &mut dots[i * nb..(i + 1) * nb];
                // Squared distances in place; gated pairs get +∞ (branch-free: vectorises).
                let pen = &penalty[sign_slot(a_sign[ai])];
                let an = a_n2[ai];
                for ((d, &bn), &p) in row.iter_mut().zip(&b_n2).zip(pen.iter()) {
                    *d = (an + bn - 2.0 * *d).max(0.0) + p;
                }
                // Branch-free so that it vectorises.
                for ((&d, cd), ci) in row.iter().zip(col_d.iter_mut()).zip(col_i.iter_mut()) {
                    let better = d < *cd;
                    *cd = if better { d } else { *cd };
                    *ci = if better { ai as u32 } else { *ci };
                }
                let mut n = Nearest {
                    best: usize::MAX,
                    d1: f32::INFINITY,
                    d2: f32::INFINITY,
                };
                for (j, &d) in row.iter().enumerate() {
                    if d < n.d2 {
                        if d < n.d1 {
                            n.d2 = n.d1;
                            n.d1 = d;
                            n.best = j;
                        } else {
                            n.d2 = d;
                        }
                    }
                }
                (n.best != usize::MAX).then_some(n)
            })
            .collect();
        let col = col_d
            .into_iter()
            .zip(col_i)
            .map(|(d, i)| {
                (
                    d,
                    if i == u32::MAX {
                        usize::MAX
                    } else {
                        i as usize
                    },
                )
            })
            .collect();
        (near, col)
    };
    let blocks = na.div_ceil(rows);
    let parts: Vec<BlockNearest> = if parallel {
        (0..blocks).into_par_iter().map(block).collect()
    } else {
        (0..blocks).map(block).collect()
    };
    let mut forward = Vec::with_capacity(na);
    let mut col_best = vec![(f32::INFINITY, usize::MAX); nb];
    // Blocks in order, strict `<`: a tie keeps the lower query index.
    for (near, col) in parts {
        forward.extend(near);
        for (best, c) in col_best.iter_mut().zip(col) {
            if c.0 < best.0 {
                *best = c;
            }
        }
    }
    let backward = col_best
        .into_iter()
        .map(|(_, i)| (i != usize::MAX).then_some(i))
        .collect();
    (forward, backward)
}

/// For each row of `a`, the nearest and second-nearest rows of `b` (squared L2), by the
/// plain loop.
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

    #[test]
    fn fast_path_gives_the_reference_matches() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        // Train items are noisy copies of some queries (true matches) mixed with distractors;
        // lengths not multiples of the block size.
        let unit = |rng: &mut rand_chacha::ChaCha8Rng| -> Vec<f32> {
            let mut d: Vec<f32> = (0..64).map(|_| rng.random::<f32>() - 0.5).collect();
            let n = d.iter().map(|v| v * v).sum::<f32>().sqrt();
            d.iter_mut().for_each(|v| *v /= n);
            d
        };
        let q: Vec<Feature> = (0..437)
            .map(|i| feat(&unit(&mut rng), [1, -1, 0][i % 3]))
            .collect();
        let mut t: Vec<Feature> = Vec::new();
        for (i, f) in q.iter().enumerate().step_by(2) {
            let d: Vec<f32> = f
                .descriptor
                .iter()
                .map(|v| v + 0.03 * (rng.random::<f32>() - 0.5))
                .collect();
            t.push(feat(&d, f.keypoint.laplacian));
            if i % 5 == 0 {
                t.push(feat(&unit(&mut rng), 1));
            }
        }
        for cfg in [
            MatcherConfig::default(),
            MatcherConfig::default().with_mutual(false).with_ratio(0.9),
            MatcherConfig::default()
                .with_laplacian_gating(false)
                .with_parallel(false),
        ] {
            let m = Matcher::new(cfg.clone());
            let fast = m.match_descriptors(&q, &t).unwrap();
            let naive = m.match_descriptors_naive(&q, &t).unwrap();
            assert!(fast.len() >= 200, "{cfg:?}: {} matches", fast.len());
            assert_eq!(fast.len(), naive.len(), "{cfg:?}");
            for (a, b) in fast.iter().zip(&naive) {
                assert_eq!((a.query, a.train), (b.query, b.train), "{cfg:?}");
                assert!((a.distance - b.distance).abs() < 1e-3, "{a:?} vs {b:?}");
            }
        }
        // Both directions of the empty cases.
        let m = Matcher::new(MatcherConfig::default());
        assert!(
            m.match_descriptors(&q, &[] as &[Feature])
                .unwrap()
                .is_empty()
        );
        assert!(
            m.match_descriptors(&[] as &[Feature], &t)
                .unwrap()
                .is_empty()
        );
    }
}
