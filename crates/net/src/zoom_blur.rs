//! Zoom blur: the motion blur of a scope that moves along its optical axis during the
//! exposure, for the zoom-blurred views of the descriptor database
//! ([`TrainConfig::index_zoom_blur`](crate::TrainConfig::index_zoom_blur)).
//!
//! A scope advancing by `Δz` towards a wall at depth `z` magnifies the image about the
//! principal point by `z / (z − Δz)`: every point streaks radially, the more the farther from
//! the centre and the nearer the wall. An image blurred by an amplitude `a` is the mean of the
//! image magnified by `s` for `s` evenly spaced in `[1 − a, 1 + a]`
//! ([`ZOOM_BLUR_SAMPLES`] scalings, bilinear). With one amplitude for the whole frame it
//! stands for a mean depth: `a` = 0.06 is a scope moving ±1.2 mm during the exposure in
//! front of a wall 20 mm away. The lumen's far end (deeper) is blurred less in reality than
//! here; the database only needs views that resemble a blurred frame, not a rendering.

use crate::preprocess::sample_bilinear;

/// Scalings averaged per blurred image.
pub const ZOOM_BLUR_SAMPLES: usize = 9;

/// `pixels` (`width × height`, row-major, any value range) blurred by magnifications in
/// `1 ± amplitude` about `centre` (pixels, origin at the top-left pixel's centre); samples
/// outside the image take the nearest border pixel. `amplitude` 0 returns the image as it is.
pub fn zoom_blur(
    pixels: &[f32],
    width: usize,
    height: usize,
    centre: (f64, f64),
    amplitude: f64,
) -> Vec<f32> {
    if amplitude == 0.0 || width == 0 || height == 0 {
        return pixels.to_vec();
    }
    let n = ZOOM_BLUR_SAMPLES;
    // Each output pixel x samples the image at c + (x − c)/s.
    let inverse: Vec<f64> = (0..n)
        .map(|j| 1.0 / (1.0 - amplitude + 2.0 * amplitude * j as f64 / (n - 1) as f64))
        .collect();
    let (cx, cy) = centre;
    let mut out = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let mut sum = 0.0f64;
            for &k in &inverse {
                let sx = cx + (x as f64 - cx) * k;
                let sy = cy + (y as f64 - cy) * k;
                sum += f64::from(sample_bilinear(pixels, width, height, sx as f32, sy as f32));
            }
            out.push((sum / n as f64) as f32);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streaks_run_radially_and_spare_the_centre() {
        // A bright spoke along the row through the centre and a bright ring: zoom blur keeps
        // the spoke (radial) and spreads the ring (tangential to it) over its neighbours.
        let (w, h) = (64usize, 48usize);
        let c = (31.5, 23.5);
        let img: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let r = ((x - c.0).powi(2) + (y - c.1).powi(2)).sqrt();
                if (y - c.1).abs() < 1.0 || (r - 15.0).abs() < 0.7 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let out = zoom_blur(&img, w, h, c, 0.1);
        let px = |v: &[f32], x: usize, y: usize| v[y * w + x];
        // On the spoke, far from the centre: still bright.
        assert!(px(&out, 60, 23) > 0.9, "{}", px(&out, 60, 23));
        // The ring straight above the centre (r = 15 at y ≈ 8.5) spreads radially: weaker on
        // the ring, brighter 2 px inside it.
        assert!(px(&out, 31, 8) < 0.6, "{}", px(&out, 31, 8));
        assert!(px(&out, 31, 10) > 0.1, "{}", px(&out, 31, 10));
        assert_eq!(px(&img, 31, 10), 0.0);
        // A uniform image stays uniform; amplitude 0 is the identity.
        let flat = vec![0.4f32; w * h];
        assert!(
            zoom_blur(&flat, w, h, c, 0.2)
                .iter()
                .all(|v| (v - 0.4).abs() < 1e-6)
        );
        assert_eq!(zoom_blur(&img, w, h, c, 0.0), img);
    }
}
