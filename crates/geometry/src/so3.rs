//! The rotation group SO(3): hat/vee, exponential and logarithm maps, and the left and right
//! Jacobians with their inverses.
//!
//! A tangent vector `φ ∈ ℝ³` is a rotation vector (axis × angle, radians). `exp(φ)` is the
//! rotation by `‖φ‖` about `φ/‖φ‖` (Rodrigues' formula); `log` is its inverse on angles in
//! `[0, π]`.
//!
//! Jacobians follow Barfoot ("State Estimation for Robotics") and Eade ("Lie groups for
//! computer vision"):
//! - left Jacobian `J_l(φ)`: `exp(φ + δ) ≈ exp(J_l(φ) δ) · exp(φ)`,
//! - right Jacobian `J_r(φ) = J_l(−φ)`: `exp(φ + δ) ≈ exp(φ) · exp(J_r(φ) δ)`.
//!
//! Every closed-form coefficient switches to its Taylor series below a small angle, so the maps
//! are accurate to machine precision at and near the identity. The logarithm goes through a
//! unit quaternion obtained with Shepperd's method, which keeps it accurate near `π` where the
//! matrix-trace formula loses all precision.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Below this angle (radians) the series expansions are used.
const SMALL_ANGLE: f64 = 1e-4;

/// The skew-symmetric matrix `[φ]×` with `[φ]× v = φ × v`.
pub fn hat(phi: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(
        0.0, -phi.z, phi.y, //
        phi.z, 0.0, -phi.x, //
        -phi.y, phi.x, 0.0,
    )
}

/// The vector `φ` of a skew-symmetric matrix `[φ]×` (the inverse of [`hat`]); the symmetric
/// part of a non-skew input is ignored.
pub fn vee(m: &Matrix3<f64>) -> Vector3<f64> {
    Vector3::new(
        0.5 * (m[(2, 1)] - m[(1, 2)]),
        0.5 * (m[(0, 2)] - m[(2, 0)]),
        0.5 * (m[(1, 0)] - m[(0, 1)]),
    )
}

/// `(sin θ / θ, (1 − cos θ) / θ², (θ − sin θ) / θ³)` for `θ = ‖φ‖`, with series near zero.
fn rodrigues_coefficients(theta: f64) -> (f64, f64, f64) {
    let t2 = theta * theta;
    if theta < SMALL_ANGLE {
        (
            1.0 - t2 / 6.0 * (1.0 - t2 / 20.0),
            0.5 - t2 / 24.0 * (1.0 - t2 / 30.0),
            1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0),
        )
    } else {
        let (s, c) = theta.sin_cos();
        (s / theta, (1.0 - c) / t2, (theta - s) / (t2 * theta))
    }
}

/// The rotation matrix `exp([φ]×)` (Rodrigues' formula), `φ` in radians.
pub fn exp_matrix(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let (a, b, _) = rodrigues_coefficients(theta);
    let k = hat(phi);
    Matrix3::identity() + k * a + k * k * b
}

/// `exp(φ)` as a rotation, `φ` in radians.
pub fn exp(phi: &Vector3<f64>) -> Rotation3<f64> {
    Rotation3::from_matrix_unchecked(exp_matrix(phi))
}

/// `exp(φ)` as a unit quaternion (Hamilton), `φ` in radians; exact to rounding for every angle.
pub fn exp_quaternion(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    let theta = phi.norm();
    let half = 0.5 * theta;
    // sin(θ/2)/θ, with its series near zero.
    let k = if theta < SMALL_ANGLE {
        0.5 - theta * theta / 48.0
    } else {
        half.sin() / theta
    };
    UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
        half.cos(),
        k * phi.x,
        k * phi.y,
        k * phi.z,
    ))
}

