//! Fast-Hessian detector: box-filter approximations of the second derivatives of a Gaussian,
//! evaluated on an integral image over octaves × scale levels, determinant threshold, 3×3×3
//! non-maximum suppression and quadratic interpolation of position and scale.
//!
//! Filter of side `L = (9 + 6·level)·2^octave` (odd in octave 0, even above) with lobe
//! `l = L/3`:
//! - `Dxx`: three lobes `l` wide and `2l − 1` tall (`2l − 2` when `L` is even), weights
//!   +1, −2, +1 per lobe *mean*; `Dyy` its transpose;
//! - `Dxy`: four `l × l` quadrants around a one-pixel cross (two pixels when `L` is even),
//!   weights +1 on the top-left/bottom-right, −1 on the others, per quadrant mean;
//! - response `det = Dxx·Dyy − (0.9·Dxy)²`, Laplacian sign `sign(Dxx + Dyy)`.
//!
//! A sample of octave `o` sits on the grid `X = k·step` (`step = initial_step·2^o`); an odd
//! filter is centred on pixel `X`, an even one between pixels `X − 1` and `X` (centre
//! `X − 0.5`), so all levels of one octave share sample centres.

use rayon::prelude::*;

use crate::integral::IntegralImage;
use crate::{Keypoint, SurfConfig};

/// Box-filter geometry of one scale level, as offsets into the integral image relative to the
/// filter's top-left corner.
#[derive(Debug, Clone)]
pub(crate) struct LayerFilter {
    /// Filter side length `L` in pixels.
    pub size: usize,
    /// Pixels the filter reaches left of / above the sample pixel `X`.
    reach_lo: usize,
    /// `X + reach_hi` must be ≤ the image width (exclusive end of the filter).
    reach_hi: usize,
    /// Corner offsets (relative to the filter's top-left corner) of the `Dxx` outer and
    /// middle boxes, each `[x1y1, x1y0, x0y1, x0y0]`.
    xx: [usize; 8],
    yy: [usize; 8],
    /// `Dxy` quadrants: top-left, bottom-right (weight +1), top-right, bottom-left (−1).
    xy: [usize; 16],
    inv_lobe_area: f64,
    inv_quadrant_area: f64,
    /// Largest entry of `xx`, `yy` and `xy`.
    max_offset: usize,
}

