//! Conversions between Python values and endoloc's: images (NumPy `uint8`), poses (4×4
//! `float64`, `T_wc`, mm), errors (`EndolocError` with the full message) and job options
//! (keyword arguments → a TOML table → the job's serde struct).

use endoloc_geometry::Pose;
use endoloc_jobs::JobError;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

pyo3::create_exception!(
    endoloc,
    EndolocError,
    pyo3::exceptions::PyException,
    "An endoloc job or call failed; the message is endoloc's own: what was being done, then \
     each cause (file, line, what was expected)."
);

/// Tolerance on a user's pose matrix: Frobenius norm of `RᵀR − I` and of the bottom row's
/// difference to `0 0 0 1`.
pub const POSE_TOLERANCE: f64 = 1e-6;

/// The Python exception for a job error: `EndolocError` with every cause in its message.
pub fn job_error(e: JobError) -> PyErr {
    EndolocError::new_err(e.full_message())
}

/// Any library error, through [`JobError`]'s conversions.
pub fn lib_error(e: impl Into<JobError>) -> PyErr {
    job_error(e.into())
}

/// `type(obj).__name__` with its shape and dtype when it is an array: for error messages.
fn describe(obj: &Bound<'_, PyAny>) -> String {
    let ty = obj
        .get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string());
    match (obj.getattr("shape"), obj.getattr("dtype")) {
        (Ok(shape), Ok(dtype)) => format!("{ty} of shape {shape} and dtype {dtype}"),
        _ => ty,
    }
}

/// A grey image from a NumPy `uint8` array: `H×W` grey, `H×W×1`, `H×W×3` RGB or `H×W×4`
/// RGBA (colour is converted to grey exactly as endoloc converts a colour PNG).
pub fn gray_from_array(obj: &Bound<'_, PyAny>) -> PyResult<image::GrayImage> {
    let arr: PyReadonlyArrayDyn<'_, u8> = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!(
            "expected an image as a NumPy array of uint8 (H×W grey, H×W×3 RGB or H×W×4 RGBA), got {}",
            describe(obj)
        ))
    })?;
    let shape = arr.shape().to_vec();
    let bad = || {
        PyValueError::new_err(format!(
            "expected an image of shape (H, W), (H, W, 3) or (H, W, 4), got shape {shape:?}"
        ))
    };
    let (h, w, c) = match shape[..] {
        [h, w] => (h, w, 1),
        [h, w, c @ (1 | 3 | 4)] => (h, w, c),
        _ => return Err(bad()),
    };
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(bad());
    };
    if w == 0 || h == 0 {
        return Err(PyValueError::new_err(format!(
            "the image is empty (shape {shape:?})"
        )));
    }
    let raw: Vec<u8> = match arr.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => arr.as_array().iter().copied().collect(),
    };
    let dynamic = match c {
        1 => image::GrayImage::from_raw(w32, h32, raw).map(image::DynamicImage::ImageLuma8),
        3 => image::RgbImage::from_raw(w32, h32, raw).map(image::DynamicImage::ImageRgb8),
        _ => image::RgbaImage::from_raw(w32, h32, raw).map(image::DynamicImage::ImageRgba8),
    };
    match dynamic {
        Some(image::DynamicImage::ImageLuma8(g)) => Ok(g),
        Some(other) => Ok(other.into_luma8()),
        None => Err(bad()),
    }
}

/// A NumPy `uint8` array of shape `(H, W)` from a grey image.
pub fn array_from_gray<'py>(py: Python<'py>, img: image::GrayImage) -> PyResult<Bound<'py, PyAny>> {
    let (w, h) = img.dimensions();
    let a = Array2::from_shape_vec((h as usize, w as usize), img.into_raw())
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py).into_any())
}

/// A NumPy `uint8` array of shape `(H, W, 3)` from an RGB image.
pub fn array_from_rgb<'py>(py: Python<'py>, img: image::RgbImage) -> PyResult<Bound<'py, PyAny>> {
    let (w, h) = img.dimensions();
    let a = numpy::ndarray::Array3::from_shape_vec((h as usize, w as usize, 3), img.into_raw())
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py).into_any())
}

