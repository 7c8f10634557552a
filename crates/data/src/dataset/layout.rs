//! The names and version of the dataset format's files and folders.

/// The dataset format version this crate reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// The only length unit of the format.
pub const UNITS: &str = "mm";

/// File name of the dataset description.
pub const META_FILE: &str = "dataset.toml";
/// File name of a sequence's trajectory.
pub const POSES_FILE: &str = "poses.txt";
/// File name of the frame times of a pass recorded without poses (a video imported without a
/// pose log), in place of [`POSES_FILE`]: one line per image, in the same order, the frame's
/// time in seconds; `#` comments. Such a pass can be localized, not trained on, mapped or
/// evaluated.
pub const FRAME_TIMES_FILE: &str = "frames.txt";
/// File name of a sequence's poses in a *changed* colon, beside `poses.txt` (TUM, mm): when
/// the colon moved between the passes (a simulated test pass through a deformed colon),
/// `poses.txt` holds each frame's anatomical pose — in the colon as it was mapped, what a
/// localizer should output — and this file the pose the frame was taken from.
pub const CHANGED_POSES_FILE: &str = "poses_changed.txt";
/// File name of a sequence's own camera, in the sequence folder: a `[camera]` table as in
/// `dataset.toml` (model, size, intrinsics in pixels, optional `[camera.distortion]`; no mask)
/// for a pass taken with another scope than the dataset's `[camera]` — another field of view,
/// principal point or distortion at the same image size. Without it a sequence's camera is the
/// dataset's.
pub const SEQUENCE_CAMERA_FILE: &str = "camera.toml";
/// File name of the colon's mid-line at the dataset's root: one point `x y z` (mm, world
/// frame) per line from the anus to the caecum, `#` comments. In a dataset whose colon changed
/// between the passes, the mid-line of the colon as mapped (the frame of every `poses.txt`).
pub const MIDLINE_FILE: &str = "midline.txt";
/// File name of a sequence's per-frame anatomical labels.
pub const SECTIONS_FILE: &str = "sections.csv";
/// Folder of a sequence's images.
pub const IMAGES_DIR: &str = "images";
/// Folder of a sequence's depth maps.
pub const DEPTH_DIR: &str = "depth";

/// The usual file name of a dataset's image mask.
pub const MASK_FILE: &str = "mask.png";
