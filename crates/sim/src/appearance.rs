//! Mucosa appearance: colour, vessels and micro-relief, baked once into a texture atlas over
//! the surface coordinates `(s, θ)` of the colon.
//!
//! Appearance is homogeneous within an anatomical section and changes between sections (the
//! paper's zone classifier relies on that): each section has its own base colour, mottling and
//! vessel pattern, blended over ±10 mm at section boundaries. A few seeded stretches are nearly
//! textureless (contrast × 0.06), so feature-poor frames exist as in the paper's Fig. 6.
//!
//! The atlas is periodic in θ. Along θ the texture is laid out for a reference radius
//! ([`AppearanceConfig::reference_radius_mm`]), so its scale in mm is right for a lumen of
//! that radius and stretches mildly in wider or narrower parts.

use endoloc_data::Section;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

use crate::SimError;
use crate::colon::ColonModel;

/// Mucosa and texture parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceConfig {
    /// Seed of the texture (vessel layout, mottling, textureless stretches).
    pub seed: u64,
    /// Atlas resolution along the mid-line, mm per texel.
    pub texel_mm: f64,
    /// Atlas texels around the circumference.
    pub theta_texels: usize,
    /// Radius at which the texture has its nominal scale, mm.
    pub reference_radius_mm: f64,
    /// Number of nearly textureless stretches along the colon.
    pub textureless_stretches: usize,
    /// Length of each textureless stretch, mm.
    pub textureless_length_mm: f64,
    /// Texture contrast, multiplying each section's mottling and vessel strength. The default
    /// 2.0 gives a median of about 55 SURF keypoints (threshold 200, the paper's setting; range
    /// 9–256 over 30 frames of the `paper` preset) on 640×480 frames, and under 20 in the
    /// textureless stretches.
    pub contrast: f64,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        AppearanceConfig {
            seed: 11,
            texel_mm: 0.2,
            theta_texels: 1024,
            reference_radius_mm: 20.0,
            textureless_stretches: 4,
            textureless_length_mm: 50.0,
            contrast: 2.0,
        }
    }
}

/// The gloss of an ordinary texel in [`MucosaAtlas::gloss`] (the specular multiplier × 64).
pub const GLOSS_ONE: u8 = 64;

/// Per-section look (linear RGB albedo in `[0, 1]`).
#[derive(Debug, Clone, Copy)]
struct SectionLook {
    base: [f32; 3],
    vessel: [f32; 3],
    /// Vessel opacity at full contrast.
    vessel_strength: f32,
    /// Spatial scale of the vessel network, mm.
    vessel_scale_mm: f32,
    /// Relative amplitude of the mottling.
    mottle: f32,
    /// Spatial scale of the mottling, mm.
    mottle_scale_mm: f32,
}

/// Per-section look. Colours are written as display (sRGB) values and converted to linear
/// albedo here.
fn look_of(section: Section) -> SectionLook {
    let lin = |c: [f32; 3]| c.map(|x| x.powf(2.2));
    let l = |base, vessel, vessel_strength, vessel_scale_mm, mottle, mottle_scale_mm| SectionLook {
        base: lin(base),
        vessel: lin(vessel),
        vessel_strength,
        vessel_scale_mm,
        mottle,
        mottle_scale_mm,
    };
    match section {
        Section::AnalCanal => l([0.80, 0.50, 0.47], [0.50, 0.16, 0.18], 0.25, 6.0, 0.20, 2.5),
        Section::Rectum => l([0.84, 0.49, 0.44], [0.42, 0.09, 0.12], 0.75, 7.0, 0.12, 3.0),
        Section::Rectosigmoid => l([0.82, 0.45, 0.40], [0.45, 0.10, 0.12], 0.60, 5.0, 0.15, 2.0),
        Section::Sigmoid => l([0.80, 0.39, 0.34], [0.40, 0.08, 0.10], 0.65, 4.0, 0.22, 1.5),
        Section::Descending => l([0.83, 0.46, 0.37], [0.45, 0.12, 0.12], 0.55, 5.5, 0.18, 2.2),
        Section::SplenicFlexure => l([0.76, 0.43, 0.44], [0.35, 0.12, 0.22], 0.55, 5.0, 0.20, 2.0),
        Section::Transverse => l([0.87, 0.56, 0.42], [0.50, 0.15, 0.12], 0.45, 6.5, 0.15, 3.0),
        Section::HepaticFlexure => l([0.78, 0.48, 0.45], [0.33, 0.13, 0.24], 0.55, 5.0, 0.22, 2.0),
        Section::Ascending => l([0.86, 0.59, 0.40], [0.50, 0.18, 0.12], 0.45, 4.5, 0.25, 1.6),
        Section::Caecum => l([0.87, 0.62, 0.43], [0.48, 0.17, 0.13], 0.40, 4.0, 0.28, 1.4),
    }
}

