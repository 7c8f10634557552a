//! endoloc's data layer: the dataset format v1 (`DESIGN.md`), trajectories, anatomy labels,
//! and import of colon surface meshes and mid-line paths.

pub mod anatomy;

pub use anatomy::Section;
