//! Triangle surface meshes (colon walls): import from legacy VTK, OBJ, PLY and STL.
//!
//! Coordinates are taken as stored (the GCA colon models are in millimetres). Polygons with
//! more than three vertices are fan-triangulated; triangle winding is kept as in the file.

mod obj;
mod ply;
mod stl;
mod tokens;
mod tri_mesh;
mod vtk;

use crate::DataError;
use std::path::Path;

pub use obj::parse_obj;
pub use ply::parse_ply;
pub use stl::parse_stl;
pub use tri_mesh::TriMesh;
pub use vtk::parse_vtk;

/// Reads a triangle mesh, choosing the format by extension: `.vtk` (legacy ASCII POLYDATA),
/// `.obj`, `.ply` (ASCII or binary), `.stl` (ASCII or binary; duplicate vertices merged).
///
/// # Errors
/// [`DataError::Io`] if unreadable; [`DataError::Parse`] naming the line (0 for binary data)
/// and what was expected, for a bad or truncated file, an index out of range or a non-finite
/// coordinate; [`DataError::Invalid`] for an unknown extension.
pub fn read_mesh(path: &Path) -> Result<TriMesh, DataError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let bytes = || std::fs::read(path).map_err(|e| DataError::io(path, e));
    let text = || crate::fsutil::read_text(path);
    let mesh = match ext.as_str() {
        "vtk" => parse_vtk(path, &text()?)?,
        "obj" => parse_obj(path, &text()?)?,
        "ply" => parse_ply(path, &bytes()?)?,
        "stl" => parse_stl(path, &bytes()?)?,
        _ => {
            return Err(DataError::invalid(
                path,
                format!("unknown mesh extension {ext:?}; expected .vtk, .obj, .ply or .stl"),
            ));
        }
    };
    mesh.validate().map_err(|m| DataError::parse(path, 0, m))?;
    Ok(mesh)
}
