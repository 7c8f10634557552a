//! Datasets, sequences, cameras and TUM trajectories from Python.

use std::path::PathBuf;

use endoloc_data::{Dataset, Sequence, StampedPose};
use endoloc_geometry::{Camera, Distortion};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray3, PyReadonlyArray1};
use pyo3::exceptions::{PyIndexError, PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{
    array_from_gray, array_from_pose, array_from_rgb, lib_error, path_from_py, pose_from_array,
};

/// A pinhole camera with optional OpenCV distortion: intrinsics in pixels, OpenCV axes (x
/// right, y down, z forward), pixel origin at the centre of the top-left pixel.
#[pyclass(module = "endoloc", name = "Camera", frozen)]
#[derive(Clone)]
pub struct PyCamera {
    pub(crate) camera: Camera,
}

#[pymethods]
impl PyCamera {
    /// Image width, pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.camera.width
    }
    /// Image height, pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.camera.height
    }
    /// Focal length along x, pixels.
    #[getter]
    fn fx(&self) -> f64 {
        self.camera.fx
    }
    /// Focal length along y, pixels.
    #[getter]
    fn fy(&self) -> f64 {
        self.camera.fy
    }
    /// Principal point x, pixels.
    #[getter]
    fn cx(&self) -> f64 {
        self.camera.cx
    }
    /// Principal point y, pixels.
    #[getter]
    fn cy(&self) -> f64 {
        self.camera.cy
    }
    /// The 3×3 intrinsic matrix `K` (pixels).
    #[getter(K)]
    fn k<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        let c = &self.camera;
        let k = [[c.fx, 0.0, c.cx], [0.0, c.fy, c.cy], [0.0, 0.0, 1.0]];
        Array2::from_shape_fn((3, 3), |(i, j)| k[i][j]).into_pyarray(py)
    }
    /// Lens distortion: `None`, or a dict with `model` (`radial-tangential`: OpenCV's `k1 k2 p1
    /// p2 k3`; `fisheye`: OpenCV's equidistant `k1 k2 k3 k4`) and its coefficients.
    #[getter]
    fn distortion<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let d = PyDict::new(py);
        match self.camera.distortion {
            Distortion::None => return Ok(None),
            Distortion::RadialTangential { k1, k2, p1, p2, k3 } => {
                d.set_item("model", "radial-tangential")?;
                for (k, v) in [("k1", k1), ("k2", k2), ("p1", p1), ("p2", p2), ("k3", k3)] {
                    d.set_item(k, v)?;
                }
            }
            Distortion::Fisheye { k1, k2, k3, k4 } => {
                d.set_item("model", "fisheye")?;
                for (k, v) in [("k1", k1), ("k2", k2), ("k3", k3), ("k4", k4)] {
                    d.set_item(k, v)?;
                }
            }
        }
        Ok(Some(d))
    }
    /// Horizontal field of view, degrees.
    #[getter]
    fn hfov_deg(&self) -> f64 {
        self.camera.hfov_deg()
    }
    fn __repr__(&self) -> String {
        let c = &self.camera;
        format!(
            "Camera({}x{}, fx={}, fy={}, cx={}, cy={}{})",
            c.width,
            c.height,
            c.fx,
            c.fy,
            c.cx,
            c.cy,
            if c.distortion.is_none() {
                ""
            } else {
                ", distorted"
            }
        )
    }
}

/// An endoloc dataset (format version 1) opened for reading: `dataset.toml`, its camera and
/// its sequences (`ds["test"]`).
#[pyclass(module = "endoloc", name = "Dataset", frozen)]
pub struct PyDataset {
    dataset: Box<Dataset>,
}

