//! Multi-view triangulation of a feature track with known camera poses (the paper's Eq. 1).
//!
//! For one track — the pixels of one 3D point in `m ≥ 2` images whose poses `T_wc` are known —
//! [`Triangulator::triangulate`]:
//! 1. undistorts every pixel to normalized image coordinates (`Camera::normalized`);
//! 2. rejects a zero baseline (all camera centres equal);
//! 3. initialises the point linearly from all views: the DLT rows `x·P₃ − P₁`, `y·P₃ − P₂`
//!    of every view, solved in the inhomogeneous form (`w = 1`) through 3×3 normal equations,
//!    after centring and scaling the world frame on the camera centres for conditioning;
//! 4. refines it by Gauss-Newton over all views, minimising the squared reprojection error
//!    (Eq. 1), with step halving so the cost never increases and every view keeps the point in
//!    front of it;
//! 5. checks cheirality (depth > `min_depth_mm` in every view), parallax (the largest angle
//!    between two viewing rays *at the point* ≥ `min_parallax_deg`), and the paper's `δr`
//!    filter: a point is dropped when any observation reprojects farther than `delta_r_px`
//!    (10 px in the paper) from its pixel.
//!
//! # Residual units
//!
//! Gauss-Newton works in undistorted normalized coordinates scaled by the focal lengths
//! (`fx·(x/z − x̂)`, `fy·(y/z − ŷ)`), i.e. in pixels of the ideal pinhole; with no distortion
//! this is exactly the pixel reprojection error. The reported errors and the `δr` test always
//! use the true camera model (`Camera::project`, distortion included) in pixels.
//!
//! All work is on fixed-size nalgebra types; a [`Triangulator`] keeps one scratch buffer and
//! reuses it across tracks, so the batch path allocates only for its output.

use nalgebra::{Matrix3, Point2, Point3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::camera::Camera;
use crate::pose::Pose;
use crate::reprojection;

/// One observation of a track: the pixel where the point was seen and the pose of that image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Camera-to-world pose `T_wc` of the image (mm).
    pub pose: Pose,
    /// Observed pixel (origin at the top-left pixel's centre).
    pub pixel: Point2<f64>,
}

/// Settings of [`Triangulator`]; the defaults follow the paper (`δr = 10 px`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TriangulationConfig {
    /// The paper's `δr`: a point is rejected when any observation reprojects farther than
    /// this from its pixel, in pixels.
    pub delta_r_px: f64,
    /// Minimum triangulation angle: the largest angle between two viewing rays at the point
    /// must reach this, degrees.
    pub min_parallax_deg: f64,
    /// Cheirality: the point must lie at least this far in front of every camera (depth along
    /// the optical axis), mm.
    pub min_depth_mm: f64,
    /// Maximum number of Gauss-Newton iterations.
    pub max_iterations: usize,
    /// Gauss-Newton stops when a step moves the point by less than this fraction of its
    /// distance to the cameras (dimensionless).
    pub relative_step_tolerance: f64,
}

impl Default for TriangulationConfig {
    fn default() -> Self {
        Self {
            delta_r_px: 10.0,
            min_parallax_deg: 1.0,
            min_depth_mm: 1e-3,
            max_iterations: 10,
            relative_step_tolerance: 1e-12,
        }
    }
}

/// A triangulated map point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TriangulatedPoint {
    /// The point in the world frame, mm.
    pub p_world: Point3<f64>,
    /// Root-mean-square reprojection error over the views (true camera model), pixels.
    pub reprojection_rms_px: f64,
    /// Largest reprojection error over the views, pixels.
    pub reprojection_max_px: f64,
    /// Largest angle between two viewing rays at the point, degrees.
    pub parallax_deg: f64,
    /// Number of views used.
    pub views: usize,
    /// Gauss-Newton iterations performed.
    pub iterations: usize,
}

/// Why a track could not be triangulated.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TriangulationError {
    /// Fewer than two observations.
    #[error("a track needs at least 2 views, got {views}")]
    TooFewViews {
        /// Number of observations given.
        views: usize,
    },
    /// An observation had a NaN or infinite pose or pixel.
    #[error("observation {view} has a non-finite pose or pixel")]
    NonFinite {
        /// Index of the observation in the track.
        view: usize,
    },
    /// A pixel could not be undistorted (outside the lens model's invertible region).
    #[error("pixel of observation {view} cannot be undistorted")]
    Unprojectable {
        /// Index of the observation in the track.
        view: usize,
    },
    /// All camera centres coincide: depth is unobservable.
    #[error("zero baseline: all {views} camera centres coincide")]
    ZeroBaseline {
        /// Number of observations.
        views: usize,
    },
    /// The linear system was singular (e.g. parallel rays, point at infinity).
    #[error("degenerate geometry: the linear triangulation is singular")]
    Degenerate,
    /// The point lies behind (or too close to) one of the cameras.
    #[error("point is behind camera {view} (depth {depth_mm:.3} mm)")]
    BehindCamera {
        /// Index of the observation in the track.
        view: usize,
        /// Depth of the point along that camera's optical axis, mm.
        depth_mm: f64,
    },
    /// The triangulation angle is too small for a reliable depth.
    #[error("parallax {parallax_deg:.3}° below the minimum {min_parallax_deg}°")]
    InsufficientParallax {
        /// Largest angle between two viewing rays at the point, degrees.
        parallax_deg: f64,
        /// The configured minimum, degrees.
        min_parallax_deg: f64,
    },
    /// The `δr` filter: an observation reprojects too far from its pixel.
    #[error("reprojection error {max_px:.2} px exceeds δr = {delta_r_px} px")]
    ReprojectionTooHigh {
        /// Largest reprojection error over the views, pixels.
        max_px: f64,
        /// The configured `δr`, pixels.
        delta_r_px: f64,
    },
}

