//! Every job's options (the stages' and the experiments') are defined once, on the job type: each of its command-line arguments
//! (the `cli` feature's clap derive) is a key of the job's TOML table with the job's own
//! default and a help text, and every key of the table has an argument.

use clap::{ArgAction, Args, Command, FromArgMatches};
use endoloc_experiments::{
    BenchmarkJob, ChangesJob, CompareJob, ExperimentData, ExpertJob, PerturbJob, ZoneSweepJob,
};
use endoloc_jobs::{
    ClassifyJob, DatasetJob, DemoJob, EvalJob, FeaturesJob, ImportJob, LiveBenchJob, LocalizeJob,
    MapJob, MaskDetectConfig, PretrainJob, SimulateJob, TrainJob, ViewJob,
};
use serde::Serialize;

/// The job's command, built (clap's own consistency checks run here).
fn command<J: Args>(name: &'static str) -> Command {
    let mut cmd = J::augment_args(Command::new(name));
    cmd.build();
    cmd
}

/// A table of the job flattened into its arguments: its name in the job's table and the ids
/// of its arguments.
type Nested = (&'static str, Vec<String>);

/// The arguments of `T`, flattened into a job as its table `name`.
fn nested<T: Args>(name: &'static str) -> Nested {
    let ids = T::augment_args(Command::new(name))
        .get_arguments()
        .map(|a| a.get_id().to_string())
        .collect();
    (name, ids)
}

/// Where an argument's field is in the job's table: `data.x` for an experiment's data.
fn key_of(id: &str, nested: &[Nested]) -> Vec<String> {
    match nested.iter().find(|(_, ids)| ids.iter().any(|i| i == id)) {
        Some((table, _)) => vec![(*table).into(), id.into()],
        None => vec![id.into()],
    }
}

/// Fields that are no option: set by the caller (`ImportJob::command`, the command line
/// recorded in the dataset).
const NOT_OPTIONS: &[&str] = &["command"];

fn get<'a>(t: &'a toml::Table, key: &[String]) -> Option<&'a toml::Value> {
    match key {
        [k] => t.get(k),
        [k, rest @ ..] => get(t.get(k)?.as_table()?, rest),
        [] => None,
    }
}

/// The job parsed from a command line holding only its required arguments (those required
/// unless another is given too, as clap names them when they are missing), with the ids of
/// the arguments given.
fn parsed_defaults<J: Args + FromArgMatches>(cmd: &Command) -> (J, Vec<String>) {
    let mut line = vec![cmd.get_name().to_string()];
    let mut given = Vec::new();
    for arg in cmd.get_arguments().filter(|a| a.is_required_set()) {
        let value = arg
            .get_possible_values()
            .first()
            .map_or_else(|| "x".to_string(), |v| v.get_name().to_string());
        if let Some(long) = arg.get_long() {
            line.push(format!("--{long}"));
        }
        line.push(value);
        given.push(arg.get_id().to_string());
    }
    loop {
        match cmd.clone().try_get_matches_from(&line) {
            Ok(matches) => {
                let job = J::from_arg_matches(&matches).unwrap_or_else(|e| panic!("{line:?}: {e}"));
                return (job, given);
            }
            Err(e) if e.kind() == clap::error::ErrorKind::MissingRequiredArgument => {
                let Some(clap::error::ContextValue::Strings(missing)) =
                    e.get(clap::error::ContextKind::InvalidArg)
                else {
                    panic!("{line:?}: {e}");
                };
                let before = line.len();
                for m in missing {
                    let flag = m.split_whitespace().next().unwrap_or_default();
                    let arg = cmd
                        .get_arguments()
                        .find(|a| a.get_long().is_some_and(|l| flag == format!("--{l}")))
                        .unwrap_or_else(|| panic!("{line:?}: {e}"));
                    line.extend([flag.to_string(), "x".to_string()]);
                    given.push(arg.get_id().to_string());
                }
                assert!(line.len() > before, "{line:?}: {e}");
            }
            Err(e) => panic!("{line:?}: {e}"),
        }
    }
}

