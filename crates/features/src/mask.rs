//! The valid area of an endoscope image: where features may be detected and described.
//!
//! Real endoscope frames carry a black border and a circular field stop; the edge between the
//! lit mucosa and the black gives strong, meaningless SURF responses, and keypoints near it
//! are mismatched and triangulated far from the wall. A [`Mask`] (8-bit image, non-zero =
//! valid, the size of the frames) keeps the detector and the descriptor inside the valid area:
//!
//! - a keypoint is kept only when the whole box filter it was detected with lies in the valid
//!   area (its clearance from the nearest invalid pixel is at least
//!   [`DETECTOR_REACH_PER_SCALE`] × scale);
//! - orientation and descriptor samples whose Haar box reaches an invalid pixel count as zero,
//!   exactly like samples beyond the image border.
//!
//! [`Mask::clearance`] is the exact Euclidean distance (pixels) from a pixel to the nearest
//! invalid pixel (Felzenszwalb & Huttenlocher's separable transform), computed once per mask.
//! Detecting a mask from a recording is [`crate::mask_detect`].

use image::GrayImage;

use crate::FeatureError;

/// A keypoint of scale σ is kept when its clearance is at least this many σ: the half-diagonal
/// of its Hessian box filter (side `L = 7.5σ`, half-diagonal `L/√2 ≈ 5.3σ`).
pub const DETECTOR_REACH_PER_SCALE: f32 = 5.31;

/// The valid area of the frames of one camera (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Mask {
    width: usize,
    height: usize,
    /// Distance to the nearest invalid pixel, pixels (0 on invalid pixels; `f32::MAX` when
    /// every pixel is valid).
    clearance: Vec<f32>,
}

impl Mask {
    /// A mask from an 8-bit image: non-zero pixels are valid.
    ///
    /// # Errors
    /// [`FeatureError::EmptyMask`] when no pixel is valid.
    pub fn from_gray(image: &GrayImage) -> Result<Self, FeatureError> {
        let valid: Vec<bool> = image.as_raw().iter().map(|&v| v != 0).collect();
        Self::from_valid(image.width() as usize, image.height() as usize, &valid)
    }