impl LayerFilter {
    pub(crate) fn new(size: usize, stride: usize) -> Self {
        let lobe = size / 3;
        let even = usize::from(size.is_multiple_of(2));
        let reach_lo = size / 2;
        let reach_hi = size - reach_lo;
        let lobe_h = 2 * lobe - 1 - even;
        // Box corners relative to the sample pixel X (may be negative), then shifted by reach_lo.
        let r = reach_lo as i64;
        let corners = |x0: i64, y0: i64, x1: i64, y1: i64| -> [usize; 4] {
            let at = |x: i64, y: i64| ((y + r) as usize) * stride + (x + r) as usize;
            [at(x1, y1), at(x1, y0), at(x0, y1), at(x0, y0)]
        };
        let (l, lh, lo) = (lobe as i64, lobe_h as i64, reach_lo as i64);
        let top = -(l - 1);
        let outer = (-lo, top, size as i64 - lo, top + lh);
        let mid_x0 = -(l / 2);
        let mid = (mid_x0, top, mid_x0 + l, top + lh);
        let t = |b: (i64, i64, i64, i64)| (b.1, b.0, b.3, b.2);
        let cat2 = |a: [usize; 4], b: [usize; 4]| [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]];
        let xx = cat2(
            corners(outer.0, outer.1, outer.2, outer.3),
            corners(mid.0, mid.1, mid.2, mid.3),
        );
        let (o2, m2) = (t(outer), t(mid));
        let yy = cat2(
            corners(o2.0, o2.1, o2.2, o2.3),
            corners(m2.0, m2.1, m2.2, m2.3),
        );
        let e = even as i64;
        let (n0, n1) = (-e - l, -e); // negative side: [−e−l, −e)
        let (p0, p1) = (1, 1 + l); // positive side: [1, 1+l)
        let q = |x: (i64, i64), y: (i64, i64)| corners(x.0, y.0, x.1, y.1);
        let (tl, br) = (q((n0, n1), (n0, n1)), q((p0, p1), (p0, p1)));
        let (tr, bl) = (q((p0, p1), (n0, n1)), q((n0, n1), (p0, p1)));
        let mut xy = [0usize; 16];
        for (i, b) in [tl, br, tr, bl].iter().enumerate() {
            xy[4 * i..4 * i + 4].copy_from_slice(b);
        }
        let max_offset = xx.iter().chain(&yy).chain(&xy).copied().max().unwrap_or(0);
        Self {
            max_offset,
            size,
            reach_lo,
            reach_hi,
            xx,
            yy,
            xy,
            inv_lobe_area: 1.0 / (lobe * lobe_h) as f64,
            inv_quadrant_area: 1.0 / (lobe * lobe) as f64,
        }
    }

    /// `(Dxx, Dyy, Dxy)` at the filter whose top-left integral corner is `base`.
    ///
    /// # Panics
    /// When the filter reaches outside `d` — callers only pass samples from
    /// [`LayerFilter::valid_range`], for which it never does.
    #[inline(always)]
    fn responses(&self, d: &[f64], base: usize) -> (f64, f64, f64) {
        // One bounds check for the whole filter.
        let win = &d[base..=base + self.max_offset];
        #[inline(always)]
        fn bx(w: &[f64], c: &[usize]) -> f64 {
            // SAFETY: every corner offset is ≤ `max_offset` (the maximum over all of them,
            // computed in `new`), and `w` has `max_offset + 1` elements.
            unsafe {
                w.get_unchecked(c[0]) - w.get_unchecked(c[1]) - w.get_unchecked(c[2])
                    + w.get_unchecked(c[3])
            }
        }
        let dxx = (bx(win, &self.xx[0..4]) - 3.0 * bx(win, &self.xx[4..8])) * self.inv_lobe_area;
        let dyy = (bx(win, &self.yy[0..4]) - 3.0 * bx(win, &self.yy[4..8])) * self.inv_lobe_area;
        let dxy = (bx(win, &self.xy[0..4]) + bx(win, &self.xy[4..8])
            - bx(win, &self.xy[8..12])
            - bx(win, &self.xy[12..16]))
            * self.inv_quadrant_area;
        (dxx, dyy, dxy)
    }

    /// The determinant `Dxx·Dyy − (0.9·Dxy)²` at the filter whose top-left integral corner
    /// is `base`, sample by sample: the reference that [`det_row`] reproduces bit for bit.
    #[inline(always)]
    fn det(&self, d: &[f64], base: usize) -> f32 {
        let (dxx, dyy, dxy) = self.responses(d, base);
        (dxx * dyy - 0.81 * dxy * dxy) as f32
    }

    /// Range of grid indices `k` (sample pixel `k·step`) where the filter fits in `extent`
    /// pixels; `None` when it never fits.
    fn valid_range(&self, extent: usize, step: usize) -> Option<(usize, usize)> {
        if extent < self.reach_hi || extent < self.reach_lo {
            return None;
        }
        let lo = self.reach_lo.div_ceil(step);
        let hi = (extent - self.reach_hi) / step;
        (lo <= hi).then_some((lo, hi))
    }
}

/// Determinant-of-Hessian map of one level on the octave's sample grid (0 where the filter
/// does not fit).
///
/// The lowest and highest levels of an octave only serve as the neighbours of the levels
/// between them, so they are left empty ([`Layer::sparse`]) and evaluated at the few samples
/// the non-maximum suppression and the interpolation ask for: the same arithmetic, so the
/// same values, for a third of the work.
struct Layer {
    filter: LayerFilter,
    /// One value per sample of the grid; empty for a sparse layer.
    det: Vec<f32>,
    /// Samples where the filter fits, inclusive: `(x_lo, x_hi, y_lo, y_hi)` (`None`: nowhere).
    valid: Option<(usize, usize, usize, usize)>,
}

impl Layer {
    /// A layer evaluated on demand by [`Layer::at`].
    fn sparse(ii: &IntegralImage, filter: LayerFilter, grid: Grid) -> Self {
        let valid = valid_samples(ii, &filter, grid);
        Layer {
            filter,
            det: Vec::new(),
            valid,
        }
    }

