//! Umeyama alignment of an estimated trajectory onto the ground truth (evo `-a`, `-as`).
//!
//! Umeyama (1991) finds the similarity `S = (R, t, s)` minimising
//! `Σ ‖y_i − (s·R·x_i + t)‖²` over corresponding positions `x_i` (estimate) and `y_i`
//! (ground truth): with means `μx, μy`, variance `σx² = mean ‖x_i − μx‖²` and cross-covariance
//! `Σxy = mean (y_i − μy)(x_i − μx)ᵀ = U D Vᵀ` (singular values descending),
//! `W = diag(1, 1, ±1)` (−1 when `det U · det V < 0`), `R = U W Vᵀ`, `s = tr(D W)/σx²`
//! (or 1 for SE(3)), `t = μy − s·R·μx`. The estimate's poses then become
//! `T ← (R, t)·T` after their positions were scaled by `s`: rotation `R·R_est`, position
//! `s·R·t_est + t`, exactly what evo applies.

use endoloc_geometry::Pose;
use nalgebra::{Matrix3, Rotation3, SVD, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::EvalError;

/// Which alignment is applied before the errors are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlignmentKind {
    /// None: errors in the ground truth's world frame (evo's default, and ours).
    #[default]
    None,
    /// Rigid SE(3) Umeyama alignment (evo `-a`).
    Se3,
    /// Similarity Sim(3) Umeyama alignment, with scale (evo `-a -s`).
    Sim3,
}

/// A similarity transform `y = scale·R·x + t` (mm), the result of [`umeyama`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Similarity3 {
    /// Rotation `R` (estimate world → ground-truth world).
    pub rotation: Rotation3<f64>,
    /// Translation `t`, mm.
    pub translation_mm: Vector3<f64>,
    /// Scale `s` (1 for SE(3)).
    pub scale: f64,
}

impl Similarity3 {
    /// The identity transform.
    pub fn identity() -> Self {
        Self {
            rotation: Rotation3::identity(),
            translation_mm: Vector3::zeros(),
            scale: 1.0,
        }
    }

    /// Maps a point: `s·R·x + t`, mm.
    pub fn transform_point(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.scale * (self.rotation * x) + self.translation_mm
    }

    /// Maps a pose `T_wc` of the estimate's world into the ground truth's world: rotation
    /// `R·R_wc`, position `s·R·t_wc + t` (the camera's own frame is not scaled).
    pub fn transform_pose(&self, t_wc: &Pose) -> Pose {
        let t = self.transform_point(&t_wc.translation.vector);
        let r = UnitQuaternion::from_rotation_matrix(&self.rotation) * t_wc.rotation;
        Pose::from_parts(Translation3::from(t), r)
    }
}

/// Umeyama's moments of corresponding positions (`x` estimate, `y` ground truth, mm),
/// accumulated in two passes over the same pairs in the same order: [`UmeyamaSums::add_mean`]
/// for every pair, then [`UmeyamaSums::add_centred`] for every pair. The result of
/// [`UmeyamaSums::solve`] is then exactly that of [`umeyama`] on the whole lists.
#[derive(Debug, Clone, Copy)]
pub(crate) struct UmeyamaSums {
    n: usize,
    sum_x: Vector3<f64>,
    sum_y: Vector3<f64>,
    /// Means, fixed at the first centred pair.
    means: Option<(Vector3<f64>, Vector3<f64>)>,
    centred: usize,
    sigma_x: f64,
    cov: Matrix3<f64>,
}

impl UmeyamaSums {
    pub(crate) fn new() -> Self {
        Self {
            n: 0,
            sum_x: Vector3::zeros(),
            sum_y: Vector3::zeros(),
            means: None,
            centred: 0,
            sigma_x: -0.0,
            cov: Matrix3::zeros(),
        }
    }

