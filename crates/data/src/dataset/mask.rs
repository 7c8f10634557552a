//! The dataset's image mask (`mask.png`, non-zero = valid pixel): checked against the camera,
//! read, written, and applied to frames.

use crate::DataError;
use crate::fsutil::{hidden_sibling, write_atomic};
use crate::png_io::{decode_png, write_png};
use endoloc_geometry::Camera;
use std::path::{Path, PathBuf};

use super::layout::{MASK_FILE, META_FILE};
use super::meta::DatasetMeta;

/// Checks a mask against the camera: its size, and at least one valid pixel.
pub(super) fn check_mask(
    path: &Path,
    mask: &image::GrayImage,
    camera: &Camera,
) -> Result<(), DataError> {
    if (mask.width(), mask.height()) != (camera.width, camera.height) {
        return Err(DataError::invalid(
            path,
            format!(
                "mask is {}×{} pixels; expected the camera's {}×{}",
                mask.width(),
                mask.height(),
                camera.width,
                camera.height
            ),
        ));
    }
    if mask.as_raw().iter().all(|&v| v == 0) {
        return Err(DataError::invalid(
            path,
            "no valid pixel (every value is 0); expected non-zero inside the field of view",
        ));
    }
    Ok(())
}

/// Decodes the bytes of a dataset's mask PNG (see [`Dataset::load_mask`](crate::Dataset::load_mask)) and checks it
/// against `camera`; `path` names the file in errors.
///
/// # Errors
/// [`DataError::Image`] for bytes that are not a PNG; [`DataError::Invalid`] when its size is
/// not the camera's or no pixel is valid.
pub fn mask_from_png(
    path: &Path,
    bytes: &[u8],
    camera: &Camera,
) -> Result<image::GrayImage, DataError> {
    let img = decode_png(path, bytes)?.into_luma8();
    check_mask(path, &img, camera)?;
    Ok(img)
}

/// Writes a mask as an 8-bit grey PNG.
pub(super) fn write_mask_png(path: &Path, mask: &image::GrayImage) -> Result<(), DataError> {
    write_png(
        path,
        mask.width(),
        mask.height(),
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        mask.as_raw(),
    )
}

/// Adds (or replaces, with `force`) the image mask of the dataset in `dir`: writes
/// [`MASK_FILE`] and names it in `dataset.toml`, each atomically.
///
/// # Errors
/// [`DataError::AlreadyExists`] when the dataset already has a mask and `force` is off;
/// [`DataError::Invalid`] for a mask of another size or without a valid pixel; read and
/// write errors naming the file.
pub fn write_dataset_mask(
    dir: &Path,
    mask: &image::GrayImage,
    force: bool,
) -> Result<PathBuf, DataError> {
    let meta_path = dir.join(META_FILE);
    let mut meta = DatasetMeta::read(&meta_path)?;
    let path = dir.join(MASK_FILE);
    if !force && (meta.mask.is_some() || path.exists()) {
        return Err(DataError::AlreadyExists { path });
    }
    check_mask(&path, mask, &meta.camera)?;
    let tmp = hidden_sibling(&path, "tmp");
    write_mask_png(&tmp, mask)?;
    std::fs::rename(&tmp, &path).map_err(|e| DataError::io(&path, e))?;
    meta.mask = Some(MASK_FILE.to_string());
    let text = meta
        .to_toml_string()
        .map_err(|m| DataError::invalid(&meta_path, m))?;
    write_atomic(&meta_path, text.as_bytes())?;
    Ok(path)
}

/// The mask named by `meta`'s `[camera] mask` in the dataset folder `root`, when there is one.
pub(super) fn read_dataset_mask(
    root: &Path,
    meta: &DatasetMeta,
) -> Result<Option<image::GrayImage>, DataError> {
    let Some(name) = &meta.mask else {
        return Ok(None);
    };
    let path = root.join(name);
    let bytes = std::fs::read(&path).map_err(|e| DataError::io(&path, e))?;
    mask_from_png(&path, &bytes, &meta.camera).map(Some)
}

/// Sets every pixel of `img` where `mask` is 0 to black. `img` and `mask` have the camera's
/// size (checked when the image is loaded and when the mask is read).
pub fn black_outside<P: image::Pixel<Subpixel = u8>>(
    img: &mut image::ImageBuffer<P, Vec<u8>>,
    mask: &image::GrayImage,
) {
    let channels = usize::from(P::CHANNEL_COUNT);
    for (px, &m) in img.chunks_exact_mut(channels).zip(mask.as_raw()) {
        if m == 0 {
            px.fill(0);
        }
    }
}
