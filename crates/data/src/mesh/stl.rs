//! STL, ASCII (`solid … facet normal … outer loop vertex x y z ×3 endloop endfacet …
//! endsolid`) or binary (80-byte header, u32 count, 50 bytes per triangle). STL stores every
//! triangle's corners separately; corners with bit-identical coordinates are merged into one
//! vertex (in order of first appearance), which restores the connectivity of a surface.

use super::tokens::Tokens;
use super::tri_mesh::{TriMesh, fan};
use crate::DataError;
use nalgebra::Point3;
use std::collections::HashMap;
use std::path::Path;

/// Merges bit-identical corners into indexed vertices.
#[derive(Default)]
struct Welder {
    index: HashMap<[u64; 3], u32>,
    vertices: Vec<Point3<f64>>,
}

impl Welder {
    fn add(&mut self, p: [f64; 3]) -> u32 {
        // +0.0 and -0.0 are the same point.
        let key = p.map(|c| if c == 0.0 { 0u64 } else { c.to_bits() });
        *self.index.entry(key).or_insert_with(|| {
            self.vertices.push(Point3::new(p[0], p[1], p[2]));
            (self.vertices.len() - 1) as u32
        })
    }
}

/// Whether `bytes` is a binary STL: its size matches the triangle count in its header.
fn is_binary(bytes: &[u8]) -> bool {
    if bytes.len() < 84 {
        return false;
    }
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    84 + 50 * n == bytes.len() as u64
}

/// Parses an STL file (ASCII or binary).
///
/// # Errors
/// [`DataError::Parse`]: for ASCII, the line and what was expected; for binary (line 0), a
/// size that does not match the triangle count or a non-finite coordinate.
pub fn parse_stl(path: &Path, bytes: &[u8]) -> Result<TriMesh, DataError> {
    if is_binary(bytes) {
        return parse_binary(path, bytes);
    }
    let starts_solid = bytes
        .iter()
        .skip_while(|b| b.is_ascii_whitespace())
        .take(5)
        .copied()
        .collect::<Vec<u8>>()
        .eq_ignore_ascii_case(b"solid");
    if !starts_solid {
        let hint = if bytes.len() >= 84 {
            let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
            format!(
                "; as binary STL its header announces {n} triangles = {} bytes, but the file has {}",
                84 + 50 * n,
                bytes.len()
            )
        } else {
            String::new()
        };
        return Err(DataError::parse(
            path,
            0,
            format!("neither ASCII STL (starting with `solid`) nor a complete binary STL{hint}"),
        ));
    }
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        DataError::parse(
            path,
            line,
            "invalid UTF-8 in ASCII STL; expected ASCII text",
        )
    })?;
    parse_ascii(path, text)
}

fn parse_binary(path: &Path, bytes: &[u8]) -> Result<TriMesh, DataError> {
    let n = (bytes.len() - 84) / 50;
    let mut w = Welder::default();
    let mut triangles = Vec::with_capacity(n);
    for t in 0..n {
        let rec = &bytes[84 + 50 * t..84 + 50 * (t + 1)];
        let mut tri = [0u32; 3];
        for (k, corner) in tri.iter_mut().enumerate() {
            let mut p = [0.0f64; 3];
            for (c, v) in p.iter_mut().enumerate() {
                let o = 12 + 12 * k + 4 * c;
                let f = f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]]);
                if !f.is_finite() {
                    return Err(DataError::parse(
                        path,
                        0,
                        format!(
                            "triangle {t} corner {k} has a non-finite coordinate {f}; expected finite numbers"
                        ),
                    ));
                }
                *v = f as f64;
            }
            *corner = w.add(p);
        }
        triangles.push(tri);
    }
    Ok(TriMesh {
        vertices: w.vertices,
        triangles,
    })
}

fn parse_ascii(path: &Path, text: &str) -> Result<TriMesh, DataError> {
    let mut tok = Tokens::new(path, text, 1);
    let mut w = Welder::default();
    let mut triangles = Vec::new();
    let mut corners: Vec<u32> = Vec::with_capacity(4);
    let mut in_loop = false;
    let mut facets = 0usize;
    while let Some((t, line)) = tok.next_token() {
        match t.to_ascii_lowercase().as_str() {
            "vertex" => {
                if !in_loop {
                    return Err(DataError::parse(
                        path,
                        line,
                        "`vertex` outside `outer loop … endloop`; expected `outer loop` first",
                    ));
                }
                let what = format!("a coordinate of `vertex x y z` in facet {facets}");
                let p = [tok.finite(&what)?, tok.finite(&what)?, tok.finite(&what)?];
                corners.push(w.add(p));
            }
            "outer" => {
                let (l, line) = tok.expect("`loop` after `outer`")?;
                if !l.eq_ignore_ascii_case("loop") {
                    return Err(DataError::parse(
                        path,
                        line,
                        format!("found {l:?}; expected `outer loop`"),
                    ));
                }
                in_loop = true;
                corners.clear();
            }
            "endloop" => {
                if corners.len() < 3 {
                    return Err(DataError::parse(
                        path,
                        line,
                        format!("facet {facets} has {} vertices; expected 3", corners.len()),
                    ));
                }
                fan(&corners, &mut triangles);
                in_loop = false;
                facets += 1;
            }
            // `solid NAME` and `endsolid NAME`: the name may be several words; skip to the
            // next keyword we know.
            "solid" | "endsolid" => {
                while let Some((n, _)) = tok.peek() {
                    if n.eq_ignore_ascii_case("facet") || n.eq_ignore_ascii_case("solid") {
                        break;
                    }
                    tok.next_token();
                }
            }
            "facet" => {
                // `facet normal nx ny nz`: the normal is recomputed by users, skip it.
                let (n, line) = tok.expect("`normal` after `facet`")?;
                if !n.eq_ignore_ascii_case("normal") {
                    return Err(DataError::parse(
                        path,
                        line,
                        format!("found {n:?}; expected `facet normal nx ny nz`"),
                    ));
                }
                for _ in 0..3 {
                    tok.parse::<f64>("a facet normal component")?;
                }
            }
            "endfacet" => {}
            _ => {
                return Err(DataError::parse(
                    path,
                    line,
                    format!(
                        "found {t:?}; expected an ASCII STL keyword (facet, outer loop, vertex, endloop, endfacet, endsolid)"
                    ),
                ));
            }
        }
    }
    if in_loop {
        return Err(tok.eof("`endloop` to close the last facet"));
    }
    Ok(TriMesh {
        vertices: w.vertices,
        triangles,
    })
}