    /// First pass: one pair.
    pub(crate) fn add_mean(&mut self, x: &Vector3<f64>, y: &Vector3<f64>) {
        self.sum_x += x;
        self.sum_y += y;
        self.n += 1;
    }

    fn means(&self) -> (Vector3<f64>, Vector3<f64>) {
        let n = self.n as f64;
        (self.sum_x / n, self.sum_y / n)
    }

    /// Second pass: one pair (the same ones, in the same order).
    pub(crate) fn add_centred(&mut self, x: &Vector3<f64>, y: &Vector3<f64>) {
        let (mean_x, mean_y) = *self.means.get_or_insert_with(|| {
            let n = self.n as f64;
            (self.sum_x / n, self.sum_y / n)
        });
        self.sigma_x += (x - mean_x).norm_squared();
        self.cov += (y - mean_y) * (x - mean_x).transpose();
        self.centred += 1;
    }

    /// The similarity taking `x` onto `y`; `with_scale` false gives a rigid SE(3) transform.
    ///
    /// # Errors
    /// As [`umeyama`].
    pub(crate) fn solve(&self, with_scale: bool) -> Result<Similarity3, EvalError> {
        if self.n < 2 || self.centred != self.n {
            return Err(EvalError::Alignment(format!(
                "needs as many estimated as ground-truth positions, at least 2; got {}",
                self.n
            )));
        }
        let n = self.n as f64;
        let (mean_x, mean_y) = self.means();
        let sigma_x = self.sigma_x / n;
        let cov = self.cov / n;
        let svd = SVD::try_new(cov, true, true, f64::EPSILON, 1000)
            .ok_or_else(|| EvalError::Alignment("SVD did not converge".into()))?;
        let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
            return Err(EvalError::Alignment(
                "SVD returned no singular vectors".into(),
            ));
        };
        let d = svd.singular_values;
        if d.iter().filter(|&&s| s > f64::EPSILON).count() < 2 {
            return Err(EvalError::Alignment(
                "degenerate covariance rank (the positions are all on one line or one spot)".into(),
            ));
        }
        let mut w = Matrix3::identity();
        if u.determinant() * v_t.determinant() < 0.0 {
            w[(2, 2)] = -1.0;
        }
        let r = u * w * v_t;
        let scale = if with_scale {
            if sigma_x.is_nan() || sigma_x <= 0.0 {
                return Err(EvalError::Alignment(
                    "the estimated positions have zero spread; scale undefined".into(),
                ));
            }
            (Matrix3::from_diagonal(&d) * w).trace() / sigma_x
        } else {
            1.0
        };
        let rotation = Rotation3::from_matrix_unchecked(r);
        let translation_mm = mean_y - scale * (rotation * mean_x);
        Ok(Similarity3 {
            rotation,
            translation_mm,
            scale,
        })
    }
}

/// Umeyama's least-squares similarity taking the points `x` (estimate) onto `y` (ground
/// truth), mm; `with_scale` false gives a rigid SE(3) transform.
///
/// # Errors
/// [`EvalError::Alignment`] if the lists differ in length, hold fewer than 2 points, or the
/// cross-covariance has rank below 2 (all points on a line through one spot; evo raises
/// "Degenerate covariance rank" in the same case), or the SVD does not converge.
pub fn umeyama(
    x: &[Vector3<f64>],
    y: &[Vector3<f64>],
    with_scale: bool,
) -> Result<Similarity3, EvalError> {
    if x.len() != y.len() || x.len() < 2 {
        return Err(EvalError::Alignment(format!(
            "needs as many estimated as ground-truth positions, at least 2; got {} and {}",
            x.len(),
            y.len()
        )));
    }
    let mut sums = UmeyamaSums::new();
    for (p, q) in x.iter().zip(y) {
        sums.add_mean(p, q);
    }
    for (p, q) in x.iter().zip(y) {
        sums.add_centred(p, q);
    }
    sums.solve(with_scale)
}

