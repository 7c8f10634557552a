//! The live motion model: a damped constant-velocity prediction on SE(3) from the recent
//! refined frames, and the gate that a new registration must pass against it.
//!
//! A colonoscope moves less than a millimetre between frames at 30 fps, so a registration that
//! lands centimetres from where the last refined frames say the scope is, supported by only a
//! handful of inliers, is far more likely a spurious consensus in a wrong zone than a real
//! jump. The model:
//!
//! - **Velocity** in the camera's own frame: `ξ = log(T₀⁻¹ · T₁) / (f₁ − f₀)` per frame, from the
//!   last refined pose `T₁` (frame `f₁`) and the oldest refined pose `T₀` at most
//!   [`MotionConfig::velocity_frames`] frames before it (none from a single pose).
//! - **Prediction** `age = f − f₁` frames later: `T₁ · exp(ξ · d)` with the damped displacement
//!   `d = Σ_{k<age} λᵏ` (`λ` = [`MotionConfig::damping`]): the scope is assumed to slow down
//!   when nothing confirms its motion. With confirmation against the map (the CLI's default,
//!   [`crate::ConfirmConfig`]) the refined poses behind the velocity are trustworthy enough to
//!   extrapolate further: the translation `ρ` of `ξ = [ρ; φ]` is damped by
//!   [`MotionConfig::confirmed_damping`] (1: a scope keeps advancing through a stretch it
//!   cannot register, where a prediction that stands still falls behind by its speed every
//!   frame), the rotation `φ` still by `λ` (the view direction wanders and swings back), and a
//!   velocity faster than the training pass's 95th-percentile step per frame is first scaled
//!   down to it ([`Gate::max_step_mm`]). Without confirmation a drifting chain of weak
//!   registrations, each agreeing with the prediction, would feed an undamped prediction its
//!   own drift. Poses are `T_wc` (camera-to-world, mm).
//! - **Gate** ([`Gate`]): a registration agrees with the prediction when its camera centre
//!   lies within `gate_mm + v · age` and its orientation within `gate_deg + ω · age` of it,
//!   where `v` is [`MotionConfig::gate_mm_per_frame`] or, when the training pass moves faster
//!   per frame (a fast pass, a subsampled recording), its 95th-percentile step between
//!   consecutive frames; `ω` likewise in degrees.

use std::collections::VecDeque;

use endoloc_geometry::{Pose, orientation_error_deg, position_error_mm, se3};
use nalgebra::Vector6;
use serde::{Deserialize, Serialize};

/// Settings of the live motion model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotionConfig {
    /// Per-frame damping `λ` of the velocity while no frame is refined, in `[0, 1]`
    /// (0 = hold the last pose, 1 = undamped constant velocity).
    pub damping: f64,
    /// With confirmation against the map: per-frame damping of the translational velocity
    /// instead of [`MotionConfig::damping`], in `[0, 1]` (see the module docs).
    pub confirmed_damping: f64,
    /// The velocity is measured over at most this many frames before the last refined one.
    pub velocity_frames: usize,
    /// Gate on the camera centre: base distance from the prediction, mm.
    pub gate_mm: f64,
    /// Gate on the camera centre: growth per frame of the prediction's age, mm (at least the
    /// training pass's 95th-percentile step between consecutive frames).
    pub gate_mm_per_frame: f64,
    /// Gate on the orientation: base angle from the prediction, degrees.
    pub gate_deg: f64,
    /// Gate on the orientation: growth per frame of the prediction's age, degrees (at least
    /// the training pass's 95th-percentile rotation between consecutive frames).
    pub gate_deg_per_frame: f64,
    /// A registration with at least this many inliers is trusted without the prediction's
    /// agreement (and restarts the track); below it, a registration must agree with the
    /// prediction — or, when there is none or it has failed, with the previous frame's
    /// registration.
    pub trusted_inliers: usize,
    /// Guided matching from the prediction: a map point competes for the features within
    /// this many pixels of its projection ([`crate::guided`]). 0: brute-force matching
    /// against the predicted zone's map points, as for an untracked frame.
    pub search_px: f64,
    /// Growth of the search radius per frame of the prediction's age, pixels.
    pub search_px_per_frame: f64,
}

impl Default for MotionConfig {
    fn default() -> Self {
        MotionConfig {
            damping: 0.9,
            confirmed_damping: 1.0,
            velocity_frames: 5,
            gate_mm: 3.0,
            gate_mm_per_frame: 1.0,
            gate_deg: 6.0,
            gate_deg_per_frame: 1.5,
            trusted_inliers: 30,
            search_px: 40.0,
            search_px_per_frame: 10.0,
        }
    }
}