/// The baked atlas: linear albedo RGB and a micro-relief height, per texel.
///
/// Layout: row-major over `s` (rows) and `θ` (columns), `theta_texels` columns.
#[derive(Debug, Clone)]
pub struct MucosaAtlas {
    /// mm per texel along the mid-line.
    pub texel_mm: f32,
    /// Texels around the circumference.
    pub theta_texels: usize,
    /// Number of rows (along `s`).
    pub rows: usize,
    /// `[r, g, b, height]`, each 0..=255; albedo is linear (`value / 255`).
    pub texels: Vec<[u8; 4]>,
    /// Texture contrast multiplier along the colon, one value per row (1 = normal,
    /// ≈0.06 in a textureless stretch).
    pub contrast: Vec<f32>,
    /// Specular multiplier per texel × [`GLOSS_ONE`] (64 = 1×), where something glossy
    /// covers the wall (fluid in a changed colon); `None`: 1 everywhere.
    pub gloss: Option<Vec<u8>>,
}

impl MucosaAtlas {
    /// Bakes the atlas for a colon.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] for non-positive resolutions.
    pub fn bake(colon: &ColonModel, cfg: &AppearanceConfig) -> Result<Self, SimError> {
        if !(cfg.texel_mm.is_finite() && cfg.texel_mm > 0.0) || cfg.theta_texels < 16 {
            return Err(SimError::InvalidConfig(format!(
                "appearance: texel_mm must be positive and theta_texels ≥ 16, got {} and {}",
                cfg.texel_mm, cfg.theta_texels
            )));
        }
        if !(cfg.contrast.is_finite() && cfg.contrast >= 0.0) {
            return Err(SimError::InvalidConfig(format!(
                "appearance: contrast must be ≥ 0, got {}",
                cfg.contrast
            )));
        }
        let length = colon.centerline.length_mm();
        let rows = (length / cfg.texel_mm).ceil() as usize + 2;
        let cols = cfg.theta_texels;
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        let noise = PeriodicNoise::new(rng.random());
        let vessel_noise = PeriodicNoise::new(rng.random());
        let relief_noise = PeriodicNoise::new(rng.random());

        // Section look per row, blended over ±10 mm.
        let looks: Vec<SectionLook> = (0..rows)
            .map(|r| blended_look(colon, r as f64 * cfg.texel_mm, 10.0))
            .collect();
        let contrast = textureless_profile(colon, cfg, rows, &mut rng);
        let circumference = TAU * cfg.reference_radius_mm;
        let col_mm = circumference / cols as f64;

        let mut texels = vec![[0u8; 4]; rows * cols];
        texels
            .par_chunks_mut(cols)
            .enumerate()
            .for_each(|(r, row)| {
                let look = &looks[r];
                let c = contrast[r] * cfg.contrast as f32;
                let s = r as f64 * cfg.texel_mm;
                for (j, texel) in row.iter_mut().enumerate() {
                    let v = j as f64 * col_mm;
                    // Mottling: 3 octaves of periodic value noise.
                    let ms = look.mottle_scale_mm as f64;
                    let mottle = noise.fbm(s / ms, v / ms, circumference / ms, 3) as f32;
                    // Vessels: thin ridges of |noise|, two scales for branches.
                    let vs = look.vessel_scale_mm as f64;
                    let ridge = |k: f64, seed_off: f64| {
                        let n = vessel_noise.value(
                            s / (vs * k) + seed_off,
                            v / (vs * k),
                            circumference / (vs * k),
                        );
                        (1.0 - (n.abs() * 14.0).min(1.0)).powi(2)
                    };
                    // Vessels show in patches (a low-frequency mask), as submucosal vessels do.
                    let mask = (noise.value(
                        s / (vs * 3.0) + 71.3,
                        v / (vs * 3.0),
                        circumference / (vs * 3.0),
                    ) * 1.6
                        + 0.3)
                        .clamp(0.0, 1.0);
                    let vessel = (mask * ridge(1.0, 0.0).max(0.6 * ridge(0.45, 17.0))) as f32;
                    let a = (look.vessel_strength * vessel * c).min(1.0);
                    let m = 1.0 + look.mottle * c * mottle;
                    let mut rgb = [0f32; 3];
                    for (k, out) in rgb.iter_mut().enumerate() {
                        let base = (look.base[k] * m).clamp(0.0, 1.0);
                        *out = base * (1.0 - a) + look.vessel[k] * a;
                    }
                    let relief = relief_noise.fbm(s / 1.2, v / 1.2, circumference / 1.2, 2);
                    let height = 0.5 + 0.35 * relief * c.max(0.3) as f64 + 0.15 * vessel as f64;
                    *texel = [
                        (rgb[0] * 255.0).round() as u8,
                        (rgb[1] * 255.0).round() as u8,
                        (rgb[2] * 255.0).round() as u8,
                        (height.clamp(0.0, 1.0) * 255.0).round() as u8,
                    ];
                }
            });
        Ok(MucosaAtlas {
            texel_mm: cfg.texel_mm as f32,
            theta_texels: cols,
            rows,
            texels,
            contrast,
            gloss: None,
        })
    }

