//! Scope trajectories: a clinical pass from the anus to the caecum.
//!
//! A pass advances along the mid-line with a varying speed and a few short pauses; the tip
//! drifts laterally within the lumen (smooth, at most [`TrajectoryConfig::lateral_fraction`]
//! of the local lumen radius) and is kept at least [`TrajectoryConfig::clearance_mm`] from the
//! wall; the view direction wanders around the direction to a point `look_ahead_mm` further
//! along the mid-line, and the scope rolls slowly. Two passes with different seeds through the
//! same colon give independent `train` and `test` sequences.
//!
//! Every quantity is a smooth function of time, so [`PassGenerator::pose_at`] can be evaluated
//! between frames (used for motion blur).

use endoloc_data::Section;
use endoloc_geometry::Pose;
use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

use crate::SimError;
use crate::colon::ColonModel;

/// Arc length behind the scope whose wall counts for the clearance, mm.
const CLEARANCE_BEHIND_MM: f64 = 120.0;
/// Arc length ahead of the scope whose wall counts for the clearance, mm (covers the
/// renderer's default view).
const CLEARANCE_AHEAD_MM: f64 = 260.0;

/// Parameters of one pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrajectoryConfig {
    /// Number of frames.
    pub frames: usize,
    /// Frame rate, frames per second.
    pub fps: f64,
    /// Seed of this pass (speed, pauses, lateral drift, gaze).
    pub seed: u64,
    /// Largest lateral offset from the mid-line, as a fraction of the local lumen radius.
    pub lateral_fraction: f64,
    /// Smallest distance from the lens to the colon wall, mm.
    pub clearance_mm: f64,
    /// Distance along the mid-line to the point the scope looks towards, mm.
    pub look_ahead_mm: f64,
    /// Amplitude of the gaze wander (yaw and pitch), degrees.
    pub gaze_wander_deg: f64,
    /// Amplitude of the scope's roll about its axis, degrees.
    pub roll_wander_deg: f64,
    /// Relative speed variation (0 = constant speed).
    pub speed_variation: f64,
    /// Number of short pauses.
    pub pauses: usize,
    /// Length of each pause, seconds.
    pub pause_s: f64,
}

impl Default for TrajectoryConfig {
    fn default() -> Self {
        TrajectoryConfig {
            frames: 400,
            fps: 30.0,
            seed: 1,
            lateral_fraction: 0.35,
            clearance_mm: 3.0,
            look_ahead_mm: 30.0,
            gaze_wander_deg: 10.0,
            roll_wander_deg: 25.0,
            speed_variation: 0.45,
            pauses: 4,
            pause_s: 1.0,
        }
    }
}

impl TrajectoryConfig {
    /// Checks ranges.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] naming the first bad field.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |m: String| Err(SimError::InvalidConfig(format!("trajectory: {m}")));
        if self.frames < 2 {
            return bad(format!("frames must be at least 2, got {}", self.frames));
        }
        if !(self.fps.is_finite() && self.fps > 0.0) {
            return bad(format!("fps must be positive, got {}", self.fps));
        }
        if !(self.lateral_fraction.is_finite() && (0.0..0.95).contains(&self.lateral_fraction)) {
            return bad(format!(
                "lateral_fraction must be in [0, 0.95), got {}",
                self.lateral_fraction
            ));
        }
        for (name, v) in [
            ("clearance_mm", self.clearance_mm),
            ("look_ahead_mm", self.look_ahead_mm),
            ("gaze_wander_deg", self.gaze_wander_deg),
            ("roll_wander_deg", self.roll_wander_deg),
            ("speed_variation", self.speed_variation),
            ("pause_s", self.pause_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} must be ≥ 0, got {v}"));
            }
        }
        if self.look_ahead_mm < 1.0 {
            return bad(format!(
                "look_ahead_mm must be at least 1 mm, got {}",
                self.look_ahead_mm
            ));
        }
        Ok(())
    }
}

/// A generated pass: one pose per frame.
#[derive(Debug, Clone)]
pub struct Pass {
    /// Timestamps, seconds from the first frame.
    pub timestamps_s: Vec<f64>,
    /// Camera poses `T_wc`, mm.
    pub poses: Vec<Pose>,
    /// Arc length of the scope along the mid-line, mm.
    pub s_mm: Vec<f64>,
    /// Anatomical section of each frame.
    pub sections: Vec<Section>,
    /// Distance from the lens to the nearest wall triangle, mm.
    pub clearance_mm: Vec<f64>,
}

/// A sum of sinusoids normalised to `[-1, 1]`: smooth seeded noise over time (or arc length).
#[derive(Debug, Clone)]
pub(crate) struct Wave {
    terms: Vec<(f64, f64, f64)>, // amplitude, frequency (Hz), phase
}

