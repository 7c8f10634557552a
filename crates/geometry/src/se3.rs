//! The rigid-motion group SE(3) on top of [`nalgebra::Isometry3`] (our [`Pose`]).
//!
//! # Tangent ordering
//!
//! A tangent vector is `ξ = [ρ; φ] ∈ ℝ⁶`: **translation part first** (`ρ`, mm), **rotation
//! part second** (`φ`, radians) — the Barfoot/Sophus ordering. Everything in this crate that
//! takes or returns a 6-vector or a 6×6 matrix (updates, Jacobians, covariances) uses it.
//!
//! `exp(ξ) = (exp(φ), V(φ) ρ)` with `V = J_l(φ)` the SO(3) left Jacobian, and
//! `log` is its inverse (principal branch, rotation angle in `[0, π]`).
//!
//! # Perturbations
//!
//! Pose refinement uses the **left** perturbation `T ← exp(δ) · T` (the paper perturbs "on the
//! left tangent space"). For `T = T_wc` the increment `δ` is expressed in the world frame:
//! `exp(δ)` is a small rigid motion of the whole camera about the world origin.

use nalgebra::{Isometry3, Matrix3, Matrix3x6, Matrix4, Matrix6, Point3, Translation3, Vector6};

use crate::pose::Pose;
use crate::so3;

/// The rotation part `φ` (radians) of a tangent vector `[ρ; φ]`.
fn phi_of(xi: &Vector6<f64>) -> nalgebra::Vector3<f64> {
    xi.fixed_rows::<3>(3).into_owned()
}

/// The translation part `ρ` (mm) of a tangent vector `[ρ; φ]`.
fn rho_of(xi: &Vector6<f64>) -> nalgebra::Vector3<f64> {
    xi.fixed_rows::<3>(0).into_owned()
}

/// The 4×4 Lie-algebra matrix `ξ^ = [[φ]×, ρ; 0, 0]` of `ξ = [ρ; φ]`.
pub fn hat(xi: &Vector6<f64>) -> Matrix4<f64> {
    let mut m = Matrix4::zeros();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&so3::hat(&phi_of(xi)));
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&rho_of(xi));
    m
}

/// The tangent vector `[ρ; φ]` of a 4×4 Lie-algebra matrix (inverse of [`hat`]).
pub fn vee(m: &Matrix4<f64>) -> Vector6<f64> {
    let phi = so3::vee(&m.fixed_view::<3, 3>(0, 0).into_owned());
    Vector6::new(m[(0, 3)], m[(1, 3)], m[(2, 3)], phi.x, phi.y, phi.z)
}

/// `exp(ξ)` for `ξ = [ρ; φ]` (ρ in mm, φ in radians): rotation `exp(φ)`, translation
/// `J_l(φ) ρ` (mm).
pub fn exp(xi: &Vector6<f64>) -> Pose {
    let phi = phi_of(xi);
    let t = so3::left_jacobian(&phi) * rho_of(xi);
    Isometry3::from_parts(Translation3::from(t), so3::exp_quaternion(&phi))
}

/// `log(T) = [ρ; φ]` (ρ in mm, φ in radians, angle in `[0, π]`); the inverse of [`exp`].
pub fn log(t: &Pose) -> Vector6<f64> {
    let phi = so3::log_quaternion(&t.rotation);
    let rho = so3::left_jacobian_inverse(&phi) * t.translation.vector;
    Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z)
}

/// The adjoint `Ad_T = [[R, [t]× R]; [0, R]]` (for the `[ρ; φ]` ordering), so that
/// `T · exp(ξ) · T⁻¹ = exp(Ad_T ξ)`: it moves a tangent vector from the right of `T` to its
/// left.
pub fn adjoint(t: &Pose) -> Matrix6<f64> {
    let r = t.rotation.to_rotation_matrix().into_inner();
    let tx = so3::hat(&t.translation.vector);
    let mut ad = Matrix6::zeros();
    ad.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    ad.fixed_view_mut::<3, 3>(0, 3).copy_from(&(tx * r));
    ad.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    ad
}

/// The left-perturbation update `T ← exp(δ) · T`, `δ = [ρ; φ]` (mm, radians).
///
/// The result's quaternion is renormalised so that long iteration chains stay on the group.
pub fn left_update(t: &Pose, delta: &Vector6<f64>) -> Pose {
    let mut out = exp(delta) * t;
    out.rotation = nalgebra::UnitQuaternion::new_normalize(out.rotation.into_inner());
    out
}

