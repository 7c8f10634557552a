//! A colon from a surface mesh and its mid-line path, e.g. a CT segmentation.
//!
//! The lumen is sampled as a radial profile about the mid-line: from every mid-line sample
//! (every `ring_step_mm`), rays in the cross-section plane at `ring_segments` angles find the
//! nearest wall of the input surface (the first hit is always the colon's own wall, even where
//! two loops touch). A 3×3 median over `(s, θ)` removes spikes, and the lumen is rebuilt as a
//! clean tube of radius `r(s, θ)` around the mid-line, closed at the far end of the path.
//!
//! A CT colon scanned without insufflation is narrower than during colonoscopy: `inflation`
//! grows the lumen radially about the mid-line. The default 1.0 renders the scanned wall (on
//! GCA 00090 the rays give a median radius of 14.6 mm). Above 1, each ray grows into the
//! tissue but never past half-way to the next surface behind the wall, and no point of the
//! lumen gets nearer to another stretch of the mid-line than to its own; where loops are
//! packed tightly (as in a non-insufflated abdomen) the grown walls flatten against each
//! other, which shows as planar patches in the images.
//!
//! Sections come from landmarks on the path (GCA model JSON: anus, RSJ, DSJ, SF, HF, CCJ, …;
//! missing ones are placed as [`endoloc_data::section_cut`] documents and listed in
//! [`ColonModel::notes`]); without landmarks they are approximated from typical section
//! lengths (documented in [`sections_by_typical_lengths`]). GCA mid-lines run on through the
//! appendix orifice (AO) to the appendix tip: a pass ends before the AO (or at the ileocaecal
//! valve, ICVc, without an AO), so the scope never enters the appendix.

use std::path::{Path, PathBuf};

use endoloc_data::Section;
use nalgebra::Point3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::ColonModel;
use crate::SimError;
use crate::centerline::Centerline;

/// Where the mesh colon comes from and how it is prepared.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshColonConfig {
    /// Lumen surface: legacy VTK, OBJ, PLY or STL, in mm (a closed tube around the path).
    pub surface: PathBuf,
    /// Mid-line from the anus to the caecum: GCA `.jsn` or CSV of `x,y,z` points, mm.
    pub path: PathBuf,
    /// Optional GCA model JSON whose landmarks label the path with anatomical sections.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub landmarks: Option<PathBuf>,
    /// Radial growth of the lumen about the mid-line (1.0 = as scanned, the default).
    #[serde(default = "default_inflation")]
    pub inflation: f64,
    /// Distance between the rings of the rebuilt lumen, mm.
    #[serde(default = "default_ring_step")]
    pub ring_step_mm: f64,
    /// Rays (and vertices) per ring.
    #[serde(default = "default_ring_segments")]
    pub ring_segments: usize,
}

fn default_ring_step() -> f64 {
    1.0
}

fn default_ring_segments() -> usize {
    96
}

fn default_inflation() -> f64 {
    1.0
}

impl MeshColonConfig {
    /// A config with the default inflation (2.5) and ring resolution (1 mm, 96 rays).
    pub fn new(surface: PathBuf, path: PathBuf, landmarks: Option<PathBuf>) -> Self {
        MeshColonConfig {
            surface,
            path,
            landmarks,
            inflation: default_inflation(),
            ring_step_mm: default_ring_step(),
            ring_segments: default_ring_segments(),
        }
    }

    /// A config for the files of a GCA model folder, as published
    /// (`EdinGCA_3D_NNNNN_V_S.json`, `Paths/large_intestine_path.jsn`,
    /// `Surfaces/large-intestine.vtk`) or flattened (`large_intestine_100k.vtk` or the 20k
    /// one, `large_intestine_path.jsn` and the model JSON side by side); see
    /// [`endoloc_data::find_gca_model`] for the rules.
    ///
    /// # Errors
    /// [`SimError::Data`] when the folder cannot be listed or lacks a surface or a path.
    pub fn from_gca_folder(dir: &Path) -> Result<Self, SimError> {
        let files = endoloc_data::find_gca_model(dir)?;
        Ok(MeshColonConfig {
            surface: files.surface,
            path: files.path,
            landmarks: files.landmarks,
            inflation: default_inflation(),
            ring_step_mm: default_ring_step(),
            ring_segments: default_ring_segments(),
        })
    }
}

/// Mid-line resampling step, mm.
const STEP_MM: f64 = 0.5;

