//! The settings of a change between the passes: severity presets and every factor.

use serde::{Deserialize, Serialize};

use crate::SimError;

/// How much the colon changes between the passes: one setting for every factor.
///
/// | factor | mild | moderate | severe |
/// |---|---|---|---|
/// | mobile-segment shift, peak | 5 mm | 15 mm | 30 mm |
/// | lumen radius (insufflation) | ±7 % | ±15 % | ±25 % |
/// | local deformation | 0.7 mm | 2 mm | 4 mm |
/// | exposure gain over the pass | 0.85–1.2 | 0.7–1.4 | 0.5–1.8 |
/// | gamma | 1.05 | 1.15 | 1.3 |
/// | white balance (R, G, B) | 1.03, 1, 0.97 | 1.08, 1, 0.9 | 1.15, 1, 0.8 |
/// | light power, beam exponent | ×0.9, 1.3 | ×0.8, 1.6 | ×0.65, 2.2 |
/// | specular, wet sheen | ×1.5, 0.05 | ×2.5, 0.1 | ×4, 0.2 |
/// | texture contrast | ×0.85 | ×0.75 | ×0.5 |
/// | residue on the wall | 2 % | 5 % | 12 % |
/// | fluid on the dependent side | 1 % | 3 % | 8 % |
/// | frames with bubbles, cover up to | 2 %, 10 % | 5 %, 20 % | 12 %, 40 % |
/// | motion blur sub-frames over the camera's travel, defocus σ | as the map pass, 0.3 px | 3 over 0.3 mm, 0.7 px | 5 over 0.6 mm, 1.2 px |
/// | test scope's wider field of view | 5° | 10° | 20° |
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Severity {
    /// No change: both passes through the same colon with the same look.
    #[default]
    None,
    /// Another day, the same patient prepared the same way.
    Mild,
    /// Another procedure: segments shifted by centimetres, other insufflation, another light.
    Moderate,
    /// A hard case: large shifts, a collapsed or ballooned lumen, poor preparation.
    Severe,
}

impl Severity {
    /// All severities, mildest first.
    pub const ALL: [Severity; 4] = [
        Severity::None,
        Severity::Mild,
        Severity::Moderate,
        Severity::Severe,
    ];

    /// The severity's name on the command line and in files.
    pub fn name(&self) -> &'static str {
        match self {
            Severity::None => "none",
            Severity::Mild => "mild",
            Severity::Moderate => "moderate",
            Severity::Severe => "severe",
        }
    }
}

impl std::fmt::Display for Severity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Severity {
    type Err = SimError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Severity::ALL
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| {
                SimError::InvalidConfig(format!(
                    "unknown change severity {s:?}; expected none, mild, moderate or severe"
                ))
            })
    }
}

/// The shape of the colon in the test pass against the map pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShapeChange {
    /// Peak displacement of the mobile segments (sigmoid and transverse colon on their
    /// mesentery; flexures, recto-sigmoid and caecum half as free; rectum, descending and
    /// ascending colon fixed), mm. A smooth displacement of whole stretches of the mid-line,
    /// the cross-sections turning with it.
    pub shift_mm: f64,
    /// Wavelength of the shift along the mid-line, mm.
    pub shift_wavelength_mm: f64,
    /// Largest relative change of the lumen radius about the mid-line (0.15: between ×0.85
    /// and ×1.15), varying smoothly along it: more or less insufflation.
    pub insufflation: f64,
    /// Wavelength of the insufflation's variation along the mid-line, mm.
    pub insufflation_wavelength_mm: f64,
    /// Amplitude of the local non-rigid deformation at the wall (haustral contraction, a
    /// peristaltic wave), mm.
    pub deform_mm: f64,
    /// Wavelength of the local deformation along the mid-line, mm.
    pub deform_wavelength_mm: f64,
}