#[pymethods]
impl PyDataset {
    /// Opens the dataset folder `path` (with `dataset.toml`).
    #[new]
    fn new(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let dir = path_from_py(path)?;
        let dataset = py.detach(|| Dataset::open(&dir)).map_err(lib_error)?;
        Ok(PyDataset {
            dataset: Box::new(dataset),
        })
    }
    /// The dataset folder.
    #[getter]
    fn path(&self) -> PathBuf {
        self.dataset.root.clone()
    }
    /// The dataset's name.
    #[getter]
    fn name(&self) -> String {
        self.dataset.meta.name.clone()
    }
    /// The camera of every image of every sequence.
    #[getter]
    fn camera(&self) -> PyCamera {
        PyCamera {
            camera: self.dataset.meta.camera,
        }
    }
    /// The sequence names (sub-folders with a `poses.txt`), sorted.
    #[getter]
    fn sequences(&self) -> Vec<String> {
        self.dataset.sequences.clone()
    }
    /// The passes without poses (sub-folders with a `frames.txt` and no `poses.txt`: a
    /// video imported without a pose log), sorted: localized by folder, not opened here.
    #[getter]
    fn unposed(&self) -> Vec<String> {
        self.dataset.unposed.clone()
    }
    /// The simulator's configuration (TOML text) when the dataset was simulated.
    #[getter]
    fn simulation(&self) -> Option<String> {
        self.dataset
            .meta
            .simulation
            .as_ref()
            .and_then(|t| toml::to_string(t).ok())
    }
    /// The sequence `name`.
    fn sequence(&self, py: Python<'_>, name: &str) -> PyResult<PySequence> {
        let seq = py
            .detach(|| self.dataset.sequence(name))
            .map_err(lib_error)?;
        Ok(PySequence { seq: Box::new(seq) })
    }
    fn __getitem__(&self, py: Python<'_>, name: &str) -> PyResult<PySequence> {
        if !self.dataset.sequences.iter().any(|s| s == name) {
            return Err(PyKeyError::new_err(format!(
                "no sequence {name:?} in {}; it has: {}",
                self.dataset.root.display(),
                self.dataset.sequences.join(", ")
            )));
        }
        self.sequence(py, name)
    }
    fn __contains__(&self, name: &str) -> bool {
        self.dataset.sequences.iter().any(|s| s == name)
    }
    fn __repr__(&self) -> String {
        format!(
            "Dataset({:?}: {}, sequences {:?})",
            self.dataset.root.display().to_string(),
            self.camera().__repr__(),
            self.dataset.sequences
        )
    }
}

/// One sequence of a dataset: poses in memory, images read on demand. `len(seq)` frames;
/// `seq[i]` is frame `i` as grey `uint8` (H×W), loaded exactly as `endoloc localize` loads it.
#[pyclass(module = "endoloc", name = "Sequence", frozen)]
pub struct PySequence {
    pub(crate) seq: Box<Sequence>,
}

impl PySequence {
    fn index(&self, i: isize) -> PyResult<usize> {
        let n = self.seq.len() as isize;
        let j = if i < 0 { i + n } else { i };
        if j < 0 || j >= n {
            return Err(PyIndexError::new_err(format!(
                "frame {i} out of range; sequence {:?} has {n} frames",
                self.seq.name
            )));
        }
        Ok(j as usize)
    }
}

