//! Relative pose of two calibrated views: the essential matrix from the minimal 5-point solver
//! inside a seeded MSAC RANSAC, and its decomposition into `(R, t)` with the cheirality test —
//! what OpenCV's `findEssentialMat` + `recoverPose` do.
//!
//! # Convention
//!
//! Correspondences are normalized image coordinates `x = (X/Z, Y/Z, 1)` (or any bearing, any
//! positive scale) of the same 3D point in camera 1 and camera 2 (OpenCV axes). The essential
//! matrix satisfies `x₂ᵀ E x₁ = 0` with `E = [t₂₁]× R₂₁`, where `X₂ = R₂₁ X₁ + t₂₁` maps a point
//! from camera 1's frame to camera 2's (OpenCV's `recoverPose` convention). The translation is
//! known only up to scale and is returned as a unit vector; [`RelativePose::pose_2_in_1`] gives
//! camera 2's pose `T_wc` in a world frame equal to camera 1's.
//!
//! # Solvers
//!
//! - [`five_point`]: Stewénius, Engels & Nistér (2006), "Recent developments on direct relative
//!   orientation": the four-dimensional null space of the five epipolar constraints, the ten
//!   cubic constraints `det E = 0` and `2 E Eᵀ E − tr(E Eᵀ) E = 0` in the unknowns `(x, y, z)`
//!   expanded over 20 monomials, Gauss–Jordan elimination of the ten cubic monomials, and the
//!   real eigenvectors of the 10×10 action matrix of `x`. Up to 10 solutions.
//! - [`eight_point`]: the linear 8-point algorithm on normalized coordinates with projection
//!   onto the essential manifold (singular values `(1, 1, 0)`). It is used only to re-fit the
//!   RANSAC winner on all its inliers (a least-squares polish of the minimal sample, kept only
//!   when its MSAC score is not worse), never as the minimal solver: the 5-point solver needs
//!   fewer points per sample and is exact for planar scenes, where the 8-point degenerates.
//!
//! # RANSAC
//!
//! [`ransac_essential`] follows [`crate::pnp::ransac`]: ChaCha8 sampling with `cfg.seed`, MSAC
//! scoring `Σ min(e², τ²)` with `e` the Sampson distance converted to pixels with the mean
//! focal length `√(fx·fy)`, and an adaptive iteration count `N = ln(1 − confidence) /
//! ln(1 − w⁵)` clamped to `[min_iterations, max_iterations]`. The winner is decomposed by
//! [`recover_pose`] on its inliers, and `(R, t)` is polished by Levenberg–Marquardt on the
//! Sampson distances of the inliers ([`refine_relative_pose`]).

use nalgebra::{Matrix3, Point2, Rotation3, SMatrix, SVD, Schur, SymmetricEigen, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::camera::Camera;
use crate::pose::Pose;

/// Settings of [`ransac_essential`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EssentialRansacConfig {
    /// Inlier threshold `τ` on the Sampson distance, pixels (normalized units × `√(fx·fy)`).
    /// Default 1.5 px: about 2σ of the epipolar distance for 0.5 px keypoint noise in each
    /// view (OpenCV's default of 1 px keeps too few true inliers at that noise and biased
    /// the translation direction by up to 3° in the property tests).
    pub threshold_px: f64,
    /// Probability of drawing at least one all-inlier sample, in `(0, 1)`.
    pub confidence: f64,
    /// Minimum number of iterations.
    pub min_iterations: usize,
    /// Maximum number of iterations.
    pub max_iterations: usize,
    /// Random seed of the sampler.
    pub seed: u64,
    /// A consensus needs at least this many inliers.
    pub min_inliers: usize,
    /// Re-fit the winner on all its inliers with the 8-point algorithm (kept when its MSAC
    /// score is not worse).
    pub refit_on_inliers: bool,
    /// Levenberg–Marquardt iterations refining `(R, t)` on the Sampson distances of the
    /// inliers in front of both cameras after the decomposition (0 = none).
    pub refine_iterations: usize,
    /// Cheirality: triangulated points farther than this many baselines from camera 1 count
    /// as "at infinity" and are not in front (OpenCV's `distanceThresh` is 50).
    pub max_distance_baselines: f64,
}

impl Default for EssentialRansacConfig {
    fn default() -> Self {
        Self {
            threshold_px: 1.5,
            confidence: 0.999,
            min_iterations: 20,
            max_iterations: 1000,
            seed: 0,
            min_inliers: 8,
            refit_on_inliers: true,
            refine_iterations: 10,
            max_distance_baselines: 50.0,
        }
    }
}

/// Relative pose of camera 2 with respect to camera 1 (translation up to scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelativePose {
    /// Rotation `R₂₁` from camera 1's frame to camera 2's: `X₂ = R₂₁ X₁ + t₂₁`.
    pub r_21: Rotation3<f64>,
    /// Unit translation `t₂₁` (camera 2 frame); the true one is `s·t₂₁` for an unknown `s > 0`.
    pub t_21: Vector3<f64>,
}

