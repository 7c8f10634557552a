//! Seeded synthetic scenes with known truth, for tests, benchmarks, examples and the OpenCV
//! comparison. Scales follow the colonoscopy setting: points 20–150 mm in front of the camera,
//! a 640×480 camera with a wide field of view.

use nalgebra::{Point2, Point3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::camera::Camera;
use crate::pose::{Pose, pose_from_parts};
use crate::so3;

/// Settings of [`pnp_scene`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PnpSceneConfig {
    /// Number of 2D–3D correspondences.
    pub points: usize,
    /// Standard deviation of the Gaussian pixel noise on inliers, pixels.
    pub noise_px: f64,
    /// Fraction of correspondences replaced by outliers (pixel drawn uniformly in the image).
    pub outlier_fraction: f64,
    /// Nearest and farthest depth of the points along the optical axis, mm.
    pub depth_range_mm: (f64, f64),
    /// Extent of the camera position around the world origin (uniform per axis, ±), mm.
    pub position_extent_mm: f64,
}

impl Default for PnpSceneConfig {
    fn default() -> Self {
        Self {
            points: 200,
            noise_px: 0.5,
            outlier_fraction: 0.3,
            depth_range_mm: (20.0, 150.0),
            position_extent_mm: 200.0,
        }
    }
}

/// A 2D–3D registration problem with its true pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PnpScene {
    /// The camera (640×480, 90° horizontal field of view, no distortion unless changed).
    pub camera: Camera,
    /// True camera-to-world pose `T_wc`, mm.
    pub t_wc: Pose,
    /// Map points in the world frame, mm.
    pub points_world: Vec<Point3<f64>>,
    /// Observed pixels (noisy projections, or random pixels for outliers).
    pub pixels: Vec<Point2<f64>>,
    /// Which correspondences are outliers.
    pub outlier: Vec<bool>,
}

/// A standard normal sample (Box–Muller).
pub fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A uniformly distributed random rotation.
pub fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    let q = nalgebra::Quaternion::new(
        standard_normal(rng),
        standard_normal(rng),
        standard_normal(rng),
        standard_normal(rng),
    );
    UnitQuaternion::new_normalize(q)
}

/// A random unit vector.
pub fn random_unit_vector(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(
        standard_normal(rng),
        standard_normal(rng),
        standard_normal(rng),
    )
    .normalize()
}

/// `pose` moved by exactly `angle_deg` about a random axis (rotation about the camera centre)
/// and by exactly `offset_mm` in a random direction: a "bad prior" at a known distance.
pub fn perturb_pose(pose: &Pose, angle_deg: f64, offset_mm: f64, rng: &mut ChaCha8Rng) -> Pose {
    let dr = so3::exp_quaternion(&(random_unit_vector(rng) * angle_deg.to_radians()));
    let dt = random_unit_vector(rng) * offset_mm;
    pose_from_parts(pose.translation.vector + dt, pose.rotation * dr)
}

/// A seeded random registration problem: a random camera pose, points spread over the image
/// at depths within `cfg.depth_range_mm`, Gaussian pixel noise and uniform outliers.
pub fn pnp_scene(cfg: &PnpSceneConfig, seed: u64) -> PnpScene {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let camera = Camera::from_hfov(640, 480, 90.0);
    let e = cfg.position_extent_mm;
    let t_wc = pose_from_parts(
        Vector3::new(
            rng.random_range(-e..=e),
            rng.random_range(-e..=e),
            rng.random_range(-e..=e),
        ),
        random_rotation(&mut rng),
    );
    let n_out = (cfg.points as f64 * cfg.outlier_fraction).round() as usize;
    let mut points_world = Vec::with_capacity(cfg.points);
    let mut pixels = Vec::with_capacity(cfg.points);
    let mut outlier = Vec::with_capacity(cfg.points);
    let (w, h) = (camera.width as f64 - 1.0, camera.height as f64 - 1.0);
    for i in 0..cfg.points {
        let px_true = Point2::new(rng.random_range(0.0..=w), rng.random_range(0.0..=h));
        let depth = rng.random_range(cfg.depth_range_mm.0..=cfg.depth_range_mm.1);
        let p_cam = camera
            .unproject(&px_true, depth)
            .unwrap_or(Point3::new(0.0, 0.0, depth));
        points_world.push(t_wc * p_cam);
        let is_out = i < n_out;
        let px = if is_out {
            Point2::new(rng.random_range(0.0..=w), rng.random_range(0.0..=h))
        } else {
            let clean = camera.project(&p_cam).unwrap_or(px_true);
            clean
                + nalgebra::Vector2::new(standard_normal(&mut rng), standard_normal(&mut rng))
                    * cfg.noise_px
        };
        pixels.push(px);
        outlier.push(is_out);
    }
    PnpScene {
        camera,
        t_wc,
        points_world,
        pixels,
        outlier,
    }
}
