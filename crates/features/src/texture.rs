//! A deterministic, seeded textured test image: Gaussian blobs at many scales on smooth
//! shading — blob-rich like a rendered colon wall, with no external files.

use image::GrayImage;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::warp::Plane;

/// Parameters of [`textured_plane`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TextureConfig {
    /// Width in pixels. Default 640.
    pub width: usize,
    /// Height in pixels. Default 480.
    pub height: usize,
    /// Random seed. Default 1.
    pub seed: u64,
    /// Blob density: expected blobs per pixel is `density / σ²` per unit of `ln σ`.
    /// Default 0.021 (about 820 SURF keypoints at threshold 200 on 640 × 480, and
    /// fewer than 0.2 % of the pixels beyond 0..255).
    pub density: f32,
    /// Smallest blob σ in pixels. Default 1.5.
    pub min_sigma: f32,
    /// Largest blob σ in pixels. Default 24.
    pub max_sigma: f32,
    /// Largest blob amplitude (0..255 intensity); amplitudes are uniform in
    /// `[amplitude/4, amplitude]` with a random sign. Default 60.
    pub amplitude: f32,
}

impl Default for TextureConfig {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            seed: 1,
            density: 0.021,
            min_sigma: 1.5,
            max_sigma: 24.0,
            amplitude: 60.0,
        }
    }
}

/// Renders the texture as a float plane on the 0..255 scale (not clamped).
pub fn textured_plane(cfg: &TextureConfig) -> Plane {
    let (w, h) = (cfg.width, cfg.height);
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut plane = Plane::filled(w, h, 0.0);
    // Smooth shading: a tilted plane and a broad bump.
    let (gx, gy) = (
        rng.random_range(-0.04..0.04f32),
        rng.random_range(-0.04..0.04f32),
    );
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f32 - w as f32 / 2.0, y as f32 - h as f32 / 2.0);
            plane.data[y * w + x] = 128.0 + gx * dx + gy * dy;
        }
    }
    let (lo, hi) = (
        cfg.min_sigma.max(0.5).ln(),
        cfg.max_sigma.max(cfg.min_sigma.max(0.5)).ln(),
    );
    // Expected count: ∫ density/σ² dlnσ · area = density·area·(σmin⁻² − σmax⁻²)/2.
    let (smin, smax) = (lo.exp(), hi.exp());
    let count =
        (cfg.density * (w * h) as f32 * (1.0 / (smin * smin) - 1.0 / (smax * smax)) / 2.0) as usize;
    for _ in 0..count {
        // Inverse-CDF sampling of σ with density ∝ σ⁻³ on [σmin, σmax].
        let u: f32 = rng.random();
        let inv2 = 1.0 / (smin * smin) - u * (1.0 / (smin * smin) - 1.0 / (smax * smax));
        let sigma = 1.0 / inv2.sqrt();
        let cx = rng.random_range(-3.0 * sigma..w as f32 + 3.0 * sigma);
        let cy = rng.random_range(-3.0 * sigma..h as f32 + 3.0 * sigma);
        let amp = rng.random_range(cfg.amplitude / 4.0..=cfg.amplitude.max(1e-3))
            * if rng.random::<bool>() { 1.0 } else { -1.0 };
        let elong = rng.random_range(1.0..1.6f32);
        let theta = rng.random_range(0.0..std::f32::consts::PI);
        add_blob(&mut plane, cx, cy, sigma, elong, theta, amp);
    }
    plane
}

fn add_blob(plane: &mut Plane, cx: f32, cy: f32, sigma: f32, elong: f32, theta: f32, amp: f32) {
    let r = 3.0 * sigma * elong;
    let (w, h) = (plane.width as i64, plane.height as i64);
    let x0 = ((cx - r).floor() as i64).max(0);
    let x1 = ((cx + r).ceil() as i64).min(w - 1);
    let y0 = ((cy - r).floor() as i64).max(0);
    let y1 = ((cy + r).ceil() as i64).min(h - 1);
    let (s, c) = theta.sin_cos();
    let (ia, ib) = (
        1.0 / (2.0 * (sigma * elong).powi(2)),
        1.0 / (2.0 * sigma * sigma),
    );
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
            plane.data[(y * w + x) as usize] += amp * (-(u * u * ia + v * v * ib)).exp();
        }
    }
}

/// The default texture (640 × 480 unless other sizes are given) as an 8-bit image.
pub fn textured_image(width: usize, height: usize, seed: u64) -> GrayImage {
    textured_plane(&TextureConfig {
        width,
        height,
        seed,
        ..TextureConfig::default()
    })
    .to_gray()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_image_other_seed_other_image() {
        let a = textured_image(64, 48, 3);
        let b = textured_image(64, 48, 3);
        let c = textured_image(64, 48, 4);
        assert_eq!(a, b);
        assert_ne!(a, c);
        let (mn, mx) = a
            .as_raw()
            .iter()
            .fold((255u8, 0u8), |(mn, mx), &v| (mn.min(v), mx.max(v)));
        assert!(mx - mn > 60, "texture should have contrast: {mn}..{mx}");
    }
}
