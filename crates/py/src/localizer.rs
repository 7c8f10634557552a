//! The zone classifier (`Model`) and the localizer (`Localizer`, `FrameResult`) from Python.

use std::path::PathBuf;
use std::time::Instant;

use endoloc_jobs::LocalizeJob;
use endoloc_localize::{FrameResult, LiveState, Localizer};
use endoloc_net::ZoneClassifier;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{
    EndolocError, array_from_pose, gray_from_array, job_error, lib_error, path_from_py,
    table_from_dict,
};
use crate::dataset::PyCamera;

/// A trained model folder (`endoloc train`): the Siamese network, its zones and the
/// descriptor database of the training pass.
#[pyclass(module = "endoloc", name = "Model", frozen)]
pub struct PyModel {
    /// Boxed: parts of a classifier are aligned beyond what Python's allocator guarantees for
    /// the object that holds it.
    classifier: Box<ZoneClassifier>,
}

/// Grey images from a NumPy array (one image H×W or H×W×3, or a stack N×H×W or N×H×W×3) or
/// a list of arrays.
fn images_from(obj: &Bound<'_, PyAny>) -> PyResult<Vec<image::GrayImage>> {
    let each = |o: &Bound<'_, PyAny>| -> PyResult<Vec<image::GrayImage>> {
        o.try_iter()?.map(|im| gray_from_array(&im?)).collect()
    };
    if let Ok(shape) = obj.getattr("shape").and_then(|s| s.extract::<Vec<usize>>()) {
        return match shape[..] {
            [_, _] | [_, _, 1 | 3 | 4] => Ok(vec![gray_from_array(obj)?]),
            [_, _, _] | [_, _, _, _] => each(obj),
            _ => Err(pyo3::exceptions::PyValueError::new_err(format!(
                "expected images of shape (H, W), (H, W, 3), (N, H, W) or (N, H, W, 3), got {shape:?}"
            ))),
        };
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<pyo3::types::PyTuple>() {
        return each(obj);
    }
    Err(PyTypeError::new_err(
        "expected images: a NumPy uint8 array (H×W, or a stack N×H×W), or a list of arrays",
    ))
}

#[pymethods]
impl PyModel {
    /// Loads a model folder on the CPU.
    #[staticmethod]
    fn load(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let dir = path_from_py(path)?;
        let classifier = py.detach(|| ZoneClassifier::load(&dir)).map_err(|e| {
            job_error(endoloc_jobs::JobError::Context {
                context: format!("loading model {}", dir.display()),
                source: Box::new(e.into()),
            })
        })?;
        Ok(PyModel {
            classifier: Box::new(classifier),
        })
    }
    /// The model folder.
    #[getter]
    fn path(&self) -> PathBuf {
        self.classifier.dir().to_path_buf()
    }
    /// Number of zones along the training pass.
    #[getter]
    fn zone_count(&self) -> usize {
        self.classifier.zone_count()
    }
    /// Length of a descriptor.
    #[getter]
    fn descriptor_dim(&self) -> usize {
        self.classifier.database().dim
    }
    /// The camera the model was trained with (test images must match it).
    #[getter]
    fn camera(&self) -> PyCamera {
        PyCamera {
            camera: self.classifier.config().camera,
        }
    }
    /// Median pose `T_wc` of every zone: `float64` (Z, 4, 4), mm — the initial pose of a frame
    /// classified to that zone.
    #[getter]
    fn zone_poses<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray3<f64>> {
        let zones = &self.classifier.zones().zones;
        numpy::ndarray::Array3::from_shape_fn((zones.len(), 4, 4), |(k, i, j)| {
            zones[k].median_pose.to_homogeneous()[(i, j)]
        })
        .into_pyarray(py)
    }
    /// The zone of one frame and every zone's score: `(zone, scores)`, zone 0-based along the
    /// training pass, scores a `float32` array (Z,) of descriptor distances (lower = better).
    fn classify<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
    ) -> PyResult<(usize, Bound<'py, PyArray1<f32>>)> {
        let img = gray_from_array(image)?;
        let p = py
            .detach(|| self.classifier.classify(&img))
            .map_err(lib_error)?;
        Ok((p.zone, PyArray1::from_vec(py, p.zone_scores)))
    }
    /// Descriptors of images (one H×W array, a stack N×H×W or a list of arrays): `float32`
    /// (N, D), unit rows, as the training database holds them.
    fn describe<'py>(
        &self,
        py: Python<'py>,
        images: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let imgs = images_from(images)?;
        let d = self.classifier.database().dim;
        let rows = py
            .detach(|| self.classifier.describe_batch(&imgs))
            .map_err(lib_error)?;
        let flat: Vec<f32> = rows.into_iter().flatten().collect();
        let a = Array2::from_shape_vec((imgs.len(), d), flat)
            .map_err(|e| EndolocError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }
    fn __repr__(&self) -> String {
        format!(
            "Model({:?}, {} zones)",
            self.classifier.dir().display().to_string(),
            self.classifier.zone_count()
        )
    }
}

