//! Finding the valid area of a recording from its frames: black borders and circular field
//! stops.
//!
//! Outside the valid area every frame is (nearly) black; inside it, each pixel is lit in at
//! least some frames. The detector:
//!
//! 1. takes the per-pixel maximum over the frames, of each frame and of a 3 × 3 box-smoothed
//!    copy (sensor noise does not light a border pixel, a dark lumen in some frames does not
//!    darken the wall), and calls a pixel lit when both exceed the threshold;
//! 2. thresholds it ([`MaskDetectConfig::threshold`]), opens it — erodes, then dilates, by a
//!    square of half-width [`MaskDetectConfig::open_px`] — so that thin bright strokes in the
//!    border (a scope's overlay text, a time stamp, a frame counter) are cut off even where they
//!    touch the image, keeps the largest 4-connected region and fills its holes (a lumen that
//!    stays dark in every frame is still inside);
//! 3. fits two shapes to that region — its bounding rectangle, and a circle (algebraic fit to
//!    the region's boundary away from the image edge) cut by that rectangle — and keeps the
//!    shape that agrees best with the region when it agrees to an IoU of at least
//!    [`MaskDetectConfig::min_shape_iou`] (a clean edge for the usual optics), the region
//!    itself otherwise;
//! 4. shrinks the result by [`MaskDetectConfig::margin_px`] so the dim ring at the field
//!    stop's edge is left out.

use image::GrayImage;
use serde::{Deserialize, Serialize};

use crate::FeatureError;
use crate::mask::Mask;

/// Settings of [`detect_mask`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct MaskDetectConfig {
    /// A pixel whose smoothed maximum over the frames is at or below this (0–255) is black.
    #[cfg_attr(
        feature = "cli",
        arg(long, default_value_t = MaskDetectConfig::default().threshold)
    )]
    pub threshold: u8,
    /// Shrink the valid area by this many pixels (the dim ring at a field stop's edge).
    #[cfg_attr(
        feature = "cli",
        arg(long, default_value_t = MaskDetectConfig::default().margin_px)
    )]
    pub margin_px: f32,
    /// A fitted shape (circle or rectangle) replaces the thresholded region when their IoU
    /// is at least this.
    #[cfg_attr(
        feature = "cli",
        arg(long, default_value_t = MaskDetectConfig::default().min_shape_iou)
    )]
    pub min_shape_iou: f64,
    /// Lit strokes narrower than `2 × open_px + 1` pixels (overlay text, a time stamp in the
    /// border) never count as valid: the lit area is opened by a square of this half-width
    /// before the region is chosen. 0 = off.
    #[cfg_attr(
        feature = "cli",
        arg(long, default_value_t = MaskDetectConfig::default().open_px)
    )]
    pub open_px: u32,
}

impl Default for MaskDetectConfig {
    fn default() -> Self {
        MaskDetectConfig {
            threshold: 20,
            margin_px: 1.0,
            min_shape_iou: 0.97,
            open_px: 3,
        }
    }
}

/// The shape a detected mask was given.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum MaskShape {
    /// A rectangle (a black border): pixels `x0..=x1`, `y0..=y1`.
    Rectangle {
        /// First valid column.
        x0: u32,
        /// First valid row.
        y0: u32,
        /// Last valid column.
        x1: u32,
        /// Last valid row.
        y1: u32,
    },
    /// A circular field stop (centre and radius in pixels), cut by the valid rectangle.
    Circle {
        /// Centre column, pixels.
        cx: f64,
        /// Centre row, pixels.
        cy: f64,
        /// Radius, pixels.
        radius: f64,
    },
    /// Neither shape fits: the thresholded region itself.
    Region,
}

/// A detected mask and how it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectedMask {
    /// The valid area.
    pub mask: Mask,
    /// The shape it was given.
    pub shape: MaskShape,
    /// IoU of that shape with the thresholded region (1 for [`MaskShape::Region`]).
    pub shape_iou: f64,
}

