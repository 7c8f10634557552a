//! Mesh import: the same cube in VTK, OBJ, PLY (ascii, binary LE/BE) and STL (ascii, binary)
//! gives the same surface; bad and truncated files give errors naming the line.

use endoloc_data::{DataError, TriMesh, read_mesh};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Unit cube with outward-facing quads (counter-clockwise seen from outside).
fn cube() -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
    let v = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let q = vec![
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    (v, q)
}

/// The triangles as coordinate triples, each rotated to start at its smallest corner (winding
/// kept), sorted: equal for equal surfaces whatever the vertex numbering.
fn canonical(m: &TriMesh) -> Vec<[[i64; 3]; 3]> {
    let key = |i: u32| {
        let p = m.vertices[i as usize];
        [p.x, p.y, p.z].map(|c| (c * 1e6).round() as i64)
    };
    let mut tris: Vec<[[i64; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let c = [key(t[0]), key(t[1]), key(t[2])];
            let r = (0..3).min_by_key(|&k| c[k]).unwrap();
            [c[r], c[(r + 1) % 3], c[(r + 2) % 3]]
        })
        .collect();
    tris.sort();
    tris
}

fn reference() -> TriMesh {
    let (v, q) = cube();
    let mut triangles = Vec::new();
    for f in &q {
        triangles.push([f[0], f[1], f[2]]);
        triangles.push([f[0], f[2], f[3]]);
    }
    TriMesh {
        vertices: v
            .iter()
            .map(|p| nalgebra::Point3::new(p[0], p[1], p[2]))
            .collect(),
        triangles,
    }
}

fn vtk_text() -> String {
    let (v, q) = cube();
    let mut s = String::from("# vtk DataFile Version 3.0\ncube\nASCII\nDATASET POLYDATA\n");
    let _ = writeln!(s, "POINTS {} float", v.len());
    for p in &v {
        let _ = writeln!(s, "{} {} {}", p[0], p[1], p[2]);
    }
    let _ = writeln!(s, "POLYGONS {} {}", q.len(), q.len() * 5);
    for f in &q {
        let _ = writeln!(s, "4 {} {} {} {}", f[0], f[1], f[2], f[3]);
    }
    s.push_str("POINT_DATA 8\nSCALARS s float 1\nLOOKUP_TABLE default\n0 0 0 0 0 0 0 0\n");
    s
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn ply_binary(little: bool) -> Vec<u8> {
    let (v, q) = cube();
    let fmt = if little {
        "binary_little_endian"
    } else {
        "binary_big_endian"
    };
    let mut b = format!(
        "ply\nformat {fmt} 1.0\ncomment test\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        v.len(),
        q.len()
    )
    .into_bytes();
    for p in &v {
        for c in p {
            b.extend(if little {
                c.to_le_bytes()
            } else {
                c.to_be_bytes()
            });
        }
        b.push(200);
    }
    for f in &q {
        b.push(4);
        for i in f {
            let i = *i as i32;
            b.extend(if little {
                i.to_le_bytes()
            } else {
                i.to_be_bytes()
            });
        }
    }
    b
}

fn stl_triangles() -> Vec<[[f64; 3]; 3]> {
    let r = reference();
    r.triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                let p = r.vertices[i as usize];
                [p.x, p.y, p.z]
            })
        })
        .collect()
}

