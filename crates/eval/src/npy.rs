//! NumPy `.npy` files (format version 1.0) of little-endian `float32` arrays: what
//! `numpy.load` reads without help, for descriptors and other per-frame vectors that a person
//! wants to study in Python.
//!
//! Layout: the magic `\x93NUMPY`, version `1 0`, a `u16` header length, then an ASCII Python
//! dict `{'descr': '<f4', 'fortran_order': False, 'shape': (n, d), }` padded with spaces and a
//! closing `\n` so that the data starts at a multiple of 64 bytes, then the values in C
//! (row-major) order.

use crate::EvalError;
use std::path::Path;

const MAGIC: &[u8] = b"\x93NUMPY";

/// The bytes of a `.npy` file holding `values` as a C-order `float32` array of `shape`.
///
/// # Errors
/// [`EvalError::Invalid`] when the shape's product is not `values.len()`.
pub fn npy_f32(shape: &[usize], values: &[f32]) -> Result<Vec<u8>, EvalError> {
    let count: usize = shape.iter().product();
    if count != values.len() {
        return Err(EvalError::Invalid(format!(
            "npy: shape {shape:?} holds {count} values, got {}",
            values.len()
        )));
    }
    let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
    // Python writes a one-element tuple as `(n,)`.
    let shape_text = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape_text}, }}");
    let unpadded = MAGIC.len() + 2 + 2 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let header_len = u16::try_from(header.len())
        .map_err(|_| EvalError::Invalid(format!("npy: shape {shape:?} is too long")))?;
    let mut out = Vec::with_capacity(MAGIC.len() + 4 + header.len() + 4 * values.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&header_len.to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Ok(out)
}

/// Writes `rows` (all of one length) as an `n × d` `float32` `.npy` file, atomically
/// ([`crate::write_atomic`]).
///
/// # Errors
/// [`EvalError::Invalid`] for rows of different lengths; [`EvalError::Io`] naming the file.
pub fn write_npy_rows(path: &Path, rows: &[Vec<f32>]) -> Result<(), EvalError> {
    let d = rows.first().map_or(0, Vec::len);
    if let Some((i, r)) = rows.iter().enumerate().find(|(_, r)| r.len() != d) {
        return Err(EvalError::Invalid(format!(
            "{}: row {i} has {} values, row 0 has {d}",
            path.display(),
            r.len()
        )));
    }
    let flat: Vec<f32> = rows.iter().flatten().copied().collect();
    crate::write_atomic(path, &npy_f32(&[rows.len(), d], &flat)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parses what [`npy_f32`] writes, as numpy would: magic, version, header dict, data.
    fn parse(bytes: &[u8]) -> (String, Vec<f32>) {
        assert_eq!(&bytes[..6], MAGIC);
        assert_eq!(&bytes[6..8], &[1, 0]);
        let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        let header = std::str::from_utf8(&bytes[10..10 + len])
            .unwrap()
            .to_string();
        assert_eq!((10 + len) % 64, 0, "data must start 64-byte aligned");
        assert!(header.ends_with('\n'));
        let data = bytes[10 + len..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        (header, data)
    }

    #[test]
    fn header_names_type_order_and_shape_and_data_follows_in_c_order() {
        let values = [1.0f32, -2.5, 3.25, 0.0, f32::MAX, 1e-7];
        let (header, data) = parse(&npy_f32(&[2, 3], &values).unwrap());
        assert!(
            header.starts_with("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }"),
            "{header}"
        );
        assert_eq!(data, values);
        let (header, data) = parse(&npy_f32(&[4], &values[..4]).unwrap());
        assert!(header.contains("'shape': (4,)"), "{header}");
        assert_eq!(data.len(), 4);
        // An empty array is a valid file too.
        let (header, data) = parse(&npy_f32(&[0, 128], &[]).unwrap());
        assert!(header.contains("'shape': (0, 128)"));
        assert!(data.is_empty());
    }

    #[test]
    fn a_shape_that_does_not_hold_the_values_and_ragged_rows_are_errors() {
        let e = npy_f32(&[2, 2], &[1.0; 3]).unwrap_err().to_string();
        assert!(e.contains("[2, 2]") && e.contains("got 3"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.npy");
        let e = write_npy_rows(&path, &[vec![1.0, 2.0], vec![3.0]])
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 1 has 1 values"), "{e}");
        assert!(!path.exists(), "nothing is written on error");
        write_npy_rows(&path, &[vec![1.0, 2.0], vec![3.0, 4.0]]).unwrap();
        let (header, data) = parse(&std::fs::read(&path).unwrap());
        assert!(header.contains("(2, 2)"));
        assert_eq!(data, [1.0, 2.0, 3.0, 4.0]);
    }
}
