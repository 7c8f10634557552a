//! endoloc's jobs from Python: keyword arguments → the job's TOML table (the one `endoloc run`
//! reads) → the typed job → `run` with the GIL released and progress sent to a Python
//! callback.

use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use endoloc_experiments::{
    BenchmarkJob, ChangesJob, CompareJob, ExpertJob, PerturbJob, ZoneSweepJob,
};
use endoloc_jobs::{
    ClassifyJob, DemoJob, EvalJob, FeaturesJob, ImportJob, LocalizeJob, MapJob, PretrainJob,
    Progress, RunJob, SimulateJob, TrainJob, ViewJob,
};
use endoloc_localize::FrameResult;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::convert::{job_error, table_from_dict};
use crate::localizer::PyFrameResult;
use crate::options::{keywords_of, options_of, table_from_keywords, unknown_job};

/// The job's TOML table from keyword arguments.
fn job_table(job: &str, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<toml::Table> {
    let t = match kwargs {
        Some(d) => table_from_dict(d)?,
        None => toml::Table::new(),
    };
    table_from_keywords(job, &keywords_of(job)?, t)
}

/// The job from its table, through the same deserialisation as `endoloc run`.
fn job_from_table<J: DeserializeOwned>(job: &str, t: toml::Table) -> PyResult<J> {
    let text = toml::to_string(&t).map_err(|e| PyValueError::new_err(e.to_string()))?;
    toml::from_str(&text).map_err(|e| {
        PyValueError::new_err(format!("{job}(): invalid option: {}", e.to_string().trim()))
    })
}

/// Progress of a job sent to a Python callable `callback(event, text, done, total)`:
/// `start` (loop label, 0, steps), `progress` (label, steps done, steps), `message` (short
/// status), `finish` (label), `note` (a line for the user). The first exception the callback
/// raises stops further calls and is raised when the job returns.
pub struct PyProgress {
    callback: Py<PyAny>,
    label: Mutex<String>,
    done: AtomicU64,
    total: AtomicU64,
    error: Mutex<Option<PyErr>>,
}

impl PyProgress {
    /// A sink calling `callback`.
    pub fn new(callback: Py<PyAny>) -> Self {
        PyProgress {
            callback,
            label: Mutex::new(String::new()),
            done: AtomicU64::new(0),
            total: AtomicU64::new(0),
            error: Mutex::new(None),
        }
    }

    fn call(&self, event: &str, text: &str) {
        let Ok(mut error) = self.error.lock() else {
            return;
        };
        if error.is_some() {
            return;
        }
        let done = self.done.load(Ordering::Relaxed);
        let total = self.total.load(Ordering::Relaxed);
        Python::attach(|py| {
            if let Err(e) = self.callback.call1(py, (event, text, done, total)) {
                *error = Some(e);
            }
        });
    }

    fn label(&self) -> String {
        self.label.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// The callback's first exception, if any.
    pub fn take_error(&self) -> Option<PyErr> {
        self.error.lock().ok().and_then(|mut e| e.take())
    }
}

impl Progress for PyProgress {
    fn start(&self, label: &str, total: u64) {
        if let Ok(mut l) = self.label.lock() {
            *l = label.to_string();
        }
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        self.call("start", label);
    }
    fn inc(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
        self.call("progress", &self.label());
    }
    fn position(&self, done: u64, total: u64) {
        self.done.store(done, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        self.call("progress", &self.label());
    }
    fn message(&self, msg: &str) {
        self.call("message", msg);
    }
    fn finish(&self) {
        self.call("finish", &self.label());
    }
    fn note(&self, line: &str) {
        self.call("note", line);
    }
}

/// What a job did, as returned to Python.
#[pyclass(module = "endoloc", name = "Report", frozen)]
pub struct PyReport {
    /// The job's name (`train`, `experiment.compare`, …).
    #[pyo3(get)]
    job: String,
    /// The report as the command line prints it.
    #[pyo3(get)]
    text: String,
    /// The output folder (or file), when the job writes one.
    #[pyo3(get)]
    out: Option<PathBuf>,
    /// The job's full settings as a TOML table (defaults filled in), as `endoloc run` reads it.
    #[pyo3(get)]
    settings: String,
    /// `localize` with the endoloc method: one result per frame, in order; empty otherwise.
    #[pyo3(get)]
    frames: Vec<Py<PyFrameResult>>,
}

#[pymethods]
impl PyReport {
    /// `eval`: its `metrics.json` as a dict; `None` for other jobs.
    #[getter]
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let (true, Some(out)) = (self.job == "eval", &self.out) else {
            return Ok(None);
        };
        let path = out.join("metrics.json");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| job_error(endoloc_jobs::JobError::io(&path, e)))?;
        py.import("json")?.call_method1("loads", (text,)).map(Some)
    }
    fn __str__(&self) -> String {
        self.text.clone()
    }
    fn __repr__(&self) -> String {
        format!(
            "<endoloc.Report of {} → {}>",
            self.job,
            self.out
                .as_ref()
                .map_or_else(|| "-".to_string(), |p| p.display().to_string())
        )
    }
}

/// What a job's run gives back before it becomes a [`PyReport`].
struct Outcome {
    text: String,
    out: Option<PathBuf>,
    frames: Vec<FrameResult>,
}

impl Outcome {
    fn new(report: &impl std::fmt::Display, out: Option<PathBuf>) -> Self {
        Outcome {
            text: report.to_string(),
            out,
            frames: Vec::new(),
        }
    }
}

fn non_empty(p: &std::path::Path) -> Option<PathBuf> {
    (!p.as_os_str().is_empty()).then(|| p.to_path_buf())
}

/// Runs `job` with the GIL released, progress to `progress` (a callable) when given.
fn execute<J: Serialize + Send + Sync>(
    py: Python<'_>,
    name: &str,
    job: J,
    progress: Option<Py<PyAny>>,
    run: impl FnOnce(&J, &dyn Progress) -> endoloc_jobs::Result<Outcome> + Send,
) -> PyResult<PyReport> {
    let settings = toml::to_string_pretty(&job).unwrap_or_default();
    let sink = progress.map(PyProgress::new);
    let result = py.detach(|| match &sink {
        Some(s) => run(&job, s),
        None => run(&job, &endoloc_jobs::Silent),
    });
    if let Some(e) = sink.as_ref().and_then(PyProgress::take_error) {
        return Err(e);
    }
    let outcome = result.map_err(job_error)?;
    let frames = outcome
        .frames
        .into_iter()
        .map(|r| Py::new(py, PyFrameResult::from_result(r, None)))
        .collect::<PyResult<Vec<_>>>()?;
    Ok(PyReport {
        job: name.to_string(),
        text: outcome.text,
        out: outcome.out,
        settings,
        frames,
    })
}

/// Runs the job `name` with keyword arguments `options` (command-line option names, `_` for
/// `-`); `progress` is a callable `(event, text, done, total)` or `None`.
#[pyfunction]
#[pyo3(signature = (name, progress=None, **options))]
pub fn run_job(
    py: Python<'_>,
    name: &str,
    progress: Option<Py<PyAny>>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyReport> {
    let t = job_table(name, options)?;
    macro_rules! go {
        ($ty:ty, $out:expr) => {{
            let job: $ty = job_from_table(name, t)?;
            execute(py, name, job, progress, |j, p| {
                let r = j.run(p)?;
                #[allow(clippy::redundant_closure_call)]
                let out = ($out)(j, &r);
                Ok(Outcome::new(&r, out))
            })
        }};
    }
    match name {
        "simulate" => go!(SimulateJob, |j: &SimulateJob, _| non_empty(&j.out)),
        "import" => go!(ImportJob, |j: &ImportJob, _| non_empty(&j.out)),
        "train" => go!(TrainJob, |j: &TrainJob, _| non_empty(&j.out)),
        "map" => go!(MapJob, |j: &MapJob, _| non_empty(&j.model)),
        "localize" => {
            let job: LocalizeJob = job_from_table(name, t)?;
            execute(py, name, job, progress, |j, p| {
                let mut frames = Vec::new();
                let r = j.run_with(p, &mut |f| frames.push(f))?;
                let mut o = Outcome::new(&r, non_empty(&j.out));
                o.frames = frames;
                Ok(o)
            })
        }
        "eval" => go!(EvalJob, |_: &EvalJob, r: &endoloc_jobs::EvalReport| {
            non_empty(&r.out)
        }),
        "classify" => go!(ClassifyJob, |j: &ClassifyJob, _| j.out.clone()),
        "view" => go!(ViewJob, |_: &ViewJob, r: &endoloc_jobs::ViewReport| {
            non_empty(&r.out)
        }),
        "features" => go!(FeaturesJob, |j: &FeaturesJob, _| j.overlay.clone()),
        "pretrain" => go!(PretrainJob, |j: &PretrainJob, _| non_empty(&j.out)),
        "demo" => go!(DemoJob, |j: &DemoJob, _| non_empty(&j.out)),
        "experiment.benchmark" => go!(BenchmarkJob, |j: &BenchmarkJob, _| non_empty(&j.out)),
        "experiment.changes" => go!(ChangesJob, |j: &ChangesJob, _| non_empty(&j.out)),
        "experiment.compare" => go!(CompareJob, |j: &CompareJob, _| non_empty(&j.out)),
        "experiment.zones" => go!(ZoneSweepJob, |j: &ZoneSweepJob, _| non_empty(&j.out)),
        "experiment.expert" => go!(ExpertJob, |j: &ExpertJob, _| non_empty(&j.out)),
        "experiment.perturb" => go!(PerturbJob, |j: &PerturbJob, _| non_empty(&j.out)),
        _ => Err(unknown_job(name)),
    }
}

/// `endoloc run --config FILE`: the whole chain from one TOML file.
#[pyfunction]
#[pyo3(signature = (config, force=false, progress=None))]
pub fn run_config(
    py: Python<'_>,
    config: PathBuf,
    force: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyReport> {
    let text = std::fs::read_to_string(&config)
        .map_err(|e| job_error(endoloc_jobs::JobError::io(&config, e)))?;
    let job = RunJob::from_toml(&text).map_err(|e| {
        job_error(endoloc_jobs::JobError::Context {
            context: config.display().to_string(),
            source: Box::new(e),
        })
    })?;
    execute(py, "run", job, progress, |j, p| {
        let timings = j.run(&text, force, p)?;
        Ok(Outcome::new(&timings, non_empty(&j.out)))
    })
}

/// The keyword arguments a job accepts, sorted.
#[pyfunction]
pub fn job_options(name: &str) -> PyResult<Vec<String>> {
    options_of(name)
}