/// The outcome for one frame, as a row of `frames.csv`.
#[pyclass(module = "endoloc", name = "FrameResult", frozen)]
pub struct PyFrameResult {
    result: Box<FrameResult>,
    wall_ms: Option<f64>,
}

impl PyFrameResult {
    /// Wraps a result; `wall_ms` is the wall time of the library call that made it.
    pub fn from_result(result: FrameResult, wall_ms: Option<f64>) -> Self {
        PyFrameResult {
            result: Box::new(result),
            wall_ms,
        }
    }
}

#[pymethods]
impl PyFrameResult {
    /// Pose `T_wc` (4×4 `float64`, mm): refined, or the initial pose for `init_only`; `None`
    /// when rejected.
    #[getter]
    fn pose<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.result.t_wc.as_ref().map(|p| array_from_pose(py, p))
    }
    /// Camera position `t_wc` (`float64` (3,), mm, world frame); `None` when rejected.
    #[getter]
    fn position<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.result
            .t_wc
            .as_ref()
            .map(|p| PyArray1::from_slice(py, p.translation.vector.as_slice()))
    }
    /// Camera-to-world rotation as the unit quaternion `(qx, qy, qz, qw)` with `qw ≥ 0` —
    /// the last four columns of a TUM line; `None` when rejected.
    #[getter]
    fn quaternion<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.result.t_wc.as_ref().map(|p| {
            let q = endoloc_geometry::canonical_quaternion(p.rotation);
            PyArray1::from_slice(py, &[q.i, q.j, q.k, q.w])
        })
    }
    /// `refined`, `init_only` or `rejected`.
    #[getter]
    fn status(&self) -> &'static str {
        self.result.status.as_str()
    }
    /// Why the frame is not `refined`: a keyword (`too_few_correspondences`,
    /// `too_few_inliers`, `rms_too_high`, `jump_too_large`, `degenerate_geometry`,
    /// `unreadable_image`); `None` when refined.
    #[getter]
    fn reason(&self) -> Option<&'static str> {
        self.result.reason.as_ref().map(|r| r.code())
    }
    /// The reason in words, with its numbers; `None` when refined.
    #[getter]
    fn reason_detail(&self) -> Option<String> {
        self.result.reason.as_ref().map(|r| r.to_string())
    }
    /// Zone used (0-based along the training pass); `None` for a frame that has none.
    #[getter]
    fn zone(&self) -> Option<usize> {
        self.result.has_zone().then_some(self.result.zone)
    }
    /// The classifier's score of that zone (descriptor distance, lower = better); ``None``
    /// when the frame was not classified (live, tracked from the motion model's prediction).
    #[getter]
    fn zone_score(&self) -> Option<f32> {
        (self.result.has_zone() && self.result.zone_score.is_finite())
            .then_some(self.result.zone_score)
    }
    /// Where the pose comes from: ``refined``, ``predicted`` (live motion model),
    /// ``zone_median`` or ``none``.
    #[getter]
    fn source(&self) -> &'static str {
        self.result.source.as_str()
    }
    /// Calibrated standard deviations of a refined pose: ``(position_mm, orientation_deg)``
    /// along its least certain direction (1.96 × bounds ~95 % of errors); ``None`` unless
    /// refined.
    #[getter]
    fn std(&self) -> Option<(f64, f64)> {
        let r = &self.result;
        (r.position_std_mm.is_finite() && r.orientation_std_deg.is_finite())
            .then_some((r.position_std_mm, r.orientation_std_deg))
    }
    /// Inliers of the final estimate.
    #[getter]
    fn inliers(&self) -> usize {
        self.result.inliers
    }
    /// Correspondences found by matching.
    #[getter]
    fn correspondences(&self) -> usize {
        self.result.correspondences
    }
    /// Inlier keypoints in the image: `float32` (K, 2), pixels (x right, y down, origin at
    /// the centre of the top-left pixel).
    #[getter]
    fn inlier_px<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        let px = &self.result.inlier_px;
        Array2::from_shape_fn((px.len(), 2), |(i, j)| px[i][j]).into_pyarray(py)
    }
    /// RMS reprojection error of the inliers, pixels; `None` when there is no estimate.
    #[getter]
    fn reprojection_rms_px(&self) -> Option<f64> {
        let r = self.result.reprojection_rms_px;
        r.is_finite().then_some(r)
    }
    /// Time spent per stage, ms: `zone`, `surf`, `matching`, `refine`.
    #[getter]
    fn times_ms<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = &self.result.times;
        let d = PyDict::new(py);
        d.set_item("zone", t.zone_ms)?;
        d.set_item("surf", t.surf_ms)?;
        d.set_item("matching", t.matching_ms)?;
        d.set_item("refine", t.refine_ms)?;
        Ok(d)
    }
    /// Time of the frame as `frames.csv` gives it (sum of the stages), ms.
    #[getter]
    fn time_ms(&self) -> f64 {
        self.result.times.total_ms()
    }
    /// Wall time of the library call that localized the frame, ms (`Localizer.localize`
    /// only; `None` in a job's report).
    #[getter]
    fn wall_ms(&self) -> Option<f64> {
        self.wall_ms
    }
    fn __repr__(&self) -> String {
        let zone = self
            .zone()
            .map_or_else(|| "-".to_string(), |z| z.to_string());
        match self.reason() {
            Some(r) => format!(
                "FrameResult({}, reason={r}, zone={zone}, inliers={})",
                self.status(),
                self.result.inliers
            ),
            None => format!(
                "FrameResult({}, zone={zone}, inliers={})",
                self.status(),
                self.result.inliers
            ),
        }
    }
}

