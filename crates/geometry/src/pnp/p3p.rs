//! Minimal absolute-pose solver from three 2D–3D correspondences (P3P).
//!
//! Grunert's formulation: with unit bearings `fᵢ` (camera frame), distances `sᵢ` along them and
//! the known world distances `dᵢⱼ`, the law of cosines gives
//! `sᵢ² + sⱼ² − 2 sᵢ sⱼ cos θᵢⱼ = dᵢⱼ²`. Writing `s₂ = u s₁`, `s₃ = v s₁` and eliminating `s₁`
//! leaves two quadratics in `u` whose coefficients are polynomials in `v`; their resultant is a
//! quartic in `v`, built here numerically by polynomial products (no hand-expanded
//! coefficients). Each positive real root gives `u` (from the difference of the two
//! quadratics), then `s₁`, the three camera-frame points, and the pose by aligning the two
//! point triangles. Up to four solutions.
//!
//! Real roots are isolated with the critical points of the polynomial (recursively through its
//! derivatives) and polished by safeguarded Newton iterations: no eigen-solver, no iteration
//! that can run forever, no heap.

use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};

use crate::pose::Pose;

/// Up to four real numbers (roots or poses) without heap allocation.
#[derive(Debug, Clone, Copy)]
pub struct Solutions<T: Copy, const N: usize> {
    items: [Option<T>; N],
    len: usize,
}

impl<T: Copy, const N: usize> Solutions<T, N> {
    fn new() -> Self {
        Self {
            items: [None; N],
            len: 0,
        }
    }

    fn push(&mut self, v: T) {
        if self.len < N {
            self.items[self.len] = Some(v);
            self.len += 1;
        }
    }

    /// Number of solutions.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there is no solution.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The solutions, in no particular order.
    pub fn iter(&self) -> impl Iterator<Item = T> + '_ {
        self.items[..self.len].iter().filter_map(|v| *v)
    }
}

/// Horner evaluation of `Σ c[i] xⁱ` and its derivative.
fn eval(c: &[f64], x: f64) -> (f64, f64) {
    let mut p = 0.0;
    let mut dp = 0.0;
    for &a in c.iter().rev() {
        dp = dp * x + p;
        p = p * x + a;
    }
    (p, dp)
}

/// A root of `c` in `[a, b]` where `c(a)` and `c(b)` differ in sign: Newton steps kept inside
/// the bracket, bisection otherwise.
fn bracketed_root(c: &[f64], mut a: f64, mut b: f64) -> f64 {
    let (fa, _) = eval(c, a);
    if fa > 0.0 {
        std::mem::swap(&mut a, &mut b); // keep f(a) < 0 < f(b)
    }
    let mut x = 0.5 * (a + b);
    for _ in 0..100 {
        let (f, df) = eval(c, x);
        if f == 0.0 {
            return x;
        }
        if f < 0.0 {
            a = x;
        } else {
            b = x;
        }
        let newton = x - f / df;
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        let next = if df != 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (a + b)
        };
        if (next - x).abs() <= 1e-15 * (1.0 + x.abs()) {
            return next;
        }
        x = next;
    }
    x
}

/// Real roots of the polynomial `Σ c[i] xⁱ` (degree ≤ 4, ascending coefficients), ascending.
/// Roots of even multiplicity (touching zero without a sign change) may be missed.
pub fn real_roots(c: &[f64]) -> Solutions<f64, 4> {
    let mut out = Solutions::new();
    let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(c.iter().all(|v| v.is_finite()) && scale > 0.0) {
        return out;
    }
    let mut deg = c.len().saturating_sub(1).min(4);
    while deg > 0 && c[deg].abs() <= 1e-13 * scale {
        deg -= 1;
    }
    match deg {
        0 => return out,
        1 => {
            out.push(-c[0] / c[1]);
            return out;
        }
        _ => {}
    }
    let c = &c[..=deg];
    // Cauchy bound: every root lies in [-B, B].
    let bound = 1.0
        + c[..deg]
            .iter()
            .fold(0.0f64, |m, v| m.max((v / c[deg]).abs()));
    let mut d = [0.0; 4];
    for i in 0..deg {
        d[i] = (i + 1) as f64 * c[i + 1];
    }
    let crit = real_roots(&d[..deg]);
    let mut points = [0.0; 6];
    let mut n = 0;
    points[n] = -bound;
    n += 1;
    for x in crit.iter() {
        if x > -bound && x < bound {
            points[n] = x;
            n += 1;
        }
    }
    points[n] = bound;
    n += 1;
    for w in points[..n].windows(2) {
        let (fa, _) = eval(c, w[0]);
        let (fb, _) = eval(c, w[1]);
        if fa == 0.0 {
            out.push(w[0]);
        } else if fa.signum() != fb.signum() && fb != 0.0 {
            out.push(bracketed_root(c, w[0], w[1]));
        }
    }
    if eval(c, bound).0 == 0.0 {
        out.push(bound);
    }
    out
}

