//! Image preprocessing shared by training and inference: area resampling to the network's
//! input size and per-image standardisation.
//!
//! A frame (8-bit grey, any size) becomes `width × height` floats in `[0, 1]` by exact area
//! averaging (each output pixel is the mean of the input pixels it covers, fractional pixels
//! weighted by coverage — no aliasing when shrinking 640×480 to 128×96), then is standardised
//! to zero mean and unit standard deviation over the image. Standardising each image makes
//! the descriptor blind to global brightness and contrast, which change with the distance to
//! the wall and the light power.

use serde::{Deserialize, Serialize};

/// The network's input: grey images of `width × height` pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputSize {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
}

impl InputSize {
    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

impl std::fmt::Display for InputSize {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

impl std::str::FromStr for InputSize {
    type Err = crate::NetError;

    /// Parses `WIDTHxHEIGHT`, e.g. `160x120` (`×` is accepted too).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            crate::NetError::Config(format!(
                "input size {s:?}: expected WIDTHxHEIGHT in pixels, e.g. 160x120"
            ))
        };
        let (w, h) = s.trim().split_once(['x', 'X', '×']).ok_or_else(bad)?;
        Ok(InputSize {
            width: w.trim().parse().map_err(|_| bad())?,
            height: h.trim().parse().map_err(|_| bad())?,
        })
    }
}

/// Weights of the area resampling of one axis: for each output index, `(first input index,
/// weights)`; the weights sum to 1.
fn area_weights(src: usize, dst: usize) -> Vec<(usize, Vec<f32>)> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|o| {
            let a = o as f64 * scale;
            let b = (o + 1) as f64 * scale;
            let first = a.floor() as usize;
            let last = (b.ceil() as usize).min(src).max(first + 1);
            let w: Vec<f32> = (first..last)
                .map(|i| {
                    let lo = a.max(i as f64);
                    let hi = b.min((i + 1) as f64);
                    ((hi - lo).max(0.0) / scale) as f32
                })
                .collect();
            (first.min(src - 1), w)
        })
        .collect()
}

/// Resamples an 8-bit grey image (`src_w × src_h`, row-major) to `size` by area averaging;
/// values in `[0, 1]`. Works for enlarging too (then it is nearest-neighbour-like).
///
/// # Panics
/// Never for `src.len() == src_w · src_h` with both ≥ 1; callers check sizes.
pub fn resize_area(src: &[u8], src_w: usize, src_h: usize, size: InputSize) -> Vec<f32> {
    let (dw, dh) = (size.width as usize, size.height as usize);
    let wx = area_weights(src_w, dw);
    let wy = area_weights(src_h, dh);
    // Horizontal pass: src_h × dw.
    let mut tmp = vec![0f32; src_h * dw];
    for y in 0..src_h {
        let row = &src[y * src_w..(y + 1) * src_w];
        let out = &mut tmp[y * dw..(y + 1) * dw];
        for (o, (first, w)) in out.iter_mut().zip(&wx) {
            let mut acc = 0.0;
            for (k, &wk) in w.iter().enumerate() {
                acc += wk * row[(first + k).min(src_w - 1)] as f32;
            }
            *o = acc * (1.0 / 255.0);
        }
    }
    // Vertical pass.
    let mut out = vec![0f32; dh * dw];
    for (oy, (first, w)) in wy.iter().enumerate() {
        let dst = &mut out[oy * dw..(oy + 1) * dw];
        for (k, &wk) in w.iter().enumerate() {
            let y = (first + k).min(src_h - 1);
            let src_row = &tmp[y * dw..(y + 1) * dw];
            for (d, s) in dst.iter_mut().zip(src_row) {
                *d += wk * s;
            }
        }
    }
    out
}

/// Standardises in place to zero mean and unit standard deviation (a flat image becomes 0).
pub fn standardize(px: &mut [f32]) {
    if px.is_empty() {
        return;
    }
    let n = px.len() as f64;
    let mean = px.iter().map(|&v| v as f64).sum::<f64>() / n;
    let var = px.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / n;
    let inv = if var > 1e-12 { 1.0 / var.sqrt() } else { 0.0 };
    for v in px.iter_mut() {
        *v = ((*v as f64 - mean) * inv) as f32;
    }
}

/// `px` (`w × h`, row-major) sampled bilinearly at `(x, y)` (pixels, origin at the top-left
/// pixel's centre); coordinates outside the image are clamped to its border, so the border
/// pixels are replicated. `w` and `h` must be at least 1.
pub fn sample_bilinear(px: &[f32], w: usize, h: usize, x: f32, y: f32) -> f32 {
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let top = px[y0 * w + x0] * (1.0 - fx) + px[y0 * w + x1] * fx;
    let bottom = px[y1 * w + x0] * (1.0 - fx) + px[y1 * w + x1] * fx;
    top * (1.0 - fy) + bottom * fy
}

/// Resize + standardise: the network input of one grey image.
pub fn network_input(img: &image::GrayImage, size: InputSize) -> Vec<f32> {
    let mut v = resize_area(
        img.as_raw(),
        img.width() as usize,
        img.height() as usize,
        size,
    );
    standardize(&mut v);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_sizes_parse_or_name_the_expected_form() {
        let s: InputSize = "160x120".parse().unwrap();
        assert_eq!((s.width, s.height), (160, 120));
        assert_eq!(
            " 64 × 48 ".parse::<InputSize>().unwrap().to_string(),
            "64x48"
        );
        for bad in ["160", "160x", "ax120", "-1x5", ""] {
            let e = bad.parse::<InputSize>().unwrap_err().to_string();
            assert!(e.contains("WIDTHxHEIGHT"), "{bad}: {e}");
        }
    }

    #[test]
    fn area_resize_averages_blocks_exactly() {
        // 4×2 → 2×1: each output is the mean of a 2×2 block.
        let src = [0u8, 255, 10, 20, 255, 0, 30, 40];
        let out = resize_area(
            &src,
            4,
            2,
            InputSize {
                width: 2,
                height: 1,
            },
        );
        assert!((out[0] - 0.5).abs() < 1e-6, "{out:?}");
        assert!((out[1] - 25.0 / 255.0).abs() < 1e-6, "{out:?}");
        // 5 → 2 (fractional coverage): means over [0, 2.5) and [2.5, 5).
        let src = [0u8, 0, 255, 255, 255];
        let out = resize_area(
            &src,
            5,
            1,
            InputSize {
                width: 2,
                height: 1,
            },
        );
        assert!(
            (out[0] - 0.2).abs() < 1e-6 && (out[1] - 1.0).abs() < 1e-6,
            "{out:?}"
        );
    }

    #[test]
    fn standardize_gives_zero_mean_unit_std_and_survives_flat_images() {
        let mut v = vec![1.0, 2.0, 3.0, 4.0];
        standardize(&mut v);
        let m: f32 = v.iter().sum::<f32>() / 4.0;
        let s: f32 = (v.iter().map(|x| x * x).sum::<f32>() / 4.0).sqrt();
        assert!(m.abs() < 1e-6 && (s - 1.0).abs() < 1e-5);
        let mut flat = vec![0.3; 9];
        standardize(&mut flat);
        assert!(flat.iter().all(|&x| x == 0.0));
    }
}