#[test]
fn all_formats_give_the_same_cube() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (v, q) = cube();
    let mut files = vec![write(d, "cube.vtk", vtk_text().as_bytes())];

    // OBJ: positive indices with texture/normal refs, negative indices, comments.
    let mut obj = String::from("# cube\no cube\n");
    for p in &v {
        let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
    }
    obj.push_str("vt 0 0\nvn 0 0 1\n");
    for (k, f) in q.iter().enumerate() {
        match k % 3 {
            0 => {
                let _ = writeln!(
                    obj,
                    "f {}/1/1 {}/1/1 {}/1/1 {}/1/1",
                    f[0] + 1,
                    f[1] + 1,
                    f[2] + 1,
                    f[3] + 1
                );
            }
            1 => {
                let _ = writeln!(
                    obj,
                    "f {}//1 {}//1 {} {}/1",
                    f[0] + 1,
                    f[1] + 1,
                    f[2] + 1,
                    f[3] + 1
                );
            }
            _ => {
                let n = v.len() as i64;
                let r = f.map(|i| i as i64 - n);
                let _ = writeln!(obj, "f {} {} {} {}", r[0], r[1], r[2], r[3]);
            }
        }
    }
    files.push(write(d, "cube.obj", obj.as_bytes()));

    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_index\nend_header\n",
        v.len(),
        q.len()
    );
    for p in &v {
        let _ = writeln!(ply, "{} {} {}", p[0], p[1], p[2]);
    }
    for f in &q {
        let _ = writeln!(ply, "4 {} {} {} {}", f[0], f[1], f[2], f[3]);
    }
    files.push(write(d, "cube_ascii.ply", ply.as_bytes()));
    files.push(write(d, "cube_le.ply", &ply_binary(true)));
    files.push(write(d, "cube_be.PLY", &ply_binary(false)));

    let mut stl = String::from("solid my cube\n");
    for t in stl_triangles() {
        stl.push_str("  facet normal 0 0 0\n    outer loop\n");
        for p in t {
            let _ = writeln!(stl, "      vertex {} {} {}", p[0], p[1], p[2]);
        }
        stl.push_str("    endloop\n  endfacet\n");
    }
    stl.push_str("endsolid my cube\n");
    files.push(write(d, "cube_ascii.stl", stl.as_bytes()));

    let mut bin = vec![0u8; 80];
    let tris = stl_triangles();
    bin.extend((tris.len() as u32).to_le_bytes());
    for t in &tris {
        bin.extend([0u8; 12]);
        for p in t {
            for c in p {
                bin.extend((*c as f32).to_le_bytes());
            }
        }
        bin.extend([0u8; 2]);
    }
    files.push(write(d, "cube_bin.stl", &bin));

    let want = canonical(&reference());
    for f in &files {
        let m = read_mesh(f).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            m.vertices.len(),
            8,
            "{}: duplicate vertices not merged?",
            f.display()
        );
        assert_eq!(m.triangles.len(), 12, "{}", f.display());
        assert_eq!(canonical(&m), want, "{}", f.display());
        assert_eq!(m.boundary_edge_count(), 0, "{}", f.display());
        assert!((m.surface_area() - 6.0).abs() < 1e-12, "{}", f.display());
    }
    // Formats with explicit indices keep the file's vertex numbering exactly.
    for name in [
        "cube.vtk",
        "cube.obj",
        "cube_ascii.ply",
        "cube_le.ply",
        "cube_be.PLY",
    ] {
        assert_eq!(read_mesh(&d.join(name)).unwrap(), reference(), "{name}");
    }
}

fn parse_err(dir: &Path, name: &str, text: &str) -> (usize, String) {
    let p = write(dir, name, text.as_bytes());
    match read_mesh(&p) {
        Err(e @ DataError::Parse { line, .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(name), "{msg}");
            (line, msg)
        }
        other => panic!("{name}: expected a parse error, got {other:?}"),
    }
}

#[test]
fn truncated_vtk_names_the_line_and_what_was_expected() {
    let tmp = tempfile::tempdir().unwrap();
    let full = vtk_text();
    // Cut in the middle of the polygons: keep the header, 8 points, POLYGONS and 2 cells.
    let kept: Vec<&str> = full.lines().take(4 + 1 + 8 + 1 + 2).collect();
    let text = kept.join("\n") + "\n";
    let (line, msg) = parse_err(tmp.path(), "cut.vtk", &text);
    assert_eq!(line, kept.len(), "{msg}");
    assert!(
        msg.contains("truncated") && msg.contains("cell 2 of 6"),
        "{msg}"
    );

    // Cut in the middle of the points.
    let text: String = full.lines().take(8).map(|l| format!("{l}\n")).collect();
    let (line, msg) = parse_err(tmp.path(), "cut2.vtk", &text);
    assert_eq!(line, 8, "{msg}");
    assert!(msg.contains("point 3 (of 8 POINTS)"), "{msg}");
}

