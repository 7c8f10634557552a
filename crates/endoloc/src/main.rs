//! `endoloc`: image-based colonoscope localization from the command line.
//!
//! The binary is a thin shell over `endoloc-jobs`: each subcommand lives in `cmd/<name>.rs`,
//! turns its arguments into a job, runs it with a terminal progress sink, and prints the
//! job's report.

// Doc comments here are `--help` texts (clap), written for a terminal: `[train]` is a TOML
// table and `<method>` a placeholder, not a link or a tag.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]

mod cmd;
mod ui;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// Tell where a colonoscope is inside the colon from the images it sees.
///
/// Typical flow: `simulate` (or import) a dataset with known poses, inspect it with
/// `dataset info`/`dataset check`, then train, map, localize and evaluate.
#[derive(Debug, Parser)]
#[command(
    name = "endoloc",
    version,
    about,
    long_about = None,
    propagate_version = true,
    after_help = "Exit status: 0 done; 2 bad input, settings or output folder (one message names \
                  the file, the line and what was expected; nothing is written); 101 a bug."
)]
struct Cli {
    /// More log output (-v info, -vv debug); errors and warnings are always shown.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,

    /// No progress bars or stage lines on stderr (warnings and errors are still shown).
    #[arg(short, long, global = true)]
    quiet: bool,

    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Simulate(cmd::simulate::Args),
    Features(cmd::features::Args),
    Dataset(cmd::dataset::Args),
    Eval(cmd::eval::Args),
    Import(cmd::import::Args),
    Pretrain(cmd::pretrain::Args),
    Train(cmd::train::Args),
    Classify(cmd::classify::Args),
    Map(cmd::localize::MapArgs),
    Localize(cmd::localize::LocalizeArgs),
    View(cmd::view::Args),
    Demo(cmd::demo::Args),
    Run(cmd::run::Args),
    Experiment(cmd::experiment::Args),
    Bench(cmd::bench::Args),
}

fn main() -> std::process::ExitCode {
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    ui::init_logging(cli.verbose);
    let ui = ui::Terminal::new(cli.quiet);
    let ui = &ui;
    let result = match cli.command {
        Command::Simulate(args) => cmd::simulate::run(args, ui),
        Command::Features(args) => cmd::features::run(args, ui),
        Command::Dataset(args) => cmd::dataset::run(args, ui),
        Command::Eval(args) => cmd::eval::run(args, ui),
        Command::Import(args) => cmd::import::run(args, ui),
        Command::Pretrain(args) => cmd::pretrain::run(args, ui),
        Command::Train(args) => cmd::train::run(args, ui),
        Command::Classify(args) => cmd::classify::run(args, ui),
        Command::Map(args) => cmd::localize::run_map(args, ui),
        Command::Localize(args) => cmd::localize::run_localize(args, ui),
        Command::View(args) => cmd::view::run(args, ui),
        Command::Demo(args) => cmd::demo::run(args, ui),
        Command::Run(args) => cmd::run::run(args, ui),
        Command::Experiment(args) => cmd::experiment::run(args, ui),
        Command::Bench(args) => cmd::bench::run(args, ui),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            let text = flags_for_fields(&error_message(&err), &leaf_command(&matches));
            eprintln!("error: {text}");
            std::process::ExitCode::from(EXIT_REFUSED)
        }
    }
}

/// Exit status of a run that stopped with an error: the input, the settings or the output
/// folder were not usable (the message names the file, the line where there is one, and what
/// was expected). Usage errors from the argument parser use the same status; 0 is success and
/// 101 a bug (a panic), which is never the user's fault.
const EXIT_REFUSED: u8 = 2;

/// `context: cause: cause …`, each cause once: an error whose message already quotes its
/// source (`path: No such file or directory`) is not followed by the source again.
fn error_message(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let line = cause.to_string();
        if line.is_empty() || text.contains(&line) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&line);
    }
    text
}

/// The subcommand that ran (`experiment zones`, not `experiment`), with its arguments.
fn leaf_command(matches: &clap::ArgMatches) -> clap::Command {
    let mut command = Cli::command();
    let mut matches = matches;
    while let Some((name, sub)) = matches.subcommand() {
        match command.find_subcommand(name) {
            Some(c) => command = c.clone(),
            None => break,
        }
        matches = sub;
    }
    command
}

/// The libraries name a job's options by field, in backticks (`` `min_zone_frames` ``), as
/// the TOML of `endoloc run` and the Python keywords spell them; on the command line they are
/// flags. Each such name of one of `command`'s options becomes its `--flag`; any other text
/// in backticks stays as it is, and so does everything from a TOML or JSON parser's report on
/// (`unknown field `x`, expected one of …` lists the keys of a file, not options).
fn flags_for_fields(message: &str, command: &clap::Command) -> String {
    const PARSER_REPORTS: [&str; 4] = [
        "unknown field `",
        "unknown variant `",
        "missing field `",
        "expected one of `",
    ];
    let parser_report = PARSER_REPORTS
        .iter()
        .filter_map(|m| message.find(m))
        .min()
        .unwrap_or(message.len());
    let (message, rest) = message.split_at(parser_report);
    let mut text = options_as_flags(message, command);
    text.push_str(rest);
    text
}

fn options_as_flags(message: &str, command: &clap::Command) -> String {
    let long_of = |name: &str| {
        command.get_arguments().find_map(|arg| {
            let long = arg.get_long()?;
            (arg.get_id().as_str() == name || long.replace('-', "_") == name).then_some(long)
        })
    };
    let pieces: Vec<&str> = message.split('`').collect();
    let mut text = String::with_capacity(message.len());
    for (i, piece) in pieces.iter().enumerate() {
        // Odd pieces lie between two backticks; an unpaired last backtick stays literal.
        let quoted = i % 2 == 1 && i + 1 < pieces.len();
        match long_of(piece).filter(|_| quoted) {
            Some(long) => {
                text.push_str("--");
                text.push_str(long);
            }
            None if quoted => {
                text.push('`');
                text.push_str(piece);
                text.push('`');
            }
            None => {
                if i > 0 && i % 2 == 1 {
                    text.push('`');
                }
                text.push_str(piece);
            }
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn train() -> clap::Command {
        Cli::command().find_subcommand("train").unwrap().clone()
    }

    #[test]
    fn field_names_in_messages_become_the_commands_flags() {
        let m = "`pair_frames` 8: expected P,N; a larger `min_zone_frames`; `force` replaces it";
        assert_eq!(
            flags_for_fields(m, &train()),
            "--pair-frames 8: expected P,N; a larger --min-zone-frames; --force replaces it"
        );
    }

    #[test]
    fn a_parsers_list_of_file_keys_stays() {
        let m = "`seed` in sim.toml: unknown field `colour`, expected one of `name`, `seed`";
        assert_eq!(
            flags_for_fields(
                m,
                &Cli::command().find_subcommand("simulate").unwrap().clone()
            ),
            "--seed in sim.toml: unknown field `colour`, expected one of `name`, `seed`"
        );
    }

    #[test]
    fn other_quoted_text_and_unpaired_backticks_stay() {
        let m = "expected `average` or `gem` in `x.toml`; a stray ` here";
        assert_eq!(flags_for_fields(m, &train()), m);
    }
}
