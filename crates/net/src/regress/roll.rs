//! Roll augmentation with an exact label: rotating the camera about its optical axis by θ
//! (`R_wc' = R_wc · R_z(θ)`, OpenCV axes: z forward, x right, y down) moves the image of every
//! point about the principal point by −θ, so the new image is `I'(u') = I(c + R(θ)(u' − c))`
//! with `R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]` in pixel coordinates (x right, y down).
//! Exact when the principal point is the image centre and the pixels are square (fx = fy),
//! as for the simulator's camera; approximate otherwise. Corners that come from outside the
//! image replicate the border.

use nalgebra::{UnitQuaternion, Vector3};

/// The image `px` (`w × h`, row-major) seen by the camera rolled by `theta_rad` about its
/// optical axis (bilinear sampling, borders replicated).
pub fn roll_image(px: &[f32], w: usize, h: usize, theta_rad: f32) -> Vec<f32> {
    if w == 0 || h == 0 || px.len() != w * h {
        return px.to_vec();
    }
    let (s, c) = theta_rad.sin_cos();
    let (cx, cy) = ((w as f32 - 1.0) / 2.0, (h as f32 - 1.0) / 2.0);
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            let sx = (c * dx - s * dy + cx).clamp(0.0, (w - 1) as f32);
            let sy = (s * dx + c * dy + cy).clamp(0.0, (h - 1) as f32);
            let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
            let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
            let (fx, fy) = (sx - x0 as f32, sy - y0 as f32);
            let top = px[y0 * w + x0] * (1.0 - fx) + px[y0 * w + x1] * fx;
            let bot = px[y1 * w + x0] * (1.0 - fx) + px[y1 * w + x1] * fx;
            out[y * w + x] = top * (1.0 - fy) + bot * fy;
        }
    }
    out
}

/// The camera-to-world rotation after a roll by `theta_rad` about the optical axis:
/// `R_wc · R_z(θ)`.
pub fn rolled_rotation(r_wc: &UnitQuaternion<f64>, theta_rad: f64) -> UnitQuaternion<f64> {
    r_wc * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta_rad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    /// A bright spot where the camera sees a world point, before and after a roll.
    #[test]
    fn rolled_image_matches_the_projection_of_the_rolled_camera() {
        let (w, h) = (41usize, 31usize);
        let f = 20.0; // focal length, pixels; principal point at the centre
        let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
        let r_wc = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7);
        let p_w = r_wc * Point3::new(0.4, -0.1, 1.0); // camera at the origin
        let project = |r: &UnitQuaternion<f64>| {
            let p = r.inverse() * p_w;
            (f * p.x / p.z + cx, f * p.y / p.z + cy)
        };
        let (u, v) = project(&r_wc);
        let spot = |u: f64, v: f64| -> Vec<f32> {
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f64, (i / w) as f64);
                    (-((x - u).powi(2) + (y - v).powi(2)) / 4.0).exp() as f32
                })
                .collect()
        };
        let theta = 0.6f64;
        let rolled = roll_image(&spot(u, v), w, h, theta as f32);
        let (u2, v2) = project(&rolled_rotation(&r_wc, theta));
        // Centroid of the rolled image is where the rolled camera sees the point.
        let total: f32 = rolled.iter().sum();
        let (mut mx, mut my) = (0.0, 0.0);
        for (i, &a) in rolled.iter().enumerate() {
            mx += (i % w) as f32 * a;
            my += (i / w) as f32 * a;
        }
        let (mx, my) = ((mx / total) as f64, (my / total) as f64);
        assert!(
            (mx - u2).abs() < 0.1 && (my - v2).abs() < 0.1,
            "({mx}, {my}) vs ({u2}, {v2}); before ({u}, {v})"
        );
        assert!(
            (u2 - u).abs() + (v2 - v).abs() > 3.0,
            "the roll moved the spot"
        );
        assert_eq!(roll_image(&spot(u, v), w, h, 0.0), spot(u, v));
    }
}