impl Wave {
    /// Four terms of frequencies in `[f_lo, f_hi)` (per unit of the argument of [`Wave::at`]).
    pub(crate) fn new(rng: &mut ChaCha8Rng, f_lo: f64, f_hi: f64) -> Self {
        let terms: Vec<(f64, f64, f64)> = (0..4)
            .map(|_| {
                (
                    rng.random_range(0.5..1.0),
                    rng.random_range(f_lo..f_hi),
                    rng.random_range(0.0..TAU),
                )
            })
            .collect();
        let sum: f64 = terms.iter().map(|t| t.0).sum();
        Wave {
            terms: terms.into_iter().map(|(a, f, p)| (a / sum, f, p)).collect(),
        }
    }

    pub(crate) fn at(&self, t: f64) -> f64 {
        self.terms
            .iter()
            .map(|(a, f, p)| a * (TAU * f * t + p).sin())
            .sum()
    }
}

/// Evaluates a pass's pose at any time; see the module docs.
#[derive(Debug, Clone)]
pub struct PassGenerator<'a> {
    colon: &'a ColonModel,
    cfg: TrajectoryConfig,
    /// Arc length at each frame (the speed profile integrated), mm.
    s_frames: Vec<f64>,
    /// Smallest lumen radius around each mid-line sample, mm.
    lumen_radius: Vec<f64>,
    lateral: (Wave, Wave),
    gaze: (Wave, Wave),
    roll: Wave,
}

