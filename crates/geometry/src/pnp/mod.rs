//! Absolute pose from 2D–3D correspondences without a prior: a minimal P3P solver inside a
//! seeded, adaptive RANSAC with MSAC scoring. The result seeds [`crate::refine_pose()`].

pub mod p3p;
pub mod ransac;

pub use p3p::p3p;
pub use ransac::{RansacConfig, RansacError, RansacPose, ransac_pnp, ransac_pnp_tolerant};
