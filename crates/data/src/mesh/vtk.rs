//! Legacy VTK, ASCII `DATASET POLYDATA`: `POINTS n float|double` then `POLYGONS m k` (or
//! `TRIANGLE_STRIPS`), in the classic layout (`c i0 … ic-1` per cell) or the VTK ≥ 9 layout
//! (`OFFSETS` / `CONNECTIVITY` arrays). `VERTICES` and `LINES` are skipped; parsing stops at
//! `POINT_DATA` / `CELL_DATA` (attributes are not needed for a surface).

use super::tokens::Tokens;
use super::tri_mesh::{TriMesh, fan};
use crate::DataError;
use nalgebra::Point3;
use std::path::Path;

/// Parses legacy ASCII VTK POLYDATA text.
///
/// # Errors
/// [`DataError::Parse`] naming the line and what was expected (a truncated file names its
/// last line).
pub fn parse_vtk(path: &Path, text: &str) -> Result<TriMesh, DataError> {
    let mut lines = text.lines();
    let first = lines.next().unwrap_or("");
    if !first
        .trim_start()
        .to_ascii_lowercase()
        .starts_with("# vtk datafile")
    {
        return Err(DataError::parse(
            path,
            1,
            format!("found {first:?}; expected the header `# vtk DataFile Version x.x`"),
        ));
    }
    let _title = lines.next();
    let format = lines.next().map(str::trim).unwrap_or("");
    if format.eq_ignore_ascii_case("BINARY") {
        return Err(DataError::parse(
            path,
            3,
            "binary legacy VTK is not supported; expected ASCII (convert with e.g. meshio or ParaView)",
        ));
    }
    if !format.eq_ignore_ascii_case("ASCII") {
        return Err(DataError::parse(
            path,
            3,
            format!("found {format:?}; expected ASCII"),
        ));
    }

    let mut tok = Tokens::new(path, text, 4);
    let (kw, line) = tok.expect("DATASET POLYDATA")?;
    let (kind, _) = tok.expect("DATASET POLYDATA")?;
    if !kw.eq_ignore_ascii_case("DATASET") || !kind.eq_ignore_ascii_case("POLYDATA") {
        return Err(DataError::parse(
            path,
            line,
            format!("found `{kw} {kind}`; expected DATASET POLYDATA (a triangle surface)"),
        ));
    }

    let mut vertices: Option<Vec<Point3<f64>>> = None;
    let mut triangles = Vec::new();
    let mut saw_cells = false;
    while let Some((kw, line)) = tok.next_token() {
        match kw.to_ascii_uppercase().as_str() {
            "POINTS" => {
                let (n, _) = tok.parse::<usize>("the number of points after POINTS")?;
                let (ty, tline) = tok.expect("the point type (float or double)")?;
                if !matches!(ty.to_ascii_lowercase().as_str(), "float" | "double") {
                    return Err(DataError::parse(
                        path,
                        tline,
                        format!("point type {ty:?}; expected float or double"),
                    ));
                }
                let mut pts = Vec::with_capacity(n.min(1 << 24));
                for i in 0..n {
                    let what = format!("coordinate of point {i} (of {n} POINTS)");
                    let x = tok.finite(&format!("x {what}"))?;
                    let y = tok.finite(&format!("y {what}"))?;
                    let z = tok.finite(&format!("z {what}"))?;
                    pts.push(Point3::new(x, y, z));
                }
                vertices = Some(pts);
            }
            "METADATA" => tok.skip_block_until_blank_line(),
            k @ ("POLYGONS" | "TRIANGLE_STRIPS" | "VERTICES" | "LINES") => {
                let Some(verts) = vertices.as_ref() else {
                    return Err(DataError::parse(
                        path,
                        line,
                        format!("{k} before POINTS; expected POINTS first"),
                    ));
                };
                let n_vertices = verts.len();
                let cells = read_cells(&mut tok, k, n_vertices)?;
                match k {
                    "POLYGONS" => {
                        saw_cells = true;
                        for c in &cells {
                            fan(c, &mut triangles);
                        }
                    }
                    "TRIANGLE_STRIPS" => {
                        saw_cells = true;
                        for c in &cells {
                            for i in 0..c.len().saturating_sub(2) {
                                triangles.push(if i % 2 == 0 {
                                    [c[i], c[i + 1], c[i + 2]]
                                } else {
                                    [c[i + 1], c[i], c[i + 2]]
                                });
                            }
                        }
                    }
                    _ => {}
                }
            }
            "POINT_DATA" | "CELL_DATA" | "FIELD" => break,
            _ => {
                return Err(DataError::parse(
                    path,
                    line,
                    format!(
                        "found {kw:?}; expected a POLYDATA section (POINTS, POLYGONS, TRIANGLE_STRIPS, VERTICES, LINES, POINT_DATA, CELL_DATA)"
                    ),
                ));
            }
        }
    }
    let Some(vertices) = vertices else {
        return Err(tok.eof("a POINTS section"));
    };
    if !saw_cells {
        return Err(tok.eof("a POLYGONS (or TRIANGLE_STRIPS) section"));
    }
    Ok(TriMesh {
        vertices,
        triangles,
    })
}