/// Loads and prepares a mesh colon.
///
/// # Errors
/// File errors from [`endoloc_data`] (naming file and line), [`SimError::InvalidPath`] for a
/// degenerate mid-line, [`SimError::InvalidConfig`] for a bad inflation factor or a mesh that
/// does not surround the path.
pub fn build(cfg: &MeshColonConfig) -> Result<ColonModel, SimError> {
    if !(cfg.inflation.is_finite() && cfg.inflation > 0.0 && cfg.inflation <= 10.0) {
        return Err(SimError::InvalidConfig(format!(
            "mesh colon: inflation must be in (0, 10], got {}",
            cfg.inflation
        )));
    }
    let raw_path = endoloc_data::read_path(&cfg.path)?;
    let mesh = endoloc_data::read_mesh(&cfg.surface)?;
    if mesh.triangles.is_empty() {
        return Err(SimError::InvalidConfig(format!(
            "{}: the surface has no triangles",
            cfg.surface.display()
        )));
    }
    let mut notes = Vec::new();
    let mut stop_landmark = None;
    let raw_sections = match &cfg.landmarks {
        Some(file) => {
            let landmarks = endoloc_data::read_gca_landmarks(file)?;
            let cut = endoloc_data::section_cut(raw_path.len(), &landmarks)?;
            notes.extend(
                cut.estimated
                    .iter()
                    .map(|e| format!("{}: {e}", file.display())),
            );
            stop_landmark = caecum_stop_landmark(&landmarks);
            let mut labels = Vec::with_capacity(raw_path.len());
            for r in &cut.ranges {
                labels.extend(std::iter::repeat_n(r.section, r.end - r.start));
            }
            labels
        }
        None => {
            notes.push(format!(
                "no landmarks: sections of {} approximated from typical section lengths",
                cfg.path.display()
            ));
            sections_by_typical_lengths(&raw_path)
        }
    };
    // Arc length of each original path point, to carry labels over to the resampled curve.
    let mut raw_s = vec![0.0f64; raw_path.len()];
    for i in 1..raw_path.len() {
        raw_s[i] = raw_s[i - 1] + (raw_path[i] - raw_path[i - 1]).norm();
    }
    let centerline = Centerline::from_polyline(&raw_path, STEP_MM)?.smoothed(4);
    let scale = centerline.length_mm() / raw_s.last().copied().unwrap_or(1.0).max(1e-9);
    let mut sections = Vec::with_capacity(centerline.len());
    let mut j = 0;
    for i in 0..centerline.len() {
        let s = i as f64 * STEP_MM / scale;
        while j + 1 < raw_s.len() && raw_s[j + 1] <= s {
            j += 1;
        }
        sections.push(raw_sections[j]);
    }

    if !(cfg.ring_step_mm.is_finite() && cfg.ring_step_mm > 0.0) || cfg.ring_segments < 8 {
        return Err(SimError::InvalidConfig(format!(
            "mesh colon: ring_step_mm must be positive and ring_segments ≥ 8, got {} and {}",
            cfg.ring_step_mm, cfg.ring_segments
        )));
    }
    let profile = RadialProfile::measure(
        &centerline,
        &mesh,
        cfg.ring_step_mm,
        cfg.ring_segments,
        cfg.inflation,
    );
    if profile.hit_fraction < 0.5 {
        return Err(SimError::InvalidConfig(format!(
            "{}: only {:.0} % of the rays from the mid-line in {} hit the surface — are both in mm, \
             in the same frame, and is the path inside the surface?",
            cfg.surface.display(),
            100.0 * profile.hit_fraction,
            cfg.path.display()
        )));
    }
    let median_radius = profile.median_radius();
    let surface = super::tube_surface(&centerline, cfg.ring_step_mm, cfg.ring_segments, |s, th| {
        profile.radius(s, th)
    });

    let length = centerline.length_mm();
    let mut end = pass_end(&centerline, &sections, length);
    if let Some((abbr, i, margin)) = stop_landmark {
        let at = raw_s.get(i).copied().unwrap_or(0.0) * scale;
        let limit = at - margin;
        if limit < end {
            end = limit;
            notes.push(format!(
                "the pass ends at {end:.0} mm along the mid-line, {margin:.0} mm before landmark \
                 {abbr} (the mid-line runs on into the appendix, which is never entered)"
            ));
        }
    }
    Ok(ColonModel {
        pass_range_mm: (20.0_f64.min(end / 2.0), end),
        description: format!(
            "mesh colon {} (mid-line {}, {:.0} mm, inflation ×{}, median lumen radius {:.1} mm)",
            cfg.surface.display(),
            cfg.path.display(),
            length,
            cfg.inflation,
            median_radius
        ),
        centerline,
        sections,
        mesh: surface,
        notes,
    })
}

