//! Colon models: a mid-line with anatomical sections and a lumen surface mesh.
//!
//! Both models — [`procedural`] (built-in, no files) and [`from_mesh`] (a CT surface with its
//! mid-line) — end up as the same [`ColonModel`], so the renderer, the appearance model and the
//! trajectory generator never know which one they work on.

pub mod from_mesh;
pub mod procedural;

use endoloc_data::Section;
use nalgebra::{Point3, Vector3};

use crate::centerline::Centerline;

/// A lumen surface whose vertices carry surface coordinates along the mid-line, ordered by
/// arc length so that the part of the colon around the scope is a contiguous range.
#[derive(Debug, Clone)]
pub struct SurfaceMesh {
    /// Vertex positions, world frame, mm.
    pub positions: Vec<Point3<f64>>,
    /// Unit vertex normals pointing into the lumen (towards the mid-line).
    pub normals: Vec<Vector3<f32>>,
    /// Arc length of each vertex's projection on the mid-line, mm.
    pub s_mm: Vec<f32>,
    /// Angle of each vertex around the mid-line, radians in `[0, 2π)`.
    pub theta: Vec<f32>,
    /// Triangles as vertex indices, sorted by chunk.
    pub triangles: Vec<[u32; 3]>,
    /// Chunk length along the mid-line, mm.
    pub chunk_mm: f64,
    /// `triangles[chunk_tri_start[c]..chunk_tri_start[c + 1]]` lie in chunk `c`.
    pub chunk_tri_start: Vec<u32>,
    /// Smallest and largest vertex index used by each chunk's triangles.
    pub chunk_vertex_range: Vec<(u32, u32)>,
    /// Bounding sphere of each triangle (centroid, radius), for fast distance queries.
    pub triangle_bounds: Vec<(Point3<f64>, f64)>,
}

impl SurfaceMesh {
    /// Builds the chunk index: sorts triangles by the mean arc length of their vertices and
    /// computes each chunk's triangle and vertex ranges. Normals are recomputed from the faces
    /// and oriented towards `inward_hint(vertex)`, a point inside the lumen near the vertex.
    pub(crate) fn finalize(
        positions: Vec<Point3<f64>>,
        s_mm: Vec<f32>,
        theta: Vec<f32>,
        mut triangles: Vec<[u32; 3]>,
        chunk_mm: f64,
        inward_hint: impl Fn(usize) -> Point3<f64>,
    ) -> Self {
        let chunk_of = |t: &[u32; 3]| -> usize {
            let s = t.iter().map(|&v| s_mm[v as usize] as f64).sum::<f64>() / 3.0;
            (s.max(0.0) / chunk_mm) as usize
        };
        triangles.sort_by_key(|t| chunk_of(t));
        let n_chunks = triangles.last().map_or(0, |t| chunk_of(t) + 1);
        let mut chunk_tri_start = vec![0u32; n_chunks + 1];
        let mut chunk_vertex_range = vec![(u32::MAX, 0u32); n_chunks];
        for (i, t) in triangles.iter().enumerate() {
            let c = chunk_of(t);
            chunk_tri_start[c + 1] = i as u32 + 1;
            let r = &mut chunk_vertex_range[c];
            for &v in t {
                r.0 = r.0.min(v);
                r.1 = r.1.max(v);
            }
        }
        // Empty chunks start where the previous one ended.
        for c in 1..=n_chunks {
            chunk_tri_start[c] = chunk_tri_start[c].max(chunk_tri_start[c - 1]);
        }
        let normals = vertex_normals(&positions, &triangles, inward_hint);
        let triangle_bounds = triangle_bounds(&positions, &triangles);
        SurfaceMesh {
            positions,
            normals,
            s_mm,
            theta,
            triangles,
            chunk_mm,
            chunk_tri_start,
            chunk_vertex_range,
            triangle_bounds,
        }
    }

    /// The same surface with its vertices moved to `positions` (same order, same surface
    /// coordinates and chunks): normals and triangle bounds recomputed, normals oriented
    /// towards `inward_hint(vertex)`.
    ///
    /// # Panics
    /// If `positions` does not have one position per vertex.
    pub fn with_positions(
        &self,
        positions: Vec<Point3<f64>>,
        inward_hint: impl Fn(usize) -> Point3<f64>,
    ) -> Self {
        assert_eq!(
            positions.len(),
            self.positions.len(),
            "one position per vertex"
        );
        SurfaceMesh {
            normals: vertex_normals(&positions, &self.triangles, inward_hint),
            triangle_bounds: triangle_bounds(&positions, &self.triangles),
            positions,
            ..self.clone()
        }
    }

