//! A colon from a surface mesh and its mid-line path, e.g. a CT segmentation.
//!
//! Each surface vertex is attached to its nearest mid-line sample, which gives its surface
//! coordinates `(s, θ)` (used by the mucosa texture) and lets the lumen be *inflated*: a CT
//! colon scanned without insufflation is far narrower than during colonoscopy, so every vertex
//! is moved radially away from the mid-line by `inflation` (1.0 keeps the scan as it is).
//!
//! Sections come from landmarks on the path (GCA model JSON: anus, RSJ, DSJ, SF, HF, CCJ, …);
//! without landmarks they are approximated from typical section lengths (documented in
//! [`sections_by_typical_lengths`]).

use std::path::{Path, PathBuf};

use endoloc_data::Section;
use nalgebra::Point3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{ColonModel, SurfaceMesh};
use crate::SimError;
use crate::centerline::Centerline;

/// Where the mesh colon comes from and how it is prepared.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshColonConfig {
    /// Lumen surface: legacy VTK, OBJ, PLY or STL, in mm.
    pub surface: PathBuf,
    /// Mid-line from the anus to the caecum: GCA `.jsn` or CSV of `x,y,z` points, mm.
    pub path: PathBuf,
    /// Optional GCA model JSON whose landmarks label the path with anatomical sections.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub landmarks: Option<PathBuf>,
    /// Radial growth of the lumen about the mid-line (1.0 = as scanned).
    #[serde(default = "default_inflation")]
    pub inflation: f64,
}

fn default_inflation() -> f64 {
    2.5
}

impl MeshColonConfig {
    /// A config for the files of a GCA model folder such as `shared/data/gca-edin-00090`:
    /// `large_intestine_100k.vtk` (or the 20k one), `large_intestine_path.jsn` and the first
    /// `*.json` model file.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] when the folder lacks a surface or a path.
    pub fn from_gca_folder(dir: &Path) -> Result<Self, SimError> {
        let pick = |names: &[&str]| names.iter().map(|n| dir.join(n)).find(|p| p.is_file());
        let surface =
            pick(&["large_intestine_100k.vtk", "large_intestine_20k.vtk"]).ok_or_else(|| {
                SimError::InvalidConfig(format!(
                    "{}: no large_intestine_100k.vtk or large_intestine_20k.vtk",
                    dir.display()
                ))
            })?;
        let path = pick(&["large_intestine_path.jsn"]).ok_or_else(|| {
            SimError::InvalidConfig(format!("{}: no large_intestine_path.jsn", dir.display()))
        })?;
        let landmarks = std::fs::read_dir(dir)
            .map_err(|e| SimError::InvalidConfig(format!("{}: {e}", dir.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "json"))
            .min();
        Ok(MeshColonConfig {
            surface,
            path,
            landmarks,
            inflation: default_inflation(),
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
    let raw_path = shim::read_path(&cfg.path)?;
    let mesh = shim::read_mesh(&cfg.surface)?;
    if mesh.triangles.is_empty() {
        return Err(SimError::InvalidConfig(format!(
            "{}: the surface has no triangles",
            cfg.surface.display()
        )));
    }
    let raw_sections = match &cfg.landmarks {
        Some(file) => {
            let landmarks = shim::read_gca_landmarks(file)?;
            shim::sections_from_landmarks(raw_path.len(), &landmarks)?
        }
        None => sections_by_typical_lengths(&raw_path),
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

    // Attach every vertex to its nearest mid-line sample.
    let attached: Vec<(Point3<f64>, f32, f32, Point3<f64>)> = mesh
        .vertices
        .par_iter()
        .map(|v| {
            let pos = centerline.locate(v);
            let s = pos.s_mm.clamp(0.0, centerline.length_mm());
            let centre = centerline.point_at(s);
            let inflated = centre + (v - centre) * cfg.inflation;
            (inflated, s as f32, pos.theta as f32, centre)
        })
        .collect();
    let radial: Vec<f64> = attached.iter().map(|a| (a.0 - a.3).norm()).collect();
    let median_radius = median(&radial);
    if median_radius > 200.0 {
        return Err(SimError::InvalidConfig(format!(
            "{}: the surface is on average {median_radius:.0} mm from the mid-line in {} — \
             are both in mm and in the same frame?",
            cfg.surface.display(),
            cfg.path.display()
        )));
    }

    // Order vertices by arc length so each stretch of colon is a contiguous vertex range.
    let mut order: Vec<u32> = (0..attached.len() as u32).collect();
    order.sort_by(|a, b| attached[*a as usize].1.total_cmp(&attached[*b as usize].1));
    let mut new_index = vec![0u32; order.len()];
    for (new, old) in order.iter().enumerate() {
        new_index[*old as usize] = new as u32;
    }
    let positions: Vec<Point3<f64>> = order.iter().map(|&o| attached[o as usize].0).collect();
    let s_mm: Vec<f32> = order.iter().map(|&o| attached[o as usize].1).collect();
    let theta: Vec<f32> = order.iter().map(|&o| attached[o as usize].2).collect();
    let hint: Vec<Point3<f64>> = order.iter().map(|&o| attached[o as usize].3).collect();
    let triangles: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| new_index[v as usize]))
        .collect();
    let surface = SurfaceMesh::finalize(positions, s_mm, theta, triangles, 8.0, |i| hint[i]);

    let length = centerline.length_mm();
    let end = pass_end(&centerline, &sections, cfg, length);
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
    })
}

/// The pass ends 40 mm into the caecum (before the appendix orifice), or 30 mm before the
/// end of the path when no caecum is labelled.
fn pass_end(c: &Centerline, sections: &[Section], _cfg: &MeshColonConfig, length: f64) -> f64 {
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

mod shim {
    use super::*;
    pub struct M {
        pub vertices: Vec<Point3<f64>>,
        pub triangles: Vec<[u32; 3]>,
    }
    fn e(p: &Path) -> SimError {
        SimError::InvalidConfig(format!("{}: not yet", p.display()))
    }
    pub fn read_path(p: &Path) -> Result<Vec<Point3<f64>>, SimError> {
        Err(e(p))
    }
    pub fn read_mesh(p: &Path) -> Result<M, SimError> {
        Err(e(p))
    }
    pub fn read_gca_landmarks(p: &Path) -> Result<Vec<u8>, SimError> {
        Err(e(p))
    }
    pub fn sections_from_landmarks(_n: usize, _l: &[u8]) -> Result<Vec<Section>, SimError> {
        Ok(vec![])
    }
}
