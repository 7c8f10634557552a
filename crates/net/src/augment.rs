//! Training-time augmentation of the resized grey images (values in `[0, 1]`, before
//! standardisation): small rotation (roll of the scope), brightness and contrast with
//! saturation, gamma, Gaussian blur (defocus, motion), specular highlights and sensor noise.
//!
//! Every draw comes from the caller's seeded RNG, so a run is reproducible. Note that a pure
//! gain or offset is removed by the per-image standardisation ([`crate::preprocess`]): what
//! brightness and contrast change for the network is where pixels saturate, and gamma.

use rand::Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Augmentation settings (all effects are independent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AugmentConfig {
    /// Apply augmentation at all.
    pub enabled: bool,
    /// Rotation about the image centre, uniform in `±rotation_deg` degrees (the scope's roll).
    pub rotation_deg: f32,
    /// Zoom uniform in `1 ± scale` (distance to the wall).
    pub scale: f32,
    /// Shift uniform in `±translate` of the image size, each axis (lateral offset, gaze).
    pub translate: f32,
    /// Gain uniform in `1 ± brightness`, then clipped to `[0, 1]`.
    pub brightness: f32,
    /// Contrast about the mean uniform in `1 ± contrast`, then clipped.
    pub contrast: f32,
    /// Gamma uniform in `[1/gamma, gamma]` (log-uniform); 1 disables it.
    pub gamma: f32,
    /// Probability of a Gaussian blur.
    pub blur_probability: f32,
    /// Largest blur standard deviation, input pixels (uniform in `[0.3, max]`).
    pub blur_max_sigma_px: f32,
    /// Probability of adding specular highlights.
    pub specular_probability: f32,
    /// At most this many highlights (uniform in `1..=max`).
    pub specular_max_blobs: u32,
    /// Standard deviation of additive Gaussian noise (image in `[0, 1]`).
    pub noise_sigma: f32,
}

impl Default for AugmentConfig {
    fn default() -> Self {
        AugmentConfig {
            enabled: true,
            rotation_deg: 45.0,
            scale: 0.15,
            translate: 0.08,
            brightness: 0.3,
            contrast: 0.3,
            gamma: 1.3,
            blur_probability: 0.3,
            blur_max_sigma_px: 1.2,
            specular_probability: 0.3,
            specular_max_blobs: 3,
            noise_sigma: 0.01,
        }
    }
}

impl AugmentConfig {
    /// No augmentation.
    pub fn off() -> Self {
        AugmentConfig {
            enabled: false,
            ..AugmentConfig::default()
        }
    }
}

/// Returns an augmented copy of `px` (`w × h`, row-major, values in `[0, 1]`).
pub fn augment<R: Rng>(
    px: &[f32],
    w: usize,
    h: usize,
    cfg: &AugmentConfig,
    rng: &mut R,
) -> Vec<f32> {
    if !cfg.enabled || w == 0 || h == 0 {
        return px.to_vec();
    }
    let mut out = if cfg.rotation_deg > 0.0 || cfg.scale > 0.0 || cfg.translate > 0.0 {
        let a = rng
            .random_range(-cfg.rotation_deg..=cfg.rotation_deg)
            .to_radians();
        let s = 1.0 + rng.random_range(-cfg.scale..=cfg.scale);
        let tx = rng.random_range(-cfg.translate..=cfg.translate) * w as f32;
        let ty = rng.random_range(-cfg.translate..=cfg.translate) * h as f32;
        warp(px, w, h, a, s, tx, ty)
    } else {
        px.to_vec()
    };
    if cfg.blur_probability > 0.0 && rng.random::<f32>() < cfg.blur_probability {
        let s = rng.random_range(0.3..=cfg.blur_max_sigma_px.max(0.3));
        out = blur(&out, w, h, s);
    }
    let gain = 1.0 + rng.random_range(-cfg.brightness..=cfg.brightness);
    let contrast = 1.0 + rng.random_range(-cfg.contrast..=cfg.contrast);
    let gamma = if cfg.gamma > 1.0 {
        let l = cfg.gamma.ln();
        rng.random_range(-l..=l).exp()
    } else {
        1.0
    };
    let mean = out.iter().sum::<f32>() / out.len() as f32;
    for v in out.iter_mut() {
        let c = (mean + (*v - mean) * contrast) * gain;
        *v = c.clamp(0.0, 1.0).powf(gamma);
    }
    if cfg.specular_probability > 0.0 && rng.random::<f32>() < cfg.specular_probability {
        let n = rng.random_range(1..=cfg.specular_max_blobs.max(1));
        for _ in 0..n {
            let cx = rng.random_range(0.0..w as f32);
            let cy = rng.random_range(0.0..h as f32);
            let r = rng.random_range(0.8..=2.5f32) * (w as f32 / 128.0).max(0.25);
            let amp = rng.random_range(0.5..=1.0f32);
            add_blob(&mut out, w, h, cx, cy, r, amp);
        }
    }
    if cfg.noise_sigma > 0.0
        && let Ok(normal) = Normal::new(0.0f32, cfg.noise_sigma)
    {
        for v in out.iter_mut() {
            *v = (*v + normal.sample(rng)).clamp(0.0, 1.0);
        }
    }
    out
}

/// Bilinear rotation by `angle` radians about the image centre, borders replicated.
#[cfg(test)]
fn rotate(px: &[f32], w: usize, h: usize, angle: f32) -> Vec<f32> {
    warp(px, w, h, angle, 1.0, 0.0, 0.0)
}

/// Bilinear similarity warp: rotation by `angle` radians and zoom by `scale` about the image
/// centre, then a shift by `(tx, ty)` pixels; borders replicated.
fn warp(px: &[f32], w: usize, h: usize, angle: f32, scale: f32, tx: f32, ty: f32) -> Vec<f32> {
    let (s, c) = angle.sin_cos();
    let inv = 1.0 / scale.max(1e-3);
    let (cx, cy) = ((w as f32 - 1.0) / 2.0, (h as f32 - 1.0) / 2.0);
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = ((x as f32 - cx - tx) * inv, (y as f32 - cy - ty) * inv);
            let sx = (c * dx + s * dy + cx).clamp(0.0, (w - 1) as f32);
            let sy = (-s * dx + c * dy + cy).clamp(0.0, (h - 1) as f32);
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

/// Separable Gaussian blur, borders replicated.
fn blur(px: &[f32], w: usize, h: usize, sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil().max(1.0) as isize;
    let k: Vec<f32> = (-r..=r)
        .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f32 = k.iter().sum();
    let k: Vec<f32> = k.iter().map(|v| v / norm).collect();
    let mut tmp = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for (j, kj) in k.iter().enumerate() {
                let xx = (x as isize + j as isize - r).clamp(0, w as isize - 1) as usize;
                acc += kj * px[y * w + xx];
            }
            tmp[y * w + x] = acc;
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for (j, kj) in k.iter().enumerate() {
                let yy = (y as isize + j as isize - r).clamp(0, h as isize - 1) as usize;
                acc += kj * tmp[yy * w + x];
            }
            out[y * w + x] = acc;
        }
    }
    out
}

