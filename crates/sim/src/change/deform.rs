//! The shape change: a smooth, invertible map from the unchanged colon to the changed one.
//!
//! A point `p` at arc length `s` of the mid-line `c(s)` (frame `t, n, b`) moves to
//!
//! ```text
//! D(p) = c(s) + u(s) + R(s) · k(s, θ) · (p − c(s))
//! ```
//!
//! - `u(s)`: the mobile-segment shift, a smooth 3-D displacement of the mid-line weighted by
//!   how free each section hangs (sigmoid and transverse colon 1, flexures, recto-sigmoid and
//!   caecum ½, the retroperitoneal rest 0, blended over ±40 mm), peak `shift_mm`;
//! - `R(s)`: the rotation taking the mid-line's tangent `t(s)` to the shifted mid-line's
//!   `t + u′(s)`, so cross-sections turn with the segment;
//! - `k(s, θ) = ρ(s) + δ(s, θ) / r̄(s)`: insufflation `ρ(s) ∈ [1 − a, 1 + a]` and the local
//!   deformation `δ` (mm at the wall, `r̄(s)` the mean wall radius there), `θ` the angle of
//!   `p − c(s)` about the mid-line.
//!
//! Wall vertices use their own surface coordinate `s`; a camera uses the arc length of the
//! scope along the mid-line. Given `s`, the map inverts in closed form ([`Deformation::unmap_point`]),
//! and a pose turns by `R(s)` ([`Deformation::map_pose`]): the anatomical pose of a frame is
//! the changed pose carried back.