/// Detects the valid area of frames of one camera (see the module docs).
///
/// # Errors
/// [`FeatureError::InvalidConfig`] without frames or with frames of different sizes;
/// [`FeatureError::EmptyMask`] when every pixel is black in every frame.
pub fn detect_mask(
    frames: &[GrayImage],
    cfg: &MaskDetectConfig,
) -> Result<DetectedMask, FeatureError> {
    let Some(first) = frames.first() else {
        return Err(FeatureError::InvalidConfig {
            field: "frames",
            reason: "is empty; expected at least one frame".into(),
        });
    };
    let (w, h) = (first.width() as usize, first.height() as usize);
    let mut max = vec![0u16; w * h];
    let mut raw_max = vec![0u8; w * h];
    for (k, f) in frames.iter().enumerate() {
        if (f.width() as usize, f.height() as usize) != (w, h) {
            return Err(FeatureError::InvalidConfig {
                field: "frames",
                reason: format!(
                    "frame {k} is {}×{} but frame 0 is {w}×{h}; expected one camera",
                    f.width(),
                    f.height()
                ),
            });
        }
        let smooth = box3(f.as_raw(), w, h);
        for (m, s) in max.iter_mut().zip(smooth) {
            *m = (*m).max(s);
        }
        for (m, &v) in raw_max.iter_mut().zip(f.as_raw()) {
            *m = (*m).max(v);
        }
    }
    // Lit both smoothed (not a lone noisy pixel) and itself (the smoothing does not spread the
    // region by a pixel).
    let lit: Vec<bool> = max
        .iter()
        .zip(&raw_max)
        .map(|(&s, &v)| s > cfg.threshold as u16 && v > cfg.threshold)
        .collect();
    let lit = open(&lit, w, h, cfg.open_px as usize);
    let region = fill_holes(&largest_component(&lit, w, h), w, h);
    if !region.iter().any(|&v| v) {
        return Err(FeatureError::EmptyMask {
            width: w,
            height: h,
        });
    }
    let (x0, y0, x1, y1) = bounding_box(&region, w, h);
    let rect: Vec<bool> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            x >= x0 && x <= x1 && y >= y0 && y <= y1
        })
        .collect();
    let mut best = (
        MaskShape::Rectangle {
            x0: x0 as u32,
            y0: y0 as u32,
            x1: x1 as u32,
            y1: y1 as u32,
        },
        iou(&rect, &region),
        rect.clone(),
    );
    if let Some((cx, cy, radius)) = fit_circle(&region, w, h) {
        let r2 = radius * radius;
        let circle: Vec<bool> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                rect[i] && (x - cx).powi(2) + (y - cy).powi(2) <= r2
            })
            .collect();
        let score = iou(&circle, &region);
        if score > best.1 {
            best = (MaskShape::Circle { cx, cy, radius }, score, circle);
        }
    }
    let (shape, shape_iou, valid) = if best.1 >= cfg.min_shape_iou {
        best
    } else {
        (MaskShape::Region, 1.0, region)
    };
    let full = Mask::from_valid(w, h, &valid)?;
    let mask = if cfg.margin_px > 0.0 {
        let shrunk: Vec<bool> = (0..w * h)
            .map(|i| full.clearance_at((i % w) as i64, (i / w) as i64) > cfg.margin_px)
            .collect();
        Mask::from_valid(w, h, &shrunk)?
    } else {
        full
    };
    Ok(DetectedMask {
        mask,
        shape,
        shape_iou,
    })
}

/// 3 × 3 box filter (edges replicated), same scale as the input.
fn box3(px: &[u8], w: usize, h: usize) -> Vec<u16> {
    let at = |x: isize, y: isize| -> u16 {
        let x = x.clamp(0, w as isize - 1) as usize;
        let y = y.clamp(0, h as isize - 1) as usize;
        px[y * w + x] as u16
    };
    let mut out = vec![0u16; w * h];
    for y in 0..h as isize {
        for x in 0..w as isize {
            let mut s = 0u16;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    s += at(x + dx, y + dy);
                }
            }
            out[y as usize * w + x as usize] = (s + 4) / 9;
        }
    }
    out
}

