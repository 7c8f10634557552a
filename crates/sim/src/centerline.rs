//! The colon's mid-line: an arc-length parametrised curve with rotation-minimising frames.
//!
//! Every other part of the simulator is expressed along this curve: the tube's surface
//! coordinates `(s, θ)`, the anatomical section of a point, the scope's progress.

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

use crate::SimError;

/// A mid-line resampled at a uniform arc-length step, with a parallel-transport
/// (rotation-minimising) frame at every sample.
///
/// Frame convention at sample `i`: `tangent[i]` points towards the caecum (increasing `s`);
/// `normal[i]` and `binormal[i] = tangent × normal` span the cross-section. The angle `θ` of a
/// point around the mid-line is measured from `normal` towards `binormal`.
#[derive(Debug, Clone)]
pub struct Centerline {
    /// Arc-length step between samples, mm.
    pub step_mm: f64,
    /// Sample positions, world frame, mm.
    pub points: Vec<Point3<f64>>,
    /// Unit tangents.
    pub tangents: Vec<Vector3<f64>>,
    /// Unit normals (parallel-transported, no twist).
    pub normals: Vec<Vector3<f64>>,
    /// Unit binormals `tangent × normal`.
    pub binormals: Vec<Vector3<f64>>,
}

/// Where a point projects on the mid-line.
#[derive(Debug, Clone, Copy)]
pub struct CurvePosition {
    /// Nearest sample index.
    pub index: usize,
    /// Arc length of the projection, mm (may extend past the ends by the tangent offset).
    pub s_mm: f64,
    /// Angle around the mid-line, radians in `[0, 2π)`.
    pub theta: f64,
    /// Distance from the mid-line sample, mm.
    pub radial_mm: f64,
}

impl Centerline {
    /// Resamples a polyline at a uniform arc-length `step_mm` and computes frames.
    ///
    /// Consecutive duplicate points are skipped.
    ///
    /// # Errors
    /// [`SimError::InvalidPath`] when the polyline has fewer than two distinct points,
    /// non-finite coordinates, or is shorter than one step.
    pub fn from_polyline(points: &[Point3<f64>], step_mm: f64) -> Result<Self, SimError> {
        if !(step_mm.is_finite() && step_mm > 0.0) {
            return Err(SimError::InvalidPath(format!(
                "resampling step must be positive, got {step_mm}"
            )));
        }
        if let Some(i) = points
            .iter()
            .position(|p| !p.coords.iter().all(|v| v.is_finite()))
        {
            return Err(SimError::InvalidPath(format!(
                "mid-line point {i} is not finite: {:?}",
                points[i]
            )));
        }
        let mut pts: Vec<Point3<f64>> = Vec::with_capacity(points.len());
        for p in points {
            if pts.last().is_none_or(|q| (p - q).norm() > 1e-9) {
                pts.push(*p);
            }
        }
        if pts.len() < 2 {
            return Err(SimError::InvalidPath(
                "a mid-line needs at least two distinct points".into(),
            ));
        }
        let mut cumulative = vec![0.0; pts.len()];
        for i in 1..pts.len() {
            cumulative[i] = cumulative[i - 1] + (pts[i] - pts[i - 1]).norm();
        }
        let length = cumulative[pts.len() - 1];
        if length < step_mm {
            return Err(SimError::InvalidPath(format!(
                "mid-line is {length:.3} mm long, shorter than one step of {step_mm} mm"
            )));
        }
        let n = (length / step_mm).floor() as usize + 1;
        let mut out = Vec::with_capacity(n);
        let mut seg = 0;
        for k in 0..n {
            let s = k as f64 * step_mm;
            while seg + 2 < pts.len() && cumulative[seg + 1] < s {
                seg += 1;
            }
            let (s0, s1) = (cumulative[seg], cumulative[seg + 1]);
            let t = ((s - s0) / (s1 - s0)).clamp(0.0, 1.0);
            out.push(pts[seg] + (pts[seg + 1] - pts[seg]) * t);
        }
        Ok(Self::from_uniform_samples(out, step_mm))
    }