/// The rotation vector of a unit quaternion, radians, with angle in `[0, π]`.
///
/// Uses `θ = 2·atan2(‖v‖, |w|)` on the sign-canonicalised quaternion (`w ≥ 0`), accurate at
/// every angle including `0` and `π`.
pub fn log_quaternion(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let n = v.norm();
    if n < 1e-12 {
        // θ = 2 n / w to first order; the next term is O(n³).
        return v * (2.0 / w) * (1.0 - n * n / (3.0 * w * w));
    }
    let theta = 2.0 * n.atan2(w);
    v * (theta / n)
}

/// The rotation vector of a rotation, radians, with angle in `[0, π]` (the principal branch).
///
/// Accurate near `0` and near `π` (see the module docs). At exactly `π` the sign of the axis is
/// arbitrary (both `±π·axis` are logarithms).
pub fn log(r: &Rotation3<f64>) -> Vector3<f64> {
    log_quaternion(&UnitQuaternion::from_rotation_matrix(r))
}

/// The left Jacobian `J_l(φ) = I + (1−cos θ)/θ² [φ]× + (θ−sin θ)/θ³ [φ]×²`.
pub fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let (_, b, c) = rodrigues_coefficients(phi.norm());
    let k = hat(phi);
    Matrix3::identity() + k * b + k * k * c
}

/// The right Jacobian `J_r(φ) = J_l(−φ)`.
pub fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    left_jacobian(&(-phi))
}

/// `1/θ² − (1 + cos θ) / (2 θ sin θ)`, with its series near zero.
///
/// Evaluated as `1/θ² − 1 / (2 θ tan(θ/2))` (the same value: `(1 + cos θ)/sin θ = cot(θ/2)`),
/// which stays accurate near θ = π where `1 + cos θ` cancels catastrophically.
fn inverse_coefficient(theta: f64) -> f64 {
    let t2 = theta * theta;
    if theta < SMALL_ANGLE {
        1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    } else {
        1.0 / t2 - 1.0 / (2.0 * theta * (0.5 * theta).tan())
    }
}

/// The inverse left Jacobian `J_l⁻¹(φ) = I − ½[φ]× + (1/θ² − (1+cos θ)/(2θ sin θ)) [φ]×²`.
///
/// Finite for `θ < 2π`; on the principal branch (`θ ≤ π`) it is well conditioned.
pub fn left_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let k = hat(phi);
    Matrix3::identity() - k * 0.5 + k * k * inverse_coefficient(phi.norm())
}

/// The inverse right Jacobian `J_r⁻¹(φ) = J_l⁻¹(−φ)`.
pub fn right_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    left_jacobian_inverse(&(-phi))
}