/// Room kept before the appendix orifice, mm: the pass ends this far before it.
const BEFORE_APPENDIX_MM: f64 = 10.0;

/// The caecum landmark a pass must not pass (the mid-lines of GCA models run on through the
/// appendix orifice to the appendix tip): the appendix orifice `AO` (ending
/// [`BEFORE_APPENDIX_MM`] before it) or else the ileocaecal valve `ICVc` (ending at it).
/// Returns the abbreviation, the path index and the margin, mm.
fn caecum_stop_landmark(
    landmarks: &[endoloc_data::Landmark],
) -> Option<(&'static str, usize, f64)> {
    let find = |abbr: &str| {
        landmarks
            .iter()
            .find(|l| l.abbreviation.eq_ignore_ascii_case(abbr))
            .map(|l| l.path_index)
    };
    find("AO")
        .map(|i| ("AO", i, BEFORE_APPENDIX_MM))
        .or_else(|| find("ICVc").map(|i| ("ICVc", i, 0.0)))
}

/// The pass ends 40 mm into the caecum (at most 60 % of the way through it), or 30 mm before
/// the end of the path when no caecum is labelled; [`caecum_stop_landmark`] may end it
/// earlier.
fn pass_end(c: &Centerline, sections: &[Section], length: f64) -> f64 {
    match sections.iter().position(|s| *s == Section::Caecum) {
        Some(i) => {
            let caecum_end = sections
                .iter()
                .rposition(|s| *s == Section::Caecum)
                .unwrap_or(i);
            let start = i as f64 * c.step_mm;
            let stop = caecum_end as f64 * c.step_mm;
            (start + 40.0)
                .min(start + 0.6 * (stop - start))
                .min(length - 10.0)
        }
        None => length - 30.0,
    }
}

/// The (inflated) lumen radius around the mid-line, per ring and angle, mm.
struct RadialProfile {
    ring_step_mm: f64,
    segments: usize,
    /// `rings × segments`, row-major by ring.
    radius: Vec<f64>,
    /// Fraction of rays that hit the surface (before filling the misses).
    hit_fraction: f64,
}

impl RadialProfile {
    /// Casts the rays. Each ray records the first wall hit `t0` and the next surface hit `t1`
    /// behind it (a neighbouring loop, or the same colon at a bend), and the radius is
    /// `min(inflation · t0, (t0 + t1) / 2)`: the lumen grows into the tissue around it but
    /// never past half-way to the next lumen, so inflated loops never intersect.
    fn measure(
        c: &Centerline,
        mesh: &endoloc_data::TriMesh,
        ring_step_mm: f64,
        segments: usize,
        inflation: f64,
    ) -> Self {
        let grid = TriangleGrid::new(mesh, 6.0);
        let length = c.length_mm();
        let rings = (length / ring_step_mm).ceil() as usize + 1;
        let max_t = 120.0;
        let raw: Vec<Vec<f64>> = (0..rings)
            .into_par_iter()
            .map(|k| {
                let s = (k as f64 * ring_step_mm).min(length);
                let origin = c.point_at(s);
                let (_, n, b) = c.frame_at(s);
                let mut scratch = Vec::new();
                (0..segments)
                    .map(|j| {
                        let th = j as f64 * std::f64::consts::TAU / segments as f64;
                        let dir = n * th.cos() + b * th.sin();
                        match grid.first_two_hits(&origin, &dir, max_t, &mut scratch) {
                            (Some(t0), Some(t1)) => (inflation * t0).min(0.5 * (t0 + t1)).max(t0),
                            (Some(t0), None) => inflation * t0,
                            _ => f64::NAN,
                        }
                    })
                    .collect()
            })
            .collect();
        let total = (rings * segments).max(1);
        let hits = raw.iter().flatten().filter(|r| r.is_finite()).count();
        let mut radius: Vec<f64> = raw.into_iter().flatten().collect();
        fill_misses(&mut radius, rings, segments);
        let mut radius = median3x3(&radius, rings, segments);
        cap_outliers(&mut radius, rings, segments, ring_step_mm);
        if inflation > 1.0 {
            cap_to_own_stretch(&mut radius, c, rings, segments, ring_step_mm);
        }
        // Median then mean over 3×3: no single-ray spikes, no steps between capped and free rays.
        let radius = median3x3(&radius, rings, segments);
        let radius = mean3x3(&radius, rings, segments);
        RadialProfile {
            ring_step_mm,
            segments,
            radius,
            hit_fraction: hits as f64 / total as f64,
        }
    }

