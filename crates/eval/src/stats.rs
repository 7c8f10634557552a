//! Summary statistics of an error array, with evo's definitions: the one place where
//! endoloc-eval computes means, medians, percentiles and the like.
//!
//! - `mean`, `rmse = sqrt(mean(e²))`, `max`, `min`;
//! - `median`: the middle value, or the mean of the two middle values (numpy `median`);
//! - `std`: population standard deviation, `sqrt(mean((e − mean)²))` (numpy `std`, ddof 0);
//! - `p90`: the 90th percentile with numpy's default "linear" method: with the values sorted
//!   ascending as `a[0..n]`, position `h = 0.9·(n − 1)`, result
//!   `a[⌊h⌋] + (h − ⌊h⌋)·(a[⌊h⌋+1] − a[⌊h⌋])` (Hyndman–Fan type 7).

use serde::{Deserialize, Serialize};

use crate::EvalError;

/// Summary of an error array; every value has the unit of the errors (mm or degrees).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Statistics {
    /// Number of errors summarised.
    pub count: usize,
    /// Arithmetic mean.
    pub mean: f64,
    /// Median (mean of the two middle values for an even count).
    pub median: f64,
    /// Root mean square.
    pub rmse: f64,
    /// 90th percentile, linear interpolation between closest ranks (numpy's default).
    pub p90: f64,
    /// Largest error.
    pub max: f64,
    /// Smallest error.
    pub min: f64,
    /// Population standard deviation (ddof 0, as numpy and evo).
    pub std: f64,
}

/// Where the `q`-th percentile (`q` in `[0, 100]`) of `n ≥ 1` sorted values lies: the ranks
/// `lo`, `hi` (0-based) and the weight `t` of `hi`, numpy's default linear method.
pub(crate) fn percentile_position(n: usize, q: f64) -> (usize, usize, f64) {
    let h = (q / 100.0).clamp(0.0, 1.0) * (n - 1) as f64;
    let lo = h.floor() as usize;
    (lo, (lo + 1).min(n - 1), h - lo as f64)
}

/// numpy's `_lerp`: `a + (b − a)·t`, in the symmetric form that is accurate near `t = 1`.
pub(crate) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    if t >= 0.5 {
        b - (b - a) * (1.0 - t)
    } else {
        a + (b - a) * t
    }
}

/// The `q`-th percentile (`q` in `[0, 100]`) of `sorted` (ascending, non-empty), numpy's
/// default linear method (see the module docs). Returns NaN for an empty slice.
pub fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let (lo, hi, t) = percentile_position(sorted.len(), q);
    lerp(sorted[lo], sorted[hi], t)
}

/// The `q`-th percentile (`q` in `[0, 100]`) of `values` in any order, numpy's default linear
/// method; NaN for an empty slice.
pub fn percentile(values: &[f64], q: f64) -> f64 {
    percentile_sorted(&sorted(values), q)
}

/// `values` sorted ascending (total order: NaN last).
fn sorted(values: &[f64]) -> Vec<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v
}

/// The median of `sorted` (ascending): the middle value, or the mean of the two middle values
/// for an even count; NaN for an empty slice.
pub fn median_sorted(sorted: &[f64]) -> f64 {
    let m = sorted.len();
    if m == 0 {
        f64::NAN
    } else if m % 2 == 1 {
        sorted[m / 2]
    } else {
        0.5 * (sorted[m / 2 - 1] + sorted[m / 2])
    }
}

/// The median of `values` in any order ([`median_sorted`]); NaN for an empty slice.
pub fn median(values: &[f64]) -> f64 {
    median_sorted(&sorted(values))
}

/// The arithmetic mean; NaN for an empty slice.
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// The root mean square `sqrt(mean(e²))`; NaN for an empty slice.
pub fn rmse(values: &[f64]) -> f64 {
    (values.iter().map(|e| e * e).sum::<f64>() / values.len() as f64).sqrt()
}

/// The population standard deviation `sqrt(mean((e − mean)²))` (ddof 0, as numpy and evo);
/// NaN for an empty slice.
pub fn std(values: &[f64]) -> f64 {
    let m = mean(values);
    (values.iter().map(|e| (e - m) * (e - m)).sum::<f64>() / values.len() as f64).sqrt()
}

