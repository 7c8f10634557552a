//! The validity check that classifies a localization result (the paper's "thresholds are used
//! for outlier rejection" after the refinement).
//!
//! Three outcomes ([`Status`], written verbatim to `frames.csv`):
//! - `refined`: the refined pose passed every check;
//! - `init_only`: the refinement was impossible or is not trusted for a *local* reason (too
//!   few correspondences or inliers, RMS too high, degenerate geometry); the pose reported is
//!   the prior (the zone median), as in the paper's classification-only baseline;
//! - `rejected`: no pose is reported — the refined pose jumped too far from the prior (the
//!   zone classification is then most likely wrong), or a local failure occurred while
//!   [`ValidityConfig::fallback_to_prior`] is off.
//!
//! The order of the checks is: correspondences, inliers, degenerate geometry, RMS, jump.

use serde::{Deserialize, Serialize};

use crate::pose::{Pose, orientation_error_deg, position_error_mm};
use crate::refine_pose::PoseEstimate;

/// Thresholds of the validity check.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ValidityConfig {
    /// Fewer 2D–3D correspondences than this: no refinement is attempted.
    pub min_correspondences: usize,
    /// Fewer inliers than this after refinement: not trusted.
    pub min_inliers: usize,
    /// Inlier reprojection RMS above this: not trusted, pixels.
    pub max_rms_px: f64,
    /// A refined camera centre farther than this from the prior's: rejected, mm.
    pub max_jump_mm: f64,
    /// A refined orientation farther than this from the prior's: rejected, degrees.
    pub max_jump_deg: f64,
    /// Largest predicted position standard deviation (from the covariance) before the geometry
    /// counts as degenerate, mm.
    pub max_position_sigma_mm: f64,
    /// On a local failure, report the prior as `init_only` (true) or reject the frame (false).
    pub fallback_to_prior: bool,
}

impl Default for ValidityConfig {
    fn default() -> Self {
        Self {
            min_correspondences: 8,
            min_inliers: 8,
            max_rms_px: 3.0,
            max_jump_mm: 50.0,
            max_jump_deg: 60.0,
            max_position_sigma_mm: 5.0,
            fallback_to_prior: true,
        }
    }
}

/// The classification of a result; displays as `refined`, `init_only` or `rejected`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The refined pose passed every check.
    Refined,
    /// The prior pose is reported; the refinement was impossible or not trusted.
    InitOnly,
    /// No pose is reported.
    Rejected,
}

