//! Averages of rotations and the median pose of a zone.
//!
//! - [`chordal_mean`]: the L2 chordal mean — the arithmetic mean of the rotation matrices
//!   projected back onto SO(3) with an SVD (`R = U diag(1, 1, det(U Vᵀ)) Vᵀ`). Closed form,
//!   fast, but pulled by outliers.
//! - [`geodesic_median`]: the L1 geodesic median `argmin_R Σ d(R, R_i)` (`d` = rotation angle of
//!   `Rᵀ R_i`), found by Weiszfeld iterations on SO(3) (Hartley, Aftab & Trumpf, "L1 rotation
//!   averaging using the Weiszfeld algorithm", CVPR 2011), started from the medoid of the
//!   inputs. Robust: it stays with the majority when up to ~40 % of the inputs are arbitrary.
//! - [`zone_median_pose`]: what the pipeline uses as a zone's initial pose (`docs/CONVENTIONS.md`):
//!   **component-wise median of the positions** and **geodesic L1 median of the rotations**.
//!
//! Quaternions are sign-canonicalised (`qw ≥ 0`) on input and on output; the computations
//! themselves use rotation matrices and logarithms, which do not depend on the sign.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::pose::{Pose, canonical_quaternion, pose_from_parts};
use crate::so3;

/// Why a mean or median could not be computed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RotationMeanError {
    /// The input was empty.
    #[error("cannot average an empty set of rotations or poses")]
    Empty,
    /// An input had a NaN or infinite component.
    #[error("input {index} has a non-finite component")]
    NonFinite {
        /// Index of the offending input.
        index: usize,
    },
}

/// Settings of the Weiszfeld iterations of [`geodesic_median`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GeodesicMedianConfig {
    /// Maximum number of Weiszfeld iterations.
    pub max_iterations: usize,
    /// Stop when an update rotates the estimate by less than this, radians.
    pub tolerance_rad: f64,
    /// Inputs closer than this to the current estimate (radians) are left out of a step
    /// (Weiszfeld's singularity); the estimate is then exactly that input if it is optimal.
    pub coincidence_rad: f64,
}

impl Default for GeodesicMedianConfig {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            tolerance_rad: 1e-12,
            coincidence_rad: 1e-10,
        }
    }
}

fn check_finite(rotations: &[UnitQuaternion<f64>]) -> Result<(), RotationMeanError> {
    if rotations.is_empty() {
        return Err(RotationMeanError::Empty);
    }
    for (index, q) in rotations.iter().enumerate() {
        if !q.coords.iter().all(|v| v.is_finite()) {
            return Err(RotationMeanError::NonFinite { index });
        }
    }
    Ok(())
}

/// Projects a 3×3 matrix onto the nearest rotation (Frobenius norm).
fn project_to_so3(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => {
            let d = (u * v_t).determinant().signum();
            let s = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, if d == 0.0 { 1.0 } else { d }));
            Rotation3::from_matrix_unchecked(u * s * v_t)
        }
        // nalgebra always returns U and Vᵀ when asked; fall back to Gram–Schmidt otherwise.
        _ => Rotation3::from_matrix(m),
    }
}

/// The chordal L2 mean of rotations (SVD projection of the mean matrix), canonical sign.
///
/// # Errors
/// [`RotationMeanError::Empty`] for no input, [`RotationMeanError::NonFinite`] for NaN/∞.
pub fn chordal_mean(
    rotations: &[UnitQuaternion<f64>],
) -> Result<UnitQuaternion<f64>, RotationMeanError> {
    check_finite(rotations)?;
    let sum: Matrix3<f64> = rotations
        .iter()
        .map(|q| q.to_rotation_matrix().into_inner())
        .sum();
    let r = project_to_so3(&(sum / rotations.len() as f64));
    Ok(canonical_quaternion(UnitQuaternion::from_rotation_matrix(
        &r,
    )))
}

/// The input minimising the sum of geodesic distances to all others (the medoid); `O(n²)`.
fn medoid(rotations: &[UnitQuaternion<f64>]) -> UnitQuaternion<f64> {
    let mut best = (f64::INFINITY, rotations[0]);
    for a in rotations {
        let cost: f64 = rotations.iter().map(|b| so3::geodesic_distance(a, b)).sum();
        if cost < best.0 {
            best = (cost, *a);
        }
    }
    best.1
}

/// The geodesic L1 median of rotations (Weiszfeld on SO(3)), canonical sign (`qw ≥ 0`).
///
/// Started from the medoid of the inputs (or the chordal mean when there are more than 512
/// inputs, to bound the `O(n²)` start), then iterated until an update is smaller than
/// `cfg.tolerance_rad` or `cfg.max_iterations` is reached.
///
/// # Errors
/// [`RotationMeanError::Empty`] for no input, [`RotationMeanError::NonFinite`] for NaN/∞.
pub fn geodesic_median(
    rotations: &[UnitQuaternion<f64>],
    cfg: &GeodesicMedianConfig,
) -> Result<UnitQuaternion<f64>, RotationMeanError> {
    check_finite(rotations)?;
    let rotations: Vec<UnitQuaternion<f64>> =
        rotations.iter().map(|q| canonical_quaternion(*q)).collect();
    let mut estimate = if rotations.len() <= 512 {
        medoid(&rotations)
    } else {
        chordal_mean(&rotations)?
    };
    for _ in 0..cfg.max_iterations {
        let inv = estimate.inverse();
        let mut num = Vector3::zeros();
        let mut den = 0.0;
        for q in &rotations {
            let v = so3::log_quaternion(&(inv * q));
            let d = v.norm();
            if d > cfg.coincidence_rad {
                num += v / d;
                den += 1.0 / d;
            }
        }
        if den == 0.0 {
            break; // every input coincides with the estimate
        }
        let step = num / den;
        estimate *= so3::exp_quaternion(&step);
        if step.norm() < cfg.tolerance_rad {
            break;
        }
    }
    Ok(canonical_quaternion(estimate))
}