impl MotionConfig {
    /// Checks the settings.
    ///
    /// # Errors
    /// A message naming the first setting out of range.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("damping", self.damping),
            ("confirmed_damping", self.confirmed_damping),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(format!("motion.{name} = {v}; expected 0..=1"));
            }
        }
        for (name, v) in [
            ("gate_mm", self.gate_mm),
            ("gate_mm_per_frame", self.gate_mm_per_frame),
            ("gate_deg", self.gate_deg),
            ("gate_deg_per_frame", self.gate_deg_per_frame),
            ("search_px", self.search_px),
            ("search_px_per_frame", self.search_px_per_frame),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("motion.{name} = {v}; expected a finite value >= 0"));
            }
        }
        Ok(())
    }
}

/// The gate's radii for one recording: [`MotionConfig`]'s, widened to the training pass's
/// own speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gate {
    /// Base radius on the camera centre, mm.
    pub mm: f64,
    /// Growth per frame of age, mm.
    pub mm_per_frame: f64,
    /// Base angle, degrees.
    pub deg: f64,
    /// Growth per frame of age, degrees.
    pub deg_per_frame: f64,
    /// Fastest step of the prediction per frame (the training pass's 95th-percentile step
    /// between consecutive frames), mm; 0 = no limit.
    pub max_step_mm: f64,
    /// The same for the rotation, degrees.
    pub max_step_deg: f64,
}

impl Gate {
    /// The gate of `cfg` for a recording whose training pass is `train` (`T_wc`, mm, in frame
    /// order): the per-frame growth is at least the pass's 95th-percentile step.
    pub fn new(cfg: &MotionConfig, train: &[Pose]) -> Self {
        let (step_mm, step_deg) = step_p95(train);
        Gate {
            mm: cfg.gate_mm,
            mm_per_frame: cfg.gate_mm_per_frame.max(step_mm),
            deg: cfg.gate_deg,
            deg_per_frame: cfg.gate_deg_per_frame.max(step_deg),
            max_step_mm: step_mm,
            max_step_deg: step_deg,
        }
    }
}

/// The 95th percentiles of the camera-centre distance (mm) and rotation angle (degrees)
/// between consecutive poses; zeros for fewer than two poses.
pub fn step_p95(poses: &[Pose]) -> (f64, f64) {
    let mut mm: Vec<f64> = poses
        .windows(2)
        .map(|w| position_error_mm(&w[1], &w[0]))
        .collect();
    let mut deg: Vec<f64> = poses
        .windows(2)
        .map(|w| orientation_error_deg(&w[1], &w[0]))
        .collect();
    let p95 = |v: &mut Vec<f64>| {
        if v.is_empty() {
            return 0.0;
        }
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * 0.95).round() as usize]
    };
    (p95(&mut mm), p95(&mut deg))
}

/// A predicted pose and how old the evidence behind it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Predicted `T_wc`, mm.
    pub t_wc: Pose,
    /// Frames since the last refined frame (≥ 1).
    pub age: usize,
}

/// How far a registration lies from a prediction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disagreement {
    /// Distance between the camera centres, mm.
    pub position_mm: f64,
    /// Angle between the orientations, degrees.
    pub orientation_deg: f64,
    /// Whether both are inside the gate.
    pub agrees: bool,
}

/// The recent refined frames of a live stream.
#[derive(Debug, Clone, Default)]
pub struct Track {
    /// `(frame, T_wc)` of the recent refined frames, oldest first.
    poses: VecDeque<(usize, Pose)>,
}

impl Track {
    /// Forgets every pose.
    pub fn clear(&mut self) {
        self.poses.clear();
    }

    /// The last refined frame and its pose.
    pub fn last(&self) -> Option<(usize, Pose)> {
        self.poses.back().copied()
    }

    /// Adds the refined pose of `frame` (frames in increasing order).
    pub fn push(&mut self, frame: usize, t_wc: Pose, cfg: &MotionConfig) {
        self.poses.push_back((frame, t_wc));
        while let Some(&(f0, _)) = self.poses.front() {
            if frame - f0 > cfg.velocity_frames {
                self.poses.pop_front();
            } else {
                break;
            }
        }
    }