fn poly_mul(a: &[f64; 5], b: &[f64; 5]) -> [f64; 5] {
    let mut out = [0.0; 5];
    for i in 0..5 {
        for j in 0..5 - i {
            out[i + j] += a[i] * b[j];
        }
    }
    out
}

fn poly_sub(a: &[f64; 5], b: &[f64; 5]) -> [f64; 5] {
    std::array::from_fn(|i| a[i] - b[i])
}

/// A right-handed orthonormal frame attached to the triangle `(p0, p1, p2)`; two congruent
/// triangles' frames give the rotation between them. `None` for a collinear triangle.
fn frame(p0: &Vector3<f64>, p1: &Vector3<f64>, p2: &Vector3<f64>) -> Option<Matrix3<f64>> {
    let e1 = (p1 - p0).try_normalize(1e-12)?;
    let e3 = e1.cross(&(p2 - p0)).try_normalize(1e-12)?;
    let e2 = e3.cross(&e1);
    Some(Matrix3::from_columns(&[e1, e2, e3]))
}

/// All P3P poses `T_wc` (mm) consistent with three world points (mm) and their unit viewing
/// rays in the camera frame (`bearings[i]` points at `points_world[i]`).
///
/// Returns no solution for degenerate input (collinear or coincident points, parallel rays,
/// non-finite values).
pub fn p3p(points_world: &[Point3<f64>; 3], bearings: &[Vector3<f64>; 3]) -> Solutions<Pose, 4> {
    let mut out = Solutions::new();
    let [p1, p2, p3] = points_world.map(|p| p.coords);
    let [f1, f2, f3] = *bearings;
    let (c12, c13, c23) = (f1.dot(&f2), f1.dot(&f3), f2.dot(&f3));
    let (a, b, c) = (
        (p2 - p3).norm_squared(),
        (p1 - p3).norm_squared(),
        (p1 - p2).norm_squared(),
    );
    if !(a > 0.0 && b > 0.0 && c > 0.0 && [c12, c13, c23].iter().all(|v| v.is_finite())) {
        return out;
    }
    // Quadratics in u (leading coefficient b in both), coefficients ascending in v:
    //   Q1: b u² + B1 u + C1(v),  from  b(1 + u² − 2u c12) = c(1 + v² − 2v c13)
    //   Q2: b u² + B2(v) u + C2(v), from b(u² + v² − 2uv c23) = a(1 + v² − 2v c13)
    let b1 = [-2.0 * b * c12, 0.0, 0.0, 0.0, 0.0];
    let c1 = [b - c, 2.0 * c * c13, -c, 0.0, 0.0];
    let b2 = [0.0, -2.0 * b * c23, 0.0, 0.0, 0.0];
    let c2 = [-a, 2.0 * a * c13, b - a, 0.0, 0.0];
    // Resultant / b:  b (C2 − C1)² − (B2 − B1)(B1 C2 − B2 C1).
    let dc = poly_sub(&c2, &c1);
    let db = poly_sub(&b2, &b1);
    let cross = poly_sub(&poly_mul(&b1, &c2), &poly_mul(&b2, &c1));
    let quartic = poly_sub(&poly_mul(&dc, &dc).map(|v| v * b), &poly_mul(&db, &cross));
    let fw = frame(&p1, &p2, &p3);
    let Some(fw) = fw else {
        return out;
    };
    for v in real_roots(&quartic).iter() {
        if !(v > 0.0) {
            continue;
        }
        let (b1v, _) = eval(&b1, v);
        let (c1v, _) = eval(&c1, v);
        let (b2v, _) = eval(&b2, v);
        let (c2v, _) = eval(&c2, v);
        // Q1 − Q2 = (B1 − B2) u + (C1 − C2) = 0.
        let den = b1v - b2v;
        let mut candidates = [f64::NAN; 2];
        if den.abs() > 1e-12 * (b1v.abs() + b2v.abs() + 1e-300) {
            candidates[0] = (c2v - c1v) / den;
        } else {
            // Solve Q1 directly; Q2 then holds for both roots up to rounding.
            let disc = b1v * b1v - 4.0 * b * c1v;
            if disc >= 0.0 {
                let sq = disc.sqrt();
                candidates = [(-b1v + sq) / (2.0 * b), (-b1v - sq) / (2.0 * b)];
            }
        }
        for u in candidates {
            if !(u > 0.0) {
                continue;
            }
            let denom = 1.0 + v * v - 2.0 * v * c13;
            if !(denom > 0.0) {
                continue;
            }
            let s1 = (b / denom).sqrt();
            // Newton polish of the distances on the three law-of-cosines equations: the
            // quartic's root can be ill-conditioned near a double root.
            let mut d = Vector3::new(s1, u * s1, v * s1);
            for _ in 0..3 {
                let (x, y, z) = (d.x, d.y, d.z);
                let f = Vector3::new(
                    x * x + y * y - 2.0 * x * y * c12 - c,
                    x * x + z * z - 2.0 * x * z * c13 - b,
                    y * y + z * z - 2.0 * y * z * c23 - a,
                );
                let j = Matrix3::new(
                    2.0 * (x - y * c12),
                    2.0 * (y - x * c12),
                    0.0,
                    2.0 * (x - z * c13),
                    0.0,
                    2.0 * (z - x * c13),
                    0.0,
                    2.0 * (y - z * c23),
                    2.0 * (z - y * c23),
                );
                match j.try_inverse() {
                    Some(inv) => {
                        let next = d - inv * f;
                        if next.iter().all(|v| v.is_finite() && *v > 0.0) {
                            d = next;
                        } else {
                            break;
                        }
                    }
                    None => break,
                }
            }
            let (x1, x2, x3) = (f1 * d.x, f2 * d.y, f3 * d.z);
            let Some(fc) = frame(&x1, &x2, &x3) else {
                continue;
            };
            // X = R_cw P + t_cw  ⇒  R_cw = Fc Fwᵀ.
            let r_cw = fc * fw.transpose();
            let centroid_c = (x1 + x2 + x3) / 3.0;
            let centroid_w = (p1 + p2 + p3) / 3.0;
            let t_cw = centroid_c - r_cw * centroid_w;
            let q_cw =
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r_cw));
            let t_wc = Pose::from_parts((-(q_cw.inverse() * t_cw)).into(), q_cw.inverse());
            if t_wc.translation.vector.iter().all(|x| x.is_finite()) {
                out.push(t_wc);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::{orientation_error_deg, position_error_mm};
    use crate::synthetic::{PnpSceneConfig, pnp_scene};

    #[test]
    fn real_roots_of_known_polynomials() {
        // (x − 1)(x + 2)(x − 3)(x − 0.5) = x⁴ − 2.5x³ − 4x² + 8.5x − 3
        let r: Vec<f64> = real_roots(&[-3.0, 8.5, -4.0, -2.5, 1.0]).iter().collect();
        let expect = [-2.0, 0.5, 1.0, 3.0];
        assert_eq!(r.len(), 4, "{r:?}");
        for (a, b) in r.iter().zip(expect) {
            assert!((a - b).abs() < 1e-12, "{r:?}");
        }
        // x² + 1: no real root; a cubic written with a zero leading term.
        assert!(real_roots(&[1.0, 0.0, 1.0]).is_empty());
        let cubic: Vec<f64> = real_roots(&[-6.0, 11.0, -6.0, 1.0, 0.0]).iter().collect();
        assert_eq!(cubic.len(), 3);
        assert!(real_roots(&[f64::NAN, 1.0]).is_empty());
    }

    #[test]
    fn p3p_finds_the_true_pose_among_its_solutions() {
        for seed in 0..200 {
            let s = pnp_scene(
                &PnpSceneConfig {
                    points: 3,
                    noise_px: 0.0,
                    outlier_fraction: 0.0,
                    ..Default::default()
                },
                seed,
            );
            let pts = [s.points_world[0], s.points_world[1], s.points_world[2]];
            let bearings = [0, 1, 2].map(|i| s.camera.ray(&s.pixels[i]).unwrap());
            let sols = p3p(&pts, &bearings);
            assert!(!sols.is_empty(), "seed {seed}");
            let best = sols
                .iter()
                .map(|t| position_error_mm(&t, &s.t_wc) + orientation_error_deg(&t, &s.t_wc))
                .fold(f64::INFINITY, f64::min);
            assert!(best < 1e-6, "seed {seed}: best {best}");
            for t in sols.iter() {
                // Every solution reprojects the three points exactly and in front.
                for i in 0..3 {
                    let pc = t.inverse_transform_point(&pts[i]);
                    assert!(pc.z > 0.0);
                    assert!((pc.coords.normalize() - bearings[i]).norm() < 1e-6);
                }
            }
        }
    }

    #[test]
    fn degenerate_triples_give_no_solution() {
        let f = Vector3::new(0.0, 0.0, 1.0);
        let collinear = [
            Point3::new(0.0, 0.0, 10.0),
            Point3::new(1.0, 0.0, 10.0),
            Point3::new(2.0, 0.0, 10.0),
        ];
        let bearings = [
            f,
            Vector3::new(0.1, 0.0, 1.0).normalize(),
            Vector3::new(0.2, 0.0, 1.0).normalize(),
        ];
        assert!(p3p(&collinear, &bearings).is_empty());
        let coincident = [collinear[0]; 3];
        assert!(p3p(&coincident, &bearings).is_empty());
        let nan = [Point3::new(f64::NAN, 0.0, 1.0), collinear[1], collinear[2]];
        assert!(p3p(&nan, &bearings).is_empty());
    }
}
