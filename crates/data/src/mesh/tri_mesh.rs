//! The indexed triangle surface every mesh format is read into.

use nalgebra::Point3;
use std::collections::HashMap;

/// An indexed triangle surface.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriMesh {
    /// Vertex positions, in the file's units (mm for the colon models).
    pub vertices: Vec<Point3<f64>>,
    /// Triangles as indices into `vertices`, in the file's winding order.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Checks that every coordinate is finite and every index is in range.
    ///
    /// # Errors
    /// A message naming the first bad vertex or triangle (0-based) and what was expected.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(i) = self
            .vertices
            .iter()
            .position(|p| !p.coords.iter().all(|c| c.is_finite()))
        {
            return Err(format!(
                "vertex {i} has a non-finite coordinate {:?}; expected finite numbers",
                self.vertices[i].coords.as_slice()
            ));
        }
        let n = self.vertices.len();
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&bad) = tri.iter().find(|&&v| v as usize >= n) {
                return Err(format!(
                    "triangle {t} uses vertex index {bad}; expected < {n} (the number of vertices)"
                ));
            }
        }
        Ok(())
    }

    /// Axis-aligned bounding box `(min, max)`; `None` for a mesh without vertices.
    pub fn bounding_box(&self) -> Option<(Point3<f64>, Point3<f64>)> {
        let first = *self.vertices.first()?;
        Some(
            self.vertices
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p))),
        )
    }

    /// Total surface area, in squared file units (mm²).
    pub fn surface_area(&self) -> f64 {
        self.triangles
            .iter()
            .filter_map(|t| {
                let a = self.vertices.get(t[0] as usize)?;
                let b = self.vertices.get(t[1] as usize)?;
                let c = self.vertices.get(t[2] as usize)?;
                Some(0.5 * (b - a).cross(&(c - a)).norm())
            })
            .sum()
    }

    /// Number of edges used by exactly one triangle (0 for a closed surface).
    pub fn boundary_edge_count(&self) -> usize {
        let mut count: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.triangles.len() * 2);
        for t in &self.triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        count.values().filter(|&&c| c == 1).count()
    }
}

/// Appends the fan triangulation `(p0, p_i, p_i+1)` of a polygon.
pub(crate) fn fan(polygon: &[u32], out: &mut Vec<[u32; 3]>) {
    for i in 1..polygon.len().saturating_sub(1) {
        out.push([polygon[0], polygon[i], polygon[i + 1]]);
    }
}
