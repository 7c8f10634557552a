//! The small binary files of a model folder (`database.bin`, `whitening.bin`): an 8-byte
//! magic, two 4-byte header words, then little-endian 32-bit values.

use crate::NetError;
use std::path::Path;

/// Bytes of the magic and the two header words.
pub(crate) const HEADER: usize = 16;

/// A file's bytes, started with `magic` and the two header `words`; append the body with
/// [`put_u32`] and [`put_f32`], reserving room for `body` more bytes.
pub(crate) fn start(magic: &[u8; 8], words: [[u8; 4]; 2], body: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + body);
    out.extend_from_slice(magic);
    out.extend_from_slice(&words[0]);
    out.extend_from_slice(&words[1]);
    out
}

pub(crate) fn put_u32(out: &mut Vec<u8>, values: impl IntoIterator<Item = u32>) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

pub(crate) fn put_f32<'a>(out: &mut Vec<u8>, values: impl IntoIterator<Item = &'a f32>) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Reads the bytes of `path`.
///
/// # Errors
/// [`NetError::Io`] if unreadable.
pub(crate) fn read(path: &Path) -> Result<Vec<u8>, NetError> {
    std::fs::read(path).map_err(|e| NetError::io(path, e))
}

/// Checks that the bytes of the file `path` start with `magic` and hold the two header words;
/// `what` names the kind of file in the error ("descriptor database").
///
/// # Errors
/// [`NetError::Parse`] for a short file or another magic.
pub(crate) fn check_header(
    path: &Path,
    bytes: &[u8],
    magic: &[u8; 8],
    what: &str,
) -> Result<(), NetError> {
    if bytes.len() < HEADER || &bytes[..8] != magic {
        return Err(NetError::parse(
            path,
            0,
            format!("not an endoloc {what} (bad header)"),
        ));
    }
    Ok(())
}

/// The 4 bytes at `offset`.
pub(crate) fn word(bytes: &[u8], offset: usize) -> [u8; 4] {
    [
        bytes[offset],
        bytes[offset + 1],
        bytes[offset + 2],
        bytes[offset + 3],
    ]
}

/// `bytes` read as little-endian `u32`s (a trailing partial value is ignored).
pub(crate) fn u32s(bytes: &[u8]) -> impl Iterator<Item = u32> + '_ {
    bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
}

/// `bytes` read as little-endian `f32`s (a trailing partial value is ignored).
pub(crate) fn f32s(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}
