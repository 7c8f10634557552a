//! Dominant orientation of a keypoint from Haar wavelet responses in a sliding 60° window.
//!
//! Responses of Haar wavelets of side `4σ` are sampled at step `σ` in a disc of radius `6σ`
//! around the keypoint (109 samples), weighted by a Gaussian of σ_w = `2.5σ`. A window of
//! π/3 slides around the circle of response angles; the orientation is the angle of the
//! largest summed response vector. Angles are in image axes (x right, y down), radians in
//! `[0, 2π)`.

use std::f32::consts::{PI, TAU};
use std::sync::OnceLock;

use crate::integral::{HaarWindow, IntegralImage, round_i64};
use crate::mask::Mask;

/// Number of samples in the disc.
const SAMPLES: usize = 109;

/// Sample offsets (in units of σ) and their Gaussian weights.
fn samples() -> &'static [(f32, f32, f32)] {
    static TABLE: OnceLock<Vec<(f32, f32, f32)>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Vec::with_capacity(SAMPLES);
        for j in -6i32..=6 {
            for i in -6i32..=6 {
                let r2 = i * i + j * j;
                if r2 < 36 {
                    let g = (-(r2 as f32) / (2.0 * 2.5 * 2.5)).exp();
                    t.push((i as f32, j as f32, g));
                }
            }
        }
        t
    })
}

/// Orientation (radians in `[0, 2π)`, image axes) of a keypoint at `(x, y)` with scale σ
/// `scale` pixels; 0 when no response is available (flat region or at the border). Samples
/// whose Haar box reaches outside `mask` count as no response.
pub(crate) fn orientation(
    ii: &IntegralImage,
    mask: Option<&Mask>,
    x: f32,
    y: f32,
    scale: f32,
) -> f32 {
    let size = 2 * round_i64(2.0 * scale).max(1);
    let window = HaarWindow::new(ii, mask, (x, y), 6.0 * scale, size);
    let mut rx = [0.0f32; SAMPLES];
    let mut ry = [0.0f32; SAMPLES];
    let mut n = 0;
    for &(i, j, g) in samples() {
        let (sx, sy) = (x + i * scale, y + j * scale);
        let Some((dx, dy)) = window.at(sx, sy) else {
            continue;
        };
        let (gx, gy) = (g * dx, g * dy);
        if gx != 0.0 || gy != 0.0 {
            (rx[n], ry[n]) = (gx, gy);
            n += 1;
        }
    }
    if n == 0 {
        return 0.0;
    }
    // Angles in a branch-free loop, then sorted by one integer key each: the angle's bits in
    // `f32::total_cmp` order above the sample's index, so the order is that of a stable sort
    // by angle.
    let mut keys = [0u64; SAMPLES];
    for k in 0..n {
        keys[k] = (u64::from(total_order_bits(atan2(ry[k], rx[k]))) << 32) | k as u64;
    }
    let keys = &mut keys[..n];
    keys.sort_unstable();
    let resp: Vec<(f32, f32, f32)> = keys
        .iter()
        .map(|&key| {
            let k = (key & 0xffff_ffff) as usize;
            (from_total_order_bits((key >> 32) as u32), rx[k], ry[k])
        })
        .collect();
    let window = PI / 3.0;
    let angle_at = |e: usize| {
        if e < n {
            resp[e].0
        } else {
            resp[e - n].0 + TAU
        }
    };
    let (mut sx, mut sy) = (0.0f32, 0.0f32);
    let (mut best, mut best_x, mut best_y) = (-1.0f32, 0.0f32, 0.0f32);
    let mut end = 0usize; // exclusive end of the window in the doubled sequence
    for start in 0..n {
        while end < start + n && angle_at(end) - resp[start].0 < window {
            let r = resp[end % n];
            sx += r.1;
            sy += r.2;
            end += 1;
        }
        let m = sx * sx + sy * sy;
        if m > best {
            (best, best_x, best_y) = (m, sx, sy);
        }
        sx -= resp[start].1;
        sy -= resp[start].2;
    }
    let a = best_y.atan2(best_x);
    if a < 0.0 { a + TAU } else { a }
}