#[pymethods]
impl PySequence {
    /// Opens a sequence folder directly (`images/`, `poses.txt`).
    #[new]
    fn new(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let dir = path_from_py(path)?;
        let seq = py.detach(|| Sequence::open(&dir)).map_err(lib_error)?;
        Ok(PySequence { seq: Box::new(seq) })
    }
    /// The sequence's name (its folder's).
    #[getter]
    fn name(&self) -> String {
        self.seq.name.clone()
    }
    /// The sequence folder.
    #[getter]
    fn path(&self) -> PathBuf {
        self.seq.dir.clone()
    }
    /// Camera-to-world poses `T_wc` of every frame: `float64` array of shape (N, 4, 4), mm.
    #[getter]
    fn poses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        poses_array(py, &self.seq.poses)
    }
    /// Time stamps of every frame, seconds: `float64` array of shape (N,).
    #[getter]
    fn timestamps<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_iter(self.seq.poses.iter().map(|p| p.timestamp_s)).into_pyarray(py)
    }
    /// The pose `T_wc` of frame `i`: 4×4 `float64`, mm.
    fn pose<'py>(&self, py: Python<'py>, i: isize) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let i = self.index(i)?;
        Ok(array_from_pose(py, &self.seq.poses[i].pose))
    }
    /// Image `i` as `uint8`: grey (H×W), or RGB (H×W×3) with `rgb=True`.
    #[pyo3(signature = (i, rgb=false))]
    fn image<'py>(&self, py: Python<'py>, i: isize, rgb: bool) -> PyResult<Bound<'py, PyAny>> {
        let i = self.index(i)?;
        if rgb {
            let img = py.detach(|| self.seq.load_rgb(i)).map_err(lib_error)?;
            array_from_rgb(py, img)
        } else {
            let img = py.detach(|| self.seq.load_gray(i)).map_err(lib_error)?;
            array_from_gray(py, img)
        }
    }
    /// Depth map `i` along the optical axis, mm (`float32`, H×W; 0 where there is none).
    fn depth<'py>(&self, py: Python<'py>, i: isize) -> PyResult<Bound<'py, PyAny>> {
        let i = self.index(i)?;
        let (w, h, d) = py.detach(|| self.seq.load_depth_mm(i)).map_err(lib_error)?;
        let a = Array2::from_shape_vec((h as usize, w as usize), d)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py).into_any())
    }
    /// Whether the sequence has depth maps.
    #[getter]
    fn has_depth(&self) -> bool {
        self.seq.depth_paths.is_some()
    }
    /// Anatomical section of every frame (`sections.csv`), or `None`.
    #[getter]
    fn sections(&self) -> Option<Vec<String>> {
        self.seq
            .sections
            .as_ref()
            .map(|s| s.iter().map(|x| x.to_string()).collect())
    }
    /// The image files in frame order.
    #[getter]
    fn image_paths(&self) -> Vec<PathBuf> {
        self.seq.image_paths.clone()
    }
    fn __len__(&self) -> usize {
        self.seq.len()
    }
    fn __getitem__<'py>(&self, py: Python<'py>, i: isize) -> PyResult<Bound<'py, PyAny>> {
        self.image(py, i, false)
    }
    fn __repr__(&self) -> String {
        format!(
            "Sequence({:?}, {} frames)",
            self.seq.dir.display().to_string(),
            self.seq.len()
        )
    }
}

/// Poses as an (N, 4, 4) array.
fn poses_array<'py>(py: Python<'py>, poses: &[StampedPose]) -> Bound<'py, PyArray3<f64>> {
    let mut a = Array3::zeros((poses.len(), 4, 4));
    for (k, p) in poses.iter().enumerate() {
        let m = p.pose.to_homogeneous();
        for i in 0..4 {
            for j in 0..4 {
                a[(k, i, j)] = m[(i, j)];
            }
        }
    }
    a.into_pyarray(py)
}

/// Time stamps (N,) and poses (N, 4, 4) of a trajectory.
type Trajectory<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray3<f64>>);

/// Reads a TUM trajectory (`timestamp tx ty tz qx qy qz qw`; `T_wc`, mm): returns the time
/// stamps (N,) and the poses (N, 4, 4).
#[pyfunction]
pub fn read_tum<'py>(py: Python<'py>, path: &Bound<'py, PyAny>) -> PyResult<Trajectory<'py>> {
    let path = path_from_py(path)?;
    let poses = py
        .detach(|| endoloc_data::read_tum(&path))
        .map_err(lib_error)?;
    let t = Array1::from_iter(poses.iter().map(|p| p.timestamp_s)).into_pyarray(py);
    Ok((t, poses_array(py, &poses)))
}

/// Writes a TUM trajectory as endoloc writes one (atomically; canonical quaternions,
/// `qw ≥ 0`): `timestamps` (N,) in seconds, `poses` (N, 4, 4) `T_wc` in mm.
#[pyfunction]
pub fn write_tum(
    py: Python<'_>,
    path: &Bound<'_, PyAny>,
    timestamps: PyReadonlyArray1<'_, f64>,
    poses: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let path = path_from_py(path)?;
    let t = timestamps.as_array();
    let n: usize = poses.len()?;
    if n != t.len() {
        return Err(PyValueError::new_err(format!(
            "{} time stamps but {n} poses; expected one time stamp per pose",
            t.len()
        )));
    }
    let mut stamped = Vec::with_capacity(n);
    for (k, ts) in t.iter().enumerate() {
        let pose = pose_from_array(&poses.get_item(k)?)
            .map_err(|e| PyValueError::new_err(format!("pose {k}: {e}")))?;
        stamped.push(StampedPose {
            timestamp_s: *ts,
            pose,
        });
    }
    py.detach(|| endoloc_data::write_tum(&path, &stamped))
        .map_err(lib_error)
}