impl RelativePose {
    /// Camera 2's pose `T_wc` in a world frame equal to camera 1's, with a baseline of
    /// `baseline` (the distance between the camera centres, in the caller's unit, e.g. mm).
    pub fn pose_2_in_1(&self, baseline: f64) -> Pose {
        let r_12 = self.r_21.inverse();
        let centre = -(r_12 * self.t_21) * baseline;
        Pose::from_parts(
            nalgebra::Translation3::from(centre),
            nalgebra::UnitQuaternion::from_rotation_matrix(&r_12),
        )
    }
}

/// The result of [`recover_pose`].
#[derive(Debug, Clone, PartialEq)]
pub struct RecoveredPose {
    /// The decomposition of `E` with the most points in front of both cameras.
    pub pose: RelativePose,
    /// Per correspondence: considered (mask) and triangulated in front of both cameras,
    /// closer than `max_distance_baselines`.
    pub in_front: Vec<bool>,
    /// Number of `true` entries in `in_front`.
    pub in_front_count: usize,
}

/// The result of [`ransac_essential`].
#[derive(Debug, Clone, PartialEq)]
pub struct EssentialEstimate {
    /// The essential matrix (unit Frobenius norm): `x₂ᵀ E x₁ = 0`.
    pub essential: Matrix3<f64>,
    /// Relative pose from [`recover_pose`] on the inliers.
    pub pose: RelativePose,
    /// Per correspondence: Sampson distance below the threshold.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// Inliers that also triangulate in front of both cameras with `pose`.
    pub in_front: Vec<bool>,
    /// Number of `true` entries in `in_front`.
    pub in_front_count: usize,
    /// RANSAC iterations (samples) drawn.
    pub iterations: usize,
    /// MSAC score of `essential`, px² (lower is better).
    pub score_px2: f64,
}

/// Why no essential matrix was found.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EssentialError {
    /// The two correspondence lists differ in length.
    #[error("{first} points in the first view but {second} in the second")]
    LengthMismatch {
        /// Points in view 1.
        first: usize,
        /// Points in view 2.
        second: usize,
    },
    /// A point had a NaN or infinite component.
    #[error("correspondence {index} has a non-finite coordinate")]
    NonFinite {
        /// Index of the correspondence.
        index: usize,
    },
    /// Fewer than the 6 correspondences RANSAC needs (5 to sample, 1 to verify).
    #[error("too few correspondences: {usable} usable, at least 6 needed")]
    TooFewCorrespondences {
        /// Correspondences with an invertible pixel in both views.
        usable: usize,
    },
    /// No hypothesis reached the minimum inlier count.
    #[error("no consensus: best hypothesis has {best_inliers} inliers, {min_inliers} needed")]
    NoConsensus {
        /// Inliers of the best hypothesis (0 if none).
        best_inliers: usize,
        /// The configured minimum.
        min_inliers: usize,
    },
    /// The focal length used to convert the threshold is not positive and finite.
    #[error("focal length must be positive and finite, got {focal_px}")]
    InvalidFocal {
        /// The focal length given, pixels.
        focal_px: f64,
    },
}

// ---------------------------------------------------------------------------------------------
// Polynomials in (x, y, z) of degree ≤ 3 over 20 monomials.
// ---------------------------------------------------------------------------------------------

/// Exponents `(a, b, c)` of `xᵃ yᵇ zᶜ` per column: the ten cubic monomials first (eliminated),
/// then the basis of the quotient ring `x², xy, xz, y², yz, z², x, y, z, 1`.
const EXPONENTS: [(u8, u8, u8); 20] = [
    (3, 0, 0),
    (2, 1, 0),
    (2, 0, 1),
    (1, 2, 0),
    (1, 1, 1),
    (1, 0, 2),
    (0, 3, 0),
    (0, 2, 1),
    (0, 1, 2),
    (0, 0, 3),
    (2, 0, 0),
    (1, 1, 0),
    (1, 0, 1),
    (0, 2, 0),
    (0, 1, 1),
    (0, 0, 2),
    (1, 0, 0),
    (0, 1, 0),
    (0, 0, 1),
    (0, 0, 0),
];

const fn monomial_index(a: u8, b: u8, c: u8) -> usize {
    let mut i = 0;
    while i < 20 {
        let e = EXPONENTS[i];
        if e.0 == a && e.1 == b && e.2 == c {
            return i;
        }
        i += 1;
    }
    usize::MAX
}

/// For each monomial of degree ≤ 2 (columns 10..20), the column of it times x, y, z.
const TIMES_XYZ: [[usize; 3]; 10] = {
    let mut t = [[0usize; 3]; 10];
    let mut k = 0;
    while k < 10 {
        let (a, b, c) = EXPONENTS[10 + k];
        t[k] = [
            monomial_index(a + 1, b, c),
            monomial_index(a, b + 1, c),
            monomial_index(a, b, c + 1),
        ];
        k += 1;
    }
    t
};