/// Aligns `est` onto `gt` (already associated, same order) as evo does, returning the
/// transform (identity for [`AlignmentKind::None`]) and the transformed estimate.
///
/// # Errors
/// See [`umeyama`].
pub fn align_trajectory(
    gt: &[Pose],
    est: &[Pose],
    kind: AlignmentKind,
) -> Result<(Similarity3, Vec<Pose>), EvalError> {
    let sim = match kind {
        AlignmentKind::None => return Ok((Similarity3::identity(), est.to_vec())),
        AlignmentKind::Se3 | AlignmentKind::Sim3 => {
            let x: Vec<Vector3<f64>> = est.iter().map(|p| p.translation.vector).collect();
            let y: Vec<Vector3<f64>> = gt.iter().map(|p| p.translation.vector).collect();
            umeyama(&x, &y, kind == AlignmentKind::Sim3)?
        }
    };
    let aligned = est.iter().map(|p| sim.transform_pose(p)).collect();
    Ok((sim, aligned))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn cloud(seed: u64, n: usize) -> Vec<Vector3<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                Vector3::new(
                    rng.random_range(-50.0..50.0),
                    rng.random_range(-50.0..50.0),
                    rng.random_range(-20.0..20.0),
                )
            })
            .collect()
    }

    #[test]
    fn recovers_a_known_se3_and_sim3() {
        let x = cloud(7, 30);
        let rotation = Rotation3::from_euler_angles(0.4, -1.1, 2.5);
        let t = Vector3::new(100.0, -20.0, 3.5);
        for (with_scale, s) in [(false, 1.0), (true, 0.37)] {
            let truth = Similarity3 {
                rotation,
                translation_mm: t,
                scale: s,
            };
            let y: Vec<_> = x.iter().map(|p| truth.transform_point(p)).collect();
            let est = umeyama(&x, &y, with_scale).unwrap();
            let dr = (est.rotation.matrix() - rotation.matrix()).norm();
            assert!(dr < 1e-12, "{dr}");
            assert!(
                (est.translation_mm - t).norm() < 1e-10,
                "{}",
                est.translation_mm
            );
            assert!((est.scale - s).abs() < 1e-12);
            for (p, q) in x.iter().zip(&y) {
                assert!((est.transform_point(p) - q).norm() < 1e-10);
            }
        }
    }

    #[test]
    fn reflection_is_not_returned() {
        // y is a mirror image of x: the best proper rotation has det +1.
        let x = cloud(3, 20);
        let y: Vec<_> = x.iter().map(|p| Vector3::new(p.x, p.y, -p.z)).collect();
        let est = umeyama(&x, &y, false).unwrap();
        assert!((est.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn aligned_poses_rotate_with_the_frame() {
        let x = cloud(11, 10);
        let truth = Similarity3 {
            rotation: Rotation3::from_euler_angles(0.0, 0.0, 0.5),
            translation_mm: Vector3::new(1.0, 2.0, 3.0),
            scale: 1.0,
        };
        let est: Vec<Pose> = x
            .iter()
            .map(|p| {
                Pose::from_parts(
                    Translation3::from(*p),
                    UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
                )
            })
            .collect();
        let gt: Vec<Pose> = est.iter().map(|p| truth.transform_pose(p)).collect();
        let (_, aligned) = align_trajectory(&gt, &est, AlignmentKind::Se3).unwrap();
        for (a, g) in aligned.iter().zip(&gt) {
            assert!(endoloc_geometry::position_error_mm(a, g) < 1e-10);
            assert!(endoloc_geometry::orientation_error_deg(a, g) < 1e-9);
        }
    }

    #[test]
    fn collinear_points_are_degenerate() {
        let x: Vec<_> = (0..5).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
        let e = umeyama(&x, &x, false).unwrap_err();
        assert!(e.to_string().contains("degenerate"), "{e}");
        assert!(umeyama(&x[..1], &x[..1], false).is_err());
    }
}