/// The right-perturbation update `T ← T · exp(δ)`, `δ = [ρ; φ]` (mm, radians).
pub fn right_update(t: &Pose, delta: &Vector6<f64>) -> Pose {
    let mut out = t * exp(delta);
    out.rotation = nalgebra::UnitQuaternion::new_normalize(out.rotation.into_inner());
    out
}

/// `∂(exp(δ) · p)/∂δ` at `δ = 0`: the 3×6 matrix `[I, −[p]×]` (same units as `p` for the
/// translation block, mm/rad for the rotation block).
pub fn point_jacobian_left(p: &Point3<f64>) -> Matrix3x6<f64> {
    let mut j = Matrix3x6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::identity());
    j.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-so3::hat(&p.coords)));
    j
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Vector3;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn tangent_strategy() -> impl Strategy<Value = Vector6<f64>> {
        let axis = (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
            .prop_filter("non-zero", |(x, y, z)| x * x + y * y + z * z > 1e-2)
            .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize());
        let angle = prop_oneof![0.0f64..PI, 0.0f64..1e-6, (PI - 1e-3)..(PI - 1e-9)];
        let rho = (-500.0f64..500.0, -500.0f64..500.0, -500.0f64..500.0);
        (axis, angle, rho).prop_map(|(a, t, (x, y, z))| {
            let phi = a * t;
            Vector6::new(x, y, z, phi.x, phi.y, phi.z)
        })
    }

    proptest! {
        #[test]
        fn log_of_exp_is_identity(xi in tangent_strategy()) {
            let back = log(&exp(&xi));
            // J_l⁻¹ stays finite up to θ = π (it is singular only at 2π), so the round trip
            // is accurate on the whole principal branch; within ~1e-7 rad of π the recovered
            // translation loses a few digits (3e-8 mm at |ρ| = 156 mm, θ = π − 2e-7: the
            // regression case in proptest-regressions/se3.txt), hence 1e-8 relative.
            prop_assert!((back - xi).norm() < 1e-8 * (1.0 + rho_of(&xi).norm()),
                "xi {xi:?} back {back:?}");
        }

        #[test]
        fn exp_of_log_is_identity(xi in tangent_strategy()) {
            let t = exp(&xi);
            let again = exp(&log(&t));
            prop_assert!((again.to_homogeneous() - t.to_homogeneous()).norm()
                < 1e-9 * (1.0 + rho_of(&xi).norm()));
        }

        #[test]
        fn adjoint_moves_tangents_across(xi in tangent_strategy(), d in tangent_strategy()) {
            let t = exp(&xi);
            let small = d * 1e-3;
            let lhs = t * exp(&small) * t.inverse();
            let rhs = exp(&(adjoint(&t) * small));
            prop_assert!((lhs.to_homogeneous() - rhs.to_homogeneous()).norm() < 1e-9);
        }

        #[test]
        fn point_jacobian_matches_finite_differences(xi in tangent_strategy(),
                                                     x in -100.0f64..100.0,
                                                     y in -100.0f64..100.0,
                                                     z in -100.0f64..100.0) {
            let t = exp(&xi);
            let p = Point3::new(x, y, z);
            let q = t * p;
            let j = point_jacobian_left(&q);
            let h = 1e-6;
            for k in 0..6 {
                let mut e = Vector6::zeros();
                e[k] = h;
                let fd = (left_update(&t, &e) * p - left_update(&t, &(-e)) * p) / (2.0 * h);
                prop_assert!((fd - j.column(k)).norm() < 1e-6 * (1.0 + q.coords.norm()));
            }
        }
    }

    #[test]
    fn hat_vee_and_exp_match_matrix_exponential() {
        let xi = Vector6::new(10.0, -5.0, 3.0, 0.2, -0.1, 0.3);
        assert_eq!(vee(&hat(&xi)), xi);
        // Truncated power series of the 4×4 matrix exponential.
        let a = hat(&xi);
        let mut term = Matrix4::identity();
        let mut sum = Matrix4::identity();
        for k in 1..30 {
            term = term * a / k as f64;
            sum += term;
        }
        assert_relative_eq!(exp(&xi).to_homogeneous(), sum, epsilon = 1e-12);
    }

    #[test]
    fn left_and_right_updates_are_related_by_the_adjoint() {
        let t = exp(&Vector6::new(100.0, 20.0, -30.0, 0.5, 1.0, -0.3));
        let d = Vector6::new(0.1, 0.2, 0.3, 0.01, -0.02, 0.03);
        let left = left_update(&t, &(adjoint(&t) * d));
        let right = right_update(&t, &d);
        assert_relative_eq!(
            left.to_homogeneous(),
            right.to_homogeneous(),
            epsilon = 1e-12
        );
    }
}
