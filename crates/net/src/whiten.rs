//! Partial PCA whitening of descriptors, learnt from the database of the training pass.
//!
//! The network's descriptor spends most of its variance on a few directions (the coarse look
//! of the lumen: fold rings, brightness, the shape of the dark centre) that many places share;
//! the directions that tell look-alikes apart (vessels, fine relief) vary little. Rescaling
//! each principal direction of the database by `λ^−p` (λ its variance, `0 < p ≤ ½`; `p = ½`
//! is full whitening) evens that out, and nearest-neighbour look-up improves — a known step
//! of image retrieval (Jégou & Chum, "Negative evidences and co-occurrences in image
//! retrieval", ECCV 2012; Radenović et al., TPAMI 2019). Full whitening also inflates the
//! directions of pure noise; a power near ¼ keeps the gain without that.
//!
//! Measured on the simulator's `paper` preset (50 zones, exact zone per frame, test pass /
//! a second pass): `builtin-track` weights indexed without training 82.3 / 80.2 % raw, 85.6
//! / 84.7 % whitened at `p = ¼`; the power was chosen on the second pass.
//!
//! A whitened descriptor is `y = normalise(Pᵀ (x − μ))`, `P = U diag(max(λ, ε)^−p)` from the
//! eigen-decomposition `U diag(λ) Uᵀ` of the rows' covariance; it stays unit length, so
//! every look-up, filter and ensemble works on it unchanged.

use crate::NetError;
use crate::binfile;
use nalgebra::{DMatrix, SymmetricEigen};
use std::path::Path;

/// File of a model folder holding its whitening.
pub const WHITENING_FILE: &str = "whitening.bin";

const MAGIC: &[u8; 8] = b"ELWHITE1";

/// Smallest eigenvalue used, relative to the largest: directions of less variance are
/// scaled as if they had this much (at `p = ¼` at most `10^1.5 ≈ 32×` more than the first).
const EIGEN_FLOOR: f64 = 1e-6;

/// A learnt whitening: `y = normalise(Pᵀ (x − μ))` (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Whitening {
    /// Descriptor length (in and out).
    pub dim: usize,
    /// The power `p` of the eigenvalues.
    pub power: f32,
    /// Mean of the rows it was learnt from, `dim` values.
    pub mean: Vec<f32>,
    /// `P`, `dim × dim`, row-major: `y_j = Σ_i (x_i − μ_i) · P[i][j]`.
    pub projection: Vec<f32>,
}

impl Whitening {
    /// Learns the whitening of `rows` (`n × dim`, row-major) at `power`.
    ///
    /// # Errors
    /// [`NetError::Config`] for a power outside `(0, 0.5]`, fewer than two rows, a length
    /// that is not a multiple of `dim`, or a value that is not finite.
    pub fn fit(rows: &[f32], dim: usize, power: f32) -> Result<Self, NetError> {
        if !(power > 0.0 && power <= 0.5) {
            return Err(NetError::Config(format!(
                "whitening power {power} must be in (0, 0.5]"
            )));
        }
        if dim == 0 || !rows.len().is_multiple_of(dim) {
            return Err(NetError::Config(format!(
                "whitening needs whole rows of {dim} values; got {}",
                rows.len()
            )));
        }
        let n = rows.len() / dim;
        if n < 2 {
            return Err(NetError::Config(format!(
                "whitening needs at least 2 descriptors; got {n}"
            )));
        }
        if rows.iter().any(|v| !v.is_finite()) {
            return Err(NetError::Config(
                "whitening: a descriptor is not finite".into(),
            ));
        }
        let mut mean = vec![0.0f64; dim];
        for r in rows.chunks_exact(dim) {
            for (m, &v) in mean.iter_mut().zip(r) {
                *m += v as f64;
            }
        }
        mean.iter_mut().for_each(|m| *m /= n as f64);
        let mut cov = DMatrix::<f64>::zeros(dim, dim);
        let mut centred = vec![0.0f64; dim];
        for r in rows.chunks_exact(dim) {
            for ((c, &v), m) in centred.iter_mut().zip(r).zip(&mean) {
                *c = v as f64 - m;
            }
            for i in 0..dim {
                let ci = centred[i];
                for j in i..dim {
                    cov[(i, j)] += ci * centred[j];
                }
            }
        }
        for i in 0..dim {
            for j in i..dim {
                let v = cov[(i, j)] / (n - 1) as f64;
                cov[(i, j)] = v;
                cov[(j, i)] = v;
            }
        }
        let eig = SymmetricEigen::new(cov);
        let top = eig.eigenvalues.max().max(f64::MIN_POSITIVE);
        let mut projection = vec![0.0f32; dim * dim];
        for (j, &lambda) in eig.eigenvalues.iter().enumerate() {
            let scale = lambda.max(EIGEN_FLOOR * top).powf(-(power as f64));
            for i in 0..dim {
                projection[i * dim + j] = (eig.eigenvectors[(i, j)] * scale) as f32;
            }
        }
        Ok(Whitening {
            dim,
            power,
            mean: mean.into_iter().map(|m| m as f32).collect(),
            projection,
        })
    }