    /// Number of chunks.
    pub fn chunk_count(&self) -> usize {
        self.chunk_vertex_range.len()
    }

    /// The chunks whose triangles lie (by mean arc length) within `[s_lo, s_hi]`, mm.
    pub fn chunks_between(&self, s_lo: f64, s_hi: f64) -> std::ops::Range<usize> {
        let n = self.chunk_count();
        let lo = ((s_lo.max(0.0) / self.chunk_mm).floor() as usize).min(n);
        let hi = ((s_hi.max(0.0) / self.chunk_mm).floor() as usize + 1).min(n);
        lo..hi.max(lo)
    }

    /// Triangle index range of a chunk range.
    pub fn triangle_range(&self, chunks: std::ops::Range<usize>) -> std::ops::Range<usize> {
        if chunks.is_empty() {
            return 0..0;
        }
        self.chunk_tri_start[chunks.start] as usize..self.chunk_tri_start[chunks.end] as usize
    }

    /// Smallest vertex range covering the triangles of a chunk range (empty if none).
    pub fn vertex_range(&self, chunks: std::ops::Range<usize>) -> std::ops::Range<usize> {
        let mut lo = u32::MAX;
        let mut hi = 0u32;
        for c in chunks {
            let (a, b) = self.chunk_vertex_range[c];
            if a <= b {
                lo = lo.min(a);
                hi = hi.max(b);
            }
        }
        if lo > hi {
            0..0
        } else {
            lo as usize..hi as usize + 1
        }
    }
}

/// Unit vertex normals, area-weighted over the faces, oriented towards `inward_hint(vertex)`;
/// zero for a vertex of no face.
fn vertex_normals(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
    inward_hint: impl Fn(usize) -> Point3<f64>,
) -> Vec<Vector3<f32>> {
    let mut normals = vec![Vector3::<f64>::zeros(); positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        let n = (b - a).cross(&(c - a)); // area-weighted
        for &v in t {
            normals[v as usize] += n;
        }
    }
    normals
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let len = n.norm();
            if len < 1e-12 {
                return Vector3::zeros();
            }
            let mut n = n / len;
            if n.dot(&(inward_hint(i) - positions[i])) < 0.0 {
                n = -n;
            }
            n.cast::<f32>()
        })
        .collect()
}

/// Bounding sphere (centroid, radius) of every triangle.
fn triangle_bounds(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Vec<(Point3<f64>, f64)> {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            let centre = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            let r = [a, b, c]
                .iter()
                .map(|p| (p - centre).norm())
                .fold(0.0, f64::max);
            (centre, r)
        })
        .collect()
}

/// A tube around a mid-line: rings every `ring_step_mm` (and a last one exactly at the end),
/// `segments` vertices per ring at angles `θ = 2πj/segments` from the frame's normal towards its
/// binormal, at distance `radius(s, θ)` (mm) from the mid-line.
///
/// On the inside of a bend the radius is capped at 0.9 × the bend radius (measured along the
/// direction towards the centre of curvature), so neighbouring rings never cross and the
/// surface never folds over itself.
pub fn tube_surface(
    c: &Centerline,
    ring_step_mm: f64,
    segments: usize,
    radius: impl Fn(f64, f64) -> f64,
) -> SurfaceMesh {
    let length = c.length_mm();
    let rings = (length / ring_step_mm).ceil() as usize + 1;
    let m = segments;
    let mut positions = Vec::with_capacity(rings * m);
    let mut s_mm = Vec::with_capacity(rings * m);
    let mut theta = Vec::with_capacity(rings * m);
    let mut hint = Vec::with_capacity(rings * m);
    for k in 0..rings {
        let s = (k as f64 * ring_step_mm).min(length);
        let centre = c.point_at(s);
        let (_, n, b) = c.frame_at(s);
        // Curvature vector κN = dT/ds over ±3 mm.
        let (t_ahead, _, _) = c.frame_at(s + 3.0);
        let (t_behind, _, _) = c.frame_at(s - 3.0);
        let span = (s + 3.0).min(length) - (s - 3.0).max(0.0);
        let curvature = (t_ahead - t_behind) / span.max(1e-9);
        for j in 0..m {
            let th = j as f64 * std::f64::consts::TAU / m as f64;
            let dir = n * th.cos() + b * th.sin();
            let inward = dir.dot(&curvature); // κ · cos(angle to the centre of curvature)
            let mut r = radius(s, th);
            if inward > 1e-9 {
                r = r.min(0.9 / inward);
            }
            positions.push(centre + dir * r);
            s_mm.push(s as f32);
            theta.push(th as f32);
            hint.push(centre);
        }
    }
    let mut triangles = Vec::with_capacity((rings - 1) * m * 2);
    for k in 0..rings - 1 {
        for j in 0..m {
            let a = (k * m + j) as u32;
            let b = (k * m + (j + 1) % m) as u32;
            let c2 = ((k + 1) * m + j) as u32;
            let d = ((k + 1) * m + (j + 1) % m) as u32;
            triangles.push([a, c2, d]);
            triangles.push([a, d, b]);
        }
    }
    SurfaceMesh::finalize(positions, s_mm, theta, triangles, 8.0, |i| hint[i])
}

