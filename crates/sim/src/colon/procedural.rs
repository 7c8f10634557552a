//! The built-in procedural large intestine: no files needed.
//!
//! The mid-line runs anus → rectum → sigmoid loop → descending colon (patient's left) →
//! splenic flexure → sagging transverse colon → hepatic flexure → ascending colon (right) →
//! caecum, through anatomical control points that are jittered by the seed and joined by a
//! centripetal Catmull-Rom spline, then smoothed until no bend is sharper than the lumen is
//! wide. World frame (a coronal view, as in the paper's Fig. 5): x towards the patient's
//! left, y cranial (towards the head), z anterior; mm.
//!
//! The lumen radius `r(s, θ)` combines a per-section radius, haustral folds between three
//! taeniae coli (none in the rectum, which has three Houston valves instead), a roughly
//! triangular cross-section in the transverse colon, the ileocaecal valve lip, and a
//! hemispherical caecal pole.

use endoloc_data::Section;
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

use super::{ColonModel, SurfaceMesh};
use crate::SimError;
use crate::centerline::{Centerline, moving_average};

/// Parameters of the procedural colon.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProceduralColonConfig {
    /// Seed of the anatomical variation (shape, radii, fold spacing).
    pub seed: u64,
    /// Standard deviation of the control-point jitter, mm.
    pub shape_jitter_mm: f64,
    /// Multiplies every lumen radius (1.0 = an insufflated adult colon).
    pub radius_scale: f64,
    /// Depth of the haustral folds as a fraction of the radius (0 = smooth tube).
    pub fold_depth: f64,
    /// Distance between surface rings, mm.
    pub ring_step_mm: f64,
    /// Vertices per ring.
    pub ring_segments: usize,
}

impl Default for ProceduralColonConfig {
    fn default() -> Self {
        ProceduralColonConfig {
            seed: 7,
            shape_jitter_mm: 6.0,
            radius_scale: 1.0,
            fold_depth: 0.3,
            ring_step_mm: 1.0,
            ring_segments: 96,
        }
    }
}

/// Per-section shape: nominal radius (mm), haustral fold spacing (mm, 0 = no haustra),
/// fold depth relative to [`ProceduralColonConfig::fold_depth`], and triangularity.
#[derive(Debug, Clone, Copy)]
struct SectionShape {
    radius_mm: f64,
    fold_period_mm: f64,
    fold_scale: f64,
    triangularity: f64,
}

fn shape_of(section: Section) -> SectionShape {
    let s = |radius_mm, fold_period_mm, fold_scale, triangularity| SectionShape {
        radius_mm,
        fold_period_mm,
        fold_scale,
        triangularity,
    };
    match section {
        Section::AnalCanal => s(11.0, 0.0, 0.0, 0.0),
        Section::Rectum => s(24.0, 0.0, 0.0, 0.0),
        Section::Rectosigmoid => s(17.0, 22.0, 0.7, 0.03),
        Section::Sigmoid => s(17.0, 20.0, 1.0, 0.04),
        Section::Descending => s(19.0, 24.0, 0.9, 0.05),
        Section::SplenicFlexure => s(21.0, 26.0, 0.8, 0.06),
        Section::Transverse => s(24.0, 30.0, 1.2, 0.15),
        Section::HepaticFlexure => s(23.0, 28.0, 0.9, 0.08),
        Section::Ascending => s(26.0, 32.0, 1.0, 0.06),
        Section::Caecum => s(31.0, 36.0, 0.5, 0.03),
    }
}

/// Scale applied to [`CONTROL_POINTS`]: brings the mid-line to about 1.4 m, an adult colon.
const BODY_SCALE: f64 = 1.12;