    /// The whitened, unit-length descriptor of `x` (`dim` values).
    pub fn apply(&self, x: &[f32]) -> Vec<f32> {
        let d = self.dim;
        let centred: Vec<f32> = x.iter().zip(&self.mean).map(|(v, m)| v - m).collect();
        let mut y = vec![0.0f32; d];
        for (c, row) in centred.iter().zip(self.projection.chunks_exact(d)) {
            for (yj, p) in y.iter_mut().zip(row) {
                *yj += c * p;
            }
        }
        let norm = y.iter().map(|v| v * v).sum::<f32>().sqrt();
        if norm > 0.0 {
            y.iter_mut().for_each(|v| *v /= norm);
        }
        y
    }

    /// Whitens every row of `rows` (`n × dim`, row-major).
    pub fn apply_rows(&self, rows: &[f32]) -> Vec<f32> {
        rows.chunks_exact(self.dim)
            .flat_map(|r| self.apply(r))
            .collect()
    }

    /// Writes the whitening (`ELWHITE1`, dim and power, then μ and `P` as little-endian f32).
    ///
    /// # Errors
    /// [`NetError::Io`].
    pub fn save(&self, path: &Path) -> Result<(), NetError> {
        let header = [(self.dim as u32).to_le_bytes(), self.power.to_le_bytes()];
        let mut out = binfile::start(MAGIC, header, 4 * (self.dim + self.dim * self.dim));
        binfile::put_f32(&mut out, self.mean.iter().chain(&self.projection));
        std::fs::write(path, out).map_err(|e| NetError::io(path, e))
    }

    /// Reads a whitening of descriptors of length `dim`.
    ///
    /// # Errors
    /// [`NetError::Io`] if unreadable; [`NetError::Parse`] for a bad header, another length,
    /// a truncated file or a value that is not finite.
    pub fn load(path: &Path, dim: usize) -> Result<Self, NetError> {
        Self::from_bytes(path, &binfile::read(path)?, dim)
    }