type Poly = [f64; 20];

/// A linear polynomial `lx·x + ly·y + lz·z + l1` as a [`Poly`].
fn poly_from_linear(l: &[f64; 4]) -> Poly {
    let mut p = [0.0; 20];
    p[16] = l[0];
    p[17] = l[1];
    p[18] = l[2];
    p[19] = l[3];
    p
}

/// `a · l` for a polynomial `a` of degree ≤ 2 and a linear `l = (lx, ly, lz, l1)`.
fn mul_linear(a: &Poly, l: &[f64; 4]) -> Poly {
    let mut out = [0.0; 20];
    for k in 0..10 {
        let c = a[10 + k];
        if c == 0.0 {
            continue;
        }
        let [ix, iy, iz] = TIMES_XYZ[k];
        out[ix] += c * l[0];
        out[iy] += c * l[1];
        out[iz] += c * l[2];
        out[10 + k] += c * l[3];
    }
    out
}

fn add_scaled(acc: &mut Poly, p: &Poly, s: f64) {
    for (a, b) in acc.iter_mut().zip(p) {
        *a += s * b;
    }
}

/// Unit homogeneous-normalized row of one epipolar constraint `x₂ᵀ E x₁` over the row-major
/// entries of `E`.
fn epipolar_row(x1: &Vector3<f64>, x2: &Vector3<f64>) -> [f64; 9] {
    let mut r = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            r[3 * i + j] = x2[i] * x1[j];
        }
    }
    r
}

fn matrix_from_row_major(v: &[f64; 9]) -> Matrix3<f64> {
    Matrix3::new(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8])
}