impl Status {
    /// The word used in `frames.csv`: `refined`, `init_only` or `rejected`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Refined => "refined",
            Status::InitOnly => "init_only",
            Status::Rejected => "rejected",
        }
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Why a result is not `refined`. `Display` gives a human sentence without commas (CSV-safe);
/// [`Reason::code`] a stable snake_case keyword.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "code", rename_all = "snake_case")]
pub enum Reason {
    /// Too few 2D–3D correspondences to refine.
    TooFewCorrespondences {
        /// Correspondences available.
        count: usize,
        /// The configured minimum.
        min: usize,
    },
    /// Too few inliers after refinement.
    TooFewInliers {
        /// Inliers found.
        count: usize,
        /// The configured minimum.
        min: usize,
    },
    /// Inlier reprojection RMS too high.
    RmsTooHigh {
        /// RMS over the inliers, pixels.
        rms_px: f64,
        /// The configured maximum, pixels.
        max_px: f64,
    },
    /// The refined pose is too far from the prior.
    JumpTooLarge {
        /// Distance between the camera centres, mm.
        position_mm: f64,
        /// Angle between the orientations, degrees.
        orientation_deg: f64,
    },
    /// The geometry does not constrain the pose (collinear or clustered points, a singular
    /// system, or a predicted position uncertainty above the limit).
    DegenerateGeometry {
        /// What was found, e.g. the solver's message.
        detail: String,
    },
    /// The frame's image could not be read or decoded (a dropped or corrupt frame).
    UnreadableImage {
        /// The decoder's or the file system's message.
        detail: String,
    },
    /// Live mode: a registration with few inliers that lies far from the motion model's
    /// prediction (a scope does not jump between frames); the pose reported is the prediction.
    InconsistentMotion {
        /// Distance of the registered camera centre from the predicted one, mm.
        position_mm: f64,
        /// Rotation angle between the registered and the predicted orientation, degrees.
        orientation_deg: f64,
        /// Inliers of the registration.
        inliers: usize,
    },
    /// Live mode: a registration with few inliers and no recent refined frame to check it
    /// against; the next frame's registration confirms it when the two agree.
    Unconfirmed {
        /// Inliers of the registration.
        inliers: usize,
    },
    /// Per frame (no motion to check against): a registration whose stated position
    /// uncertainty is above what a frame with its inlier count may have to be trusted; the
    /// registered pose is still reported.
    Uncertain {
        /// Calibrated standard deviation of the camera centre, mm.
        position_std_mm: f64,
        /// The limit for a registration with this many inliers, mm.
        max_mm: f64,
        /// Inliers of the registration.
        inliers: usize,
    },
    /// Too few of the map points near the registered pose match the frame when matched in
    /// windows around their projections: the registration rests on a few look-alike matches.
    /// The registered pose is still reported.
    Unsupported {
        /// Inliers of the confirming refinement.
        inliers: usize,
        /// The configured minimum.
        min: usize,
    },
    /// The confirmed pose is valid but fits fewer map points near it than a pose trusted on
    /// its own needs (a weakly textured view). Live, it is `refined` when it agrees with the
    /// motion model's prediction. The confirmed pose is reported.
    WeaklySupported {
        /// Inliers of the confirmed pose.
        inliers: usize,
        /// The configured minimum.
        min: usize,
    },
    /// Confirmation started from poses around the registered one ends at two poses far apart
    /// that the map points near them support almost equally: the frame does not tell them
    /// apart. The better-supported pose is reported.
    Ambiguous {
        /// Distance between the two camera centres, mm.
        distance_mm: f64,
        /// Inliers of the better-supported pose.
        inliers: usize,
        /// Inliers of the other.
        rival_inliers: usize,
    },
}

impl Reason {
    /// A stable keyword: `too_few_correspondences`, `too_few_inliers`, `rms_too_high`,
    /// `jump_too_large`, `degenerate_geometry`, `unreadable_image`, `inconsistent_with_motion`,
    /// `unconfirmed`, `uncertain`, `unsupported`, `weakly_supported` or `ambiguous`.
    pub fn code(&self) -> &'static str {
        match self {
            Reason::TooFewCorrespondences { .. } => "too_few_correspondences",
            Reason::TooFewInliers { .. } => "too_few_inliers",
            Reason::RmsTooHigh { .. } => "rms_too_high",
            Reason::JumpTooLarge { .. } => "jump_too_large",
            Reason::DegenerateGeometry { .. } => "degenerate_geometry",
            Reason::UnreadableImage { .. } => "unreadable_image",
            Reason::InconsistentMotion { .. } => "inconsistent_with_motion",
            Reason::Unconfirmed { .. } => "unconfirmed",
            Reason::Uncertain { .. } => "uncertain",
            Reason::Unsupported { .. } => "unsupported",
            Reason::WeaklySupported { .. } => "weakly_supported",
            Reason::Ambiguous { .. } => "ambiguous",
        }
    }
}

