//! The descriptor database: the descriptors of the training frames (one per frame, or more
//! with zoom-blurred views), each with its zone and frame, and the zone look-up rule.
//!
//! **Rule.** The distance from a test descriptor `q` to zone `z` is the Euclidean distance to
//! the nearest descriptor of that zone ([`ScoreRule::Nearest`], the default) or the mean of
//! the `k` nearest ([`ScoreRule::MeanOfNearest`]). The predicted zone has the smallest
//! distance. This is the paper's rule: it assigns the zone "with the smallest contrastive
//! loss", and for a similar pair that loss is `½ d²`, increasing in `d`. **Zone scores are
//! distances: lower is better**, in descriptor units (unit-length descriptors: `0 ≤ d ≤ 2`).
//!
//! A training frame may have several rows (its zoom-blurred views,
//! [`TrainConfig::index_zoom_blur`](crate::TrainConfig::index_zoom_blur)): a zone's score and
//! a frame's distance are those of its nearest row (with [`ScoreRule::MeanOfNearest`], the
//! mean over the zone's nearest rows, views included). A frame's first row is its own
//! descriptor; a later row of the same frame is a **view**, and its distance counts
//! [`DescriptorDatabase::view_penalty`] more, so that a view wins only when it is clearly
//! nearer than the sharp rows.
//!
//! File format (`database.bin`, little-endian): the 8 bytes `EDLCDB01`, `u32` row count `n`,
//! `u32` descriptor length `dim`, `n × u32` zone indices, `n × dim × f32` descriptors; row `i`
//! is training frame `i`. A database whose rows are not the frames one by one is written as
//! `EDLCDB02`: the same, with `n × u32` training frames after the zone indices.

use crate::NetError;
use crate::binfile;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// File name of the database in a model folder.
pub const DATABASE_FILE: &str = "database.bin";

const MAGIC: &[u8; 8] = b"EDLCDB01";
/// The format with each row's training frame.
const MAGIC_ROWS: &[u8; 8] = b"EDLCDB02";

/// How a zone's score is computed from the distances to its descriptors.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "snake_case", deny_unknown_fields)]
pub enum ScoreRule {
    /// Distance to the nearest descriptor of the zone (1-nearest neighbour; the default).
    #[default]
    Nearest,
    /// Mean distance to the `k` nearest descriptors of the zone (fewer if the zone is
    /// smaller).
    MeanOfNearest {
        /// How many nearest descriptors to average.
        k: usize,
    },
}

/// The zone a descriptor belongs to, with the evidence.
#[derive(Debug, Clone, PartialEq)]
pub struct ZonePrediction {
    /// Predicted zone (0-based along the training trajectory).
    pub zone: usize,
    /// Score of every zone: distance in descriptor space (lower = better), see
    /// [`ScoreRule`].
    pub zone_scores: Vec<f32>,
    /// Training frame with the nearest descriptor.
    pub nearest_frame: usize,
    /// Distance to that descriptor (a view's with the database's
    /// [`DescriptorDatabase::view_penalty`]).
    pub distance: f32,
    /// The test descriptor the prediction was made from (for further look-ups such as the
    /// track filter's frame distances, [`DescriptorDatabase::frame_distances`]).
    pub descriptor: Vec<f32>,
}

/// Descriptors of the training frames.
#[derive(Debug, Clone, PartialEq)]
pub struct DescriptorDatabase {
    /// Descriptor length.
    pub dim: usize,
    /// Number of zones.
    pub zones: usize,
    /// `frames × dim` descriptors, row-major, one row per training frame.
    pub descriptors: Vec<f32>,
    /// Zone of each row.
    pub zone_of_row: Vec<usize>,
    /// Training frame of each row.
    pub frame_of_row: Vec<usize>,
    /// Added to the distance of every view row at look-up (a row whose frame an earlier row
    /// already holds), descriptor units; 0 (the constructors' value) counts a view as its
    /// frame's own row. The model's [`TrainConfig::index_view_penalty`](crate::TrainConfig::index_view_penalty).
    pub view_penalty: f32,
    /// Whether each row is a view (derived from `frame_of_row`).
    is_view: Vec<bool>,
}

impl DescriptorDatabase {
    /// A database from descriptors (`frames × dim`, row `i` = training frame `i`) and the zone
    /// of each frame.
    ///
    /// # Errors
    /// [`NetError::Config`] when the sizes disagree.
    pub fn new(
        dim: usize,
        zones: usize,
        descriptors: Vec<f32>,
        zone_of_frame: Vec<usize>,
    ) -> Result<Self, NetError> {
        let frames: Vec<usize> = (0..zone_of_frame.len()).collect();
        Self::from_rows(dim, zones, descriptors, zone_of_frame, frames)
    }

