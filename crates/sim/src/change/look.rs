//! The test pass's light, exposure, bubbles and optics, prepared for the renderer.
//!
//! - Light: power and specular scaled, the LED's cosine beam raised to `beam_exponent`, a
//!   broad wet sheen added (in the renderer's shading).
//! - Exposure: a gain drifting slowly over the pass between the two ends of its range
//!   (periods of 100–600 frames), a white balance, and a gamma folded into the display curve.
//! - Bubbles: frames come in episodes of [`EPISODE_FRAMES`]; an episode has bubbles with
//!   probability `bubble_frames`: a cluster of bubbles near the lens, drifting across the
//!   episode, covering up to `bubble_cover` of the frame — lenses with bright rims and a
//!   specular dot, lit by the scope's light and fixed to no wall point, showing the wall behind
//!   them magnified (`ChangedLook::draw_bubbles`). A `bubble_cover`
//!   of 1 is foam over the whole lens: every pixel of such a frame lies in a bubble.
//! - Defocus: a Gaussian blur of the linear image.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::config::{LookChange, ScopeChange};
use crate::appearance::splitmix64;
use crate::trajectory::Wave;

/// Frames per bubble episode.
pub const EPISODE_FRAMES: usize = 12;

/// One bubble in pixels of the output image.
#[derive(Debug, Clone, Copy)]
struct Bubble {
    x: f32,
    y: f32,
    r: f32,
}

/// The test pass's look, ready for the renderer (`Renderer::with_look`).
#[derive(Debug, Clone)]
pub struct ChangedLook {
    pub(crate) light_power: f32,
    pub(crate) beam_exponent: f32,
    pub(crate) specular: f32,
    pub(crate) sheen: f32,
    pub(crate) white_balance: [f32; 3],
    pub(crate) gamma: f64,
    log_gain: [f64; 2],
    gain_wave: Wave,
    bubble_frames: f64,
    bubble_cover: f64,
    defocus_px: f64,
    seed: u64,
}

impl ChangedLook {
    /// Prepares `look` and `scope` with the change's `seed`.
    pub fn new(look: &LookChange, scope: &ScopeChange, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        ChangedLook {
            light_power: look.light_power as f32,
            beam_exponent: look.beam_exponent as f32,
            specular: look.specular as f32,
            sheen: look.sheen as f32,
            white_balance: look.white_balance.map(|w| w as f32),
            gamma: look.gamma,
            log_gain: look.gain.map(f64::ln),
            gain_wave: Wave::new(&mut rng, 1.0 / 600.0, 1.0 / 100.0),
            bubble_frames: look.bubble_frames,
            bubble_cover: look.bubble_cover,
            defocus_px: scope.defocus_px,
            seed: rng.random(),
        }
    }

    /// Exposure gain of frame `frame`.
    pub fn gain_at(&self, frame: usize) -> f32 {
        let [lo, hi] = self.log_gain;
        let t = 0.5 + 0.5 * self.gain_wave.at(frame as f64);
        (lo + (hi - lo) * t).exp() as f32
    }