impl std::fmt::Display for Reason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Reason::TooFewCorrespondences { count, min } => {
                write!(f, "too few correspondences ({count} < {min})")
            }
            Reason::TooFewInliers { count, min } => write!(f, "too few inliers ({count} < {min})"),
            Reason::RmsTooHigh { rms_px, max_px } => {
                write!(f, "RMS too high ({rms_px:.2} px > {max_px} px)")
            }
            Reason::JumpTooLarge {
                position_mm,
                orientation_deg,
            } => write!(
                f,
                "jump from the prior too large ({position_mm:.1} mm / {orientation_deg:.1} deg)"
            ),
            Reason::DegenerateGeometry { detail } => {
                write!(f, "degenerate geometry ({})", detail.replace(',', ";"))
            }
            Reason::UnreadableImage { detail } => {
                write!(f, "unreadable image ({})", detail.replace(',', ";"))
            }
            Reason::InconsistentMotion {
                position_mm,
                orientation_deg,
                inliers,
            } => write!(
                f,
                "registration {position_mm:.1} mm / {orientation_deg:.1} deg from the motion model's prediction with only {inliers} inliers"
            ),
            Reason::Unconfirmed { inliers } => write!(
                f,
                "registration with only {inliers} inliers and no recent motion to check it against"
            ),
            Reason::Uncertain {
                position_std_mm,
                max_mm,
                inliers,
            } => write!(
                f,
                "registration with {inliers} inliers and a position uncertainty of {position_std_mm:.2} mm (at most {max_mm:.2} mm to be trusted)"
            ),
            Reason::Unsupported { inliers, min } => write!(
                f,
                "only {inliers} map points near the registered pose match the frame (at least {min} to be trusted)"
            ),
            Reason::WeaklySupported { inliers, min } => write!(
                f,
                "the confirmed pose fits only {inliers} map points near it (at least {min} to be trusted on its own)"
            ),
            Reason::Ambiguous {
                distance_mm,
                inliers,
                rival_inliers,
            } => write!(
                f,
                "two poses {distance_mm:.1} mm apart fit the map points near them ({inliers} and {rival_inliers} inliers)"
            ),
        }
    }
}

/// A classification: the status and, unless `refined`, the reason.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// `refined`, `init_only` or `rejected`.
    pub status: Status,
    /// Why the result is not `refined`; `None` when it is.
    pub reason: Option<Reason>,
}

impl ValidityConfig {
    /// The verdict for a local failure: `init_only` with the prior, or `rejected`.
    pub fn local_failure(&self, reason: Reason) -> Verdict {
        Verdict {
            status: if self.fallback_to_prior {
                Status::InitOnly
            } else {
                Status::Rejected
            },
            reason: Some(reason),
        }
    }

    /// Classifies a refined `estimate` against its `prior` (`T_wc`, mm) given the number of
    /// correspondences it used.
    pub fn check(&self, estimate: &PoseEstimate, prior: &Pose, correspondences: usize) -> Verdict {
        if correspondences < self.min_correspondences {
            return self.local_failure(Reason::TooFewCorrespondences {
                count: correspondences,
                min: self.min_correspondences,
            });
        }
        if estimate.inlier_count < self.min_inliers {
            return self.local_failure(Reason::TooFewInliers {
                count: estimate.inlier_count,
                min: self.min_inliers,
            });
        }
        let sigma = estimate.position_sigma_mm();
        if !(sigma <= self.max_position_sigma_mm) {
            return self.local_failure(Reason::DegenerateGeometry {
                detail: format!(
                    "position sigma {sigma:.2} mm > {} mm",
                    self.max_position_sigma_mm
                ),
            });
        }
        if !(estimate.rms_px <= self.max_rms_px) {
            return self.local_failure(Reason::RmsTooHigh {
                rms_px: estimate.rms_px,
                max_px: self.max_rms_px,
            });
        }
        let position_mm = position_error_mm(&estimate.t_wc, prior);
        let orientation_deg = orientation_error_deg(&estimate.t_wc, prior);
        if !(position_mm <= self.max_jump_mm && orientation_deg <= self.max_jump_deg) {
            return Verdict {
                status: Status::Rejected,
                reason: Some(Reason::JumpTooLarge {
                    position_mm,
                    orientation_deg,
                }),
            };
        }
        Verdict {
            status: Status::Refined,
            reason: None,
        }
    }
}