/// The component-wise median of values; the mean of the two middle ones for an even count.
fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// The median pose of a zone: component-wise median of the positions (mm, world frame) and
/// geodesic L1 median of the camera-to-world rotations ([`geodesic_median`] with default
/// settings). Poses are `T_wc`.
///
/// # Errors
/// [`RotationMeanError::Empty`] for no poses, [`RotationMeanError::NonFinite`] for NaN/∞.
pub fn zone_median_pose(poses: &[Pose]) -> Result<Pose, RotationMeanError> {
    if poses.is_empty() {
        return Err(RotationMeanError::Empty);
    }
    for (index, p) in poses.iter().enumerate() {
        if !p.translation.vector.iter().all(|v| v.is_finite()) {
            return Err(RotationMeanError::NonFinite { index });
        }
    }
    let rotations: Vec<UnitQuaternion<f64>> = poses.iter().map(|p| p.rotation).collect();
    let rotation = geodesic_median(&rotations, &GeodesicMedianConfig::default())?;
    let mut position = Vector3::zeros();
    let mut buf: Vec<f64> = Vec::with_capacity(poses.len());
    for k in 0..3 {
        buf.clear();
        buf.extend(poses.iter().map(|p| p.translation.vector[k]));
        position[k] = median(&mut buf);
    }
    Ok(pose_from_parts(position, rotation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
        let q = nalgebra::Quaternion::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        UnitQuaternion::new_normalize(q)
    }

    fn perturbed(
        center: &UnitQuaternion<f64>,
        sigma_rad: f64,
        rng: &mut ChaCha8Rng,
    ) -> UnitQuaternion<f64> {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) * sigma_rad;
        // Flip some signs on purpose: the result must not depend on the quaternion sign.
        let q = center * so3::exp_quaternion(&v);
        if rng.random_bool(0.5) {
            UnitQuaternion::new_unchecked(-q.into_inner())
        } else {
            q
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]
        #[test]
        fn geodesic_median_is_robust_to_30_percent_outliers(seed in 0u64..10_000) {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let truth = random_rotation(&mut rng);
            let n = 40;
            let mut rots: Vec<_> = (0..n).map(|_| perturbed(&truth, 0.02, &mut rng)).collect();
            for r in rots.iter_mut().take(n * 3 / 10) {
                *r = random_rotation(&mut rng);
            }
            let med = geodesic_median(&rots, &GeodesicMedianConfig::default()).unwrap();
            let err_med = so3::geodesic_distance(&med, &truth);
            let mean = chordal_mean(&rots).unwrap();
            let err_mean = so3::geodesic_distance(&mean, &truth);
            // Inliers are within ±0.02 rad per axis: the median must stay close to the truth,
            // and beat the chordal mean whenever the outliers pull the mean beyond the inlier
            // spread (random outliers sometimes cancel out and leave the mean close: seed 10).
            prop_assert!(err_med < 0.02, "median error {err_med} rad");
            if err_mean > 0.02 {
                prop_assert!(err_med < err_mean, "median {err_med} mean {err_mean}");
            }
            prop_assert!(med.w >= 0.0);
        }
    }

    #[test]
    fn chordal_mean_of_symmetric_spread_is_the_centre() {
        let center = so3::exp_quaternion(&Vector3::new(0.3, -1.0, 2.0));
        let mut rots = Vec::new();
        for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
            rots.push(center * so3::exp_quaternion(&(axis * 0.1)));
            rots.push(center * so3::exp_quaternion(&(axis * -0.1)));
        }
        let mean = chordal_mean(&rots).unwrap();
        assert!(so3::geodesic_distance(&mean, &center) < 1e-12);
        let med = geodesic_median(&rots, &GeodesicMedianConfig::default()).unwrap();
        assert!(so3::geodesic_distance(&med, &center) < 1e-9);
    }

    #[test]
    fn zone_median_pose_takes_component_medians_and_rejects_bad_input() {
        let r = so3::exp_quaternion(&Vector3::new(0.1, 0.2, 0.3));
        let poses = [
            pose_from_parts(Vector3::new(1.0, 10.0, -5.0), r),
            pose_from_parts(Vector3::new(2.0, 30.0, -7.0), r),
            pose_from_parts(Vector3::new(100.0, 20.0, -6.0), r),
        ];
        let m = zone_median_pose(&poses).unwrap();
        assert_eq!(m.translation.vector, Vector3::new(2.0, 20.0, -6.0));
        assert!(so3::geodesic_distance(&m.rotation, &r) < 1e-12);
        assert_eq!(zone_median_pose(&[]), Err(RotationMeanError::Empty));
        let bad = pose_from_parts(Vector3::new(f64::NAN, 0.0, 0.0), r);
        assert_eq!(
            zone_median_pose(&[poses[0], bad]),
            Err(RotationMeanError::NonFinite { index: 1 })
        );
        assert_eq!(chordal_mean(&[]), Err(RotationMeanError::Empty));
    }
}