    /// The per-frame velocity `ξ` in the camera frame (see the module docs); zero from a
    /// single pose.
    pub fn velocity(&self) -> Vector6<f64> {
        match (self.poses.front(), self.poses.back()) {
            (Some(&(f0, t0)), Some(&(f1, t1))) if f1 > f0 => {
                se3::log(&(t0.inverse() * t1)) / (f1 - f0) as f64
            }
            _ => Vector6::zeros(),
        }
    }

    /// The prediction for `frame` (after the last refined frame), or `None` without a refined
    /// frame within `horizon` frames before it. `confirmed`: the gate of a recording whose
    /// registrations are confirmed against the map; the translation is then damped by
    /// [`MotionConfig::confirmed_damping`] and the velocity capped at the step the gate allows
    /// per frame ([`Gate::max_step_mm`], [`Gate::max_step_deg`]), as the module docs describe.
    pub fn predict(
        &self,
        frame: usize,
        horizon: usize,
        cfg: &MotionConfig,
        confirmed: Option<&Gate>,
    ) -> Option<Prediction> {
        let (f1, t1) = self.last()?;
        let age = frame.checked_sub(f1).filter(|a| *a >= 1 && *a <= horizon)?;
        let displacement = |lambda: f64| -> f64 { (0..age).map(|k| lambda.powi(k as i32)).sum() };
        let xi = self.velocity();
        let Some(gate) = confirmed else {
            return Some(Prediction {
                t_wc: t1 * se3::exp(&(xi * displacement(cfg.damping))),
                age,
            });
        };
        // Scale the velocity down to the gate's fastest step (a limit of 0 = none).
        let ratio = |limit: f64, speed: f64| {
            if limit > 0.0 && speed > limit {
                limit / speed
            } else {
                1.0
            }
        };
        let scale = ratio(gate.max_step_mm, xi.fixed_rows::<3>(0).norm()).min(ratio(
            gate.max_step_deg,
            xi.fixed_rows::<3>(3).norm().to_degrees(),
        ));
        let mut step = xi * scale;
        step.fixed_rows_mut::<3>(0)
            .scale_mut(displacement(cfg.confirmed_damping));
        step.fixed_rows_mut::<3>(3)
            .scale_mut(displacement(cfg.damping));
        Some(Prediction {
            t_wc: t1 * se3::exp(&step),
            age,
        })
    }
}

impl Prediction {
    /// How far `t_wc` lies from this prediction, and whether it is inside the gate.
    pub fn compare(&self, t_wc: &Pose, gate: &Gate) -> Disagreement {
        let position_mm = position_error_mm(t_wc, &self.t_wc);
        let orientation_deg = orientation_error_deg(t_wc, &self.t_wc);
        let age = self.age as f64;
        let agrees = position_mm <= gate.mm + gate.mm_per_frame * age
            && orientation_deg <= gate.deg + gate.deg_per_frame * age;
        Disagreement {
            position_mm,
            orientation_deg,
            agrees,
        }
    }

