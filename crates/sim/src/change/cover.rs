//! What covers the wall in the test pass: residue patches and fluid pools, painted into the
//! test pass's mucosa atlas.
//!
//! - **Residue** (stool, mucus): seeded low-frequency patches over the surface coordinates,
//!   the given fraction of the wall; a mottled brown-yellow that hides the mucosa's texture
//!   and relief, with soft edges.
//! - **Fluid**: pools on the gravity-dependent side of the *changed* colon (where the wall's
//!   outward direction points along gravity), patchy along the mid-line, the given fraction of
//!   the wall; a translucent yellow film, flat and glossy (specular × 4 in its middle).
//!
//! Gloss is stored per texel in [`MucosaAtlas::gloss`] (64 = the map pass's specular).

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::TAU;

use super::config::LookChange;
use super::deform::Deformation;
use crate::appearance::{GLOSS_ONE, MucosaAtlas, PeriodicNoise};
use crate::colon::ColonModel;

/// Width of the soft edge of a patch, in units of its score.
const EDGE: f32 = 0.06;

/// The score above which `fraction` of `scores` lie (`+∞` for a zero fraction).
fn threshold(scores: &[f32], fraction: f64) -> f32 {
    if fraction <= 0.0 || scores.is_empty() {
        return f32::INFINITY;
    }
    let mut sorted = scores.to_vec();
    let k = ((1.0 - fraction.min(1.0)) * (sorted.len() - 1) as f64).round() as usize;
    let (_, t, _) = sorted.select_nth_unstable_by(k, f32::total_cmp);
    *t
}

/// Paints residue and fluid into `atlas` (the test pass's) and gives it a gloss layer.
/// `colon` is the unchanged colon (its mid-line frames give each texel's direction),
/// `deformation` the shape change (fluid settles where the *changed* wall is lowest).
pub fn cover_atlas(
    atlas: &mut MucosaAtlas,
    colon: &ColonModel,
    deformation: Option<&Deformation>,
    look: &LookChange,
    seed: u64,
) {
    let (rows, cols) = (atlas.rows, atlas.theta_texels);
    let texel_mm = atlas.texel_mm as f64;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let residue_noise = PeriodicNoise::new(rng.random());
    let pool_noise = PeriodicNoise::new(rng.random());
    let mottle_noise = PeriodicNoise::new(rng.random());
    let gravity = Vector3::from(look.gravity).normalize();
    let cl = &colon.centerline;
    // Residue patches of about 8 mm, laid out for a 20 mm radius.
    let circumference = TAU * 20.0;
    let col_mm = circumference / cols as f64;

    // Per row: the outward directions of θ = 0 and θ = π/2 in the changed colon.
    let frames: Vec<(Vector3<f64>, Vector3<f64>)> = (0..rows)
        .map(|r| {
            let s = r as f64 * texel_mm;
            let (_, n, b) = cl.frame_at(s);
            match deformation {
                Some(d) => {
                    let rot = d.rotation_at(s);
                    (rot * n, rot * b)
                }
                None => (n, b),
            }
        })
        .collect();
    let residue: Vec<f32> = (0..rows * cols)
        .into_par_iter()
        .map(|i| {
            let (r, j) = (i / cols, i % cols);
            let (s, v) = (r as f64 * texel_mm, j as f64 * col_mm);
            residue_noise.fbm(s / 8.0, v / 8.0, circumference / 8.0, 3) as f32
        })
        .collect();
    let fluid: Vec<f32> = (0..rows * cols)
        .into_par_iter()
        .map(|i| {
            let (r, j) = (i / cols, i % cols);
            let theta = j as f64 * TAU / cols as f64;
            let (n, b) = frames[r];
            let outward = n * theta.cos() + b * theta.sin();
            let pool = pool_noise.value(r as f64 * texel_mm / 60.0, 0.0, 1.0);
            (outward.dot(&gravity) + 0.6 * pool) as f32
        })
        .collect();
    let residue_at = threshold(&residue, look.residue_fraction);
    let fluid_at = threshold(&fluid, look.fluid_fraction);

    let lin = |c: [f32; 3]| c.map(|x| x.powf(2.2));
    let residue_colour = lin([0.62, 0.47, 0.22]);
    let fluid_colour = lin([0.80, 0.66, 0.38]);
    let mut gloss = vec![GLOSS_ONE; rows * cols];
    atlas
        .texels
        .par_chunks_mut(cols)
        .zip(gloss.par_chunks_mut(cols))
        .enumerate()
        .for_each(|(r, (row, gloss_row))| {
            for (j, (texel, g)) in row.iter_mut().zip(gloss_row.iter_mut()).enumerate() {
                let i = r * cols + j;
                let a_res = ((residue[i] - residue_at) / EDGE).clamp(0.0, 1.0);
                let a_fl = ((fluid[i] - fluid_at) / EDGE).clamp(0.0, 1.0);
                if a_res == 0.0 && a_fl == 0.0 {
                    continue;
                }
                let (s, v) = (r as f64 * texel_mm, j as f64 * col_mm);
                let mottle = mottle_noise.fbm(s / 1.5, v / 1.5, circumference / 1.5, 2) as f32;
                let mut rgb = [0f32; 3];
                for (k, out) in rgb.iter_mut().enumerate() {
                    let own = texel[k] as f32 / 255.0;
                    let res = (residue_colour[k] * (1.0 + 0.35 * mottle)).clamp(0.0, 1.0);
                    let x = own + (res - own) * a_res;
                    *out = x + (fluid_colour[k] - x) * 0.7 * a_fl;
                }
                let h = texel[3] as f32 / 255.0;
                let h = h + (0.5 + 0.15 * mottle - h) * a_res;
                let h = h + (0.5 - h) * a_fl;
                *texel = [
                    (rgb[0] * 255.0).round() as u8,
                    (rgb[1] * 255.0).round() as u8,
                    (rgb[2] * 255.0).round() as u8,
                    (h.clamp(0.0, 1.0) * 255.0).round() as u8,
                ];
                *g = (GLOSS_ONE as f32 + (255.0 - GLOSS_ONE as f32) * a_fl).round() as u8;
            }
        });
    atlas.gloss = Some(gloss);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_threshold_keeps_the_asked_fraction() {
        let scores: Vec<f32> = (0..1000).map(|i| ((i * 37) % 1000) as f32).collect();
        let t = threshold(&scores, 0.05);
        let above = scores.iter().filter(|s| **s > t).count();
        assert!((45..=55).contains(&above), "{above}");
        assert_eq!(threshold(&scores, 0.0), f32::INFINITY);
    }
}
