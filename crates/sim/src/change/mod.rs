//! A colon that changes between the two passes.
//!
//! The training (map) pass goes through the colon as it was built; the test pass through a
//! *changed* colon: its shape moved ([`ShapeChange`]: mobile segments shifted, lumen
//! insufflated or collapsed, local haustral contraction), its look changed ([`LookChange`]:
//! another light source and exposure, texture contrast, residue, fluid pools, bubbles) and seen
//! through another scope ([`ScopeChange`]: motion blur, defocus). Every change is seeded and
//! stored with the simulation config in `dataset.toml` (`[simulation.changes]`).
//!
//! The test pass is planned in the unchanged colon and carried into the changed one by the
//! shape change ([`Deformation`]): the pose in the unchanged colon is the **anatomical** pose
//! (what a localizer against the map should output: `poses.txt`), the carried pose the one the
//! frame was rendered from (`poses_changed.txt`).
//!
//! Severity presets (`none`, `mild`, `moderate`, `severe`) set every factor at once; `none`
//! changes nothing and leaves the dataset exactly as without this module.

mod config;
mod cover;
mod deform;
mod look;

pub use config::{ChangeConfig, LookChange, ScopeChange, Severity, ShapeChange};
pub use cover::cover_atlas;
pub use deform::Deformation;
pub use look::ChangedLook;

use crate::SimError;
use crate::appearance::{AppearanceConfig, MucosaAtlas, splitmix64};
use crate::colon::ColonModel;

/// Everything the test pass of a changed colon is rendered with.
#[derive(Debug)]
pub struct ChangedPass {
    /// The shape change (`None`: the shape stays).
    pub deformation: Option<Deformation>,
    /// The changed colon (`None`: the shape stays).
    pub colon: Option<ColonModel>,
    /// The test pass's atlas (`None`: the map pass's texture, uncovered).
    pub atlas: Option<MucosaAtlas>,
    /// Light, exposure, bubbles and defocus.
    pub look: ChangedLook,
    /// Motion-blur sub-frames of the test scope (`None`: as the map pass).
    pub motion_blur_samples: Option<usize>,
    /// The test scope's travel during an exposure, mm (`None`: the map pass's shutter).
    pub motion_blur_mm: Option<f64>,
    /// What changed, in words, for the user.
    pub notes: Vec<String>,
}

impl ChangedPass {
    /// Prepares the changes `ch` to `colon`, whose map pass has the texture `appearance`.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] for out-of-range settings.
    pub fn new(
        ch: &ChangeConfig,
        appearance: &AppearanceConfig,
        colon: &ColonModel,
    ) -> Result<Self, SimError> {
        ch.validate()?;
        let seed = |tag: u64| splitmix64(ch.seed ^ tag.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let mut notes = Vec::new();
        let deformation =
            (!ch.shape.is_none()).then(|| Deformation::new(colon, &ch.shape, seed(1)));
        if let Some(d) = &deformation {
            let s = &ch.shape;
            notes.push(format!(
                "test pass through a changed colon ({}): mobile segments shifted by up to {:.1} mm, \
                 lumen radius ×{:.2}–{:.2}, local deformation {:.1} mm",
                ch.severity,
                d.peak_shift_mm(),
                1.0 - s.insufflation,
                1.0 + s.insufflation,
                s.deform_mm
            ));
        }
        let l = &ch.look;
        let recolour =
            l.texture_contrast != 1.0 || l.residue_fraction > 0.0 || l.fluid_fraction > 0.0;
        let atlas = if recolour {
            let appearance = AppearanceConfig {
                contrast: appearance.contrast * l.texture_contrast,
                ..appearance.clone()
            };
            let mut atlas = MucosaAtlas::bake(colon, &appearance)?;
            if l.residue_fraction > 0.0 || l.fluid_fraction > 0.0 {
                cover_atlas(&mut atlas, colon, deformation.as_ref(), l, seed(2));
            }
            Some(atlas)
        } else {
            None
        };
        if !l.is_none() {
            notes.push(format!(
                "test pass look: gain {:.2}–{:.2}, gamma {:.2}, light ×{:.2}, specular ×{:.1}, \
                 texture contrast ×{:.2}, residue {:.0} % and fluid {:.0} % of the wall, bubbles \
                 in {:.0} % of the frames",
                l.gain[0],
                l.gain[1],
                l.gamma,
                l.light_power,
                l.specular,
                l.texture_contrast,
                100.0 * l.residue_fraction,
                100.0 * l.fluid_fraction,
                100.0 * l.bubble_frames
            ));
        }
        let motion_blur_samples =
            (ch.scope.motion_blur_samples > 0).then_some(ch.scope.motion_blur_samples);
        if !ch.scope.is_none() {
            notes.push(format!(
                "test scope: motion blur of {} sub-frames{}, defocus σ {:.1} px, {}",
                motion_blur_samples.map_or("the map pass's".to_string(), |n| n.to_string()),
                if ch.scope.motion_blur_mm > 0.0 {
                    format!(" over {:.2} mm of travel", ch.scope.motion_blur_mm)
                } else {
                    String::new()
                },
                ch.scope.defocus_px,
                if ch.scope.hfov_change_deg == 0.0 {
                    "the map scope's field of view".to_string()
                } else {
                    format!(
                        "field of view {:+.1}° (its camera in test/camera.toml)",
                        ch.scope.hfov_change_deg
                    )
                }
            ));
        }
        Ok(ChangedPass {
            colon: deformation.as_ref().map(|d| d.apply(colon)),
            deformation,
            atlas,
            look: ChangedLook::new(l, &ch.scope, seed(3)),
            motion_blur_samples,
            motion_blur_mm: (ch.scope.motion_blur_mm > 0.0).then_some(ch.scope.motion_blur_mm),
            notes,
        })
    }
}