/// The localizer: a model, its map and the settings of `endoloc localize`, for frames one at
/// a time. Live (frames in order, as a scope delivers them) it keeps the causal filters and
/// the last refined pose between calls.
#[pyclass(module = "endoloc", name = "Localizer")]
pub struct PyLocalizer {
    /// Boxed, as [`PyModel::classifier`].
    localizer: Box<Localizer>,
    /// The live stream's state; `None` when frames are independent.
    live: Option<Box<LiveState>>,
    job: LocalizeJob,
}

/// The localize job's options that do not apply to a localizer fed frame by frame (what to
/// run, where the frames come from and where results go); `live`, `mask` and the model are
/// the localizer's own arguments.
const NOT_LOCALIZER_OPTIONS: &[&str] = &[
    "method",
    "model",
    "regressor",
    "reference_seq",
    "seq",
    "video",
    "realtime",
    "size",
    "pix_fmt",
    "mask",
    "out",
    "live",
    "strict",
    "force",
];

/// The keyword arguments of `Localizer`: the localize job's, less [`NOT_LOCALIZER_OPTIONS`].
fn localizer_keywords() -> PyResult<Vec<crate::options::Keyword>> {
    Ok(crate::options::keywords_of("localize")?
        .into_iter()
        .filter(|k| !NOT_LOCALIZER_OPTIONS.contains(&k.field.as_str()))
        .collect())
}

