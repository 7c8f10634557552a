//! The keyword arguments of endoloc's jobs, read from each job's command-line definition
//! (its clap derive): names, the fields they set, `no_…` negations, and the TOML table they
//! make. The job runner and `Localizer` both take their options from here.

use endoloc_experiments::{
    BenchmarkJob, ChangesJob, CompareJob, ExperimentData, ExpertJob, PerturbJob, ZoneSweepJob,
};
use endoloc_jobs::{
    ClassifyJob, DemoJob, EvalJob, FeaturesJob, ImportJob, LocalizeJob, MapJob, PretrainJob,
    SimulateJob, TrainJob, ViewJob,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// Every job the module runs, by the name of its command (`experiment compare` is
/// `experiment.compare`).
pub const JOBS: &[&str] = &[
    "simulate",
    "import",
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
    "experiment.changes",
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
        "import" => ImportJob::augment_args(cmd),
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
        "experiment.changes" => ChangesJob::augment_args(cmd),
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

pub(crate) fn unknown_job(job: &str) -> PyErr {
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
