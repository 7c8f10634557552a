//! Exact summary statistics of values streamed in several passes, in memory independent of
//! how many there are.
//!
//! The caller replays the same values, in the same order, once per pass, each tagged with
//! the group it belongs to. The first pass sums; the second sums squared deviations from the
//! mean; every order statistic (median, 90th percentile) is found by radix selection on the
//! values' bits: each pass counts, per wanted rank, the values that share the bits found so
//! far by their next byte, so eight byte-passes pin the k-th smallest value down to its
//! exact bits. The results equal [`Statistics::from_errors`] on the same values in the same
//! order, bit for bit; memory is 2 KiB per wanted rank.

use crate::EvalError;
use crate::stats::{Statistics, lerp, percentile_position};

/// One pass over the values: calls its argument with `(group, value)` for every value.
pub(crate) type Pass<'a> = dyn FnMut(&mut dyn FnMut(usize, f64)) -> Result<(), EvalError> + 'a;

/// What to compute for a group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Want {
    /// Every field of [`Statistics`].
    Full,
    /// Count, mean and median only (per-zone rows).
    MeanMedian,
}

/// The statistics of one group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GroupSummary {
    /// Number of values.
    pub count: usize,
    /// Mean, root mean square, population standard deviation.
    pub mean: f64,
    pub rmse: f64,
    pub std: f64,
    /// Smallest and largest value (total order).
    pub min: f64,
    pub max: f64,
    /// Median, and 90th percentile (NaN unless [`Want::Full`]).
    pub median: f64,
    pub p90: f64,
    /// The first value that is not finite: its position in the group and the value.
    pub non_finite: Option<(usize, f64)>,
}

impl GroupSummary {
    /// As [`Statistics::from_errors`]: an error when the group is empty or holds a value that
    /// is not finite; `what` names the quantity.
    pub(crate) fn statistics(&self, what: &str) -> Result<Statistics, EvalError> {
        if self.count == 0 {
            return Err(EvalError::Invalid(format!(
                "{what}: no errors to summarise"
            )));
        }
        if let Some((i, v)) = self.non_finite {
            return Err(EvalError::Invalid(format!(
                "{what}: error {i} is {v} (expected a finite number)"
            )));
        }
        Ok(Statistics {
            count: self.count,
            mean: self.mean,
            median: self.median,
            rmse: self.rmse,
            p90: self.p90,
            max: self.max,
            min: self.min,
            std: self.std,
        })
    }

    /// Mean and median, both `None` for an empty group or one with a non-finite value
    /// (as [`crate::stats::mean_median`]).
    pub(crate) fn mean_median(&self) -> (Option<f64>, Option<f64>) {
        if self.count == 0 || self.non_finite.is_some() {
            (None, None)
        } else {
            (Some(self.mean), Some(self.median))
        }
    }
}

/// A 64-bit key whose unsigned order is `f64::total_cmp`'s order.
fn order_key(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 { !b } else { b | (1 << 63) }
}