/// Essential matrices consistent with five correspondences (normalized coordinates or
/// bearings, camera 1 and camera 2): the minimal 5-point solver (see the module docs).
///
/// Returns between 0 and 10 matrices, each with unit Frobenius norm. Degenerate samples
/// (coincident or collinear points, numerical breakdown) give an empty list, never a panic.
pub fn five_point(x1: &[Vector3<f64>; 5], x2: &[Vector3<f64>; 5]) -> Vec<Matrix3<f64>> {
    let mut q = SMatrix::<f64, 9, 9>::zeros();
    for k in 0..5 {
        let (a, b) = (x1[k].normalize(), x2[k].normalize());
        let row = epipolar_row(&a, &b);
        for (j, v) in row.iter().enumerate() {
            q[(k, j)] = *v;
        }
    }
    if !q.iter().all(|v| v.is_finite()) {
        return Vec::new();
    }
    let Some(svd) = SVD::try_new(q, false, true, 1e-15, 200) else {
        return Vec::new();
    };
    let Some(v_t) = svd.v_t else {
        return Vec::new();
    };
    // The null space: the right singular vectors of the four smallest singular values
    // (sorted in descending order; rows 5..9 after the five constraints).
    let mut order: Vec<usize> = (0..9).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    if !(svd.singular_values[order[4]] > 1e-10 * svd.singular_values[order[0]]) {
        return Vec::new(); // fewer than five independent constraints
    }
    let basis: [[f64; 9]; 4] = core::array::from_fn(|k| {
        let r = order[5 + k];
        core::array::from_fn(|j| v_t[(r, j)])
    });
    // E = x·B0 + y·B1 + z·B2 + B3, entry-wise linear polynomials.
    let e: [[[f64; 4]; 3]; 3] = core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            let k = 3 * i + j;
            [basis[0][k], basis[1][k], basis[2][k], basis[3][k]]
        })
    });
    let ep: [[Poly; 3]; 3] =
        core::array::from_fn(|i| core::array::from_fn(|j| poly_from_linear(&e[i][j])));

    let mut m = SMatrix::<f64, 10, 20>::zeros();
    // det E by cofactors of the first row.
    let cof = |a: (usize, usize), b: (usize, usize), c: (usize, usize), d: (usize, usize)| {
        let mut p = mul_linear(&ep[a.0][a.1], &e[b.0][b.1]);
        add_scaled(&mut p, &mul_linear(&ep[c.0][c.1], &e[d.0][d.1]), -1.0);
        p
    };
    let cofactors = [
        cof((1, 1), (2, 2), (1, 2), (2, 1)),
        cof((1, 2), (2, 0), (1, 0), (2, 2)),
        cof((1, 0), (2, 1), (1, 1), (2, 0)),
    ];
    let mut det = [0.0; 20];
    for j in 0..3 {
        add_scaled(&mut det, &mul_linear(&cofactors[j], &e[0][j]), 1.0);
    }
    for (c, v) in det.iter().enumerate() {
        m[(0, c)] = *v;
    }
    // E Eᵀ (degree 2, symmetric) and its trace.
    let mut eet = [[[0.0; 20]; 3]; 3];
    for i in 0..3 {
        for j in i..3 {
            let mut p = [0.0; 20];
            for k in 0..3 {
                add_scaled(&mut p, &mul_linear(&ep[i][k], &e[j][k]), 1.0);
            }
            eet[i][j] = p;
            eet[j][i] = p;
        }
    }
    let mut half_trace = [0.0; 20];
    for (i, row) in eet.iter().enumerate() {
        add_scaled(&mut half_trace, &row[i], 0.5);
    }
    // E Eᵀ E − ½ tr(E Eᵀ) E = 0: nine cubic equations.
    for i in 0..3 {
        for j in 0..3 {
            let mut p = mul_linear(&half_trace, &e[i][j]);
            for v in p.iter_mut() {
                *v = -*v;
            }
            for k in 0..3 {
                add_scaled(&mut p, &mul_linear(&eet[i][k], &e[k][j]), 1.0);
            }
            for (c, v) in p.iter().enumerate() {
                m[(1 + 3 * i + j, c)] = *v;
            }
        }
    }

    // Gauss–Jordan elimination of the ten cubic monomials (partial pivoting).
    let scale = m.amax();
    if !(scale > 0.0 && scale.is_finite()) {
        return Vec::new();
    }
    for col in 0..10 {
        let mut piv = col;
        for r in col + 1..10 {
            if m[(r, col)].abs() > m[(piv, col)].abs() {
                piv = r;
            }
        }
        if !(m[(piv, col)].abs() > 1e-12 * scale) {
            return Vec::new();
        }
        m.swap_rows(col, piv);
        let p = m[(col, col)];
        for c in 0..20 {
            m[(col, c)] /= p;
        }
        for r in 0..10 {
            if r != col {
                let f = m[(r, col)];
                if f != 0.0 {
                    for c in 0..20 {
                        m[(r, c)] -= f * m[(col, c)];
                    }
                }
            }
        }
    }
    // Action matrix of multiplication by x on the basis b = (x², xy, xz, y², yz, z², x, y, z, 1):
    // x·b_i for i < 6 is the cubic monomial of row i (= −B_i·b), then x·x = x², x·y = xy,
    // x·z = xz, x·1 = x.
    let mut action = SMatrix::<f64, 10, 10>::zeros();
    for i in 0..6 {
        for j in 0..10 {
            action[(i, j)] = -m[(i, 10 + j)];
        }
    }
    action[(6, 0)] = 1.0;
    action[(7, 1)] = 1.0;
    action[(8, 2)] = 1.0;
    action[(9, 6)] = 1.0;
    let Some(schur) = Schur::try_new(action, 1e-14, 500) else {
        return Vec::new();
    };
    let eigenvalues = schur.complex_eigenvalues();
    let mut out: Vec<Matrix3<f64>> = Vec::new();
    for ev in eigenvalues.iter() {
        if !(ev.im.abs() <= 1e-8 * (1.0 + ev.re.abs())) || !ev.re.is_finite() {
            continue;
        }
        let lambda = ev.re;
        let shifted = action - SMatrix::<f64, 10, 10>::identity() * lambda;
        let Some(svd) = SVD::try_new(shifted, false, true, 1e-15, 200) else {
            continue;
        };
        let Some(vt) = svd.v_t else { continue };
        let (kmin, _) = svd.singular_values.argmin();
        let b: [f64; 10] = core::array::from_fn(|j| vt[(kmin, j)]);
        if !(b[9].abs() > 1e-12) {
            continue;
        }
        let (x, y, z) = (b[6] / b[9], b[7] / b[9], b[8] / b[9]);
        let v: [f64; 9] = core::array::from_fn(|k| {
            x * basis[0][k] + y * basis[1][k] + z * basis[2][k] + basis[3][k]
        });
        let em = matrix_from_row_major(&v);
        let norm = em.norm();
        if !(norm > 0.0 && norm.is_finite()) {
            continue;
        }
        let em = em / norm;
        // Repeated real eigenvalues give the same matrix twice: keep one.
        if out
            .iter()
            .any(|o| (o - em).norm() < 1e-9 || (o + em).norm() < 1e-9)
        {
            continue;
        }
        out.push(em);
    }
    out
}

/// Nearest essential matrix (singular values `(1, 1, 0)`, unit Frobenius norm up to `√2`
/// scaling) to `m` in the Frobenius sense; `None` when the SVD fails.
pub fn project_to_essential(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = SVD::try_new(*m, true, true, 1e-15, 200)?;
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0));
    let e = u * d * v_t;
    let n = e.norm();
    (n > 0.0 && n.is_finite()).then(|| e / n)
}