impl Default for ShapeChange {
    fn default() -> Self {
        ShapeChange {
            shift_mm: 0.0,
            shift_wavelength_mm: 300.0,
            insufflation: 0.0,
            insufflation_wavelength_mm: 400.0,
            deform_mm: 0.0,
            deform_wavelength_mm: 40.0,
        }
    }
}

impl ShapeChange {
    /// Whether the shape stays as it is.
    pub fn is_none(&self) -> bool {
        self.shift_mm == 0.0 && self.insufflation == 0.0 && self.deform_mm == 0.0
    }
}

/// The look of the test pass against the map pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LookChange {
    /// Range of the exposure gain, drifting slowly over the pass between the two values
    /// (another auto-exposure; `[1, 1]` = none).
    pub gain: [f64; 2],
    /// Gamma applied to the tone-mapped intensity (1 = none; above 1 darker mid-tones).
    pub gamma: f64,
    /// White balance: multipliers of the linear red, green and blue.
    pub white_balance: [f64; 3],
    /// Light power of the other light source, × the map pass's.
    pub light_power: f64,
    /// Exponent of the light's cosine beam (1 = the map pass's lobe; larger: a narrower beam,
    /// darker periphery).
    pub beam_exponent: f64,
    /// Strength of the specular highlights, × the map pass's.
    pub specular: f64,
    /// A broad wet sheen over the whole wall (a second specular lobe of exponent 4).
    pub sheen: f64,
    /// Texture contrast (vessels and mottling), × the map pass's.
    pub texture_contrast: f64,
    /// Fraction of the wall hidden by residue patches (stool, mucus), 0–1.
    pub residue_fraction: f64,
    /// Fraction of the wall under fluid pools, on the gravity-dependent side, 0–1.
    pub fluid_fraction: f64,
    /// Direction of gravity in the world frame (the procedural colon lies supine: −z).
    pub gravity: [f64; 3],
    /// Fraction of frames with bubbles on or near the lens, 0–1.
    pub bubble_frames: f64,
    /// Largest fraction of such a frame the bubbles cover, 0–1; 1 is foam over the whole lens
    /// (every pixel in a bubble).
    pub bubble_cover: f64,
}

impl Default for LookChange {
    fn default() -> Self {
        LookChange {
            gain: [1.0, 1.0],
            gamma: 1.0,
            white_balance: [1.0; 3],
            light_power: 1.0,
            beam_exponent: 1.0,
            specular: 1.0,
            sheen: 0.0,
            texture_contrast: 1.0,
            residue_fraction: 0.0,
            fluid_fraction: 0.0,
            gravity: [0.0, 0.0, -1.0],
            bubble_frames: 0.0,
            bubble_cover: 0.2,
        }
    }
}

impl LookChange {
    /// Whether the look stays as it is (gravity and bubble cover matter only with fluid and
    /// bubbles).
    pub fn is_none(&self) -> bool {
        let d = LookChange::default();
        LookChange {
            gravity: d.gravity,
            bubble_cover: d.bubble_cover,
            ..self.clone()
        } == d
    }
}

/// The scope of the test pass against the map pass's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScopeChange {
    /// Sub-frames averaged per test frame for motion blur (0: as the map pass).
    pub motion_blur_samples: usize,
    /// With the sub-frames: the camera's travel during a test frame's exposure, mm (the render
    /// setting `motion_blur_mm`; 0: over the map pass's shutter, a fraction of the frame
    /// interval).
    #[serde(skip_serializing_if = "is_zero")]
    pub motion_blur_mm: f64,
    /// Defocus: standard deviation of a Gaussian blur of the test frames, pixels (0 = none).
    pub defocus_px: f64,
    /// The test scope's horizontal field of view minus the map scope's, degrees (0: the same
    /// optics). The test pass is rendered with it at the same image size, and its camera is
    /// stored as the test sequence's own (`test/camera.toml`).
    pub hfov_change_deg: f64,
}

