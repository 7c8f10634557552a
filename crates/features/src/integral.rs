//! Summed-area table (integral image) for O(1) box sums.

use crate::mask::Mask;

/// Integral image of a grey image: `sum(x, y)` is the sum of all pixels with column `< x`
/// and row `< y`, stored for `x ∈ 0..=width`, `y ∈ 0..=height` (one row/column more than the
/// image). Intensities are on the 0..255 scale; sums are `f64`, exact for 8-bit images of any
/// size this crate accepts.
#[derive(Debug, Clone)]
pub struct IntegralImage {
    width: usize,
    height: usize,
    data: Vec<f64>,
    /// The same table in wrapping 32-bit integers, for 8-bit images only: a box sum taken
    /// with wrapping arithmetic is exact (a box of at most 2²³ pixels fits), and half the
    /// bytes of `data` to read in the detector's filter loops.
    exact: Option<Vec<u32>>,
}

impl IntegralImage {
    /// Builds the table from 8-bit pixels (row-major, `width × height`, length checked by the
    /// caller).
    pub(crate) fn from_u8(pixels: &[u8], width: usize, height: usize) -> Self {
        let mut ii = Self::build(width, height, |i| f64::from(pixels[i]));
        let stride = width + 1;
        let mut exact = vec![0u32; stride * (height + 1)];
        for y in 0..height {
            let mut row_sum = 0u32;
            let (prev, cur) = exact.split_at_mut((y + 1) * stride);
            let prev = &prev[y * stride..];
            let cur = &mut cur[..stride];
            let px = &pixels[y * width..(y + 1) * width];
            for x in 0..width {
                row_sum = row_sum.wrapping_add(u32::from(px[x]));
                cur[x + 1] = prev[x + 1].wrapping_add(row_sum);
            }
        }
        ii.exact = Some(exact);
        ii
    }

    /// Builds the table from intensities on the 0..1 scale (multiplied by 255).
    pub(crate) fn from_f32_unit(pixels: &[f32], width: usize, height: usize) -> Self {
        Self::build(width, height, |i| f64::from(pixels[i]) * 255.0)
    }

    fn build(width: usize, height: usize, pixel: impl Fn(usize) -> f64) -> Self {
        let stride = width + 1;
        let mut data = vec![0.0f64; stride * (height + 1)];
        for y in 0..height {
            let mut row_sum = 0.0;
            let (prev, cur) = data.split_at_mut((y + 1) * stride);
            let prev = &prev[y * stride..];
            let cur = &mut cur[..stride];
            for x in 0..width {
                row_sum += pixel(y * width + x);
                cur[x + 1] = prev[x + 1] + row_sum;
            }
        }
        Self {
            width,
            height,
            data,
            exact: None,
        }
    }

    /// Image width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Row stride of [`IntegralImage::data`] (`width + 1`).
    pub(crate) fn stride(&self) -> usize {
        self.width + 1
    }

    /// The raw table, row-major with stride `width + 1`.
    pub(crate) fn data(&self) -> &[f64] {
        &self.data
    }

    /// The table in wrapping 32-bit integers (same layout as [`IntegralImage::data`]), for a
    /// table built from 8-bit pixels.
    pub(crate) fn exact(&self) -> Option<&[u32]> {
        self.exact.as_deref()
    }

    /// Sum of the pixels in columns `x0..x1` and rows `y0..y1` (half-open); the rectangle is
    /// clipped to the image, an empty rectangle sums to 0.
    pub fn box_sum(&self, x0: i64, y0: i64, x1: i64, y1: i64) -> f64 {
        let cx = |v: i64| v.clamp(0, self.width as i64) as usize;
        let cy = |v: i64| v.clamp(0, self.height as i64) as usize;
        let (x0, x1, y0, y1) = (cx(x0), cx(x1), cy(y0), cy(y1));
        if x1 <= x0 || y1 <= y0 {
            return 0.0;
        }
        self.box_sum_unchecked(x0, y0, x1, y1)
    }

    /// Box sum for a rectangle known to lie inside the image (`x1 ≤ width`, `y1 ≤ height`).
    #[inline(always)]
    pub(crate) fn box_sum_unchecked(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> f64 {
        let s = self.stride();
        let d = &self.data;
        d[y1 * s + x1] - d[y0 * s + x1] - d[y1 * s + x0] + d[y0 * s + x0]
    }
}

/// The Haar wavelets of one keypoint's window (orientation disc, descriptor grid): a sample
/// whose box reaches outside the mask or the image gives `None`. Without a mask, and with the
/// whole window inside the image (most keypoints), samples skip every check.
pub(crate) struct HaarWindow<'a> {
    ii: &'a IntegralImage,
    mask: Option<&'a Mask>,
    size: i64,
    /// Distance from a wavelet's centre to its box's corners, pixels (the mask test).
    reach: f32,
    /// No mask, and every wavelet of the window lies inside the image.
    inside: bool,
}

