//! Pieces shared by the two training loops: held-out frames, augmented query images,
//! batches as tensors.

use super::config::RegressConfig;
use crate::augment::augment;
use crate::preprocess::{InputSize, standardize};
use crate::train::ImageCache;
use crate::view::{ViewIntrinsics, rotate_view, view_turn};
use burn::tensor::{Device, Tensor, TensorData};
use nalgebra::UnitQuaternion;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Whether frame `f` is held out (every `every`-th frame, offset by `every / 2`; 0 or 1: none).
pub(crate) fn is_held(f: usize, every: usize) -> bool {
    every > 1 && f % every == every / 2
}

/// (training frames, held-out frames) of `n` frames.
pub(crate) fn split_holdout(n: usize, every: usize) -> (Vec<usize>, Vec<usize>) {
    (0..n).partition(|&f| !is_held(f, every))
}

/// A query image of cached frame `f`: photometric augmentation and a view turn drawn from
/// `seed` (roll; pitch and yaw only with intrinsics `k`), standardised. Returns the pixels and
/// the turn `ΔR` (identity without view augmentation): the label's rotation is `R_wc · ΔR`.
pub(crate) fn query_input(
    cache: &ImageCache,
    f: usize,
    cfg: &RegressConfig,
    k: Option<&ViewIntrinsics>,
    seed: u64,
) -> (Vec<f32>, UnitQuaternion<f64>) {
    let (w, h) = (cache.size.width as usize, cache.size.height as usize);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut draw = |limit_deg: f32| -> f64 {
        if limit_deg > 0.0 {
            rng.random_range(-limit_deg..=limit_deg).to_radians() as f64
        } else {
            0.0
        }
    };
    let roll = draw(cfg.roll_deg);
    let (pitch, yaw) = if k.is_some() {
        (draw(cfg.tilt_deg), draw(cfg.tilt_deg))
    } else {
        (0.0, 0.0)
    };
    let mut v = augment(cache.image(f), w, h, None, &cfg.photometric(), &mut rng);
    let turn = view_turn(roll, pitch, yaw);
    if roll != 0.0 || pitch != 0.0 || yaw != 0.0 {
        let centred = ViewIntrinsics::centred(w, h, w as f64 / 2.0);
        v = rotate_view(&v, w, h, k.unwrap_or(&centred), &turn.to_rotation_matrix());
    }
    standardize(&mut v);
    (v, turn)
}

/// Queries for `frames` in parallel, each from its own seed drawn sequentially from `rng`.
pub(crate) fn query_batch(
    cache: &ImageCache,
    frames: &[usize],
    cfg: &RegressConfig,
    k: Option<&ViewIntrinsics>,
    rng: &mut ChaCha8Rng,
) -> (Vec<f32>, Vec<UnitQuaternion<f64>>) {
    let seeds: Vec<u64> = frames.iter().map(|_| rng.random()).collect();
    let parts: Vec<(Vec<f32>, UnitQuaternion<f64>)> = frames
        .par_iter()
        .zip(seeds.par_iter())
        .map(|(&f, &s)| query_input(cache, f, cfg, k, s))
        .collect();
    let mut px = Vec::with_capacity(frames.len() * cache.size.pixels());
    let mut rolls = Vec::with_capacity(frames.len());
    for (p, r) in parts {
        px.extend(p);
        rolls.push(r);
    }
    (px, rolls)
}

/// Standardised, un-augmented cached frames, concatenated.
pub(crate) fn clean_batch(cache: &ImageCache, frames: &[usize]) -> Vec<f32> {
    frames
        .par_iter()
        .flat_map_iter(|&f| {
            let mut v = cache.image(f).to_vec();
            standardize(&mut v);
            v
        })
        .collect()
}

/// `[n, 1, h, w]` tensor of `n` standardised images.
pub(crate) fn images_tensor(px: Vec<f32>, n: usize, size: InputSize, device: &Device) -> Tensor<4> {
    Tensor::<4>::from_data(
        TensorData::new(px, [n, 1, size.height as usize, size.width as usize]),
        device,
    )
}

/// `[rows, cols]` tensor of `f32` rows.
pub(crate) fn rows_tensor<const C: usize>(rows: &[[f32; C]], device: &Device) -> Tensor<2> {
    let flat: Vec<f32> = rows.iter().flat_map(|r| r.iter().copied()).collect();
    Tensor::<2>::from_data(TensorData::new(flat, [rows.len(), C]), device)
}

/// `b` frames drawn from `pool`: without replacement when `b ≤ pool.len()`, else with.
pub(crate) fn draw_frames(pool: &[usize], b: usize, rng: &mut ChaCha8Rng) -> Vec<usize> {
    if pool.is_empty() {
        return Vec::new();
    }
    if b <= pool.len() {
        rand::seq::index::sample(rng, pool.len(), b)
            .into_iter()
            .map(|i| pool[i])
            .collect()
    } else {
        (0..b)
            .map(|_| pool[rng.random_range(0..pool.len())])
            .collect()
    }
}