    /// Bilinear lookup of albedo (linear, 0..1) and height (0..1) at arc length `s` (mm) and
    /// angle `theta` (rad, any value: wrapped), with the gradient of the height `(∂h/∂s per mm,
    /// ∂h/∂θ per radian)` from the same four texels (the bilinear patch's derivatives).
    #[inline]
    pub fn sample_with_gradient(&self, s: f32, theta: f32) -> ([f32; 4], f32, f32) {
        let (i00, i01, i10, i11, fu, fv) = self.corners(s, theta);
        let (t00, t01, t10, t11) = (
            self.texels[i00],
            self.texels[i01],
            self.texels[i10],
            self.texels[i11],
        );
        let mut out = [0f32; 4];
        let mut rows = [0f32; 2];
        for k in 0..4 {
            let a = t00[k] as f32 + (t01[k] as f32 - t00[k] as f32) * fv;
            let b = t10[k] as f32 + (t11[k] as f32 - t10[k] as f32) * fv;
            out[k] = (a + (b - a) * fu) * (1.0 / 255.0);
            if k == 3 {
                rows = [a, b];
            }
        }
        let dh_du = (rows[1] - rows[0]) * (1.0 / 255.0);
        let c0 = t01[3] as f32 - t00[3] as f32;
        let c1 = t11[3] as f32 - t10[3] as f32;
        let dh_dv = (c0 + (c1 - c0) * fu) * (1.0 / 255.0);
        let rad_per_texel = std::f32::consts::TAU / self.theta_texels as f32;
        (out, dh_du / self.texel_mm, dh_dv / rad_per_texel)
    }

    /// Specular multiplier at `(s, θ)` (nearest texel; 1 without a gloss layer).
    #[inline]
    pub fn gloss_at(&self, s: f32, theta: f32) -> f32 {
        match &self.gloss {
            Some(g) => {
                let (i00, _, _, _, _, _) = self.corners(s, theta);
                g[i00] as f32 * (1.0 / GLOSS_ONE as f32)
            }
            None => 1.0,
        }
    }

    /// Texel indices of the four bilinear corners and the fractional offsets.
    #[inline]
    fn corners(&self, s: f32, theta: f32) -> (usize, usize, usize, usize, f32, f32) {
        let u = (s / self.texel_mm).clamp(0.0, (self.rows - 2) as f32);
        let r0 = u as usize; // u ≥ 0: truncation is floor
        let fu = u - r0 as f32;
        let n = self.theta_texels;
        let v = theta * (n as f32 / std::f32::consts::TAU);
        // Shift into positive range before truncating (θ stays within a few turns of 0).
        let v = v + (n as f32) * 8.0;
        let vi = v.max(0.0) as usize;
        let fv = v - vi as f32;
        let c0 = vi % n;
        let c1 = if c0 + 1 == n { 0 } else { c0 + 1 };
        let row0 = r0 * n;
        let row1 = row0 + n;
        (row0 + c0, row0 + c1, row1 + c0, row1 + c1, fu, fv)
    }

    /// Memory held by the atlas, bytes.
    pub fn bytes(&self) -> usize {
        self.texels.len() * 4 + self.contrast.len() * 4 + self.gloss.as_ref().map_or(0, Vec::len)
    }
}

