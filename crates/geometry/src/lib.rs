//! Geometry core of endoloc.
//!
//! Conventions used by every endoloc crate (`docs/CONVENTIONS.md`): lengths in millimetres; poses are
//! `T_wc` (camera-to-world); OpenCV camera axes (x right, y down, z forward); pixel origin at
//! the centre of the top-left pixel.

#![warn(missing_docs)]
// `!(x > limit)` is used on purpose throughout: it rejects NaN as well as small values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod camera;
pub mod essential;
pub mod pnp;
pub mod polyline;
pub mod pose;
pub mod refine_pose;
pub mod refine_radial;
pub mod registration;
pub mod reprojection;
pub mod rotation_mean;
pub mod se3;
pub mod so3;
pub mod synthetic;
pub mod triangulate;
pub mod validity;
pub mod wall_covariance;

#[cfg(test)]
mod config_tests;

pub use camera::{Camera, Distortion};
pub use essential::{
    EssentialError, EssentialEstimate, EssentialRansacConfig, RecoveredPose, RelativePose,
    five_point, ransac_essential, ransac_essential_normalized, recover_pose, refine_relative_pose,
};
pub use pnp::{RansacConfig, RansacError, RansacPose, ransac_pnp, ransac_pnp_tolerant};
pub use polyline::{Nearest, Polyline};
pub use pose::{
    Pose, canonical_quaternion, orientation_error_deg, pose_from_matrix, position_error_mm,
};
pub use refine_pose::{
    BOUND95_PER_STD, PoseEstimate, RefineConfig, RefineError, RobustKernel, position_sigma_mm,
    refine_pose, rotation_sigma_deg,
};
pub use refine_radial::{Foot, RadialConfig, RadialFit, refine_radial};
pub use registration::{Localization, RegistrationConfig, RegistrationError, localize_pose};
pub use rotation_mean::{
    GeodesicMedianConfig, RotationMeanError, chordal_mean, geodesic_median, zone_median_pose,
};
pub use triangulate::{
    Observation, TriangulatedPoint, TriangulationConfig, TriangulationError, Triangulator,
    triangulate_track, triangulate_tracks,
};
pub use validity::{Reason, Status, ValidityConfig, Verdict};
pub use wall_covariance::{WallCovariance, WallCovarianceConfig, WallMotionPool, wall_covariance};