/// Anatomical control points (mm, before [`BODY_SCALE`]) and the section each one starts or continues.
const CONTROL_POINTS: &[([f64; 3], Section)] = &[
    ([0.0, -5.0, 0.0], Section::AnalCanal),
    ([0.0, 0.0, 0.0], Section::AnalCanal),
    ([0.0, 32.0, -6.0], Section::Rectum),
    ([3.0, 75.0, -28.0], Section::Rectum),
    ([6.0, 120.0, -36.0], Section::Rectum),
    ([12.0, 155.0, -22.0], Section::Rectosigmoid),
    ([22.0, 180.0, 0.0], Section::Sigmoid),
    ([-8.0, 205.0, 30.0], Section::Sigmoid),
    ([-22.0, 245.0, 55.0], Section::Sigmoid),
    ([15.0, 272.0, 72.0], Section::Sigmoid),
    ([68.0, 255.0, 62.0], Section::Sigmoid),
    ([92.0, 210.0, 40.0], Section::Sigmoid),
    ([118.0, 178.0, 15.0], Section::Sigmoid),
    ([135.0, 190.0, -5.0], Section::Descending),
    ([142.0, 265.0, -18.0], Section::Descending),
    ([142.0, 345.0, -22.0], Section::Descending),
    ([138.0, 405.0, -16.0], Section::SplenicFlexure),
    ([122.0, 440.0, 2.0], Section::SplenicFlexure),
    ([92.0, 445.0, 28.0], Section::Transverse),
    ([48.0, 405.0, 55.0], Section::Transverse),
    ([0.0, 352.0, 70.0], Section::Transverse),
    ([-52.0, 372.0, 62.0], Section::Transverse),
    ([-92.0, 418.0, 38.0], Section::HepaticFlexure),
    ([-118.0, 432.0, 10.0], Section::HepaticFlexure),
    ([-134.0, 405.0, -8.0], Section::Ascending),
    ([-138.0, 345.0, -12.0], Section::Ascending),
    ([-136.0, 290.0, -6.0], Section::Caecum),
    ([-132.0, 238.0, 2.0], Section::Caecum),
];

