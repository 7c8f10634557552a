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

/// Sample offsets (in units of σ) and their Gaussian weights.
fn samples() -> &'static [(f32, f32, f32)] {
    static TABLE: OnceLock<Vec<(f32, f32, f32)>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Vec::with_capacity(109);
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
    let mut resp: Vec<(f32, f32, f32)> = Vec::with_capacity(109);
    let window = HaarWindow::new(ii, mask, (x, y), 6.0 * scale, size);
    for &(i, j, g) in samples() {
        let (sx, sy) = (x + i * scale, y + j * scale);
        let Some((dx, dy)) = window.at(sx, sy) else {
            continue;
        };
        let (rx, ry) = (g * dx, g * dy);
        if rx != 0.0 || ry != 0.0 {
            resp.push((ry.atan2(rx), rx, ry));
        }
    }
    let n = resp.len();
    if n == 0 {
        return 0.0;
    }
    resp.sort_by(|a, b| a.0.total_cmp(&b.0));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn there_are_109_samples() {
        assert_eq!(samples().len(), 109);
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