impl Default for ScopeChange {
    fn default() -> Self {
        ScopeChange {
            motion_blur_samples: 0,
            motion_blur_mm: 0.0,
            defocus_px: 0.0,
            hfov_change_deg: 0.0,
        }
    }
}

impl ScopeChange {
    /// Whether the test scope sees as the map pass's does.
    pub fn is_none(&self) -> bool {
        self.motion_blur_samples == 0
            && self.motion_blur_mm == 0.0
            && self.defocus_px == 0.0
            && self.hfov_change_deg == 0.0
    }
}

/// Every change between the passes, with its seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChangeConfig {
    /// The severity preset these settings started from (informative; the factors below are
    /// what is applied).
    pub severity: Severity,
    /// Seed of every random draw of the change (shift directions, insufflation profile,
    /// residue and fluid layout, bubbles, exposure drift).
    pub seed: u64,
    /// Shape.
    pub shape: ShapeChange,
    /// Look.
    pub look: LookChange,
    /// Scope of the test pass.
    pub scope: ScopeChange,
}

impl Default for ChangeConfig {
    fn default() -> Self {
        ChangeConfig::preset(Severity::None)
    }
}

impl ChangeConfig {
    /// The settings of a severity preset (seed 0; the simulation config's `with_seed` derives
    /// it).
    pub fn preset(severity: Severity) -> Self {
        // Columns: mild, moderate, severe.
        let pick = |v: [f64; 3]| match severity {
            Severity::None => None,
            Severity::Mild => Some(v[0]),
            Severity::Moderate => Some(v[1]),
            Severity::Severe => Some(v[2]),
        };
        let (shape, look, scope) = match severity {
            Severity::None => (
                ShapeChange::default(),
                LookChange::default(),
                ScopeChange::default(),
            ),
            _ => {
                let p = |v: [f64; 3]| pick(v).unwrap_or_default();
                (
                    ShapeChange {
                        shift_mm: p([5.0, 15.0, 30.0]),
                        insufflation: p([0.07, 0.15, 0.25]),
                        deform_mm: p([0.7, 2.0, 4.0]),
                        ..ShapeChange::default()
                    },
                    LookChange {
                        gain: [p([0.85, 0.7, 0.5]), p([1.2, 1.4, 1.8])],
                        gamma: p([1.05, 1.15, 1.3]),
                        white_balance: [p([1.03, 1.08, 1.15]), 1.0, p([0.97, 0.9, 0.8])],
                        light_power: p([0.9, 0.8, 0.65]),
                        beam_exponent: p([1.3, 1.6, 2.2]),
                        specular: p([1.5, 2.5, 4.0]),
                        sheen: p([0.05, 0.1, 0.2]),
                        texture_contrast: p([0.85, 0.75, 0.5]),
                        residue_fraction: p([0.02, 0.05, 0.12]),
                        fluid_fraction: p([0.01, 0.03, 0.08]),
                        bubble_frames: p([0.02, 0.05, 0.12]),
                        bubble_cover: p([0.1, 0.2, 0.4]),
                        ..LookChange::default()
                    },
                    ScopeChange {
                        motion_blur_samples: p([0.0, 3.0, 5.0]) as usize,
                        motion_blur_mm: p([0.0, 0.3, 0.6]),
                        defocus_px: p([0.3, 0.7, 1.2]),
                        hfov_change_deg: p([5.0, 10.0, 20.0]),
                    },
                )
            }
        };
        ChangeConfig {
            severity,
            seed: 0,
            shape,
            look,
            scope,
        }
    }

