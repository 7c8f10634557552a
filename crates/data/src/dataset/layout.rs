//! The names and version of the dataset format's files and folders.

/// The dataset format version this crate reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// The only length unit of the format.
pub const UNITS: &str = "mm";

/// File name of the dataset description.
pub const META_FILE: &str = "dataset.toml";
/// File name of a sequence's trajectory.
pub const POSES_FILE: &str = "poses.txt";
/// File name of a sequence's per-frame anatomical labels.
pub const SECTIONS_FILE: &str = "sections.csv";
/// Folder of a sequence's images.
pub const IMAGES_DIR: &str = "images";
/// Folder of a sequence's depth maps.
pub const DEPTH_DIR: &str = "depth";

/// The usual file name of a dataset's image mask.
pub const MASK_FILE: &str = "mask.png";