impl<'a> PassGenerator<'a> {
    /// Prepares a pass through `colon`.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] for an invalid config or a colon too short for a pass.
    pub fn new(colon: &'a ColonModel, cfg: &TrajectoryConfig) -> Result<Self, SimError> {
        cfg.validate()?;
        let (s0, s1) = colon.pass_range_mm;
        if !(s1 > s0 + 10.0) {
            return Err(SimError::InvalidConfig(format!(
                "the colon's pass range {s0:.1}–{s1:.1} mm is too short for a pass"
            )));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        let n = cfg.frames;
        // Speed profile with pauses, integrated and scaled to span the pass range exactly.
        let speed_wave = Wave::new(&mut rng, 0.02, 0.25);
        let mut w: Vec<f64> = (0..n)
            .map(|k| (1.0 + cfg.speed_variation * speed_wave.at(k as f64 / cfg.fps)).max(0.1))
            .collect();
        let pause_frames = (cfg.pause_s * cfg.fps).round() as usize;
        if pause_frames > 0 && n > 4 * pause_frames {
            for _ in 0..cfg.pauses {
                let start = rng.random_range(pause_frames..n - 2 * pause_frames);
                for k in 0..pause_frames {
                    // Smooth dip to almost standing still.
                    let x = k as f64 / pause_frames as f64;
                    let dip = (std::f64::consts::PI * x).sin();
                    w[start + k] *= 1.0 - 0.97 * dip;
                }
            }
        }
        let total: f64 = w[..n - 1].iter().sum();
        let mut s_frames = Vec::with_capacity(n);
        let mut acc = 0.0;
        s_frames.push(s0 + (s1 - s0) * (acc / total).min(1.0));
        for wk in &w[..n - 1] {
            acc += wk;
            s_frames.push(s0 + (s1 - s0) * (acc / total).min(1.0));
        }
        let lateral = (
            Wave::new(&mut rng, 0.03, 0.3),
            Wave::new(&mut rng, 0.03, 0.3),
        );
        let gaze = (
            Wave::new(&mut rng, 0.05, 0.5),
            Wave::new(&mut rng, 0.05, 0.5),
        );
        let roll = Wave::new(&mut rng, 0.01, 0.1);
        Ok(PassGenerator {
            colon,
            cfg: cfg.clone(),
            s_frames,
            lumen_radius: lumen_radius_profile(colon),
            lateral,
            gaze,
            roll,
        })
    }

    /// Arc length along the mid-line at fractional frame `t`, mm.
    pub fn s_at(&self, t: f64) -> f64 {
        let n = self.s_frames.len();
        let x = t.clamp(0.0, (n - 1) as f64);
        let i = (x.floor() as usize).min(n - 2);
        let f = x - i as f64;
        self.s_frames[i] * (1.0 - f) + self.s_frames[i + 1] * f
    }

    /// Pose `T_wc` at fractional frame `t`, the arc length there (mm), and the lens's distance
    /// to the wall (mm).
    pub fn pose_at(&self, t: f64) -> (Pose, f64, f64) {
        let time = t / self.cfg.fps;
        let s = self.s_at(t);
        let c = &self.colon.centerline;
        let centre = c.point_at(s);
        let (_, n, b) = c.frame_at(s);
        let r = self.lumen_radius[c.index_at(s)];
        let (ox, oy) = (self.lateral.0.at(time), self.lateral.1.at(time));
        let mag = (ox * ox + oy * oy).sqrt().max(1.0); // keep inside the unit disc
        let offset = (n * ox + b * oy) * (self.cfg.lateral_fraction * r / mag);
        let (p, clearance) = self.keep_clear(centre, offset, s);

        // View direction: towards a point further along, then gaze wander and roll.
        let target = c.point_at(s + self.cfg.look_ahead_mm);
        let mut z = target - p;
        if z.norm() < 1e-6 {
            z = c.frame_at(s).0;
        }
        let z = z.normalize();
        let mut y = n - z * z.dot(&n);
        if y.norm() < 1e-6 {
            y = b - z * z.dot(&b);
        }
        let y = y.normalize();
        let x = y.cross(&z);
        let base = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
        let amp = self.cfg.gaze_wander_deg.to_radians();
        let yaw = amp * self.gaze.0.at(time);
        let pitch = amp * self.gaze.1.at(time);
        let roll = self.cfg.roll_wander_deg.to_radians() * self.roll.at(time);
        let wander = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), pitch)
            * Rotation3::from_axis_angle(&Vector3::z_axis(), roll);
        let rot = UnitQuaternion::from_rotation_matrix(&(base * wander));
        let pose = endoloc_geometry::pose::pose_from_parts(p.coords, rot);
        (pose, s, clearance)
    }

    /// Shrinks the lateral offset (bisection) until the lens is `clearance_mm` from the wall;
    /// if even the mid-line is too close, steps away from the nearest wall point.
    fn keep_clear(&self, centre: Point3<f64>, offset: Vector3<f64>, s: f64) -> (Point3<f64>, f64) {
        // Every stretch of wall that can be drawn around the scope counts (with an inflated CT
        // mesh a neighbouring loop can come close).
        let window = (s - CLEARANCE_BEHIND_MM, s + CLEARANCE_AHEAD_MM);
        let need = self.cfg.clearance_mm;
        let dist = |p: &Point3<f64>| self.colon.distance_to_surface(p, window.0, window.1);
        let full = centre + offset;
        let (d_full, _) = dist(&full);
        if d_full >= need {
            return (full, d_full);
        }
        let (d_centre, _) = dist(&centre);
        if d_centre >= need {
            let (mut lo, mut hi) = (0.0, 1.0); // lo is clear, hi is not
            for _ in 0..20 {
                let mid = 0.5 * (lo + hi);
                if dist(&(centre + offset * mid)).0 >= need {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let p = centre + offset * lo;
            return (p, dist(&p).0);
        }
        // The mid-line itself is too close to a wall (a narrow or off-centre path): push away.
        let mut p = centre;
        let mut best = (centre, d_centre);
        for _ in 0..50 {
            let (d, q) = dist(&p);
            if d > best.1 {
                best = (p, d);
            }
            if d >= need {
                return (p, d);
            }
            let away = p - q;
            let dir = if away.norm() > 1e-9 {
                away.normalize()
            } else {
                (centre - q).normalize()
            };
            p += dir * (need - d + 0.05);
        }
        best
    }

    /// Generates every frame of the pass (in parallel).
    ///
    /// # Errors
    /// [`SimError::Clearance`] when the lumen somewhere along the pass is too narrow to keep
    /// the lens `clearance_mm` from every wall (a narrow scanned colon: inflate it or lower
    /// the clearance).
    pub fn generate(&self) -> Result<Pass, SimError> {
        let n = self.cfg.frames;
        let frames: Vec<(Pose, f64, f64)> = (0..n)
            .into_par_iter()
            .map(|k| self.pose_at(k as f64))
            .collect();
        if let Some((k, f)) = frames
            .iter()
            .enumerate()
            .find(|(_, f)| f.2 < self.cfg.clearance_mm - 1e-6)
        {
            return Err(SimError::Clearance {
                frame: k,
                s_mm: f.1,
                achieved_mm: f.2,
                required_mm: self.cfg.clearance_mm,
            });
        }
        Ok(Pass {
            timestamps_s: (0..n).map(|k| k as f64 / self.cfg.fps).collect(),
            sections: frames.iter().map(|f| self.colon.section_at(f.1)).collect(),
            s_mm: frames.iter().map(|f| f.1).collect(),
            clearance_mm: frames.iter().map(|f| f.2).collect(),
            poses: frames.into_iter().map(|f| f.0).collect(),
        })
    }

    /// The pass's config.
    pub fn config(&self) -> &TrajectoryConfig {
        &self.cfg
    }
}

/// Smallest distance from the mid-line to the wall vertices attached within ±5 mm of each
/// mid-line sample, mm (a conservative local lumen radius).
pub fn lumen_radius_profile(colon: &ColonModel) -> Vec<f64> {
    let c = &colon.centerline;
    let n = c.len();
    let mut min_r = vec![f64::INFINITY; n];
    for (v, p) in colon.mesh.positions.iter().enumerate() {
        let s = colon.mesh.s_mm[v] as f64;
        let i = c.index_at(s);
        let r = (p - c.point_at(s)).norm();
        if r < min_r[i] {
            min_r[i] = r;
        }
    }
    let half = (5.0 / c.step_mm).round() as usize;
    let fallback = min_r
        .iter()
        .copied()
        .filter(|r| r.is_finite())
        .fold(f64::INFINITY, f64::min);
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + half + 1).min(n);
            let r = min_r[lo..hi].iter().copied().fold(f64::INFINITY, f64::min);
            if r.is_finite() {
                r
            } else if fallback.is_finite() {
                fallback
            } else {
                1.0
            }
        })
        .collect()
}