/// Builds the procedural colon.
///
/// # Errors
/// [`SimError::InvalidConfig`] for non-positive or non-finite parameters.
pub fn build(cfg: &ProceduralColonConfig) -> Result<ColonModel, SimError> {
    validate(cfg)?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let jitter = Normal::new(0.0, cfg.shape_jitter_mm.max(1e-12))
        .map_err(|e| SimError::InvalidConfig(format!("shape_jitter_mm: {e}")))?;
    let n_ctrl = CONTROL_POINTS.len();
    let ctrl: Vec<Point3<f64>> = CONTROL_POINTS
        .iter()
        .enumerate()
        .map(|(i, (p, _))| {
            let p = Point3::new(p[0], p[1], p[2]) * BODY_SCALE;
            // Keep the anus fixed; jitter the rest.
            if i < 2 || cfg.shape_jitter_mm == 0.0 {
                p
            } else {
                p + Vector3::new(
                    jitter.sample(&mut rng),
                    jitter.sample(&mut rng),
                    jitter.sample(&mut rng),
                )
            }
        })
        .collect();

    // Dense spline, remembering where each control point lands.
    let mut dense = Vec::new();
    let mut ctrl_dense_index = vec![0usize; n_ctrl];
    const SUB: usize = 40;
    for i in 0..n_ctrl - 1 {
        ctrl_dense_index[i] = dense.len();
        let p0 = ctrl[i.saturating_sub(1)];
        let p1 = ctrl[i];
        let p2 = ctrl[i + 1];
        let p3 = ctrl[(i + 2).min(n_ctrl - 1)];
        for k in 0..SUB {
            dense.push(catmull_rom_centripetal(
                p0,
                p1,
                p2,
                p3,
                k as f64 / SUB as f64,
            ));
        }
    }
    ctrl_dense_index[n_ctrl - 1] = dense.len();
    dense.push(ctrl[n_ctrl - 1]);
    let mut cumulative = vec![0.0; dense.len()];
    for i in 1..dense.len() {
        cumulative[i] = cumulative[i - 1] + (dense[i] - dense[i - 1]).norm();
    }
    // Arc length (before smoothing) where each section starts.
    let mut section_starts: Vec<(Section, f64)> = Vec::new();
    for (i, (_, sec)) in CONTROL_POINTS.iter().enumerate() {
        if section_starts.last().is_none_or(|l| l.0 != *sec) {
            section_starts.push((*sec, cumulative[ctrl_dense_index[i]]));
        }
    }
    // The first two control points only orient the anal canal: start the colon at the anus.
    let anus_s = cumulative[ctrl_dense_index[1]];
    let dense: Vec<Point3<f64>> = dense[ctrl_dense_index[1]..].to_vec();
    for s in &mut section_starts {
        s.1 = (s.1 - anus_s).max(0.0);
    }

    let step = 0.5;
    let mut centerline = Centerline::from_polyline(&dense, step)?;
    // Per-section radius variation.
    let radius_factor: Vec<f64> = Section::ALL
        .iter()
        .map(|_| rng.random_range(0.92..1.08))
        .collect();
    let period_factor: Vec<f64> = Section::ALL
        .iter()
        .map(|_| rng.random_range(0.9..1.1))
        .collect();
    let section_of = |s: f64, starts: &[(Section, f64)]| -> Section {
        starts
            .iter()
            .rev()
            .find(|(_, s0)| s >= *s0)
            .map_or(Section::AnalCanal, |(sec, _)| *sec)
    };
    // Smooth until no bend is sharper than 1.25 × the local radius (rings must not fold over).
    for _ in 0..200 {
        let worst = (1..centerline.len() - 1)
            .map(|i| {
                let s = i as f64 * step;
                let sec = section_of(s, &section_starts);
                let r = shape_of(sec).radius_mm * cfg.radius_scale * radius_factor[sec.index()];
                bend_radius(&centerline, i) / (1.25 * r)
            })
            .fold(f64::INFINITY, f64::min);
        if worst >= 1.0 {
            break;
        }
        centerline = centerline.smoothed(6);
    }
    // Smoothing shortens the curve slightly: rescale section starts to the new length.
    let original_length = section_starts
        .last()
        .map_or(0.0, |_| cumulative[cumulative.len() - 1] - anus_s);
    let scale = centerline.length_mm() / original_length.max(1e-9);
    for s in &mut section_starts {
        s.1 *= scale;
    }
    let sections: Vec<Section> = (0..centerline.len())
        .map(|i| section_of(i as f64 * step, &section_starts))
        .collect();

    let profile = RadiusProfile::new(
        &centerline,
        &sections,
        cfg,
        &radius_factor,
        &period_factor,
        &mut rng,
    );
    let mesh = tube_mesh(&centerline, &profile, cfg);
    let length = centerline.length_mm();
    // The pass ends in the caecum, 60 % of the way from its start to the pole (at least 15 mm
    // before the pole).
    let caecum_start = sections
        .iter()
        .position(|s| *s == Section::Caecum)
        .map_or(length - 60.0, |i| i as f64 * step);
    let end = (caecum_start + 0.6 * (length - caecum_start)).min(length - 15.0);
    Ok(ColonModel {
        pass_range_mm: (20.0, end),
        description: format!(
            "procedural colon (seed {}, {:.0} mm mid-line, {} vertices)",
            cfg.seed,
            length,
            mesh.positions.len()
        ),
        centerline,
        sections,
        mesh,
        notes: Vec::new(),
    })
}

fn validate(cfg: &ProceduralColonConfig) -> Result<(), SimError> {
    let bad = |name: &str, v: f64| {
        Err(SimError::InvalidConfig(format!(
            "procedural colon: {name} must be positive and finite, got {v}"
        )))
    };
    if !(cfg.radius_scale.is_finite() && cfg.radius_scale > 0.0) {
        return bad("radius_scale", cfg.radius_scale);
    }
    if !(cfg.ring_step_mm.is_finite() && cfg.ring_step_mm > 0.0) {
        return bad("ring_step_mm", cfg.ring_step_mm);
    }
    if !(cfg.shape_jitter_mm.is_finite() && cfg.shape_jitter_mm >= 0.0) {
        return bad("shape_jitter_mm", cfg.shape_jitter_mm);
    }
    if !(cfg.fold_depth.is_finite() && (0.0..0.8).contains(&cfg.fold_depth)) {
        return Err(SimError::InvalidConfig(format!(
            "procedural colon: fold_depth must be in [0, 0.8), got {}",
            cfg.fold_depth
        )));
    }
    if cfg.ring_segments < 8 {
        return Err(SimError::InvalidConfig(format!(
            "procedural colon: ring_segments must be at least 8, got {}",
            cfg.ring_segments
        )));
    }
    Ok(())
}