    /// A database of selected rows (`frame_of_row[i]` = training frame of row `i`).
    ///
    /// # Errors
    /// [`NetError::Config`] when the sizes disagree or a zone index is out of range.
    pub fn from_rows(
        dim: usize,
        zones: usize,
        descriptors: Vec<f32>,
        zone_of_row: Vec<usize>,
        frame_of_row: Vec<usize>,
    ) -> Result<Self, NetError> {
        if dim == 0
            || descriptors.len() != dim * zone_of_row.len()
            || frame_of_row.len() != zone_of_row.len()
            || zone_of_row.iter().any(|&z| z >= zones)
        {
            return Err(NetError::Config(format!(
                "descriptor database: {} values for {} rows of {dim} (zones < {zones})",
                descriptors.len(),
                zone_of_row.len()
            )));
        }
        let mut seen = std::collections::HashSet::with_capacity(frame_of_row.len());
        let is_view = frame_of_row.iter().map(|&f| !seen.insert(f)).collect();
        Ok(DescriptorDatabase {
            dim,
            zones,
            descriptors,
            zone_of_row,
            frame_of_row,
            view_penalty: 0.0,
            is_view,
        })
    }

    /// This database with [`DescriptorDatabase::view_penalty`] `penalty` (descriptor units).
    pub fn with_view_penalty(mut self, penalty: f32) -> Self {
        self.view_penalty = penalty;
        self
    }

    /// Whether some row is a view of a frame that an earlier row holds.
    pub fn has_views(&self) -> bool {
        self.is_view.iter().any(|&v| v)
    }

    /// Distance from `q` to every row, a view's with the penalty (see the module docs).
    fn row_distances<'a>(&'a self, q: &'a [f32]) -> impl Iterator<Item = f32> + 'a {
        self.descriptors
            .chunks_exact(self.dim)
            .zip(&self.is_view)
            .map(move |(r, &view)| {
                let d = squared_distance(r, q).sqrt();
                if view { d + self.view_penalty } else { d }
            })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.zone_of_row.len()
    }

    /// Whether the database is empty.
    pub fn is_empty(&self) -> bool {
        self.zone_of_row.is_empty()
    }

    /// Descriptor of row `i`.
    pub fn row(&self, i: usize) -> Option<&[f32]> {
        self.descriptors.get(i * self.dim..(i + 1) * self.dim)
    }