/// Pixels of `set` in a box of half-width `r` around each pixel (the box clipped to the
/// image), from an integral image of `set`: `(count, box area)` per pixel.
fn box_counts(set: &[bool], w: usize, h: usize, r: usize) -> Vec<(u32, u32)> {
    let mut ii = vec![0u32; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0u32;
        for x in 0..w {
            row += u32::from(set[y * w + x]);
            ii[(y + 1) * (w + 1) + x + 1] = ii[y * (w + 1) + x + 1] + row;
        }
    }
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
            let (x1, y1) = ((x + r + 1).min(w), (y + r + 1).min(h));
            let at = |xx: usize, yy: usize| ii[yy * (w + 1) + xx];
            let count = at(x1, y1) + at(x0, y0) - at(x0, y1) - at(x1, y0);
            (count, ((x1 - x0) * (y1 - y0)) as u32)
        })
        .collect()
}

/// Morphological opening of `set` by a square of half-width `r` (erosion, then dilation),
/// kept inside `set`; the image edge does not erode (the box is clipped to the image).
fn open(set: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    if r == 0 {
        return set.to_vec();
    }
    let eroded: Vec<bool> = box_counts(set, w, h, r)
        .into_iter()
        .map(|(n, area)| n == area)
        .collect();
    box_counts(&eroded, w, h, r)
        .into_iter()
        .zip(set)
        .map(|((n, _), &v)| v && n > 0)
        .collect()
}