/// Adds a saturating Gaussian highlight of radius `r` pixels and amplitude `amp`.
fn add_blob(px: &mut [f32], w: usize, h: usize, cx: f32, cy: f32, r: f32, amp: f32) {
    let reach = (3.0 * r).ceil() as isize;
    let (ix, iy) = (cx as isize, cy as isize);
    for y in (iy - reach).max(0)..=(iy + reach).min(h as isize - 1) {
        for x in (ix - reach).max(0)..=(ix + reach).min(w as isize - 1) {
            let d2 = (x as f32 - cx).powi(2) + (y as f32 - cy).powi(2);
            let v = &mut px[y as usize * w + x as usize];
            *v = (*v + amp * (-d2 / (2.0 * r * r)).exp()).min(1.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn augmentation_is_seeded_bounded_and_off_means_identity() {
        let (w, h) = (16, 12);
        let px: Vec<f32> = (0..w * h).map(|i| (i % 7) as f32 / 7.0).collect();
        let cfg = AugmentConfig {
            blur_probability: 1.0,
            specular_probability: 1.0,
            ..AugmentConfig::default()
        };
        let a = augment(&px, w, h, &cfg, &mut ChaCha8Rng::seed_from_u64(3));
        let b = augment(&px, w, h, &cfg, &mut ChaCha8Rng::seed_from_u64(3));
        let c = augment(&px, w, h, &cfg, &mut ChaCha8Rng::seed_from_u64(4));
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, px);
        assert!(a.iter().all(|v| (0.0..=1.0).contains(v)));
        let off = augment(
            &px,
            w,
            h,
            &AugmentConfig::off(),
            &mut ChaCha8Rng::seed_from_u64(3),
        );
        assert_eq!(off, px);
    }

    #[test]
    fn rotation_by_zero_is_identity_and_by_180_flips() {
        let (w, h) = (5, 3);
        let px: Vec<f32> = (0..15).map(|i| i as f32).collect();
        assert_eq!(rotate(&px, w, h, 0.0), px);
        let r = rotate(&px, w, h, std::f32::consts::PI);
        for (i, v) in r.iter().enumerate() {
            assert!((v - px[14 - i]).abs() < 1e-4, "{r:?}");
        }
    }
}