    /// A mask from one flag per pixel, row-major (`true` = valid).
    ///
    /// # Errors
    /// [`FeatureError::BufferSize`] when `valid.len() != width·height`;
    /// [`FeatureError::EmptyMask`] when no pixel is valid.
    pub fn from_valid(width: usize, height: usize, valid: &[bool]) -> Result<Self, FeatureError> {
        if valid.len() != width * height {
            return Err(FeatureError::BufferSize {
                width,
                height,
                expected: width * height,
                actual: valid.len(),
            });
        }
        if !valid.iter().any(|&v| v) {
            return Err(FeatureError::EmptyMask { width, height });
        }
        Ok(Mask {
            width,
            height,
            clearance: distance_to_invalid(width, height, valid),
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Whether pixel `(x, y)` (integer coordinates) is valid; false outside the image.
    pub fn is_valid(&self, x: i64, y: i64) -> bool {
        self.clearance_at(x, y) > 0.0
    }

    /// Distance from pixel `(x, y)` to the nearest invalid pixel, pixels; 0 outside the image.
    pub fn clearance_at(&self, x: i64, y: i64) -> f32 {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return 0.0;
        }
        self.clearance[y as usize * self.width + x as usize]
    }

    /// Clearance at the pixel nearest to `(x, y)` (sub-pixel coordinates, origin at the centre
    /// of the top-left pixel).
    pub fn clearance(&self, x: f32, y: f32) -> f32 {
        self.clearance_at(x.round() as i64, y.round() as i64)
    }

    /// Whether a disc of `radius` pixels around `(x, y)` lies entirely in the valid area
    /// (up to the pixel grid).
    pub fn contains_disc(&self, x: f32, y: f32, radius: f32) -> bool {
        self.clearance(x, y) >= radius.max(0.5)
    }

    /// Fraction of valid pixels, in `(0, 1]`.
    pub fn valid_fraction(&self) -> f64 {
        let n = self.clearance.iter().filter(|&&c| c > 0.0).count();
        n as f64 / self.clearance.len() as f64
    }

    /// The mask as an 8-bit image (255 = valid, 0 = invalid).
    pub fn to_gray(&self) -> GrayImage {
        let px = self
            .clearance
            .iter()
            .map(|&c| if c > 0.0 { 255 } else { 0 })
            .collect();
        GrayImage::from_raw(self.width as u32, self.height as u32, px)
            .expect("buffer has width × height pixels")
    }

    /// Intersection over union with another mask of the same size; `None` for another size.
    pub fn iou(&self, other: &Mask) -> Option<f64> {
        if (self.width, self.height) != (other.width, other.height) {
            return None;
        }
        let (mut inter, mut union) = (0usize, 0usize);
        for (a, b) in self.clearance.iter().zip(&other.clearance) {
            let (a, b) = (*a > 0.0, *b > 0.0);
            inter += usize::from(a && b);
            union += usize::from(a || b);
        }
        Some(if union == 0 {
            1.0
        } else {
            inter as f64 / union as f64
        })
    }
}

/// Exact Euclidean distance from every pixel to the nearest invalid one (0 on invalid pixels,
/// `f32::MAX` when none is invalid): squared distances by the separable lower-envelope
/// transform, columns then rows.
fn distance_to_invalid(width: usize, height: usize, valid: &[bool]) -> Vec<f32> {
    const INF: f64 = 1e20;
    let mut d: Vec<f64> = valid.iter().map(|&v| if v { INF } else { 0.0 }).collect();
    let mut f = vec![0.0; width.max(height)];
    let mut out = vec![0.0; width.max(height)];
    for x in 0..width {
        for y in 0..height {
            f[y] = d[y * width + x];
        }
        squared_distance_1d(&f[..height], &mut out[..height]);
        for y in 0..height {
            d[y * width + x] = out[y];
        }
    }
    for y in 0..height {
        let row = &mut d[y * width..(y + 1) * width];
        f[..width].copy_from_slice(row);
        squared_distance_1d(&f[..width], &mut out[..width]);
        row.copy_from_slice(&out[..width]);
    }
    d.iter()
        .map(|&v| if v >= INF { f32::MAX } else { v.sqrt() as f32 })
        .collect()
}

/// 1-D squared distance transform of sampled function `f` (Felzenszwalb & Huttenlocher 2012):
/// `out[q] = min_p (q − p)² + f[p]`.
fn squared_distance_1d(f: &[f64], out: &mut [f64]) {
    let n = f.len();
    if n == 0 {
        return;
    }
    let mut v = vec![0usize; n];
    let mut z = vec![0.0f64; n + 1];
    let mut k = 0usize;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    let intersect = |q: usize, p: usize| {
        let (qf, pf) = (q as f64, p as f64);
        ((f[q] + qf * qf) - (f[p] + pf * pf)) / (2.0 * qf - 2.0 * pf)
    };
    for q in 1..n {
        let mut s = intersect(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = intersect(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = d * d + f[v[k]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clearance_is_the_euclidean_distance_to_the_nearest_invalid_pixel() {
        let (w, h) = (40usize, 30usize);
        let invalid = [(3usize, 4usize), (30, 20)];
        let valid: Vec<bool> = (0..w * h)
            .map(|i| !invalid.contains(&(i % w, i / w)))
            .collect();
        let m = Mask::from_valid(w, h, &valid).unwrap();
        for y in 0..h {
            for x in 0..w {
                let want = invalid
                    .iter()
                    .map(|&(a, b)| {
                        ((x as f32 - a as f32).powi(2) + (y as f32 - b as f32).powi(2)).sqrt()
                    })
                    .fold(f32::MAX, f32::min);
                let got = m.clearance_at(x as i64, y as i64);
                assert!((got - want).abs() < 1e-4, "({x},{y}): {got} vs {want}");
            }
        }
        assert!(!m.is_valid(3, 4) && m.is_valid(0, 0) && !m.is_valid(-1, 0));
    }

    #[test]
    fn an_all_valid_mask_has_unbounded_clearance_and_an_empty_one_is_refused() {
        let m = Mask::from_valid(5, 4, &[true; 20]).unwrap();
        assert_eq!(m.clearance_at(2, 2), f32::MAX);
        assert_eq!(m.valid_fraction(), 1.0);
        assert!(matches!(
            Mask::from_valid(5, 4, &[false; 20]),
            Err(FeatureError::EmptyMask { .. })
        ));
        let img = m.to_gray();
        assert_eq!(Mask::from_gray(&img).unwrap(), m);
    }
}
