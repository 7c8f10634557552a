//! Keypoint overlays: circles of radius proportional to the scale, a radius line showing the
//! orientation.

use image::{GrayImage, Rgb, RgbImage};

use crate::Keypoint;

/// Colour for dark blobs (Laplacian +1): green.
pub const DARK_BLOB: Rgb<u8> = Rgb([40, 230, 60]);
/// Colour for bright blobs (Laplacian −1): magenta.
pub const BRIGHT_BLOB: Rgb<u8> = Rgb([240, 60, 220]);

/// The grey image in colour with each keypoint drawn as a circle of radius `2.5·σ` (≥ 2 px)
/// and a line from its centre along its orientation; green for dark blobs, magenta for
/// bright ones.
pub fn draw_keypoints(image: &GrayImage, keypoints: &[Keypoint]) -> RgbImage {
    let mut out = RgbImage::from_fn(image.width(), image.height(), |x, y| {
        let v = image.get_pixel(x, y).0[0];
        Rgb([v, v, v])
    });
    for kp in keypoints {
        let colour = if kp.laplacian >= 0 {
            DARK_BLOB
        } else {
            BRIGHT_BLOB
        };
        let r = (2.5 * kp.scale).max(2.0);
        let steps = (8.0 * r).ceil().max(16.0) as usize;
        for k in 0..steps {
            let t = k as f32 / steps as f32 * std::f32::consts::TAU;
            put(&mut out, kp.x + r * t.cos(), kp.y + r * t.sin(), colour);
        }
        let (s, c) = kp.orientation.sin_cos();
        let n = r.ceil() as usize * 2;
        for k in 0..=n {
            let d = r * k as f32 / n as f32;
            put(&mut out, kp.x + d * c, kp.y + d * s, colour);
        }
    }
    out
}

fn put(img: &mut RgbImage, x: f32, y: f32, c: Rgb<u8>) {
    let (xi, yi) = ((x + 0.5).floor(), (y + 0.5).floor());
    if xi >= 0.0 && yi >= 0.0 && xi < img.width() as f32 && yi < img.height() as f32 {
        img.put_pixel(xi as u32, yi as u32, c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circle_and_orientation_line_are_drawn_inside_the_image_only() {
        let img = GrayImage::new(40, 40);
        let kp = Keypoint {
            x: 20.0,
            y: 20.0,
            scale: 4.0,
            orientation: 0.0,
            response: 1.0,
            laplacian: -1,
            octave: 0,
        };
        let edge = Keypoint {
            x: 0.0,
            y: 0.0,
            ..kp
        };
        let out = draw_keypoints(&img, &[kp, edge]);
        // Radius 10: the circle passes through (30, 20) and (20, 10); the line runs along +x.
        assert_eq!(*out.get_pixel(30, 20), BRIGHT_BLOB);
        assert_eq!(*out.get_pixel(20, 10), BRIGHT_BLOB);
        assert_eq!(*out.get_pixel(25, 20), BRIGHT_BLOB);
        assert_eq!(*out.get_pixel(20, 25), Rgb([0, 0, 0]));
    }
}