    /// A change drawn at random up to a severity, for training with the change model as
    /// augmentation: every factor independently between none and the severity's value
    /// (uniform), those with two directions (gamma, white balance, light power, texture
    /// contrast, the test scope's field of view) turned either way — brighter or dimmer,
    /// warmer or cooler, vessels more or less visible, a wider or a narrower scope. The
    /// severity's own preset is one point among the draws, never all of them. `seed` seeds the
    /// draw and becomes the change's seed; `severity` records `up_to`.
    pub fn draw(up_to: Severity, seed: u64) -> Self {
        use rand::{Rng, SeedableRng};
        let full = ChangeConfig::preset(up_to);
        let none = ChangeConfig::preset(Severity::None);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // Between none (`a`) and the severity (`b`), linearly.
        let mut lerp = |a: f64, b: f64| a + rng.random::<f64>() * (b - a);
        let (s, l, c) = (&full.shape, &full.look, &full.scope);
        let shape = ShapeChange {
            shift_mm: lerp(0.0, s.shift_mm),
            insufflation: lerp(0.0, s.insufflation),
            deform_mm: lerp(0.0, s.deform_mm),
            ..none.shape.clone()
        };
        let mut look = LookChange {
            gain: [lerp(1.0, l.gain[0]), lerp(1.0, l.gain[1])],
            beam_exponent: lerp(1.0, l.beam_exponent),
            specular: lerp(1.0, l.specular),
            sheen: lerp(0.0, l.sheen),
            residue_fraction: lerp(0.0, l.residue_fraction),
            fluid_fraction: lerp(0.0, l.fluid_fraction),
            bubble_frames: lerp(0.0, l.bubble_frames),
            bubble_cover: lerp(0.0, l.bubble_cover),
            ..none.look.clone()
        };
        let mut scope = ScopeChange {
            motion_blur_samples: lerp(0.0, c.motion_blur_samples as f64).round() as usize,
            // Over the map pass's shutter (as the drawn changes of the shipped pretrained
            // weights were rendered).
            motion_blur_mm: 0.0,
            defocus_px: lerp(0.0, c.defocus_px),
            hfov_change_deg: 0.0,
        };
        // Factors with two directions: a signed fraction of the severity's change.
        let mut signed = || {
            let u = rng.random::<f64>();
            if rng.random::<bool>() { u } else { -u }
        };
        look.gamma = l.gamma.powf(signed());
        look.light_power = l.light_power.powf(signed());
        look.texture_contrast = l.texture_contrast.powf(signed());
        let warm = signed();
        look.white_balance = [
            l.white_balance[0].powf(warm),
            1.0,
            l.white_balance[2].powf(warm),
        ];
        scope.hfov_change_deg = signed() * c.hfov_change_deg;
        ChangeConfig {
            severity: up_to,
            seed,
            shape,
            look,
            scope,
        }
    }

    /// Whether nothing changes between the passes (the seed and the informative severity
    /// aside).
    pub fn is_none(&self) -> bool {
        self.shape.is_none() && self.look.is_none() && self.scope.is_none()
    }

