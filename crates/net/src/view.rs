//! View augmentation with exact labels: a camera that turns about its own centre by `ΔR`
//! (`R_wc' = R_wc · ΔR`) sees the same scene through the homography `K ΔRᵀ K⁻¹`, whatever the
//! depths — so the augmented image and its rotated label agree exactly (up to resampling, and
//! the border that comes into view, which replicates the edge pixels).
//!
//! For an output pixel `u'` of the turned camera the ray is `d' = K⁻¹ u'` in its frame, `ΔR d'`
//! in the original camera's frame, and the sample is taken at `K ΔR d'` in the original image.
//! A roll by θ about the optical axis (OpenCV axes: z forward, x right, y down) is
//! `ΔR = R_z(θ)`: the sample is at `c + R(θ)(u' − c)` and needs no focal length; tilts (about
//! x and y) need the intrinsics ([`ViewIntrinsics`]).

use crate::preprocess::sample_bilinear;
use endoloc_geometry::Camera;
use nalgebra::{Rotation3, UnitQuaternion, Vector3};

/// Pinhole intrinsics of the network's input image (pixels of the resized image).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewIntrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (origin at the top-left pixel's centre).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
}

impl ViewIntrinsics {
    /// The intrinsics of `camera`'s frames resized to `width × height` (area resampling keeps
    /// pixel edges aligned: `c' = (c + ½)·s − ½`, `f' = f·s`).
    pub fn resized(camera: &Camera, width: u32, height: u32) -> Self {
        let sx = width as f64 / camera.width.max(1) as f64;
        let sy = height as f64 / camera.height.max(1) as f64;
        ViewIntrinsics {
            fx: camera.fx * sx,
            fy: camera.fy * sy,
            cx: (camera.cx + 0.5) * sx - 0.5,
            cy: (camera.cy + 0.5) * sy - 0.5,
        }
    }

    /// An ideal camera with the principal point at the image centre and focal length `f`.
    pub fn centred(width: usize, height: usize, f: f64) -> Self {
        ViewIntrinsics {
            fx: f,
            fy: f,
            cx: (width as f64 - 1.0) / 2.0,
            cy: (height as f64 - 1.0) / 2.0,
        }
    }
}

/// The image `px` (`w × h`, row-major) seen by the camera turned by `delta` about its centre
/// (`R_wc · delta`), with intrinsics `k` (bilinear sampling, borders replicated).
pub fn rotate_view(
    px: &[f32],
    w: usize,
    h: usize,
    k: &ViewIntrinsics,
    delta: &Rotation3<f64>,
) -> Vec<f32> {
    if w == 0 || h == 0 || px.len() != w * h {
        return px.to_vec();
    }
    let m = delta.matrix();
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let d = Vector3::new((x as f64 - k.cx) / k.fx, (y as f64 - k.cy) / k.fy, 1.0);
            let s = m * d;
            let (sx, sy) = if s.z > 1e-9 {
                (k.fx * s.x / s.z + k.cx, k.fy * s.y / s.z + k.cy)
            } else {
                (x as f64, y as f64)
            };
            out[y * w + x] = sample_bilinear(px, w, h, sx as f32, sy as f32);
        }
    }
    out
}

/// The camera-to-world rotation after turning the camera by `delta` about its centre:
/// `R_wc · delta`.
pub fn rotated_rotation(
    r_wc: &UnitQuaternion<f64>,
    delta: &UnitQuaternion<f64>,
) -> UnitQuaternion<f64> {
    r_wc * delta
}

/// The turn of a roll by `roll_rad` about the optical axis after a tilt of `pitch_rad` about
/// the camera's x axis (down) and `yaw_rad` about its y axis (right):
/// `R_y(yaw) · R_x(pitch) · R_z(roll)`.
pub fn view_turn(roll_rad: f64, pitch_rad: f64, yaw_rad: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), yaw_rad)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch_rad)
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll_rad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    /// A bright spot where the camera sees a world point, before and after a turn: the
    /// centroid of the turned image is where the turned camera projects the point.
    fn check(delta: UnitQuaternion<f64>) {
        let (w, h) = (61usize, 45usize);
        let k = ViewIntrinsics {
            fx: 30.0,
            fy: 30.0,
            cx: 30.0,
            cy: 22.0,
        };
        let r_wc = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7);
        let p_w = r_wc * Point3::new(0.3, -0.1, 1.0); // camera at the origin
        let project = |r: &UnitQuaternion<f64>| {
            let p = r.inverse() * p_w;
            (k.fx * p.x / p.z + k.cx, k.fy * p.y / p.z + k.cy)
        };
        let (u, v) = project(&r_wc);
        let spot: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                (-((x - u).powi(2) + (y - v).powi(2)) / 4.0).exp() as f32
            })
            .collect();
        let turned = rotate_view(&spot, w, h, &k, &delta.to_rotation_matrix());
        let (u2, v2) = project(&rotated_rotation(&r_wc, &delta));
        let total: f32 = turned.iter().sum();
        let (mut mx, mut my) = (0.0, 0.0);
        for (i, &a) in turned.iter().enumerate() {
            mx += (i % w) as f32 * a;
            my += (i / w) as f32 * a;
        }
        let (mx, my) = ((mx / total) as f64, (my / total) as f64);
        assert!(
            (mx - u2).abs() < 0.15 && (my - v2).abs() < 0.15,
            "({mx}, {my}) vs ({u2}, {v2}); before ({u}, {v})"
        );
        assert!(
            (u2 - u).abs() + (v2 - v).abs() > 3.0,
            "the turn moved the spot"
        );
    }

    #[test]
    fn turned_image_matches_the_projection_of_the_turned_camera() {
        check(view_turn(0.6, 0.0, 0.0)); // roll only
        check(view_turn(0.0, 0.15, 0.0)); // pitch
        check(view_turn(0.0, 0.0, -0.2)); // yaw
        check(view_turn(-0.4, 0.1, 0.12)); // all three
        let px: Vec<f32> = (0..12).map(|i| i as f32).collect();
        let k = ViewIntrinsics::centred(4, 3, 2.0);
        assert_eq!(rotate_view(&px, 4, 3, &k, &Rotation3::identity()), px);
    }

    #[test]
    fn resized_intrinsics_keep_the_centre_and_the_field_of_view() {
        let cam = Camera::from_hfov(640, 480, 90.0);
        let k = ViewIntrinsics::resized(&cam, 128, 96);
        assert!(
            (k.cx - 63.5).abs() < 1e-9 && (k.cy - 47.5).abs() < 1e-9,
            "{k:?}"
        );
        assert!((k.fx - 64.0).abs() < 1e-9, "{k:?}"); // 90° over 128 px
    }
}
