//! endoloc's data layer: the dataset format v1 (`docs/CONVENTIONS.md`), trajectories, anatomy labels,
//! and import of colon surface meshes and mid-line paths.
//!
//! Conventions: lengths in millimetres, poses `T_wc` (camera-to-world), timestamps in seconds.

#![warn(missing_docs)]

pub mod anatomy;
pub mod centerline;
pub mod check;
pub mod dataset;
pub mod error;
pub mod fingerprint;
pub mod fsutil;
pub mod gca;
pub mod import;
pub mod info;
pub mod mesh;
pub mod png_io;
pub mod sections_csv;
pub mod stream;
pub mod trajectory;

pub use anatomy::Section;
pub use centerline::{
    EstimatedLandmark, Landmark, SectionCut, SectionRange, cumulative_length, parse_gca_landmarks,
    parse_path, read_gca_landmarks, read_path, section_cut, section_ranges,
    sections_from_landmarks,
};
pub use check::{CheckReport, Problem, check_dataset};
pub use dataset::{
    CHANGED_POSES_FILE, Dataset, DatasetMeta, DatasetWriter, FORMAT_VERSION, FRAME_TIMES_FILE,
    MASK_FILE, MIDLINE_FILE, SEQUENCE_CAMERA_FILE, Sequence, SequenceWriter, black_outside,
    mask_from_png, read_camera_file, sequence_camera, write_dataset_mask, write_sequence_camera,
};
pub use error::{DataError, toml_error_line};
pub use fingerprint::{Fingerprint, poses_fingerprint};
pub use fsutil::write_atomic;
pub use gca::{GcaModelFiles, find_gca_model};
pub use info::{DatasetInfo, SequenceInfo, dataset_info};
pub use mesh::{TriMesh, read_mesh};
pub use png_io::{
    MAX_DEPTH_MM, decode_png, depth_code_from_mm, depth_mm_from_code, depth_mm_from_png,
};
pub use sections_csv::{parse_sections, read_sections, write_sections};
pub use trajectory::{
    StampedPose, TUM_HEADER, TumReader, format_tum_line, parse_tum, read_frame_times, read_tum,
    write_frame_times, write_tum,
};