/// Linear 8-point essential matrix from `n ≥ 8` correspondences (normalized coordinates,
/// least squares on the algebraic error), projected onto the essential manifold; `None` with
/// fewer than 8 points or non-finite input.
pub fn eight_point(x1: &[Vector3<f64>], x2: &[Vector3<f64>]) -> Option<Matrix3<f64>> {
    if x1.len() != x2.len() || x1.len() < 8 {
        return None;
    }
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (a, b) in x1.iter().zip(x2) {
        let r = nalgebra::SVector::<f64, 9>::from(epipolar_row(&a.normalize(), &b.normalize()));
        ata += r * r.transpose();
    }
    if !ata.iter().all(|v| v.is_finite()) {
        return None;
    }
    let eig = SymmetricEigen::try_new(ata, 1e-15, 500)?;
    let (k, _) = eig.eigenvalues.argmin();
    let v: [f64; 9] = core::array::from_fn(|j| eig.eigenvectors[(j, k)]);
    project_to_essential(&matrix_from_row_major(&v))
}

/// Squared Sampson distance of a correspondence to `E`, in normalized units².
pub fn sampson_distance_sq(e: &Matrix3<f64>, x1: &Vector3<f64>, x2: &Vector3<f64>) -> f64 {
    let ex1 = e * x1;
    let etx2 = e.transpose() * x2;
    let num = x2.dot(&ex1);
    let den = ex1.x * ex1.x + ex1.y * ex1.y + etx2.x * etx2.x + etx2.y * etx2.y;
    if den > 0.0 {
        num * num / den
    } else {
        f64::INFINITY
    }
}

