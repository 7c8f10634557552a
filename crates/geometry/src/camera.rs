//! Pinhole camera with optional lens distortion.
//!
//! Conventions (see `docs/CONVENTIONS.md`): OpenCV camera axes (x right, y down, z forward along the
//! optical axis); pixel coordinates with the origin at the centre of the top-left pixel, x to
//! the right, y down; lengths in millimetres.
//!
//! Distortion models follow OpenCV exactly, so intrinsics calibrated with OpenCV (or with the
//! Kalibr `radtan` / `equidistant` models) can be used unchanged:
//! - [`Distortion::RadialTangential`]: OpenCV's default model `k1 k2 p1 p2 k3`.
//! - [`Distortion::Fisheye`]: OpenCV's `cv::fisheye` equidistant model `k1 k2 k3 k4`.

use nalgebra::{Point2, Point3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Lens distortion applied to normalized image coordinates `(x/z, y/z)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "model", rename_all = "kebab-case")]
pub enum Distortion {
    /// No distortion: an ideal pinhole.
    #[default]
    None,
    /// OpenCV's radial-tangential (Brown–Conrady) model, coefficients `k1 k2 p1 p2 k3`.
    RadialTangential {
        /// First radial coefficient (r² term).
        k1: f64,
        /// Second radial coefficient (r⁴ term).
        k2: f64,
        /// First tangential coefficient.
        p1: f64,
        /// Second tangential coefficient.
        p2: f64,
        /// Third radial coefficient (r⁶ term); 0 when absent.
        #[serde(default)]
        k3: f64,
    },
    /// OpenCV's fisheye (equidistant) model: `θd = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`.
    Fisheye {
        /// θ² coefficient.
        k1: f64,
        /// θ⁴ coefficient.
        k2: f64,
        /// θ⁶ coefficient.
        k3: f64,
        /// θ⁸ coefficient.
        k4: f64,
    },
}

impl Distortion {
    /// Whether this is the identity mapping.
    pub fn is_none(&self) -> bool {
        matches!(self, Distortion::None)
    }

    /// Distorts normalized coordinates `(x/z, y/z)` of an ideal pinhole into the distorted
    /// normalized plane.
    pub fn distort(&self, xn: Vector2<f64>) -> Vector2<f64> {
        match *self {
            Distortion::None => xn,
            Distortion::RadialTangential { k1, k2, p1, p2, k3 } => {
                let (x, y) = (xn.x, xn.y);
                let r2 = x * x + y * y;
                let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                Vector2::new(
                    x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                    y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
                )
            }
            Distortion::Fisheye { k1, k2, k3, k4 } => {
                let r = xn.norm();
                if r < 1e-12 {
                    return xn;
                }
                let theta = r.atan();
                let t2 = theta * theta;
                let theta_d = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
                xn * (theta_d / r)
            }
        }
    }

    /// Inverts [`Distortion::distort`] by Gauss-Newton iterations started at the distorted
    /// point; returns `None` when the iteration does not converge to 1e-12 (a point far outside
    /// the calibrated field of view).
    pub fn undistort(&self, xd: Vector2<f64>) -> Option<Vector2<f64>> {
        if self.is_none() {
            return Some(xd);
        }
        let mut x = xd;
        for _ in 0..50 {
            let f = self.distort(x) - xd;
            if f.norm() < 1e-12 {
                return Some(x);
            }
            // Numerical 2×2 Jacobian: the models are smooth and this is not a hot path.
            let h = 1e-7;
            let jx = (self.distort(x + Vector2::new(h, 0.0)) - self.distort(x)) / h;
            let jy = (self.distort(x + Vector2::new(0.0, h)) - self.distort(x)) / h;
            let j = nalgebra::Matrix2::from_columns(&[jx, jy]);
            let step = j.try_inverse()? * f;
            x -= step;
            if !x.iter().all(|v| v.is_finite()) {
                return None;
            }
        }
        let residual = (self.distort(x) - xd).norm();
        (residual < 1e-9).then_some(x)
    }
}

/// A pinhole camera of a given image size, intrinsics in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (origin at the top-left pixel's centre).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Lens distortion; [`Distortion::None`] for an ideal pinhole.
    #[serde(default, skip_serializing_if = "Distortion::is_none")]
    pub distortion: Distortion,
}

impl Camera {
    /// An ideal pinhole with the principal point at the image centre and the given horizontal
    /// field of view in degrees (square pixels).
    pub fn from_hfov(width: u32, height: u32, hfov_deg: f64) -> Self {
        let f = (width as f64 / 2.0) / (hfov_deg.to_radians() / 2.0).tan();
        Camera {
            width,
            height,
            fx: f,
            fy: f,
            cx: (width as f64 - 1.0) / 2.0,
            cy: (height as f64 - 1.0) / 2.0,
            distortion: Distortion::None,
        }
    }

    /// Horizontal field of view of the undistorted pinhole, degrees.
    pub fn hfov_deg(&self) -> f64 {
        2.0 * (self.width as f64 / 2.0 / self.fx).atan().to_degrees()
    }

    /// Vertical field of view of the undistorted pinhole, degrees.
    pub fn vfov_deg(&self) -> f64 {
        2.0 * (self.height as f64 / 2.0 / self.fy).atan().to_degrees()
    }

    /// Checks that the intrinsics are usable: positive size and focal lengths, all finite.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!(
                "image size must be positive, got {}x{}",
                self.width, self.height
            ));
        }
        for (name, v) in [
            ("fx", self.fx),
            ("fy", self.fy),
            ("cx", self.cx),
            ("cy", self.cy),
        ] {
            if !v.is_finite() {
                return Err(format!("{name} must be finite, got {v}"));
            }
        }
        if self.fx <= 0.0 || self.fy <= 0.0 {
            return Err(format!(
                "focal lengths must be positive, got fx={} fy={}",
                self.fx, self.fy
            ));
        }
        Ok(())
    }

    /// Projects a point in the camera frame (mm) to pixel coordinates.
    ///
    /// Returns `None` for points at or behind the camera (`z ≤ 1e-9`).
    pub fn project(&self, p_cam: &Point3<f64>) -> Option<Point2<f64>> {
        if p_cam.z <= 1e-9 {
            return None;
        }
        let xn = Vector2::new(p_cam.x / p_cam.z, p_cam.y / p_cam.z);
        let xd = self.distortion.distort(xn);
        Some(Point2::new(
            self.fx * xd.x + self.cx,
            self.fy * xd.y + self.cy,
        ))
    }

    /// Normalized undistorted coordinates `(x/z, y/z)` of a pixel; `None` when the distortion
    /// cannot be inverted there.
    pub fn normalized(&self, pixel: &Point2<f64>) -> Option<Vector2<f64>> {
        let xd = Vector2::new((pixel.x - self.cx) / self.fx, (pixel.y - self.cy) / self.fy);
        self.distortion.undistort(xd)
    }

    /// Back-projects a pixel to the point at depth `z` (mm, along the optical axis) in the
    /// camera frame.
    pub fn unproject(&self, pixel: &Point2<f64>, z: f64) -> Option<Point3<f64>> {
        let n = self.normalized(pixel)?;
        Some(Point3::new(n.x * z, n.y * z, z))
    }

    /// Unit viewing ray through a pixel, camera frame.
    pub fn ray(&self, pixel: &Point2<f64>) -> Option<Vector3<f64>> {
        let n = self.normalized(pixel)?;
        Some(Vector3::new(n.x, n.y, 1.0).normalize())
    }

    /// Whether a pixel lies inside the image (pixel centres span `0..=width-1`).
    pub fn contains(&self, pixel: &Point2<f64>) -> bool {
        pixel.x >= -0.5
            && pixel.y >= -0.5
            && pixel.x < self.width as f64 - 0.5
            && pixel.y < self.height as f64 - 0.5
    }

    /// The same camera for an image resized by `scale` (e.g. 0.5 halves width and height).
    ///
    /// Pixel centres map as `u' = (u + 0.5) * scale - 0.5`.
    pub fn scaled(&self, scale: f64) -> Camera {
        Camera {
            width: ((self.width as f64) * scale).round().max(1.0) as u32,
            height: ((self.height as f64) * scale).round().max(1.0) as u32,
            fx: self.fx * scale,
            fy: self.fy * scale,
            cx: (self.cx + 0.5) * scale - 0.5,
            cy: (self.cy + 0.5) * scale - 0.5,
            distortion: self.distortion,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn project_unproject_round_trip_all_models() {
        let mut cam = Camera::from_hfov(640, 480, 90.0);
        for d in [
            Distortion::None,
            Distortion::RadialTangential {
                k1: -0.2,
                k2: 0.05,
                p1: 0.001,
                p2: -0.002,
                k3: 0.0,
            },
            Distortion::Fisheye {
                k1: -0.18867,
                k2: -0.00393,
                k3: 0.03052,
                k4: -0.01276,
            },
        ] {
            cam.distortion = d;
            let p = Point3::new(3.0, -2.0, 10.0);
            let px = cam.project(&p).unwrap();
            let back = cam.unproject(&px, 10.0).unwrap();
            assert_relative_eq!(back, p, epsilon = 1e-8);
        }
    }

    #[test]
    fn principal_point_is_image_centre_and_fov_matches() {
        let cam = Camera::from_hfov(640, 480, 90.0);
        assert_relative_eq!(cam.fx, 320.0, epsilon = 1e-9);
        let px = cam.project(&Point3::new(0.0, 0.0, 5.0)).unwrap();
        assert_relative_eq!(px.x, 319.5);
        assert_relative_eq!(px.y, 239.5);
        assert_relative_eq!(cam.hfov_deg(), 90.0, epsilon = 1e-9);
        assert!(cam.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
    }

    #[test]
    fn serde_round_trip_is_toml_friendly() {
        let mut cam = Camera::from_hfov(320, 240, 80.0);
        cam.distortion = Distortion::Fisheye {
            k1: 0.1,
            k2: 0.0,
            k3: 0.0,
            k4: 0.0,
        };
        let s = serde_json::to_string(&cam).unwrap();
        assert!(s.contains("\"model\":\"fisheye\""), "{s}");
        let back: Camera = serde_json::from_str(&s).unwrap();
        assert_eq!(back, cam);
    }
}

#[cfg(test)]
mod proptests {
    use super::*;
    use proptest::prelude::*;

    fn camera_strategy() -> impl Strategy<Value = Camera> {
        let dist = prop_oneof![
            Just(Distortion::None),
            (
                -0.3f64..0.1,
                -0.05f64..0.1,
                -0.002f64..0.002,
                -0.002f64..0.002,
                -0.01f64..0.01
            )
                .prop_map(|(k1, k2, p1, p2, k3)| Distortion::RadialTangential {
                    k1,
                    k2,
                    p1,
                    p2,
                    k3
                }),
            (
                -0.2f64..0.1,
                -0.02f64..0.02,
                -0.01f64..0.01,
                -0.005f64..0.005
            )
                .prop_map(|(k1, k2, k3, k4)| Distortion::Fisheye { k1, k2, k3, k4 }),
        ];
        (60.0f64..110.0, dist).prop_map(|(hfov, d)| {
            let mut c = Camera::from_hfov(640, 480, hfov);
            c.distortion = d;
            c
        })
    }

    proptest! {
        /// A point within 35° of the optical axis (where all these lens models are monotonic)
        /// projects to a pixel that unprojects onto it at its depth.
        #[test]
        fn project_then_unproject_returns_the_point(
            cam in camera_strategy(),
            off_axis_deg in 0.0f64..35.0,
            azimuth in 0.0f64..std::f64::consts::TAU,
            z in 1.0f64..200.0,
        ) {
            let r = off_axis_deg.to_radians().tan();
            let p = Point3::new(r * azimuth.cos() * z, r * azimuth.sin() * z, z);
            let px = cam.project(&p).unwrap();
            let back = cam.unproject(&px, z);
            prop_assert!(back.is_some(), "{p:?} -> {px:?} not invertible for {cam:?}");
            prop_assert!((back.unwrap() - p).norm() < 1e-8 * z, "{p:?} -> {px:?} -> {back:?}");
            let ray = cam.ray(&px).unwrap();
            prop_assert!((ray - p.coords.normalize()).norm() < 1e-9);
        }

        /// Wherever a pixel can be unprojected (some strong lenses do not reach the image
        /// corners), the unprojected point projects back onto that pixel.
        #[test]
        fn unproject_then_project_returns_the_pixel(
            cam in camera_strategy(),
            u in 0.0f64..639.0,
            v in 0.0f64..479.0,
            z in 1.0f64..200.0,
        ) {
            let px = Point2::new(u, v);
            if let Some(p) = cam.unproject(&px, z) {
                prop_assert!((p.z - z).abs() < 1e-12);
                let back = cam.project(&p).unwrap();
                prop_assert!((back - px).norm() < 1e-6, "{px:?} -> {p:?} -> {back:?}");
            }
        }
    }
}