    fn rings(&self) -> usize {
        self.radius.len() / self.segments
    }

    /// Bilinear radius at arc length `s` (mm) and angle `theta` (rad), mm.
    fn radius(&self, s: f64, theta: f64) -> f64 {
        let rings = self.rings();
        let x = (s / self.ring_step_mm).clamp(0.0, (rings - 1) as f64);
        let k = (x.floor() as usize).min(rings.saturating_sub(2));
        let fk = x - k as f64;
        let y =
            theta.rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU * self.segments as f64;
        let j = (y.floor() as usize) % self.segments;
        let fj = y - y.floor();
        let j1 = (j + 1) % self.segments;
        let at = |k: usize, j: usize| self.radius[k.min(rings - 1) * self.segments + j];
        let r0 = at(k, j) * (1.0 - fj) + at(k, j1) * fj;
        let r1 = at(k + 1, j) * (1.0 - fj) + at(k + 1, j1) * fj;
        let r = r0 * (1.0 - fk) + r1 * fk;
        // Close the tube at the far end of the path over the last 3 mm.
        let to_end = (rings - 1) as f64 * self.ring_step_mm - s;
        if to_end < 3.0 {
            r * (to_end.max(0.0) / 3.0).sqrt()
        } else {
            r
        }
    }

    fn median_radius(&self) -> f64 {
        median(&self.radius)
    }
}

/// Triangles binned in a uniform 3-D grid (each triangle in every cell its bounding box
/// overlaps), for ray queries.
struct TriangleGrid {
    cell_mm: f64,
    origin: Point3<f64>,
    dims: [usize; 3],
    cells: Vec<Vec<u32>>,
    triangles: Vec<[Point3<f64>; 3]>,
}

impl TriangleGrid {
    fn new(mesh: &endoloc_data::TriMesh, cell_mm: f64) -> Self {
        let triangles: Vec<[Point3<f64>; 3]> = mesh
            .triangles
            .iter()
            .filter_map(|t| {
                let p = t.map(|v| mesh.vertices.get(v as usize).copied());
                match p {
                    [Some(a), Some(b), Some(c)] => Some([a, b, c]),
                    _ => None,
                }
            })
            .collect();
        let mut lo = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for t in &triangles {
            for p in t {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
        }
        if triangles.is_empty() {
            lo = Point3::origin();
            hi = Point3::origin();
        }
        let dims = [0, 1, 2].map(|a| (((hi[a] - lo[a]) / cell_mm).floor() as usize + 1).min(4096));
        let mut cells = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        let cell_of =
            |p: f64, a: usize| (((p - lo[a]) / cell_mm).floor().max(0.0) as usize).min(dims[a] - 1);
        for (i, t) in triangles.iter().enumerate() {
            let tlo = t[0].inf(&t[1]).inf(&t[2]);
            let thi = t[0].sup(&t[1]).sup(&t[2]);
            for x in cell_of(tlo.x, 0)..=cell_of(thi.x, 0) {
                for y in cell_of(tlo.y, 1)..=cell_of(thi.y, 1) {
                    for z in cell_of(tlo.z, 2)..=cell_of(thi.z, 2) {
                        cells[(x * dims[1] + y) * dims[2] + z].push(i as u32);
                    }
                }
            }
        }
        TriangleGrid {
            cell_mm,
            origin: lo,
            dims,
            cells,
            triangles,
        }
    }

    fn cell(&self, p: &Point3<f64>) -> Option<usize> {
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let f = ((p[a] - self.origin[a]) / self.cell_mm).floor();
            if f < 0.0 || f >= self.dims[a] as f64 {
                return None;
            }
            idx[a] = f as usize;
        }
        Some((idx[0] * self.dims[1] + idx[1]) * self.dims[2] + idx[2])
    }