use endoloc_data::Section;
use endoloc_geometry::Pose;
use nalgebra::{Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::TAU;

use super::config::ShapeChange;
use crate::centerline::{Centerline, moving_average as smooth};
use crate::colon::ColonModel;
use crate::trajectory::Wave;

/// Smallest radial scale: the lumen never collapses below a fifth of its radius.
const MIN_SCALE: f64 = 0.2;

/// The shape change of one colon, tabulated along its mid-line.
#[derive(Debug, Clone)]
pub struct Deformation {
    centerline: Centerline,
    /// Mid-line shift `u(s)` at every mid-line sample, mm.
    shift: Vec<Vector3<f64>>,
    /// Rotation `R(s)` at every sample.
    rotation: Vec<UnitQuaternion<f64>>,
    /// Insufflation `ρ(s)` at every sample.
    radius_scale: Vec<f64>,
    /// Mean wall radius `r̄(s)` at every sample, mm.
    mean_radius: Vec<f64>,
    deform_mm: f64,
    /// 2π / wavelength of the local deformation, rad/mm.
    deform_k: f64,
    deform_phase: f64,
    lobe_phase: f64,
}

/// How freely a section moves between procedures (1: on a long mesentery).
fn mobility(section: Section) -> f64 {
    match section {
        Section::Sigmoid | Section::Transverse => 1.0,
        Section::SplenicFlexure
        | Section::HepaticFlexure
        | Section::Rectosigmoid
        | Section::Caecum => 0.5,
        Section::AnalCanal | Section::Rectum | Section::Descending | Section::Ascending => 0.0,
    }
}

impl Deformation {
    /// The shape change `shape` of `colon`, drawn from `seed`.
    pub fn new(colon: &ColonModel, shape: &ShapeChange, seed: u64) -> Self {
        let cl = &colon.centerline;
        let n = cl.len();
        let step = cl.step_mm;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let per_mm = |wavelength: f64| (0.7 / wavelength, 1.3 / wavelength);

        // Mobile-segment shift.
        let (lo, hi) = per_mm(shape.shift_wavelength_mm);
        let axes = [
            Wave::new(&mut rng, lo, hi),
            Wave::new(&mut rng, lo, hi),
            Wave::new(&mut rng, lo, hi),
        ];
        let raw_mobility: Vec<f64> = colon.sections.iter().map(|s| mobility(*s)).collect();
        let weight = smooth(&raw_mobility, (40.0 / step).round() as usize);
        let mut shift: Vec<Vector3<f64>> = (0..n)
            .map(|i| {
                let s = i as f64 * step;
                Vector3::new(axes[0].at(s), axes[1].at(s), axes[2].at(s)) * weight[i]
            })
            .collect();
        let peak = shift.iter().map(|u| u.norm()).fold(0.0, f64::max);
        let scale = if peak > 1e-12 {
            shape.shift_mm / peak
        } else {
            0.0
        };
        for u in &mut shift {
            *u *= scale;
        }

        // Cross-sections turn with the shifted mid-line.
        let h = ((5.0 / step).round() as usize).max(1);
        let rotation = (0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(h), (i + h).min(n - 1));
                if b == a {
                    return UnitQuaternion::identity();
                }
                let du = (shift[b] - shift[a]) / ((b - a) as f64 * step);
                let t = cl.tangents[i];
                let t2 = t + du;
                UnitQuaternion::rotation_between(&t, &t2).unwrap_or_else(UnitQuaternion::identity)
            })
            .collect();

        // Insufflation profile, peak exactly `insufflation`.
        let (lo, hi) = per_mm(shape.insufflation_wavelength_mm);
        let wave = Wave::new(&mut rng, lo, hi);
        let raw: Vec<f64> = (0..n).map(|i| wave.at(i as f64 * step)).collect();
        let peak = raw.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let radius_scale = raw
            .iter()
            .map(|v| {
                if peak > 1e-12 {
                    1.0 + shape.insufflation * v / peak
                } else {
                    1.0
                }
            })
            .collect();

        Deformation {
            centerline: cl.clone(),
            shift,
            rotation,
            radius_scale,
            mean_radius: mean_wall_radius(colon),
            deform_mm: shape.deform_mm,
            deform_k: TAU / shape.deform_wavelength_mm,
            deform_phase: rng.random_range(0.0..TAU),
            lobe_phase: rng.random_range(0.0..TAU),
        }
    }

    /// Sample index and fraction at arc length `s_mm` (clamped to the mid-line).
    fn at(&self, s_mm: f64) -> (usize, f64) {
        let n = self.shift.len();
        if n < 2 {
            return (0, 0.0);
        }
        let x = (s_mm / self.centerline.step_mm).clamp(0.0, (n - 1) as f64);
        let i = (x.floor() as usize).min(n - 2);
        (i, x - i as f64)
    }

    /// Mid-line shift `u(s)`, mm.
    pub fn shift_at(&self, s_mm: f64) -> Vector3<f64> {
        let (i, f) = self.at(s_mm);
        match self.shift.get(i + 1) {
            Some(next) => self.shift[i].lerp(next, f),
            None => self.shift.first().copied().unwrap_or_else(Vector3::zeros),
        }
    }

    /// Rotation `R(s)` of the cross-section at arc length `s_mm`.
    pub fn rotation_at(&self, s_mm: f64) -> UnitQuaternion<f64> {
        let (i, f) = self.at(s_mm);
        match self.rotation.get(i + 1) {
            Some(next) => self.rotation[i].nlerp(next, f),
            None => self
                .rotation
                .first()
                .copied()
                .unwrap_or_else(UnitQuaternion::identity),
        }
    }

    fn lerp(values: &[f64], (i, f): (usize, f64)) -> f64 {
        match values.get(i + 1) {
            Some(next) => values[i] + (next - values[i]) * f,
            None => values.first().copied().unwrap_or(1.0),
        }
    }

    /// Radial scale `k(s, θ)` (insufflation and local deformation).
    pub fn radial_scale(&self, s_mm: f64, theta: f64) -> f64 {
        let at = self.at(s_mm);
        let rho = Self::lerp(&self.radius_scale, at);
        let local = if self.deform_mm > 0.0 {
            let r = Self::lerp(&self.mean_radius, at).max(1.0);
            let wave = (self.deform_k * s_mm + self.deform_phase).sin();
            let lobes = 0.75 + 0.25 * (3.0 * theta + self.lobe_phase).cos();
            self.deform_mm * wave * lobes / r
        } else {
            0.0
        };
        (rho + local).max(MIN_SCALE)
    }

    /// The largest mid-line shift, mm.
    pub fn peak_shift_mm(&self) -> f64 {
        self.shift.iter().map(|u| u.norm()).fold(0.0, f64::max)
    }

    /// Where `p` (world, mm), at arc length `s_mm` of the unchanged mid-line, lies in the
    /// changed colon.
    pub fn map_point(&self, p: &Point3<f64>, s_mm: f64) -> Point3<f64> {
        let c = self.centerline.point_at(s_mm);
        let (_, n, b) = self.centerline.frame_at(s_mm);
        let d = p - c;
        let theta = d.dot(&b).atan2(d.dot(&n));
        let k = self.radial_scale(s_mm, theta);
        c + self.shift_at(s_mm) + self.rotation_at(s_mm) * (d * k)
    }

    /// Inverse of [`Deformation::map_point`] for the same `s_mm`: the unchanged colon's point
    /// that moved to `q`.
    pub fn unmap_point(&self, q: &Point3<f64>, s_mm: f64) -> Point3<f64> {
        let c = self.centerline.point_at(s_mm);
        let (_, n, b) = self.centerline.frame_at(s_mm);
        let d = self.rotation_at(s_mm).inverse() * (q - c - self.shift_at(s_mm));
        let theta = d.dot(&b).atan2(d.dot(&n));
        c + d / self.radial_scale(s_mm, theta)
    }

    /// A camera pose `T_wc` of the unchanged colon with the scope at `s_mm`, carried into the
    /// changed colon: centre by [`Deformation::map_point`], orientation turned by `R(s)`.
    pub fn map_pose(&self, pose: &Pose, s_mm: f64) -> Pose {
        let centre = self.map_point(&Point3::from(pose.translation.vector), s_mm);
        Pose::from_parts(
            Translation3::from(centre.coords),
            self.rotation_at(s_mm) * pose.rotation,
        )
    }

    /// Inverse of [`Deformation::map_pose`]: the anatomical pose of a camera of the changed
    /// colon.
    pub fn unmap_pose(&self, pose: &Pose, s_mm: f64) -> Pose {
        let centre = self.unmap_point(&Point3::from(pose.translation.vector), s_mm);
        Pose::from_parts(
            Translation3::from(centre.coords),
            self.rotation_at(s_mm).inverse() * pose.rotation,
        )
    }

    /// The changed colon: every wall vertex carried by the map, normals and bounds recomputed,
    /// the mid-line shifted and its frames turned. Surface coordinates, sections and chunks
    /// are those of `colon` (the texture moves with the wall).
    pub fn apply(&self, colon: &ColonModel) -> ColonModel {
        let mesh = &colon.mesh;
        let positions: Vec<Point3<f64>> = mesh
            .positions
            .iter()
            .zip(&mesh.s_mm)
            .map(|(p, s)| self.map_point(p, *s as f64))
            .collect();
        let hint = |v: usize| {
            let s = mesh.s_mm[v] as f64;
            self.centerline.point_at(s) + self.shift_at(s)
        };
        let mesh = mesh.with_positions(positions, hint);
        let mut centerline = colon.centerline.clone();
        for (i, p) in centerline.points.iter_mut().enumerate() {
            *p += self.shift[i];
            let r = self.rotation[i];
            centerline.tangents[i] = r * centerline.tangents[i];
            centerline.normals[i] = r * centerline.normals[i];
            centerline.binormals[i] = r * centerline.binormals[i];
        }
        ColonModel {
            centerline,
            mesh,
            description: format!("{} (changed)", colon.description),
            ..colon.clone()
        }
    }
}