/// `atan2(y, x)` in `[-π, π]` within 4e-7 rad (2 ulp at π) of the exact value (the sign of a
/// zero `y` kept, as `f32::atan2` does), in straight-line code: `atan(a) = a · P(a²)` on `[0, 1]`
/// with a degree-7 polynomial fitted to the minimax error (4e-8 rad), then the octant.
fn atan2(y: f32, x: f32) -> f32 {
    const C: [f32; 8] = [
        0.999_999_34,
        -0.333_298_6,
        0.199_465_66,
        -0.139_086_3,
        0.096_421_97,
        -0.055_912_316,
        0.021_862_95,
        -0.004_054_565,
    ];
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = if hi > 0.0 { lo / hi } else { 0.0 };
    let s = a * a;
    let mut p = C[7];
    for &c in C[..7].iter().rev() {
        p = p * s + c;
    }
    let mut r = a * p;
    if ay > ax {
        r = PI / 2.0 - r;
    }
    if x.is_sign_negative() {
        r = PI - r;
    }
    if y.is_sign_negative() { -r } else { r }
}

/// The bits of `v` as an unsigned integer ordered as [`f32::total_cmp`] orders the values.
fn total_order_bits(v: f32) -> u32 {
    let b = v.to_bits();
    if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
}

/// Inverse of [`total_order_bits`].
fn from_total_order_bits(b: u32) -> f32 {
    f32::from_bits(if b >> 31 == 1 { b & 0x7fff_ffff } else { !b })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn there_are_109_samples() {
        assert_eq!(samples().len(), SAMPLES);
    }

    /// The polynomial atan2 agrees with the exact value to 4e-7 rad everywhere, axes and signed
    /// zeros included, and the integer keys order angles as `total_cmp` does.
    #[test]
    fn fast_atan2_matches_the_library_and_keys_keep_the_order() {
        let mut worst = 0.0f64;
        for k in 0..100_000 {
            let t = k as f64 / 100_000.0 * std::f64::consts::TAU;
            for r in [1e-6f64, 0.37, 1.0, 250.0] {
                let (y, x) = ((r * t.sin()) as f32, (r * t.cos()) as f32);
                let exact = (y as f64).atan2(x as f64);
                worst = worst.max((atan2(y, x) as f64 - exact).abs());
            }
        }
        assert!(worst < 4e-7, "worst error {worst:e} rad");
        for (y, x) in [
            (0.0f32, 1.0f32),
            (-0.0, 1.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (1.0, 0.0),
        ] {
            assert_eq!(atan2(y, x), y.atan2(x), "atan2({y}, {x})");
        }
        let values = [-PI, -1.0, -0.0, 0.0, 1e-30, 0.5, PI];
        for w in values.windows(2) {
            assert!(total_order_bits(w[0]) < total_order_bits(w[1]), "{w:?}");
        }
        for v in values {
            assert_eq!(
                from_total_order_bits(total_order_bits(v)).to_bits(),
                v.to_bits()
            );
        }
    }

    /// A linear ramp increasing along direction θ has orientation θ.
    #[test]
    fn ramp_orientation_follows_the_gradient_direction() {
        let (w, h) = (80usize, 80usize);
        for deg in [0.0f32, 30.0, 90.0, 135.0, 200.0, 300.0] {
            let t = deg.to_radians();
            let px: Vec<u8> = (0..w * h)
                .map(|k| {
                    let (x, y) = ((k % w) as f32 - 40.0, (k / w) as f32 - 40.0);
                    (128.0 + 2.0 * (x * t.cos() + y * t.sin())).clamp(0.0, 255.0) as u8
                })
                .collect();
            let ii = IntegralImage::from_u8(&px, w, h);
            let got = orientation(&ii, None, 40.0, 40.0, 2.0);
            let diff = (got - t).rem_euclid(TAU);
            let err = diff.min(TAU - diff);
            assert!(err < 0.1, "{deg}°: got {}°", got.to_degrees());
        }
    }
}
