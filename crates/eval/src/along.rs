//! The error along the colon: how far apart, in mm of mid-line, the estimate and the truth are.
//!
//! A clinician reads a position as a distance along the colon ("32 cm from the anus"), not as a
//! point in space. Each position is projected onto the nearest point of the colon's mid-line
//! (a polyline, anus → caecum); the error is the difference of the two projections' arc
//! lengths, mm. The mid-line is the dataset's own (`midline.txt`, written by the simulator) or,
//! for a dataset without one, the training pass's camera positions standing in for it.

use std::path::Path;

use endoloc_data::StampedPose;
use endoloc_geometry::Polyline;
use nalgebra::Point3;

use crate::EvalError;

/// A colon's mid-line with the arc length of every vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct Midline {
    line: Polyline,
    /// Where it came from, in words (for the report).
    source: String,
}

impl Midline {
    /// A mid-line through `points` (world frame, mm), anus → caecum; consecutive duplicates
    /// are dropped. `source` says where it came from.
    ///
    /// # Errors
    /// [`EvalError::Invalid`] for a non-finite point or fewer than two distinct points.
    pub fn new(points: &[Point3<f64>], source: impl Into<String>) -> Result<Self, EvalError> {
        let source = source.into();
        if let Some(i) = points
            .iter()
            .position(|p| !p.coords.iter().all(|v| v.is_finite()))
        {
            return Err(EvalError::Invalid(format!(
                "{source}: mid-line point {i} is not finite"
            )));
        }
        let Some(line) = Polyline::new(points) else {
            return Err(EvalError::Invalid(format!(
                "{source}: a mid-line needs at least two distinct points"
            )));
        };
        Ok(Midline { line, source })
    }

    /// Reads a mid-line file (`midline.txt`: `x y z` per line, mm; or any path format
    /// [`endoloc_data::read_path`] reads).
    ///
    /// # Errors
    /// The file's read or parse error (naming the line); [`EvalError::Invalid`] as
    /// [`Midline::new`].
    pub fn from_file(path: &Path) -> Result<Self, EvalError> {
        let points = endoloc_data::read_path(path)?;
        Midline::new(&points, format!("mid-line {}", path.display()))
    }

    /// The camera positions of a pass standing in for the mid-line (a dataset without one:
    /// the training pass runs along the colon).
    ///
    /// # Errors
    /// As [`Midline::new`].
    pub fn from_trajectory(
        poses: &[StampedPose],
        source: impl Into<String>,
    ) -> Result<Self, EvalError> {
        let points: Vec<Point3<f64>> = poses
            .iter()
            .map(|p| Point3::from(p.pose.translation.vector))
            .collect();
        Midline::new(&points, source)
    }

    /// Where the mid-line came from.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Length of the mid-line, mm.
    pub fn length_mm(&self) -> f64 {
        self.line.length_mm()
    }

    /// Arc length (mm from the first point) of the mid-line point nearest to `p`.
    pub fn arc_length_at(&self, p: &Point3<f64>) -> f64 {
        self.line.nearest(p).s_mm
    }

    /// The error along the colon between an estimated and a true position, mm.
    pub fn along_error_mm(&self, est: &Point3<f64>, truth: &Point3<f64>) -> f64 {
        (self.arc_length_at(est) - self.arc_length_at(truth)).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_are_measured_along_a_bent_mid_line() {
        // An L: 100 mm along x, then 100 mm along y.
        let pts = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(100.0, 0.0, 0.0),
            Point3::new(100.0, 0.0, 0.0),
            Point3::new(100.0, 100.0, 0.0),
        ];
        let m = Midline::new(&pts, "test").unwrap();
        assert_eq!(m.length_mm(), 200.0);
        // Off the line by 5 mm: projects to 30 mm and 150 mm.
        let a = Point3::new(30.0, 5.0, 0.0);
        let b = Point3::new(95.0, 50.0, 0.0);
        assert!((m.arc_length_at(&a) - 30.0).abs() < 1e-9);
        assert!((m.along_error_mm(&a, &b) - 120.0).abs() < 1e-9);
        assert!(Midline::new(&pts[..1], "one").is_err());
        let nan = [Point3::new(0.0, f64::NAN, 0.0), Point3::new(1.0, 0.0, 0.0)];
        let e = Midline::new(&nan, "x").unwrap_err().to_string();
        assert!(e.contains("point 0"), "{e}");
    }
}