/// Mean distance of the wall vertices from the mid-line at every mid-line sample (±5 mm),
/// mm; samples without vertices take their nearest neighbour's.
fn mean_wall_radius(colon: &ColonModel) -> Vec<f64> {
    let cl = &colon.centerline;
    let n = cl.len();
    let mut sum = vec![0.0; n];
    let mut count = vec![0usize; n];
    for (p, s) in colon.mesh.positions.iter().zip(&colon.mesh.s_mm) {
        let s = *s as f64;
        let i = cl.index_at(s);
        sum[i] += (p - cl.point_at(s)).norm();
        count[i] += 1;
    }
    let mut radius: Vec<Option<f64>> = (0..n)
        .map(|i| (count[i] > 0).then(|| sum[i] / count[i] as f64))
        .collect();
    // Fill gaps forwards then backwards.
    let mut last = None;
    for r in radius.iter_mut() {
        match r {
            Some(v) => last = Some(*v),
            None => *r = last,
        }
    }
    let mut next = None;
    for r in radius.iter_mut().rev() {
        match r {
            Some(v) => next = Some(*v),
            None => *r = next,
        }
    }
    let filled: Vec<f64> = radius.into_iter().map(|r| r.unwrap_or(20.0)).collect();
    smooth(&filled, (5.0 / cl.step_mm).round() as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::change::config::{ChangeConfig, Severity};
    use crate::colon::procedural::{self, ProceduralColonConfig};

    fn colon() -> ColonModel {
        procedural::build(&ProceduralColonConfig {
            ring_segments: 24,
            ring_step_mm: 4.0,
            ..ProceduralColonConfig::default()
        })
        .unwrap()
    }

    #[test]
    fn points_and_poses_round_trip_and_shifts_reach_their_peak() {
        let colon = colon();
        let shape = ChangeConfig::preset(Severity::Severe).shape;
        let d = Deformation::new(&colon, &shape, 5);
        assert!((d.peak_shift_mm() - shape.shift_mm).abs() < 1e-9);
        let len = colon.centerline.length_mm();
        let mut worst: f64 = 0.0;
        for k in 0..200 {
            let s = len * k as f64 / 199.0;
            let c = colon.centerline.point_at(s);
            let (_, n, b) = colon.centerline.frame_at(s);
            let p = c + n * (3.0 + k as f64 % 9.0) + b * 2.0;
            let q = d.map_point(&p, s);
            worst = worst.max((d.unmap_point(&q, s) - p).norm());
            let pose = Pose::from_parts(
                Translation3::from(p.coords),
                UnitQuaternion::from_euler_angles(0.1 * k as f64, 0.2, -0.3),
            );
            let back = d.unmap_pose(&d.map_pose(&pose, s), s);
            worst = worst.max((back.translation.vector - pose.translation.vector).norm());
            assert!(back.rotation.angle_to(&pose.rotation) < 1e-9);
        }
        assert!(worst < 1e-6, "round trip off by {worst} mm");
        // Fixed sections stay (nearly) where they were: the rectum's start does not move.
        assert!(d.shift_at(20.0).norm() < 1e-6);
    }

    #[test]
    fn the_changed_wall_is_the_mapped_wall() {
        let colon = colon();
        let shape = ChangeConfig::preset(Severity::Moderate).shape;
        let d = Deformation::new(&colon, &shape, 1);
        let changed = d.apply(&colon);
        for v in (0..colon.mesh.positions.len()).step_by(97) {
            let s = colon.mesh.s_mm[v] as f64;
            let moved = changed.mesh.positions[v];
            assert!((d.map_point(&colon.mesh.positions[v], s) - moved).norm() < 1e-12);
            assert!((d.unmap_point(&moved, s) - colon.mesh.positions[v]).norm() < 0.01);
            // The normal still points into the lumen.
            let n = changed.mesh.normals[v].cast::<f64>();
            assert!(n.dot(&(changed.centerline.point_at(s) - moved)) > 0.0);
        }
        // The lumen radius changes by at most the insufflation and the local deformation.
        let mean = |m: &crate::colon::SurfaceMesh, cl: &Centerline| {
            m.positions
                .iter()
                .zip(&m.s_mm)
                .map(|(p, s)| (p - cl.point_at(*s as f64)).norm())
                .sum::<f64>()
                / m.positions.len() as f64
        };
        let ratio = mean(&changed.mesh, &changed.centerline) / mean(&colon.mesh, &colon.centerline);
        assert!((ratio - 1.0).abs() < shape.insufflation + 0.1, "{ratio}");
    }
}