    /// The zone of descriptor `q` by `rule` (see the module documentation).
    ///
    /// # Errors
    /// [`NetError::Config`] when `q` has the wrong length or the database is empty.
    pub fn lookup(&self, q: &[f32], rule: ScoreRule) -> Result<ZonePrediction, NetError> {
        if q.len() != self.dim {
            return Err(NetError::Config(format!(
                "descriptor of length {}; the database holds length {}",
                q.len(),
                self.dim
            )));
        }
        if self.is_empty() {
            return Err(NetError::Config("the descriptor database is empty".into()));
        }
        let dist: Vec<f32> = self.row_distances(q).collect();
        let (best_row, &best) = dist
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &f32::INFINITY));
        let mut zone_scores = vec![f32::INFINITY; self.zones];
        match rule {
            ScoreRule::Nearest => {
                for (d, &z) in dist.iter().zip(&self.zone_of_row) {
                    if *d < zone_scores[z] {
                        zone_scores[z] = *d;
                    }
                }
            }
            ScoreRule::MeanOfNearest { k } => {
                let k = k.max(1);
                let mut per: Vec<Vec<f32>> = vec![Vec::new(); self.zones];
                for (d, &z) in dist.iter().zip(&self.zone_of_row) {
                    per[z].push(*d);
                }
                for (z, v) in per.iter_mut().enumerate() {
                    if v.is_empty() {
                        continue;
                    }
                    let kk = k.min(v.len());
                    v.select_nth_unstable_by(kk - 1, f32::total_cmp);
                    zone_scores[z] = v[..kk].iter().sum::<f32>() / kk as f32;
                }
            }
        }
        let zone = zone_scores
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(z, _)| z);
        Ok(ZonePrediction {
            zone,
            zone_scores,
            nearest_frame: self.frame_of_row[best_row],
            distance: best,
            descriptor: q.to_vec(),
        })
    }

    /// The number of training frames the rows come from (`1 +` the largest frame index).
    pub fn frame_count(&self) -> usize {
        self.frame_of_row.iter().max().map_or(0, |f| f + 1)
    }

    /// Distance from descriptor `q` to every training frame (the nearest of the frame's rows;
    /// `∞` for a frame without rows), indexed by training frame: the evidence of the
    /// frame-level track filter ([`crate::track`]).
    ///
    /// # Errors
    /// [`NetError::Config`] when `q` has the wrong length.
    pub fn frame_distances(&self, q: &[f32]) -> Result<Vec<f32>, NetError> {
        if q.len() != self.dim {
            return Err(NetError::Config(format!(
                "descriptor of length {}; the database holds length {}",
                q.len(),
                self.dim
            )));
        }
        let mut out = vec![f32::INFINITY; self.frame_count()];
        for (d, &f) in self.row_distances(q).zip(&self.frame_of_row) {
            if d < out[f] {
                out[f] = d;
            }
        }
        Ok(out)
    }

    /// Whether row `i` is training frame `i` for every row (the `EDLCDB01` layout).
    fn rows_are_frames(&self) -> bool {
        self.frame_of_row.iter().enumerate().all(|(i, &f)| i == f)
    }

    /// Writes `database.bin` (see the module documentation for the layout).
    ///
    /// # Errors
    /// [`NetError::Io`] when the file cannot be written.
    pub fn save(&self, path: &Path) -> Result<(), NetError> {
        let header = [
            (self.len() as u32).to_le_bytes(),
            (self.dim as u32).to_le_bytes(),
        ];
        let one_per_frame = self.rows_are_frames();
        let (magic, frame_words) = if one_per_frame {
            (MAGIC, 0)
        } else {
            (MAGIC_ROWS, 4)
        };
        let mut out = binfile::start(magic, header, self.len() * (4 + frame_words + 4 * self.dim));
        binfile::put_u32(&mut out, self.zone_of_row.iter().map(|&z| z as u32));
        if !one_per_frame {
            binfile::put_u32(&mut out, self.frame_of_row.iter().map(|&f| f as u32));
        }
        binfile::put_f32(&mut out, &self.descriptors);
        std::fs::write(path, out).map_err(|e| NetError::io(path, e))
    }

    /// Reads `database.bin` for a model of `zones` zones.
    ///
    /// # Errors
    /// [`NetError::Io`] if unreadable; [`NetError::Parse`] for a bad header, a truncated
    /// file or a zone index `≥ zones`.
    pub fn load(path: &Path, zones: usize) -> Result<Self, NetError> {
        Self::from_bytes(path, &binfile::read(path)?, zones)
    }

    /// Parses the bytes of a `database.bin` (see [`DescriptorDatabase::load`]); `path` names
    /// the file in errors.
    ///
    /// # Errors
    /// [`NetError::Parse`] for a bad header, a truncated file or a zone index `≥ zones`.
    pub fn from_bytes(path: &Path, bytes: &[u8], zones: usize) -> Result<Self, NetError> {
        let with_frames = bytes.len() >= 8 && &bytes[..8] == MAGIC_ROWS;
        let magic = if with_frames { MAGIC_ROWS } else { MAGIC };
        binfile::check_header(path, bytes, magic, "descriptor database")?;
        let bad = |m: String| NetError::parse(path, 0, m);
        let n = u32::from_le_bytes(binfile::word(bytes, 8)) as usize;
        let dim = u32::from_le_bytes(binfile::word(bytes, 12)) as usize;
        let words = if with_frames { 2 } else { 1 };
        // In u128: a damaged header's counts must not overflow.
        let expected = binfile::HEADER as u128 + 4 * n as u128 * (words + dim as u128);
        if bytes.len() as u128 != expected {
            return Err(bad(format!(
                "{} bytes; expected {expected} for {n} descriptors of length {dim}",
                bytes.len()
            )));
        }
        let zone_end = binfile::HEADER + 4 * n;
        let zone_of_row: Vec<usize> = binfile::u32s(&bytes[binfile::HEADER..zone_end])
            .map(|z| z as usize)
            .collect();
        if let Some((i, z)) = zone_of_row.iter().enumerate().find(|(_, z)| **z >= zones) {
            return Err(bad(format!(
                "row {i} has zone {z}; the model has {zones} zones"
            )));
        }
        let (frame_of_row, off) = if with_frames {
            let end = zone_end + 4 * n;
            let frames: Vec<usize> = binfile::u32s(&bytes[zone_end..end])
                .map(|f| f as usize)
                .collect();
            // A frame index past the row count is damage: a database holds at least one row
            // per frame.
            if let Some((i, f)) = frames.iter().enumerate().find(|(_, f)| **f >= n) {
                return Err(bad(format!(
                    "row {i} has training frame {f}; the database has {n} rows"
                )));
            }
            (frames, end)
        } else {
            ((0..n).collect(), zone_end)
        };
        let descriptors = binfile::f32s(&bytes[off..]);
        DescriptorDatabase::from_rows(dim, zones, descriptors, zone_of_row, frame_of_row)
    }
}