fn from_key(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// The search for one rank of one group.
struct Target {
    /// Rank still to skip among the values that share `prefix`.
    rank: u64,
    /// Key bits found so far (`8·digits` of them).
    prefix: u64,
    hist: Box<[u64; 256]>,
}

#[derive(Clone, Copy)]
struct Sums {
    count: usize,
    sum: f64,
    sum_sq: f64,
    min: f64,
    max: f64,
    non_finite: Option<(usize, f64)>,
    centred: f64,
}

/// Summarises every group: `wants[g]` says what group `g` needs; `pass` replays the values
/// (9 passes in all).
///
/// # Errors
/// Whatever `pass` returns.
pub(crate) fn summarise(
    wants: &[Want],
    pass: &mut Pass<'_>,
) -> Result<Vec<GroupSummary>, EvalError> {
    let groups = wants.len();
    let mut sums = vec![
        Sums {
            count: 0,
            sum: -0.0,
            sum_sq: -0.0,
            min: f64::NAN,
            max: f64::NAN,
            non_finite: None,
            centred: -0.0,
        };
        groups
    ];
    pass(&mut |g, v| {
        let s = &mut sums[g];
        if s.count == 0 {
            (s.min, s.max) = (v, v);
        } else {
            if v.total_cmp(&s.min).is_lt() {
                s.min = v;
            }
            if v.total_cmp(&s.max).is_gt() {
                s.max = v;
            }
        }
        if s.non_finite.is_none() && !v.is_finite() {
            s.non_finite = Some((s.count, v));
        }
        s.sum += v;
        s.sum_sq += v * v;
        s.count += 1;
    })?;
    let means: Vec<f64> = sums.iter().map(|s| s.sum / s.count as f64).collect();

    // The ranks each group needs (sorted ascending, 0-based), deduplicated.
    let mut targets: Vec<Target> = Vec::new();
    let mut by_group: Vec<Vec<usize>> = vec![Vec::new(); groups];
    let mut ranks_of = |g: usize, want: Want, n: usize| -> Vec<u64> {
        let mut r = vec![(n / 2) as u64];
        if n.is_multiple_of(2) {
            r.push((n / 2 - 1) as u64);
        }
        if want == Want::Full {
            let (lo, hi, _) = percentile_position(n, 90.0);
            r.extend([lo as u64, hi as u64]);
        }
        r.sort_unstable();
        r.dedup();
        for &rank in &r {
            by_group[g].push(targets.len());
            targets.push(Target {
                rank,
                prefix: 0,
                hist: Box::new([0; 256]),
            });
        }
        r
    };
    let ranks: Vec<Vec<u64>> = (0..groups)
        .map(|g| {
            if sums[g].count == 0 {
                Vec::new()
            } else {
                ranks_of(g, wants[g], sums[g].count)
            }
        })
        .collect();

    for digit in 0..8u32 {
        let shift = 56 - 8 * digit;
        pass(&mut |g, v| {
            if digit == 0 {
                let d = v - means[g];
                sums[g].centred += d * d;
            }
            let key = order_key(v);
            for &t in &by_group[g] {
                let t = &mut targets[t];
                if digit == 0 || key >> (shift + 8) == t.prefix {
                    t.hist[((key >> shift) & 0xff) as usize] += 1;
                }
            }
        })?;
        for t in &mut targets {
            let mut below = 0u64;
            for (b, &c) in t.hist.iter().enumerate() {
                if below + c > t.rank {
                    t.rank -= below;
                    t.prefix = (t.prefix << 8) | b as u64;
                    break;
                }
                below += c;
            }
            t.hist.fill(0);
        }
    }

    Ok((0..groups)
        .map(|g| {
            let s = sums[g];
            let n = s.count;
            let value = |rank: u64| -> f64 {
                let k = ranks[g].iter().position(|&r| r == rank).unwrap_or(0);
                from_key(targets[by_group[g][k]].prefix)
            };
            let (median, p90) = if n == 0 {
                (f64::NAN, f64::NAN)
            } else {
                let median = if n % 2 == 1 {
                    value((n / 2) as u64)
                } else {
                    0.5 * (value((n / 2 - 1) as u64) + value((n / 2) as u64))
                };
                let p90 = if wants[g] == Want::Full {
                    let (lo, hi, t) = percentile_position(n, 90.0);
                    lerp(value(lo as u64), value(hi as u64), t)
                } else {
                    f64::NAN
                };
                (median, p90)
            };
            GroupSummary {
                count: n,
                mean: means[g],
                rmse: (s.sum_sq / n as f64).sqrt(),
                std: (s.centred / n as f64).sqrt(),
                min: s.min,
                max: s.max,
                median,
                p90,
                non_finite: s.non_finite,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn run(groups: &[Vec<f64>], wants: &[Want]) -> Vec<GroupSummary> {
        let mut passes = 0;
        let out = summarise(wants, &mut |emit| {
            passes += 1;
            // Interleaved, as records of several groups arrive.
            let longest = groups.iter().map(Vec::len).max().unwrap_or(0);
            for i in 0..longest {
                for (g, v) in groups.iter().enumerate() {
                    if let Some(&x) = v.get(i) {
                        emit(g, x);
                    }
                }
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(passes, 9);
        out
    }

    #[test]
    fn equals_the_in_memory_statistics_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut groups: Vec<Vec<f64>> = (0..6)
            .map(|g| {
                let n = [1usize, 2, 3, 10, 1001, 4096][g];
                (0..n).map(|_| rng.random::<f64>().powi(3) * 40.0).collect()
            })
            .collect();
        // Ties, zeros and a spread of magnitudes.
        groups.push(vec![0.0, 0.0, 1.5, 1.5, 1.5, 1e-300, 7e6]);
        let wants = vec![Want::Full; groups.len()];
        for (g, s) in run(&groups, &wants).iter().enumerate() {
            let want = Statistics::from_errors(&groups[g], "x").unwrap();
            assert_eq!(s.statistics("x").unwrap(), want, "group {g}");
        }
    }

    #[test]
    fn mean_and_median_only_and_empty_and_non_finite_groups() {
        let groups = vec![vec![3.0, 1.0, 2.0, 10.0], vec![], vec![1.0, f64::NAN, 2.0]];
        let s = run(&groups, &[Want::MeanMedian, Want::Full, Want::Full]);
        assert_eq!(s[0].mean_median(), (Some(4.0), Some(2.5)));
        assert!(s[0].p90.is_nan());
        assert_eq!(s[1].mean_median(), (None, None));
        assert!(
            s[1].statistics("rpe")
                .unwrap_err()
                .to_string()
                .contains("rpe: no errors")
        );
        let e = s[2].statistics("position").unwrap_err().to_string();
        assert!(e.contains("error 1 is NaN"), "{e}");
    }

    #[test]
    fn keys_keep_the_total_order() {
        let v = [
            f64::NEG_INFINITY,
            -2.0,
            -0.0,
            0.0,
            1e-310,
            1.0,
            f64::INFINITY,
        ];
        for w in v.windows(2) {
            assert!(order_key(w[0]) < order_key(w[1]));
        }
        for x in v {
            assert_eq!(from_key(order_key(x)).to_bits(), x.to_bits());
        }
    }
}
