//! PLY (Stanford polygon format), `ascii`, `binary_little_endian` or `binary_big_endian`:
//! element `vertex` with properties `x y z` (any numeric type), element `face` with a list
//! property `vertex_indices` (or `vertex_index`). Other elements and properties are read
//! and ignored; faces with more than 3 vertices are fan-triangulated.

use super::tokens::Tokens;
use super::tri_mesh::{TriMesh, fan};
use crate::DataError;
use nalgebra::Point3;
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar {
        name: String,
        ty: Scalar,
    },
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar { name, .. } | Property::List { name, .. } => name,
        }
    }
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

/// Parses a PLY file.
///
/// # Errors
/// [`DataError::Parse`] naming the header or body line (ASCII) or 0 (binary body) and what
/// was expected: a bad header, missing `x y z` or face list, a truncated body, a non-finite
/// coordinate or an index out of range.
pub fn parse_ply(path: &Path, bytes: &[u8]) -> Result<TriMesh, DataError> {
    let (format, elements, body_start, header_lines) = parse_header(path, bytes)?;
    let mut values = match format {
        Format::Ascii => {
            let text = std::str::from_utf8(&bytes[body_start..]).map_err(|_| {
                DataError::parse(path, header_lines + 1, "invalid UTF-8 in an ASCII PLY body")
            })?;
            Source::Ascii {
                tokens: Tokens::new(path, text, 1),
                header_lines,
            }
        }
        Format::BinaryLe | Format::BinaryBe => Source::Binary {
            path,
            bytes: &bytes[body_start..],
            pos: 0,
            little: format == Format::BinaryLe,
        },
    };

    let mut vertices: Vec<Point3<f64>> = Vec::new();
    let mut triangles = Vec::new();
    let mut have_vertices = false;
    let mut have_faces = false;
    let mut list: Vec<f64> = Vec::with_capacity(16);
    let mut polygon: Vec<u32> = Vec::with_capacity(16);
    for el in &elements {
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let xyz = if is_vertex {
            let find = |n: &str| {
                el.props
                    .iter()
                    .position(|p| p.name() == n && matches!(p, Property::Scalar { .. }))
            };
            match (find("x"), find("y"), find("z")) {
                (Some(x), Some(y), Some(z)) => Some([x, y, z]),
                _ => {
                    return Err(DataError::parse(
                        path,
                        0,
                        "element vertex has no scalar properties x, y and z; expected `property float x` (and y, z)",
                    ));
                }
            }
        } else {
            None
        };
        let face_list = if is_face {
            let p = el.props.iter().position(|p| {
                matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")
            });
            if p.is_none() {
                return Err(DataError::parse(
                    path,
                    0,
                    "element face has no list property vertex_indices (or vertex_index); expected `property list uchar int vertex_indices`",
                ));
            }
            p
        } else {
            None
        };
        if is_vertex {
            have_vertices = true;
            // Room for the vertices the rest of the file can hold (each property takes at
            // least a byte), not for any count a header states.
            let room = (bytes.len() - body_start) / el.props.len().max(1);
            vertices.reserve(el.count.min(room));
        }
        if is_face {
            have_faces = true;
        }
        if el.props.is_empty() {
            // Nothing to read however large its count: its items take no bytes.
            continue;
        }
        let n_vertices = vertices.len();
        for i in 0..el.count {
            let mut p = [0.0f64; 3];
            for (k, prop) in el.props.iter().enumerate() {
                let what = || {
                    format!(
                        "property {} of {} {i} (of {})",
                        prop.name(),
                        el.name,
                        el.count
                    )
                };
                match prop {
                    Property::Scalar { ty, .. } => {
                        let v = values.scalar(*ty, &what)?;
                        if let Some(xyz) = xyz
                            && let Some(c) = xyz.iter().position(|&j| j == k)
                        {
                            if !v.is_finite() {
                                return Err(values.error(format!(
                                    "{} = {v}; expected a finite coordinate",
                                    what()
                                )));
                            }
                            p[c] = v;
                        }
                    }
                    Property::List { count, item, .. } => {
                        let n = values.scalar(*count, &what)?;
                        if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                            return Err(values.error(format!(
                                "list length {n} in {}; expected a count 0..=1000000",
                                what()
                            )));
                        }
                        list.clear();
                        for _ in 0..n as usize {
                            list.push(values.scalar(*item, &what)?);
                        }
                        if face_list == Some(k) {
                            polygon.clear();
                            for &v in &list {
                                if v < 0.0 || v >= n_vertices as f64 || v.fract() != 0.0 {
                                    return Err(values.error(format!(
                                        "vertex index {v} in {}; expected 0 ≤ index < {n_vertices} (the number of vertices)",
                                        what()
                                    )));
                                }
                                polygon.push(v as u32);
                            }
                            if polygon.len() < 3 {
                                return Err(values.error(format!(
                                    "{} has {} vertices; expected at least 3",
                                    what(),
                                    polygon.len()
                                )));
                            }
                            fan(&polygon, &mut triangles);
                        }
                    }
                }
            }
            if xyz.is_some() {
                vertices.push(Point3::new(p[0], p[1], p[2]));
            }
        }
    }
    if !have_vertices || !have_faces {
        return Err(DataError::parse(
            path,
            0,
            "the header declares no `element vertex` or no `element face`; expected both",
        ));
    }
    Ok(TriMesh {
        vertices,
        triangles,
    })
}