/// Reads the cells after `KEYWORD m k`, in either layout; indices are range-checked.
fn read_cells(
    tok: &mut Tokens<'_>,
    kw: &str,
    n_vertices: usize,
) -> Result<Vec<Vec<u32>>, DataError> {
    let (m, _) = tok.parse::<usize>(&format!("the number of cells after {kw}"))?;
    let (k, kline) = tok.parse::<usize>(&format!("the size of the cell list after {kw} {m}"))?;
    let new_layout = tok
        .peek()
        .is_some_and(|(t, _)| t.eq_ignore_ascii_case("OFFSETS"));
    let mut cells = Vec::with_capacity(m.min(1 << 24));
    if new_layout {
        // VTK ≥ 9: `m` offsets (cells + 1), then `k` connectivity entries.
        tok.next_token();
        tok.expect("the OFFSETS type")?;
        let mut offsets = Vec::with_capacity(m.min(1 << 24));
        for i in 0..m {
            let (o, line) = tok.parse::<usize>(&format!("offset {i} of {m} in {kw} OFFSETS"))?;
            if o > k || offsets.last().is_some_and(|&prev| o < prev) {
                return Err(DataError::parse(
                    tok.path(),
                    line,
                    format!("offset {o}; expected non-decreasing offsets ≤ {k}"),
                ));
            }
            offsets.push(o);
        }
        let (c, line) = tok.expect("CONNECTIVITY")?;
        if !c.eq_ignore_ascii_case("CONNECTIVITY") {
            return Err(DataError::parse(
                tok.path(),
                line,
                format!("found {c:?}; expected CONNECTIVITY"),
            ));
        }
        tok.expect("the CONNECTIVITY type")?;
        let mut conn = Vec::with_capacity(k.min(1 << 26));
        for i in 0..k {
            conn.push(tok.index(
                n_vertices,
                &format!("connectivity entry {i} of {k} in {kw}"),
            )?);
        }
        for w in offsets.windows(2) {
            cells.push(conn[w[0]..w[1]].to_vec());
        }
    } else {
        let mut used = 0usize;
        for i in 0..m {
            let what = format!("cell {i} of {m} in {kw} (`count i0 i1 …`)");
            let (c, _) = tok.parse::<usize>(&format!("the vertex count of {what}"))?;
            let mut cell = Vec::with_capacity(c.min(64));
            for j in 0..c {
                cell.push(tok.index(n_vertices, &format!("vertex {j} of {what}"))?);
            }
            used += c + 1;
            cells.push(cell);
        }
        if used != k {
            return Err(DataError::parse(
                tok.path(),
                kline,
                format!("{kw} {m} {k}: the cells hold {used} numbers; expected {k}"),
            ));
        }
    }
    Ok(cells)
}
