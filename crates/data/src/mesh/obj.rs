//! Wavefront OBJ: `v x y z [w]` vertices and `f` faces (`i`, `i/t`, `i/t/n`, `i//n`; negative
//! indices count back from the last vertex defined). Other statements (`vt`, `vn`, `g`, `o`,
//! `s`, `usemtl`, `mtllib`, `l`, …) are ignored; faces with more than 3 vertices are
//! fan-triangulated.

use super::tri_mesh::{TriMesh, fan};
use crate::DataError;
use nalgebra::Point3;
use std::path::Path;

/// Parses OBJ text.
///
/// # Errors
/// [`DataError::Parse`] naming the line for a bad number, a non-finite coordinate, a face
/// with fewer than 3 vertices, index 0 or an index that refers to no vertex defined so far.
pub fn parse_obj(path: &Path, text: &str) -> Result<TriMesh, DataError> {
    let mut vertices: Vec<Point3<f64>> = Vec::new();
    let mut triangles = Vec::new();
    let mut face: Vec<u32> = Vec::with_capacity(8);
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("");
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => {
                let mut c = [0.0f64; 3];
                for (k, name) in ["x", "y", "z"].iter().enumerate() {
                    let t = parts.next().ok_or_else(|| {
                        DataError::parse(path, line_no, "expected `v x y z`: 3 coordinates")
                    })?;
                    let v: f64 = t.parse().map_err(|_| {
                        DataError::parse(
                            path,
                            line_no,
                            format!("{name} = {t:?} is not a number; expected `v x y z`"),
                        )
                    })?;
                    if !v.is_finite() {
                        return Err(DataError::parse(
                            path,
                            line_no,
                            format!("{name} = {t} is not finite; expected a finite coordinate"),
                        ));
                    }
                    c[k] = v;
                }
                vertices.push(Point3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                face.clear();
                let n = vertices.len();
                for r in parts {
                    let idx = r.split('/').next().unwrap_or("");
                    let v: i64 = idx.parse().map_err(|_| {
                        DataError::parse(
                            path,
                            line_no,
                            format!("face vertex {r:?}; expected `i`, `i/t`, `i/t/n` or `i//n` with an integer i"),
                        )
                    })?;
                    let resolved = if v > 0 { v - 1 } else { n as i64 + v };
                    if v == 0 || resolved < 0 || resolved >= n as i64 {
                        return Err(DataError::parse(
                            path,
                            line_no,
                            format!(
                                "face vertex index {v} refers to no vertex; expected 1..={n} or -{n}..=-1 ({n} vertices defined so far)"
                            ),
                        ));
                    }
                    face.push(resolved as u32);
                }
                if face.len() < 3 {
                    return Err(DataError::parse(
                        path,
                        line_no,
                        format!("face with {} vertices; expected at least 3", face.len()),
                    ));
                }
                fan(&face, &mut triangles);
            }
            _ => {}
        }
    }
    Ok(TriMesh {
        vertices,
        triangles,
    })
}