    /// Checks ranges.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] naming the first bad field (as `changes.<part>.<field>`).
    pub fn validate(&self) -> Result<(), SimError> {
        let check = |name: &str, v: f64, ok: bool| {
            if v.is_finite() && ok {
                Ok(())
            } else {
                Err(SimError::InvalidConfig(format!(
                    "changes.{name} out of range: {v}"
                )))
            }
        };
        let s = &self.shape;
        check("shape.shift_mm", s.shift_mm, s.shift_mm >= 0.0)?;
        check(
            "shape.shift_wavelength_mm",
            s.shift_wavelength_mm,
            s.shift_wavelength_mm >= 50.0,
        )?;
        check(
            "shape.insufflation",
            s.insufflation,
            (0.0..=0.5).contains(&s.insufflation),
        )?;
        check(
            "shape.insufflation_wavelength_mm",
            s.insufflation_wavelength_mm,
            s.insufflation_wavelength_mm >= 20.0,
        )?;
        check(
            "shape.deform_mm",
            s.deform_mm,
            (0.0..=10.0).contains(&s.deform_mm),
        )?;
        check(
            "shape.deform_wavelength_mm",
            s.deform_wavelength_mm,
            s.deform_wavelength_mm >= 5.0,
        )?;
        let l = &self.look;
        for (i, g) in l.gain.iter().enumerate() {
            check(&format!("look.gain[{i}]"), *g, *g > 0.0 && *g <= 10.0)?;
        }
        check("look.gamma", l.gamma, (0.2..=5.0).contains(&l.gamma))?;
        for (i, w) in l.white_balance.iter().enumerate() {
            check(
                &format!("look.white_balance[{i}]"),
                *w,
                *w > 0.0 && *w <= 5.0,
            )?;
        }
        check("look.light_power", l.light_power, l.light_power > 0.0)?;
        check(
            "look.beam_exponent",
            l.beam_exponent,
            (0.1..=20.0).contains(&l.beam_exponent),
        )?;
        check("look.specular", l.specular, l.specular >= 0.0)?;
        check("look.sheen", l.sheen, l.sheen >= 0.0)?;
        check(
            "look.texture_contrast",
            l.texture_contrast,
            l.texture_contrast >= 0.0,
        )?;
        for (name, v) in [
            ("look.residue_fraction", l.residue_fraction),
            ("look.fluid_fraction", l.fluid_fraction),
            ("look.bubble_frames", l.bubble_frames),
            ("look.bubble_cover", l.bubble_cover),
        ] {
            check(name, v, (0.0..=1.0).contains(&v))?;
        }
        let g = nalgebra::Vector3::from(l.gravity);
        check("look.gravity (its length)", g.norm(), g.norm() > 1e-9)?;
        if self.scope.motion_blur_samples > 64 {
            return Err(SimError::InvalidConfig(format!(
                "changes.scope.motion_blur_samples must be 0..=64, got {}",
                self.scope.motion_blur_samples
            )));
        }
        check(
            "scope.motion_blur_mm",
            self.scope.motion_blur_mm,
            (0.0..=50.0).contains(&self.scope.motion_blur_mm),
        )?;
        check(
            "scope.defocus_px",
            self.scope.defocus_px,
            (0.0..=20.0).contains(&self.scope.defocus_px),
        )?;
        check(
            "scope.hfov_change_deg",
            self.scope.hfov_change_deg,
            (-60.0..=60.0).contains(&self.scope.hfov_change_deg),
        )?;
        Ok(())
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Draws stay between none and the severity (either way for two-way factors), differ
    /// from seed to seed, repeat with a seed, and validate.
    #[test]
    fn a_drawn_change_is_bounded_by_its_severity_and_seeded() {
        let full = ChangeConfig::preset(Severity::Moderate);
        let draws: Vec<_> = (0..64)
            .map(|seed| ChangeConfig::draw(Severity::Moderate, seed))
            .collect();
        assert_eq!(draws[7], ChangeConfig::draw(Severity::Moderate, 7));
        assert_ne!(draws[7], draws[8]);
        for d in &draws {
            d.validate().unwrap();
            assert!((0.0..=full.shape.shift_mm).contains(&d.shape.shift_mm));
            assert!((full.look.gain[0]..=1.0).contains(&d.look.gain[0]));
            let gamma = d.look.gamma.ln().abs();
            assert!(gamma <= full.look.gamma.ln() + 1e-12, "{}", d.look.gamma);
            assert!(d.scope.hfov_change_deg.abs() <= full.scope.hfov_change_deg);
            assert!(d.scope.motion_blur_samples <= full.scope.motion_blur_samples);
        }
        // Both directions are drawn: warmer and cooler, wider and narrower.
        assert!(draws.iter().any(|d| d.look.white_balance[0] > 1.0));
        assert!(draws.iter().any(|d| d.look.white_balance[0] < 1.0));
        assert!(draws.iter().any(|d| d.scope.hfov_change_deg < 0.0));
        assert!(draws.iter().any(|d| d.scope.hfov_change_deg > 0.0));
        assert!(ChangeConfig::draw(Severity::None, 3).is_none());
    }
}