/// The four `(R₂₁, t₂₁)` decompositions of an essential matrix (`t₂₁` unit, both signs), or
/// `None` when the SVD fails.
pub fn decompose_essential(e: &Matrix3<f64>) -> Option<[RelativePose; 4]> {
    let svd = SVD::try_new(*e, true, true, 1e-15, 200)?;
    let (mut u, mut v_t) = (svd.u?, svd.v_t?);
    // Order by singular value: the null direction must be the third column.
    let (kmin, _) = svd.singular_values.argmin();
    if kmin != 2 {
        u.swap_columns(kmin, 2);
        v_t.swap_rows(kmin, 2);
    }
    if u.determinant() < 0.0 {
        u = -u;
    }
    if v_t.determinant() < 0.0 {
        v_t = -v_t;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let r1 = Rotation3::from_matrix_unchecked(u * w * v_t);
    let r2 = Rotation3::from_matrix_unchecked(u * w.transpose() * v_t);
    let t: Vector3<f64> = u.column(2).into_owned().normalize();
    Some([
        RelativePose { r_21: r1, t_21: t },
        RelativePose { r_21: r1, t_21: -t },
        RelativePose { r_21: r2, t_21: t },
        RelativePose { r_21: r2, t_21: -t },
    ])
}

/// Depths `(λ₁, λ₂)` along the bearings `f₁`, `f₂` of the point closest to both rays, for
/// `X₂ = R X₁ + t` (least squares on `λ₂ f₂ = λ₁ R f₁ + t`); `None` for parallel rays.
fn ray_depths(pose: &RelativePose, f1: &Vector3<f64>, f2: &Vector3<f64>) -> Option<(f64, f64)> {
    let a = pose.r_21 * f1;
    let b = -f2;
    // [a b] [λ₁ λ₂]ᵀ = −t
    let (aa, ab, bb) = (a.dot(&a), a.dot(&b), b.dot(&b));
    let det = aa * bb - ab * ab;
    if !(det > 1e-12 * aa * bb) {
        return None;
    }
    let (ra, rb) = (-a.dot(&pose.t_21), -b.dot(&pose.t_21));
    let l1 = (bb * ra - ab * rb) / det;
    let l2 = (aa * rb - ab * ra) / det;
    Some((l1, l2))
}

fn count_in_front(
    pose: &RelativePose,
    x1: &[Vector3<f64>],
    x2: &[Vector3<f64>],
    mask: Option<&[bool]>,
    max_distance: f64,
) -> Vec<bool> {
    x1.iter()
        .zip(x2)
        .enumerate()
        .map(|(i, (a, b))| {
            if mask.is_some_and(|m| !m.get(i).copied().unwrap_or(false)) {
                return false;
            }
            let (f1, f2) = (a.normalize(), b.normalize());
            match ray_depths(pose, &f1, &f2) {
                // Unit baseline: λ₁ is the distance from camera 1 in baselines.
                // (bearings of pixels have z > 0, so positive depth along a ray is z > 0).
                Some((l1, l2)) => l1 > 0.0 && l2 > 0.0 && l1 < max_distance,
                None => false,
            }
        })
        .collect()
}

/// Signed Sampson residual of a correspondence for `E`, normalized units.
fn sampson_residual(e: &Matrix3<f64>, x1: &Vector3<f64>, x2: &Vector3<f64>) -> f64 {
    let ex1 = e * x1;
    let etx2 = e.transpose() * x2;
    let den = ex1.x * ex1.x + ex1.y * ex1.y + etx2.x * etx2.x + etx2.y * etx2.y;
    if den > 0.0 {
        x2.dot(&ex1) / den.sqrt()
    } else {
        0.0
    }
}

/// Refines a relative pose by Levenberg–Marquardt on the squared Sampson distances of the
/// selected correspondences (`mask`, all when `None`), over the 5 degrees of freedom of
/// `(R₂₁, t₂₁)`: `R ← exp(ω) R`, `t ← normalize(t + B β)` with `B` a basis of the tangent plane
/// of the unit sphere at `t`. Returns the input unchanged when fewer than 6 points are
/// selected or no step lowers the cost.
pub fn refine_relative_pose(
    pose: &RelativePose,
    x1: &[Vector3<f64>],
    x2: &[Vector3<f64>],
    mask: Option<&[bool]>,
    max_iterations: usize,
) -> RelativePose {
    let idx: Vec<usize> = (0..x1.len().min(x2.len()))
        .filter(|&i| mask.is_none_or(|m| m.get(i).copied().unwrap_or(false)))
        .filter(|&i| x1[i].iter().chain(x2[i].iter()).all(|v| v.is_finite()))
        .collect();
    if idx.len() < 6 {
        return *pose;
    }
    let essential_of = |p: &RelativePose| crate::so3::hat(&p.t_21) * p.r_21.matrix();
    let cost_of = |p: &RelativePose| -> f64 {
        let e = essential_of(p);
        idx.iter()
            .map(|&i| sampson_residual(&e, &x1[i], &x2[i]).powi(2))
            .sum()
    };
    let apply = |p: &RelativePose, d: &nalgebra::Vector5<f64>| -> RelativePose {
        let t = p.t_21;
        let helper = if t.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let b1 = t.cross(&helper).normalize();
        let b2 = t.cross(&b1);
        let r = crate::so3::exp(&Vector3::new(d[0], d[1], d[2])) * p.r_21;
        let t = (t + b1 * d[3] + b2 * d[4]).normalize();
        RelativePose { r_21: r, t_21: t }
    };
    let mut current = *pose;
    let mut cost = cost_of(&current);
    let mut lambda = 1e-3;
    let h = 1e-7;
    for _ in 0..max_iterations {
        // Forward-difference Jacobian of the residuals (5 parameters).
        let e0 = essential_of(&current);
        let r0: Vec<f64> = idx
            .iter()
            .map(|&i| sampson_residual(&e0, &x1[i], &x2[i]))
            .collect();
        let mut jtj = nalgebra::Matrix5::<f64>::zeros();
        let mut jtr = nalgebra::Vector5::<f64>::zeros();
        let mut cols: [Vec<f64>; 5] = Default::default();
        for (k, col) in cols.iter_mut().enumerate() {
            let mut d = nalgebra::Vector5::zeros();
            d[k] = h;
            let e = essential_of(&apply(&current, &d));
            *col = idx
                .iter()
                .zip(&r0)
                .map(|(&i, r)| (sampson_residual(&e, &x1[i], &x2[i]) - r) / h)
                .collect();
        }
        for (row, r) in r0.iter().enumerate() {
            let j = nalgebra::Vector5::from_fn(|k, _| cols[k][row]);
            jtj += j * j.transpose();
            jtr += j * *r;
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj;
            for k in 0..5 {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| -c.solve(&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let candidate = apply(&current, &step);
            let c = cost_of(&candidate);
            if c < cost {
                let rel = (cost - c) / cost.max(f64::MIN_POSITIVE);
                current = candidate;
                cost = c;
                lambda = (lambda * 0.3).max(1e-9);
                improved = rel > 1e-10;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    current
}

/// Decomposes `E` and keeps the `(R₂₁, t₂₁)` with the most correspondences (among `mask`, all
/// when `None`) triangulated in front of both cameras and closer than `max_distance_baselines`
/// baselines (OpenCV's `recoverPose`).
///
/// # Errors
/// [`EssentialError::LengthMismatch`] when `x1` and `x2` differ in length, and
/// [`EssentialError::NoConsensus`] when `E` cannot be decomposed or no point is in front.
pub fn recover_pose(
    e: &Matrix3<f64>,
    x1: &[Vector3<f64>],
    x2: &[Vector3<f64>],
    mask: Option<&[bool]>,
    max_distance_baselines: f64,
) -> Result<RecoveredPose, EssentialError> {
    if x1.len() != x2.len() {
        return Err(EssentialError::LengthMismatch {
            first: x1.len(),
            second: x2.len(),
        });
    }
    let candidates = decompose_essential(e).ok_or(EssentialError::NoConsensus {
        best_inliers: 0,
        min_inliers: 1,
    })?;
    let mut best: Option<RecoveredPose> = None;
    for pose in candidates {
        let in_front = count_in_front(&pose, x1, x2, mask, max_distance_baselines);
        let in_front_count = in_front.iter().filter(|&&b| b).count();
        if best
            .as_ref()
            .is_none_or(|b| in_front_count > b.in_front_count)
        {
            best = Some(RecoveredPose {
                pose,
                in_front,
                in_front_count,
            });
        }
    }
    match best {
        Some(b) if b.in_front_count > 0 => Ok(b),
        _ => Err(EssentialError::NoConsensus {
            best_inliers: 0,
            min_inliers: 1,
        }),
    }
}

/// Estimates the relative pose of two views from pixel correspondences (`pixels1[i]` in view
/// 1 matches `pixels2[i]` in view 2, same `camera`): undistorts them, runs
/// [`ransac_essential_normalized`] with the focal length `√(fx·fy)`.
///
/// # Errors
/// As [`ransac_essential_normalized`]; pixels that cannot be undistorted are skipped (never
/// inliers).
pub fn ransac_essential(
    pixels1: &[Point2<f64>],
    pixels2: &[Point2<f64>],
    camera: &Camera,
    cfg: &EssentialRansacConfig,
) -> Result<EssentialEstimate, EssentialError> {
    if pixels1.len() != pixels2.len() {
        return Err(EssentialError::LengthMismatch {
            first: pixels1.len(),
            second: pixels2.len(),
        });
    }
    let nan = Vector2::new(f64::NAN, f64::NAN);
    let mut x1 = Vec::with_capacity(pixels1.len());
    let mut x2 = Vec::with_capacity(pixels2.len());
    for (index, (a, b)) in pixels1.iter().zip(pixels2).enumerate() {
        if !(a
            .coords
            .iter()
            .chain(b.coords.iter())
            .all(|v| v.is_finite()))
        {
            return Err(EssentialError::NonFinite { index });
        }
        match (camera.normalized(a), camera.normalized(b)) {
            (Some(p), Some(q)) => {
                x1.push(p);
                x2.push(q);
            }
            _ => {
                x1.push(nan);
                x2.push(nan);
            }
        }
    }
    ransac_essential_normalized(&x1, &x2, (camera.fx * camera.fy).sqrt(), cfg)
}

/// Estimates the relative pose of two views from normalized image coordinates `(X/Z, Y/Z)`
/// (`x1[i]` in view 1 matches `x2[i]` in view 2); `focal_px` converts the Sampson distance to
/// pixels for the threshold. Correspondences with a NaN coordinate are skipped.
///
/// # Errors
/// [`EssentialError::LengthMismatch`], [`EssentialError::NonFinite`] (an infinite
/// coordinate), [`EssentialError::InvalidFocal`], [`EssentialError::TooFewCorrespondences`]
/// below 6 usable correspondences, and [`EssentialError::NoConsensus`] when no hypothesis
/// gathers `cfg.min_inliers` inliers with points in front of both cameras.
pub fn ransac_essential_normalized(
    x1: &[Vector2<f64>],
    x2: &[Vector2<f64>],
    focal_px: f64,
    cfg: &EssentialRansacConfig,
) -> Result<EssentialEstimate, EssentialError> {
    if x1.len() != x2.len() {
        return Err(EssentialError::LengthMismatch {
            first: x1.len(),
            second: x2.len(),
        });
    }
    if !(focal_px.is_finite() && focal_px > 0.0) {
        return Err(EssentialError::InvalidFocal { focal_px });
    }
    let mut usable = Vec::with_capacity(x1.len());
    for (index, (a, b)) in x1.iter().zip(x2).enumerate() {
        let vals = [a.x, a.y, b.x, b.y];
        if vals.iter().any(|v| v.is_nan()) {
            continue;
        }
        if vals.iter().any(|v| !v.is_finite()) {
            return Err(EssentialError::NonFinite { index });
        }
        usable.push(index);
    }
    let h1: Vec<Vector3<f64>> = x1.iter().map(|v| Vector3::new(v.x, v.y, 1.0)).collect();
    let h2: Vec<Vector3<f64>> = x2.iter().map(|v| Vector3::new(v.x, v.y, 1.0)).collect();
    let m = usable.len();
    if m < 6 {
        return Err(EssentialError::TooFewCorrespondences { usable: m });
    }
    let tau = cfg.threshold_px / focal_px;
    let tau2 = tau * tau;
    let score = |e: &Matrix3<f64>, limit: f64| -> f64 {
        let mut s = 0.0;
        for &i in &usable {
            s += sampson_distance_sq(e, &h1[i], &h2[i]).min(tau2);
            if s > limit {
                return f64::INFINITY;
            }
        }
        s
    };
    let inlier_mask = |e: &Matrix3<f64>| -> Vec<bool> {
        let mut mask = vec![false; x1.len()];
        for &i in &usable {
            mask[i] = sampson_distance_sq(e, &h1[i], &h2[i]) < tau2;
        }
        mask
    };

    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut best: Option<(f64, Matrix3<f64>)> = None;
    let mut needed = cfg.max_iterations.max(cfg.min_iterations);
    let mut iterations = 0;
    let log_fail = (1.0 - cfg.confidence.clamp(1e-9, 1.0 - 1e-12)).ln();
    let mut sample = [0usize; 5];
    while iterations
        < needed
            .max(cfg.min_iterations)
            .min(cfg.max_iterations.max(1))
    {
        iterations += 1;
        // Five distinct indices (rejection: m ≥ 6 keeps this short).
        let mut k = 0;
        while k < 5 {
            let c = rng.random_range(0..m);
            if !sample[..k].contains(&c) {
                sample[k] = c;
                k += 1;
            }
        }
        let a: [Vector3<f64>; 5] = core::array::from_fn(|j| h1[usable[sample[j]]]);
        let b: [Vector3<f64>; 5] = core::array::from_fn(|j| h2[usable[sample[j]]]);
        for e in five_point(&a, &b) {
            let limit = best.map_or(f64::INFINITY, |b| b.0);
            let s = score(&e, limit);
            if s < limit {
                best = Some((s, e));
                let inl = usable
                    .iter()
                    .filter(|&&i| sampson_distance_sq(&e, &h1[i], &h2[i]) < tau2)
                    .count();
                let w = inl as f64 / m as f64;
                let p_all = w.powi(5);
                needed = if p_all >= 1.0 - 1e-12 {
                    cfg.min_iterations
                } else if p_all <= 0.0 {
                    cfg.max_iterations
                } else {
                    let n = (log_fail / (1.0 - p_all).ln()).ceil();
                    if n.is_finite() {
                        (n as usize).min(cfg.max_iterations)
                    } else {
                        cfg.max_iterations
                    }
                };
            }
        }
    }
    let Some((mut best_score, mut essential)) = best else {
        return Err(EssentialError::NoConsensus {
            best_inliers: 0,
            min_inliers: cfg.min_inliers,
        });
    };
    if cfg.refit_on_inliers {
        // Two rounds of 8-point re-fits on the current inliers.
        for _ in 0..2 {
            let mask = inlier_mask(&essential);
            let (p1, p2): (Vec<_>, Vec<_>) = (0..x1.len())
                .filter(|&i| mask[i])
                .map(|i| (h1[i], h2[i]))
                .unzip();
            let Some(e) = eight_point(&p1, &p2) else {
                break;
            };
            let s = score(&e, f64::INFINITY);
            if s <= best_score {
                best_score = s;
                essential = e;
            } else {
                break;
            }
        }
    }
    let inliers = inlier_mask(&essential);
    let inlier_count = inliers.iter().filter(|&&b| b).count();
    if inlier_count < cfg.min_inliers.max(5) {
        return Err(EssentialError::NoConsensus {
            best_inliers: inlier_count,
            min_inliers: cfg.min_inliers,
        });
    }
    let recovered = recover_pose(
        &essential,
        &h1,
        &h2,
        Some(&inliers),
        cfg.max_distance_baselines,
    )
    .map_err(|_| EssentialError::NoConsensus {
        best_inliers: 0,
        min_inliers: cfg.min_inliers,
    })?;
    let mut pose = recovered.pose;
    let mut in_front = recovered.in_front;
    let mut in_front_count = recovered.in_front_count;
    // Local optimization: refine on the inliers in front, re-select the inliers, repeat while
    // the MSAC score improves.
    if cfg.refine_iterations > 0 {
        for _ in 0..3 {
            let refined =
                refine_relative_pose(&pose, &h1, &h2, Some(&in_front), cfg.refine_iterations);
            let e = crate::so3::hat(&refined.t_21) * refined.r_21.matrix();
            let e = e / e.norm();
            let s = score(&e, f64::INFINITY);
            if !(s < best_score) {
                break;
            }
            let front = count_in_front(
                &refined,
                &h1,
                &h2,
                Some(&inlier_mask(&e)),
                cfg.max_distance_baselines,
            );
            let count = front.iter().filter(|&&b| b).count();
            if 10 * count < 9 * in_front_count {
                break;
            }
            best_score = s;
            essential = e;
            pose = refined;
            in_front = front;
            in_front_count = count;
        }
    }
    let inliers = inlier_mask(&essential);
    let inlier_count = inliers.iter().filter(|&&b| b).count();
    Ok(EssentialEstimate {
        essential,
        pose,
        inliers,
        inlier_count,
        in_front,
        in_front_count,
        iterations,
        score_px2: best_score * focal_px * focal_px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monomial_table_is_consistent() {
        for (i, e) in EXPONENTS.iter().enumerate() {
            assert_eq!(monomial_index(e.0, e.1, e.2), i);
        }
        // x · x² = x³, y · yz = y²z, z · 1 = z.
        assert_eq!(TIMES_XYZ[0][0], 0);
        assert_eq!(TIMES_XYZ[4][1], 7);
        assert_eq!(TIMES_XYZ[9][2], 18);
    }
}