/// A colon ready to be rendered: mid-line, sections and lumen surface.
#[derive(Debug, Clone)]
pub struct ColonModel {
    /// Mid-line from the anus (s = 0) to the end of the caecum.
    pub centerline: Centerline,
    /// Anatomical section of every mid-line sample.
    pub sections: Vec<Section>,
    /// Lumen surface.
    pub mesh: SurfaceMesh,
    /// Arc length where a scope pass starts and ends (inside the anal canal, before the
    /// caecum's pole or the appendix), mm.
    pub pass_range_mm: (f64, f64),
    /// Human-readable description (model kind, source files).
    pub description: String,
    /// What the model had to assume, for the user: landmarks that were missing and where they
    /// were placed, where the pass stops short of the appendix. Empty for the built-in colon.
    pub notes: Vec<String>,
}

impl ColonModel {
    /// Section at arc length `s_mm` (clamped to the mid-line).
    pub fn section_at(&self, s_mm: f64) -> Section {
        self.sections[self.centerline.index_at(s_mm)]
    }

    /// Arc-length range `[start, end)` of each section present, in insertion order, mm.
    pub fn section_ranges(&self) -> Vec<(Section, f64, f64)> {
        let mut out: Vec<(Section, f64, f64)> = Vec::new();
        let step = self.centerline.step_mm;
        for (i, &sec) in self.sections.iter().enumerate() {
            let s = i as f64 * step;
            match out.last_mut() {
                Some(last) if last.0 == sec => last.2 = s + step,
                _ => out.push((sec, s, s + step)),
            }
        }
        out
    }

    /// Distance from `p` to the nearest surface triangle whose chunk lies within
    /// `[s_lo, s_hi]` of arc length, mm, and the nearest surface point.
    ///
    /// Chunks are visited from the middle of the window outwards and triangles whose bounding
    /// sphere is farther than the best distance so far are skipped, so a query costs a few
    /// hundred exact point–triangle distances.
    pub fn distance_to_surface(&self, p: &Point3<f64>, s_lo: f64, s_hi: f64) -> (f64, Point3<f64>) {
        let chunks = self.mesh.chunks_between(s_lo, s_hi);
        let mid = self
            .mesh
            .chunks_between(0.5 * (s_lo + s_hi), 0.5 * (s_lo + s_hi))
            .start
            .clamp(chunks.start, chunks.end.max(chunks.start + 1) - 1);
        let mut best = (f64::INFINITY, *p);
        let visit = |c: usize, best: &mut (f64, Point3<f64>)| {
            for ti in self.mesh.triangle_range(c..c + 1) {
                let (centre, r) = self.mesh.triangle_bounds[ti];
                let reach = best.0 + r;
                if (p - centre).norm_squared() > reach * reach {
                    continue;
                }
                let [a, b, c] = self.mesh.triangles[ti].map(|v| self.mesh.positions[v as usize]);
                let q = closest_point_on_triangle(p, &a, &b, &c);
                let d = (p - q).norm();
                if d < best.0 {
                    *best = (d, q);
                }
            }
        };
        if chunks.is_empty() {
            return best;
        }
        for k in 0.. {
            let up = mid + k;
            let down = mid.checked_sub(k + 1);
            let up_ok = up < chunks.end;
            let down_ok = down.is_some_and(|d| d >= chunks.start);
            if !up_ok && !down_ok {
                break;
            }
            if up_ok {
                visit(up, &mut best);
            }
            if let (true, Some(d)) = (down_ok, down) {
                visit(d, &mut best);
            }
        }
        best
    }
}

/// Closest point to `p` on triangle `abc` (Ericson, *Real-Time Collision Detection*, 5.1.5).
pub fn closest_point_on_triangle(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Point3<f64> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    if !denom.is_finite() {
        return *a; // degenerate (zero-area) triangle
    }
    a + ab * (vb * denom) + ac * (vc * denom)
}