/// Geodesic distance between two rotations, radians in `[0, π]`.
pub fn geodesic_distance(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    log_quaternion(&(a.inverse() * b)).norm()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn axis_strategy() -> impl Strategy<Value = Vector3<f64>> {
        (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
            .prop_filter("non-zero axis", |(x, y, z)| x * x + y * y + z * z > 1e-2)
            .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize())
    }

    /// Angles spread over the whole principal range plus the two hard ends.
    fn angle_strategy() -> impl Strategy<Value = f64> {
        prop_oneof![
            0.0f64..PI,
            0.0f64..1e-6,
            1e-6f64..1e-3,
            (PI - 1e-3)..(PI - 1e-9),
        ]
    }

    fn rotation_strategy() -> impl Strategy<Value = Vector3<f64>> {
        (axis_strategy(), angle_strategy()).prop_map(|(a, t)| a * t)
    }

    proptest! {
        #[test]
        fn log_of_exp_is_identity(phi in rotation_strategy()) {
            let back = log(&exp(&phi));
            prop_assert!((back - phi).norm() < 1e-9, "phi {phi:?} back {back:?}");
            let back_q = log_quaternion(&exp_quaternion(&phi));
            prop_assert!((back_q - phi).norm() < 1e-12 * (1.0 + phi.norm()));
        }

        #[test]
        fn exp_of_log_is_identity(phi in rotation_strategy()) {
            let r = exp(&phi);
            let again = exp(&log(&r));
            prop_assert!((again.matrix() - r.matrix()).norm() < 1e-12);
        }

        #[test]
        fn exp_matches_quaternion_and_is_orthonormal(phi in rotation_strategy()) {
            let r = exp_matrix(&phi);
            let q = exp_quaternion(&phi).to_rotation_matrix();
            prop_assert!((r - q.matrix()).norm() < 1e-12);
            prop_assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
            prop_assert!((r.determinant() - 1.0).abs() < 1e-12);
        }

        #[test]
        fn left_and_right_jacobians_match_finite_differences(phi in rotation_strategy(),
                                                            dir in axis_strategy()) {
            // Avoid the branch cut at π where a finite step leaves the principal branch.
            prop_assume!(phi.norm() < PI - 1e-2);
            // Central differences: truncation O(h²), rounding O(ε/h).
            let h = 1e-5;
            let d = dir * h;
            // exp(φ + δ) · exp(φ)⁻¹ ≈ exp(J_l δ)
            let lhs_l = (log(&(exp(&(phi + d)) * exp(&phi).inverse()))
                - log(&(exp(&(phi - d)) * exp(&phi).inverse()))) / (2.0 * h);
            let rhs_l = left_jacobian(&phi) * dir;
            prop_assert!((lhs_l - rhs_l).norm() < 1e-8, "{lhs_l:?} vs {rhs_l:?}");
            // exp(φ)⁻¹ · exp(φ + δ) ≈ exp(J_r δ)
            let lhs_r = (log(&(exp(&phi).inverse() * exp(&(phi + d))))
                - log(&(exp(&phi).inverse() * exp(&(phi - d))))) / (2.0 * h);
            let rhs_r = right_jacobian(&phi) * dir;
            prop_assert!((lhs_r - rhs_r).norm() < 1e-8, "{lhs_r:?} vs {rhs_r:?}");
        }

        #[test]
        fn inverse_jacobians_are_inverses(phi in rotation_strategy()) {
            let i = Matrix3::identity();
            prop_assert!((left_jacobian(&phi) * left_jacobian_inverse(&phi) - i).norm() < 1e-9);
            prop_assert!((right_jacobian(&phi) * right_jacobian_inverse(&phi) - i).norm() < 1e-9);
        }
    }

    #[test]
    fn hat_vee_round_trip_and_cross_product() {
        let a = Vector3::new(0.3, -1.2, 2.0);
        let b = Vector3::new(-0.7, 0.1, 0.4);
        assert_eq!(vee(&hat(&a)), a);
        assert_relative_eq!(hat(&a) * b, a.cross(&b), epsilon = 1e-15);
    }

    #[test]
    fn log_at_exactly_pi_and_identity() {
        let axis = Vector3::new(1.0, 2.0, -2.0).normalize();
        let r = exp(&(axis * PI));
        let l = log(&r);
        assert_relative_eq!(l.norm(), PI, epsilon = 1e-12);
        assert!((l / PI - axis).norm() < 1e-9 || (l / PI + axis).norm() < 1e-9);
        assert_eq!(log(&Rotation3::identity()), Vector3::zeros());
        assert_relative_eq!(left_jacobian(&Vector3::zeros()), Matrix3::identity());
    }

    #[test]
    fn series_and_closed_forms_agree_at_the_switch() {
        for theta in [SMALL_ANGLE * 0.999, SMALL_ANGLE * 1.001] {
            let phi = Vector3::new(theta, 0.0, 0.0);
            let r = exp_matrix(&phi);
            assert_relative_eq!(r[(1, 1)], theta.cos(), epsilon = 1e-15);
            assert_relative_eq!(r[(2, 1)], theta.sin(), epsilon = 1e-15);
            assert_relative_eq!(
                inverse_coefficient(theta),
                1.0 / 12.0,
                epsilon = 1e-7 // the closed form itself loses ~1e-8 here
            );
        }
    }
}
