//! The files of a Gut Cell Atlas (GCA) colon model folder.
//!
//! GCA models are published as one folder per model (e.g. `EdinGCA_3D_00060/`) holding the
//! model configuration `EdinGCA_3D_NNNNN_V_S.json` (landmarks as indices on the mid-line
//! paths, and the paths' file names), `Paths/large_intestine_path.jsn` (the mid-line, anus →
//! appendix tip) and `Surfaces/large-intestine.vtk` (the lumen surface). Copies often flatten
//! that into one folder (`large_intestine_100k.vtk`, `large_intestine_path.jsn`, the model
//! JSON). [`find_gca_model`] accepts both.

use std::path::{Path, PathBuf};

use crate::DataError;
use crate::fsutil::read_text;

/// The three files of a GCA colon model.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GcaModelFiles {
    /// The large intestine's lumen surface (legacy VTK, mm).
    pub surface: PathBuf,
    /// The large intestine's mid-line path (`.jsn`, mm).
    pub path: PathBuf,
    /// The model configuration JSON with the landmarks, when the folder has one.
    pub landmarks: Option<PathBuf>,
}

/// Surface file names tried, most detailed first.
const SURFACE_NAMES: [&str; 4] = [
    "large_intestine_100k.vtk",
    "large_intestine_20k.vtk",
    "large_intestine.vtk",
    "large-intestine.vtk",
];

/// Sub-folders tried for surfaces and paths, besides the folder itself.
const SURFACE_DIRS: [&str; 3] = ["", "Surfaces", "surfaces"];
const PATH_DIRS: [&str; 3] = ["", "Paths", "paths"];

/// Finds the surface, mid-line path and model JSON of a GCA model folder, flattened or as
/// published:
///
/// - **model JSON**: the `*.json` file of the folder with a `"landmarks"` array and the
///   highest `"version"`, then `"sub_version"` (published folders keep older configurations
///   next to the current one); none is fine (the sections are then approximated);
/// - **path**: the file the model JSON names for the path of the `anus` landmark
///   (`"paths"[…]."filepath"` + `"spline_filename"`), else `large_intestine_path.jsn`, in
///   the folder or its `Paths/` sub-folder;
/// - **surface**: `large_intestine_100k.vtk`, `large_intestine_20k.vtk`,
///   `large_intestine.vtk` or `large-intestine.vtk`, in the folder or its `Surfaces/`
///   sub-folder.
///
/// # Errors
/// [`DataError::Invalid`] naming the folder and the file names looked for when there is no
/// surface or no path; [`DataError::Io`] when the folder cannot be listed.
pub fn find_gca_model(dir: &Path) -> Result<GcaModelFiles, DataError> {
    let listing = std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))?;
    let mut jsons: Vec<PathBuf> = listing
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .is_some_and(|x| x.eq_ignore_ascii_case("json"))
        })
        .collect();
    jsons.sort();
    // Rank each JSON: parsed with landmarks → (version, sub_version); anything else ranks lowest.
    let parsed: Vec<(PathBuf, Option<serde_json::Value>)> = jsons
        .into_iter()
        .map(|p| {
            let v = read_text(&p)
                .ok()
                .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                .filter(|v| v.get("landmarks").is_some_and(|l| l.is_array()));
            (p, v)
        })
        .collect();
    let rank = |v: &Option<serde_json::Value>| {
        v.as_ref().map(|v| {
            let num = |k: &str| v.get(k).and_then(|x| x.as_u64()).unwrap_or(0);
            (num("version"), num("sub_version"))
        })
    };
    let best = parsed
        .iter()
        .max_by(|a, b| rank(&a.1).cmp(&rank(&b.1)).then(a.0.cmp(&b.0)));
    let landmarks = best.map(|b| b.0.clone());

    let mut path_names: Vec<PathBuf> = Vec::new();
    if let Some((_, Some(model))) = best
        && let Some(named) = named_path_file(model)
    {
        path_names.push(named.clone());
        if let Some(name) = named.file_name() {
            path_names.push(PathBuf::from(name));
        }
    }
    for sub in PATH_DIRS {
        path_names.push(Path::new(sub).join("large_intestine_path.jsn"));
    }
    let path = path_names
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            DataError::invalid(
                dir,
                format!(
                    "no mid-line path in this GCA model folder; looked for {}",
                    list(&path_names)
                ),
            )
        })?;
    let surface_names: Vec<PathBuf> = SURFACE_DIRS
        .iter()
        .flat_map(|sub| SURFACE_NAMES.iter().map(move |n| Path::new(sub).join(n)))
        .collect();
    let surface = surface_names
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            DataError::invalid(
                dir,
                format!(
                    "no large-intestine surface in this GCA model folder; looked for {}",
                    list(&surface_names)
                ),
            )
        })?;
    Ok(GcaModelFiles {
        surface,
        path,
        landmarks,
    })
}

fn list(names: &[PathBuf]) -> String {
    names
        .iter()
        .map(|n| n.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The path file (relative to the model folder) that the model JSON names for the path of
/// its `anus` landmark.
fn named_path_file(model: &serde_json::Value) -> Option<PathBuf> {
    let anus_path = model
        .get("landmarks")?
        .as_array()?
        .iter()
        .find(|l| {
            l.get("anatomy")
                .and_then(|a| a.get(0))
                .and_then(|a| a.get("abbreviated_name"))
                .and_then(|n| n.as_str())
                .is_some_and(|n| n.eq_ignore_ascii_case("anus"))
        })?
        .get("paths")?
        .get(0)?
        .as_str()?;
    let entry = model
        .get("paths")?
        .as_array()?
        .iter()
        .find(|p| p.get("id").and_then(|i| i.as_str()) == Some(anus_path))?;
    let file = entry.get("spline_filename")?.as_str()?;
    let folder = entry.get("filepath").and_then(|f| f.as_str()).unwrap_or("");
    // Only plain relative names: never leave the model folder.
    let rel = Path::new(folder).join(file);
    rel.components()
        .all(|c| matches!(c, std::path::Component::Normal(_)))
        .then_some(rel)
}