/// Labels of the 4-connected components of `set` (usize::MAX outside it) and their sizes.
fn components(set: &[bool], w: usize, h: usize) -> (Vec<usize>, Vec<usize>) {
    let mut label = vec![usize::MAX; w * h];
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !set[start] || label[start] != usize::MAX {
            continue;
        }
        let id = sizes.len();
        let mut n = 0;
        label[start] = id;
        stack.push(start);
        while let Some(i) = stack.pop() {
            n += 1;
            let (x, y) = (i % w, i / w);
            let mut visit = |j: usize| {
                if set[j] && label[j] == usize::MAX {
                    label[j] = id;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        sizes.push(n);
    }
    (label, sizes)
}

fn largest_component(set: &[bool], w: usize, h: usize) -> Vec<bool> {
    let (label, sizes) = components(set, w, h);
    let Some(big) = (0..sizes.len()).max_by_key(|&k| sizes[k]) else {
        return vec![false; w * h];
    };
    label.iter().map(|&l| l == big).collect()
}

/// `set` with every hole (a component of its complement that does not touch the image edge)
/// filled.
fn fill_holes(set: &[bool], w: usize, h: usize) -> Vec<bool> {
    let outside: Vec<bool> = set.iter().map(|&v| !v).collect();
    let (label, sizes) = components(&outside, w, h);
    let mut touches = vec![false; sizes.len()];
    for y in 0..h {
        for x in 0..w {
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                let l = label[y * w + x];
                if l != usize::MAX {
                    touches[l] = true;
                }
            }
        }
    }
    set.iter()
        .zip(&label)
        .map(|(&v, &l)| v || (l != usize::MAX && !touches[l]))
        .collect()
}

fn bounding_box(set: &[bool], w: usize, h: usize) -> (usize, usize, usize, usize) {
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for (i, _) in set.iter().enumerate().filter(|(_, v)| **v) {
        let (x, y) = (i % w, i / w);
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    (x0, y0, x1, y1)
}

/// Algebraic (Kåsa) circle fit to the region's boundary pixels that are not on the edge of
/// the region's bounding box: `(cx, cy, r)`, or `None` with too few of them.
fn fit_circle(set: &[bool], w: usize, h: usize) -> Option<(f64, f64, f64)> {
    let (x0, y0, x1, y1) = bounding_box(set, w, h);
    let mut pts = Vec::new();
    for y in y0 + 1..y1 {
        for x in x0 + 1..x1 {
            let i = y * w + x;
            if set[i] && (!set[i - 1] || !set[i + 1] || !set[i - w] || !set[i + w]) {
                pts.push((x as f64, y as f64));
            }
        }
    }
    if pts.len() < 20 {
        return None;
    }
    // Least squares on x² + y² + D x + E y + F = 0.
    let mut a = nalgebra_lite::Sym3::default();
    for &(x, y) in &pts {
        a.add([x, y, 1.0], -(x * x + y * y));
    }
    let [d, e, f] = a.solve()?;
    let (cx, cy) = (-d / 2.0, -e / 2.0);
    let r2 = cx * cx + cy * cy - f;
    (r2 > 0.0).then(|| (cx, cy, r2.sqrt()))
}

fn iou(a: &[bool], b: &[bool]) -> f64 {
    let (mut i, mut u) = (0usize, 0usize);
    for (&x, &y) in a.iter().zip(b) {
        i += usize::from(x && y);
        u += usize::from(x || y);
    }
    if u == 0 { 1.0 } else { i as f64 / u as f64 }
}

/// The 3 × 3 normal equations of the circle fit, without a linear-algebra dependency.
mod nalgebra_lite {
    /// Accumulates `Σ v vᵀ` and `Σ v b` for rows `v` (3 values) and targets `b`.
    #[derive(Default)]
    pub(super) struct Sym3 {
        m: [[f64; 3]; 3],
        r: [f64; 3],
    }

    impl Sym3 {
        pub(super) fn add(&mut self, v: [f64; 3], b: f64) {
            for i in 0..3 {
                for j in 0..3 {
                    self.m[i][j] += v[i] * v[j];
                }
                self.r[i] += v[i] * b;
            }
        }

        /// Solves by Cramer's rule; `None` when singular.
        pub(super) fn solve(&self) -> Option<[f64; 3]> {
            let det = |m: &[[f64; 3]; 3]| {
                m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                    - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                    + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
            };
            let d = det(&self.m);
            if d.abs() < 1e-12 {
                return None;
            }
            let mut out = [0.0; 3];
            for (k, o) in out.iter_mut().enumerate() {
                let mut m = self.m;
                for (row, r) in m.iter_mut().zip(self.r) {
                    row[k] = r;
                }
                *o = det(&m) / d;
            }
            Some(out)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames of a textured scene seen through a circular stop of radius `r` at `(cx, cy)`,
    /// with a dark lumen in the middle that stays dark in every frame, and sensor noise in the
    /// black.
    fn frames(w: u32, h: u32, cx: f64, cy: f64, r: f64) -> (Vec<GrayImage>, Vec<bool>) {
        let inside = |x: u32, y: u32| (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) <= r * r;
        let truth = (0..w * h).map(|i| inside(i % w, i / w)).collect();
        let frames = (0..6u32)
            .map(|k| {
                GrayImage::from_fn(w, h, |x, y| {
                    let noise = ((x * 7 + y * 13 + k * 31) % 5) as u8;
                    if !inside(x, y) {
                        return image::Luma([noise]);
                    }
                    let lumen = (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) < 400.0;
                    let v = if lumen {
                        4
                    } else {
                        60 + ((x / 4 + y / 4 + k) % 7) as u8 * 20
                    };
                    image::Luma([v])
                })
            })
            .collect();
        (frames, truth)
    }

    #[test]
    fn a_field_stop_cut_by_the_image_edges_is_found_as_a_circle() {
        let (w, h) = (200u32, 160u32);
        let (f, truth) = frames(w, h, 101.0, 79.5, 95.0);
        let got = detect_mask(&f, &MaskDetectConfig::default()).unwrap();
        let MaskShape::Circle { cx, cy, radius } = got.shape else {
            panic!("{:?}", got.shape);
        };
        assert!(
            (cx - 101.0).abs() < 1.0 && (cy - 79.5).abs() < 1.0,
            "{cx} {cy}"
        );
        assert!((radius - 95.0).abs() < 1.5, "{radius}");
        let truth = Mask::from_valid(w as usize, h as usize, &truth).unwrap();
        let iou = got.mask.iou(&truth).unwrap();
        assert!(iou >= 0.98, "IoU {iou}");
    }

    /// A scope's overlay in the black border: a line of "characters" (1–2 px strokes) that
    /// changes from frame to frame, drawn at `(x, y)`.
    fn overlay(img: &mut GrayImage, x: u32, y: u32, frame: u32) {
        for c in 0..8u32 {
            let glyph = (c * 37 + frame * 11) % 13;
            for k in 0..7u32 {
                let (px, py) = (x + c * 6 + (k * glyph) % 4, y + k);
                if px < img.width() && py < img.height() {
                    img.put_pixel(px, py, image::Luma([255]));
                    if glyph.is_multiple_of(2) && px + 1 < img.width() {
                        img.put_pixel(px + 1, py, image::Luma([255]));
                    }
                }
            }
        }
    }

    #[test]
    fn overlay_text_in_the_border_never_counts_as_valid() {
        // A field stop with a time stamp in a corner and a counter touching its edge.
        let (w, h) = (200u32, 160u32);
        let (mut f, truth) = frames(w, h, 101.0, 79.5, 70.0);
        for (k, img) in f.iter_mut().enumerate() {
            overlay(img, 2, 2, k as u32);
            overlay(img, 80, 150, k as u32);
        }
        let exact = MaskDetectConfig {
            margin_px: 0.0,
            ..MaskDetectConfig::default()
        };
        let got = detect_mask(&f, &exact).unwrap();
        let truth = Mask::from_valid(w as usize, h as usize, &truth).unwrap();
        let iou = got.mask.iou(&truth).unwrap();
        assert!(
            matches!(got.shape, MaskShape::Circle { .. }) && iou >= 0.98,
            "{:?}, IoU {iou}",
            got.shape
        );
        for (k, img) in f.iter().enumerate() {
            for (x, y, p) in img.enumerate_pixels() {
                if p.0[0] == 255 {
                    assert!(
                        !got.mask.is_valid(i64::from(x), i64::from(y)),
                        "frame {k}: overlay pixel ({x}, {y}) counted valid"
                    );
                }
            }
        }
        // A black border with a status line right under the image, touching it.
        let (w, h) = (120u32, 90u32);
        let f: Vec<GrayImage> = (0..4u32)
            .map(|k| {
                let mut img = GrayImage::from_fn(w, h, |x, y| {
                    let inside = (10..=109).contains(&x) && (5..=74).contains(&y);
                    image::Luma([if inside {
                        50 + ((x + y + k) % 9) as u8 * 10
                    } else {
                        2
                    }])
                });
                overlay(&mut img, 12, 75, k);
                img
            })
            .collect();
        let cfg = MaskDetectConfig {
            margin_px: 0.0,
            ..MaskDetectConfig::default()
        };
        let got = detect_mask(&f, &cfg).unwrap();
        assert_eq!(
            got.shape,
            MaskShape::Rectangle {
                x0: 10,
                y0: 5,
                x1: 109,
                y1: 74
            }
        );
        // Without the opening the status line joins the image.
        let plain = detect_mask(&f, &MaskDetectConfig { open_px: 0, ..cfg }).unwrap();
        assert_ne!(plain.shape, got.shape);
    }

    #[test]
    fn a_black_border_is_found_as_a_rectangle_and_an_all_black_recording_is_refused() {
        let (w, h) = (120u32, 90u32);
        let f: Vec<GrayImage> = (0..3)
            .map(|k| {
                GrayImage::from_fn(w, h, |x, y| {
                    let inside = (10..=109).contains(&x) && (5..=84).contains(&y);
                    image::Luma([if inside {
                        50 + ((x + y + k) % 9) as u8 * 10
                    } else {
                        2
                    }])
                })
            })
            .collect();
        let cfg = MaskDetectConfig {
            margin_px: 0.0,
            ..MaskDetectConfig::default()
        };
        let got = detect_mask(&f, &cfg).unwrap();
        assert_eq!(
            got.shape,
            MaskShape::Rectangle {
                x0: 10,
                y0: 5,
                x1: 109,
                y1: 84
            }
        );
        let black = vec![GrayImage::new(w, h)];
        assert!(matches!(
            detect_mask(&black, &cfg),
            Err(FeatureError::EmptyMask { .. })
        ));
        assert!(detect_mask(&[], &cfg).is_err());
    }
}