fn check<J: Args + FromArgMatches + Serialize + Default>(name: &'static str, nested: &[Nested]) {
    let cmd = command::<J>(name);
    let table = toml::Table::try_from(J::default()).expect("the default serialises to TOML");
    let (job, given) = parsed_defaults::<J>(&cmd);
    let parsed = toml::Table::try_from(job).expect("serialises");
    // Every key, `None` ones too (JSON keeps them as null).
    let mut keys: Vec<Vec<String>> = Vec::new();
    let serde_json::Value::Object(json) = serde_json::to_value(J::default()).unwrap() else {
        panic!("{name}: a job serialises to a table");
    };
    for (k, v) in &json {
        match v {
            serde_json::Value::Object(inner) if nested.iter().any(|(t, _)| t == k) => {
                keys.extend(inner.keys().map(|i| vec![k.clone(), i.clone()]));
            }
            _ if NOT_OPTIONS.contains(&k.as_str()) => {}
            _ => keys.push(vec![k.clone()]),
        }
    }
    let mut covered = Vec::new();
    for arg in cmd.get_arguments() {
        if matches!(arg.get_action(), ArgAction::Help | ArgAction::Version) {
            continue; // clap's own --help
        }
        let id = arg.get_id().as_str();
        let key = key_of(id, nested);
        assert!(
            keys.contains(&key),
            "{name}: argument {id} is no field of the job (fields: {keys:?})"
        );
        covered.push(key.clone());
        let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
        assert!(!help.trim().is_empty(), "{name}: argument {id} has no help");
        if !arg.get_default_values().is_empty() && !given.iter().any(|g| g == id) {
            assert_eq!(
                get(&parsed, &key),
                get(&table, &key),
                "{name}: the default of {id} ({:?}) is not the job's",
                arg.get_default_values()
            );
        }
    }
    for key in &keys {
        assert!(
            covered.contains(key),
            "{name}: field {key:?} has no argument"
        );
    }
}

#[test]
fn every_option_of_every_job_is_defined_once_on_the_job() {
    let data = [nested::<ExperimentData>("data")];
    check::<SimulateJob>("simulate", &[]);
    check::<TrainJob>("train", &[]);
    check::<MapJob>("map", &[]);
    check::<LocalizeJob>("localize", &[]);
    check::<EvalJob>("eval", &[]);
    check::<ClassifyJob>("classify", &[]);
    check::<ViewJob>("view", &[]);
    check::<FeaturesJob>("features", &[]);
    check::<PretrainJob>("pretrain", &[]);
    check::<DemoJob>("demo", &[]);
    check::<LiveBenchJob>("live", &[]);
    check::<ImportJob>("import", &[]);
    check::<DatasetJob>("dataset", &[nested::<MaskDetectConfig>("detect")]);
    check::<BenchmarkJob>("benchmark", &[]);
    check::<ChangesJob>("changes", &[]);
    check::<CompareJob>("compare", &data);
    check::<ZoneSweepJob>("zones", &data);
    check::<ExpertJob>("expert", &data);
    check::<PerturbJob>("perturb", &data);
}

fn parse<J: Args + FromArgMatches>(name: &'static str, line: &[&str]) -> J {
    let matches = command::<J>(name)
        .try_get_matches_from(std::iter::once(name).chain(line.iter().copied()))
        .unwrap();
    J::from_arg_matches(&matches).unwrap()
}

#[test]
fn no_flags_turn_their_field_off() {
    let base = ["--seq", "s", "--out", "o"];
    assert!(parse::<LocalizeJob>("localize", &base).confirm);
    let off = parse::<LocalizeJob>("localize", &[&base[..], &["--no-confirm"]].concat());
    assert!(!off.confirm);
    assert_eq!(parse::<SimulateJob>("simulate", &[]).depth, None);
    assert_eq!(
        parse::<SimulateJob>("simulate", &["--no-depth"]).depth,
        Some(false)
    );
    let live = parse::<LiveBenchJob>("live", &["--model", "m", "--seq", "s", "--no-compare"]);
    assert!(!live.compare && live.confirm);
}

#[test]
fn zones_parse_from_the_command_line() {
    use endoloc_net::ZoneSpec;
    let base = ["--data", "d", "--out", "o"];
    let train = |z: &str| parse::<TrainJob>("train", &[&base[..], &["--zones", z]].concat());
    assert_eq!(train("70").zones, ZoneSpec::Uniform(70));
    assert_eq!(train("expert").zones, ZoneSpec::Expert(None));
    assert_eq!(train("expert:9").zones, ZoneSpec::Expert(Some(9)));
    assert!(
        command::<TrainJob>("train")
            .try_get_matches_from(["train", "--data", "d", "--out", "o", "--zones", "many"])
            .is_err()
    );
}
