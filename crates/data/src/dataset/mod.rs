//! The endoloc dataset, format version 1 (docs/CONVENTIONS.md):
//!
//! ```text
//! DATASET/
//!   dataset.toml            name, format_version, units = "mm", [source], [camera], [simulation]
//!   mask.png                optional ([camera] mask = "mask.png"): 8-bit, non-zero = valid pixel
//!   SEQUENCE/               one folder per trajectory (train/, test/, …)
//!     images/000000.png …   8-bit grey or RGB PNG; frame index = file order
//!     poses.txt             TUM trajectory, T_wc, mm — one line per image, same order
//!     sections.csv          optional: `frame,section`, one anatomical label per frame
//!     depth/000000.png …    optional: 16-bit depth along z, value = mm × 100 (0 = none)
//! ```
//!
//! [`DatasetWriter`] builds a dataset in a hidden staging folder next to its destination and
//! renames it into place only in [`DatasetWriter::finish`], so a crash or an error never
//! leaves a half-written dataset at the destination. [`Dataset`] and [`Sequence`] read one.

mod layout;
mod mask;
mod meta;
mod reader;
mod writer;

pub use layout::{
    CHANGED_POSES_FILE, DEPTH_DIR, FORMAT_VERSION, FRAME_TIMES_FILE, IMAGES_DIR, MASK_FILE,
    META_FILE, MIDLINE_FILE, POSES_FILE, SECTIONS_FILE, SEQUENCE_CAMERA_FILE, UNITS,
};
pub use mask::{black_outside, mask_from_png, write_dataset_mask};
pub use meta::{DatasetMeta, read_camera_file, sequence_camera, write_sequence_camera};
pub(crate) use reader::list_pngs;
pub use reader::{Dataset, Sequence};
pub use writer::{DatasetWriter, SequenceWriter};