/// Radius of the circle through samples `i-k, i, i+k` (k = 10 samples), mm.
fn bend_radius(c: &Centerline, i: usize) -> f64 {
    let k = 10;
    let a = c.points[i.saturating_sub(k)];
    let b = c.points[i];
    let d = c.points[(i + k).min(c.len() - 1)];
    let (ab, bd, ad) = ((b - a).norm(), (d - b).norm(), (d - a).norm());
    let area2 = (b - a).cross(&(d - a)).norm();
    if area2 < 1e-9 {
        f64::INFINITY
    } else {
        ab * bd * ad / (2.0 * area2)
    }
}

fn catmull_rom_centripetal(
    p0: Point3<f64>,
    p1: Point3<f64>,
    p2: Point3<f64>,
    p3: Point3<f64>,
    t: f64,
) -> Point3<f64> {
    let knot = |a: Point3<f64>, b: Point3<f64>| (b - a).norm().sqrt().max(1e-6);
    let t0 = 0.0;
    let t1 = t0 + knot(p0, p1);
    let t2 = t1 + knot(p1, p2);
    let t3 = t2 + knot(p2, p3);
    let u = t1 + (t2 - t1) * t;
    let lerp = |a: Point3<f64>, b: Point3<f64>, ta: f64, tb: f64| {
        a.coords * ((tb - u) / (tb - ta)) + b.coords * ((u - ta) / (tb - ta))
    };
    let a1 = lerp(p0, p1, t0, t1);
    let a2 = lerp(p1, p2, t1, t2);
    let a3 = lerp(p2, p3, t2, t3);
    let b1 = a1 * ((t2 - u) / (t2 - t0)) + a2 * ((u - t0) / (t2 - t0));
    let b2 = a2 * ((t3 - u) / (t3 - t1)) + a3 * ((u - t1) / (t3 - t1));
    Point3::from(b1 * ((t2 - u) / (t2 - t1)) + b2 * ((u - t1) / (t2 - t1)))
}

/// The lumen radius as a function of arc length and angle.
struct RadiusProfile {
    step: f64,
    length: f64,
    /// Per mid-line sample: smoothed base radius, fold phase (cycles), fold scale,
    /// triangularity.
    base: Vec<f64>,
    phase: Vec<f64>,
    fold: Vec<f64>,
    tri: Vec<f64>,
    rectum: (f64, f64),
    caecum_start: f64,
    taenia_theta: f64,
    valve_theta: [f64; 3],
    icv_theta: f64,
    fold_depth: f64,
}