impl<'a> HaarWindow<'a> {
    /// Wavelets of side `size` (even, ≥ 2) centred within `radius` pixels of `(x, y)`.
    pub(crate) fn new(
        ii: &'a IntegralImage,
        mask: Option<&'a Mask>,
        (x, y): (f32, f32),
        radius: f32,
        size: i64,
    ) -> Self {
        HaarWindow {
            ii,
            mask,
            size,
            reach: size as f32 * std::f32::consts::FRAC_1_SQRT_2,
            inside: mask.is_none() && ii.contains_samples(x, y, radius, size),
        }
    }

    /// The responses `(dx, dy)` of the wavelet centred at `(sx, sy)`, which must lie within
    /// the window's radius ([`IntegralImage::haar`]).
    #[inline(always)]
    pub(crate) fn at(&self, sx: f32, sy: f32) -> Option<(f32, f32)> {
        if self.inside {
            // SAFETY: `new` checked that every wavelet within the radius lies inside.
            return Some(unsafe { self.ii.haar_inside(sx, sy, self.size) });
        }
        if self
            .mask
            .is_some_and(|m| !m.contains_disc(sx, sy, self.reach))
        {
            return None;
        }
        self.ii.haar(sx, sy, self.size)
    }
}

/// Floor of a finite `f32` as `i64` without a libm call.
#[inline(always)]
pub(crate) fn floor_i64(v: f32) -> i64 {
    let i = v as i64;
    if (i as f32) > v { i - 1 } else { i }
}

/// Nearest integer of a finite `f32` (halves round up).
#[inline(always)]
pub(crate) fn round_i64(v: f32) -> i64 {
    floor_i64(v + 0.5)
}

impl IntegralImage {
    /// Haar wavelet responses `(dx, dy)` of side `size` (even, ≥ 2) centred at the pixel
    /// position `(x, y)`: `dx` = right half − left half, `dy` = bottom half − top half
    /// (0..255 intensity sums). `None` when the wavelet leaves the image.
    #[inline(always)]
    pub(crate) fn haar(&self, x: f32, y: f32, size: i64) -> Option<(f32, f32)> {
        let half = size / 2;
        // The box covers pixels px−half ..= px+half−1, centred at px − 0.5 ≈ x.
        let px = floor_i64(x + 1.0);
        let py = floor_i64(y + 1.0);
        if px - half < 0
            || py - half < 0
            || px + half > self.width as i64
            || py + half > self.height as i64
        {
            return None;
        }
        // SAFETY: the box's corners lie in the table, checked just above.
        Some(unsafe { self.haar_corners(px as usize, py as usize, half as usize) })
    }

    /// [`IntegralImage::haar`] for a wavelet that lies inside the image, e.g. one of a
    /// keypoint's samples when [`IntegralImage::contains_samples`] says they all do
    /// ([`HaarWindow`]).
    ///
    /// # Safety
    /// The wavelet must lie inside the image: `haar(x, y, size)` is `Some`.
    #[inline(always)]
    pub(crate) unsafe fn haar_inside(&self, x: f32, y: f32, size: i64) -> (f32, f32) {
        let half = size / 2;
        debug_assert!(self.haar(x, y, size).is_some());
        // Inside the image `x + 1` and `y + 1` are positive and small, where truncation is
        // the floor of `haar`.
        // SAFETY: finite, positive and below the image size, by the caller's guarantee.
        let (px, py) = unsafe {
            (
                (x + 1.0).to_int_unchecked::<u32>() as usize,
                (y + 1.0).to_int_unchecked::<u32>() as usize,
            )
        };
        // SAFETY: the caller guarantees the box lies inside the table.
        unsafe { self.haar_corners(px, py, half as usize) }
    }

    /// Whether every wavelet of side `size` centred within `radius` pixels of `(x, y)` lies
    /// inside the image (with a pixel to spare for rounding).
    #[inline]
    pub(crate) fn contains_samples(&self, x: f32, y: f32, radius: f32, size: i64) -> bool {
        let r = radius + (size / 2) as f32 + 2.0;
        x - r >= 0.0 && y - r >= 0.0 && x + r <= self.width as f32 && y + r <= self.height as f32
    }