#[pymethods]
impl PyLocalizer {
    /// A localizer for `model` (a `Model` or its folder, with its map from `endoloc map`):
    /// live or per frame, with `endoloc localize`'s options as keyword arguments. `mask`: the
    /// frames' image mask — a dataset folder (its `[camera] mask`) or a mask PNG; SURF keeps
    /// inside it and the zone network sees frames black outside it, as in training.
    #[new]
    #[pyo3(signature = (model, live=false, mask=None, **options))]
    fn new(
        py: Python<'_>,
        model: &Bound<'_, PyAny>,
        live: bool,
        mask: Option<&Bound<'_, PyAny>>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mask_path = mask.map(path_from_py).transpose()?;
        let dir = match model.cast::<PyModel>() {
            Ok(m) => m.get().classifier.dir().to_path_buf(),
            Err(_) => path_from_py(model)?,
        };
        let t = match options {
            Some(d) => table_from_dict(d)?,
            None => toml::Table::new(),
        };
        let mut t = crate::options::table_from_keywords("Localizer", &localizer_keywords()?, t)?;
        t.insert(
            "model".into(),
            toml::Value::String(dir.to_string_lossy().into_owned()),
        );
        t.insert("live".into(), toml::Value::Boolean(live));
        let text = toml::to_string(&t).map_err(|e| EndolocError::new_err(e.to_string()))?;
        let job: LocalizeJob = toml::from_str(&text).map_err(|e| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "Localizer(): invalid option: {}",
                e.to_string().trim()
            ))
        })?;
        let localizer = py
            .detach(|| {
                let localizer = job.localizer()?;
                let mask = match &mask_path {
                    Some(p) => endoloc_jobs::localize::read_mask(p, localizer.camera())?,
                    None => None,
                };
                Ok(localizer.with_mask(mask))
            })
            .map_err(job_error)?;
        let live = live.then(|| Box::new(localizer.live_state()));
        Ok(PyLocalizer {
            localizer: Box::new(localizer),
            live,
            job,
        })
    }

    /// Localizes one frame (grey H×W or RGB H×W×3 `uint8`, the model's image size). Live,
    /// frames must come in order.
    fn localize(&mut self, py: Python<'_>, image: &Bound<'_, PyAny>) -> PyResult<PyFrameResult> {
        let img = gray_from_array(image)?;
        let localizer = &self.localizer;
        let live = &mut self.live;
        let (result, wall_ms) = py.detach(|| {
            let t = Instant::now();
            let r = match live {
                Some(state) => localizer.localize_live(state, &img),
                None => localizer.localize(&img),
            };
            (r, t.elapsed().as_secs_f64() * 1e3)
        });
        let result = result.map_err(lib_error)?;
        Ok(PyFrameResult::from_result(result, Some(wall_ms)))
    }

    /// Forgets the live stream's past (a new video); no effect per frame.
    fn reset(&mut self) {
        if let Some(s) = &mut self.live {
            s.reset();
        }
    }

    /// Whether frames are localized live (in order, with the causal filters).
    #[getter]
    fn live(&self) -> bool {
        self.live.is_some()
    }

    /// Frames seen so far in live mode.
    #[getter]
    fn frames(&self) -> usize {
        self.live.as_ref().map_or(0, |s| s.frames())
    }

    /// The camera of the model and map (test images must have its size).
    #[getter]
    fn camera(&self) -> PyCamera {
        PyCamera {
            camera: *self.localizer.camera(),
        }
    }

    /// The settings as `endoloc localize` would record them (`localize.toml`), TOML.
    #[getter]
    fn settings(&self) -> String {
        toml::to_string_pretty(&self.job).unwrap_or_default()
    }

    fn __repr__(&self) -> String {
        format!(
            "Localizer({:?}, live={})",
            self.localizer.classifier().dir().display().to_string(),
            if self.live.is_some() { "True" } else { "False" }
        )
    }
}

/// Wall time of `Localizer.localize`'s library call alone on each of `images`, seconds per
/// frame, with the images converted beforehand: the Rust side of the binding's overhead
/// benchmark.
#[pyfunction]
pub fn time_rust_calls(
    py: Python<'_>,
    localizer: &Bound<'_, PyLocalizer>,
    images: &Bound<'_, PyAny>,
) -> PyResult<Vec<f64>> {
    let imgs = images_from(images)?;
    let mut loc = localizer.borrow_mut();
    let loc = &mut *loc;
    let localizer = &loc.localizer;
    let live = &mut loc.live;
    py.detach(|| {
        let mut out = Vec::with_capacity(imgs.len());
        for img in &imgs {
            let t = Instant::now();
            let r = match live.as_mut() {
                Some(state) => localizer.localize_live(state, img),
                None => localizer.localize(img),
            };
            out.push(t.elapsed().as_secs_f64());
            r?;
        }
        Ok::<_, endoloc_localize::LocalizeError>(out)
    })
    .map_err(lib_error)
}