    /// Builds frames for samples already spaced `step_mm` apart (at least two samples).
    fn from_uniform_samples(points: Vec<Point3<f64>>, step_mm: f64) -> Self {
        let n = points.len();
        let mut tangents = Vec::with_capacity(n);
        for i in 0..n {
            let a = points[i.saturating_sub(1)];
            let b = points[(i + 1).min(n - 1)];
            let d = b - a;
            let t = if d.norm() > 1e-12 {
                d.normalize()
            } else {
                tangents.last().copied().unwrap_or(Vector3::z())
            };
            tangents.push(t);
        }
        // Initial normal: any unit vector orthogonal to the first tangent.
        let t0 = tangents[0];
        let helper = if t0.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let mut normals = Vec::with_capacity(n);
        normals.push((helper - t0 * t0.dot(&helper)).normalize());
        for i in 1..n {
            // Parallel transport: rotate the previous normal by the rotation taking the previous
            // tangent onto the current one.
            let prev = normals[i - 1];
            let q = UnitQuaternion::rotation_between(&tangents[i - 1], &tangents[i])
                .unwrap_or_else(UnitQuaternion::identity);
            let mut nrm = q * prev;
            nrm -= tangents[i] * tangents[i].dot(&nrm);
            normals.push(nrm.normalize());
        }
        let binormals = tangents
            .iter()
            .zip(&normals)
            .map(|(t, n)| t.cross(n))
            .collect();
        Centerline {
            step_mm,
            points,
            tangents,
            normals,
            binormals,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the curve has no samples (never true for a constructed curve).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Total arc length, mm.
    pub fn length_mm(&self) -> f64 {
        (self.points.len() - 1) as f64 * self.step_mm
    }

    /// Sample index nearest to arc length `s_mm` (clamped to the curve).
    pub fn index_at(&self, s_mm: f64) -> usize {
        ((s_mm / self.step_mm).round().max(0.0) as usize).min(self.points.len() - 1)
    }

    /// Linearly interpolated position at arc length `s_mm` (clamped to the curve).
    pub fn point_at(&self, s_mm: f64) -> Point3<f64> {
        let (i, t) = self.segment_at(s_mm);
        self.points[i] + (self.points[i + 1] - self.points[i]) * t
    }

    /// Interpolated frame `(tangent, normal, binormal)` at arc length `s_mm`.
    pub fn frame_at(&self, s_mm: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let (i, t) = self.segment_at(s_mm);
        let tan = Unit::new_normalize(self.tangents[i].lerp(&self.tangents[i + 1], t));
        let mut nrm = self.normals[i].lerp(&self.normals[i + 1], t);
        nrm -= tan.into_inner() * tan.dot(&nrm);
        let nrm = nrm.normalize();
        (tan.into_inner(), nrm, tan.cross(&nrm))
    }

    fn segment_at(&self, s_mm: f64) -> (usize, f64) {
        let x = (s_mm / self.step_mm).clamp(0.0, (self.points.len() - 1) as f64);
        let i = (x.floor() as usize).min(self.points.len() - 2);
        (i, x - i as f64)
    }

    /// Projects a point onto the curve, searching samples `lo..hi` (clamped) only.
    ///
    /// Restricting the search window keeps a point on its own stretch of a looping colon.
    pub fn locate_in(&self, p: &Point3<f64>, lo: usize, hi: usize) -> CurvePosition {
        let hi = hi.min(self.points.len());
        let lo = lo.min(hi.saturating_sub(1));
        let mut best = lo;
        let mut best_d2 = f64::INFINITY;
        for i in lo..hi {
            let d2 = (p - self.points[i]).norm_squared();
            if d2 < best_d2 {
                best_d2 = d2;
                best = i;
            }
        }
        self.position_relative_to(p, best)
    }

    /// Projects a point onto the whole curve (nearest sample, then the local frame).
    pub fn locate(&self, p: &Point3<f64>) -> CurvePosition {
        self.locate_in(p, 0, self.points.len())
    }

    /// Surface coordinates of `p` relative to sample `index`.
    pub fn position_relative_to(&self, p: &Point3<f64>, index: usize) -> CurvePosition {
        let d = p - self.points[index];
        let along = d.dot(&self.tangents[index]);
        let x = d.dot(&self.normals[index]);
        let y = d.dot(&self.binormals[index]);
        let mut theta = y.atan2(x);
        if theta < 0.0 {
            theta += std::f64::consts::TAU;
        }
        CurvePosition {
            index,
            s_mm: index as f64 * self.step_mm + along,
            theta,
            radial_mm: (x * x + y * y).sqrt(),
        }
    }

    /// Smooths the samples with a centred moving average of half-width `radius` samples
    /// (end points kept), then re-derives the frames. Used on noisy CT mid-lines.
    pub fn smoothed(&self, radius: usize) -> Self {
        if radius == 0 || self.points.len() < 3 {
            return self.clone();
        }
        let n = self.points.len();
        let pts: Vec<Point3<f64>> = (0..n)
            .map(|i| {
                let r = radius.min(i).min(n - 1 - i);
                let mut acc = Vector3::zeros();
                for j in i - r..=i + r {
                    acc += self.points[j].coords;
                }
                Point3::from(acc / (2 * r + 1) as f64)
            })
            .collect();
        Centerline::from_polyline(&pts, self.step_mm).unwrap_or_else(|_| self.clone())
    }
}

/// Centred moving average of `values`, `half` samples on each side (fewer at the ends), by
/// prefix sums.
pub(crate) fn moving_average(values: &[f64], half: usize) -> Vec<f64> {
    let n = values.len();
    let mut prefix = vec![0.0; n + 1];
    for (i, v) in values.iter().enumerate() {
        prefix[i + 1] = prefix[i] + v;
    }
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + half + 1).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn helix() -> Vec<Point3<f64>> {
        (0..2000)
            .map(|i| {
                let t = i as f64 * 0.01;
                Point3::new(50.0 * t.cos(), 50.0 * t.sin(), 10.0 * t)
            })
            .collect()
    }

    #[test]
    fn resampling_is_uniform_and_frames_orthonormal() {
        let c = Centerline::from_polyline(&helix(), 1.0).unwrap();
        for i in 1..c.len() {
            assert_relative_eq!((c.points[i] - c.points[i - 1]).norm(), 1.0, epsilon = 2e-3);
            let (t, n, b) = (c.tangents[i], c.normals[i], c.binormals[i]);
            assert_relative_eq!(t.norm(), 1.0, epsilon = 1e-9);
            assert_relative_eq!(n.norm(), 1.0, epsilon = 1e-9);
            assert!(t.dot(&n).abs() < 1e-9 && b.dot(&n).abs() < 1e-9);
        }
    }

    #[test]
    fn frames_do_not_twist_along_a_straight_line() {
        let pts = [Point3::new(0.0, 0.0, 0.0), Point3::new(0.0, 0.0, 100.0)];
        let c = Centerline::from_polyline(&pts, 0.5).unwrap();
        assert_relative_eq!(c.normals[0], c.normals[c.len() - 1], epsilon = 1e-12);
    }

    #[test]
    fn locate_recovers_arc_length_angle_and_radius() {
        let c = Centerline::from_polyline(&helix(), 1.0).unwrap();
        let s = 700.0;
        let (t, n, b) = c.frame_at(s);
        let theta: f64 = 2.0;
        let p = c.point_at(s) + (n * theta.cos() + b * theta.sin()) * 7.0;
        let pos = c.locate(&p);
        assert_relative_eq!(pos.s_mm, s, epsilon = 0.05);
        assert_relative_eq!(pos.theta, theta, epsilon = 1e-2);
        assert_relative_eq!(pos.radial_mm, 7.0, epsilon = 1e-2);
        assert!(t.dot(&n).abs() < 1e-9);
    }

    #[test]
    fn degenerate_polylines_are_errors() {
        let nan = [Point3::new(0.0, f64::NAN, 0.0), Point3::new(1.0, 0.0, 0.0)];
        assert!(Centerline::from_polyline(&nan, 1.0).is_err());
        let one = [Point3::new(0.0, 0.0, 0.0), Point3::new(0.0, 0.0, 0.0)];
        assert!(Centerline::from_polyline(&one, 1.0).is_err());
    }
}
