//! One triangulated map point: what a zone's map holds and what test-frame features are
//! matched to.

use endoloc_features::Describe;
use nalgebra::{Point2, Point3};

/// One triangulated map point.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPoint {
    /// Position in the world frame, mm.
    pub p_world: Point3<f64>,
    /// Mean SURF descriptor of the observations, unit L2 norm.
    pub descriptor: Vec<f32>,
    /// Sign of the Laplacian (+1 dark-on-bright… as SURF reports it; 0 unknown).
    pub laplacian: i8,
    /// Observations: training frame and pixel.
    pub observations: Vec<(usize, Point2<f64>)>,
    /// RMS reprojection error over the observations, pixels.
    pub reprojection_rms_px: f64,
}

impl Describe for MapPoint {
    fn descriptor(&self) -> &[f32] {
        &self.descriptor
    }
    fn laplacian(&self) -> i8 {
        self.laplacian
    }
}