    /// Parses the bytes of a `whitening.bin` for descriptors of length `dim` (see
    /// [`Whitening::load`]); `path` names the file in errors.
    ///
    /// # Errors
    /// [`NetError::Parse`] for a bad header, another length, a truncated file or a value that
    /// is not finite.
    pub fn from_bytes(path: &Path, bytes: &[u8], dim: usize) -> Result<Self, NetError> {
        binfile::check_header(path, bytes, MAGIC, "whitening")?;
        let bad = |m: String| NetError::parse(path, 0, m);
        let stored = u32::from_le_bytes(binfile::word(bytes, 8)) as usize;
        let power = f32::from_le_bytes(binfile::word(bytes, 12));
        if stored != dim {
            return Err(bad(format!(
                "whitens descriptors of length {stored}; the backbone makes {dim}"
            )));
        }
        if dim == 0 {
            return Err(bad(
                "whitens descriptors of length 0; expected a positive length".to_string(),
            ));
        }
        // In u128: a damaged header's length must not overflow.
        let expected = binfile::HEADER as u128 + 4 * (dim as u128 + dim as u128 * dim as u128);
        if bytes.len() as u128 != expected {
            return Err(bad(format!(
                "{} bytes; expected {expected} for descriptors of length {dim}",
                bytes.len()
            )));
        }
        let values = binfile::f32s(&bytes[binfile::HEADER..]);
        if !(power > 0.0 && power <= 0.5) || values.iter().any(|v| !v.is_finite()) {
            return Err(bad(format!(
                "power {power} or a value is out of range (a damaged file?)"
            )));
        }
        Ok(Whitening {
            dim,
            power,
            mean: values[..dim].to_vec(),
            projection: values[dim..].to_vec(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Rows whose first coordinate varies 100× more (in standard deviation) than the others.
    fn stretched(n: usize, dim: usize, seed: u64) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n * dim)
            .map(|k| {
                let v: f32 = rng.random_range(-1.0..1.0);
                if k % dim == 0 { 100.0 * v + 5.0 } else { v }
            })
            .collect()
    }

    fn spread(rows: &[f32], dim: usize, axis: usize) -> f32 {
        let v: Vec<f32> = rows.chunks_exact(dim).map(|r| r[axis]).collect();
        let m = v.iter().sum::<f32>() / v.len() as f32;
        (v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / v.len() as f32).sqrt()
    }

    #[test]
    fn full_whitening_evens_out_the_variance_and_the_power_sets_how_far() {
        let dim = 4;
        let rows = stretched(4000, dim, 1);
        // Before: 100 : 1. After full whitening (p = ½) the axes are equal, before the final
        // normalisation; at p = ¼ the ratio is the square root, 10 : 1.
        for (power, ratio) in [(0.5f32, 1.0f32), (0.25, 10.0)] {
            let w = Whitening::fit(&rows, dim, power).unwrap();
            let raw: Vec<f32> = rows
                .chunks_exact(dim)
                .flat_map(|r| {
                    let c: Vec<f32> = r.iter().zip(&w.mean).map(|(v, m)| v - m).collect();
                    (0..dim)
                        .map(|j| (0..dim).map(|i| c[i] * w.projection[i * dim + j]).sum())
                        .collect::<Vec<f32>>()
                })
                .collect();
            let mut s: Vec<f32> = (0..dim).map(|a| spread(&raw, dim, a)).collect();
            s.sort_by(f32::total_cmp);
            let got = s[dim - 1] / s[0];
            assert!(
                (got / ratio - 1.0).abs() < 0.1,
                "p {power}: spread ratio {got}"
            );
        }
        // Outputs are unit length.
        let w = Whitening::fit(&rows, dim, 0.25).unwrap();
        for y in w.apply_rows(&rows[..40]).chunks_exact(dim) {
            let n = y.iter().map(|v| v * v).sum::<f32>().sqrt();
            assert!((n - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn save_load_round_trip_and_bad_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let w = Whitening::fit(&stretched(50, 3, 2), 3, 0.25).unwrap();
        let p = dir.path().join(WHITENING_FILE);
        w.save(&p).unwrap();
        assert_eq!(Whitening::load(&p, 3).unwrap(), w);
        let e = Whitening::load(&p, 4).unwrap_err().to_string();
        assert!(e.contains("length 3") && e.contains("whitening.bin"), "{e}");
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 4]).unwrap();
        let e = Whitening::load(&p, 3).unwrap_err().to_string();
        assert!(e.contains("bytes"), "{e}");
    }

    #[test]
    fn bad_inputs_are_refused() {
        let rows = stretched(10, 2, 3);
        assert!(Whitening::fit(&rows, 2, 0.0).is_err());
        assert!(Whitening::fit(&rows, 2, 0.7).is_err());
        assert!(Whitening::fit(&rows[..2], 2, 0.25).is_err());
        assert!(Whitening::fit(&rows[..3], 2, 0.25).is_err());
        let mut nan = rows.clone();
        nan[5] = f32::NAN;
        assert!(Whitening::fit(&nan, 2, 0.25).is_err());
    }
}