/// Where body values come from.
enum Source<'a> {
    /// ASCII tokens; their line numbers count from the end of the header.
    Ascii {
        tokens: Tokens<'a>,
        header_lines: usize,
    },
    Binary {
        path: &'a Path,
        bytes: &'a [u8],
        pos: usize,
        little: bool,
    },
}

impl Source<'_> {
    /// The next value of type `ty`; `what` names it for errors.
    fn scalar(&mut self, ty: Scalar, what: &dyn Fn() -> String) -> Result<f64, DataError> {
        match self {
            Source::Ascii {
                tokens,
                header_lines,
            } => {
                let Some((t, line)) = tokens.next_token() else {
                    return Err(DataError::parse(
                        tokens.path(),
                        tokens.last_line() + *header_lines,
                        format!("file ends here (truncated?); expected {}", what()),
                    ));
                };
                let parsed = if ty.is_integer() {
                    t.parse::<i64>().ok().map(|v| v as f64)
                } else {
                    t.parse::<f64>().ok()
                };
                parsed.ok_or_else(|| {
                    DataError::parse(
                        tokens.path(),
                        line + *header_lines,
                        format!("found {t:?}; expected {} ({ty:?})", what()),
                    )
                })
            }
            Source::Binary {
                path,
                bytes,
                pos,
                little,
            } => {
                let n = ty.size();
                let Some(b) = bytes.get(*pos..*pos + n) else {
                    return Err(DataError::parse(
                        *path,
                        0,
                        format!(
                            "binary body ends after {} bytes (truncated?); expected {}",
                            bytes.len(),
                            what()
                        ),
                    ));
                };
                *pos += n;
                let mut a = [0u8; 8];
                a[..n].copy_from_slice(b);
                if !*little {
                    a[..n].reverse();
                }
                Ok(match ty {
                    Scalar::I8 => a[0] as i8 as f64,
                    Scalar::U8 => a[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(a),
                })
            }
        }
    }

    /// An error at the current place (the current line for ASCII, 0 for binary).
    fn error(&self, message: String) -> DataError {
        match self {
            Source::Ascii {
                tokens,
                header_lines,
            } => DataError::parse(tokens.path(), tokens.line() + header_lines, message),
            Source::Binary { path, .. } => DataError::parse(*path, 0, message),
        }
    }
}

/// Parses the header; returns the format, the elements, the byte offset of the body and the
/// number of header lines.
fn parse_header(
    path: &Path,
    bytes: &[u8],
) -> Result<(Format, Vec<Element>, usize, usize), DataError> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(DataError::parse(
                path,
                line_no.max(1),
                "file ends in the header; expected `end_header`",
            ));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        line_no += 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| DataError::parse(path, line_no, "invalid UTF-8 in the PLY header"))?
            .trim();
        let words: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if line != "ply" {
                return Err(DataError::parse(
                    path,
                    1,
                    format!("found {line:?}; expected `ply`"),
                ));
            }
            continue;
        }
        let err = |m: String| DataError::parse(path, line_no, m);
        match words.as_slice() {
            [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    _ => {
                        return Err(err(format!(
                            "format {f:?}; expected ascii, binary_little_endian or binary_big_endian"
                        )));
                    }
                });
            }
            ["element", name, count] => {
                let count = count.parse::<usize>().map_err(|_| {
                    err(format!(
                        "element count {count:?}; expected a non-negative integer"
                    ))
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            ["property", "list", count, item, name] => {
                let (Some(count), Some(item)) = (Scalar::from_name(count), Scalar::from_name(item))
                else {
                    return Err(err(format!(
                        "unknown type in {line:?}; expected `property list <int type> <type> name`"
                    )));
                };
                if !count.is_integer() {
                    return Err(err(format!(
                        "list count type {count:?}; expected an integer type"
                    )));
                }
                let el = elements.last_mut().ok_or_else(|| {
                    err("property before any element; expected `element` first".into())
                })?;
                el.props.push(Property::List {
                    name: name.to_string(),
                    count,
                    item,
                });
            }
            ["property", ty, name] => {
                let ty = Scalar::from_name(ty).ok_or_else(|| {
                    err(format!(
                        "unknown property type {ty:?}; expected char, uchar, short, ushort, int, uint, float, double (or int8 … float64)"
                    ))
                })?;
                let el = elements.last_mut().ok_or_else(|| {
                    err("property before any element; expected `element` first".into())
                })?;
                el.props.push(Property::Scalar {
                    name: name.to_string(),
                    ty,
                });
            }
            ["end_header"] => break,
            _ => {
                return Err(err(format!(
                    "found {line:?}; expected a PLY header line (format, element, property, comment, end_header)"
                )));
            }
        }
    }
    let format = format.ok_or_else(|| {
        DataError::parse(
            path,
            line_no,
            "no `format` line in the header; expected `format ascii 1.0` or a binary format",
        )
    })?;
    Ok((format, elements, pos, line_no))
}