#[test]
fn bad_indices_and_nan_coordinates_are_errors_with_lines() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let vtk = vtk_text().replace("4 3 0 4 7", "4 3 0 4 8");
    let (line, msg) = parse_err(d, "idx.vtk", &vtk);
    assert_eq!(line, 20, "{msg}");
    assert!(msg.contains("vertex index 8 out of range"), "{msg}");

    let vtk = vtk_text().replace("1 1 0\n", "1 nan 0\n");
    let (line, msg) = parse_err(d, "nan.vtk", &vtk);
    assert_eq!(line, 8, "{msg}");

    let (line, msg) = parse_err(d, "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    assert_eq!(line, 4, "{msg}");
    let (line, _) = parse_err(d, "nan.obj", "v 0 0 0\nv NaN 0 0\n");
    assert_eq!(line, 2);
    let (line, _) = parse_err(d, "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    assert_eq!(line, 4);

    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n";
    let (line, msg) = parse_err(d, "idx.ply", ply);
    assert_eq!(line, 13, "{msg}");
    let (line, msg) = parse_err(d, "cut.ply", &ply[..ply.len() - 3]);
    assert_eq!(line, 13, "{msg}");
    assert!(msg.contains("truncated"), "{msg}");

    let mut bin = ply_binary(true);
    bin.truncate(bin.len() - 3);
    let p = write(d, "cut.ply", &bin);
    let msg = read_mesh(&p).unwrap_err().to_string();
    assert!(msg.contains("truncated") && msg.contains("face 5"), "{msg}");

    let (line, _) = parse_err(
        d,
        "bad.stl",
        "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n",
    );
    assert_eq!(line, 6);
    let msg = read_mesh(&write(d, "x.msh", b"")).unwrap_err().to_string();
    assert!(msg.contains("expected .vtk, .obj, .ply or .stl"), "{msg}");
}

#[test]
fn real_gca_colon_surface() {
    let Some(path) = gca_file("large_intestine_20k.vtk") else {
        return;
    };
    let m = read_mesh(&path).unwrap();
    assert_eq!(m.vertices.len(), 10000);
    assert_eq!(m.triangles.len(), 20000);
    assert_eq!(m.boundary_edge_count(), 0, "the GCA surface is closed");
    let (lo, hi) = m.bounding_box().unwrap();
    let extent = hi - lo;
    assert!(
        extent.max() > 100.0 && extent.max() < 400.0,
        "{extent:?} mm"
    );

    let fine = read_mesh(&path.with_file_name("large_intestine_100k.vtk")).unwrap();
    assert_eq!(
        fine.boundary_edge_count(),
        0,
        "the 100k GCA surface is closed"
    );
    assert!(fine.triangles.len() >= 90_000, "{}", fine.triangles.len());
    let rel = (fine.surface_area() - m.surface_area()).abs() / fine.surface_area();
    assert!(
        rel < 0.05,
        "the two resolutions differ in area by {:.1} %",
        100.0 * rel
    );
}

/// A file of the CT colon folder named by `ENDOLOC_GCA_DIR` (`.ci/run` sets it when the data
/// exists); `None`, with a printed reason, otherwise.
fn gca_file(name: &str) -> Option<std::path::PathBuf> {
    let path = std::env::var_os("ENDOLOC_GCA_DIR").map(|d| std::path::PathBuf::from(d).join(name));
    match path {
        Some(p) if p.exists() => Some(p),
        other => {
            eprintln!("SKIPPED: set ENDOLOC_GCA_DIR to a Gut Cell Atlas colon folder ({other:?})");
            None
        }
    }
}
