//! endoloc's jobs from Python: keyword arguments → the job's TOML table (the one `endoloc run`
//! reads) → the typed job → `run` with the GIL released and progress sent to a Python
//! callback.

use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use endoloc_jobs::experiment::{
    BenchmarkJob, CompareJob, ExperimentData, ExpertJob, PerturbJob, ZoneSweepJob,
};
use endoloc_jobs::{
    ClassifyJob, DemoJob, EvalJob, FeaturesJob, LocalizeJob, MapJob, PretrainJob, Progress, RunJob,
    SimulateJob, TrainJob, ViewJob,
};
use endoloc_localize::FrameResult;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::convert::{job_error, table_from_dict};
use crate::localizer::PyFrameResult;

/// Every job the module runs, by the name of its command (`experiment compare` is
/// `experiment.compare`).
pub const JOBS: &[&str] = &[
    "simulate",
    "train",
    "map",
    "localize",
    "eval",
    "classify",
    "view",
    "features",
    "pretrain",
    "demo",
    "experiment.benchmark",
    "experiment.compare",
    "experiment.zones",
    "experiment.expert",
    "experiment.perturb",
];

/// One keyword argument of a job, read from the job's command-line arguments (its clap
/// derive): the long flag with `_` for `-` (a positional argument's name; `from_` for
/// `from`, a Python keyword).
#[derive(Debug, Clone)]
pub(crate) struct Keyword {
    /// The keyword.
    pub name: String,
    /// The job's field it sets (clap's argument id).
    pub field: String,
    /// A `no_…` keyword: true sets the field to false, as the command line's `--no-…` flag
    /// does (an argument whose flag is `--no-` + its field's name).
    pub negates: bool,
    /// The field lives in the job's `data` table (an experiment's data, flattened on the
    /// command line).
    pub in_data: bool,
}

/// A job's command-line arguments, as its clap derive defines them.
fn command_of(job: &str) -> PyResult<clap::Command> {
    use clap::Args as _;
    let cmd = clap::Command::new("job");
    Ok(match job {
        "simulate" => SimulateJob::augment_args(cmd),
        "train" => TrainJob::augment_args(cmd),
        "map" => MapJob::augment_args(cmd),
        "localize" => LocalizeJob::augment_args(cmd),
        "eval" => EvalJob::augment_args(cmd),
        "classify" => ClassifyJob::augment_args(cmd),
        "view" => ViewJob::augment_args(cmd),
        "features" => FeaturesJob::augment_args(cmd),
        "pretrain" => PretrainJob::augment_args(cmd),
        "demo" => DemoJob::augment_args(cmd),
        "experiment.benchmark" => BenchmarkJob::augment_args(cmd),
        "experiment.compare" => CompareJob::augment_args(cmd),
        "experiment.zones" => ZoneSweepJob::augment_args(cmd),
        "experiment.expert" => ExpertJob::augment_args(cmd),
        "experiment.perturb" => PerturbJob::augment_args(cmd),
        _ => return Err(unknown_job(job)),
    })
}

/// Python keywords that are also option names get a trailing `_`.
fn python_name(name: String) -> String {
    const RESERVED: &[&str] = &[
        "and", "as", "assert", "async", "await", "break", "class", "continue", "def", "del",
        "elif", "else", "except", "finally", "for", "from", "global", "if", "import", "in", "is",
        "lambda", "nonlocal", "not", "or", "pass", "raise", "return", "try", "while", "with",
        "yield",
    ];
    if RESERVED.contains(&name.as_str()) {
        name + "_"
    } else {
        name
    }
}

/// The keyword arguments of a job, from its command-line arguments: each flag with `_` for
/// `-`, and for a `--no-x` flag also `x` itself.
///
/// # Errors
/// An unknown job name.
pub(crate) fn keywords_of(job: &str) -> PyResult<Vec<Keyword>> {
    use clap::Args as _;
    let data_fields: Vec<String> = if job.starts_with("experiment.") {
        ExperimentData::augment_args(clap::Command::new("data"))
            .get_arguments()
            .map(|a| a.get_id().to_string())
            .collect()
    } else {
        Vec::new()
    };
    let mut out = Vec::new();
    for arg in command_of(job)?.get_arguments() {
        let field = arg.get_id().to_string();
        let flag = arg
            .get_long()
            .map_or_else(|| field.clone(), |l| l.replace('-', "_"));
        let in_data = data_fields.contains(&field);
        let negates = flag == format!("no_{field}");
        out.push(Keyword {
            name: python_name(flag),
            field: field.clone(),
            negates,
            in_data,
        });
        if negates {
            out.push(Keyword {
                name: python_name(field.clone()),
                field,
                negates: false,
                in_data,
            });
        }
    }
    Ok(out)
}

/// The keyword arguments of a job, sorted.
///
/// # Errors
/// An unknown job name.
pub fn options_of(job: &str) -> PyResult<Vec<String>> {
    let mut names: Vec<String> = keywords_of(job)?.into_iter().map(|k| k.name).collect();
    names.sort();
    Ok(names)
}

fn unknown_job(job: &str) -> PyErr {
    PyValueError::new_err(format!("no job {job:?}; the jobs are {}", JOBS.join(", ")))
}

/// The job's TOML table from keyword arguments `t` (keyword → value), for the keywords
/// `known` of the job (or a part of them): each keyword set on its field, `no_x=True` as
/// `x = false`, an experiment's data into its `data` table; unknown names refused with the
/// list of the known ones, and `who` naming the caller in messages.
///
/// # Errors
/// An unknown keyword, a `no_…` keyword that is not a bool, or one that contradicts its
/// field set to true.
pub(crate) fn table_from_keywords(
    who: &str,
    known: &[Keyword],
    t: toml::Table,
) -> PyResult<toml::Table> {
    let mut out = toml::Table::new();
    let mut data = toml::Table::new();
    let mut negations = Vec::new();
    for (name, value) in t {
        let Some(k) = known.iter().find(|k| k.name == name) else {
            let mut names: Vec<&str> = known.iter().map(|k| k.name.as_str()).collect();
            names.sort_unstable();
            return Err(PyTypeError::new_err(format!(
                "{who}() got an unexpected keyword argument {name:?}; its options are: {}",
                names.join(", ")
            )));
        };
        if k.negates {
            negations.push((k, value));
        } else if k.in_data {
            data.insert(k.field.clone(), value);
        } else {
            out.insert(k.field.clone(), value);
        }
    }
    for (k, value) in negations {
        let off = value
            .as_bool()
            .ok_or_else(|| PyTypeError::new_err(format!("option {}: expected a bool", k.name)))?;
        if off {
            if out.get(&k.field).and_then(toml::Value::as_bool) == Some(true) {
                return Err(PyValueError::new_err(format!(
                    "{}=True and {}=True contradict each other",
                    k.field, k.name
                )));
            }
            out.insert(k.field.clone(), toml::Value::Boolean(false));
        }
    }
    if !data.is_empty() {
        out.insert("data".into(), toml::Value::Table(data));
    }
    Ok(out)
}

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