impl RadiusProfile {
    fn new(
        c: &Centerline,
        sections: &[Section],
        cfg: &ProceduralColonConfig,
        radius_factor: &[f64],
        period_factor: &[f64],
        rng: &mut ChaCha8Rng,
    ) -> Self {
        let n = c.len();
        let step = c.step_mm;
        let raw: Vec<SectionShape> = sections.iter().map(|s| shape_of(*s)).collect();
        let raw_radius: Vec<f64> = sections
            .iter()
            .zip(&raw)
            .map(|(s, sh)| sh.radius_mm * cfg.radius_scale * radius_factor[s.index()])
            .collect();
        // Blend section parameters over ±12 mm so the lumen changes smoothly.
        let half = (12.0 / step) as usize;
        let blend = |v: &dyn Fn(usize) -> f64| -> Vec<f64> {
            moving_average(&(0..n).map(v).collect::<Vec<f64>>(), half)
        };
        let base = blend(&|i| raw_radius[i]);
        let fold = blend(&|i| raw[i].fold_scale);
        let tri = blend(&|i| raw[i].triangularity);
        let mut phase = vec![rng.random_range(0.0..1.0); n];
        for i in 1..n {
            let p = raw[i].fold_period_mm * period_factor[sections[i].index()];
            phase[i] = phase[i - 1] + if p > 0.0 { step / p } else { 0.0 };
        }
        let range_of = |sec: Section| {
            let first = sections.iter().position(|s| *s == sec);
            let last = sections.iter().rposition(|s| *s == sec);
            match (first, last) {
                (Some(a), Some(b)) => (a as f64 * step, (b + 1) as f64 * step),
                _ => (0.0, 0.0),
            }
        };
        RadiusProfile {
            step,
            length: c.length_mm(),
            base,
            phase,
            fold,
            tri,
            rectum: range_of(Section::Rectum),
            caecum_start: range_of(Section::Caecum).0,
            taenia_theta: rng.random_range(0.0..TAU),
            valve_theta: [
                rng.random_range(0.0..TAU),
                rng.random_range(0.0..TAU),
                rng.random_range(0.0..TAU),
            ],
            icv_theta: rng.random_range(0.0..TAU),
            fold_depth: cfg.fold_depth,
        }
    }

    fn sample(&self, v: &[f64], s: f64) -> f64 {
        let x = (s / self.step).clamp(0.0, (v.len() - 1) as f64);
        let i = (x.floor() as usize).min(v.len().saturating_sub(2));
        let t = x - i as f64;
        v[i] * (1.0 - t) + v[(i + 1).min(v.len() - 1)] * t
    }

    fn base_radius(&self, s: f64) -> f64 {
        self.sample(&self.base, s)
    }

    /// Lumen radius at arc length `s` (mm) and angle `theta` (rad), mm.
    fn radius(&self, s: f64, theta: f64) -> f64 {
        let r0 = self.base_radius(s);
        let a = theta - self.taenia_theta;
        // 0 on a taenia, 1 half-way between two.
        let between = (1.5 * a).sin().abs().powf(0.7);
        let tri = self.sample(&self.tri, s);
        let mut r = r0 * (1.0 + tri * (3.0 * a).cos()) * (1.0 + 0.05 * between);

        // Haustral folds: narrow semilunar ridges between the taeniae.
        let fold_scale = self.sample(&self.fold, s);
        if fold_scale > 0.0 {
            let phase = self.sample(&self.phase, s);
            let period = self.step / (self.sample_derivative(s)).max(1e-9);
            let d = (phase.fract() - 0.5) * period; // mm from the fold crest
            let width = 2.2 + 0.04 * period;
            let ridge = (-(d / width).powi(2)).exp();
            // Folds are interrupted at the taeniae; strongly so where the lumen is triangular.
            let taenia = (0.35 + 2.5 * tri).min(0.8);
            r *= 1.0 - self.fold_depth * fold_scale * ridge * (1.0 - taenia * (1.0 - between));
        }

        // Three Houston valves in the rectum, each over half the circumference.
        let (r_lo, r_hi) = self.rectum;
        if s > r_lo && s < r_hi {
            for (k, vt) in self.valve_theta.iter().enumerate() {
                let sv = r_lo + (r_hi - r_lo) * (0.3 + 0.25 * k as f64);
                let ds = s - sv;
                let side = (theta - vt).cos().max(0.0).powf(1.5);
                r *= 1.0 - 0.35 * (-(ds / 3.0).powi(2)).exp() * side;
            }
        }

        // Ileocaecal valve: a lip on one side where the caecum begins.
        let ds = s - (self.caecum_start + 15.0);
        let dt = wrap_angle(theta - self.icv_theta);
        r *= 1.0 - 0.3 * (-(ds / 6.0).powi(2)).exp() * (-(dt / 0.45).powi(2)).exp();

        // Hemispherical caecal pole.
        let pole = self.base_radius(self.length);
        let into_pole = s - (self.length - pole);
        if into_pole > 0.0 {
            let x = (into_pole / pole).min(1.0);
            r *= (1.0 - x * x).max(0.0).sqrt();
        }
        r
    }