    /// The Haar responses from the nine corners around `(px, py)` at distance `half`.
    ///
    /// # Safety
    /// `px ± half ∈ 0..=width` and `py ± half ∈ 0..=height`.
    #[inline(always)]
    unsafe fn haar_corners(&self, px: usize, py: usize, half: usize) -> (f32, f32) {
        let s = self.stride();
        let (x0, xm, x1) = (px - half, px, px + half);
        let (r0, rm, r1) = ((py - half) * s, py * s, (py + half) * s);
        // SAFETY: every index is a corner inside the table, by the caller's guarantee.
        let at = |k: usize| unsafe { *self.data.get_unchecked(k) };
        let (a, b, c) = (at(r0 + x0), at(r0 + xm), at(r0 + x1));
        let (e, g) = (at(rm + x0), at(rm + x1));
        let (h, i, j) = (at(r1 + x0), at(r1 + xm), at(r1 + x1));
        let left = i - b - h + a;
        let right = j - c - i + b;
        let top = g - c - e + a;
        let bottom = j - g - h + e;
        ((right - left) as f32, (bottom - top) as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_sums_match_naive_sums() {
        let (w, h) = (13usize, 7usize);
        let px: Vec<u8> = (0..w * h).map(|i| ((i * 37 + 11) % 251) as u8).collect();
        let ii = IntegralImage::from_u8(&px, w, h);
        for (x0, y0, x1, y1) in [(0, 0, 13, 7), (2, 1, 5, 6), (12, 6, 13, 7), (3, 3, 3, 5)] {
            let mut naive = 0.0;
            for y in y0..y1 {
                for x in x0..x1 {
                    naive += f64::from(px[y * w + x]);
                }
            }
            assert_eq!(
                ii.box_sum(x0 as i64, y0 as i64, x1 as i64, y1 as i64),
                naive
            );
        }
        // Clipped: only the inside part counts.
        assert_eq!(ii.box_sum(-5, -5, 1, 1), f64::from(px[0]));
        assert_eq!(ii.box_sum(20, 0, 30, 7), 0.0);
    }

    #[test]
    fn a_disc_said_to_be_inside_has_every_wavelet_inside_with_the_same_responses() {
        let (w, h) = (60usize, 40usize);
        let px: Vec<u8> = (0..w * h).map(|i| ((i * 7919) % 251) as u8).collect();
        let ii = IntegralImage::from_u8(&px, w, h);
        let mut inside = 0;
        for k in 0..4000 {
            let (x, y) = ((k * 37 % 600) as f32 / 10.0, (k * 53 % 400) as f32 / 10.0);
            let radius = (k % 13) as f32 * 0.9;
            let size = 2 * (1 + (k % 5) as i64);
            if !ii.contains_samples(x, y, radius, size) {
                continue;
            }
            inside += 1;
            for a in 0..32 {
                let t = a as f32 * std::f32::consts::TAU / 32.0;
                let (sx, sy) = (x + radius * t.cos(), y + radius * t.sin());
                let checked = ii.haar(sx, sy, size);
                assert!(checked.is_some(), "{x} {y} r {radius} size {size}");
                // SAFETY: just checked.
                assert_eq!(Some(unsafe { ii.haar_inside(sx, sy, size) }), checked);
            }
        }
        assert!(inside > 100, "{inside}");
    }

    #[test]
    fn haar_responds_to_a_vertical_edge_and_not_outside() {
        // Left half 0, right half 100: dx > 0, dy = 0.
        let (w, h) = (10usize, 10usize);
        let px: Vec<u8> = (0..w * h)
            .map(|i| if i % w >= 5 { 100 } else { 0 })
            .collect();
        let ii = IntegralImage::from_u8(&px, w, h);
        let (dx, dy) = ii.haar(4.5, 4.5, 4).unwrap();
        assert_eq!((dx, dy), (800.0, 0.0));
        assert!(ii.haar(0.0, 4.0, 4).is_none());
        assert_eq!(
            (
                floor_i64(-0.5),
                floor_i64(2.0),
                round_i64(2.5),
                round_i64(-1.4)
            ),
            (-1, 2, 3, -1)
        );
    }

    #[test]
    fn the_integer_table_gives_the_same_box_sums() {
        let (w, h) = (41usize, 23usize);
        let px: Vec<u8> = (0..w * h).map(|i| ((i * 97 + 5) % 256) as u8).collect();
        let ii = IntegralImage::from_u8(&px, w, h);
        let (d, e) = (ii.data(), ii.exact().unwrap());
        let s = ii.stride();
        for (x0, y0, x1, y1) in [(0, 0, 41, 23), (3, 2, 17, 20), (40, 22, 41, 23)] {
            let int = e[y1 * s + x1]
                .wrapping_sub(e[y0 * s + x1])
                .wrapping_sub(e[y1 * s + x0])
                .wrapping_add(e[y0 * s + x0]);
            assert_eq!(f64::from(int), ii.box_sum_unchecked(x0, y0, x1, y1));
        }
        assert_eq!(d.len(), e.len());
        assert!(
            IntegralImage::from_f32_unit(&[0.5; 4], 2, 2)
                .exact()
                .is_none()
        );
    }

    #[test]
    fn unit_float_input_is_scaled_to_255() {
        let ii = IntegralImage::from_f32_unit(&[1.0, 0.5, 0.0, 0.25], 2, 2);
        assert!((ii.box_sum(0, 0, 2, 2) - 255.0 * 1.75).abs() < 1e-9);
    }
}