    /// The determinant at grid sample `i` (0 where the filter does not fit).
    #[inline]
    fn at(&self, ii: &IntegralImage, grid: Grid, i: usize) -> f32 {
        if !self.det.is_empty() {
            return self.det[i];
        }
        let (kx, ky) = (i % grid.nx, i / grid.nx);
        match self.valid {
            Some((x_lo, x_hi, y_lo, y_hi))
                if (x_lo..=x_hi).contains(&kx) && (y_lo..=y_hi).contains(&ky) =>
            {
                let f = &self.filter;
                let base =
                    (ky * grid.step - f.reach_lo) * ii.stride() + kx * grid.step - f.reach_lo;
                f.det(ii.data(), base)
            }
            _ => 0.0,
        }
    }
}

/// Grid samples where `filter` fits in the image, clipped to the grid.
fn valid_samples(
    ii: &IntegralImage,
    filter: &LayerFilter,
    grid: Grid,
) -> Option<(usize, usize, usize, usize)> {
    let (x_lo, x_hi) = filter.valid_range(ii.width(), grid.step)?;
    let (y_lo, y_hi) = filter.valid_range(ii.height(), grid.step)?;
    let (x_hi, y_hi) = (x_hi.min(grid.nx - 1), y_hi.min(grid.ny - 1));
    (x_lo <= x_hi && y_lo <= y_hi).then_some((x_lo, x_hi, y_lo, y_hi))
}

/// Sample grid of one octave.
#[derive(Clone, Copy)]
struct Grid {
    step: usize,
    nx: usize,
    ny: usize,
}

fn compute_layer(
    ii: &IntegralImage,
    filter: LayerFilter,
    grid: Grid,
    parallel: bool,
    reference: bool,
) -> Layer {
    let mut det = vec![0.0f32; grid.nx * grid.ny];
    let valid = valid_samples(ii, &filter, grid);
    let Some((x_lo, x_hi, y_lo, y_hi)) = valid else {
        return Layer { filter, det, valid };
    };
    let stride = ii.stride();
    let f = &filter;
    let row = |ky: usize, out: &mut [f32]| {
        if ky < y_lo || ky > y_hi {
            return;
        }
        let y_top = ky * grid.step - f.reach_lo;
        let row_base = y_top * stride + x_lo * grid.step - f.reach_lo;
        let out = &mut out[x_lo..=x_hi];
        if reference {
            for (k, o) in out.iter_mut().enumerate() {
                *o = f.det(ii.data(), row_base + k * grid.step);
            }
        } else {
            det_row(ii, f, row_base, grid.step, out);
        }
    };
    if parallel {
        det.par_chunks_mut(grid.nx)
            .enumerate()
            .for_each(|(ky, out)| row(ky, out));
    } else {
        det.chunks_mut(grid.nx)
            .enumerate()
            .for_each(|(ky, out)| row(ky, out));
    }
    Layer { filter, det, valid }
}

/// An integral-image entry: `f64` sums, or wrapping `u32` sums of an 8-bit image.
trait Sum: Copy {
    /// `a − b − c + d`, the box sum of four corners, as an exact `f64`.
    fn box_sum(a: Self, b: Self, c: Self, d: Self) -> f64;
}

impl Sum for f64 {
    #[inline(always)]
    fn box_sum(a: f64, b: f64, c: f64, d: f64) -> f64 {
        a - b - c + d
    }
}

impl Sum for u32 {
    #[inline(always)]
    fn box_sum(a: u32, b: u32, c: u32, d: u32) -> f64 {
        // Exact: the true sum of a box fits in 31 bits, whatever the wrapped corners are.
        f64::from(a.wrapping_sub(b).wrapping_sub(c).wrapping_add(d))
    }
}