    /// The nearest hit along a unit ray and the nearest one at least 0.5 mm behind it, within
    /// `max_t` mm. Marches the cells along the ray in steps of a third of a cell.
    fn first_two_hits(
        &self,
        origin: &Point3<f64>,
        dir: &nalgebra::Vector3<f64>,
        max_t: f64,
        hits: &mut Vec<f64>,
    ) -> (Option<f64>, Option<f64>) {
        hits.clear();
        let step = self.cell_mm / 3.0;
        let mut last_cell = usize::MAX;
        let mut t = 0.0;
        while t <= max_t {
            if let Some(c) = self.cell(&(origin + dir * t))
                && c != last_cell
            {
                last_cell = c;
                for &ti in &self.cells[c] {
                    if let Some(h) = ray_triangle(origin, dir, &self.triangles[ti as usize]) {
                        hits.push(h);
                    }
                }
            }
            // Stop once two separated hits lie safely behind the marched distance.
            if hits.len() >= 2 {
                hits.sort_by(f64::total_cmp);
                let t0 = hits[0];
                if let Some(&t1) = hits.iter().find(|&&h| h > t0 + 0.5)
                    && t1 + 2.0 * self.cell_mm < t
                {
                    return (Some(t0), Some(t1));
                }
            }
            t += step;
        }
        hits.sort_by(f64::total_cmp);
        let t0 = hits.first().copied();
        let t1 = t0.and_then(|t0| hits.iter().copied().find(|&h| h > t0 + 0.5));
        (t0, t1)
    }
}