/// Each row replaced by the normalised sum of the rows whose place along the pass lies
/// within `radius_mm` of its own: the database of a pass smoothed along it. `path_mm[i]` is
/// the camera path length at row `i` (non-decreasing, [`crate::zones::cumulative_path_mm`]).
///
/// A training frame's descriptor then speaks for the few millimetres of the pass around it
/// rather than for one view, which a test frame from elsewhere in the lumen matches better —
/// database-side augmentation in image retrieval (Arandjelović & Zisserman, "Three things
/// everyone should know to improve object retrieval", CVPR 2012), here with the neighbours
/// the pass gives. Test frames are not smoothed: each is still looked up alone. On the
/// simulator's `paper` preset (0.54 mm of path per frame on average), after whitening,
/// ±2.2 mm adds 1.4 points of exact zone accuracy per frame on the test pass and 1.5 on a
/// second pass (chosen on that one). `radius_mm = 0` returns the rows as they are.
///
/// # Panics
/// Never; rows beyond `path_mm` (a shorter slice) are taken alone.
pub fn smooth_along_pass(rows: &[f32], dim: usize, path_mm: &[f64], radius_mm: f64) -> Vec<f32> {
    if radius_mm.is_nan() || radius_mm <= 0.0 || dim == 0 {
        return rows.to_vec();
    }
    let n = rows.len() / dim;
    let mut out = rows[..n * dim].to_vec();
    let (mut lo, mut hi) = (0usize, 0usize);
    for i in 0..n.min(path_mm.len()) {
        let s = path_mm[i];
        while path_mm[lo] < s - radius_mm {
            lo += 1;
        }
        hi = hi.max(i);
        while hi + 1 < n.min(path_mm.len()) && path_mm[hi + 1] <= s + radius_mm {
            hi += 1;
        }
        let o = &mut out[i * dim..(i + 1) * dim];
        o.fill(0.0);
        for r in rows[lo * dim..(hi + 1) * dim].chunks_exact(dim) {
            for (a, v) in o.iter_mut().zip(r) {
                *a += v;
            }
        }
        let norm = o.iter().map(|v| v * v).sum::<f32>().sqrt();
        if norm > 0.0 {
            o.iter_mut().for_each(|v| *v /= norm);
        }
    }
    out
}

/// Squared Euclidean distance between two descriptors of equal length.
///
/// Summed in eight independent lanes, so that the compiler keeps the loop in SIMD registers
/// (a single running `f32` sum has to be added in order and stays scalar): about 4× faster on
/// 128-d rows (`cargo bench -p endoloc-net --bench classify -- lookup_2610`). The lanes change
/// the order of the additions, not the result beyond rounding.
fn squared_distance(a: &[f32], b: &[f32]) -> f32 {
    const LANES: usize = 8;
    debug_assert_eq!(a.len(), b.len());
    let mut acc = [0.0f32; LANES];
    let (a_head, a_tail) = a.split_at(a.len() - a.len() % LANES);
    let (b_head, b_tail) = b.split_at(a_head.len());
    for (x, y) in a_head.chunks_exact(LANES).zip(b_head.chunks_exact(LANES)) {
        for l in 0..LANES {
            let d = x[l] - y[l];
            acc[l] += d * d;
        }
    }
    let tail: f32 = a_tail
        .iter()
        .zip(b_tail)
        .map(|(x, y)| (x - y) * (x - y))
        .sum();
    acc.iter().sum::<f32>() + tail
}

#[cfg(test)]
mod tests {
    use super::*;

