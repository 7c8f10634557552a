//! A 3-D polyline with arc lengths and nearest-point queries: a colon's mid-line.

use nalgebra::Point3;

/// The point of a [`Polyline`] nearest to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// The nearest point on the polyline (world, mm).
    pub point: Point3<f64>,
    /// Its arc length from the polyline's first vertex, mm.
    pub s_mm: f64,
    /// Its distance to the query point, mm.
    pub distance_mm: f64,
}

/// A polyline through finite points, consecutive duplicates dropped, with the arc length of
/// every vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct Polyline {
    points: Vec<Point3<f64>>,
    /// Arc length at each vertex, mm (0 at the first).
    s_mm: Vec<f64>,
}

impl Polyline {
    /// The polyline through `points` (mm); consecutive duplicates (closer than 1 nm) are
    /// dropped. `None` when a point is not finite or fewer than two distinct points remain.
    pub fn new(points: &[Point3<f64>]) -> Option<Self> {
        let mut kept: Vec<Point3<f64>> = Vec::with_capacity(points.len());
        let mut s_mm = Vec::with_capacity(points.len());
        for p in points {
            if !p.coords.iter().all(|v| v.is_finite()) {
                return None;
            }
            match kept.last() {
                Some(last) if (p - last).norm() < 1e-9 => continue,
                Some(last) => s_mm.push(s_mm.last().copied().unwrap_or(0.0) + (p - last).norm()),
                None => s_mm.push(0.0),
            }
            kept.push(*p);
        }
        (kept.len() >= 2).then_some(Polyline { points: kept, s_mm })
    }

    /// The polyline's vertices.
    pub fn points(&self) -> &[Point3<f64>] {
        &self.points
    }

    /// Total length, mm.
    pub fn length_mm(&self) -> f64 {
        self.s_mm.last().copied().unwrap_or(0.0)
    }

    /// The point of the polyline nearest to `p` (the first of equally near ones).
    pub fn nearest(&self, p: &Point3<f64>) -> Nearest {
        let mut best = (f64::INFINITY, 0, 0.0);
        for (i, pair) in self.points.windows(2).enumerate() {
            let (a, b) = (pair[0], pair[1]);
            let ab = b - a;
            let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            let d2 = (a + ab * t - p).norm_squared();
            if d2 < best.0 {
                best = (d2, i, t);
            }
        }
        let (d2, i, t) = best;
        Nearest {
            point: self.points[i] + (self.points[i + 1] - self.points[i]) * t,
            s_mm: self.s_mm[i] + t * (self.s_mm[i + 1] - self.s_mm[i]),
            distance_mm: d2.sqrt(),
        }
    }

    /// The polyline smoothed by a running mean over `± half_window_mm` of arc length at each
    /// vertex (the ends use the part of the window that exists); a camera path that weaves
    /// about the lumen's axis comes closer to the axis.
    pub fn smoothed(&self, half_window_mm: f64) -> Polyline {
        let n = self.points.len();
        let (mut lo, mut hi) = (0, 0);
        let mut sum = nalgebra::Vector3::zeros();
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            while hi < n && self.s_mm[hi] <= self.s_mm[i] + half_window_mm {
                sum += self.points[hi].coords;
                hi += 1;
            }
            while self.s_mm[lo] < self.s_mm[i] - half_window_mm {
                sum -= self.points[lo].coords;
                lo += 1;
            }
            out.push(Point3::from(sum / (hi - lo) as f64));
        }
        Polyline::new(&out).unwrap_or_else(|| self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_points_lie_on_the_right_segment_with_their_arc_length() {
        // An L: 100 mm along x, then 100 mm along y (a duplicate vertex dropped).
        let l = Polyline::new(&[
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(100.0, 0.0, 0.0),
            Point3::new(100.0, 0.0, 0.0),
            Point3::new(100.0, 100.0, 0.0),
        ])
        .unwrap();
        assert_eq!((l.points().len(), l.length_mm()), (3, 200.0));
        let n = l.nearest(&Point3::new(30.0, 5.0, 0.0));
        assert_eq!(
            (n.point, n.s_mm, n.distance_mm),
            (Point3::new(30.0, 0.0, 0.0), 30.0, 5.0)
        );
        let n = l.nearest(&Point3::new(95.0, 50.0, 0.0));
        assert_eq!((n.s_mm, n.distance_mm), (150.0, 5.0));
        assert!(Polyline::new(&[Point3::origin(), Point3::origin()]).is_none());
        assert!(Polyline::new(&[Point3::origin(), Point3::new(f64::NAN, 0.0, 0.0)]).is_none());
    }

    #[test]
    fn smoothing_pulls_a_weaving_path_onto_its_axis() {
        // ±2 mm about the x axis, one weave every 10 mm.
        let pts: Vec<Point3<f64>> = (0..=200)
            .map(|i| {
                let x = i as f64;
                Point3::new(x, 2.0 * (x * std::f64::consts::TAU / 10.0).sin(), 0.0)
            })
            .collect();
        let smooth = Polyline::new(&pts).unwrap().smoothed(10.0);
        let mid = smooth.nearest(&Point3::new(100.0, 5.0, 0.0));
        assert!(mid.point.y.abs() < 0.3, "{}", mid.point.y);
    }
}