/// The largest value; −∞ for an empty slice.
pub fn max(values: &[f64]) -> f64 {
    values.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// The smallest value; +∞ for an empty slice.
pub fn min(values: &[f64]) -> f64 {
    values.iter().copied().fold(f64::INFINITY, f64::min)
}

/// Mean and median of `values`, both `None` when `values` is empty or holds a non-finite
/// value (as [`Statistics::from_errors`] would refuse it).
pub fn mean_median(values: &[f64]) -> (Option<f64>, Option<f64>) {
    match Statistics::from_errors(values, "values") {
        Ok(s) => (Some(s.mean), Some(s.median)),
        Err(_) => (None, None),
    }
}

impl Statistics {
    /// Summarises `errors`.
    ///
    /// # Errors
    /// [`EvalError::Invalid`] if `errors` is empty or holds a non-finite value; `what` names
    /// the quantity in the message.
    pub fn from_errors(errors: &[f64], what: &str) -> Result<Self, EvalError> {
        if errors.is_empty() {
            return Err(EvalError::Invalid(format!(
                "{what}: no errors to summarise"
            )));
        }
        if let Some(i) = errors.iter().position(|e| !e.is_finite()) {
            return Err(EvalError::Invalid(format!(
                "{what}: error {i} is {} (expected a finite number)",
                errors[i]
            )));
        }
        let sorted = sorted(errors);
        let m = sorted.len();
        Ok(Self {
            count: m,
            mean: mean(errors),
            median: median_sorted(&sorted),
            rmse: rmse(errors),
            p90: percentile_sorted(&sorted, 90.0),
            max: sorted[m - 1],
            min: sorted[0],
            std: std(errors),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_values() {
        // 1, 2, 3, 4: mean 2.5, median 2.5, rmse sqrt(30/4), std sqrt(1.25),
        // p90: h = 0.9·3 = 2.7 → 3 + 0.7·1 = 3.7.
        let s = Statistics::from_errors(&[4.0, 1.0, 3.0, 2.0], "x").unwrap();
        assert_eq!(s.count, 4);
        assert!((s.mean - 2.5).abs() < 1e-15);
        assert!((s.median - 2.5).abs() < 1e-15);
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-15);
        assert!((s.p90 - 3.7).abs() < 1e-12);
        assert_eq!((s.min, s.max), (1.0, 4.0));
        // Odd count: median is the middle; p90 of 0..=10 is 9 exactly.
        let v: Vec<f64> = (0..=10).map(f64::from).collect();
        let s = Statistics::from_errors(&v, "x").unwrap();
        assert_eq!(s.median, 5.0);
        assert!((s.p90 - 9.0).abs() < 1e-12);
        // One value: everything equals it, std 0.
        let s = Statistics::from_errors(&[3.0], "x").unwrap();
        assert_eq!(
            (s.mean, s.median, s.p90, s.rmse, s.std),
            (3.0, 3.0, 3.0, 3.0, 0.0)
        );
    }

    #[test]
    fn percentile_matches_numpy_linear() {
        // numpy.percentile([1, 2, 10], q) for q = 0, 25, 50, 90, 100.
        let a = [1.0, 2.0, 10.0];
        for (q, want) in [
            (0.0, 1.0),
            (25.0, 1.5),
            (50.0, 2.0),
            (90.0, 8.4),
            (100.0, 10.0),
        ] {
            assert!((percentile_sorted(&a, q) - want).abs() < 1e-12, "q={q}");
        }
    }

    #[test]
    fn free_functions_agree_with_statistics() {
        let v = [4.0, 1.0, 3.0, 2.0, 10.0];
        let s = Statistics::from_errors(&v, "x").unwrap();
        assert_eq!(mean(&v), s.mean);
        assert_eq!(median(&v), s.median);
        assert_eq!(rmse(&v), s.rmse);
        assert_eq!(std(&v), s.std);
        assert_eq!(percentile(&v, 90.0), s.p90);
        assert_eq!((min(&v), max(&v)), (s.min, s.max));
        assert_eq!(mean_median(&v), (Some(s.mean), Some(s.median)));
        assert_eq!(mean_median(&[]), (None, None));
        assert_eq!(mean_median(&[1.0, f64::NAN]), (None, None));
        assert!(mean(&[]).is_nan() && median(&[]).is_nan() && percentile(&[], 50.0).is_nan());
    }

    #[test]
    fn empty_or_nan_is_an_error() {
        assert!(
            Statistics::from_errors(&[], "position")
                .unwrap_err()
                .to_string()
                .contains("position")
        );
        assert!(Statistics::from_errors(&[1.0, f64::NAN], "x").is_err());
    }
}