fn blended_look(colon: &ColonModel, s: f64, half_width_mm: f64) -> SectionLook {
    let samples = 9;
    let mut acc = SectionLook {
        base: [0.0; 3],
        vessel: [0.0; 3],
        vessel_strength: 0.0,
        vessel_scale_mm: 0.0,
        mottle: 0.0,
        mottle_scale_mm: 0.0,
    };
    for k in 0..samples {
        let t = k as f64 / (samples - 1) as f64 * 2.0 - 1.0;
        let l = look_of(colon.section_at(s + t * half_width_mm));
        let w = 1.0 / samples as f32;
        for c in 0..3 {
            acc.base[c] += l.base[c] * w;
            acc.vessel[c] += l.vessel[c] * w;
        }
        acc.vessel_strength += l.vessel_strength * w;
        acc.vessel_scale_mm += l.vessel_scale_mm * w;
        acc.mottle += l.mottle * w;
        acc.mottle_scale_mm += l.mottle_scale_mm * w;
    }
    acc
}

/// Contrast along the colon: 1 except in the textureless stretches (0.06), with 8 mm ramps.
/// Stretches are placed at seeded positions in the haustrated sections, not overlapping.
fn textureless_profile(
    colon: &ColonModel,
    cfg: &AppearanceConfig,
    rows: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<f32> {
    let (lo, hi) = colon.pass_range_mm;
    let len = cfg.textureless_length_mm.max(0.0);
    let mut centres: Vec<f64> = Vec::new();
    let candidates_ok = hi - lo > 4.0 * len;
    for _ in 0..cfg.textureless_stretches {
        if !candidates_ok {
            break;
        }
        for _attempt in 0..50 {
            let c = rng.random_range(lo + len..hi - len);
            let sec = colon.section_at(c);
            let haustrated = !matches!(sec, Section::AnalCanal | Section::Rectum);
            if haustrated && centres.iter().all(|o| (o - c).abs() > 3.0 * len) {
                centres.push(c);
                break;
            }
        }
    }
    (0..rows)
        .map(|r| {
            let s = r as f64 * cfg.texel_mm;
            let mut c: f64 = 1.0;
            for centre in &centres {
                let d = (s - centre).abs() - len / 2.0; // < 0 inside
                let ramp = (d / 8.0).clamp(0.0, 1.0);
                c = c.min(0.06 + 0.94 * ramp);
            }
            c as f32
        })
        .collect()
}

/// Value noise on a lattice that is periodic along its second coordinate.
pub(crate) struct PeriodicNoise {
    seed: u64,
}

impl PeriodicNoise {
    pub(crate) fn new(seed: u64) -> Self {
        PeriodicNoise { seed }
    }

    fn lattice(&self, i: i64, j: i64) -> f64 {
        let mut h = self.seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        h ^= (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        h = splitmix64(h);
        (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// Smooth noise in `[-1, 1]` at `(x, y)`, periodic in `y` with period `period_y` (rounded to
    /// a whole number of lattice cells).
    pub(crate) fn value(&self, x: f64, y: f64, period_y: f64) -> f64 {
        let py = period_y.round().max(1.0) as i64;
        let (xf, yf) = (x.floor(), y.floor());
        let (fx, fy) = (x - xf, y - yf);
        let (i, j) = (xf as i64, yf as i64);
        let wrap = |j: i64| j.rem_euclid(py);
        let sx = fx * fx * (3.0 - 2.0 * fx);
        let sy = fy * fy * (3.0 - 2.0 * fy);
        let a = self.lattice(i, wrap(j));
        let b = self.lattice(i + 1, wrap(j));
        let c = self.lattice(i, wrap(j + 1));
        let d = self.lattice(i + 1, wrap(j + 1));
        let top = a + (b - a) * sx;
        let bottom = c + (d - c) * sx;
        top + (bottom - top) * sy
    }

    pub(crate) fn fbm(&self, x: f64, y: f64, period_y: f64, octaves: u32) -> f64 {
        let mut sum = 0.0;
        let mut amp = 1.0;
        let mut norm = 0.0;
        let mut f = 1.0;
        for o in 0..octaves {
            sum += amp * self.value(x * f + o as f64 * 31.7, y * f, period_y * f);
            norm += amp;
            amp *= 0.5;
            f *= 2.0;
        }
        sum / norm
    }
}

/// SplitMix64 finaliser: a fast, well-mixed 64-bit hash.
#[inline]
pub(crate) fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