    /// Whether this prediction vouches for a pose `t_wc` whose own evidence is weak: it
    /// agrees with the prediction ([`Prediction::compare`]) and is sharp enough for that
    /// agreement to mean something, its 95 % bound as a measurement (1.96 ×
    /// `measurement_std_mm`, mm; [`FrameResult::measurement_std_mm`](crate::FrameResult::measurement_std_mm))
    /// inside the gate's base radius [`Gate::mm`]. A pose less certain than that agrees with
    /// the prediction whether it is right or not. A NaN standard deviation never vouches.
    pub fn vouches_for(&self, t_wc: &Pose, measurement_std_mm: f64, gate: &Gate) -> bool {
        endoloc_geometry::BOUND95_PER_STD * measurement_std_mm <= gate.mm
            && self.compare(t_wc, gate).agrees
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    fn pose(x: f64, yaw: f64) -> Pose {
        Pose::from_parts(
            Translation3::new(x, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
        )
    }

    #[test]
    fn constant_motion_is_extrapolated_and_damped() {
        let cfg = MotionConfig {
            damping: 1.0,
            ..MotionConfig::default()
        };
        // A screw motion: the same step in the camera frame every frame.
        let step = pose(0.5, 0.01);
        let at = |f: usize| (0..f).fold(pose(10.0, 0.3), |t, _| t * step);
        let mut track = Track::default();
        for f in 0..4 {
            track.push(f, at(f), &cfg);
        }
        let p = track.predict(6, 60, &cfg, None).unwrap();
        assert_eq!(p.age, 3);
        assert!(position_error_mm(&p.t_wc, &at(6)) < 1e-9);
        assert!(orientation_error_deg(&p.t_wc, &at(6)) < 1e-6);
        // Damped: the scope is assumed to slow down.
        let damped = MotionConfig::default();
        let p = track.predict(6, 60, &damped, None).unwrap();
        let (from_last, to_truth) = (
            position_error_mm(&p.t_wc, &at(3)),
            position_error_mm(&at(6), &at(3)),
        );
        assert!(
            from_last > 0.5 * to_truth && from_last < to_truth,
            "{from_last} vs {to_truth}"
        );
        // Too old: no prediction.
        assert!(track.predict(100, 60, &cfg, None).is_none());
    }

    #[test]
    fn confirmed_translation_coasts_rotation_settles_and_a_jump_is_capped() {
        // The training pass moves 0.5 mm and 1° per frame.
        let train: Vec<Pose> = (0..20)
            .map(|f| pose(0.5 * f as f64, (f as f64).to_radians()))
            .collect();
        let gate = Gate::new(&MotionConfig::default(), &train);
        let cfg = MotionConfig::default();
        let mut track = Track::default();
        let step = pose(0.4, 0.5f64.to_radians());
        let at = |f: usize| (0..f).fold(pose(10.0, 0.3), |t, _| t * step);
        for f in 0..4 {
            track.push(f, at(f), &cfg);
        }
        // 30 frames (12 mm) on: the position keeps up with the scope where a damped one stands
        // still; the rotation has settled.
        let p = track.predict(33, 60, &cfg, Some(&gate)).unwrap();
        let behind = position_error_mm(&p.t_wc, &at(33));
        let stale = track.predict(33, 60, &cfg, None).unwrap();
        let stale_behind = position_error_mm(&stale.t_wc, &at(33));
        assert!(
            behind < 1.5 && stale_behind > 5.0,
            "{behind} vs {stale_behind} mm"
        );
        let turned = orientation_error_deg(&p.t_wc, &at(3));
        assert!(turned > 3.0 && turned < 5.0, "{turned}°");
        // A registration 10 mm off moves the prediction by at most the pass's step per frame.
        let mut jumped = Track::default();
        jumped.push(0, pose(0.0, 0.0), &cfg);
        jumped.push(1, pose(10.0, 0.0), &cfg);
        let p = jumped.predict(5, 60, &cfg, Some(&gate)).unwrap();
        let moved = position_error_mm(&p.t_wc, &pose(10.0, 0.0));
        assert!((moved - 4.0 * gate.max_step_mm).abs() < 1e-6, "{moved} mm");
    }

    #[test]
    fn the_gate_grows_with_age_and_with_the_training_pass_speed() {
        let cfg = Gate::new(&MotionConfig::default(), &[]);
        let p = Prediction {
            t_wc: pose(0.0, 0.0),
            age: 1,
        };
        assert!(p.compare(&pose(3.5, 0.0), &cfg).agrees);
        assert!(!p.compare(&pose(10.0, 0.0), &cfg).agrees);
        let old = Prediction { age: 8, ..p };
        assert!(old.compare(&pose(10.0, 0.0), &cfg).agrees);
        assert!(!p.compare(&pose(0.0, 0.5), &cfg).agrees);
        // A pass that moves 5 mm per frame widens the gate to 3 + 5 mm at age 1.
        let fast: Vec<Pose> = (0..20).map(|f| pose(5.0 * f as f64, 0.0)).collect();
        let gate = Gate::new(&MotionConfig::default(), &fast);
        assert_eq!(gate.mm_per_frame, 5.0);
        assert!(p.compare(&pose(7.5, 0.0), &gate).agrees);
        assert!(!p.compare(&pose(7.5, 0.0), &cfg).agrees);
    }

    #[test]
    fn a_weak_pose_is_vouched_for_only_when_it_agrees_and_is_sharp() {
        let gate = Gate::new(&MotionConfig::default(), &[]);
        let p = Prediction {
            t_wc: pose(0.0, 0.0),
            age: 1,
        };
        let near = pose(2.0, 0.0);
        assert!(p.vouches_for(&near, 0.5, &gate));
        // 1.96 × 1.5 mm = 2.94 mm fits the 3 mm base radius; 1.96 × 2.6 mm does not, though
        // the pose is as close.
        assert!(p.vouches_for(&near, 1.5, &gate));
        assert!(!p.vouches_for(&near, 2.6, &gate));
        assert!(!p.vouches_for(&near, f64::NAN, &gate));
        assert!(!p.vouches_for(&pose(10.0, 0.0), 0.5, &gate));
    }
}
