//! The colon's wall for the 3-D views: rings of the lumen surface a simulated dataset was
//! rendered from (the built-in colon or a CT mesh), rebuilt from its `dataset.toml`.
//!
//! A changed colon's test pass was rendered through a deformed copy; the wall drawn is the
//! colon as mapped, the frame the anatomical poses and the map points are stated in.

use std::collections::BTreeMap;
use std::path::Path;

use endoloc_data::DatasetMeta;
use endoloc_sim::SimConfig;
use endoloc_sim::colon::SurfaceMesh;

/// Distance between the rings drawn, mm of mid-line.
pub const WALL_RING_STEP_MM: f64 = 10.0;
/// Points per ring drawn.
pub const WALL_RING_POINTS: usize = 24;

/// The rings of the wall of the colon the dataset in `data` was simulated through, each flat
/// `x y z …` (world frame, mm, closed by the page). Empty for a dataset that was not
/// simulated; when its colon cannot be rebuilt (a mesh file moved), why, in `missing`.
pub fn colon_wall(data: &Path, missing: &mut Vec<String>) -> Vec<Vec<f64>> {
    let meta_path = data.join("dataset.toml");
    let simulated = DatasetMeta::read(&meta_path).is_ok_and(|m| m.simulation.is_some());
    if !simulated {
        return Vec::new();
    }
    let colon = SimConfig::from_toml_file(&meta_path)
        .map_err(|e| e.to_string())
        .and_then(|cfg| endoloc_sim::simulate::build_colon(&cfg).map_err(|e| e.to_string()));
    match colon {
        Ok(colon) => wall_rings(&colon.mesh, WALL_RING_STEP_MM, WALL_RING_POINTS),
        Err(e) => {
            missing.push(format!("colon wall: {e}"));
            Vec::new()
        }
    }
}

/// Rings of `mesh` every `step_mm` of mid-line, each with about `points` vertices in order
/// around it (flat `x y z …`, rounded to 0.1 mm). A ring is the vertices whose arc length lies
/// within a quarter millimetre of a multiple of `step_mm`.
pub fn wall_rings(mesh: &SurfaceMesh, step_mm: f64, points: usize) -> Vec<Vec<f64>> {
    let mut rings: BTreeMap<i64, Vec<(f32, usize)>> = BTreeMap::new();
    for (i, (&s, &theta)) in mesh.s_mm.iter().zip(&mesh.theta).enumerate() {
        let k = (f64::from(s) / step_mm).round();
        if (f64::from(s) - k * step_mm).abs() <= 0.25 {
            rings.entry(k as i64).or_default().push((theta, i));
        }
    }
    rings
        .into_values()
        .filter(|r| r.len() >= 3)
        .map(|mut r| {
            r.sort_by(|a, b| a.0.total_cmp(&b.0));
            let every = (r.len() / points.max(3)).max(1);
            r.iter()
                .step_by(every)
                .flat_map(|&(_, i)| {
                    let p = mesh.positions[i];
                    [p.x, p.y, p.z].map(|v| (v * 10.0).round() / 10.0)
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in colon's rings lie on its wall, around its mid-line, one every 10 mm.
    #[test]
    fn rings_go_around_the_built_in_colon() {
        let cfg = SimConfig::preset(endoloc_sim::Preset::Small);
        let colon = endoloc_sim::simulate::build_colon(&cfg).unwrap();
        let rings = wall_rings(&colon.mesh, WALL_RING_STEP_MM, WALL_RING_POINTS);
        let length = colon.centerline.length_mm();
        let expected = (length / WALL_RING_STEP_MM) as usize;
        assert!(
            rings.len() + 2 >= expected && rings.len() <= expected + 2,
            "{} rings along {length:.0} mm",
            rings.len()
        );
        for ring in &rings {
            let n = ring.len() / 3;
            assert!(
                (WALL_RING_POINTS..=2 * WALL_RING_POINTS).contains(&n),
                "{n} points"
            );
            // The ring's centre is on the mid-line, its points a lumen radius from it.
            let c: Vec<f64> = (0..3)
                .map(|k| ring.iter().skip(k).step_by(3).sum::<f64>() / n as f64)
                .collect();
            let centre = nalgebra::Point3::new(c[0], c[1], c[2]);
            let off = colon.centerline.locate(&centre).radial_mm;
            assert!(off < 5.0, "ring centre {off:.1} mm off the mid-line");
            for p in ring.chunks_exact(3) {
                let r = (nalgebra::Point3::new(p[0], p[1], p[2]) - centre).norm();
                assert!(
                    (5.0..60.0).contains(&r),
                    "a wall point {r:.1} mm from the centre"
                );
            }
        }
    }
}