/// The 4×4 homogeneous matrix of a pose (`T_wc`, mm) as a NumPy `float64` array.
pub fn array_from_pose<'py>(py: Python<'py>, pose: &Pose) -> Bound<'py, PyArray2<f64>> {
    let m = pose.to_homogeneous();
    Array2::from_shape_fn((4, 4), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// A pose from a 4×4 array-like (`T_wc`, mm); its rotation block must be a rotation within
/// [`POSE_TOLERANCE`].
pub fn pose_from_array(obj: &Bound<'_, PyAny>) -> PyResult<Pose> {
    let m = matrix4(obj)?;
    endoloc_geometry::pose_from_matrix(&m, POSE_TOLERANCE)
        .map_err(|e| PyValueError::new_err(format!("not a pose T_wc: {e}")))
}

fn matrix4(obj: &Bound<'_, PyAny>) -> PyResult<nalgebra::Matrix4<f64>> {
    let err = || {
        PyValueError::new_err(format!(
            "expected a 4×4 pose matrix (float64), got {}",
            describe(obj)
        ))
    };
    let arr: PyReadonlyArray2<'_, f64> = match obj.extract() {
        Ok(a) => a,
        Err(_) => {
            // Lists, float32 or integer arrays: through numpy.asarray(…, float64).
            let np = obj.py().import("numpy")?;
            np.call_method1("asarray", (obj, "float64"))
                .and_then(|a| a.extract::<PyReadonlyArray2<'_, f64>>())
                .map_err(|_| err())?
        }
    };
    if arr.shape() != [4, 4] {
        return Err(err());
    }
    let a = arr.as_array();
    Ok(nalgebra::Matrix4::from_fn(|i, j| a[(i, j)]))
}

/// A path from `str` or any `os.PathLike`.
pub fn path_from_py(obj: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
    obj.extract::<std::path::PathBuf>().map_err(|_| {
        PyTypeError::new_err(format!(
            "expected a path (str or os.PathLike), got {}",
            describe(obj)
        ))
    })
}

/// A TOML value from a keyword argument's value; `None` for Python `None` (the default).
pub fn toml_from_py(key: &str, v: &Bound<'_, PyAny>) -> PyResult<Option<toml::Value>> {
    let bad = || {
        PyTypeError::new_err(format!(
            "option {key}: expected a bool, int, float, str, path, list or dict, got {}",
            describe(v)
        ))
    };
    if v.is_none() {
        return Ok(None);
    }
    // bool first: a Python bool is also an int.
    let value = if v.is_instance_of::<PyBool>() {
        toml::Value::Boolean(v.extract()?)
    } else if v.is_instance_of::<PyInt>() {
        toml::Value::Integer(v.extract().map_err(|_| {
            PyValueError::new_err(format!("option {key}: {v} does not fit a 64-bit integer"))
        })?)
    } else if v.is_instance_of::<PyFloat>() {
        toml::Value::Float(v.extract()?)
    } else if v.is_instance_of::<PyString>() {
        toml::Value::String(v.extract()?)
    } else if v.hasattr("__fspath__")? {
        toml::Value::String(path_from_py(v)?.to_string_lossy().into_owned())
    } else if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for item in v.try_iter()? {
            match toml_from_py(key, &item?)? {
                Some(x) => items.push(x),
                None => return Err(bad()),
            }
        }
        toml::Value::Array(items)
    } else if let Ok(d) = v.cast::<PyDict>() {
        toml::Value::Table(table_from_dict(d)?)
    } else if v.hasattr("__index__")? {
        // NumPy integer scalars.
        toml::Value::Integer(v.extract().map_err(|_| bad())?)
    } else if let Ok(x) = v.extract::<f64>() {
        // NumPy float scalars and anything else with __float__.
        toml::Value::Float(x)
    } else {
        return Err(bad());
    };
    Ok(Some(value))
}

/// A TOML table from a dict of keyword arguments (`None` values left out: the default).
pub fn table_from_dict(d: &Bound<'_, PyDict>) -> PyResult<toml::Table> {
    let mut t = toml::Table::new();
    for (k, v) in d.iter() {
        let key: String = k
            .extract()
            .map_err(|_| PyTypeError::new_err("option names must be strings"))?;
        if let Some(value) = toml_from_py(&key, &v)? {
            t.insert(key, value);
        }
    }
    Ok(t)
}