    /// Fold frequency (cycles per sample) at `s`.
    fn sample_derivative(&self, s: f64) -> f64 {
        let i = ((s / self.step) as usize).min(self.phase.len() - 2);
        self.phase[i + 1] - self.phase[i]
    }
}

fn wrap_angle(a: f64) -> f64 {
    let mut a = a % TAU;
    if a > PI {
        a -= TAU;
    } else if a < -PI {
        a += TAU;
    }
    a
}

fn tube_mesh(c: &Centerline, profile: &RadiusProfile, cfg: &ProceduralColonConfig) -> SurfaceMesh {
    super::tube_surface(c, cfg.ring_step_mm, cfg.ring_segments, |s, th| {
        profile.radius(s, th)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_colon_has_anatomical_length_and_all_sections_in_order() {
        let colon = build(&ProceduralColonConfig::default()).unwrap();
        let len = colon.centerline.length_mm();
        assert!((1300.0..=1500.0).contains(&len), "mid-line length {len} mm");
        let ranges = colon.section_ranges();
        let order: Vec<Section> = ranges.iter().map(|r| r.0).collect();
        assert_eq!(order, Section::ALL.to_vec(), "{ranges:?}");
        for (sec, a, b) in &ranges {
            assert!(b - a >= 20.0, "{sec} only {:.1} mm long", b - a);
        }
    }

    #[test]
    fn every_seed_gives_an_adult_length() {
        for seed in 0..12 {
            let colon = build(&ProceduralColonConfig {
                seed: crate::appearance::splitmix64(seed) >> 1,
                ..Default::default()
            })
            .unwrap();
            let len = colon.centerline.length_mm();
            assert!((1300.0..=1500.0).contains(&len), "seed {seed}: {len:.0} mm");
        }
    }

    #[test]
    fn seed_changes_shape_and_same_seed_repeats() {
        let a = build(&ProceduralColonConfig::default()).unwrap();
        let b = build(&ProceduralColonConfig::default()).unwrap();
        assert_eq!(a.mesh.positions, b.mesh.positions);
        let c = build(&ProceduralColonConfig {
            seed: 8,
            ..Default::default()
        })
        .unwrap();
        assert_ne!(a.mesh.positions.len(), 0);
        assert_ne!(a.centerline.points[500], c.centerline.points[500]);
    }

    #[test]
    fn rectum_is_smooth_and_sigmoid_is_haustrated() {
        let colon = build(&ProceduralColonConfig::default()).unwrap();
        // Radius variation along a line of constant θ: folds make it large.
        let variation = |sec: Section| {
            let (_, a, b) = *colon.section_ranges().iter().find(|r| r.0 == sec).unwrap();
            let m = colon.mesh.positions.len() / ((colon.mesh.s_mm.last().unwrap() + 1.0) as usize);
            let mut radii = Vec::new();
            for (i, p) in colon.mesh.positions.iter().enumerate().step_by(m) {
                let s = colon.mesh.s_mm[i] as f64;
                if s > a + 15.0 && s < b - 15.0 {
                    radii.push((p - colon.centerline.point_at(s)).norm());
                }
            }
            let mean = radii.iter().sum::<f64>() / radii.len() as f64;
            (radii.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / radii.len() as f64).sqrt()
                / mean
        };
        let rectum = variation(Section::Rectum);
        let sigmoid = variation(Section::Sigmoid);
        assert!(sigmoid > 2.0 * rectum, "sigmoid {sigmoid} rectum {rectum}");
    }

    #[test]
    fn invalid_config_is_an_error() {
        let err = build(&ProceduralColonConfig {
            radius_scale: -1.0,
            ..Default::default()
        })
        .unwrap_err();
        assert!(err.to_string().contains("radius_scale"));
    }
}
