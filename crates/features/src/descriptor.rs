//! The SURF descriptor (64-d, or 128-d extended), in its M-SURF form.
//!
//! Haar wavelets of side `2σ` are sampled on a 24 × 24 grid at step σ in the keypoint's frame
//! (rotated by its orientation), their responses rotated into that frame (`du` along the
//! orientation, `dv` across it). The grid is cut into 4 × 4 overlapping sub-regions of 9 × 9
//! samples (centres 5σ apart, as in Agrawal et al. 2008 and OpenSURF), each weighted by a
//! Gaussian (σ = 2.5 samples) around its centre; a sub-region contributes
//! `(Σdu, Σdv, Σ|du|, Σ|dv|)` — or, extended, the four sums split by the sign of the other
//! response — weighted by a Gaussian (σ = 1.5 sub-regions) over the 4 × 4 grid. The vector is
//! then normalised to unit L2 length. The overlap and double weighting make it more robust to
//! small shifts than the non-overlapping 20σ window of Bay et al.

use std::f32::consts::SQRT_2;
use std::sync::OnceLock;

use crate::integral::{HaarWindow, IntegralImage, round_i64};
use crate::mask::Mask;

const GRID: usize = 24;
const SUB: usize = 9;
const SUB_STEP: usize = 5;

struct Weights {
    inner: [f32; SUB * SUB],
    outer: [f32; 16],
}

fn weights() -> &'static Weights {
    static W: OnceLock<Weights> = OnceLock::new();
    W.get_or_init(|| {
        let mut inner = [0.0f32; SUB * SUB];
        for b in 0..SUB {
            for a in 0..SUB {
                let (da, db) = (a as f32 - 4.0, b as f32 - 4.0);
                inner[b * SUB + a] = (-(da * da + db * db) / (2.0 * 2.5 * 2.5)).exp();
            }
        }
        let mut outer = [0.0f32; 16];
        for rv in 0..4 {
            for ru in 0..4 {
                let (du, dv) = (ru as f32 - 1.5, rv as f32 - 1.5);
                outer[rv * 4 + ru] = (-(du * du + dv * dv) / (2.0 * 1.5 * 1.5)).exp();
            }
        }
        Weights { inner, outer }
    })
}

/// Descriptor of the keypoint at `(x, y)` (pixels), scale σ `scale` (pixels), orientation
/// `angle` (radians, image axes); writes 64 or 128 (`extended`) unit-norm values to `out`.
/// Samples whose Haar box reaches outside `mask` count as zero, like samples beyond the image.
#[allow(clippy::too_many_arguments)]
pub(crate) fn describe(
    ii: &IntegralImage,
    mask: Option<&Mask>,
    x: f32,
    y: f32,
    scale: f32,
    angle: f32,
    extended: bool,
    out: &mut Vec<f32>,
) {
    let (sin, cos) = angle.sin_cos();
    let size = 2 * round_i64(scale).max(1);
    // Rotated Haar responses on the 24 × 24 sample grid.
    let mut du = [0.0f32; GRID * GRID];
    let mut dv = [0.0f32; GRID * GRID];
    let window = HaarWindow::new(ii, mask, (x, y), 11.5 * SQRT_2 * scale, size);
    for mv in 0..GRID {
        let v = (mv as f32 - 11.5) * scale;
        for mu in 0..GRID {
            let u = (mu as f32 - 11.5) * scale;
            let px = x + u * cos - v * sin;
            let py = y + u * sin + v * cos;
            let Some((dx, dy)) = window.at(px, py) else {
                continue;
            };
            du[mv * GRID + mu] = dx * cos + dy * sin;
            dv[mv * GRID + mu] = -dx * sin + dy * cos;
        }
    }
    let w = weights();
    out.clear();
    for rv in 0..4 {
        for ru in 0..4 {
            let mut acc = [0.0f32; 8];
            for b in 0..SUB {
                let row = (rv * SUB_STEP + b) * GRID + ru * SUB_STEP;
                for a in 0..SUB {
                    let g = w.inner[b * SUB + a];
                    let (ru_, rv_) = (g * du[row + a], g * dv[row + a]);
                    if extended {
                        let k = if rv_ < 0.0 { 0 } else { 1 };
                        acc[k] += ru_;
                        acc[2 + k] += ru_.abs();
                        let k = if ru_ < 0.0 { 4 } else { 5 };
                        acc[k] += rv_;
                        acc[k + 2] += rv_.abs();
                    } else {
                        acc[0] += ru_;
                        acc[1] += rv_;
                        acc[2] += ru_.abs();
                        acc[3] += rv_.abs();
                    }
                }
            }
            let g = w.outer[rv * 4 + ru];
            let n = if extended { 8 } else { 4 };
            out.extend(acc[..n].iter().map(|v| v * g));
        }
    }
    let norm = out.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > 0.0 {
        out.iter_mut().for_each(|v| *v /= norm);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptor_is_unit_length_and_has_the_right_size() {
        let (w, h) = (100usize, 100usize);
        let px: Vec<u8> = (0..w * h)
            .map(|i| ((i * 7919 + i / w * 13) % 256) as u8)
            .collect();
        let ii = IntegralImage::from_u8(&px, w, h);
        let mut d = Vec::new();
        describe(&ii, None, 50.0, 50.0, 2.0, 0.3, false, &mut d);
        assert_eq!(d.len(), 64);
        assert!((d.iter().map(|v| v * v).sum::<f32>() - 1.0).abs() < 1e-4);
        describe(&ii, None, 50.0, 50.0, 2.0, 0.3, true, &mut d);
        assert_eq!(d.len(), 128);
        // A flat image has no gradient: an all-zero descriptor, not NaN.
        let flat = IntegralImage::from_u8(&vec![77u8; w * h], w, h);
        describe(&flat, None, 50.0, 50.0, 2.0, 0.0, false, &mut d);
        assert!(d.iter().all(|v| *v == 0.0));
    }
}