/// Determinants of one row of samples: `out[k]` for the filter whose top-left integral corner
/// is `base + k·step`, read from `ii`'s integer table when it has one.
///
/// Box sums of integer intensities are exact in either table, and everything after them is
/// the arithmetic of [`LayerFilter::responses`] in the same order, so the result is bit for
/// bit that of the sample-by-sample loop. Written with the step as a constant so that the
/// compiler vectorises it (the loads of unit-step rows are contiguous, those of steps 2–8
/// interleaved), and compiled a second time for AVX2 where the CPU has it.
fn det_row(ii: &IntegralImage, f: &LayerFilter, base: usize, step: usize, out: &mut [f32]) {
    match ii.exact() {
        Some(d) => det_row_dispatch(f, d, base, step, out),
        None => det_row_dispatch(f, ii.data(), base, step, out),
    }
}

fn det_row_dispatch<T: Sum>(f: &LayerFilter, d: &[T], base: usize, step: usize, out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        unsafe { det_row_avx2(f, d, base, step, out) };
        return;
    }
    det_row_any(f, d, base, step, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn det_row_avx2<T: Sum>(f: &LayerFilter, d: &[T], base: usize, step: usize, out: &mut [f32]) {
    det_row_any(f, d, base, step, out);
}

#[inline(always)]
fn det_row_any<T: Sum>(f: &LayerFilter, d: &[T], base: usize, step: usize, out: &mut [f32]) {
    match step {
        1 => det_row_fixed::<T, 1>(f, d, base, step, out),
        2 => det_row_fixed::<T, 2>(f, d, base, step, out),
        4 => det_row_fixed::<T, 4>(f, d, base, step, out),
        8 => det_row_fixed::<T, 8>(f, d, base, step, out),
        _ => det_row_fixed::<T, 0>(f, d, base, step, out),
    }
}

/// [`det_row`] with the step `STEP` known at compile time (`0`: use `step`).
#[inline(always)]
fn det_row_fixed<T: Sum, const STEP: usize>(
    f: &LayerFilter,
    d: &[T],
    base: usize,
    step: usize,
    out: &mut [f32],
) {
    let step = if STEP == 0 { step } else { STEP };
    let n = out.len();
    if n == 0 {
        return;
    }
    // One bounds check for the whole row.
    let w = &d[base..=base + f.max_offset + (n - 1) * step];
    #[inline(always)]
    fn bx<T: Sum>(w: &[T], c: &[usize], at: usize) -> f64 {
        // SAFETY: every corner offset is ≤ `max_offset` and `at ≤ (n − 1)·step`, and `w` has
        // `max_offset + (n − 1)·step + 1` elements.
        unsafe {
            T::box_sum(
                *w.get_unchecked(c[0] + at),
                *w.get_unchecked(c[1] + at),
                *w.get_unchecked(c[2] + at),
                *w.get_unchecked(c[3] + at),
            )
        }
    }
    let (xx, yy, xy) = (&f.xx, &f.yy, &f.xy);
    let (inv_lobe, inv_quadrant) = (f.inv_lobe_area, f.inv_quadrant_area);
    for (k, o) in out.iter_mut().enumerate() {
        let at = k * step;
        let dxx = (bx(w, &xx[0..4], at) - 3.0 * bx(w, &xx[4..8], at)) * inv_lobe;
        let dyy = (bx(w, &yy[0..4], at) - 3.0 * bx(w, &yy[4..8], at)) * inv_lobe;
        let dxy = (bx(w, &xy[0..4], at) + bx(w, &xy[4..8], at)
            - bx(w, &xy[8..12], at)
            - bx(w, &xy[12..16], at))
            * inv_quadrant;
        *o = (dxx * dyy - 0.81 * dxy * dxy) as f32;
    }
}

/// Filter side length of `level` in `octave` (MATLAB/OpenCV scheme).
pub(crate) fn filter_size(octave: usize, level: usize) -> usize {
    (9 + 6 * level) << octave
}

/// Runs the fast-Hessian detector; keypoints come with orientation 0, ordered by octave,
/// level, row, column.
pub(crate) fn detect(ii: &IntegralImage, cfg: &SurfConfig) -> Vec<Keypoint> {
    let (w, h) = (ii.width(), ii.height());
    let mut out = Vec::new();
    if w == 0 || h == 0 {
        return out;
    }
    for octave in 0..cfg.octaves {
        let step = cfg.initial_step << octave;
        let grid = Grid {
            step,
            nx: (w - 1) / step + 1,
            ny: (h - 1) / step + 1,
        };
        // Skip the octave when even its smallest triple cannot fit.
        if filter_size(octave, 2) > w.min(h) {
            break;
        }
        let make = |level: usize| {
            let filter = LayerFilter::new(filter_size(octave, level), ii.stride());
            if !cfg.reference_filters && (level == 0 || level + 1 == cfg.scale_levels) {
                Layer::sparse(ii, filter, grid)
            } else {
                compute_layer(ii, filter, grid, cfg.parallel, cfg.reference_filters)
            }
        };
        let layers: Vec<Layer> = if cfg.parallel {
            (0..cfg.scale_levels).into_par_iter().map(make).collect()
        } else {
            (0..cfg.scale_levels).map(make).collect()
        };
        for level in 1..cfg.scale_levels - 1 {
            let found = suppress(ii, &layers, level, octave, grid, cfg);
            out.extend(found);
        }
    }
    out
}

/// 3×3×3 non-maximum suppression on `level`, interpolation, Laplacian sign.
fn suppress(
    ii: &IntegralImage,
    layers: &[Layer],
    level: usize,
    octave: usize,
    grid: Grid,
    cfg: &SurfConfig,
) -> Vec<Keypoint> {
    let (below, mid, above) = (&layers[level - 1], &layers[level], &layers[level + 1]);
    // The largest filter of the triple must fit at the sample and its 8 neighbours.
    let (Some((x_lo, x_hi)), Some((y_lo, y_hi))) = (
        above.filter.valid_range(ii.width(), grid.step),
        above.filter.valid_range(ii.height(), grid.step),
    ) else {
        return Vec::new();
    };
    let (x_hi, y_hi) = (x_hi.min(grid.nx - 1), y_hi.min(grid.ny - 1));
    if x_hi < x_lo + 2 || y_hi < y_lo + 2 {
        return Vec::new();
    }
    let nx = grid.nx;
    let threshold = cfg.threshold;
    let row = |ky: usize| -> Vec<Keypoint> {
        let mut found = Vec::new();
        for kx in x_lo + 1..x_hi {
            let i = ky * nx + kx;
            let v = mid.det[i];
            if v <= threshold {
                continue;
            }
            // Strictly greater than the neighbours before it (level, row, column order) and
            // not smaller than those after it: of a tie (a blob centred between samples)
            // exactly one sample survives.
            let nbhd = [
                i - nx - 1,
                i - nx,
                i - nx + 1,
                i - 1,
                i,
                i + 1,
                i + nx - 1,
                i + nx,
                i + nx + 1,
            ];
            let is_max = nbhd[..4].iter().all(|&j| mid.det[j] < v)
                && nbhd[5..].iter().all(|&j| mid.det[j] <= v)
                && nbhd.iter().all(|&j| below.at(ii, grid, j) < v)
                && nbhd.iter().all(|&j| above.at(ii, grid, j) <= v);
            if !is_max {
                continue;
            }
            if let Some(kp) = interpolate(ii, [below, mid, above], i, kx, ky, octave, grid) {
                found.push(kp);
            }
        }
        found
    };
    let rows = y_lo + 1..y_hi;
    if cfg.parallel {
        rows.into_par_iter().flat_map_iter(row).collect()
    } else {
        rows.flat_map(row).collect()
    }
}

/// Fits a 3-D quadratic to the 3×3×3 neighbourhood; `None` when the offset leaves the cell.
fn interpolate(
    ii: &IntegralImage,
    [below, mid, above]: [&Layer; 3],
    i: usize,
    kx: usize,
    ky: usize,
    octave: usize,
    grid: Grid,
) -> Option<Keypoint> {
    let nx = grid.nx;
    let (b, m, a) = (below, mid, above);
    let v = f64::from(m.at(ii, grid, i));
    let g = |layer: &Layer, j: usize| f64::from(layer.at(ii, grid, j));
    let dx = (g(m, i + 1) - g(m, i - 1)) / 2.0;
    let dy = (g(m, i + nx) - g(m, i - nx)) / 2.0;
    let ds = (g(a, i) - g(b, i)) / 2.0;
    let dxx = g(m, i + 1) + g(m, i - 1) - 2.0 * v;
    let dyy = g(m, i + nx) + g(m, i - nx) - 2.0 * v;
    let dss = g(a, i) + g(b, i) - 2.0 * v;
    let dxy = (g(m, i + nx + 1) - g(m, i + nx - 1) - g(m, i - nx + 1) + g(m, i - nx - 1)) / 4.0;
    let dxs = (g(a, i + 1) - g(a, i - 1) - g(b, i + 1) + g(b, i - 1)) / 4.0;
    let dys = (g(a, i + nx) - g(a, i - nx) - g(b, i + nx) + g(b, i - nx)) / 4.0;
    let hm = [[dxx, dxy, dxs], [dxy, dyy, dys], [dxs, dys, dss]];
    let off = solve3(hm, [-dx, -dy, -ds])?;
    if off.iter().any(|o| !o.is_finite() || o.abs() >= 1.0) {
        return None;
    }
    let half = if mid.filter.size.is_multiple_of(2) {
        0.5
    } else {
        0.0
    };
    let step = grid.step as f64;
    let x = kx as f64 * step - half + off[0] * step;
    let y = ky as f64 * step - half + off[1] * step;
    let size_inc = (above.filter.size - mid.filter.size) as f64;
    let size = mid.filter.size as f64 + off[2] * size_inc;
    let response = v + 0.5 * (dx * off[0] + dy * off[1] + ds * off[2]);
    // Laplacian sign from the trace at the sample itself.
    let base =
        (ky * grid.step - mid.filter.reach_lo) * ii.stride() + kx * grid.step - mid.filter.reach_lo;
    let (rxx, ryy, _) = mid.filter.responses(ii.data(), base);
    Some(Keypoint {
        x: x as f32,
        y: y as f32,
        scale: (1.2 * size / 9.0) as f32,
        orientation: 0.0,
        response: response as f32,
        laplacian: if rxx + ryy >= 0.0 { 1 } else { -1 },
        octave: octave as u8,
    })
}

/// Solves the 3×3 system `m·x = r` by Cramer's rule; `None` when singular.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det3 = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det3(&m);
    let scale = m.iter().flatten().fold(0.0f64, |acc, v| acc.max(v.abs()));
    if d.abs() <= 1e-12 * scale * scale * scale || d == 0.0 {
        return None;
    }
    let mut x = [0.0; 3];
    for (c, xc) in x.iter_mut().enumerate() {
        let mut mc = m;
        for row in 0..3 {
            mc[row][c] = r[row];
        }
        *xc = det3(&mc) / d;
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force box filter response for the same geometry, from pixel loops.
    fn naive_responses(px: &[f64], w: usize, x: usize, y: usize, size: usize) -> (f64, f64, f64) {
        let lobe = size / 3;
        let even = size.is_multiple_of(2);
        let lobe_h = 2 * lobe - 1 - usize::from(even);
        let sum = |x0: i64, y0: i64, x1: i64, y1: i64| {
            let mut s = 0.0;
            for yy in y0..y1 {
                for xx in x0..x1 {
                    s += px[(y as i64 + yy) as usize * w + (x as i64 + xx) as usize];
                }
            }
            s
        };
        let (l, lo, lh) = (lobe as i64, (size / 2) as i64, lobe_h as i64);
        let top = -(l - 1);
        let left = sum(-lo, top, -lo + l, top + lh);
        let middle = sum(-lo + l, top, -lo + 2 * l, top + lh);
        let right = sum(-lo + 2 * l, top, -lo + 3 * l, top + lh);
        let a = (lobe * lobe_h) as f64;
        let dxx = (left - 2.0 * middle + right) / a;
        let upper = sum(top, -lo, top + lh, -lo + l);
        let centre = sum(top, -lo + l, top + lh, -lo + 2 * l);
        let lower = sum(top, -lo + 2 * l, top + lh, -lo + 3 * l);
        let dyy = (upper - 2.0 * centre + lower) / a;
        let e = i64::from(even);
        let q = (lobe * lobe) as f64;
        let dxy = (sum(-e - l, -e - l, -e, -e) + sum(1, 1, 1 + l, 1 + l)
            - sum(1, -e - l, 1 + l, -e)
            - sum(-e - l, 1, -e, 1 + l))
            / q;
        (dxx, dyy, dxy)
    }

    #[test]
    fn box_filters_match_pixel_loops_for_odd_and_even_sizes() {
        let (w, h) = (64usize, 60usize);
        let px: Vec<u8> = (0..w * h)
            .map(|i| ((i * 7919 + i / w * 31) % 256) as u8)
            .collect();
        let pxf: Vec<f64> = px.iter().map(|&v| f64::from(v)).collect();
        let ii = IntegralImage::from_u8(&px, w, h);
        for size in [9usize, 15, 18, 30, 39] {
            let f = LayerFilter::new(size, ii.stride());
            let (x, y) = (30usize, 29usize);
            let base = (y - f.reach_lo) * ii.stride() + x - f.reach_lo;
            let got = f.responses(ii.data(), base);
            let want = naive_responses(&pxf, w, x, y, size);
            for (g, wv) in [(got.0, want.0), (got.1, want.1), (got.2, want.2)] {
                assert!((g - wv).abs() < 1e-9, "size {size}: {g} vs {wv}");
            }
        }
    }

    #[test]
    fn row_determinants_equal_the_sample_by_sample_ones_bit_for_bit() {
        let (w, h) = (200usize, 120usize);
        let px: Vec<u8> = (0..w * h)
            .map(|i| ((i * 7919 + (i / w) * 131 + i * i % 97) % 256) as u8)
            .collect();
        let ii = IntegralImage::from_u8(&px, w, h);
        for (size, step) in [
            (9usize, 1usize),
            (27, 1),
            (18, 2),
            (42, 2),
            (36, 4),
            (72, 8),
            (30, 3),
        ] {
            let f = LayerFilter::new(size, ii.stride());
            let y = 60usize;
            let n = (w - f.size) / step;
            let base = (y - f.reach_lo) * ii.stride();
            let mut fast = vec![0.0f32; n];
            det_row(&ii, &f, base, step, &mut fast);
            let mut float = vec![0.0f32; n];
            det_row_dispatch(&f, ii.data(), base, step, &mut float);
            assert!(ii.exact().is_some());
            for (k, v) in fast.iter().enumerate() {
                assert_eq!(v.to_bits(), float[k].to_bits(), "integer table, sample {k}");
                let want = f.det(ii.data(), base + k * step);
                assert_eq!(
                    v.to_bits(),
                    want.to_bits(),
                    "size {size} step {step} sample {k}"
                );
            }
        }
    }

    #[test]
    fn the_reference_loop_over_every_level_finds_the_same_features_bit_for_bit() {
        let img = crate::texture::textured_image(320, 240, 3);
        for (threshold, upright) in [(50.0, false), (200.0, true)] {
            let cfg = SurfConfig::default()
                .with_threshold(threshold)
                .with_upright(upright);
            let reference = SurfConfig {
                reference_filters: true,
                ..cfg.clone()
            };
            let fast = cfg.init().unwrap().detect_and_describe(&img).unwrap();
            let slow = reference.init().unwrap().detect_and_describe(&img).unwrap();
            assert!(fast.len() > 20, "{} features", fast.len());
            assert_eq!(fast, slow, "threshold {threshold}, upright {upright}");
        }
    }

    #[test]
    fn filter_sizes_follow_the_matlab_opencv_scheme() {
        assert_eq!(
            (0..6).map(|l| filter_size(0, l)).collect::<Vec<_>>(),
            [9, 15, 21, 27, 33, 39]
        );
        assert_eq!(filter_size(1, 0), 18);
        assert_eq!(filter_size(3, 5), 312);
    }

    #[test]
    fn cramer_solver_solves_and_rejects_singular() {
        let x = solve3(
            [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]],
            [3.0, 5.0, 5.0],
        )
        .unwrap();
        for (v, want) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((v - want).abs() < 1e-12);
        }
        assert!(
            solve3(
                [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]],
                [1.0, 1.0, 1.0]
            )
            .is_none()
        );
    }
}