    fn uniform(&self, key: u64) -> f64 {
        (splitmix64(self.seed ^ key) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The bubbles of frame `frame` in a `w × h` image (none for most frames).
    fn bubbles(&self, frame: usize, w: usize, h: usize) -> Vec<Bubble> {
        let episode = (frame / EPISODE_FRAMES) as u64;
        let key = episode.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        if self.bubble_frames <= 0.0 || self.uniform(key) >= self.bubble_frames {
            return Vec::new();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(splitmix64(self.seed ^ key ^ 0xB0B));
        let (wf, hf) = (w as f32, h as f32);
        if self.bubble_cover >= 1.0 {
            return foam(&mut rng, wf, hf);
        }
        let area = wf * hf;
        let cover = self.bubble_cover as f32 * rng.random_range(0.4..1.0f32);
        let cluster_r = (cover * area / std::f32::consts::PI).sqrt();
        let cx = rng.random_range(0.2..0.8f32) * wf;
        let cy = rng.random_range(0.2..0.8f32) * hf;
        let drift = (
            rng.random_range(-1.0..1.0f32) * 0.01 * wf,
            rng.random_range(-1.0..1.0f32) * 0.01 * hf,
        );
        let step = (frame % EPISODE_FRAMES) as f32;
        let (cx, cy) = (cx + drift.0 * step, cy + drift.1 * step);
        let mut bubbles = Vec::new();
        let mut covered = 0.0;
        while covered < cover * area && bubbles.len() < 200 {
            let r = rng.random_range(0.015..0.07f32) * wf.min(hf);
            let a = rng.random_range(0.0..std::f32::consts::TAU);
            let d = cluster_r * rng.random::<f32>().sqrt();
            bubbles.push(Bubble {
                x: cx + d * a.cos(),
                y: cy + d * a.sin(),
                r,
            });
            covered += std::f32::consts::PI * r * r;
        }
        bubbles
    }

    /// Draws frame `frame`'s bubbles into a linear RGB image (`w × h × 3`). A bubble is a lens:
    /// the wall behind it is seen magnified about its centre (most at the centre, least at the
    /// rim), so what shows through it is not where the wall is.
    pub(crate) fn draw_bubbles(&self, linear: &mut [f32], w: usize, h: usize, frame: usize) {
        let bubbles = self.bubbles(frame, w, h);
        if bubbles.is_empty() {
            return;
        }
        let behind = linear.to_vec();
        let clamp = |v: f32, n: usize| (v.round().max(0.0) as usize).min(n - 1);
        for b in bubbles {
            let (x0, x1) = (
                (b.x - b.r).floor().max(0.0),
                (b.x + b.r).ceil().min(w as f32 - 1.0),
            );
            let (y0, y1) = (
                (b.y - b.r).floor().max(0.0),
                (b.y + b.r).ceil().min(h as f32 - 1.0),
            );
            if x0 > x1 || y0 > y1 {
                continue;
            }
            let (hx, hy, hr) = (b.x - 0.35 * b.r, b.y - 0.35 * b.r, 0.2 * b.r);
            for y in y0 as usize..=y1 as usize {
                for x in x0 as usize..=x1 as usize {
                    let (dx, dy) = (x as f32 - b.x, y as f32 - b.y);
                    let d = (dx * dx + dy * dy).sqrt() / b.r;
                    if d >= 1.0 {
                        continue;
                    }
                    let rim = ((d - 0.8) / 0.2).clamp(0.0, 1.0);
                    let (ex, ey) = (x as f32 - hx, y as f32 - hy);
                    let spot = (1.0 - (ex * ex + ey * ey).sqrt() / hr).max(0.0);
                    let add = 0.08 + 0.9 * rim * rim + 2.5 * spot * spot;
                    let keep = 0.7 - 0.3 * rim;
                    let m = 0.5 + 0.5 * d * d;
                    let (sx, sy) = (clamp(b.x + dx * m, w), clamp(b.y + dy * m, h));
                    for c in 0..3 {
                        linear[3 * (y * w + x) + c] = behind[3 * (sy * w + sx) + c] * keep + add;
                    }
                }
            }
        }
    }

    /// Blurs a linear RGB image (`w × h × 3`) by the defocus, if any.
    pub(crate) fn defocus(&self, linear: &mut [f32], w: usize, h: usize) {
        let sigma = self.defocus_px;
        if sigma <= 0.0 {
            return;
        }
        let radius = (3.0 * sigma).ceil() as isize;
        let kernel: Vec<f32> = (-radius..=radius)
            .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32)
            .collect();
        let sum: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / sum).collect();
        let mut tmp = vec![0f32; linear.len()];
        let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0f32; 3];
                for (k, wk) in kernel.iter().enumerate() {
                    let xx = clamp(x as isize + k as isize - radius, w);
                    for (c, a) in acc.iter_mut().enumerate() {
                        *a += wk * linear[3 * (y * w + xx) + c];
                    }
                }
                tmp[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&acc);
            }
        }
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0f32; 3];
                for (k, wk) in kernel.iter().enumerate() {
                    let yy = clamp(y as isize + k as isize - radius, h);
                    for (c, a) in acc.iter_mut().enumerate() {
                        *a += wk * tmp[3 * (yy * w + x) + c];
                    }
                }
                linear[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&acc);
            }
        }
    }
}

/// Foam over the whole lens: bubbles on a jittered square grid of pitch `r0`, each with a
/// radius of at least 0.9 `r0`, so that every pixel of a `wf × hf` image lies in one (a grid
/// cell's farthest point is r0/√2 + the jitter, 0.71 + 0.14 < 0.9 pitches, from its bubble).
fn foam(rng: &mut ChaCha8Rng, wf: f32, hf: f32) -> Vec<Bubble> {
    let r0 = 0.08 * wf.min(hf);
    let (nx, ny) = ((wf / r0).ceil() as usize + 1, (hf / r0).ceil() as usize + 1);
    let mut bubbles = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            bubbles.push(Bubble {
                x: (i as f32 + rng.random_range(-0.1..0.1f32)) * r0,
                y: (j as f32 + rng.random_range(-0.1..0.1f32)) * r0,
                r: rng.random_range(0.9..1.3f32) * r0,
            });
        }
    }
    bubbles
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::change::config::{ChangeConfig, Severity};

    #[test]
    fn gain_stays_in_its_range_and_bubbles_come_in_the_asked_share_of_frames() {
        let cfg = ChangeConfig::preset(Severity::Severe);
        let look = ChangedLook::new(&cfg.look, &cfg.scope, 3);
        let [lo, hi] = cfg.look.gain;
        let gains: Vec<f32> = (0..3000).map(|f| look.gain_at(f)).collect();
        assert!(
            gains
                .iter()
                .all(|g| *g as f64 >= lo - 1e-6 && *g as f64 <= hi + 1e-6)
        );
        let spread =
            gains.iter().fold(0f32, |m, g| m.max(*g)) / gains.iter().fold(9f32, |m, g| m.min(*g));
        assert!(spread > 1.5, "the gain drifts: {spread}");
        let frames = 12_000;
        let with = (0..frames)
            .filter(|f| !look.bubbles(*f, 64, 48).is_empty())
            .count();
        let share = with as f64 / frames as f64;
        assert!((share - cfg.look.bubble_frames).abs() < 0.04, "{share}");
    }

    #[test]
    fn foam_puts_every_pixel_in_a_bubble() {
        let mut cfg = ChangeConfig::preset(Severity::Moderate);
        cfg.look.bubble_frames = 1.0;
        cfg.look.bubble_cover = 1.0;
        let look = ChangedLook::new(&cfg.look, &cfg.scope, 4);
        for (frame, (w, h)) in [(0, (64, 48)), (13, (160, 120)), (40, (47, 61))] {
            let bubbles = look.bubbles(frame, w, h);
            for y in 0..h {
                for x in 0..w {
                    let (x, y) = (x as f32, y as f32);
                    assert!(
                        bubbles.iter().any(|b| (x - b.x).hypot(y - b.y) < b.r),
                        "frame {frame} ({w}x{h}): pixel ({x}, {y}) in no bubble"
                    );
                }
            }
        }
    }
}
