//! PNG encoding and decoding for dataset images (8-bit grey/RGB) and depth maps (16-bit grey).

use crate::DataError;
use image::DynamicImage;
use std::fs::File;
use std::io::{BufWriter, Cursor, Write};
use std::path::Path;

/// Depth scale of the dataset format: stored value = round(depth_mm × 100).
pub const DEPTH_UNITS_PER_MM: f64 = 100.0;

/// Largest depth a 16-bit depth PNG can hold, mm (65535 / 100).
pub const MAX_DEPTH_MM: f64 = 655.35;

/// Stored 16-bit value of a depth in mm: `round(mm × 100)`; 0 (no depth) for non-finite,
/// non-positive or too large (> [`MAX_DEPTH_MM`]) depths.
pub fn depth_code_from_mm(depth_mm: f32) -> u16 {
    let d = depth_mm as f64;
    if !d.is_finite() || d <= 0.0 || d > MAX_DEPTH_MM {
        return 0;
    }
    (d * DEPTH_UNITS_PER_MM).round().clamp(0.0, 65535.0) as u16
}

/// Depth in mm of a stored 16-bit value (0 stays 0: no depth).
pub fn depth_mm_from_code(code: u16) -> f32 {
    (code as f64 / DEPTH_UNITS_PER_MM) as f32
}

/// Writes an 8- or 16-bit PNG with fast compression (speed matters more than size here).
/// `data` is row-major, 16-bit samples big-endian.
pub(crate) fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    data: &[u8],
) -> Result<(), DataError> {
    let file = File::create(path).map_err(|e| DataError::io(path, e))?;
    let mut w = BufWriter::with_capacity(1 << 16, file);
    {
        let mut enc = png::Encoder::new(&mut w, width, height);
        enc.set_color(color);
        enc.set_depth(depth);
        enc.set_compression(png::Compression::Fast);
        let mut writer = enc
            .write_header()
            .map_err(|e| DataError::image(path, format!("cannot encode PNG: {e}")))?;
        writer
            .write_image_data(data)
            .map_err(|e| DataError::image(path, format!("cannot encode PNG: {e}")))?;
        writer
            .finish()
            .map_err(|e| DataError::image(path, format!("cannot encode PNG: {e}")))?;
    }
    w.flush().map_err(|e| DataError::io(path, e))?;
    Ok(())
}

/// Checks that a pixel buffer has `width × height × channels` samples.
pub(crate) fn check_len(
    path: &Path,
    width: u32,
    height: u32,
    channels: usize,
    len: usize,
) -> Result<(), DataError> {
    let expected = width as usize * height as usize * channels;
    if len != expected {
        return Err(DataError::image(
            path,
            format!("buffer has {len} samples; expected {width}x{height}x{channels} = {expected}"),
        ));
    }
    Ok(())
}

/// Decodes a dataset PNG file (fully, so a corrupt file is found).
pub(crate) fn decode(path: &Path) -> Result<DynamicImage, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    decode_png(path, &bytes)
}

/// Decodes the bytes of a dataset PNG (8-bit grey or RGB image, 16-bit depth, mask), fully,
/// so that a corrupt file is found; `path` names the file in errors.
///
/// # Errors
/// [`DataError::Image`] for bytes that are not a PNG the decoder reads.
pub fn decode_png(path: &Path, bytes: &[u8]) -> Result<DynamicImage, DataError> {
    let mut reader = image::ImageReader::new(Cursor::new(bytes));
    reader.set_format(image::ImageFormat::Png);
    reader
        .decode()
        .map_err(|e| DataError::image(path, format!("cannot decode PNG: {e}")))
}

/// Decodes a 16-bit grey depth PNG into mm (0 = no depth); returns `(width, height, depth_mm)`.
pub(crate) fn decode_depth_mm(path: &Path) -> Result<(u32, u32, Vec<f32>), DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    depth_mm_from_png(path, &bytes)
}

/// Decodes the bytes of a 16-bit grey depth PNG (value = mm × 100) into mm, 0 where there is
/// no depth; returns `(width, height, depth_mm)`, row-major. `path` names the file in errors.
///
/// # Errors
/// [`DataError::Image`] for bytes that are not a PNG, or a PNG that is not 16-bit grey.
pub fn depth_mm_from_png(path: &Path, bytes: &[u8]) -> Result<(u32, u32, Vec<f32>), DataError> {
    match decode_png(path, bytes)? {
        DynamicImage::ImageLuma16(img) => {
            let (w, h) = img.dimensions();
            let d = img.into_raw().into_iter().map(depth_mm_from_code).collect();
            Ok((w, h, d))
        }
        other => Err(DataError::image(
            path,
            format!(
                "depth image is {:?}; expected 16-bit grey (value = mm x 100)",
                other.color()
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_codes() {
        assert_eq!(depth_code_from_mm(12.345), 1235);
        assert_eq!(depth_code_from_mm(f32::NAN), 0);
        assert_eq!(depth_code_from_mm(-1.0), 0);
        assert_eq!(depth_code_from_mm(0.0), 0);
        assert_eq!(depth_code_from_mm(655.35), 65535);
        assert_eq!(depth_code_from_mm(655.36), 0);
        assert!((depth_mm_from_code(1235) - 12.35).abs() < 1e-5);
    }
}