/// Möller–Trumbore: distance along a unit ray to triangle `v`, if hit in front.
fn ray_triangle(
    origin: &Point3<f64>,
    dir: &nalgebra::Vector3<f64>,
    v: &[Point3<f64>; 3],
) -> Option<f64> {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let p = dir.cross(&e2);
    let det = e1.dot(&p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let o = origin - v[0];
    let u = o.dot(&p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = o.cross(&e1);
    let w = dir.dot(&q) * inv;
    if w < 0.0 || u + w > 1.0 {
        return None;
    }
    let t = e2.dot(&q) * inv;
    (t > 1e-9).then_some(t)
}

/// Replaces rays that hit nothing by the nearest hit of the same ring (around the circle), or
/// of the nearest ring with hits.
fn fill_misses(r: &mut [f64], rings: usize, m: usize) {
    for k in 0..rings {
        let row = &mut r[k * m..(k + 1) * m];
        if row.iter().all(|v| !v.is_finite()) {
            continue;
        }
        let known: Vec<(usize, f64)> = row
            .iter()
            .enumerate()
            .filter(|(_, v)| v.is_finite())
            .map(|(j, v)| (j, *v))
            .collect();
        for (j, x) in row.iter_mut().enumerate() {
            if !x.is_finite() {
                let nearest = known
                    .iter()
                    .min_by_key(|(kj, _)| {
                        let d = kj.abs_diff(j);
                        d.min(m - d)
                    })
                    .map(|(_, v)| *v);
                *x = nearest.unwrap_or(f64::NAN);
            }
        }
    }
    let filled: Vec<bool> = (0..rings).map(|k| r[k * m].is_finite()).collect();
    for k in 0..rings {
        if filled[k] {
            continue;
        }
        let source = (1..rings).find_map(|d| {
            [k.checked_sub(d), Some(k + d)]
                .into_iter()
                .flatten()
                .find(|&q| q < rings && filled[q])
        });
        for j in 0..m {
            r[k * m + j] = source.map_or(5.0, |q| r[q * m + j]);
        }
    }
}

/// Caps every radius at 1.8 × the median radius of the rings within ±10 mm: a ray that
/// slipped through a gap or along a bend of the input surface must not make a flap reaching
/// across the lumen.
fn cap_outliers(r: &mut [f64], rings: usize, m: usize, ring_step_mm: f64) {
    let ring_median: Vec<f64> = (0..rings).map(|k| median(&r[k * m..(k + 1) * m])).collect();
    let half = (10.0 / ring_step_mm).round().max(1.0) as usize;
    for k in 0..rings {
        let lo = k.saturating_sub(half);
        let hi = (k + half + 1).min(rings);
        let local = median(&ring_median[lo..hi]);
        for v in &mut r[k * m..(k + 1) * m] {
            *v = v.min(1.8 * local);
        }
    }
}

/// Keeps each ring's surface in its own stretch of colon: a point at distance `r` along
/// direction `d` from the mid-line at `s` must be nearer to the mid-line at `s` than to any
/// mid-line sample more than 25 mm of arc length away. For such a sample `c_i` (offset
/// `Δ = c_i − c(s)`) that caps `r` at the bisector plane, `|Δ|² / (2 Δ·d)` (× 0.95). Where
/// two loops of a CT colon lie side by side, their inflated lumens therefore never cross.
fn cap_to_own_stretch(r: &mut [f64], c: &Centerline, rings: usize, m: usize, ring_step_mm: f64) {
    const FAR_MM: f64 = 25.0;
    let length = c.length_mm();
    let max_r = r
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    r.par_chunks_mut(m).enumerate().for_each(|(k, row)| {
        let s = (k as f64 * ring_step_mm).min(length);
        let centre = c.point_at(s);
        let (_, n, b) = c.frame_at(s);
        let far: Vec<nalgebra::Vector3<f64>> = c
            .points
            .iter()
            .enumerate()
            .filter(|(i, _)| ((*i as f64) * c.step_mm - s).abs() > FAR_MM)
            .map(|(_, p)| p - centre)
            .filter(|d| d.norm() < 2.0 * max_r)
            .collect();
        for (j, v) in row.iter_mut().enumerate() {
            let th = j as f64 * std::f64::consts::TAU / m as f64;
            let dir = n * th.cos() + b * th.sin();
            for d in &far {
                let along = d.dot(&dir);
                if along > 1e-9 {
                    *v = v.min(0.95 * d.norm_squared() / (2.0 * along));
                }
            }
        }
    });
    let _ = rings;
}

/// 3×3 mean over (ring, angle), wrapping around the angle; never larger than the input
/// (a cap stays a cap).
fn mean3x3(r: &[f64], rings: usize, m: usize) -> Vec<f64> {
    (0..rings * m)
        .map(|i| {
            let (k, j) = (i / m, i % m);
            let (mut sum, mut n) = (0.0, 0.0);
            for dk in [-1i64, 0, 1] {
                let kk = k as i64 + dk;
                if kk < 0 || kk >= rings as i64 {
                    continue;
                }
                for dj in [m - 1, 0, 1] {
                    sum += r[kk as usize * m + (j + dj) % m];
                    n += 1.0;
                }
            }
            (sum / n).min(r[i])
        })
        .collect()
}

/// 3×3 median over (ring, angle), wrapping around the angle.
fn median3x3(r: &[f64], rings: usize, m: usize) -> Vec<f64> {
    (0..rings * m)
        .map(|i| {
            let (k, j) = (i / m, i % m);
            let mut w = [0.0; 9];
            let mut n = 0;
            for dk in [-1i64, 0, 1] {
                let kk = k as i64 + dk;
                if kk < 0 || kk >= rings as i64 {
                    continue;
                }
                for dj in [m - 1, 0, 1] {
                    w[n] = r[kk as usize * m + (j + dj) % m];
                    n += 1;
                }
            }
            let win = &mut w[..n];
            win.sort_by(f64::total_cmp);
            win[n / 2]
        })
        .collect()
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut w = v.to_vec();
    let mid = w.len() / 2;
    *w.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Sections for a path without landmarks, from typical adult section lengths (mm):
/// anal canal 35, rectum 120, recto-sigmoid 30, sigmoid 400, descending 250, splenic flexure
/// 80, transverse 450, hepatic flexure 80, ascending 150, caecum 60 — scaled to the path's
/// length. A coarse stand-in: give landmarks whenever they exist.
pub fn sections_by_typical_lengths(path: &[Point3<f64>]) -> Vec<Section> {
    const TYPICAL: [f64; 10] = [
        35.0, 120.0, 30.0, 400.0, 250.0, 80.0, 450.0, 80.0, 150.0, 60.0,
    ];
    let total: f64 = TYPICAL.iter().sum();
    let mut s = vec![0.0; path.len()];
    for i in 1..path.len() {
        s[i] = s[i - 1] + (path[i] - path[i - 1]).norm();
    }
    let length = s.last().copied().unwrap_or(0.0).max(1e-9);
    s.iter()
        .map(|&x| {
            let mut acc = 0.0;
            for (k, len) in TYPICAL.iter().enumerate() {
                acc += len / total * length;
                if x < acc {
                    return Section::ALL[k];
                }
            }
            Section::Caecum
        })
        .collect()
}