    fn db() -> DescriptorDatabase {
        // Zone 0: (0,0), (1,0); zone 1: (0,1), (0,3).
        DescriptorDatabase::new(
            2,
            2,
            vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 3.0],
            vec![0, 0, 1, 1],
        )
        .unwrap()
    }

    #[test]
    fn smoothing_along_the_pass_averages_neighbours_and_keeps_unit_rows() {
        // Five frames of 2-d rows, (1,0) (1,0) (0,1) (1,0) (1,0), 1 mm apart.
        let rows = [1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0];
        let path = [0.0, 1.0, 2.0, 3.0, 4.0];
        assert_eq!(smooth_along_pass(&rows, 2, &path, 0.0), rows.to_vec());
        let close =
            |a: &[f32], b: [f32; 2]| (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6;
        let s = smooth_along_pass(&rows, 2, &path, 1.0);
        // Frame 0 sees frames 0–1; frames 1 to 3 see one (0,1) among three: (2, 1) normalised.
        assert!(close(&s[0..2], [1.0, 0.0]), "{s:?}");
        let (a, b) = (2.0 / 5f32.sqrt(), 1.0 / 5f32.sqrt());
        for f in 1..4 {
            assert!(close(&s[2 * f..2 * f + 2], [a, b]), "frame {f}: {s:?}");
        }
        for r in s.chunks_exact(2) {
            assert!(((r[0] * r[0] + r[1] * r[1]).sqrt() - 1.0).abs() < 1e-6);
        }
        // A pause (frames at one place) is one place; a radius past the pass covers it all.
        let paused = smooth_along_pass(&rows, 2, &[0.0, 5.0, 5.0, 5.0, 10.0], 1.0);
        assert!(close(&paused[0..2], [1.0, 0.0]) && close(&paused[2..4], [a, b]));
        let all = smooth_along_pass(&rows, 2, &path, 100.0);
        let (c, d) = (4.0 / 17f32.sqrt(), 1.0 / 17f32.sqrt());
        assert!(all.chunks_exact(2).all(|r| close(r, [c, d])), "{all:?}");
    }

    #[test]
    fn squared_distance_matches_the_plain_sum_for_every_length() {
        // Lengths below, at and past the lane count, with a tail, and the 128-d descriptor.
        for n in [0usize, 1, 7, 8, 13, 128, 131] {
            let a: Vec<f32> = (0..n).map(|i| (i as f32 * 0.37).sin()).collect();
            let b: Vec<f32> = (0..n).map(|i| (i as f32 * 0.11).cos()).collect();
            let plain: f64 = a
                .iter()
                .zip(&b)
                .map(|(x, y)| f64::from(x - y) * f64::from(x - y))
                .sum();
            let fast = f64::from(squared_distance(&a, &b));
            assert!(
                (fast - plain).abs() <= 1e-5 * plain.max(1.0),
                "n = {n}: {fast} vs {plain}"
            );
        }
        assert_eq!(squared_distance(&[1.0, 2.0, 3.0], &[1.0, 0.0, 7.0]), 20.0);
    }

    #[test]
    fn frame_distances_take_the_nearest_row_of_each_frame() {
        // Rows of frames 0, 1, 1 (an augmented view of frame 1) and 3 (frame 2 has no row).
        let d = DescriptorDatabase::from_rows(
            2,
            2,
            vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 3.0],
            vec![0, 0, 0, 1],
            vec![0, 1, 1, 3],
        )
        .unwrap();
        let f = d.frame_distances(&[0.0, 0.6]).unwrap();
        assert_eq!(f.len(), 4);
        assert!((f[0] - 0.6).abs() < 1e-6);
        assert!((f[1] - 0.4).abs() < 1e-6, "the nearer of frame 1's rows");
        assert!(f[2].is_infinite());
        assert!((f[3] - 2.4).abs() < 1e-6);
        assert!(d.frame_distances(&[0.0]).is_err());
    }

    #[test]
    fn nearest_and_mean_of_k_rules_on_hand_computed_cases() {
        let d = db();
        // q = (0, 0.6): nearest of zone 0 is (0,0) at 0.6, of zone 1 is (0,1) at 0.4.
        let p = d.lookup(&[0.0, 0.6], ScoreRule::Nearest).unwrap();
        assert_eq!(p.zone, 1);
        assert_eq!(p.nearest_frame, 2);
        assert!((p.zone_scores[0] - 0.6).abs() < 1e-6 && (p.zone_scores[1] - 0.4).abs() < 1e-6);
        assert!((p.distance - 0.4).abs() < 1e-6);
        // Mean of 2: zone 0 = (0.6 + sqrt(1.36)) / 2 ≈ 0.883, zone 1 = (0.4 + 2.4) / 2 = 1.4.
        let p = d
            .lookup(&[0.0, 0.6], ScoreRule::MeanOfNearest { k: 2 })
            .unwrap();
        assert_eq!(p.zone, 0);
        assert!((p.zone_scores[1] - 1.4).abs() < 1e-6);
        assert!(d.lookup(&[0.0], ScoreRule::Nearest).is_err());
    }

    #[test]
    fn save_load_round_trip_and_truncation_is_reported() {
        let d = db();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(DATABASE_FILE);
        d.save(&p).unwrap();
        assert_eq!(DescriptorDatabase::load(&p, 2).unwrap(), d);
        let err = DescriptorDatabase::load(&p, 1).unwrap_err().to_string();
        assert!(err.contains("zone 1") && err.contains("1 zones"), "{err}");
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 3]).unwrap();
        let err = DescriptorDatabase::load(&p, 2).unwrap_err().to_string();
        assert!(
            err.contains("database.bin") && err.contains("expected"),
            "{err}"
        );
        // Counts damaged to their largest values: an error, not an overflow.
        let mut damaged = bytes.clone();
        damaged[8..16].fill(0xff);
        std::fs::write(&p, &damaged).unwrap();
        let err = DescriptorDatabase::load(&p, 2).unwrap_err().to_string();
        assert!(err.contains("4294967295 descriptors"), "{err}");
        std::fs::write(&p, b"EDLCDB0").unwrap();
        let err = DescriptorDatabase::load(&p, 2).unwrap_err().to_string();
        assert!(err.contains("bad header"), "{err}");
    }

    #[test]
    fn rows_of_views_keep_their_frames_through_a_file() {
        // Two frames and a blurred view of each: rows 2 and 3 are frames 0 and 1 again.
        let d = DescriptorDatabase::from_rows(
            2,
            2,
            vec![0.0, 0.0, 0.0, 1.0, 0.1, 0.0, 0.0, 0.9],
            vec![0, 1, 0, 1],
            vec![0, 1, 0, 1],
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(DATABASE_FILE);
        d.save(&p).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(&bytes[..8], b"EDLCDB02");
        let back = DescriptorDatabase::load(&p, 2).unwrap();
        assert_eq!(back, d);
        assert_eq!(back.frame_count(), 2);
        assert_eq!(
            back.lookup(&[0.0, 0.85], ScoreRule::Nearest)
                .unwrap()
                .nearest_frame,
            1
        );
        // A frame index past the rows is named.
        let mut damaged = bytes.clone();
        damaged[16 + 4 * 4 + 4..16 + 4 * 4 + 8].copy_from_slice(&9u32.to_le_bytes());
        std::fs::write(&p, &damaged).unwrap();
        let err = DescriptorDatabase::load(&p, 2).unwrap_err().to_string();
        assert!(err.contains("row 1 has training frame 9"), "{err}");
        // One row per frame in order is still written as before.
        db().save(&p).unwrap();
        assert_eq!(&std::fs::read(&p).unwrap()[..8], b"EDLCDB01");
    }

    #[test]
    fn a_view_wins_only_when_nearer_by_its_penalty() {
        // Frame 0 (zone 0) at (0, 0), frame 1 (zone 1) at (0, 1), and a blurred view of
        // frame 0 at (0, 0.6), near frame 1. The query (0, 0.75) is 0.15 from the view and
        // 0.25 from frame 1.
        let d = DescriptorDatabase::from_rows(
            2,
            2,
            vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.6],
            vec![0, 1, 0],
            vec![0, 1, 0],
        )
        .unwrap();
        assert!(d.has_views() && !db().has_views());
        let q = [0.0, 0.75];
        let zone = |d: &DescriptorDatabase| d.lookup(&q, ScoreRule::Nearest).unwrap().zone;
        assert_eq!(zone(&d), 0);
        assert_eq!(zone(&d.clone().with_view_penalty(0.07)), 0);
        let penalised = d.with_view_penalty(0.2);
        assert_eq!(zone(&penalised), 1);
        let f = penalised.frame_distances(&q).unwrap();
        assert!(
            (f[0] - 0.35).abs() < 1e-6 && (f[1] - 0.25).abs() < 1e-6,
            "{f:?}"
        );
        // Without views a penalty changes nothing.
        let sharp = db();
        assert_eq!(
            sharp
                .clone()
                .with_view_penalty(1.0)
                .lookup(&[0.1, 0.2], ScoreRule::Nearest)
                .unwrap(),
            sharp.lookup(&[0.1, 0.2], ScoreRule::Nearest).unwrap()
        );
    }
}