/// Per-view data precomputed once per track.
#[derive(Debug, Clone, Copy)]
struct View {
    /// World-to-camera rotation `R_cw = R_wcᵀ`.
    r_cw: Matrix3<f64>,
    /// World-to-camera translation `t_cw = −R_cw t_wc`, mm.
    t_cw: Vector3<f64>,
    /// Camera centre in the world, mm.
    centre: Vector3<f64>,
    /// Undistorted normalized coordinates of the observation.
    xn: Vector2<f64>,
}

/// A reusable triangulator: configuration, camera and a scratch buffer reused across tracks.
#[derive(Debug, Clone)]
pub struct Triangulator {
    cfg: TriangulationConfig,
    camera: Camera,
    views: Vec<View>,
}

impl Triangulator {
    /// A triangulator for images taken with `camera`.
    pub fn new(camera: Camera, cfg: TriangulationConfig) -> Self {
        Self {
            cfg,
            camera,
            views: Vec::new(),
        }
    }

    /// The configuration in use.
    pub fn config(&self) -> &TriangulationConfig {
        &self.cfg
    }

    /// Triangulates one track (see the module docs for the steps and checks).
    ///
    /// # Errors
    /// A [`TriangulationError`] naming the failed check: too few views, non-finite input,
    /// undistortion failure, zero baseline, singular geometry, a point behind a camera, too
    /// little parallax, or the `δr` reprojection filter.
    pub fn triangulate(
        &mut self,
        track: &[Observation],
    ) -> Result<TriangulatedPoint, TriangulationError> {
        if track.len() < 2 {
            return Err(TriangulationError::TooFewViews { views: track.len() });
        }
        self.views.clear();
        for (view, obs) in track.iter().enumerate() {
            let finite = obs.pixel.coords.iter().all(|v| v.is_finite())
                && obs.pose.translation.vector.iter().all(|v| v.is_finite())
                && obs.pose.rotation.coords.iter().all(|v| v.is_finite());
            if !finite {
                return Err(TriangulationError::NonFinite { view });
            }
            let xn = self
                .camera
                .normalized(&obs.pixel)
                .ok_or(TriangulationError::Unprojectable { view })?;
            let r_cw = obs
                .pose
                .rotation
                .to_rotation_matrix()
                .into_inner()
                .transpose();
            let centre = obs.pose.translation.vector;
            self.views.push(View {
                r_cw,
                t_cw: -(r_cw * centre),
                centre,
                xn,
            });
        }
        let views = &self.views;
        let n = views.len();

        // Centre and scale the world on the camera centres.
        let mean_c = views.iter().map(|v| v.centre).sum::<Vector3<f64>>() / n as f64;
        let spread = views
            .iter()
            .map(|v| (v.centre - mean_c).norm())
            .sum::<f64>()
            / n as f64;
        if !(spread > 1e-9 * (1.0 + mean_c.norm())) {
            return Err(TriangulationError::ZeroBaseline { views: n });
        }
        let scale = 1.0 / spread;

        // Linear initialisation: inhomogeneous DLT over all views, 3×3 normal equations.
        let mut ata = Matrix3::zeros();
        let mut atb = Vector3::zeros();
        for v in views {
            // Projection rows of [R_cw | s (R_cw c̄ + t_cw)] acting on the scaled point.
            let t = (v.r_cw * mean_c + v.t_cw) * scale;
            for (k, x) in [(0usize, v.xn.x), (1usize, v.xn.y)] {
                let a = v.r_cw.row(2).transpose() * x - v.r_cw.row(k).transpose();
                let b = t.z * x - t[k];
                ata += a * a.transpose();
                atb -= a * b;
            }
        }
        let x_scaled = ata
            .cholesky()
            .map(|c| c.solve(&atb))
            .ok_or(TriangulationError::Degenerate)?;
        if !x_scaled.iter().all(|v| v.is_finite()) {
            return Err(TriangulationError::Degenerate);
        }
        let mut x = x_scaled / scale + mean_c;
        for (view, v) in views.iter().enumerate() {
            let depth_mm = v.r_cw.row(2).dot(&x.transpose()) + v.t_cw.z;
            if depth_mm <= self.cfg.min_depth_mm {
                return Err(TriangulationError::BehindCamera { view, depth_mm });
            }
        }

        // Gauss-Newton on the reprojection error (ideal-pinhole pixels).
        let (fx, fy) = (self.camera.fx, self.camera.fy);
        let min_depth = self.cfg.min_depth_mm;
        let cost_at = |x: &Vector3<f64>| -> Option<f64> {
            let p = Point3::from(*x);
            let mut c = 0.0;
            for v in views {
                c += reprojection::residual(&v.r_cw, &v.t_cw, &p, &v.xn, fx, fy, min_depth)?
                    .norm_squared();
            }
            Some(c)
        };
        let mut cost = cost_at(&x).ok_or(TriangulationError::Degenerate)?;
        let mut iterations = 0;
        for _ in 0..self.cfg.max_iterations {
            iterations += 1;
            let mut h = Matrix3::zeros();
            let mut g = Vector3::zeros();
            let p = Point3::from(x);
            for v in views {
                let Some((r, j)) = reprojection::residual_and_point_jacobian(
                    &v.r_cw, &v.t_cw, &p, &v.xn, fx, fy, min_depth,
                ) else {
                    continue;
                };
                h += j.transpose() * j;
                g += j.transpose() * r;
            }
            let Some(step) = h.cholesky().map(|c| -c.solve(&g)) else {
                break;
            };
            // Step halving: accept the first fraction that does not raise the cost.
            let mut alpha = 1.0;
            let mut accepted = false;
            for _ in 0..8 {
                let candidate = x + step * alpha;
                if let Some(c) = cost_at(&candidate)
                    && c <= cost
                {
                    x = candidate;
                    cost = c;
                    accepted = true;
                    break;
                }
                alpha *= 0.5;
            }
            let dist = (x - mean_c).norm().max(spread);
            if !accepted || (step * alpha).norm() <= self.cfg.relative_step_tolerance * dist {
                break;
            }
        }

        // Final checks with the true camera model.
        let mut sum_sq = 0.0;
        let mut max_px: f64 = 0.0;
        let mut max_cos: f64 = 1.0;
        let p_world = Point3::from(x);
        for (view, (v, obs)) in views.iter().zip(track).enumerate() {
            let p = Point3::from(v.r_cw * x + v.t_cw);
            if p.z <= self.cfg.min_depth_mm {
                return Err(TriangulationError::BehindCamera {
                    view,
                    depth_mm: p.z,
                });
            }
            let e = match self.camera.project(&p) {
                Some(px) => (px - obs.pixel).norm(),
                None => f64::INFINITY,
            };
            sum_sq += e * e;
            max_px = max_px.max(e);
            let ray_i = (x - v.centre).normalize();
            for w in &views[view + 1..] {
                max_cos = max_cos.min(ray_i.dot(&(x - w.centre).normalize()));
            }
        }
        let parallax_deg = max_cos.clamp(-1.0, 1.0).acos().to_degrees();
        if !(parallax_deg >= self.cfg.min_parallax_deg) {
            return Err(TriangulationError::InsufficientParallax {
                parallax_deg,
                min_parallax_deg: self.cfg.min_parallax_deg,
            });
        }
        if !(max_px <= self.cfg.delta_r_px) {
            return Err(TriangulationError::ReprojectionTooHigh {
                max_px,
                delta_r_px: self.cfg.delta_r_px,
            });
        }
        Ok(TriangulatedPoint {
            p_world,
            reprojection_rms_px: (sum_sq / n as f64).sqrt(),
            reprojection_max_px: max_px,
            parallax_deg,
            views: n,
            iterations,
        })
    }
}

/// Triangulates one track with `camera` and `cfg` (see [`Triangulator::triangulate`]).
///
/// # Errors
/// See [`Triangulator::triangulate`].
pub fn triangulate_track(
    track: &[Observation],
    camera: &Camera,
    cfg: &TriangulationConfig,
) -> Result<TriangulatedPoint, TriangulationError> {
    Triangulator::new(*camera, *cfg).triangulate(track)
}

/// Triangulates many tracks, reusing one scratch buffer; one result per track, in order
/// (a failed track does not stop the others).
pub fn triangulate_tracks<T: AsRef<[Observation]>>(
    tracks: &[T],
    camera: &Camera,
    cfg: &TriangulationConfig,
) -> Vec<Result<TriangulatedPoint, TriangulationError>> {
    let mut tri = Triangulator::new(*camera, *cfg);
    tracks.iter().map(|t| tri.triangulate(t.as_ref())).collect()
}
