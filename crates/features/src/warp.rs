//! Float image planes, homographies, warping, blur and brightness changes: the known
//! transforms of the repeatability evaluation.

use image::GrayImage;

/// A row-major single-channel `f32` image, intensities on the 0..255 scale.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` values, row-major.
    pub data: Vec<f32>,
}

impl Plane {
    /// A plane filled with `value`.
    pub fn filled(width: usize, height: usize, value: f32) -> Self {
        Self {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// From an 8-bit grey image.
    pub fn from_gray(image: &GrayImage) -> Self {
        Self {
            width: image.width() as usize,
            height: image.height() as usize,
            data: image.as_raw().iter().map(|&v| f32::from(v)).collect(),
        }
    }

    /// To an 8-bit grey image (rounded, clamped to 0..255).
    pub fn to_gray(&self) -> GrayImage {
        let raw: Vec<u8> = self
            .data
            .iter()
            .map(|&v| (v + 0.5).clamp(0.0, 255.0) as u8)
            .collect();
        // The buffer has exactly width × height bytes, so this cannot fail.
        GrayImage::from_raw(self.width as u32, self.height as u32, raw)
            .unwrap_or_else(|| GrayImage::new(self.width as u32, self.height as u32))
    }

    /// Bilinear sample at pixel position `(x, y)` (pixel centres at integers); `None` outside
    /// `[0, width−1] × [0, height−1]`.
    pub fn sample(&self, x: f64, y: f64) -> Option<f32> {
        if !(x >= 0.0 && y >= 0.0 && x <= (self.width - 1) as f64 && y <= (self.height - 1) as f64)
        {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let at = |xx: usize, yy: usize| self.data[yy * self.width + xx];
        let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
        let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
    }
}

/// A 3×3 homography acting on pixel coordinates (origin at the top-left pixel's centre),
/// row-major: `[x', y', w']ᵀ = H·[x, y, 1]ᵀ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homography(pub [[f64; 3]; 3]);

impl Homography {
    /// The identity.
    pub fn identity() -> Self {
        Self([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    }

    /// Rotation by `angle_rad` (image axes: +x towards +y, clockwise on screen) and uniform
    /// `scale` about `centre_src`, which lands on `centre_dst`.
    pub fn similarity(
        angle_rad: f64,
        scale: f64,
        centre_src: (f64, f64),
        centre_dst: (f64, f64),
    ) -> Self {
        let (s, c) = angle_rad.sin_cos();
        let (a, b) = (scale * c, scale * s);
        let tx = centre_dst.0 - (a * centre_src.0 - b * centre_src.1);
        let ty = centre_dst.1 - (b * centre_src.0 + a * centre_src.1);
        Self([[a, -b, tx], [b, a, ty], [0.0, 0.0, 1.0]])
    }

    /// Maps a point; `None` when it goes to infinity.
    pub fn apply(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let m = &self.0;
        let w = m[2][0] * x + m[2][1] * y + m[2][2];
        if w.abs() < 1e-12 {
            return None;
        }
        Some((
            (m[0][0] * x + m[0][1] * y + m[0][2]) / w,
            (m[1][0] * x + m[1][1] * y + m[1][2]) / w,
        ))
    }

    /// The inverse; `None` when singular.
    pub fn inverse(&self) -> Option<Self> {
        let m = &self.0;
        let c = |r0: usize, r1: usize, c0: usize, c1: usize| {
            m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
        };
        let adj = [
            [c(1, 2, 1, 2), -c(0, 2, 1, 2), c(0, 1, 1, 2)],
            [-c(1, 2, 0, 2), c(0, 2, 0, 2), -c(0, 1, 0, 2)],
            [c(1, 2, 0, 1), -c(0, 2, 0, 1), c(0, 1, 0, 1)],
        ];
        let det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
        if det.abs() < 1e-15 {
            return None;
        }
        let mut out = [[0.0; 3]; 3];
        for (r, row) in out.iter_mut().enumerate() {
            for (k, v) in row.iter_mut().enumerate() {
                *v = adj[r][k] / det;
            }
        }
        Some(Self(out))
    }

    /// `self ∘ other` (apply `other` first).
    pub fn compose(&self, other: &Self) -> Self {
        let (a, b) = (&self.0, &other.0);
        let mut out = [[0.0; 3]; 3];
        for (r, row) in out.iter_mut().enumerate() {
            for (k, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|i| a[r][i] * b[i][k]).sum();
            }
        }
        Self(out)
    }
}

/// Warps `src` into a `width × height` plane: `dst(q) = src(H⁻¹·q)` with `h_dst_from_src = H`,
/// bilinear; pixels that fall outside `src` get `fill`. `None` when `H` is singular.
pub fn warp(
    src: &Plane,
    h_dst_from_src: &Homography,
    width: usize,
    height: usize,
    fill: f32,
) -> Option<Plane> {
    let inv = h_dst_from_src.inverse()?;
    let mut out = Plane::filled(width, height, fill);
    for y in 0..height {
        for x in 0..width {
            if let Some((sx, sy)) = inv.apply(x as f64, y as f64)
                && let Some(v) = src.sample(sx, sy)
            {
                out.data[y * width + x] = v;
            }
        }
    }
    Some(out)
}

/// Separable Gaussian blur with standard deviation `sigma` pixels (kernel radius ⌈3σ⌉,
/// replicated borders). `sigma ≤ 0` returns a copy.
pub fn gaussian_blur(src: &Plane, sigma: f32) -> Plane {
    if sigma <= 0.0 || src.width == 0 || src.height == 0 {
        return src.clone();
    }
    let r = (3.0 * sigma).ceil() as i64;
    let mut k: Vec<f32> = (-r..=r)
        .map(|i| (-((i * i) as f32) / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f32 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    let (w, h) = (src.width as i64, src.height as i64);
    let mut tmp = Plane::filled(src.width, src.height, 0.0);
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for (i, kv) in k.iter().enumerate() {
                let xx = (x + i as i64 - r).clamp(0, w - 1);
                acc += kv * src.data[(y * w + xx) as usize];
            }
            tmp.data[(y * w + x) as usize] = acc;
        }
    }
    let mut out = Plane::filled(src.width, src.height, 0.0);
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for (i, kv) in k.iter().enumerate() {
                let yy = (y + i as i64 - r).clamp(0, h - 1);
                acc += kv * tmp.data[(yy * w + x) as usize];
            }
            out.data[(y * w + x) as usize] = acc;
        }
    }
    out
}

/// `gain · I + offset`, clamped to 0..255.
pub fn adjust_brightness(src: &Plane, gain: f32, offset: f32) -> Plane {
    Plane {
        width: src.width,
        height: src.height,
        data: src
            .data
            .iter()
            .map(|v| (gain * v + offset).clamp(0.0, 255.0))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn similarity_inverse_and_compose_round_trip() {
        let h = Homography::similarity(0.7, 1.6, (10.0, 20.0), (100.0, 50.0));
        let (x, y) = h.apply(10.0, 20.0).unwrap();
        assert!((x - 100.0).abs() < 1e-9 && (y - 50.0).abs() < 1e-9);
        let id = h.compose(&h.inverse().unwrap());
        for r in 0..3 {
            for c in 0..3 {
                assert!((id.0[r][c] - if r == c { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        // Rotation by +90° maps +x onto +y (image axes).
        let r = Homography::similarity(std::f64::consts::FRAC_PI_2, 1.0, (0.0, 0.0), (0.0, 0.0));
        let (x, y) = r.apply(1.0, 0.0).unwrap();
        assert!(x.abs() < 1e-12 && (y - 1.0).abs() < 1e-12);
    }

    #[test]
    fn warp_by_translation_shifts_pixels_and_blur_keeps_the_mean() {
        let mut p = Plane::filled(8, 8, 0.0);
        p.data[3 * 8 + 2] = 100.0;
        let t = Homography([[1.0, 0.0, 2.0], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]]);
        let q = warp(&p, &t, 8, 8, 0.0).unwrap();
        assert_eq!(q.data[4 * 8 + 4], 100.0);
        let b = gaussian_blur(&Plane::filled(9, 9, 50.0), 1.5);
        assert!(b.data.iter().all(|v| (v - 50.0).abs() < 1e-3));
    }
}
